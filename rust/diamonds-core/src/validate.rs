//! Independent checks of an output mesh, written without the hierarchy's own machinery (no diamonds, no
//! [`crate::scan`]): conformity, exact volume, bounds, and the tolerance at every input sample.
//! Used by the tests and by the CLI's `verify` command.

use crate::volume::{Grid, Sample, Volume};
use crate::TetMesh;
use glam::{DMat3, DVec3, I64Vec3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};

/// What [`check_mesh`] measured.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MeshReport {
    pub tets: usize,
    pub interior_faces: usize,
    pub boundary_faces: usize,
}

/// Checks that `mesh` is a conforming tetrahedralisation of exactly the grid's box whose vertices are
/// input samples: positive volumes summing to the box volume, every face shared by two tetrahedra unless
/// it lies on the box boundary, coordinates equal to the samples' positions.
pub fn check_mesh(mesh: &TetMesh, grid: &Grid) -> Result<MeshReport, String> {
    let n = mesh.points.len();
    if mesh.point_ids.len() != n
        || mesh.levels.len() != mesh.tets.len()
        || mesh.errors.len() != mesh.tets.len()
    {
        return Err("array lengths disagree".into());
    }
    let ijk: Vec<I64Vec3> = mesh
        .point_ids
        .iter()
        .map(|&i| {
            let [x, y, z] = grid.ijk(i);
            I64Vec3::new(x as i64, y as i64, z as i64)
        })
        .collect();
    for (k, &i) in mesh.point_ids.iter().enumerate() {
        if i >= grid.len() {
            return Err(format!(
                "point {k} refers to input point {i} outside the grid"
            ));
        }
        let want = grid.point(grid.ijk(i));
        if (0..3).any(|a| (mesh.points[k][a] - want[a]).abs() > 1e-9 * (1.0 + want[a].abs())) {
            return Err(format!(
                "point {k} at {:?} is not input point {i} at {want:?}",
                mesh.points[k]
            ));
        }
    }
    let hi = I64Vec3::new(
        grid.dims[0] as i64 - 1,
        grid.dims[1] as i64 - 1,
        grid.dims[2] as i64 - 1,
    );
    let mut volume6 = 0i64;
    let mut faces: HashMap<[u32; 3], u32> = HashMap::with_capacity(2 * mesh.tets.len());
    for (c, t) in mesh.tets.iter().enumerate() {
        if t.iter().any(|&v| v as usize >= n) {
            return Err(format!("tet {c} has a vertex index out of range"));
        }
        let p = t.map(|v| ijk[v as usize]);
        let det = (p[1] - p[0]).dot((p[2] - p[0]).cross(p[3] - p[0]));
        if det <= 0 {
            return Err(format!(
                "tet {c} {p:?} is degenerate or negatively oriented (6V = {det})"
            ));
        }
        volume6 += det;
        for skip in 0..4 {
            let mut f = [0u32; 3];
            let mut k = 0;
            for (i, &v) in t.iter().enumerate() {
                if i != skip {
                    f[k] = v;
                    k += 1;
                }
            }
            f.sort_unstable();
            *faces.entry(f).or_default() += 1;
        }
    }
    let box6 = 6 * hi.x * hi.y * hi.z;
    if volume6 != box6 {
        return Err(format!(
            "tet volumes sum to {volume6}/6, the box has {box6}/6"
        ));
    }
    let mut report = MeshReport {
        tets: mesh.tets.len(),
        interior_faces: 0,
        boundary_faces: 0,
    };
    for (f, count) in faces {
        let p = f.map(|v| ijk[v as usize]);
        let on_boundary =
            (0..3).any(|a| p.iter().all(|q| q[a] == 0) || p.iter().all(|q| q[a] == hi[a]));
        match (count, on_boundary) {
            (2, false) => report.interior_faces += 1,
            (1, true) => report.boundary_faces += 1,
            _ => {
                return Err(format!(
                    "face {p:?} is shared by {count} tets (boundary: {on_boundary}): the mesh is not conforming"
                ))
            }
        }
    }
    Ok(report)
}

