//! The progressive mesh (§3, §3.1): the original tetrahedra, the sequence of half-edge collapses
//! `hec(p_i → p_j)` that led to the base mesh `M^0`, and the field error of every level. Level `L`
//! (`0 ≤ L ≤ n`) is `M^L`: the base mesh after `L` vertex splits, the original after `n`. A [`Replay`]
//! moves between levels by applying collapses (down) or vertex splits (up), each touching only the
//! tetrahedra it names: nothing is recomputed.

use crate::mesh::{check_len, pieces};
use crate::Result;
use rayon::prelude::*;

/// One half-edge collapse `hec(p_i → p_j)` and its inverse vertex split (§3.1): the tetrahedra around
/// the edge are removed (`removed`, the split's T_new) and the others around `p_i` have `p_i`
/// replaced by `p_j` (`moved`, the split's T_moved). Tetrahedra are named by their index among the
/// original ones; a removed tetrahedron keeps its corners while it is away.
#[derive(Clone, Debug, PartialEq)]
pub struct VertexSplit {
    /// `p_i`, the vertex the collapse removes and the split brings back (original point index).
    pub vertex: u32,
    /// `p_j`, the vertex `p_i` collapses onto.
    pub target: u32,
    /// The tetrahedra around the edge `p_i p_j` (T_new of the split).
    pub removed: Vec<u32>,
    /// The other tetrahedra around `p_i` (T_moved of the split: around `p_j` between the levels).
    pub moved: Vec<u32>,
    /// The field error of each tetrahedron of `removed` then `moved` before the collapse (the
    /// largest error of the removed vertices inside it), and of each of `moved` after it: a replay
    /// keeps every tetrahedron's `FieldError` without locating a vertex.
    pub errors_before: Vec<f64>,
    pub errors_after: Vec<f64>,
    /// Tetrahedra outside `removed` and `moved` whose field error the collapse changed (removed
    /// vertices outside the mesh that a new boundary face came nearer to), as `(tetrahedron, before,
    /// after)`.
    pub other_errors: Vec<(u32, f64, f64)>,
}

/// The field error of a level at the original vertices it does not have, and the boundary distance of
/// the removed boundary vertices.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LevelError {
    /// Tetrahedra of the level.
    pub tets: usize,
    /// Largest `|f(v) - L(x)|` over the removed original vertices `v` (`L` the level's linear
    /// interpolant, `x = v` inside the level's mesh, else the nearest point of the mesh to `v`).
    pub max_field_error: f64,
    /// Root mean square of the same errors (0 with no removed vertex).
    pub rms_field_error: f64,
    /// Largest distance of a removed boundary vertex from the level's boundary surface (measured only
    /// when the boundary is preserved, else 0).
    pub max_boundary_distance: f64,
}

/// A tetrahedral mesh as a base mesh and vertex splits (§3): everything needed to replay any level.
#[derive(Clone, Debug, PartialEq)]
pub struct ProgressiveMesh {
    pub(super) points: Vec<[f64; 3]>,
    pub(super) tets: Vec<[u32; 4]>,
    /// In the order they were made: collapse `k` goes from level `n - k` to `n - k - 1`.
    pub(super) collapses: Vec<VertexSplit>,
    /// Indexed by level (`n + 1` entries, the last is the original: no error unless points were
    /// merged).
    pub(super) errors: Vec<LevelError>,
    /// The field the errors are measured on, one value per point.
    pub(super) scalars: Vec<f64>,
    /// Coincident input points merged into one (they count as removed vertices at every level).
    pub(super) merged_points: Vec<u32>,
    /// Input tetrahedra dropped because merging made them flat.
    pub(super) dropped_tets: usize,
    /// The field error of each original tetrahedron at the original level (non-zero only around
    /// merged points).
    pub(super) original_tet_errors: Vec<f64>,
}

/// One level as a compact mesh: the original indices of its points (ascending) and its tetrahedra
/// as indices into them (positively oriented, in the order of the original tetrahedra).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LevelMesh {
    pub point_ids: Vec<u32>,
    pub tets: Vec<[u32; 4]>,
}

impl ProgressiveMesh {
    /// The number of vertex splits `n`: levels go from 0 (base mesh) to `n` (the original).
    pub fn levels(&self) -> usize {
        self.collapses.len()
    }

