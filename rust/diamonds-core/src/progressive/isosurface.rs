//! Progressive isosurfaces (§4): marching tetrahedra on the current level of a progressive mesh,
//! updated locally under each vertex split or half-edge collapse (§4.3: only the tetrahedra of the
//! split, T_new and T_moved, are marched again), and an interval tree over the current tetrahedra
//! (§4.2, Cignoni et al.), updated under the same splits, that finds the tetrahedra an isovalue
//! crosses without scanning the mesh when the isovalue changes.
//!
//! Every vertex of a level is an original one with its original value, so a surface point is named
//! by its mesh edge and isovalue ([`EdgePoint`]) and interpolated from the edge's two ends (Eq. 7):
//! triangles of neighbouring tetrahedra share their points and the surface is watertight inside the
//! mesh at every level (open only where it meets the mesh's boundary).

use super::record::{ProgressiveMesh, Replay};
use crate::{Error, Result};
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use std::collections::BTreeSet;

/// A point of the isosurface of `isovalues[iso]`: on the mesh edge from the vertex `below` (value
/// below the isovalue) to `above` (value at or above it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct EdgePoint {
    pub iso: u32,
    pub below: u32,
    pub above: u32,
}

/// A triangle named by its points, oriented so that its normal (right hand) points toward increasing
/// values.
pub type EdgeTriangle = [EdgePoint; 3];

/// Marching tetrahedra on one positively oriented tetrahedron `corners` with values `f` for the
/// isovalue `v` (index `iso`): one triangle where one vertex is cut off, two where two are (Fig. 5).
/// A vertex at the isovalue counts as above.
fn march(corners: [u32; 4], f: [f64; 4], iso: u32, v: f64, out: &mut Vec<EdgeTriangle>) {
    let above: [bool; 4] = f.map(|x| x >= v);
    let count = above.iter().filter(|&&a| a).count();
    let point = |a: usize, b: usize| {
        let (below, up) = if above[a] { (b, a) } else { (a, b) };
        EdgePoint {
            iso,
            below: corners[below],
            above: corners[up],
        }
    };
    match count {
        1 | 3 => {
            // The vertex alone on its side, at slot k; the others in slot order. The triangle is
            // oriented like the face opposite k seen from k, which for a positive tetrahedron points
            // away from k when the permutation (k, others) is even (k even).
            let k = (0..4)
                .find(|&s| above[s] == (count == 1))
                .expect("one vertex alone");
            let o: Vec<usize> = (0..4).filter(|&s| s != k).collect();
            let mut t = [point(k, o[0]), point(k, o[1]), point(k, o[2])];
            // Away from a lone vertex below is toward increasing values.
            if above[k] != (k % 2 == 1) {
                t.swap(1, 2);
            }
            out.push(t);
        }
        2 => {
            let lo: Vec<usize> = (0..4).filter(|&s| !above[s]).collect();
            let hi: Vec<usize> = (0..4).filter(|&s| above[s]).collect();
            let (a, b, c, d) = (lo[0], lo[1], hi[0], hi[1]);
            // The quad ac, ad, bd, bc is oriented toward increasing values when (a, b, c, d) is an
            // even permutation of the slots.
            let perm = [a, b, c, d];
            let inversions = (0..4)
                .flat_map(|x| (x + 1..4).map(move |y| (x, y)))
                .filter(|&(x, y)| perm[x] > perm[y])
                .count();
            let q = [point(a, c), point(a, d), point(b, d), point(b, c)];
            let (mut t0, mut t1) = ([q[0], q[1], q[2]], [q[0], q[2], q[3]]);
            if inversions % 2 == 1 {
                t0.swap(1, 2);
                t1.swap(1, 2);
            }
            out.push(t0);
            out.push(t1);
        }
        _ => {}
    }
}

/// The marching-tetrahedra triangles of the tetrahedron `corners` of `pm` for every isovalue.
fn march_all(pm: &ProgressiveMesh, corners: [u32; 4], isovalues: &[f64]) -> Vec<EdgeTriangle> {
    let f = corners.map(|c| pm.scalars[c as usize]);
    let (lo, hi) = f
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    let mut out = Vec::new();
    for (k, &v) in isovalues.iter().enumerate() {
        if lo < v && v <= hi {
            march(corners, f, k as u32, v, &mut out);
        }
    }
    out
}

