//! Exact visibility order of a mesh's tetrahedra from the bisection tree (Marchesin §6).
//!
//! Every bisection splits a tetrahedron by the plane through its spine's midpoint and its two other
//! vertices, so the bisection tree of a mesh *is* a binary space partition of it ("hierarchically
//! splitting tetrahedra into two using a plane … implicitly corresponds to building a binary space
//! partition", Marchesin §6, Algorithm 2). Above it, the six root tetrahedra (Kuhn's split of the
//! root cube around its diagonal `x = y = z`) are the cells of the three planes `x = y`, `x = z`,
//! `y = z`, a BSP of three levels. Visiting, at every node, first the child on the far side of its
//! plane from the eye gives a back-to-front order; its reverse is front to back. It is exact for any
//! eye position — perspective, inside the volume, on a plane (then neither side can hide the other)
//! — because two tetrahedra that share a face are separated at their lowest common ancestor by the
//! plane of that face. One visit per node: linear in the number of tetrahedra.
//!
//! [`BspTree`] keeps, for one mesh, the tree's shape with the mesh index of each leaf (4 bytes per
//! node, about 8 bytes per tetrahedron), so that every new eye position costs one traversal.

use crate::diamond::{bisect, Diamond};
use crate::lattice::{Lattice, Placement, Tet};
use crate::mesh::{pieces, MeshPlan};
use crate::volume::Grid;
use crate::{Error, Result, TetMesh};
use glam::{DVec3, I64Vec3, IVec3};
use rayon::prelude::*;
use rustc_hash::FxHashMap;

/// Which end of the order comes first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// Farthest first (compositing with "over" in drawing order, Marchesin's Algorithm 2).
    BackToFront,
    /// Nearest first.
    FrontToBack,
}

/// A node with no tetrahedra in the domain.
const EMPTY: u32 = u32::MAX;
/// Marks a leaf; the low bits are its index in the mesh.
const LEAF: u32 = 1 << 31;

/// Bisection paths ([`BspTree::paths`]): the root tetrahedron's index from this bit, then one bit
/// per bisection, then the depth in the low bits.
const ROOT_SHIFT: u32 = 61;
const DEPTH_BITS: u32 = 6;
/// Bisections a path can hold (bits 6 to 60).
const PATH_BITS: u32 = ROOT_SHIFT - DEPTH_BITS;
/// The depth at which [`BspTree::from_paths`] cuts the tree into the subtrees an order fills in
/// parallel (at most 6 × 2^9 of them).
const SUBTREE_DEPTH: u32 = 9;

fn path_root(path: u64) -> usize {
    (path >> ROOT_SHIFT) as usize
}

fn path_depth(path: u64) -> u32 {
    (path & ((1 << DEPTH_BITS) - 1)) as u32
}

/// The bisection path of the `r`-th root tetrahedron.
pub(crate) fn root_path(r: usize) -> u64 {
    (r as u64) << ROOT_SHIFT
}

/// The bisection path of the first (`second` false) or second child of the tetrahedron whose path is
/// `path`; only meaningful while its depth is below [`max_path_depth`].
#[inline]
pub(crate) fn child_path(path: u64, second: bool) -> u64 {
    let depth = path_depth(path);
    let bit = u64::from(second) << (DEPTH_BITS + PATH_BITS - 1).saturating_sub(depth);
    (path | bit) + 1
}

/// The deepest bisection a path can hold.
pub(crate) fn max_path_depth() -> u32 {
    PATH_BITS
}

/// Whether the first child of `t`'s bisection (the one holding the spine's first end, as
/// [`bisect`] returns them) lies on the eye's side of the bisection plane (`eye` in lattice
/// coordinates), so that back to front visits the second child first. An eye on the plane gets
/// `false` (neither child can hide the other). Every visibility order of the crate decides with
/// this one test, so that they agree even there.
#[inline]
pub(crate) fn first_child_is_near(t: &Tet, eye: DVec3) -> bool {
    let m = (t[0] + t[1]) / 2;
    let normal = wide(t[2] - m).cross(wide(t[3] - m));
    let first_side = normal.dot(wide(t[0] - m)).signum();
    let eye_side = normal.as_dvec3().dot(eye - m.as_dvec3());
    eye_side * first_side as f64 > 0.0
}

