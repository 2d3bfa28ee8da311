//! Extraction of the current mesh: the leaves of the split set inside the domain, with points
//! deduplicated by lattice index (every output point is an input sample).
//!
//! The mesh is written where the caller wants it, once, in parallel ([`MeshPlan`]): a counting walk
//! sizes every output array exactly and gives each subtree of the split set its own slice of them; a
//! second walk writes the tetrahedra into those slices. The points need no walk: every vertex of the
//! mesh is a root-cube corner or the midpoint of a bisection, i.e. the central vertex of a split
//! diamond (LEB adds one vertex per split, Gregorski §3), and every split diamond's central vertex in
//! the domain is a vertex of the leaves around it; so the split set's bitset over the domain, plus the
//! root corners in it, *is* the set of used points, and a point's id is its rank in it. A piece of a
//! distributed mesh ([`MeshPlan::of_piece`]) writes only the tetrahedra it owns, so its counting walk
//! marks their points instead.

use crate::diamond::{bisect, signed_volume6, Diamond};
use crate::hierarchy::piece::{CellOwner, PointBox};
use crate::lattice::{Lattice, Placement, Tet};
use crate::memory;
use crate::refine::SplitSet;
use crate::view::order::{
    child_path, first_child_is_near, lattice_eye, max_path_depth, root_path, root_rank,
};
use crate::view::Direction;
use crate::volume::Grid;
use crate::{Error, Result};
use glam::DVec3;
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

/// The current mesh of a query: deduplicated input points and positively oriented tetrahedra.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TetMesh {
    /// Input point index (x fastest) of each output point, ascending.
    pub point_ids: Vec<usize>,
    /// World coordinates of each output point.
    pub points: Vec<[f64; 3]>,
    /// Tetrahedra as indices into `points`, positively oriented (VTK_TETRA order).
    pub tets: Vec<[u32; 4]>,
    /// Bisection depth of each tetrahedron (0 = the six base tetrahedra; Gregorski's level is depth / 3,
    /// the phase depth mod 3).
    pub depths: Vec<u8>,
    /// Error bound of each tetrahedron: the exact max error of its diamond, rounded up (data units).
    pub errors: Vec<f32>,
    /// Largest value of `errors`.
    pub max_error: f64,
}

/// Is the diamond of `t` split? (Unit-cube tetrahedra never are.)
#[inline]
fn is_split(split: &SplitSet, t: &Tet) -> bool {
    Diamond::of_tet(t).is_some_and(|d| split.contains(d))
}

/// Visits the inside leaves below `t` (whose bisection path is `path`), depth first, with their
/// diamonds (`None` for a unit-cube tetrahedron) and bisection paths, skipping the subtrees of the
/// tetrahedra for which `prune` holds. At every bisection the first child comes first (ascending
/// bisection paths, [`crate::view::BspTree::paths`]), or with `toward` = (eye in lattice
/// coordinates, direction) the child that comes first in that visibility order (Marchesin §6). The
/// children of an inside tetrahedron are inside: only the tetrahedra that straddle the domain's far
/// faces are placed. An inside child that is a leaf (half of all tetrahedra walked) is visited at
/// once, not through the stack, when nothing comes before it; a split one goes on the stack known
/// split, so that no tetrahedron is tested twice.
#[inline]
fn walk_pruned(
    lattice: &Lattice,
    split: &SplitSet,
    (t, path): (Tet, u64),
    toward: Option<(DVec3, Direction)>,
    prune: impl Fn(&Tet) -> bool,
    mut visit: impl FnMut(&Tet, Option<Diamond>, u64),
) {
    /// What a stack entry is known to be.
    #[derive(Clone, Copy, PartialEq)]
    enum Known {
        Nothing,
        Inside,
        /// Inside, not pruned, split.
        InsideSplit,
    }
    let mut stack = Vec::with_capacity(4 * lattice.levels as usize + 4);
    stack.push((t, path, Known::Nothing));
    while let Some((t, path, known)) = stack.pop() {
        let inside = if known == Known::InsideSplit {
            true
        } else {
            let placement = if known == Known::Inside {
                Placement::Inside
            } else {
                lattice.place(&t)
            };
            if placement == Placement::Outside || prune(&t) {
                continue;
            }
            if placement == Placement::Inside {
                let diamond = Diamond::of_tet(&t);
                if !diamond.is_some_and(|d| split.contains(d)) {
                    visit(&t, diamond, path);
                    continue;
                }
            } else {
                // Not looked up: a straddling tetrahedron's diamond straddles a far face, split in
                // the base mesh (or, in an isosurface mesh, pruned when unsplit). Along the far
                // faces these are most of the tetrahedra above the leaves, and their diamonds are
                // often centred outside the domain, where the split set is a hash set.
                debug_assert!(
                    is_split(split, &t),
                    "straddling diamonds are split in the base mesh"
                );
            }
            placement == Placement::Inside
        };
        let [first, second] = bisect(&t);
        let first = (first, child_path(path, false));
        let second = (second, child_path(path, true));
        // Back to front, the far child first; front to back, the near one.
        let first_first = toward.is_none_or(|(eye, direction)| {
            first_child_is_near(&t, eye) != (direction == Direction::BackToFront)
        });
        let (a, b) = if first_first {
            (first, second)
        } else {
            (second, first)
        };
        if !inside {
            // Pushed last, popped first.
            stack.extend([(b.0, b.1, Known::Nothing), (a.0, a.1, Known::Nothing)]);
        } else if settle(split, &prune, &mut visit, a) {
            stack.extend([(b.0, b.1, Known::Inside), (a.0, a.1, Known::InsideSplit)]);
        } else if settle(split, &prune, &mut visit, b) {
            stack.push((b.0, b.1, Known::InsideSplit));
        }
    }
}