    /// The vertex split from level `level` to `level + 1`.
    pub fn split(&self, level: usize) -> &VertexSplit {
        &self.collapses[self.collapses.len() - 1 - level]
    }

    /// The errors of `level` (`0 ..= levels()`).
    pub fn error(&self, level: usize) -> LevelError {
        self.errors[level]
    }

    /// The original points (every level's points are some of them).
    pub fn points(&self) -> &[[f64; 3]] {
        &self.points
    }

    /// Writes the coordinates of the original points `ids` into `out` (3 per point), in parallel.
    pub fn fill_points(&self, ids: &[u32], out: &mut [f64]) {
        let (xyz, rest) = out.as_chunks_mut::<3>();
        assert!(rest.is_empty() && xyz.len() == ids.len());
        xyz.par_iter_mut()
            .zip(ids)
            .for_each(|(x, &v)| *x = self.points[v as usize]);
    }

    /// Copies the tuple of each original point `ids[k]` from `source` (`tuple_bytes` bytes per
    /// original point) into slot `k` of `target`, in parallel: a point array passed through.
    pub fn gather_point_values(
        &self,
        ids: &[u32],
        source: &[u8],
        tuple_bytes: usize,
        target: &mut [u8],
    ) -> Result<()> {
        check_len(
            source.len(),
            self.points.len(),
            tuple_bytes,
            "a point array's source",
        )?;
        check_len(
            target.len(),
            ids.len(),
            tuple_bytes,
            "a point array's target",
        )?;
        if tuple_bytes > 0 {
            target
                .par_chunks_mut(tuple_bytes)
                .zip(ids)
                .for_each(|(slot, &v)| {
                    let at = v as usize * tuple_bytes;
                    slot.copy_from_slice(&source[at..at + tuple_bytes]);
                });
        }
        Ok(())
    }

    /// The original tetrahedra (after cleaning: the input's without those merging flattened).
    pub fn original_tets(&self) -> &[[u32; 4]] {
        &self.tets
    }

    /// How many coincident input points were merged, and how many tetrahedra that dropped.
    pub fn cleaning(&self) -> (usize, usize) {
        (self.merged_points.len(), self.dropped_tets)
    }

    /// The points whose error a level reports when it does not have them: those of the original
    /// tetrahedra and the merged ones, ascending.
    pub fn removable(&self) -> Vec<u32> {
        let mut used = vec![false; self.points.len()];
        for &v in self.tets.iter().flatten().chain(&self.merged_points) {
            used[v as usize] = true;
        }
        (0..self.points.len() as u32)
            .filter(|&v| used[v as usize])
            .collect()
    }

    /// The finest level with at most `tets` tetrahedra (level 0, the base mesh, if even it has more;
    /// tetrahedron counts grow with the level).
    pub fn level_for_tets(&self, tets: usize) -> usize {
        self.errors
            .partition_point(|e| e.tets <= tets)
            .saturating_sub(1)
    }

    /// The coarsest level from which every finer level has a maximum field error of at most
    /// `max_error`.
    pub fn level_for_error(&self, max_error: f64) -> usize {
        self.errors
            .iter()
            .rposition(|e| e.max_field_error > max_error)
            .map_or(0, |l| l + 1)
    }
}

/// A cursor on a [`ProgressiveMesh`]: the current level's tetrahedra, moved up by vertex splits and
/// down by half-edge collapses (§4.3: only the tetrahedra of each split change).
#[derive(Clone, Debug)]
pub struct Replay {
    tets: Vec<[u32; 4]>,
    alive: Vec<bool>,
    /// The field error of each tetrahedron at the current level (as it was last when not in it).
    errors: Vec<f64>,
    level: usize,
    /// The number of levels of the progressive mesh when the cursor last moved ([`Replay::rebase`]).
    levels: usize,
    live: usize,
    /// Built by [`Replay::index_jumps`] or the first [`Replay::set_level`] that jumps, again when
    /// the reduction went on.
    jumps: Option<JumpIndex>,
}

