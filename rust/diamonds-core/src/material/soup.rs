//! User interface meshes given as one triangle soup (what the ParaView filter's second input
//! carries): points, triangles, a material pair per triangle (the materials on either side) and
//! optionally normals (per triangle, or per point).
//!
//! The convention is the one of [`InterfaceMesh`]: the normal points from the pair's first material
//! into its second. [`InterfaceMesh::from_soup`] splits the soup into one mesh per unordered pair,
//! with the pair ordered (`a < b`), the triangles wound so that their counter-clockwise normal agrees
//! with the given normals (or, without normals, with the given winding) after the ordering, and the
//! points of each mesh compacted.

use super::InterfaceMesh;
use crate::{Error, Result};
use glam::DVec3;
use std::collections::BTreeMap;

fn invalid(what: String) -> Error {
    Error::Parameter(format!("interface mesh: {what}"))
}

impl InterfaceMesh {
    /// Splits a triangle soup into one mesh per material pair (see the module documentation):
    /// `points` (3 coordinates per point), `triangles` (3 point indices each), `pairs` (2 materials
    /// per triangle: the normal points from the first into the second), `normals` (empty, 3 per
    /// triangle, or with `point_normals` 3 per point; a point-normal triangle takes the sum of its
    /// corners' normals). Without normals the triangles' counter-clockwise winding gives the
    /// direction. The meshes come ordered by pair.
    pub fn from_soup(
        points: &[f64],
        triangles: &[u32],
        pairs: &[i64],
        normals: &[f64],
        point_normals: bool,
    ) -> Result<Vec<InterfaceMesh>> {
        if !points.len().is_multiple_of(3) {
            return Err(invalid(format!(
                "{} point coordinates is not a multiple of 3",
                points.len()
            )));
        }
        if !triangles.len().is_multiple_of(3) {
            return Err(invalid(format!(
                "{} triangle corners is not a multiple of 3",
                triangles.len()
            )));
        }
        let n_points = points.len() / 3;
        let n_triangles = triangles.len() / 3;
        if pairs.len() != 2 * n_triangles {
            return Err(invalid(format!(
                "{n_triangles} triangles need {} material-pair values (2 per triangle), got {}",
                2 * n_triangles,
                pairs.len()
            )));
        }
        let expected_normals = match (normals.is_empty(), point_normals) {
            (true, _) => 0,
            (false, true) => 3 * n_points,
            (false, false) => 3 * n_triangles,
        };
        if normals.len() != expected_normals {
            return Err(invalid(format!(
                "{} normal components for {} {} (3 each expected)",
                normals.len(),
                if point_normals { n_points } else { n_triangles },
                if point_normals { "points" } else { "triangles" }
            )));
        }
        if let Some(c) = points.iter().find(|c| !c.is_finite()) {
            return Err(invalid(format!("a point coordinate is {c}")));
        }
        let vector = |values: &[f64], i: usize| DVec3::from_slice(&values[3 * i..3 * i + 3]);
        // Triangles of each ordered pair, wound so that their normal points from pair.0 into pair.1.
        let mut by_pair: BTreeMap<(u8, u8), Vec<[u32; 3]>> = BTreeMap::new();
        for (t, corners) in triangles.chunks_exact(3).enumerate() {
            let corners = [corners[0], corners[1], corners[2]];
            if let Some(&c) = corners.iter().find(|&&c| c as usize >= n_points) {
                return Err(invalid(format!(
                    "triangle {t} refers to point {c} but there are {n_points} points"
                )));
            }
            let (first, second) = (pairs[2 * t], pairs[2 * t + 1]);
            let material = |m: i64| u8::try_from(m).ok();
            let (Some(a), Some(b)) = (material(first), material(second)) else {
                return Err(bad_pair(t, first, second));
            };
            if a == b {
                return Err(bad_pair(t, first, second));
            }
            let [pa, pb, pc] = corners.map(|c| vector(points, c as usize));
            let winding = (pb - pa).cross(pc - pa);
            // The direction the normal must have, from `first` into `second`.
            let wanted = if normals.is_empty() {
                winding
            } else if point_normals {
                corners.iter().map(|&c| vector(normals, c as usize)).sum()
            } else {
                vector(normals, t)
            };
            if !wanted.is_finite() {
                return Err(invalid(format!(
                    "triangle {t} has a non-finite normal {:?}",
                    wanted.to_array()
                )));
            }
            let (pair, wanted) = if a < b {
                ((a, b), wanted)
            } else {
                ((b, a), -wanted)
            };
            let oriented = if winding.dot(wanted) < 0.0 {
                [corners[0], corners[2], corners[1]]
            } else {
                corners
            };
            by_pair.entry(pair).or_default().push(oriented);
        }
        // Compact the points of each mesh (first use order).
        Ok(by_pair
            .into_iter()
            .map(|(pair, tris)| {
                let mut index: BTreeMap<u32, u32> = BTreeMap::new();
                let mut mesh_points = Vec::new();
                let triangles = tris
                    .iter()
                    .map(|t| {
                        t.map(|c| {
                            *index.entry(c).or_insert_with(|| {
                                mesh_points.push(vector(points, c as usize).to_array());
                                (mesh_points.len() - 1) as u32
                            })
                        })
                    })
                    .collect();
                InterfaceMesh {
                    pair,
                    points: mesh_points,
                    triangles,
                }
            })
            .collect())
    }
}