/// The rank of a root tetrahedron back to front from `eye` (lattice coordinates): the six root
/// tetrahedra sorted by it are in back-to-front order, the BSP of the planes `x = y`, `x = z`,
/// `y = z` (each root tetrahedron is one cell `x_i ≥ x_j ≥ x_k` of it), far side first at each level.
pub(crate) fn root_rank(t: &Tet, eye: DVec3) -> [bool; 3] {
    const PLANES: [(usize, usize); 3] = [(0, 1), (0, 2), (1, 2)];
    let centroid = t.iter().fold(IVec3::ZERO, |a, &p| a + p); // 4 × the centroid
    PLANES.map(|(a, b)| (centroid[a] > centroid[b]) == (eye[a] > eye[b]))
}

/// `eye` (world coordinates) in the lattice coordinates of `grid` (a positive scaling per axis keeps
/// every side of every plane), refused when not finite.
pub(crate) fn lattice_eye(grid: &Grid, eye: [f64; 3]) -> Result<DVec3> {
    if eye.iter().any(|c| !c.is_finite()) {
        return Err(Error::Parameter(format!(
            "the eye position must be finite (got {eye:?})"
        )));
    }
    Ok((DVec3::from(eye) - DVec3::from(grid.origin)) / DVec3::from(grid.spacing))
}

/// The binary space partition of a mesh's tetrahedra by their bisection planes (Marchesin §6).
#[derive(Clone, Debug)]
pub struct BspTree {
    grid: Grid,
    /// Depth-first, the first child of a bisection right after its parent (ascending bisection
    /// paths, the order of the mesh's tetrahedra): a leaf is `LEAF | mesh index`, a node outside
    /// the domain `EMPTY`, an inner node the position of its second child.
    nodes: Vec<u32>,
    /// The six root tetrahedra and the position of their nodes.
    roots: Vec<(Tet, u32)>,
    /// The nodes of the mesh plan's subtrees (its parallel work units) and their numbers of
    /// tetrahedra: an order visits them in turn, then fills each one's slice in parallel.
    subtrees: FxHashMap<u32, usize>,
    tets: usize,
}

impl BspTree {
    /// The tree of `plan`'s mesh on `grid` (the grid the plan's hierarchy was built for): leaves
    /// carry the index each tetrahedron has in the plan's mesh ([`MeshPlan::to_mesh`],
    /// [`MeshPlan::write_tets`]). Linear in the number of tetrahedra.
    pub fn new(plan: &MeshPlan, grid: &Grid) -> Result<Self> {
        let lattice = plan.lattice();
        if grid.dims != plan.grid_dims() {
            return Err(Error::Parameter(format!(
                "the mesh was planned for a grid of {:?} points, not {:?}",
                plan.grid_dims(),
                grid.dims
            )));
        }
        if plan.visibility().is_some() {
            return Err(Error::Parameter(
                "the mesh plan writes its tetrahedra in a visibility order already".into(),
            ));
        }
        let split = plan.split();
        // Each subtree of the plan with the index of its first tetrahedron and its count.
        let firsts: Vec<(Tet, usize)> = plan.subtrees().map(|(t, i)| (*t, i)).collect();
        let mut first: FxHashMap<Tet, (usize, usize)> = FxHashMap::default();
        for (k, &(t, i)) in firsts.iter().enumerate() {
            let end = firsts.get(k + 1).map_or(plan.tets(), |next| next.1);
            first.insert(t, (i, end - i));
        }
        // Subtrees are the first levels of the tree: no lookups below the deepest.
        let depth_of =
            |t: &Tet| Diamond::of_tet(t).map_or(3 * lattice.levels, |d| d.depth(lattice));
        let deepest = firsts.iter().map(|(t, _)| depth_of(t)).max().unwrap_or(0);
        let mut nodes = Vec::with_capacity(2 * plan.tets() + 64);
        let mut roots = Vec::with_capacity(6);
        let mut subtrees = FxHashMap::default();
        let mut next = 0usize;
        // (tetrahedron, its depth, the inner node whose second child it is)
        let mut stack: Vec<(Tet, u32, Option<usize>)> = Vec::new();
        for t in Diamond::root(lattice).tets(lattice) {
            roots.push((t, nodes.len() as u32));
            stack.push((t, 0, None));
            while let Some((t, depth, parent)) = stack.pop() {
                let at = nodes.len();
                if at >= LEAF as usize {
                    return Err(Error::Parameter(
                        "the mesh is too large for a visibility order (2^31 tree nodes)".into(),
                    ));
                }
                if let Some(p) = parent {
                    nodes[p] = at as u32;
                }
                if depth <= deepest {
                    if let Some(&(i, count)) = first.get(&t) {
                        next = i; // a subtree of the plan: its tetrahedra are numbered from here
                        subtrees.insert(at as u32, count);
                    }
                }
                match lattice.place(&t) {
                    Placement::Outside => nodes.push(EMPTY),
                    _ if Diamond::of_tet(&t).is_some_and(|d| split.contains(d)) => {
                        let [c0, c1] = bisect(&t);
                        nodes.push(EMPTY); // patched when its second child is placed
                        stack.push((c1, depth + 1, Some(at)));
                        stack.push((c0, depth + 1, None));
                    }
                    Placement::Inside => {
                        nodes.push(LEAF | next as u32);
                        next += 1;
                    }
                    Placement::Straddling => {
                        return Err(Error::Parameter(
                            "internal error: an unsplit tetrahedron straddles the domain".into(),
                        ))
                    }
                }
            }
        }
        Ok(Self {
            grid: *grid,
            nodes,
            roots,
            subtrees,
            tets: plan.tets(),
        })
    }