/// [`walk_pruned`]'s handling of an inside tetrahedron `t` (with its path): nothing when pruned,
/// visited when a leaf; returns whether it is split (to be walked on).
#[inline(always)]
fn settle(
    split: &SplitSet,
    prune: &impl Fn(&Tet) -> bool,
    visit: &mut impl FnMut(&Tet, Option<Diamond>, u64),
    (t, path): (Tet, u64),
) -> bool {
    if prune(&t) {
        return false;
    }
    let diamond = Diamond::of_tet(&t);
    if diamond.is_some_and(|d| split.contains(d)) {
        return true;
    }
    visit(&t, diamond, path);
    false
}

/// Visits the inside leaves below `t` in ascending bisection-path order, with their diamonds.
#[inline]
fn walk(lattice: &Lattice, split: &SplitSet, t: Tet, mut visit: impl FnMut(&Tet, Option<Diamond>)) {
    walk_pruned(
        lattice,
        split,
        (t, 0),
        None,
        |_| false,
        |t, d, _| visit(t, d),
    );
}

/// A leaf as the mesh writes it: positively oriented, with its bisection depth and the `error` of
/// its diamond (`Diamond::of_tet`; 0 for a unit-cube tetrahedron, one bisection below the finest
/// diamonds, which reproduces its samples).
#[inline]
fn output_leaf(
    lattice: &Lattice,
    leaf: &Tet,
    diamond: Option<Diamond>,
    error: &impl Fn(Diamond) -> f64,
) -> (Tet, u8, f32) {
    let mut leaf = *leaf;
    if signed_volume6(&leaf) < 0 {
        leaf.swap(2, 3);
    }
    match diamond {
        Some(dm) => (leaf, dm.depth(lattice) as u8, error(dm) as f32),
        None => (leaf, (3 * lattice.levels) as u8, 0.0),
    }
}

/// Subtrees of the split set, in order, enough for parallel work: the tetrahedra of its first levels
/// (breadth-first) until there are about a thousand; a leaf met on the way is its own subtree. In
/// the order of [`walk`] (a leaf keeps its place among the split tetrahedra around it), so that the
/// whole mesh is in ascending bisection-path order. Each with its bisection path.
fn subtrees(lattice: &Lattice, split: &SplitSet) -> Vec<(Tet, u64)> {
    let mut frontier: Vec<(Tet, u64)> = Diamond::root(lattice)
        .tets(lattice)
        .into_iter()
        .enumerate()
        .map(|(r, t)| (t, root_path(r)))
        .collect();
    loop {
        let mut next = Vec::with_capacity(2 * frontier.len());
        let mut bisected = false;
        for &(t, path) in &frontier {
            match lattice.place(&t) {
                Placement::Outside => {}
                _ if is_split(split, &t) => {
                    let [first, second] = bisect(&t);
                    next.push((first, child_path(path, false)));
                    next.push((second, child_path(path, true)));
                    bisected = true;
                }
                _ => next.push((t, path)),
            }
        }
        frontier = next;
        if !bisected || frontier.len() >= 1024 {
            return frontier;
        }
    }
}

/// What `keep` makes of the inside leaves of the split set (those it keeps), in a deterministic
/// order (depth first); subtrees of tetrahedra for which `prune` holds are skipped. Fails with
/// [`Error::OutOfMemory`] when an allocation failed meanwhile ([`memory::exhausted`]): no subtree is
/// walked after that, and the result is allocated fallibly.
pub(crate) fn leaves_where<X: Send>(
    lattice: &Lattice,
    split: &SplitSet,
    prune: impl Fn(&Tet) -> bool + Sync,
    keep: impl Fn(&Tet) -> Option<X> + Sync,
) -> Result<Vec<X>> {
    const WHAT: &str = "the leaves of the refined mesh";
    let parts: Vec<Option<Vec<X>>> = subtrees(lattice, split)
        .into_par_iter()
        .map(|(t, _)| {
            (!memory::exhausted()).then(|| leaves_below(lattice, split, t, &prune, &keep))
        })
        .collect();
    memory::check(WHAT)?;
    let total = parts.iter().flatten().map(Vec::len).sum();
    let mut out = memory::with_capacity(total, WHAT)?;
    for part in parts.into_iter().flatten() {
        out.extend(part);
    }
    Ok(out)
}

/// [`leaves_where`] below the tetrahedron `t` of the hierarchy (`t` itself when it is a leaf), on
/// the current thread. Replacing a leaf of a coarser split set by its leaves here keeps the order
/// of [`leaves_where`].
pub(crate) fn leaves_below<X>(
    lattice: &Lattice,
    split: &SplitSet,
    t: Tet,
    prune: &dyn Fn(&Tet) -> bool,
    keep: &dyn Fn(&Tet) -> Option<X>,
) -> Vec<X> {
    let mut out = Vec::new();
    walk_pruned(lattice, split, (t, 0), None, prune, |t, _, _| {
        out.extend(keep(t))
    });
    out
}