/// Marching tetrahedra on the whole current level of `replay` (the reference the progressive surface
/// equals): every triangle, sorted.
pub fn march_level(pm: &ProgressiveMesh, replay: &Replay, isovalues: &[f64]) -> Vec<EdgeTriangle> {
    let mut all: Vec<EdgeTriangle> = replay
        .live_tets()
        .flat_map(|(_, c)| march_all(pm, c, isovalues))
        .collect();
    all.sort_unstable();
    all
}

/// An interval tree (§4.2) over the value intervals `[min, max]` of tetrahedra, with inserts and
/// removals. Interval ends are vertex values, so the tree works on their ranks among the distinct
/// values of the field: a node is a rank `m` (the middle of its range, a balanced tree over all
/// ranks) holding the intervals `lo ≤ m ≤ hi` that no node above holds, in two ordered sets — by
/// ascending `lo` and by descending `hi`. The isovalue `v` crosses `[lo, hi]` when
/// `value(lo) < v ≤ value(hi)`, i.e. `lo < q ≤ hi` with `q` the number of distinct values below `v`;
/// a query walks one root-to-leaf path and reads, at each node, only a prefix of one set that all
/// crosses: `O(log h + k)` (Cignoni et al.).
#[derive(Clone, Debug)]
pub struct IntervalTree {
    /// The distinct values, ascending.
    values: Vec<f64>,
    /// Per point, the rank of its value.
    rank: Vec<u32>,
    /// Per node (rank), `(lo << 32) | tet` ascending, and `((!hi) << 32) | tet` ascending.
    by_lo: Vec<BTreeSet<u64>>,
    by_hi: Vec<BTreeSet<u64>>,
    /// Per tetrahedron (indexed by it, grown on demand), its node and interval (as ranks) while it
    /// is in the tree.
    at: Vec<Option<(u32, u32, u32)>>,
    len: usize,
}

impl IntervalTree {
    /// An empty tree for intervals of the values `scalars` (one per point).
    pub fn new(scalars: &[f64]) -> Self {
        let mut values = scalars.to_vec();
        values.sort_unstable_by(f64::total_cmp);
        values.dedup();
        let rank = scalars
            .iter()
            .map(|&x| values.partition_point(|&y| y < x) as u32)
            .collect();
        let n = values.len();
        Self {
            values,
            rank,
            by_lo: vec![BTreeSet::new(); n],
            by_hi: vec![BTreeSet::new(); n],
            at: Vec::new(),
            len: 0,
        }
    }

    /// The node holding `[lo, hi]`.
    fn node(&self, lo: u32, hi: u32) -> u32 {
        let (mut a, mut b) = (0u32, self.values.len() as u32);
        loop {
            let m = a + (b - a) / 2;
            if hi < m {
                b = m;
            } else if lo > m {
                a = m + 1;
            } else {
                return m;
            }
        }
    }

    /// The node and interval (as ranks) of a tetrahedron with corners `corners`.
    fn interval(&self, corners: [u32; 4]) -> (u32, u32, u32) {
        let r = corners.map(|c| self.rank[c as usize]);
        let (lo, hi) = (*r.iter().min().expect("4"), *r.iter().max().expect("4"));
        (self.node(lo, hi), lo, hi)
    }

    /// Inserts the tetrahedron `tet` with corners `corners` (replacing its previous interval).
    pub fn insert(&mut self, tet: u32, corners: [u32; 4]) {
        let (m, lo, hi) = self.interval(corners);
        if self.at.get(tet as usize) == Some(&Some((m, lo, hi))) {
            return; // the same interval (a moved tetrahedron often keeps its)
        }
        self.remove(tet);
        if self.at.len() <= tet as usize {
            self.at.resize(tet as usize + 1, None);
        }
        self.by_lo[m as usize].insert(((lo as u64) << 32) | tet as u64);
        self.by_hi[m as usize].insert(((!hi as u64) << 32) | tet as u64);
        self.at[tet as usize] = Some((m, lo, hi));
        self.len += 1;
    }