    /// The tree of a mesh given by the [bisection paths](BspTree::paths) of its tetrahedra, the
    /// `i`-th path that of the tetrahedron of index `i`, on `grid` (the grid of the hierarchy the
    /// mesh was refined on). Any subset of a conforming mesh's tetrahedra can be ordered this way
    /// (e.g. one rank's piece, or cells left by a threshold): branches without tetrahedra are
    /// empty. Paths that are not valid (a root index past the sixth, bits past the depth) or that
    /// overlap (twice the same tetrahedron, or one inside another) are refused. Cells in ascending
    /// path order (the order meshes are written in, [`MeshPlan::write_tets`]) are taken as they
    /// are, in one pass over the paths; any other order is sorted first (`O(n log n)`).
    pub fn from_paths(grid: &Grid, paths: &[u64]) -> Result<Self> {
        let lattice = Lattice::new(grid.dims)?;
        let root_tets = Diamond::root(&lattice).tets(&lattice);
        if paths.len() >= LEAF as usize {
            return Err(Error::Parameter(
                "the mesh is too large for a visibility order (2^31 tetrahedra)".into(),
            ));
        }
        let invalid = |&p: &u64| {
            let depth = path_depth(p);
            let bits_below = PATH_BITS - depth.min(PATH_BITS);
            let stray = (p >> DEPTH_BITS) & ((1u64 << bits_below) - 1);
            depth > PATH_BITS || path_root(p) >= root_tets.len() || stray != 0
        };
        if let Some(i) = paths.par_iter().position_first(invalid) {
            return Err(Error::Parameter(format!(
                "cell {i} has no valid bisection path ({:#x}) for a grid of {:?} points",
                paths[i], grid.dims
            )));
        }
        // The paths in ascending order and the cell of each (none: the cells are in that order).
        let ascending = paths.par_windows(2).all(|w| w[0] < w[1]);
        let (keys, cells): (Vec<u64>, Option<Vec<u32>>) = if ascending {
            (Vec::new(), None)
        } else {
            let mut pairs: Vec<(u64, u32)> = paths
                .iter()
                .enumerate()
                .map(|(i, &p)| (p, i as u32))
                .collect();
            pairs.par_sort_unstable();
            let (keys, cells) = pairs.into_iter().unzip();
            (keys, Some(cells))
        };
        let sorted: &[u64] = if ascending { paths } else { &keys };
        let cell = |k: usize| cells.as_ref().map_or(k as u32, |c| c[k]);
        // One pass over the sorted paths, each leaf placed after its predecessor.
        let mut build = TreeBuilder::default();
        build.nodes.reserve(2 * paths.len() + 64);
        let mut roots: Vec<(Tet, u32)> = Vec::with_capacity(root_tets.len());
        for (k, &p) in sorted.iter().enumerate() {
            let (root, depth) = (path_root(p), path_depth(p));
            let same_root = k > 0 && path_root(sorted[k - 1]) == root;
            let from = if same_root {
                // The first bisection where the two paths part: the last leaf took its first
                // child there, this one takes the second.
                let q = sorted[k - 1];
                let x = ((p ^ q) >> DEPTH_BITS) & ((1u64 << PATH_BITS) - 1);
                let parted = x.leading_zeros() - (64 - PATH_BITS);
                if parted >= depth.min(path_depth(q)) {
                    return Err(Error::Parameter(format!(
                        "cells {} and {} overlap (bisection paths {q:#x} and {p:#x})",
                        cell(k - 1),
                        cell(k)
                    )));
                }
                build.close_to(parted as usize + 1);
                build.start_second();
                parted + 1
            } else {
                build.close_to(0);
                while roots.len() <= root {
                    roots.push((root_tets[roots.len()], build.nodes.len() as u32));
                    if roots.len() <= root {
                        build.nodes.push(EMPTY); // a root tetrahedron without cells
                    }
                }
                0
            };
            for d in from..depth {
                let second = p >> (DEPTH_BITS + PATH_BITS - 1 - d) & 1 == 1;
                build.open(d, second);
            }
            build.leaf(depth, cell(k));
        }
        build.close_to(0);
        while roots.len() < root_tets.len() {
            roots.push((root_tets[roots.len()], build.nodes.len() as u32));
            build.nodes.push(EMPTY);
        }
        build.end_subtree();
        if build.nodes.len() >= LEAF as usize {
            return Err(Error::Parameter(
                "the mesh is too large for a visibility order (2^31 tree nodes)".into(),
            ));
        }
        let TreeBuilder {
            nodes, subtrees, ..
        } = build;
        Ok(Self {
            grid: *grid,
            nodes,
            roots,
            subtrees,
            tets: paths.len(),
        })
    }