/// Number of inside leaves of the split set.
pub(crate) fn count_tets(lattice: &Lattice, split: &SplitSet) -> usize {
    subtrees(lattice, split)
        .into_par_iter()
        .map(|(t, _)| {
            let mut n = 0;
            walk(lattice, split, t, |_, _| n += 1);
            n
        })
        .sum()
}

/// A point or cell index type of the caller's output arrays (VTK takes 32- or 64-bit signed ids; the
/// core's own [`TetMesh`] uses `u32`).
pub trait Index: Copy + Send + Sync {
    /// `i` as this type; the caller chose a type wide enough for every value written
    /// ([`MeshPlan::points`] for the connectivity, 4 × [`MeshPlan::tets`] for offsets).
    fn from_usize(i: usize) -> Self;
}

macro_rules! index_types {
    ($($t:ty),*) => {$(
        impl Index for $t {
            #[inline]
            fn from_usize(i: usize) -> Self {
                i as $t
            }
        }
    )*};
}
index_types!(u32, i32, i64, usize);

/// Checks that `len` elements are `per` per `count` items of `what` (a caller's output array).
pub(crate) fn check_len(len: usize, count: usize, per: usize, what: &str) -> Result<()> {
    if len != count * per {
        return Err(Error::Parameter(format!(
            "{what}: room for {len} values, the mesh needs {}",
            count * per
        )));
    }
    Ok(())
}

/// `slice` cut into consecutive pieces of `lens[i] × per` elements.
pub(crate) fn pieces<'a, T>(
    mut slice: &'a mut [T],
    lens: &[usize],
    per: usize,
) -> Vec<&'a mut [T]> {
    let mut out = Vec::with_capacity(lens.len());
    for &n in lens {
        let (piece, rest) = slice.split_at_mut(n * per);
        out.push(piece);
        slice = rest;
    }
    out
}

/// The mesh of one query, counted but not written yet: its split set, its subtrees with their
/// numbers of tetrahedra, and its points (a bitset over the grid's points with the rank of each
/// word). [`MeshPlan::write_tets`], [`MeshPlan::write_points`] and [`MeshPlan::gather`] write it into
/// arrays of exactly [`MeshPlan::tets`] and [`MeshPlan::points`] elements, in parallel, each output
/// array once; [`MeshPlan::to_mesh`] into a [`TetMesh`]. The output is the same whatever the thread count.
#[derive(Clone, Debug)]
pub struct MeshPlan {
    lattice: Lattice,
    split: SplitSet,
    /// The subtrees in ascending bisection-path order, each with its path.
    roots: Vec<(Tet, u64)>,
    /// Number of inside leaves below each root.
    counts: Vec<usize>,
    /// The order the subtrees are written in (indices into `roots`).
    sequence: Vec<usize>,
    /// The visibility order the tetrahedra are written in (eye in lattice coordinates), if any.
    visibility: Option<(DVec3, Direction)>,
    tets: usize,
    points: PointSet,
    /// The part of a distributed mesh one piece writes, if the plan is a piece's.
    piece: Option<PieceCells>,
    /// For a piece's plan, once asked: the number of its points the piece does not hold in each
    /// task of [`PointSet::for_points`].
    remote: OnceLock<Vec<usize>>,
}

/// The tetrahedra one piece of a distributed mesh writes ([`crate::hierarchy::piece`]): the leaves
/// it owns ([`CellOwner`]), found below the tetrahedra that meet its points.
#[derive(Clone, Debug)]
pub(crate) struct PieceCells {
    pub(crate) owned: PointBox,
    pub(crate) owner: CellOwner,
}

impl PieceCells {
    /// Is no leaf below `t` this piece's (`t` has no point in its box)?
    #[inline]
    fn prunes(&self, t: &Tet) -> bool {
        let lo = t[0].min(t[1]).min(t[2].min(t[3]));
        let hi = t[0].max(t[1]).max(t[2].max(t[3]));
        !self.owned.meets(lo, hi)
    }
}

/// [`walk_pruned`] over the leaves a plan writes: every inside leaf below `root`, or with `piece`
/// those it owns (below the tetrahedra that meet its points).
fn walk_written(
    lattice: &Lattice,
    split: &SplitSet,
    root: (Tet, u64),
    order: Option<(DVec3, Direction)>,
    piece: Option<&PieceCells>,
    mut visit: impl FnMut(&Tet, Option<Diamond>, u64),
) {
    match piece {
        None => walk_pruned(lattice, split, root, order, |_| false, visit),
        Some(piece) => walk_pruned(
            lattice,
            split,
            root,
            order,
            |t| piece.prunes(t),
            |t, diamond, path| {
                if piece.owner.owns(t) {
                    visit(t, diamond, path)
                }
            },
        ),
    }
}

/// The points of a mesh as a bitset over the grid's points (x fastest) with the number of points
/// before each word: a point's id is its rank among the used points.
#[derive(Clone, Debug)]
pub(crate) struct PointSet {
    used: Vec<u64>,
    /// Used points before each word of `used`.
    rank: Vec<u32>,
    len: usize,
}

