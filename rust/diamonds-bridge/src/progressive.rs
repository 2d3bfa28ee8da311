//! The progressive-mesh half of the bridge (Labsik et al.): the Rust side of
//! `vtkProgressiveTetrahedralMesh`. In: points, tetrahedra and the scalars as slices and the
//! [`ProgressiveSpec`]; out: an opaque [`Progressive`] the filter keeps between executions, whose
//! reduction goes as far as the coarsest level asked so far ([`Progressive::reduce_for`], continued
//! when a coarser one is asked), moved from level to level by replaying vertex splits or
//! collapses, whose current level C++ reads (point ids as a slice; coordinates, tetrahedra and
//! per-tetrahedron field errors written into its own arrays). Every fallible function runs inside
//! [`guard`]; the getters return what `set_level` checked.

use std::pin::Pin;

use diamonds::progressive::isosurface::ProgressiveIsosurface;
use diamonds::progressive::{Params, Reduction, Replay, TetInput};

use crate::ffi::{self, ProgressiveSpec};
use crate::guard;

/// A reduction under way (its progressive mesh), the cursor, the progressive isosurface if any, and
/// the current level's arrays.
pub struct Progressive {
    reduction: Reduction,
    replay: Replay,
    iso: Option<ProgressiveIsosurface>,
    point_ids: Vec<u32>,
    /// Per original point, its index in `point_ids` (`u32::MAX`: not in the level).
    index: Vec<u32>,
    iso_points: Vec<f64>,
    iso_values: Vec<f64>,
    iso_triangles: Vec<u32>,
}

/// Prepares the reduction of the input, no collapse made yet (see [`ffi::build_progressive`]).
pub fn build_progressive(
    points: &[f64],
    tets: &[i64],
    scalars: &[f64],
    spec: &ProgressiveSpec,
    boundary: &[u32],
    seam_with: &[f64],
) -> Result<Box<Progressive>, String> {
    guard("building the progressive mesh", || {
        build_with(points, tets, scalars, spec, boundary, seam_with).map(Box::new)
    })
}

/// What a piece of a distributed mesh sends the other pieces (see
/// [`ffi::progressive_seam_messages`]).
pub fn progressive_seam_messages(
    points: &[f64],
    tets: &[i64],
    boxes: &[f64],
    rank: usize,
) -> Result<ffi::SeamMessages, String> {
    guard("finding the boundary of the tetrahedra", || {
        let (xyz, corners) = mesh_of(points, tets)?;
        let (boxes, []) = boxes.as_chunks::<6>() else {
            return Err(format!(
                "{} values of bounds: not six per rank",
                boxes.len()
            ));
        };
        let input = TetInput {
            points: xyz,
            tets: &corners,
            scalars: &[],
        };
        let boundary = input.boundary_points();
        let (counts, coordinates) = input.seam_messages(&boundary, boxes, rank);
        Ok(ffi::SeamMessages {
            boundary,
            counts: counts.into_iter().map(|points| 3 * points).collect(),
            coordinates: coordinates.into_iter().flatten().collect(),
        })
    })
}

/// Points (borrowed from C++) and tetrahedra as the core takes them.
type Tetrahedra<'a> = (&'a [[f64; 3]], Vec<[u32; 4]>);

/// The points (3 coordinates each) and tetrahedra (4 point indices each, inside the points) of
/// C++'s flat arrays.
fn mesh_of<'a>(points: &'a [f64], tets: &[i64]) -> Result<Tetrahedra<'a>, String> {
    let ((xyz, []), (quads, [])) = (points.as_chunks::<3>(), tets.as_chunks::<4>()) else {
        return Err(format!(
            "{} coordinates and {} tetrahedron corners: not whole points and tetrahedra",
            points.len(),
            tets.len()
        ));
    };
    let n = xyz.len();
    let corners: Vec<[u32; 4]> = quads
        .iter()
        .map(|t| {
            let mut c = [0u32; 4];
            for (k, &v) in t.iter().enumerate() {
                c[k] = u32::try_from(v)
                    .ok()
                    .filter(|&v| (v as usize) < n)
                    .ok_or_else(|| format!("a tetrahedron refers to point {v} of {n}"))?;
            }
            Ok(c)
        })
        .collect::<Result<_, String>>()?;
    Ok((xyz, corners))
}