    /// Replaces every interval by those of `tets` (original index, corners; indices below `size`)
    /// at once: the tree that removing all and inserting each would give, built node by node from
    /// the tetrahedra bucketed on their node (a jump across many levels changes most intervals).
    pub fn rebuild(&mut self, tets: impl ParallelIterator<Item = (u32, [u32; 4])>, size: usize) {
        let entries: Vec<(u32, (u32, u32, u32))> =
            tets.map(|(t, c)| (t, self.interval(c))).collect();
        self.at.clear();
        self.at.resize(size, None);
        // Bucketed on the node: `start[m] .. start[m + 1]` of `order` (a counting sort).
        let mut start = vec![0usize; self.values.len() + 1];
        for (t, at) in &entries {
            self.at[*t as usize] = Some(*at);
            start[at.0 as usize + 1] += 1;
        }
        for m in 1..start.len() {
            start[m] += start[m - 1];
        }
        let mut next = start.clone();
        let mut order = vec![(0u32, 0u32, 0u32); entries.len()];
        for &(t, (m, lo, hi)) in &entries {
            order[next[m as usize]] = (t, lo, hi);
            next[m as usize] += 1;
        }
        self.by_lo
            .par_iter_mut()
            .zip(&mut self.by_hi)
            .enumerate()
            .for_each(|(m, (by_lo, by_hi))| {
                let bucket = &order[start[m]..start[m + 1]];
                *by_lo = bucket
                    .iter()
                    .map(|&(t, lo, _)| ((lo as u64) << 32) | t as u64)
                    .collect();
                *by_hi = bucket
                    .iter()
                    .map(|&(t, _, hi)| ((!hi as u64) << 32) | t as u64)
                    .collect();
            });
        self.len = entries.len();
    }

    /// Removes the tetrahedron `tet` (nothing if absent).
    pub fn remove(&mut self, tet: u32) {
        if let Some((m, lo, hi)) = self.at.get_mut(tet as usize).and_then(Option::take) {
            self.by_lo[m as usize].remove(&(((lo as u64) << 32) | tet as u64));
            self.by_hi[m as usize].remove(&(((!hi as u64) << 32) | tet as u64));
            self.len -= 1;
        }
    }

    /// The number of tetrahedra in the tree.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Is the tree empty?
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The tetrahedra whose interval the isovalue `v` crosses (`min < v ≤ max`), in no set order.
    pub fn crossing(&self, v: f64) -> Vec<u32> {
        let q = self.values.partition_point(|&y| y < v) as u32;
        let mut out = Vec::new();
        let (mut a, mut b) = (0u32, self.values.len() as u32);
        while a < b {
            let m = a + (b - a) / 2;
            if q <= m {
                // Every interval here reaches m ≥ q: those starting below q cross.
                out.extend(
                    self.by_lo[m as usize]
                        .iter()
                        .take_while(|&&k| ((k >> 32) as u32) < q)
                        .map(|&k| k as u32),
                );
                b = m;
            } else {
                // Every interval here starts at or below m < q: those reaching q cross.
                out.extend(
                    self.by_hi[m as usize]
                        .iter()
                        .take_while(|&&k| !((k >> 32) as u32) >= q)
                        .map(|&k| k as u32),
                );
                a = m + 1;
            }
        }
        out
    }
}

/// A triangle surface: points, their isovalue index, triangles.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfaceMesh {
    pub points: Vec<[f64; 3]>,
    /// The isovalue of each point.
    pub values: Vec<f64>,
    pub triangles: Vec<[u32; 3]>,
}

/// The isosurfaces of some isovalues on the current level of a [`Replay`], kept up to date while
/// the replay moves ([`ProgressiveIsosurface::set_level`]).
#[derive(Clone, Debug)]
pub struct ProgressiveIsosurface {
    isovalues: Vec<f64>,
    tree: IntervalTree,
    /// The triangles of each live tetrahedron the surface crosses.
    triangles: FxHashMap<u32, Vec<EdgeTriangle>>,
    /// Per original tetrahedron, whether the level change under way has touched it (reset after).
    touched: Vec<bool>,
}

impl ProgressiveIsosurface {
    /// The isosurfaces of `isovalues` (finite) on the current level of `replay`, with the interval
    /// tree over its tetrahedra.
    pub fn new(pm: &ProgressiveMesh, replay: &Replay, isovalues: &[f64]) -> Result<Self> {
        let mut tree = IntervalTree::new(&pm.scalars);
        for (t, c) in replay.live_tets() {
            tree.insert(t, c);
        }
        let mut s = Self {
            isovalues: Vec::new(),
            tree,
            triangles: FxHashMap::default(),
            touched: vec![false; pm.tets.len()],
        };
        s.set_isovalues(pm, replay, isovalues, true)?;
        Ok(s)
    }

    /// The isovalues.
    pub fn isovalues(&self) -> &[f64] {
        &self.isovalues
    }

    /// The interval tree over the current level's tetrahedra.
    pub fn tree(&self) -> &IntervalTree {
        &self.tree
    }