/// Checks that every input sample lies in some tetrahedron of `mesh` and that the linear interpolation
/// of every tetrahedron containing it is within `tolerance` of it. Returns the largest error found.
/// Brute force over each tetrahedron's bounding box with `f64` barycentric coordinates, in parallel.
pub fn check_tolerance<T: Sample>(
    mesh: &TetMesh,
    volume: &Volume<'_, T>,
    tolerance: f64,
) -> Result<f64, String> {
    let grid = volume.grid;
    let covered: Vec<AtomicBool> = (0..grid.len()).map(|_| AtomicBool::new(false)).collect();
    let slack = 1e-9 * (1.0 + tolerance);
    let worst = mesh
        .tets
        .par_iter()
        .enumerate()
        .try_fold(
            || 0.0f64,
            |mut worst, (c, t)| {
                let ids = t.map(|v| mesh.point_ids[v as usize]);
                let p = ids.map(|i| {
                    let [x, y, z] = grid.ijk(i);
                    DVec3::new(x as f64, y as f64, z as f64)
                });
                let f = ids.map(|i| volume.samples[i].to_f64());
                let allowed = tolerance + slack * (1.0 + f.iter().fold(0.0f64, |m, v| m.max(v.abs())));
                let inv = DMat3::from_cols(p[1] - p[0], p[2] - p[0], p[3] - p[0]).inverse();
                let lo = p[0].min(p[1]).min(p[2].min(p[3]));
                let hi = p[0].max(p[1]).max(p[2].max(p[3]));
                for z in lo.z as usize..=hi.z as usize {
                    for y in lo.y as usize..=hi.y as usize {
                        for x in lo.x as usize..=hi.x as usize {
                            let l = inv * (DVec3::new(x as f64, y as f64, z as f64) - p[0]);
                            let l0 = 1.0 - l.element_sum();
                            if l.min_element() < -1e-9 || l0 < -1e-9 {
                                continue;
                            }
                            let i = grid.index(x, y, z);
                            covered[i].store(true, Ordering::Relaxed);
                            let interp = f[0] * l0 + f[1] * l.x + f[2] * l.y + f[3] * l.z;
                            let e = (interp - volume.samples[i].to_f64()).abs();
                            if e > allowed {
                                return Err(format!(
                                    "sample ({x}, {y}, {z}) = {} but tet {c} interpolates {interp} (error {e} > tolerance {tolerance})",
                                    volume.samples[i].to_f64()
                                ));
                            }
                            worst = worst.max(e);
                        }
                    }
                }
                Ok(worst)
            },
        )
        .try_reduce(|| 0.0, |a, b| Ok(a.max(b)))?;
    if let Some(i) = covered.iter().position(|c| !c.load(Ordering::Relaxed)) {
        return Err(format!("sample {:?} lies in no tetrahedron", grid.ijk(i)));
    }
    Ok(worst)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Hierarchy, Query, ScalarSlice};

    #[test]
    fn the_checks_catch_broken_meshes() {
        let grid = Grid::new([9, 7, 5]);
        let samples: Vec<u8> = (0..grid.len()).map(|i| (i * 37 % 251) as u8).collect();
        let volume = Volume::new(grid, &samples[..]).unwrap();
        let h = Hierarchy::build(grid, ScalarSlice::U8(&samples), &mut |_| true).unwrap();
        let mesh = h.query(&Query::tolerance(20.0)).unwrap();
        check_mesh(&mesh, &grid).unwrap();
        check_tolerance(&mesh, &volume, 20.0).unwrap();
        // A missing tetrahedron: a hole.
        let mut holed = mesh.clone();
        holed.tets.pop();
        holed.levels.pop();
        holed.errors.pop();
        assert!(check_mesh(&holed, &grid).unwrap_err().contains("sum"));
        // An inverted tetrahedron.
        let mut inverted = mesh.clone();
        inverted.tets[0].swap(0, 1);
        assert!(check_mesh(&inverted, &grid)
            .unwrap_err()
            .contains("negatively"));
        // A sample off by more than the tolerance.
        let mut changed = samples.clone();
        let i = (0..grid.len())
            .find(|&i| !mesh.point_ids.contains(&i))
            .unwrap();
        changed[i] = changed[i].wrapping_add(128);
        let other = Volume::new(grid, &changed[..]).unwrap();
        assert!(check_tolerance(&mesh, &other, 20.0)
            .unwrap_err()
            .contains("tolerance"));
    }
}