/// [`build_progressive`] without the guard.
pub fn build_with(
    points: &[f64],
    tets: &[i64],
    scalars: &[f64],
    spec: &ProgressiveSpec,
    boundary: &[u32],
    seam_with: &[f64],
) -> Result<Progressive, String> {
    let (xyz, corners) = mesh_of(points, tets)?;
    let (others, []) = seam_with.as_chunks::<3>() else {
        return Err(format!(
            "{} coordinates of other pieces' boundary points: not whole points",
            seam_with.len()
        ));
    };
    let diagonal = diamonds::volume::bounds_diagonal(&spec.whole_bounds);
    let params = Params {
        target_tets: 0,
        max_field_error: 0.0,
        geometry_weight: spec.geometry_weight,
        field_weight: spec.field_weight,
        shape_weight: spec.shape_weight,
        preserve_boundary: spec.preserve_boundary,
        boundary_tolerance: spec.boundary_tolerance * diagonal,
    };
    let input = TetInput {
        points: xyz,
        tets: &corners,
        scalars,
    };
    let seam = input.seam_points(boundary, others);
    let reduction = Reduction::keeping(input, &params, &seam).map_err(|e| e.to_string())?;
    let replay = Replay::new(reduction.mesh());
    let mut p = Progressive {
        reduction,
        replay,
        iso: None,
        point_ids: Vec::new(),
        index: Vec::new(),
        iso_points: Vec::new(),
        iso_values: Vec::new(),
        iso_triangles: Vec::new(),
    };
    p.extract();
    Ok(p)
}

impl Progressive {
    /// Continues the reduction, if it has not gone that far, until the base mesh has at most
    /// `(1 - target_reduction)` of the original's tetrahedra or no collapse is left (see
    /// [`ffi::Progressive::reduce_for`]); returns how many collapses it added.
    pub fn reduce_for(
        &mut self,
        target_reduction: f64,
        mut progress: Pin<&mut ffi::ProgressObserver>,
    ) -> Result<usize, String> {
        guard("simplifying the tetrahedra", || {
            let mut report = crate::reporter(progress.as_mut());
            self.reduce_with(target_reduction, &mut report)
        })
    }

    /// [`Self::reduce_for`] with a Rust progress callback.
    pub fn reduce_with(
        &mut self,
        target_reduction: f64,
        progress: diamonds::Progress<'_>,
    ) -> Result<usize, String> {
        let target = self.target_tets(target_reduction)?;
        let pm = self.reduction.mesh();
        if self.reduction.exhausted() || pm.error(0).tets <= target {
            return Ok(0);
        }
        let added = self
            .reduction
            .reduce_to(target, progress)
            .map_err(|e| e.to_string());
        // Kept even after an abort: the collapses made until then are levels below the old ones.
        self.replay.rebase(self.reduction.mesh());
        if added.is_ok() {
            // Here, in the execution that simplifies, rather than in the first level change.
            self.replay.index_jumps(self.reduction.mesh());
        }
        added
    }

    /// The reduction's shortfall of `target_reduction` ([`diamonds::progressive::Reduction::shortfall`]),
    /// empty when there is none.
    pub fn reduction_warning(&self, target_reduction: f64) -> Result<String, String> {
        guard("checking the reduction", || {
            let target = self.target_tets(target_reduction)?;
            Ok(self.reduction.shortfall(target).unwrap_or_default())
        })
    }

    /// The tetrahedra left at `target_reduction`.
    fn target_tets(&self, target_reduction: f64) -> Result<usize, String> {
        if !(0.0..=1.0).contains(&target_reduction) {
            return Err(format!(
                "the target reduction is {target_reduction}; it must be between 0 and 1"
            ));
        }
        let original = self.reduction.mesh().original_tets().len() as f64;
        Ok(((1.0 - target_reduction) * original).round() as usize)
    }

    /// Reads the current level (every level is valid by construction: nothing is checked or
    /// located again) and its isosurface into the arrays C++ takes.
    fn extract(&mut self) {
        (self.point_ids, self.index) = self
            .replay
            .level_points(self.reduction.mesh().points().len());
        self.extract_surface();
    }

    fn extract_surface(&mut self) {
        let surface = self
            .iso
            .as_ref()
            .map(|iso| iso.surface(self.reduction.mesh()))
            .unwrap_or_default();
        self.iso_points = surface.points.iter().flatten().copied().collect();
        self.iso_values = surface.values;
        self.iso_triangles = surface.triangles.iter().flatten().copied().collect();
    }

    pub fn number_of_levels(&self) -> usize {
        self.reduction.mesh().levels()
    }

