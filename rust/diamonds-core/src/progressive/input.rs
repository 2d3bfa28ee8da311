//! The input of a progressive mesh: points, tetrahedra and one scalar field, checked and cleaned
//! before anything is built on them (bad input is an error naming what is wrong, never a panic).
//! Cleaning is what `vtkCleanUnstructuredGrid` does for exactly coincident points: they are merged
//! into the first of them, and the tetrahedra that become flat (repeated corners) are dropped —
//! tetrahedralised curvilinear grids with a singular axis, such as the blunt fin, have them.

use crate::validate::{boundary_faces, check_manifold_tets};
use crate::{Error, Result};
use rustc_hash::{FxHashMap, FxHashSet};

/// A tetrahedral mesh with the scalar field that drives the field error.
#[derive(Clone, Copy, Debug)]
pub struct TetInput<'a> {
    /// World coordinates of every point.
    pub points: &'a [[f64; 3]],
    /// Tetrahedra as indices into `points`, positively oriented (VTK_TETRA order).
    pub tets: &'a [[u32; 4]],
    /// One value per point.
    pub scalars: &'a [f64],
}

/// The input after cleaning: the tetrahedra on the kept points, and the merged points.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct Cleaned {
    pub(super) tets: Vec<[u32; 4]>,
    /// `(merged point, the point kept at its position)`.
    pub(super) merged: Vec<(u32, u32)>,
    /// Tetrahedra dropped because merging made them flat.
    pub(super) dropped: usize,
}

impl TetInput<'_> {
    /// The corners of the mesh's boundary faces (faces of one tetrahedron), ascending.
    pub fn boundary_points(&self) -> Vec<u32> {
        let mut points: Vec<u32> = boundary_faces(self.tets).into_iter().flatten().collect();
        points.sort_unstable();
        points.dedup();
        points
    }

    /// The boundary points at the position of one of `others` (equal coordinates, bit for bit
    /// up to the sign of 0). For a piece of a distributed mesh with `others` the boundary points
    /// of the other pieces, these are where the piece meets another: every point two pieces share
    /// is on both pieces' boundaries. A reduction that keeps them ([`super::Reduction::keeping`])
    /// changes no face between pieces, so the pieces' meshes stay conforming together.
    pub fn seam_points(&self, others: &[[f64; 3]]) -> Vec<u32> {
        // `+ 0.0` makes -0 into +0.
        let key = |p: &[f64; 3]| p.map(|c| (c + 0.0).to_bits());
        let others: FxHashSet<[u64; 3]> = others.iter().map(key).collect();
        self.boundary_points()
            .into_iter()
            .filter(|&v| {
                self.points
                    .get(v as usize)
                    .is_some_and(|p| others.contains(&key(p)))
            })
            .collect()
    }

    /// Checks and cleans the input: at least one tetrahedron, fewer than 2^32 points, one finite
    /// value and finite coordinates per point, corners inside the points; coincident points merged
    /// and the tetrahedra that repeat a corner then (flat ones) dropped; then a manifold
    /// tetrahedralisation with positive volumes ([`check_manifold_tets`]). Tetrahedra that repeat a
    /// corner in the input are flat too: ParaView's redistribution merges the coincident points of
    /// the blunt fin's pieces and leaves such tetrahedra.
    pub(super) fn clean(&self) -> Result<Cleaned> {
        let n = self.points.len();
        if self.tets.is_empty() {
            return Err(Error::Mesh("the mesh has no tetrahedra".into()));
        }
        if u32::try_from(n).is_err() {
            return Err(Error::Mesh(format!(
                "{n} points: at most 2^32 - 1 are supported"
            )));
        }
        if self.scalars.len() != n {
            return Err(Error::Mesh(format!(
                "the scalar array has {} values but the mesh has {n} points",
                self.scalars.len()
            )));
        }
        if let Some((k, v)) = self
            .scalars
            .iter()
            .enumerate()
            .find(|(_, v)| !v.is_finite())
        {
            return Err(Error::Mesh(format!(
                "the scalar array holds a non-finite value ({v}) at point {k}; replace NaN/Inf first"
            )));
        }
        if let Some((k, p)) = self
            .points
            .iter()
            .enumerate()
            .find(|(_, p)| p.iter().any(|c| !c.is_finite()))
        {
            return Err(Error::Mesh(format!(
                "point {k} has non-finite coordinates {p:?}"
            )));
        }
        if let Some((c, t)) = self
            .tets
            .iter()
            .enumerate()
            .find(|(_, t)| t.iter().any(|&v| v as usize >= n))
        {
            return Err(Error::Mesh(format!(
                "tetrahedron {c} {t:?} refers past the {n} points"
            )));
        }
        let mut first: FxHashMap<[u64; 3], u32> = FxHashMap::default();
        let mut keep: Vec<u32> = (0..n as u32).collect();
        let mut merged = Vec::new();
        let mut used = vec![false; n];
        for t in self.tets {
            for &v in t {
                used[v as usize] = true;
            }
        }
        for v in (0..n).filter(|&v| used[v]) {
            let key = self.points[v].map(|c| (c + 0.0).to_bits());
            let k = *first.entry(key).or_insert(v as u32);
            if k != v as u32 {
                keep[v] = k;
                merged.push((v as u32, k));
            }
        }
        let before = self.tets.len();
        let tets: Vec<[u32; 4]> = self
            .tets
            .iter()
            .map(|t| t.map(|v| keep[v as usize]))
            .filter(|t| (0..4).all(|a| (a + 1..4).all(|b| t[a] != t[b])))
            .collect();
        if tets.is_empty() {
            return Err(Error::Mesh(
                "every tetrahedron is flat (coincident corners)".into(),
            ));
        }
        check_manifold_tets(self.points, &tets).map_err(Error::Mesh)?;
        Ok(Cleaned {
            dropped: before - tets.len(),
            tets,
            merged,
        })
    }
}