/// What a jump to a distant level needs to set every tetrahedron directly instead of replaying each
/// collapse or split on the way (a replay touches its tetrahedra at random, about half a microsecond
/// a step on a 1 M-tetrahedron mesh; a jump reads every tetrahedron once, in parallel). Collapses are
/// named by their index `k` in the order they were made (level `L` is the original after collapses
/// `0 .. n - L`), so the names stay when the reduction goes on.
#[derive(Clone, Debug)]
struct JumpIndex {
    /// The number of collapses indexed.
    collapses: usize,
    /// The collapse that removes each original tetrahedron (`u32::MAX`: in the base mesh).
    tet_removed_by: Vec<u32>,
    /// The collapse that removes each point (`u32::MAX`: never removed).
    vertex_removed_by: Vec<u32>,
    /// Each collapse's vertex and target (`p_i`, `p_j`), compact: jumps follow them at random.
    pairs: Vec<[u32; 2]>,
    /// Each tetrahedron's field errors after the collapses that changed them (moved, or another
    /// error), as `history_start[t] .. history_start[t + 1]` into `history_collapse` (ascending) and
    /// `history_error`.
    history_start: Vec<u32>,
    history_collapse: Vec<u32>,
    history_error: Vec<f64>,
}

impl JumpIndex {
    fn new(pm: &ProgressiveMesh) -> Self {
        let n = pm.collapses.len();
        let mut tet_removed_by = vec![u32::MAX; pm.tets.len()];
        let mut vertex_removed_by = vec![u32::MAX; pm.points.len()];
        let mut history_start = vec![0u32; pm.tets.len() + 1];
        let pairs = pm.collapses.iter().map(|c| [c.vertex, c.target]).collect();
        for (k, c) in pm.collapses.iter().enumerate() {
            vertex_removed_by[c.vertex as usize] = k as u32;
            for &t in &c.removed {
                tet_removed_by[t as usize] = k as u32;
            }
            for t in c
                .moved
                .iter()
                .chain(c.other_errors.iter().map(|(t, _, _)| t))
            {
                history_start[*t as usize + 1] += 1;
            }
        }
        for t in 0..pm.tets.len() {
            history_start[t + 1] += history_start[t];
        }
        let entries = history_start[pm.tets.len()] as usize;
        let mut next = history_start.clone();
        let (mut history_collapse, mut history_error) = (vec![0u32; entries], vec![0.0; entries]);
        for (k, c) in pm.collapses.iter().enumerate() {
            let after = c.moved.iter().zip(&c.errors_after).map(|(&t, &e)| (t, e));
            for (t, e) in after.chain(c.other_errors.iter().map(|&(t, _, e)| (t, e))) {
                let slot = &mut next[t as usize];
                history_collapse[*slot as usize] = k as u32;
                history_error[*slot as usize] = e;
                *slot += 1;
            }
        }
        Self {
            collapses: n,
            tet_removed_by,
            vertex_removed_by,
            pairs,
            history_start,
            history_collapse,
            history_error,
        }
    }

    /// Tetrahedron `t`'s field error once collapses `0 .. applied` are made: the error after the
    /// last of them that changed it, else its original one.
    fn error(&self, pm: &ProgressiveMesh, t: usize, applied: u32) -> f64 {
        let range = self.history_start[t] as usize..self.history_start[t + 1] as usize;
        let before = self.history_collapse[range.clone()].partition_point(|&k| k < applied);
        if before == 0 {
            pm.original_tet_errors[t]
        } else {
            self.history_error[range.start + before - 1]
        }
    }
}

/// Replaces corner `from` of `t` by `to`.
fn substitute(t: &mut [u32; 4], from: u32, to: u32) {
    if let Some(c) = t.iter_mut().find(|c| **c == from) {
        *c = to;
    }
}

impl Replay {
    /// A cursor at the original mesh (level `pm.levels()`).
    pub fn new(pm: &ProgressiveMesh) -> Self {
        Self {
            tets: pm.tets.clone(),
            alive: vec![true; pm.tets.len()],
            errors: pm.original_tet_errors.clone(),
            level: pm.levels(),
            levels: pm.levels(),
            live: pm.tets.len(),
            jumps: None,
        }
    }

    /// Follows a progressive mesh whose reduction went on ([`Reduction`](super::Reduction)) since
    /// the cursor last moved: the new collapses went below the base mesh, so the current mesh is
    /// now as many levels higher. [`Replay::set_level_with`] does it first.
    pub fn rebase(&mut self, pm: &ProgressiveMesh) {
        self.level += pm.levels() - self.levels;
        self.levels = pm.levels();
    }

    /// The current level.
    pub fn level(&self) -> usize {
        self.level
    }