    pub fn level_for(&self, target_reduction: f64, max_field_error: f64) -> Result<usize, String> {
        guard("choosing the level", || {
            let target = self.target_tets(target_reduction)?;
            if !max_field_error.is_finite() || max_field_error < 0.0 {
                return Err(format!(
                    "the maximum field error is {max_field_error}; it must be finite and >= 0 (0 = no limit)"
                ));
            }
            let pm = self.reduction.mesh();
            let by_count = pm.level_for_tets(target);
            Ok(if max_field_error > 0.0 {
                by_count.max(pm.level_for_error(max_field_error))
            } else {
                by_count
            })
        })
    }

    pub fn set_level(&mut self, level: usize) -> Result<usize, String> {
        guard("replaying the progressive mesh", || {
            let steps = match &mut self.iso {
                Some(iso) => iso.set_level(self.reduction.mesh(), &mut self.replay, level),
                None => self.replay.set_level(self.reduction.mesh(), level),
            };
            self.extract();
            Ok(steps)
        })
    }

    pub fn current_level(&self) -> usize {
        self.replay.level()
    }

    pub fn level_point_ids(&self) -> &[u32] {
        &self.point_ids
    }

    pub fn gather_level_point_values(
        &self,
        source: &[u8],
        tuple_bytes: usize,
        target: &mut [u8],
    ) -> Result<(), String> {
        guard("passing a point array through", || {
            self.reduction
                .mesh()
                .gather_point_values(&self.point_ids, source, tuple_bytes, target)
                .map_err(|e| e.to_string())
        })
    }

    pub fn level_tet_count(&self) -> usize {
        self.replay.tets()
    }

    pub fn fill_level(
        &self,
        coordinates: &mut [f64],
        connectivity: &mut [u32],
        field_errors: &mut [f64],
    ) -> Result<(), String> {
        guard("writing the level", || {
            let (np, nt) = (self.point_ids.len(), self.replay.tets());
            if coordinates.len() != 3 * np
                || connectivity.len() != 4 * nt
                || field_errors.len() != nt
            {
                return Err(format!(
                    "arrays for {} coordinates, {} corners and {} field errors given for a level of {np} points and {nt} tetrahedra",
                    coordinates.len(),
                    connectivity.len(),
                    field_errors.len()
                ));
            }
            self.reduction
                .mesh()
                .fill_points(&self.point_ids, coordinates);
            self.replay.fill_tets(&self.index, connectivity);
            self.replay.fill_field_errors(field_errors);
            Ok(())
        })
    }

    pub fn level_max_field_error(&self) -> f64 {
        self.reduction
            .mesh()
            .error(self.replay.level())
            .max_field_error
    }

    pub fn level_rms_field_error(&self) -> f64 {
        self.reduction
            .mesh()
            .error(self.replay.level())
            .rms_field_error
    }

    pub fn merged_points(&self) -> usize {
        self.reduction.mesh().cleaning().0
    }

    pub fn dropped_tets(&self) -> usize {
        self.reduction.mesh().cleaning().1
    }

    pub fn set_isovalues(&mut self, isovalues: &[f64]) -> Result<(), String> {
        guard("extracting the progressive isosurface", || {
            if isovalues.is_empty() {
                self.iso = None;
            } else if let Some(iso) = &mut self.iso {
                if iso.isovalues() != isovalues {
                    iso.set_isovalues(self.reduction.mesh(), &self.replay, isovalues, true)
                        .map_err(|e| e.to_string())?;
                }
            } else {
                self.iso = Some(
                    ProgressiveIsosurface::new(self.reduction.mesh(), &self.replay, isovalues)
                        .map_err(|e| e.to_string())?,
                );
            }
            self.extract_surface();
            Ok(())
        })
    }

    pub fn iso_points(&self) -> &[f64] {
        &self.iso_points
    }

    pub fn iso_values(&self) -> &[f64] {
        &self.iso_values
    }