    /// The bisection path of each tetrahedron, by mesh index: which of the six root tetrahedra it
    /// lies in (3 bits, from bit 61), which child it is at each bisection from there (bit
    /// `60 - k` for the `k`-th: 1 for the second of [`bisect`]'s pair) and its bisection depth
    /// (the low 6 bits). A mesh carries these as a cell array so that
    /// [`BspTree::from_paths`] rebuilds its tree wherever its cells went.
    pub fn paths(&self) -> Result<Vec<u64>> {
        let mut out = vec![u64::MAX; self.tets];
        let mut stack: Vec<(u32, u64)> = Vec::with_capacity(128);
        for (r, &(_, node)) in self.roots.iter().enumerate() {
            stack.push((node, root_path(r)));
            while let Some((node, path)) = stack.pop() {
                let v = self.nodes[node as usize];
                if v == EMPTY {
                    continue;
                }
                if v & LEAF != 0 {
                    out[(v & !LEAF) as usize] = path;
                    continue;
                }
                if path_depth(path) >= PATH_BITS {
                    return Err(Error::Parameter(format!(
                        "the mesh is too deep for bisection paths ({PATH_BITS} levels)"
                    )));
                }
                stack.push((node + 1, child_path(path, false)));
                stack.push((v, child_path(path, true)));
            }
        }
        Ok(out)
    }

    /// Number of tetrahedra ordered.
    pub fn tets(&self) -> usize {
        self.tets
    }

    /// Bytes the tree holds.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<u32>()
    }

    /// The mesh indices of the tetrahedra in visibility order for an eye at `eye` (world
    /// coordinates, anywhere: outside, inside or on the boundary of the volume).
    pub fn order(&self, eye: [f64; 3], direction: Direction) -> Result<Vec<u32>> {
        let mut out = vec![0u32; self.tets];
        self.order_into(eye, direction, &mut out)?;
        Ok(out)
    }

    /// [`BspTree::order`] written into `out` (exactly one slot per tetrahedron): the subtrees in
    /// order first, then each subtree's tetrahedra into its slice, in parallel.
    pub fn order_into(&self, eye: [f64; 3], direction: Direction, out: &mut [u32]) -> Result<()> {
        let eye = lattice_eye(&self.grid, eye)?;
        if out.len() != self.tets {
            return Err(Error::Parameter(format!(
                "visibility order: room for {} tetrahedra, the mesh has {}",
                out.len(),
                self.tets
            )));
        }
        let mut tops = Vec::with_capacity(self.subtrees.len());
        for (t, node) in self.root_order(eye) {
            self.far_first((node, t), eye, |node, t| match self.subtrees.get(&node) {
                Some(&count) => {
                    tops.push((node, *t, count));
                    false
                }
                None => true,
            });
        }
        let counts: Vec<usize> = tops.iter().map(|top| top.2).collect();
        tops.into_par_iter()
            .zip(pieces(out, &counts, 1))
            .for_each(|((node, t, _), slice)| {
                let mut k = 0;
                self.far_first((node, t), eye, |node, _| {
                    let v = self.nodes[node as usize];
                    if v != EMPTY && v & LEAF != 0 {
                        slice[k] = v & !LEAF;
                        k += 1;
                    }
                    true
                });
            });
        if direction == Direction::FrontToBack {
            out.reverse();
        }
        Ok(())
    }

    /// Marchesin's Algorithm 2 below `start` (a node and its tetrahedron): calls `at` on every
    /// node, the far child of every bisection before the near one, and skips the subtrees of the
    /// nodes for which it returns `false`.
    fn far_first(&self, start: (u32, Tet), eye: DVec3, mut at: impl FnMut(u32, &Tet) -> bool) {
        let mut stack: Vec<(u32, Tet)> = Vec::with_capacity(128);
        stack.push(start);
        while let Some((node, t)) = stack.pop() {
            if !at(node, &t) {
                continue;
            }
            let second_child = self.nodes[node as usize];
            if second_child == EMPTY || second_child & LEAF != 0 {
                continue;
            }
            let [c0, c1] = bisect(&t);
            let (n0, n1) = ((node + 1, c0), (second_child, c1));
            // Pushed last, visited first: the far child.
            if first_child_is_near(&t, eye) {
                stack.extend([n0, n1]);
            } else {
                stack.extend([n1, n0]);
            }
        }
    }

    /// The six root tetrahedra back to front: the BSP of the planes `x = y`, `x = z`, `y = z`
    /// (each root tetrahedron is one cell `x_i ≥ x_j ≥ x_k` of it), far side first at each level.
    fn root_order(&self, eye: DVec3) -> Vec<(Tet, u32)> {
        let mut roots = self.roots.clone();
        roots.sort_by_key(|(t, _)| root_rank(t, eye));
        roots
    }
}