    /// The number of tetrahedra of the current level.
    pub fn tets(&self) -> usize {
        self.live
    }

    /// Moves to `level` (clamped to `pm.levels()`) by collapses or splits, or by a jump that sets
    /// every tetrahedron directly when the collapses or splits on the way name more than a quarter
    /// of the tetrahedra (a replayed step touches its tetrahedra at random, a jump reads them all in
    /// order: the ratio is the machine's, not the mesh's); returns how many collapses or splits
    /// lie between the levels. The result is the same either way (tested).
    pub fn set_level(&mut self, pm: &ProgressiveMesh, level: usize) -> usize {
        if !self.jumps_to(pm, level) {
            return self.replay(pm, level, &mut |_, _| {});
        }
        self.index_jumps(pm);
        self.jump(pm, level)
    }

    /// Whether [`Replay::set_level`] to `level` jumps rather than replays (rebases the cursor).
    pub fn jumps_to(&mut self, pm: &ProgressiveMesh, level: usize) -> bool {
        self.rebase(pm);
        let level = level.min(pm.levels());
        let n = pm.levels();
        let named: usize = pm.collapses[n - self.level.max(level)..n - self.level.min(level)]
            .iter()
            .map(|c| c.removed.len() + c.moved.len() + c.other_errors.len())
            .sum();
        4 * named > pm.tets.len()
    }

    /// Builds the index of the jumps for `pm`'s collapses unless it is built (the first long
    /// [`Replay::set_level`] builds it otherwise): a caller with time to spare after a reduction,
    /// as the filter's first execution, keeps its cost off the first level change.
    pub fn index_jumps(&mut self, pm: &ProgressiveMesh) {
        if self
            .jumps
            .as_ref()
            .is_none_or(|j| j.collapses != pm.levels())
        {
            self.jumps = Some(JumpIndex::new(pm));
        }
    }

    /// Sets every tetrahedron for `level` at once (see [`JumpIndex`]): a tetrahedron is in the level
    /// if no collapse `0 .. n - level` removed it, its corners are the original ones each followed
    /// along those collapses to the vertex it became, its error is its [`JumpIndex::error`]. A
    /// tetrahedron that leaves the mesh keeps the corners it had when its collapse removed it, as a
    /// replay leaves them (a later split brings it back with them).
    fn jump(&mut self, pm: &ProgressiveMesh, level: usize) -> usize {
        let jumps = self.jumps.as_ref().expect("a jump index");
        let n = pm.levels();
        let applied = (n - level) as u32;
        // What each point is at `level`: itself, or what its collapse's target is (targets are
        // removed, if ever, by later collapses, so descending order sees them first).
        let mut vertex_at: Vec<u32> = (0..pm.points.len() as u32).collect();
        for &[vertex, target] in jumps.pairs[..applied as usize].iter().rev() {
            vertex_at[vertex as usize] = vertex_at[target as usize];
        }
        let follow = |mut v: u32, until: u32| {
            while jumps.vertex_removed_by[v as usize] < until {
                v = jumps.pairs[jumps.vertex_removed_by[v as usize] as usize][1];
            }
            v
        };
        self.live = self
            .tets
            .par_iter_mut()
            .zip(self.alive.par_iter_mut())
            .zip(self.errors.par_iter_mut())
            .enumerate()
            .map(|(t, ((corners, alive), error))| {
                let removed_by = jumps.tet_removed_by[t];
                let now = removed_by >= applied;
                if now {
                    *corners = pm.tets[t].map(|v| vertex_at[v as usize]);
                    *error = jumps.error(pm, t, applied);
                } else if *alive {
                    // Its current corners followed as far as the collapse that removes it.
                    *corners = corners.map(|v| follow(v, removed_by));
                }
                *alive = now;
                usize::from(now)
            })
            .sum();
        let steps = self.level.abs_diff(level);
        self.level = level;
        steps
    }

    /// [`Replay::set_level`], calling `on_step` after each collapse or split with the cursor and
    /// the split (whose `removed` and `moved` tetrahedra are the only ones that changed).
    pub fn set_level_with(
        &mut self,
        pm: &ProgressiveMesh,
        level: usize,
        on_step: &mut dyn FnMut(&Replay, &VertexSplit),
    ) -> usize {
        self.rebase(pm);
        self.replay(pm, level, on_step)
    }