    pub fn iso_triangles(&self) -> &[u32] {
        &self.iso_triangles
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two unit cubes side by side, each cut into the six tetrahedra around its main diagonal,
    /// with a quadratic field.
    fn cubes() -> (Vec<f64>, Vec<i64>, Vec<f64>) {
        let id = |i: i64, j: i64, k: i64| i + 3 * (j + 2 * k);
        let mut points = Vec::new();
        let mut scalars = Vec::new();
        for k in 0..2 {
            for j in 0..2 {
                for i in 0..3 {
                    points.extend([i as f64, j as f64, k as f64]);
                    scalars.push((i * i + j + 2 * k) as f64);
                }
            }
        }
        let mut tets = Vec::new();
        for i in 0..2 {
            for perm in [
                [0, 1, 2],
                [0, 2, 1],
                [1, 0, 2],
                [1, 2, 0],
                [2, 0, 1],
                [2, 1, 0],
            ] {
                let mut d = [0i64; 3];
                let mut t = [id(i, 0, 0); 4];
                for (s, &axis) in perm.iter().enumerate() {
                    d[axis] = 1;
                    t[s + 1] = id(i + d[0], d[1], d[2]);
                }
                let x = |v: i64| {
                    [
                        points[3 * v as usize],
                        points[3 * v as usize + 1],
                        points[3 * v as usize + 2],
                    ]
                };
                let (a, b, c, e) = (x(t[0]), x(t[1]), x(t[2]), x(t[3]));
                let sub = |p: [f64; 3], q: [f64; 3]| [p[0] - q[0], p[1] - q[1], p[2] - q[2]];
                let (u, v, w) = (sub(b, a), sub(c, a), sub(e, a));
                let det = u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
                    + u[2] * (v[0] * w[1] - v[1] * w[0]);
                if det < 0.0 {
                    t.swap(2, 3);
                }
                tets.extend(t);
            }
        }
        (points, tets, scalars)
    }

    fn spec() -> ProgressiveSpec {
        ProgressiveSpec {
            geometry_weight: 1.0,
            field_weight: 1.0,
            shape_weight: 0.0,
            preserve_boundary: true,
            boundary_tolerance: 1e-9,
            whole_bounds: [0.0, 2.0, 0.0, 1.0, 0.0, 1.0],
        }
    }

    /// The current level as `fill_level` writes it: coordinates, corners, field errors.
    fn level(p: &Progressive) -> (Vec<f64>, Vec<u32>, Vec<f64>) {
        let (np, nt) = (p.level_point_ids().len(), p.level_tet_count());
        let mut level = (vec![0.0; 3 * np], vec![0; 4 * nt], vec![0.0; nt]);
        p.fill_level(&mut level.0, &mut level.1, &mut level.2)
            .unwrap();
        assert!(p
            .fill_level(&mut level.0, &mut level.1[1..], &mut level.2)
            .is_err());
        level
    }

    #[test]
    fn levels_are_replayed_and_read_as_slices() {
        let (points, tets, scalars) = cubes();
        let mut p = build_with(&points, &tets, &scalars, &spec(), &[], &[]).unwrap();
        assert_eq!(p.number_of_levels(), 0);
        // Half way first: the level asked, then the rest of the sequence below it, the current
        // level keeping its mesh (numbered higher).
        let half = p.reduce_with(0.25, &mut |_| true).unwrap();
        assert!(half > 0);
        assert_eq!(p.reduce_with(0.25, &mut |_| true).unwrap(), 0);
        p.set_level(p.level_for(0.25, 0.0).unwrap()).unwrap();
        let (ids, half_level) = (p.level_point_ids().to_vec(), level(&p));
        assert!(half_level.1.len() <= 3 * tets.len() / 4);
        assert!(p.reduce_with(1.0, &mut |_| true).unwrap() > 0);
        let n = p.number_of_levels();
        assert_eq!(p.current_level(), n - half);
        assert_eq!(p.set_level(p.current_level()).unwrap(), 0);
        assert_eq!((p.level_point_ids(), level(&p)), (&ids[..], half_level));
        p.set_level(n).unwrap();
        assert_eq!(p.current_level(), n);
        // The original level: every point, every tetrahedron (in order), no error.
        let (xyz, corners, errors) = level(&p);
        assert_eq!(
            (xyz, corners),
            (points.clone(), tets.iter().map(|&v| v as u32).collect())
        );
        assert!(errors.iter().all(|&e| e == 0.0));
        assert!(n > 0);
        let base = p.level_for(1.0, 0.0).unwrap();
        assert_eq!(base, 0);
        assert_eq!(p.set_level(base).unwrap(), n);
        let (xyz, corners, errors) = level(&p);
        assert_eq!(corners.len() / 4, errors.len());
        assert!(corners.len() < tets.len());
        assert!(corners
            .iter()
            .all(|&v| (v as usize) < p.level_point_ids().len()));
        for (x, &v) in xyz.chunks_exact(3).zip(p.level_point_ids()) {
            assert_eq!(x, &points[3 * v as usize..3 * v as usize + 3]);
        }
        let largest = errors.iter().copied().fold(0.0, f64::max);
        assert!((largest - p.level_max_field_error()).abs() < 1e-9);
        // A point array passed through: each level point's tuple, bytes as they are.
        let source: Vec<u8> = scalars.iter().flat_map(|v| v.to_ne_bytes()).collect();
        let mut target = vec![0u8; 8 * p.level_point_ids().len()];
        p.gather_level_point_values(&source, 8, &mut target)
            .unwrap();
        for (tuple, &v) in target.chunks_exact(8).zip(p.level_point_ids()) {
            assert_eq!(tuple, &source[8 * v as usize..8 * v as usize + 8]);
        }
        assert!(p
            .gather_level_point_values(&source[1..], 8, &mut target)
            .is_err());
        assert!(p
            .gather_level_point_values(&source, 8, &mut target[8..])
            .is_err());
        assert_eq!(p.level_for(0.0, 0.0).unwrap(), n);
        // The isosurface follows the level: at the original level, marching tetrahedra on the
        // input gives one point per crossed edge.
        p.set_isovalues(&[2.5]).unwrap();
        assert!(!p.iso_triangles().is_empty());
        p.set_level(n).unwrap();
        assert_eq!(p.iso_points().len(), 3 * p.iso_values().len());
        assert!(p.iso_values().iter().all(|&v| v == 2.5));
        assert!(!p.iso_triangles().is_empty());
        assert!(p
            .iso_triangles()
            .iter()
            .all(|&v| (v as usize) < p.iso_values().len()));
        assert!(p.set_isovalues(&[f64::INFINITY]).is_err());
        p.set_isovalues(&[]).unwrap();
        assert!(p.iso_points().is_empty());
    }

    #[test]
    fn bad_input_is_an_error() {
        let (points, mut tets, scalars) = cubes();
        assert!(build_with(&points[1..], &tets, &scalars, &spec(), &[], &[]).is_err());
        tets[0] = 99;
        let e = build_with(&points, &tets, &scalars, &spec(), &[], &[])
            .err()
            .unwrap();
        assert!(e.contains("point 99"), "{e}");
        let (points, tets, scalars) = cubes();
        let mut p = build_with(&points, &tets, &scalars, &spec(), &[], &[]).unwrap();
        assert!(p.reduce_with(1.5, &mut |_| true).is_err());
        assert!(p.level_for(1.5, 0.0).is_err());
        assert!(p.level_for(0.5, f64::NAN).is_err());
    }

    /// The two cubes as two pieces (x in [0, 1] and [1, 2]): each sends the other its boundary points
    /// inside the other's bounds, the 4 corners at x = 1 (the second cube's other corners lie
    /// outside the first's bounds), and the first cube's piece reduced as far as it goes keeps them.
    #[test]
    fn a_piece_keeps_the_points_it_shares_with_another() {
        let (points, tets, scalars) = cubes();
        let (first, second) = tets.split_at(4 * 6);
        let boxes = [0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 1.0, 2.0, 0.0, 1.0, 0.0, 1.0];
        let mine = progressive_seam_messages(&points, first, &boxes, 0).unwrap();
        let theirs = progressive_seam_messages(&points, second, &boxes, 1).unwrap();
        assert_eq!(
            mine.boundary.len(),
            8,
            "a cube's boundary points are its corners"
        );
        // 4 points each way, 3 coordinates each.
        assert_eq!(
            (mine.counts.as_slice(), theirs.counts.as_slice()),
            (&[0, 12][..], &[12, 0][..])
        );
        assert!(theirs.coordinates.chunks_exact(3).all(|p| p[0] == 1.0));
        let mut piece = build_with(
            &points,
            first,
            &scalars,
            &spec(),
            &mine.boundary,
            &theirs.coordinates,
        )
        .unwrap();
        piece.reduce_with(1.0, &mut |_| true).unwrap();
        let level = piece.level_for(1.0, 0.0).unwrap();
        piece.set_level(level).unwrap();
        let (xyz, _, _) = self::level(&piece);
        let shared = xyz.chunks_exact(3).filter(|p| p[0] == 1.0).count();
        assert_eq!(shared, 4, "the points at x = 1 stay");
        let bad = &theirs.coordinates[1..];
        assert!(build_with(&points, first, &scalars, &spec(), &mine.boundary, bad).is_err());
        assert!(progressive_seam_messages(&points, &second[1..], &boxes, 1).is_err());
        assert!(progressive_seam_messages(&points, second, &boxes[1..], 1).is_err());
    }
}