impl PointSet {
    /// The points of the bitset `used`.
    pub(crate) fn new(used: Vec<u64>) -> Result<Self> {
        let mut rank = memory::with_capacity(used.len(), "the mesh's point ids")?;
        let mut len = 0usize;
        for w in &used {
            rank.push(len as u32);
            len += w.count_ones() as usize;
        }
        Ok(Self { used, rank, len })
    }

    /// Number of points.
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// The id of used point `i` (grid index).
    #[inline]
    pub(crate) fn id(&self, i: usize) -> usize {
        let (w, b) = (i / 64, i % 64);
        self.rank[w] as usize + (self.used[w] & ((1u64 << b) - 1)).count_ones() as usize
    }

    /// Writes the grid index of each used point into `ids` (one slot per point), ascending.
    fn write_ids<I: Index>(&self, ids: &mut [I]) {
        self.for_points(ids, 1, |_, grid_ids, chunk| {
            for (slot, i) in chunk.iter_mut().zip(grid_ids) {
                *slot = I::from_usize(i);
            }
        });
    }

    /// Number of the parallel tasks of [`PointSet::for_points`].
    fn tasks(&self) -> usize {
        self.used.len().div_ceil(WORDS_PER_TASK)
    }

    /// The grid index of each used point of task `task` of [`PointSet::for_points`], ascending.
    fn task_ids(&self, task: usize) -> impl Iterator<Item = usize> + '_ {
        let first = task * WORDS_PER_TASK;
        let end = (first + WORDS_PER_TASK).min(self.used.len());
        (first..end).flat_map(|w| {
            let mut bits = self.used[w];
            std::iter::from_fn(move || {
                (bits != 0).then(|| {
                    let b = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    w * 64 + b
                })
            })
        })
    }

    /// Calls `write(task, i, chunk)` in parallel for consecutive chunks of `out` (`per` elements per
    /// point), `i` the grid index of each used point of the chunk in order ([`PointSet::task_ids`]).
    fn for_points<T: Send>(
        &self,
        out: &mut [T],
        per: usize,
        write: impl Fn(usize, &mut dyn Iterator<Item = usize>, &mut [T]) + Sync,
    ) {
        let words: Vec<usize> = self
            .used
            .chunks(WORDS_PER_TASK)
            .map(|ws| ws.iter().map(|w| w.count_ones() as usize).sum())
            .collect();
        pieces(out, &words, per)
            .into_par_iter()
            .enumerate()
            .for_each(|(task, chunk)| write(task, &mut self.task_ids(task), chunk));
    }
}

/// Words of the point bitset per parallel task.
const WORDS_PER_TASK: usize = 4096;

impl MeshPlan {
    /// Counts the mesh of `split` on `lattice`: one parallel walk for the tetrahedra, the bitset of
    /// the split set for the points.
    pub(crate) fn new(lattice: &Lattice, split: SplitSet) -> Result<Self> {
        let roots = subtrees(lattice, &split);
        let mut counts = memory::with_capacity(roots.len(), "the mesh's subtrees")?;
        counts.par_extend(roots.par_iter().map(|&(t, _)| {
            let mut n = 0;
            walk(lattice, &split, t, |_, _| n += 1);
            n
        }));
        let mut used = memory::copied(split.domain_bits(), "the mesh's point set")?;
        // The root-cube corners in the domain are vertices of the six root tetrahedra's leaves.
        for c in 0..8 {
            let p = glam::IVec3::new(c & 1, c >> 1 & 1, c >> 2) * lattice.size();
            if lattice.in_domain(p) {
                let i = lattice.index(p);
                used[i / 64] |= 1 << (i % 64);
            }
        }
        Self::counted(lattice, split, roots, counts, used, None)
    }

    /// The plan of `split` on `lattice` from its subtrees `roots` with their numbers of
    /// tetrahedra `counts` and its points `used` (a bitset over the grid's points).
    fn counted(
        lattice: &Lattice,
        split: SplitSet,
        roots: Vec<(Tet, u64)>,
        counts: Vec<usize>,
        used: Vec<u64>,
        piece: Option<PieceCells>,
    ) -> Result<Self> {
        Ok(Self {
            lattice: *lattice,
            tets: counts.iter().sum(),
            split,
            sequence: (0..roots.len()).collect(),
            visibility: None,
            roots,
            counts,
            points: PointSet::new(used)?,
            piece,
            remote: OnceLock::new(),
        })
    }

    /// Counts the tetrahedra of `split` on `lattice` that `piece` owns, and their points: one
    /// parallel walk marks the points in a bitset over the grid's points as it counts (the split
    /// set's own bitset holds the whole mesh's points, most of them other pieces').
    pub(crate) fn of_piece(lattice: &Lattice, split: SplitSet, piece: PieceCells) -> Result<Self> {
        let roots = subtrees(lattice, &split);
        let words = split.domain_bits().len();
        let mut used: Vec<AtomicU64> = memory::with_capacity(words, "the mesh's point set")?;
        used.extend((0..words).map(|_| AtomicU64::new(0)));
        let mut counts = memory::with_capacity(roots.len(), "the mesh's subtrees")?;
        counts.par_extend(roots.par_iter().map(|&root| {
            let mut n = 0;
            walk_written(lattice, &split, root, None, Some(&piece), |t, _, _| {
                n += 1;
                for p in t {
                    let i = lattice.index(*p);
                    used[i / 64].fetch_or(1 << (i % 64), Ordering::Relaxed);
                }
            });
            n
        }));
        let used = used.into_iter().map(AtomicU64::into_inner).collect();
        Self::counted(lattice, split, roots, counts, used, Some(piece))
    }