fn bad_pair(t: usize, first: i64, second: i64) -> Error {
    invalid(format!(
        "triangle {t} has the material pair ({first}, {second}); a pair names two different materials, each an index (0, 1, …) into the volume fraction arrays"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn normal_of(mesh: &InterfaceMesh, t: usize) -> DVec3 {
        let [a, b, c] = mesh.triangles[t].map(|i| DVec3::from(mesh.points[i as usize]));
        (b - a).cross(c - a)
    }

    /// Two triangles of the plane z = 0 with normals +z (counter-clockwise seen from above).
    const POINTS: [f64; 12] = [0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.];
    const TRIANGLES: [u32; 6] = [0, 1, 2, 0, 2, 3];

    fn soup(
        points: &[f64],
        triangles: &[u32],
        pairs: &[i64],
        normals: &[f64],
        point_normals: bool,
    ) -> std::result::Result<Vec<InterfaceMesh>, String> {
        InterfaceMesh::from_soup(points, triangles, pairs, normals, point_normals)
            .map_err(|e| e.to_string())
    }

    #[test]
    fn interface_soup_without_normals_keeps_the_winding_and_orders_pairs() {
        // Pair (0, 1) as given, then (2, 1): the second triangle must be flipped to point from 1
        // into 2, i.e. its normal toward -z.
        let meshes = soup(&POINTS, &TRIANGLES, &[0, 1, 2, 1], &[], false).unwrap();
        assert_eq!(meshes.len(), 2);
        assert_eq!(meshes[0].pair, (0, 1));
        assert_eq!(meshes[1].pair, (1, 2));
        assert!(normal_of(&meshes[0], 0).z > 0.0);
        assert!(normal_of(&meshes[1], 0).z < 0.0);
        // Compacted points: 3 each.
        assert_eq!(meshes[0].points.len(), 3);
        assert_eq!(meshes[1].points.len(), 3);
    }

    #[test]
    fn interface_soup_follows_the_normals() {
        // Cell normals -z: both triangles flipped.
        let normals = [0., 0., -1., 0., 0., -1.];
        let meshes = soup(&POINTS, &TRIANGLES, &[0, 1, 0, 1], &normals, false).unwrap();
        assert_eq!(meshes.len(), 1);
        assert_eq!(meshes[0].points.len(), 4);
        for t in 0..2 {
            assert!(normal_of(&meshes[0], t).z < 0.0);
        }
        // Point normals +z and a swapped pair (1, 0): from 1 into 0 is +z, so from 0 into 1 is -z.
        let point_normals = [0., 0., 1.].repeat(4);
        let meshes = soup(&POINTS, &TRIANGLES, &[1, 0, 1, 0], &point_normals, true).unwrap();
        assert_eq!(meshes[0].pair, (0, 1));
        for t in 0..2 {
            assert!(normal_of(&meshes[0], t).z < 0.0);
        }
    }

    #[test]
    fn bad_interface_soups_are_errors() {
        let ok_pairs = [0, 1, 0, 1];
        assert!(soup(&POINTS[..11], &TRIANGLES, &ok_pairs, &[], false).is_err());
        assert!(soup(&POINTS, &TRIANGLES[..5], &ok_pairs, &[], false).is_err());
        assert!(soup(&POINTS, &TRIANGLES, &ok_pairs[..3], &[], false)
            .unwrap_err()
            .contains("material-pair"));
        assert!(soup(&POINTS, &[0, 1, 7], &[0, 1], &[], false)
            .unwrap_err()
            .contains("point 7"));
        assert!(soup(&POINTS, &TRIANGLES, &[0, 0, 0, 1], &[], false)
            .unwrap_err()
            .contains("pair (0, 0)"));
        assert!(soup(&POINTS, &TRIANGLES, &[-1, 1, 0, 1], &[], false).is_err());
        assert!(soup(&POINTS, &TRIANGLES, &[0, 300, 0, 1], &[], false).is_err());
        assert!(soup(&POINTS, &TRIANGLES, &ok_pairs, &[0.0; 5], false)
            .unwrap_err()
            .contains("normal"));
        let nan = [f64::NAN, 0., 1., 0., 0., 1.];
        assert!(soup(&POINTS, &TRIANGLES, &ok_pairs, &nan, false).is_err());
    }
}
