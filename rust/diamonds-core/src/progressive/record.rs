//! The progressive mesh (§3, §3.1): the original tetrahedra, the sequence of half-edge collapses
//! `hec(p_i → p_j)` that led to the base mesh `M^0`, and the field error of every level. Level `L`
//! (`0 ≤ L ≤ n`) is `M^L`: the base mesh after `L` vertex splits, the original after `n`. A [`Replay`]
//! moves between levels by applying collapses (down) or vertex splits (up), each touching only the
//! tetrahedra it names: nothing is recomputed.

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
#[derive(Clone, Debug, PartialEq)]
pub struct Replay {
    tets: Vec<[u32; 4]>,
    alive: Vec<bool>,
    /// The field error of each tetrahedron at the current level (as it was last when not in it).
    errors: Vec<f64>,
    level: usize,
    /// The number of levels of the progressive mesh when the cursor last moved ([`Replay::rebase`]).
    levels: usize,
    live: usize,
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

    /// Moves to `level` (clamped to `pm.levels()`) by collapses or splits; returns how many were
    /// replayed.
    pub fn set_level(&mut self, pm: &ProgressiveMesh, level: usize) -> usize {
        self.set_level_with(pm, level, &mut |_, _| {})
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
        self.errors
            .iter()
            .zip(&self.alive)
            .filter(|(_, &a)| a)
            .map(|(&e, _)| e)
            .collect()
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

    /// The current level as a compact mesh.
    pub fn mesh(&self, points: usize) -> LevelMesh {
        let mut index = vec![u32::MAX; points];
        let mut point_ids = Vec::new();
        for (_, t) in self.live_tets() {
            for v in t {
                if index[v as usize] == u32::MAX {
                    index[v as usize] = 0;
                    point_ids.push(v);
                }
            }
        }
        point_ids.sort_unstable();
        for (k, &v) in point_ids.iter().enumerate() {
            index[v as usize] = k as u32;
        }
        let tets = self
            .live_tets()
            .map(|(_, t)| t.map(|v| index[v as usize]))
            .collect();
        LevelMesh { point_ids, tets }
    }
}