    /// Visits the leaves below `root` that the plan writes, in the plan's order ([`walk_written`]).
    fn walk_written(&self, root: (Tet, u64), visit: impl FnMut(&Tet, Option<Diamond>, u64)) {
        let (split, order) = (&self.split, self.visibility);
        walk_written(
            &self.lattice,
            split,
            root,
            order,
            self.piece.as_ref(),
            visit,
        );
    }

    /// Has every later [`MeshPlan::write_tets`], [`MeshPlan::write_paths`] and
    /// [`MeshPlan::to_mesh`] write the tetrahedra in the exact visibility order from `eye` (world
    /// coordinates on `grid`, the grid of the plan's hierarchy; anywhere, inside the volume or on a
    /// plane too), `direction`'s end first: Marchesin's Algorithm 2 (§6), the bisection tree walked
    /// with the far child of every bisection first, as [`crate::view::BspTree::order`] does, but
    /// while writing, so that no tree is built. The subtrees are put in that order first (a walk
    /// of the tree's first levels), then each is walked in parallel into its slice. The points are
    /// unchanged.
    pub fn set_visibility_order(
        &mut self,
        grid: &Grid,
        eye: [f64; 3],
        direction: Direction,
    ) -> Result<()> {
        if grid.dims != self.grid_dims() {
            return Err(Error::Parameter(format!(
                "the mesh was planned for a grid of {:?} points, not {:?}",
                self.grid_dims(),
                grid.dims
            )));
        }
        let eye = lattice_eye(grid, eye)?;
        let back_to_front = direction == Direction::BackToFront;
        let unit: FxHashMap<u64, usize> = self
            .roots
            .iter()
            .enumerate()
            .map(|(i, &(_, path))| (path, i))
            .collect();
        let lattice = &self.lattice;
        let mut tops: Vec<(Tet, u64)> = Diamond::root(lattice)
            .tets(lattice)
            .into_iter()
            .enumerate()
            .map(|(r, t)| (t, root_path(r)))
            .collect();
        tops.sort_by_key(|(t, _)| root_rank(t, eye));
        if !back_to_front {
            tops.reverse();
        }
        let mut sequence = Vec::with_capacity(self.roots.len());
        let mut stack = Vec::with_capacity(64);
        for top in tops {
            stack.push(top);
            while let Some((t, path)) = stack.pop() {
                if let Some(&i) = unit.get(&path) {
                    sequence.push(i);
                    continue;
                }
                if lattice.place(&t) == Placement::Outside || !is_split(&self.split, &t) {
                    continue;
                }
                let [first, second] = bisect(&t);
                let first = (first, child_path(path, false));
                let second = (second, child_path(path, true));
                // Pushed last, popped first: back to front, the far child first.
                if first_child_is_near(&t, eye) != back_to_front {
                    stack.extend([second, first]);
                } else {
                    stack.extend([first, second]);
                }
            }
        }
        if sequence.len() != self.roots.len() {
            return Err(Error::Parameter(
                "internal error: the visibility order misses subtrees of the mesh".into(),
            ));
        }
        self.sequence = sequence;
        self.visibility = Some((eye, direction));
        Ok(())
    }

    /// The direction of the visibility order the tetrahedra are written in, if one was set
    /// ([`MeshPlan::set_visibility_order`]); otherwise they are in ascending bisection-path order.
    pub fn visibility(&self) -> Option<Direction> {
        self.visibility.map(|(_, direction)| direction)
    }

    /// The subtrees in the order they are written in, with their numbers of tetrahedra.
    fn writing_order(&self) -> (Vec<(Tet, u64)>, Vec<usize>) {
        self.sequence
            .iter()
            .map(|&i| (self.roots[i], self.counts[i]))
            .unzip()
    }

    /// Number of tetrahedra.
    pub fn tets(&self) -> usize {
        self.tets
    }

    /// Number of points.
    pub fn points(&self) -> usize {
        self.points.len()
    }

    /// The lattice the mesh lives on.
    pub fn lattice(&self) -> &Lattice {
        &self.lattice
    }

    /// The split set the mesh is made of.
    pub(crate) fn split(&self) -> &SplitSet {
        &self.split
    }

    /// The subtrees the tetrahedra are written by, in order, each with the index of its first
    /// tetrahedron: below each, the tetrahedra follow [`walk`]'s depth-first order (the first
    /// child of a bisection first).
    pub(crate) fn subtrees(&self) -> impl Iterator<Item = (&Tet, usize)> {
        self.roots
            .iter()
            .map(|(t, _)| t)
            .zip(self.counts.iter().scan(0, |first, &n| {
                let this = *first;
                *first += n;
                Some(this)
            }))
    }

    /// Points per axis of the grid (the lattice's domain) whose indices the plan's points are.
    pub fn grid_dims(&self) -> [usize; 3] {
        let d = self.lattice.hi + glam::IVec3::ONE;
        [d.x as usize, d.y as usize, d.z as usize]
    }