    /// [`Replay::set_level_with`] on a rebased cursor: every collapse or split on the way.
    fn replay(
        &mut self,
        pm: &ProgressiveMesh,
        level: usize,
        on_step: &mut dyn FnMut(&Replay, &VertexSplit),
    ) -> usize {
        let level = level.min(pm.levels());
        let steps = self.level.abs_diff(level);
        while self.level > level {
            let s = pm.split(self.level - 1);
            for &t in &s.removed {
                self.alive[t as usize] = false;
            }
            for (&t, &e) in s.moved.iter().zip(&s.errors_after) {
                substitute(&mut self.tets[t as usize], s.vertex, s.target);
                self.errors[t as usize] = e;
            }
            for &(t, _, after) in &s.other_errors {
                self.errors[t as usize] = after;
            }
            self.live -= s.removed.len();
            self.level -= 1;
            on_step(self, s);
        }
        while self.level < level {
            let s = pm.split(self.level);
            for &t in &s.removed {
                self.alive[t as usize] = true;
            }
            for &t in &s.moved {
                substitute(&mut self.tets[t as usize], s.target, s.vertex);
            }
            for (&t, &e) in s.removed.iter().chain(&s.moved).zip(&s.errors_before) {
                self.errors[t as usize] = e;
            }
            for &(t, before, _) in &s.other_errors {
                self.errors[t as usize] = before;
            }
            self.live += s.removed.len();
            self.level += 1;
            on_step(self, s);
        }
        steps
    }

    /// Is the original tetrahedron `t` in the current level?
    pub fn is_live(&self, t: u32) -> bool {
        self.alive[t as usize]
    }

    /// For each tetrahedron of the current level (in [`Replay::live_tets`] order), the largest
    /// `|f(v) - L(x)|` over the removed original vertices `v` inside it (0 if none; a vertex outside
    /// the mesh, where the boundary moved, is measured at its nearest point `x` of the mesh and counts
    /// for the tetrahedron of that boundary face), as the reduction placed them.
    pub fn field_errors(&self) -> Vec<f64> {
        let mut errors = vec![0.0; self.live];
        self.fill_field_errors(&mut errors);
        errors
    }

    /// The corners of the original tetrahedron `t` at the current level (as it was last when it is
    /// not in the level).
    pub fn corners(&self, t: u32) -> [u32; 4] {
        self.tets[t as usize]
    }