/// The nodes of a [`BspTree`] laid out leaf after leaf in ascending path order
/// ([`BspTree::from_paths`]).
#[derive(Default)]
struct TreeBuilder {
    nodes: Vec<u32>,
    /// The inner nodes on the path to the last leaf, the one at depth `d` at `open[d]`: position
    /// and whether its second child was started.
    open: Vec<(usize, bool)>,
    /// Work units of [`BspTree::order_into`]: the nodes at [`SUBTREE_DEPTH`] and the leaves above
    /// it, with their numbers of leaves.
    subtrees: FxHashMap<u32, usize>,
    /// The work unit being filled.
    subtree: Option<(u32, usize)>,
}

impl TreeBuilder {
    /// A node at `depth` begins here: a new work unit at [`SUBTREE_DEPTH`].
    fn begin(&mut self, depth: u32) {
        if depth == SUBTREE_DEPTH {
            self.end_subtree();
            self.subtree = Some((self.nodes.len() as u32, 0));
        }
    }

    fn end_subtree(&mut self) {
        if let Some((node, count)) = self.subtree.take() {
            self.subtrees.insert(node, count);
        }
    }

    /// An inner node at `depth` on the way to the next leaf, which lies below its `second` child
    /// (then its first child is empty).
    fn open(&mut self, depth: u32, second: bool) {
        self.begin(depth);
        let at = self.nodes.len();
        self.nodes.push(EMPTY); // patched when its second child is placed
        if second {
            self.nodes.push(EMPTY); // no cells below its first child
            self.nodes[at] = self.nodes.len() as u32;
        }
        self.open.push((at, second));
    }

    /// A leaf at `depth` for cell `cell`.
    fn leaf(&mut self, depth: u32, cell: u32) {
        self.begin(depth);
        if depth < SUBTREE_DEPTH {
            self.subtrees.insert(self.nodes.len() as u32, 1);
        } else if let Some((_, count)) = self.subtree.as_mut() {
            *count += 1;
        }
        self.nodes.push(LEAF | cell);
    }

    /// Closes the open nodes but the first `keep` (those at depths below `keep`): a second child
    /// never started is empty.
    fn close_to(&mut self, keep: usize) {
        while self.open.len() > keep {
            let Some((at, second)) = self.open.pop() else {
                break;
            };
            if !second {
                self.nodes[at] = self.nodes.len() as u32;
                self.nodes.push(EMPTY);
            }
        }
    }

    /// The next leaf lies below the second child of the deepest open node, whose first child
    /// held the last leaf.
    fn start_second(&mut self) {
        if let Some(top) = self.open.last_mut() {
            top.1 = true;
            self.nodes[top.0] = self.nodes.len() as u32;
        }
    }
}