    /// Writes the tetrahedra, in parallel: `connectivity` (4 point ids each, positively oriented,
    /// VTK_TETRA order), `offsets` (`4 i` for tetrahedron `i`, then `4 × tets`; may be empty),
    /// `depths` (bisection depth) and `errors` (`error` of each tetrahedron's diamond, 0 for
    /// unit-cube tetrahedra, which reproduce their samples). Returns the largest error. Every array
    /// must have exactly the size the mesh needs.
    pub fn write_tets<I: Index>(
        &self,
        error: impl Fn(Diamond) -> f64 + Sync,
        connectivity: &mut [I],
        offsets: &mut [I],
        depths: &mut [u8],
        errors: &mut [f32],
    ) -> Result<f64> {
        let n = self.tets;
        check_len(connectivity.len(), n, 4, "connectivity")?;
        check_len(depths.len(), n, 1, "depths")?;
        check_len(errors.len(), n, 1, "errors")?;
        if !offsets.is_empty() {
            check_len(offsets.len(), n + 1, 1, "offsets")?;
            offsets
                .par_iter_mut()
                .enumerate()
                .for_each(|(i, o)| *o = I::from_usize(4 * i));
        }
        let lattice = &self.lattice;
        let (roots, counts) = self.writing_order();
        let jobs: Vec<_> = roots
            .into_iter()
            .zip(pieces(connectivity, &counts, 4))
            .zip(pieces(depths, &counts, 1))
            .zip(pieces(errors, &counts, 1))
            .map(|(((root, c), d), e)| (root, c, d, e))
            .collect();
        let max = jobs
            .into_par_iter()
            .map(|(root, c, d, e)| {
                let mut k = 0;
                let mut max = 0.0f32;
                self.walk_written(root, |leaf, diamond, _| {
                    let (leaf, depth, err) = output_leaf(lattice, leaf, diamond, &error);
                    for (slot, p) in c[4 * k..4 * k + 4].iter_mut().zip(leaf) {
                        *slot = I::from_usize(self.points.id(lattice.index(p)));
                    }
                    d[k] = depth;
                    e[k] = err;
                    max = max.max(err);
                    k += 1;
                });
                max
            })
            .reduce(|| 0.0, f32::max);
        Ok(max as f64)
    }

    /// Writes each tetrahedron's bisection path ([`crate::view::BspTree::paths`]: from it,
    /// [`crate::view::BspTree::from_paths`] orders the cells wherever they went) in the order of
    /// [`MeshPlan::write_tets`], in parallel; `paths` has exactly one slot per tetrahedron.
    pub fn write_paths(&self, paths: &mut [u64]) -> Result<()> {
        check_len(paths.len(), self.tets, 1, "bisection paths")?;
        // Unit-cube tetrahedra, the deepest, are 3 bisections per level below the root.
        if 3 * self.lattice.levels >= max_path_depth() {
            return Err(Error::Parameter(format!(
                "the mesh is too deep for bisection paths ({} levels)",
                max_path_depth()
            )));
        }
        let (roots, counts) = self.writing_order();
        roots
            .into_par_iter()
            .zip(pieces(paths, &counts, 1))
            .for_each(|(root, slice)| {
                let mut k = 0;
                self.walk_written(root, |_, _, path| {
                    slice[k] = path;
                    k += 1;
                });
            });
        Ok(())
    }

    /// Writes the grid index (x fastest) of each point, ascending.
    pub fn write_point_ids<I: Index>(&self, ids: &mut [I]) -> Result<()> {
        check_len(ids.len(), self.points.len(), 1, "point ids")?;
        self.points.write_ids(ids);
        Ok(())
    }

    /// Writes three coordinates per point, `position(i)` for the point of grid index `i`.
    pub fn write_points(
        &self,
        position: impl Fn(usize) -> [f64; 3] + Sync,
        xyz: &mut [f64],
    ) -> Result<()> {
        check_len(xyz.len(), self.points.len(), 3, "point coordinates")?;
        self.points.for_points(xyz, 3, |_, grid_ids, chunk| {
            for (slot, i) in chunk.chunks_exact_mut(3).zip(grid_ids) {
                slot.copy_from_slice(&position(i));
            }
        });
        Ok(())
    }

    /// Copies the values of each point from `source` (one tuple of `tuple_bytes` bytes per grid
    /// point, x fastest) into `target` (one tuple per mesh point): a point array passed through.
    pub fn gather(&self, source: &[u8], tuple_bytes: usize, target: &mut [u8]) -> Result<()> {
        let grid_len = self.grid_dims().iter().product();
        check_len(
            source.len(),
            grid_len,
            tuple_bytes,
            "a point array's source",
        )?;
        check_len(
            target.len(),
            self.points.len(),
            tuple_bytes,
            "a point array's target",
        )?;
        if tuple_bytes == 0 {
            return Ok(());
        }
        self.points
            .for_points(target, tuple_bytes, |_, grid_ids, chunk| {
                for (slot, i) in chunk.chunks_exact_mut(tuple_bytes).zip(grid_ids) {
                    slot.copy_from_slice(&source[i * tuple_bytes..(i + 1) * tuple_bytes]);
                }
            });
        Ok(())
    }