    /// Extracts the surfaces of new isovalues on the current level: the tetrahedra they cross found
    /// by the interval tree (`use_tree`) or by scanning every tetrahedron of the level.
    pub fn set_isovalues(
        &mut self,
        pm: &ProgressiveMesh,
        replay: &Replay,
        isovalues: &[f64],
        use_tree: bool,
    ) -> Result<()> {
        if let Some(v) = isovalues.iter().find(|v| !v.is_finite()) {
            return Err(Error::Parameter(format!("the isovalue {v} is not finite")));
        }
        self.isovalues = isovalues.to_vec();
        self.triangles.clear();
        let mut crossed: Vec<u32> = if use_tree {
            isovalues
                .iter()
                .flat_map(|&v| self.tree.crossing(v))
                .collect()
        } else {
            replay
                .live_tets()
                .filter(|(_, c)| {
                    let f = c.map(|k| pm.scalars[k as usize]);
                    let lo = f.iter().copied().fold(f64::INFINITY, f64::min);
                    let hi = f.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                    isovalues.iter().any(|&v| lo < v && v <= hi)
                })
                .map(|(t, _)| t)
                .collect()
        };
        crossed.sort_unstable();
        crossed.dedup();
        for t in crossed {
            self.remarch(pm, replay, t);
        }
        Ok(())
    }

    /// Marches the tetrahedron `t` again (forgets it if it is not in the level or not crossed).
    fn remarch(&mut self, pm: &ProgressiveMesh, replay: &Replay, t: u32) {
        let tris = if replay.is_live(t) {
            march_all(pm, replay.corners(t), &self.isovalues)
        } else {
            Vec::new()
        };
        if tris.is_empty() {
            self.triangles.remove(&t);
        } else {
            self.triangles.insert(t, tris);
        }
    }

    /// Moves `replay` to `level` by splits or collapses, updating the interval tree and the surface
    /// for the tetrahedra of those splits only (T_new and T_moved, §4.3); returns the steps
    /// replayed. A tetrahedron several splits touch is updated once, at the level reached.
    ///
    /// When the replay jumps instead ([`Replay::jumps_to`]: the splits name most tetrahedra), the
    /// tree is rebuilt and every crossed tetrahedron of the level marched, in parallel.
    pub fn set_level(&mut self, pm: &ProgressiveMesh, replay: &mut Replay, level: usize) -> usize {
        if replay.jumps_to(pm, level) {
            let steps = replay.set_level(pm, level);
            self.tree.rebuild(replay.par_live_tets(), pm.tets.len());
            let isovalues = &self.isovalues;
            self.triangles = replay
                .par_live_tets()
                .filter_map(|(t, c)| {
                    let tris = march_all(pm, c, isovalues);
                    (!tris.is_empty()).then_some((t, tris))
                })
                .collect();
            return steps;
        }
        let mut changed = Vec::new();
        let touched = &mut self.touched;
        let steps = replay.set_level_with(pm, level, &mut |_, s| {
            for &t in s.removed.iter().chain(&s.moved) {
                if !std::mem::replace(&mut touched[t as usize], true) {
                    changed.push(t);
                }
            }
        });
        for t in changed {
            self.touched[t as usize] = false;
            if replay.is_live(t) {
                self.tree.insert(t, replay.corners(t));
            } else {
                self.tree.remove(t);
            }
            self.remarch(pm, replay, t);
        }
        steps
    }

    /// Every triangle of the current surfaces, sorted (compare with [`march_level`]).
    pub fn edge_triangles(&self) -> Vec<EdgeTriangle> {
        let mut all: Vec<EdgeTriangle> = self.triangles.values().flatten().copied().collect();
        all.sort_unstable();
        all
    }

    /// The current surfaces as a triangle mesh: one point per crossed edge and isovalue,
    /// interpolated linearly (Eq. 7).
    pub fn surface(&self, pm: &ProgressiveMesh) -> SurfaceMesh {
        let tris = self.edge_triangles();
        let mut ids: FxHashMap<EdgePoint, u32> = FxHashMap::default();
        let mut mesh = SurfaceMesh::default();
        for t in &tris {
            let c = t.map(|p| {
                *ids.entry(p).or_insert_with(|| {
                    let v = self.isovalues[p.iso as usize];
                    let (fa, fb) = (pm.scalars[p.below as usize], pm.scalars[p.above as usize]);
                    let s = (v - fa) / (fb - fa);
                    let (a, b) = (pm.points[p.below as usize], pm.points[p.above as usize]);
                    mesh.points
                        .push(std::array::from_fn(|k| a[k] + s * (b[k] - a[k])));
                    mesh.values.push(v);
                    (mesh.points.len() - 1) as u32
                })
            });
            mesh.triangles.push(c);
        }
        mesh
    }
}