    /// The current level's tetrahedra with their original index, in that order (original point
    /// indices).
    pub fn live_tets(&self) -> impl Iterator<Item = (u32, [u32; 4])> + '_ {
        self.tets
            .iter()
            .zip(&self.alive)
            .enumerate()
            .filter(|(_, (_, &a))| a)
            .map(|(k, (&t, _))| (k as u32, t))
    }

    /// [`Replay::live_tets`] in parallel, in no set order.
    pub fn par_live_tets(&self) -> impl ParallelIterator<Item = (u32, [u32; 4])> + '_ {
        self.tets
            .par_iter()
            .zip(&self.alive)
            .enumerate()
            .filter(|(_, (_, &a))| a)
            .map(|(k, (&t, _))| (k as u32, t))
    }

    /// The current level as a compact mesh.
    pub fn mesh(&self, points: usize) -> LevelMesh {
        let (point_ids, index) = self.level_points(points);
        let mut tets = vec![[0; 4]; self.live];
        self.fill_tets(&index, tets.as_flattened_mut());
        LevelMesh { point_ids, tets }
    }

    /// The points of the current level: their original indices, ascending, and the index among
    /// them of each of the `points` original points (`u32::MAX` where not in the level).
    pub fn level_points(&self, points: usize) -> (Vec<u32>, Vec<u32>) {
        let mut index = vec![u32::MAX; points];
        for (_, t) in self.live_tets() {
            for v in t {
                index[v as usize] = 0;
            }
        }
        // Ascending by construction: numbered in a scan of the marks.
        let mut point_ids = Vec::new();
        for (v, slot) in index.iter_mut().enumerate() {
            if *slot == 0 {
                *slot = point_ids.len() as u32;
                point_ids.push(v as u32);
            }
        }
        (point_ids, index)
    }

    /// Writes the corners of the current level's tetrahedra, as indices into its points (`index`
    /// from [`Replay::level_points`]), into `out` (4 × [`Replay::tets`] long): [`Replay::mesh`]
    /// into a caller's array.
    pub fn fill_tets(&self, index: &[u32], out: &mut [u32]) {
        self.fill_live(out, |t, c: &mut [u32; 4]| {
            *c = self.tets[t].map(|v| index[v as usize])
        });
    }

    /// Writes the current level's [`Replay::field_errors`] into `out` ([`Replay::tets`] long).
    pub fn fill_field_errors(&self, out: &mut [f64]) {
        self.fill_live(out, |t, e: &mut [f64; 1]| e[0] = self.errors[t]);
    }

    /// Writes `K` values per tetrahedron of the current level into `out` (`K` × [`Replay::tets`]
    /// long, in [`Replay::live_tets`] order), `write(t, slots)` for the original tetrahedron `t`:
    /// in parallel over blocks of tetrahedra, each block at the number of live ones before it.
    fn fill_live<T: Send, const K: usize>(
        &self,
        out: &mut [T],
        write: impl Fn(usize, &mut [T; K]) + Sync,
    ) {
        const BLOCK: usize = 1 << 14;
        let (slots, rest) = out.as_chunks_mut::<K>();
        assert!(
            rest.is_empty() && slots.len() == self.live,
            "{} values for {} tetrahedra of {K} values each",
            out.len(),
            self.live
        );
        let counts: Vec<usize> = self
            .alive
            .par_chunks(BLOCK)
            .map(|b| b.iter().filter(|&&a| a).count())
            .collect();
        pieces(slots, &counts, 1)
            .into_par_iter()
            .zip(self.alive.par_chunks(BLOCK))
            .enumerate()
            .for_each(|(b, (block, alive))| {
                let mut slots = block.iter_mut();
                for (k, _) in alive.iter().enumerate().filter(|(_, &a)| a) {
                    write(b * BLOCK + k, slots.next().expect("counted"));
                }
            });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progressive::tests::{bent, grid};
    use crate::progressive::{simplify, Params};

    /// Everything a later move or a reader depends on: the level's mesh and errors, and every
    /// tetrahedron's corners (those away from the level too: a split brings them back as they are).
    fn state(r: &Replay, points: usize) -> (LevelMesh, Vec<f64>, Vec<[u32; 4]>, usize) {
        (r.mesh(points), r.field_errors(), r.tets.clone(), r.tets())
    }

    /// Jumps leave the cursor exactly where collapses and splits one by one leave it, for any
    /// sequence of levels mixing long moves (jumps) and short ones (replays after a jump), on a
    /// mesh whose collapses change errors outside their own tetrahedra too.
    #[test]
    fn a_jump_lands_where_the_replay_lands() {
        let cube = grid(5, |p| (3.0 * p.x).sin() + p.y * p.z);
        let curved = bent(6, |p| (4.0 * p.x + 3.0 * p.y).cos() + p.z);
        let mut jumped = 0;
        for (g, preserve_boundary) in [(cube, true), (curved, false)] {
            let params = Params {
                preserve_boundary,
                boundary_tolerance: 1e-9,
                ..Params::default()
            };
            let pm = simplify(g.input(), &params, &mut |_| true).unwrap();
            let n = pm.levels();
            let others: usize = pm.collapses.iter().map(|c| c.other_errors.len()).sum();
            if !preserve_boundary {
                assert!(
                    others > 0,
                    "no collapse changed another tetrahedron's error"
                );
            }
            let (mut fast, mut slow) = (Replay::new(&pm), Replay::new(&pm));
            let mut seed = 12345u64;
            for _ in 0..60 {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                // Mostly long moves, some of a few levels.
                let level = if seed >> 62 == 0 {
                    (fast.level() + (seed >> 33) as usize % 5).min(n)
                } else {
                    (seed >> 33) as usize % (n + 1)
                };
                let had = fast.jumps.is_some();
                let before = fast.level();
                assert_eq!(fast.set_level(&pm, level), before.abs_diff(level));
                slow.set_level_with(&pm, level, &mut |_, _| {});
                jumped += usize::from(had || fast.jumps.is_some());
                assert_eq!(
                    state(&fast, g.points.len()),
                    state(&slow, g.points.len()),
                    "level {before} -> {level} of {n}"
                );
            }
        }
        assert!(
            jumped > 20,
            "only {jumped} moves could jump: the test tests little"
        );
    }
}