    /// For a piece's plan ([`MeshPlan::of_piece`]): the grid index of each of its points that the
    /// piece does not hold, ascending (the points whose values it fetches from the others).
    pub fn remote_point_ids(&self) -> Result<Vec<u64>> {
        let (remote, counts) = self.remote_points()?;
        let total = counts.iter().sum();
        let mut ids = memory::filled(total, 0u64, "the ids of the points to fetch")?;
        pieces(&mut ids, counts, 1)
            .into_par_iter()
            .enumerate()
            .for_each(|(task, chunk)| {
                let task_remote = self.points.task_ids(task).filter(|&i| remote(i));
                for (slot, i) in chunk.iter_mut().zip(task_remote) {
                    *slot = i as u64;
                }
            });
        Ok(ids)
    }

    /// For a piece's plan: whether a point (grid index) is one the piece does not hold, and the
    /// number of such points of the plan in each task of [`PointSet::for_points`] (counted once).
    fn remote_points(&self) -> Result<(impl Fn(usize) -> bool + Sync + '_, &[usize])> {
        let own = self.own_box()?;
        let remote = move |i: usize| !own.contains(self.lattice.point(i));
        let counts = self.remote.get_or_init(|| {
            (0..self.points.tasks())
                .into_par_iter()
                .map(|task| self.points.task_ids(task).filter(|&i| remote(i)).count())
                .collect()
        });
        Ok((remote, counts))
    }

    /// For a piece's plan: copies each point's tuple of `tuple_bytes` bytes into `target` (one
    /// tuple per point), in parallel, from `local` (one tuple per point of the piece's box, x
    /// fastest: its own input array) or, for a point the piece does not hold, from `fetched` (one
    /// tuple per point of [`MeshPlan::remote_point_ids`], in that order): a point array passed
    /// through.
    pub fn gather_piece(
        &self,
        local: &[u8],
        fetched: &[u8],
        tuple_bytes: usize,
        target: &mut [u8],
    ) -> Result<()> {
        let own = self.own_box()?;
        check_len(local.len(), own.len(), tuple_bytes, "a point array's piece")?;
        check_len(
            target.len(),
            self.points.len(),
            tuple_bytes,
            "a point array's target",
        )?;
        // The remote points before each task's.
        let (_, counts) = self.remote_points()?;
        let mut first = Vec::with_capacity(counts.len());
        let mut before = 0;
        for n in counts {
            first.push(before);
            before += n;
        }
        check_len(
            fetched.len(),
            before,
            tuple_bytes,
            "a point array's fetched values",
        )?;
        if tuple_bytes == 0 {
            return Ok(());
        }
        self.points
            .for_points(target, tuple_bytes, |task, grid_ids, chunk| {
                let mut next = first[task];
                for (slot, i) in chunk.chunks_exact_mut(tuple_bytes).zip(grid_ids) {
                    let p = self.lattice.point(i);
                    let (source, k) = if own.contains(p) {
                        (local, own.index(p))
                    } else {
                        next += 1;
                        (fetched, next - 1)
                    };
                    slot.copy_from_slice(&source[k * tuple_bytes..(k + 1) * tuple_bytes]);
                }
            });
        Ok(())
    }

    /// The points a piece's plan was made for.
    fn own_box(&self) -> Result<PointBox> {
        self.piece
            .as_ref()
            .map(|p| p.owned)
            .ok_or_else(|| Error::Parameter("the mesh plan is not a piece's".into()))
    }