/// `mesh` with its tetrahedra (and their depths and errors) in `order`, a permutation of their
/// indices such as [`BspTree::order`] gives.
pub fn sorted(mesh: TetMesh, order: &[u32]) -> Result<TetMesh> {
    let n = mesh.tets.len();
    let mut seen = vec![false; n];
    for &i in order {
        match seen.get_mut(i as usize) {
            Some(s) if !*s => *s = true,
            _ => {
                return Err(Error::Parameter(format!(
                    "the order is no permutation of the mesh's {n} tetrahedra (index {i})"
                )))
            }
        }
    }
    if order.len() != n {
        return Err(Error::Parameter(format!(
            "the order names {} of the mesh's {n} tetrahedra",
            order.len()
        )));
    }
    let pick = |i: &u32| *i as usize;
    Ok(TetMesh {
        tets: order.iter().map(|i| mesh.tets[pick(i)]).collect(),
        depths: order.iter().map(|i| mesh.depths[pick(i)]).collect(),
        errors: order.iter().map(|i| mesh.errors[pick(i)]).collect(),
        ..mesh
    })
}

#[inline]
fn wide(v: IVec3) -> I64Vec3 {
    v.as_i64vec3()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fields::marschner_lobb_u8;
    use crate::validate::check_back_to_front;
    use crate::{Hierarchy, Query, ScalarSlice};

    /// The hierarchy of the Marschner–Lobb bytes on `dims` with the given geometry.
    fn hierarchy(dims: [usize; 3], origin: [f64; 3], spacing: [f64; 3]) -> Hierarchy {
        let (_, v) = marschner_lobb_u8(dims);
        let grid = Grid {
            dims,
            origin,
            spacing,
        };
        Hierarchy::build(grid, ScalarSlice::U8(&v), &mut |_| true).unwrap()
    }

    /// Eyes for `grid`: far outside, on the planes of many faces (a lattice plane, the root's
    /// diagonal planes), inside, at a corner, close to a face.
    fn eyes(grid: &Grid) -> Vec<[f64; 3]> {
        let b = grid.bounds();
        let at = |f: [f64; 3]| -> [f64; 3] {
            std::array::from_fn(|a| b[2 * a] + f[a] * (b[2 * a + 1] - b[2 * a]))
        };
        let lattice = |p: [f64; 3]| -> [f64; 3] {
            std::array::from_fn(|a| grid.origin[a] + grid.spacing[a] * p[a])
        };
        vec![
            at([-3.0, 0.4, 5.5]),
            at([0.5, -7.0, 0.25]),
            at([12.0, 13.0, -11.0]),
            at([0.37, 0.61, 0.29]),
            at([0.9, 0.1, 0.5]),
            lattice([8.0, 3.25, 5.5]),
            lattice([4.0, 4.0, 2.5]),
            lattice([6.0, 6.0, 6.0]),
            lattice([3.0, 5.0, -4.0]),
            at([0.0, 0.0, 0.0]),
            at([1.0, 1.0, 1.0]),
        ]
    }

    /// [`check_back_to_front`] of `order` in `direction`.
    fn check(
        mesh: &TetMesh,
        order: &[u32],
        eye: [f64; 3],
        direction: Direction,
    ) -> std::result::Result<crate::validate::VisibilityReport, String> {
        let mut order = order.to_vec();
        if direction == Direction::FrontToBack {
            order.reverse();
        }
        check_back_to_front(&mesh.points, &mesh.tets, &order, eye)
    }

    #[test]
    fn back_to_front_respects_every_interior_face() {
        let cases = [
            ([17, 17, 17], [0.0; 3], [1.0; 3]),
            ([20, 13, 9], [1.0, -2.0, 3.0], [0.5, 2.0, 1.5]),
            ([33, 9, 26], [0.0; 3], [1.0, 0.25, 3.0]),
        ];
        for (dims, origin, spacing) in cases {
            let h = hierarchy(dims, origin, spacing);
            let g = *h.grid();
            let mut queries = vec![Query::tolerance(0.0), Query::tolerance(6.0)];
            queries.push(Query {
                max_tetrahedra: 3000,
                ..Query::tolerance(0.0)
            });
            let b = g.bounds();
            queries.push(Query {
                region_of_interest: Some([
                    b[0],
                    b[0] + 0.4 * (b[1] - b[0]),
                    b[2],
                    b[3],
                    b[4],
                    b[5],
                ]),
                ..Query::tolerance(1.0)
            });
            for q in queries {
                let plan = h.plan(&q).unwrap();
                let mesh = plan.to_mesh(&g, |d| h.error(d)).unwrap();
                let tree = BspTree::new(&plan, &g).unwrap();
                assert_eq!(tree.tets(), mesh.tets.len());
                for eye in eyes(&g) {
                    let order = tree.order(eye, Direction::BackToFront).unwrap();
                    let faces = check(&mesh, &order, eye, Direction::BackToFront)
                        .unwrap_or_else(|e| panic!("{dims:?} {q:?} eye {eye:?}: {e}"));
                    assert!(faces.checked > 0, "{dims:?} {q:?}");
                    let reverse = tree.order(eye, Direction::FrontToBack).unwrap();
                    check(&mesh, &reverse, eye, Direction::FrontToBack).unwrap();
                    // A wrong order is caught: the reverse is not back to front.
                    assert!(
                        check(&mesh, &reverse, eye, Direction::BackToFront).is_err(),
                        "{dims:?} {q:?} eye {eye:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn paths_rebuild_the_order_of_any_cells() {
        let h = hierarchy([20, 13, 9], [1.0, -2.0, 3.0], [0.5, 2.0, 1.5]);
        let g = *h.grid();
        for q in [Query::tolerance(0.0), Query::tolerance(6.0)] {
            let plan = h.plan(&q).unwrap();
            let mesh = plan.to_mesh(&g, |d| h.error(d)).unwrap();
            let tree = BspTree::new(&plan, &g).unwrap();
            let paths = tree.paths().unwrap();
            // Depth in the low bits: the mesh's bisection depth.
            let depths: Vec<u8> = paths.iter().map(|&p| path_depth(p) as u8).collect();
            assert_eq!(depths, mesh.depths);
            // Meshes are written in ascending path order: the one-pass case of `from_paths`.
            assert!(paths.windows(2).all(|w| w[0] < w[1]), "{q:?}");
            let rebuilt = BspTree::from_paths(&g, &paths).unwrap();
            // The cells shuffled (as a redistribution would) and only every third one kept.
            let n = mesh.tets.len();
            let kept: Vec<usize> = (0..n).rev().filter(|i| i % 3 != 1).collect();
            let kept_paths: Vec<u64> = kept.iter().map(|&i| paths[i]).collect();
            let kept_tets: Vec<[u32; 4]> = kept.iter().map(|&i| mesh.tets[i]).collect();
            let subset = BspTree::from_paths(&g, &kept_paths).unwrap();
            for eye in eyes(&g) {
                for direction in [Direction::BackToFront, Direction::FrontToBack] {
                    let order = rebuilt.order(eye, direction).unwrap();
                    assert_eq!(order, tree.order(eye, direction).unwrap(), "{eye:?}");
                    let order = subset.order(eye, direction).unwrap();
                    let sub = TetMesh {
                        tets: kept_tets.clone(),
                        ..mesh.clone()
                    };
                    check(&sub, &order, eye, direction)
                        .unwrap_or_else(|e| panic!("subset, eye {eye:?}: {e}"));
                }
            }
        }
    }

    #[test]
    fn plans_written_in_visibility_order_are_the_trees_order() {
        // A plan set to a visibility order writes its tetrahedra, depths, errors and paths in the
        // order the tree gives (built from the plan, and rebuilt from the written paths), which
        // passes the face-by-face check: eyes outside, inside, on planes, both directions.
        let cases = [
            ([17, 17, 17], [0.0; 3], [1.0; 3]),
            ([20, 13, 9], [1.0, -2.0, 3.0], [0.5, 2.0, 1.5]),
        ];
        for (dims, origin, spacing) in cases {
            let h = hierarchy(dims, origin, spacing);
            let g = *h.grid();
            let budget = Query {
                max_tetrahedra: 3000,
                ..Query::tolerance(0.0)
            };
            for q in [Query::tolerance(0.0), Query::tolerance(6.0), budget] {
                let plan = h.plan(&q).unwrap();
                let mesh = plan.to_mesh(&g, |d| h.error(d)).unwrap();
                let tree = BspTree::new(&plan, &g).unwrap();
                let n = mesh.tets.len();
                let mut paths = vec![0u64; n];
                plan.write_paths(&mut paths).unwrap();
                assert_eq!(paths, tree.paths().unwrap(), "{dims:?} {q:?}");
                let identity: Vec<u32> = (0..n as u32).collect();
                for eye in eyes(&g) {
                    for direction in [Direction::BackToFront, Direction::FrontToBack] {
                        let label = format!("{dims:?} {q:?} eye {eye:?} {direction:?}");
                        let mut ordered = plan.clone();
                        ordered.set_visibility_order(&g, eye, direction).unwrap();
                        assert_eq!(ordered.visibility(), Some(direction));
                        let written = ordered.to_mesh(&g, |d| h.error(d)).unwrap();
                        let order = tree.order(eye, direction).unwrap();
                        let expected = sorted(mesh.clone(), &order).unwrap();
                        assert!(written == expected, "{label}: not the tree's order");
                        let mut written_paths = vec![0u64; n];
                        ordered.write_paths(&mut written_paths).unwrap();
                        let rebuilt = BspTree::from_paths(&g, &written_paths).unwrap();
                        assert_eq!(rebuilt.order(eye, direction).unwrap(), identity, "{label}");
                        check(&written, &identity, eye, direction)
                            .unwrap_or_else(|e| panic!("{label}: {e}"));
                        // A tree is not built from a plan that writes in a visibility order.
                        assert!(BspTree::new(&ordered, &g).is_err());
                    }
                }
            }
        }
    }

    #[test]
    fn bad_paths_are_refused() {
        let h = hierarchy([9, 9, 9], [0.0; 3], [1.0; 3]);
        let plan = h.plan(&Query::tolerance(2.0)).unwrap();
        let paths = BspTree::new(&plan, h.grid()).unwrap().paths().unwrap();
        let deep = *paths.iter().max_by_key(|&&p| path_depth(p)).unwrap();
        let parent = {
            let d = path_depth(deep) - 1;
            let below = DEPTH_BITS + PATH_BITS - d;
            (deep >> below << below) | u64::from(d)
        };
        let cases: Vec<(Vec<u64>, &str)> = vec![
            (vec![paths[0], paths[1], paths[0]], "overlap"),
            (vec![deep, parent], "overlap"),
            (vec![7 << ROOT_SHIFT], "no valid bisection path"),
            (vec![paths[0] | 1 << DEPTH_BITS], "no valid bisection path"),
            (vec![63], "no valid bisection path"),
        ];
        for (bad, message) in cases {
            let err = BspTree::from_paths(h.grid(), &bad).unwrap_err().to_string();
            assert!(err.contains(message), "{bad:x?}: {err}");
        }
        assert!(BspTree::from_paths(&Grid::new([1, 9, 9]), &paths).is_err());
        assert_eq!(BspTree::from_paths(h.grid(), &[]).unwrap().tets(), 0);
    }

    #[test]
    fn bad_eyes_and_buffers_are_refused() {
        let h = hierarchy([9, 9, 9], [0.0; 3], [1.0; 3]);
        let plan = h.plan(&Query::tolerance(2.0)).unwrap();
        let tree = BspTree::new(&plan, h.grid()).unwrap();
        for eye in [[f64::NAN, 0.0, 0.0], [0.0, f64::INFINITY, 1.0]] {
            let err = tree.order(eye, Direction::BackToFront).unwrap_err();
            assert!(err.to_string().contains("finite"), "{err}");
        }
        let mut short = vec![0; tree.tets() - 1];
        assert!(tree
            .order_into([1.0; 3], Direction::BackToFront, &mut short)
            .is_err());
        let other = Grid::new([9, 9, 10]);
        assert!(BspTree::new(&plan, &other).is_err());
        // The same checks when a plan is set to a visibility order, which is left unset.
        let mut ordered = plan.clone();
        assert!(ordered
            .set_visibility_order(&other, [1.0; 3], Direction::BackToFront)
            .is_err());
        assert!(ordered
            .set_visibility_order(h.grid(), [f64::NAN, 0.0, 0.0], Direction::BackToFront)
            .unwrap_err()
            .to_string()
            .contains("finite"));
        assert_eq!(ordered.visibility(), None);
        assert!(ordered
            .write_paths(&mut short.iter().map(|&i| u64::from(i)).collect::<Vec<_>>())
            .is_err());
        // `sorted` takes permutations only, and reorders every per-tetrahedron array alike.
        let mesh = plan.to_mesh(h.grid(), |d| h.error(d)).unwrap();
        let n = mesh.tets.len() as u32;
        for bad in [vec![0; n as usize], (1..=n).collect(), (0..n - 1).collect()] {
            assert!(sorted(mesh.clone(), &bad).is_err());
        }
        let reverse: Vec<u32> = (0..n).rev().collect();
        let back = sorted(mesh.clone(), &reverse).unwrap();
        assert_eq!(sorted(back, &reverse).unwrap(), mesh);
    }
}