    /// The mesh as a [`TetMesh`] on `grid`, each tetrahedron with the `error` of its diamond.
    pub fn to_mesh(&self, grid: &Grid, error: impl Fn(Diamond) -> f64 + Sync) -> Result<TetMesh> {
        let mut point_ids = memory::filled(self.points.len(), 0usize, "the mesh's point ids")?;
        self.write_point_ids(&mut point_ids)?;
        let mut points = memory::filled(self.points.len(), [0.0; 3], "the mesh's points")?;
        self.write_points(|i| grid.point(grid.ijk(i)), points.as_flattened_mut())?;
        let mut tets = memory::filled(self.tets, [0u32; 4], "the mesh's tetrahedra")?;
        let mut depths = memory::filled(self.tets, 0u8, "the mesh's depths")?;
        let mut errors = memory::filled(self.tets, 0f32, "the mesh's errors")?;
        let max_error = self.write_tets(
            error,
            tets.as_flattened_mut(),
            &mut [],
            &mut depths,
            &mut errors,
        )?;
        Ok(TetMesh {
            point_ids,
            points,
            tets,
            depths,
            errors,
            max_error,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fields::marschner_lobb_u8;
    use crate::{Hierarchy, Query, ScalarSlice};
    use std::collections::BTreeSet;

    /// The mesh of `plan` the straightforward way, on one thread: every leaf collected (in the
    /// order of the subtrees), the points deduplicated through a sorted set of their grid indices.
    fn reference(plan: &MeshPlan, grid: &Grid, error: impl Fn(Diamond) -> f64) -> TetMesh {
        let lattice = &plan.lattice;
        let mut leaves = Vec::new();
        for (t, _) in subtrees(lattice, &plan.split) {
            walk(lattice, &plan.split, t, |t, _| leaves.push(*t));
        }
        let set: BTreeSet<usize> = leaves.iter().flatten().map(|&p| lattice.index(p)).collect();
        let point_ids: Vec<usize> = set.into_iter().collect();
        let id = |i: usize| point_ids.binary_search(&i).unwrap() as u32;
        let mut mesh = TetMesh {
            points: point_ids.iter().map(|&i| grid.point(grid.ijk(i))).collect(),
            ..TetMesh::default()
        };
        for mut t in leaves {
            if signed_volume6(&t) < 0 {
                t.swap(2, 3);
            }
            let (depth, e) = Diamond::of_tet(&t).map_or((3 * lattice.levels, 0.0), |d| {
                (d.depth(lattice), error(d) as f32)
            });
            mesh.tets.push(t.map(|p| id(lattice.index(p))));
            mesh.depths.push(depth as u8);
            mesh.errors.push(e);
            mesh.max_error = mesh.max_error.max(e as f64);
        }
        mesh.point_ids = point_ids;
        mesh
    }

    fn hierarchy(dims: [usize; 3]) -> (Hierarchy, Grid) {
        let (g, v) = marschner_lobb_u8(dims);
        let h = Hierarchy::build(g, ScalarSlice::U8(&v), &mut |_| true).unwrap();
        (h, g)
    }

    #[test]
    fn written_mesh_is_the_straightforward_one() {
        for dims in [
            [17, 17, 17],
            [33, 20, 17],
            [10, 3, 7],
            [2, 2, 2],
            [40, 9, 26],
            [3, 70, 2],
        ] {
            let (h, g) = hierarchy(dims);
            let queries = [0.0, 2.0, 8.0, 1000.0]
                .map(Query::tolerance)
                .into_iter()
                .chain([
                    Query {
                        max_tetrahedra: 500,
                        ..Query::tolerance(0.0)
                    },
                    Query {
                        region_of_interest: Some([0.0, 0.3, 0.0, 1.0, 0.2, 0.6]),
                        ..Query::tolerance(1.0)
                    },
                ]);
            for q in queries {
                let plan = h.plan(&q).unwrap();
                let expected = reference(&plan, &g, |d| h.error(d));
                let mesh = h.query(&q).unwrap();
                assert_eq!(mesh, expected, "{dims:?} {q:?}");
                assert_eq!(
                    (plan.tets(), plan.points()),
                    (mesh.tets.len(), mesh.points.len())
                );

                // 32- and 64-bit ids with offsets, as VTK takes them.
                let n = plan.tets();
                let (mut c32, mut o32) = (vec![0i32; 4 * n], vec![0i32; n + 1]);
                let (mut c64, mut o64) = (vec![0i64; 4 * n], vec![0i64; n + 1]);
                let (mut d, mut e) = (vec![0u8; n], vec![0f32; n]);
                let max = h
                    .write_tets(&plan, &mut c32, &mut o32, &mut d, &mut e)
                    .unwrap();
                assert_eq!((max, &d, &e), (mesh.max_error, &mesh.depths, &mesh.errors));
                h.write_tets(&plan, &mut c64, &mut o64, &mut d, &mut e)
                    .unwrap();
                let flat: Vec<i64> = mesh.tets.as_flattened().iter().map(|&i| i as i64).collect();
                assert_eq!(c64, flat);
                assert_eq!(c32.iter().map(|&i| i as i64).collect::<Vec<_>>(), flat);
                assert!(o32.iter().enumerate().all(|(i, &o)| o as usize == 4 * i));
                assert_eq!(o64[n], 4 * n as i64);

                // A 3-byte point array passed through.
                let source: Vec<u8> = (0..3 * g.len()).map(|b| (b * 7 % 251) as u8).collect();
                let mut target = vec![0u8; 3 * plan.points()];
                plan.gather(&source, 3, &mut target).unwrap();
                for (k, &i) in mesh.point_ids.iter().enumerate() {
                    assert_eq!(target[3 * k..3 * k + 3], source[3 * i..3 * i + 3]);
                }
            }
        }
    }

    #[test]
    fn wrongly_sized_arrays_are_refused() {
        let (h, g) = hierarchy([9, 9, 9]);
        let plan = h.plan(&Query::tolerance(4.0)).unwrap();
        let n = plan.tets();
        let (mut d, mut e) = (vec![0u8; n], vec![0f32; n]);
        let mut c = vec![0i32; 4 * n - 1];
        assert!(h
            .write_tets(&plan, &mut c, &mut [], &mut d, &mut e)
            .is_err());
        let mut c = vec![0i32; 4 * n];
        assert!(h
            .write_tets(&plan, &mut c, &mut [0; 3], &mut d, &mut e)
            .is_err());
        assert!(h
            .write_tets(&plan, &mut c, &mut [], &mut d[1..], &mut e)
            .is_err());
        assert!(plan
            .write_points(|_| [0.0; 3], &mut vec![0.0; 3 * plan.points() + 3])
            .is_err());
        assert!(plan
            .gather(&vec![0; g.len() - 1], 1, &mut vec![0; plan.points()])
            .is_err());
        let (other, _) = hierarchy([9, 9, 10]);
        assert!(other
            .write_tets(&plan, &mut c, &mut [], &mut d, &mut e)
            .is_err());
    }
}
