//! Polygons (material interfaces and cuts): crack-free interfaces ([`check_crack_free`]) and the array
//! consistency of a [`PolygonMesh`] ([`check_polygon_arrays`]).

use crate::geometry::NearPoints;
use crate::material::PolygonMesh;
use glam::DVec3;
use rayon::prelude::*;

/// Checks that the offsets run from 0 to the connectivity's length, non-decreasing with at least 3
/// points per polygon, one per label (none at all, or a single 0, without labels), and that every
/// corner is inside `points`.
fn check_connectivity(polygons: &PolygonMesh) -> Result<(), String> {
    let n_points = polygons.points.len();
    let n_polys = polygons.labels.len();
    let offsets = &polygons.offsets;
    if n_polys == 0 {
        if offsets.len() > 1 || offsets.first().is_some_and(|&o| o != 0) {
            return Err(format!("no polygon labels but offsets {offsets:?}"));
        }
        if !polygons.connectivity.is_empty() {
            return Err("no polygon labels but a connectivity".into());
        }
    } else {
        if offsets.len() != n_polys + 1 {
            return Err(format!(
                "{n_polys} polygon labels but {} offsets",
                offsets.len()
            ));
        }
        if offsets[0] != 0
            || offsets.windows(2).any(|w| w[1] < w[0] + 3)
            || offsets[n_polys] as usize != polygons.connectivity.len()
        {
            return Err(format!(
                "polygon offsets do not run from 0 to the connectivity's {} entries with at least 3 points per polygon",
                polygons.connectivity.len()
            ));
        }
    }
    match polygons
        .connectivity
        .iter()
        .find(|&&c| c as usize >= n_points)
    {
        Some(c) => Err(format!("polygon corner {c} of {n_points} points")),
        None => Ok(()),
    }
}

/// The consistency C++ relies on when it builds a vtkPolyData: consistent offsets and corners (see
/// the private `check_connectivity`), labels of two materials below `materials` (`a < b` for
/// interfaces; `(m, m)`, or `(255, 255)` for the mixed field without ghost values, for a `cut`), and
/// `values` arrays (exactly `value_arrays` of them, or none) of one value per point.
pub fn check_polygon_arrays(
    polygons: &PolygonMesh,
    materials: usize,
    cut: bool,
    value_arrays: usize,
) -> Result<(), String> {
    check_connectivity(polygons)?;
    let valid = |&[a, b]: &[u8; 2]| {
        if cut {
            a == b && (a == u8::MAX || (a as usize) < materials)
        } else {
            a < b && (b as usize) < materials
        }
    };
    if let Some(l) = polygons.labels.iter().find(|l| !valid(l)) {
        return Err(format!(
            "polygon label {l:?} for {} of {materials} materials",
            if cut { "a cut" } else { "an interface" }
        ));
    }
    if !polygons.values.is_empty() && polygons.values.len() != value_arrays {
        return Err(format!(
            "{} polygon value arrays, {value_arrays} expected",
            polygons.values.len()
        ));
    }
    let n_points = polygons.points.len();
    if let Some(v) = polygons.values.iter().find(|v| v.len() != n_points) {
        return Err(format!(
            "a polygon value array has {} values for {n_points} points",
            v.len()
        ));
    }
    Ok(())
}

/// Checks that the (interface) polygons have no crack: one point per position (no two points within
/// [`crate::geometry::COINCIDENT`] of the diagonal of `bounds`, where polygons meeting there would not connect; a
/// point 1 ulp from another is the same position computed twice), no polygon edge from a point
/// to itself, and every polygon edge shared by at least two polygons (more where interfaces meet)
/// unless its two ends lie on one face of `bounds` (`[xmin, xmax, ymin, …]`, within a millionth of its
/// diagonal). Returns the number of distinct edges.
pub fn check_crack_free(polygons: &PolygonMesh, bounds: [f64; 6]) -> Result<usize, String> {
    check_connectivity(polygons)?;
    let mut positions = NearPoints::within(&bounds);
    for (i, p) in polygons.points.iter().enumerate() {
        let first = positions.merge(DVec3::from_array(*p), (), i as u32) as usize;
        if first != i {
            return Err(format!(
                "points {first} and {i} are both at {:?} (up to rounding: {:?}): two points at one position",
                polygons.points[first], p
            ));
        }
    }
    let faces = super::faces_of_bounds(&polygons.points, &bounds, super::bounds_eps(&bounds));
    let edges = super::sorted_edges(
        polygons
            .offsets
            .par_windows(2)
            .map(|w| &polygons.connectivity[w[0] as usize..w[1] as usize]),
    );
    let groups = edges.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1));
    let mut count = 0;
    for group in groups {
        let (a, b) = (group[0].0 as usize, group[0].1 as usize);
        if a == b {
            return Err(format!(
                "a polygon edge from point {a} at {:?} to itself",
                polygons.points[a]
            ));
        }
        if group.len() == 1 && faces[a] & faces[b] == 0 {
            return Err(format!(
                "edge {:?} - {:?} is in one polygon only: a crack",
                polygons.points[a], polygons.points[b]
            ));
        }
        count += 1;
    }
    Ok(count)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn polygons(offsets: Vec<u32>, connectivity: Vec<u32>, labels: Vec<[u8; 2]>) -> PolygonMesh {
        PolygonMesh {
            points: vec![[0.0; 3]; 4],
            offsets,
            connectivity,
            labels,
            ..Default::default()
        }
    }

    #[test]
    fn check_polygon_arrays_catches_inconsistent_polygons() {
        assert!(check_polygon_arrays(&polygons(vec![], vec![], vec![]), 2, false, 0).is_ok());
        assert!(check_polygon_arrays(&polygons(vec![0], vec![], vec![]), 2, true, 0).is_ok());
        let conn = vec![0, 1, 2, 0, 1, 2, 3];
        let good = polygons(vec![0, 3, 7], conn.clone(), vec![[0, 1], [1, 2]]);
        assert!(check_polygon_arrays(&good, 3, false, 0).is_ok());
        assert!(
            check_polygon_arrays(&good, 2, false, 0).is_err(),
            "material 2 of 2"
        );
        assert!(
            check_polygon_arrays(&good, 3, true, 0).is_err(),
            "a pair in a cut"
        );
        let cut = polygons(vec![0, 3, 7], conn.clone(), vec![[0, 0], [255, 255]]);
        assert!(check_polygon_arrays(&cut, 3, true, 0).is_ok());
        assert!(
            check_polygon_arrays(&cut, 3, false, 0).is_err(),
            "(m, m) interface"
        );
        let mut bad = good.clone();
        bad.connectivity[6] = 4;
        assert!(check_polygon_arrays(&bad, 3, false, 0)
            .unwrap_err()
            .contains("corner 4 of 4 points"));
        let bad = polygons(vec![0, 2, 7], conn, vec![[0, 1], [0, 1]]);
        assert!(
            check_polygon_arrays(&bad, 3, false, 0).is_err(),
            "a 2-point polygon"
        );
        let bad = polygons(vec![0, 3], vec![0, 1, 2, 3], vec![[0, 1]]);
        assert!(
            check_polygon_arrays(&bad, 3, false, 0).is_err(),
            "connectivity longer"
        );
        let mut values = cut.clone();
        values.values = vec![vec![1.0; 4]];
        assert!(check_polygon_arrays(&values, 3, true, 1).is_ok());
        assert!(check_polygon_arrays(&values, 3, true, 2).is_err());
        values.values[0].pop();
        assert!(check_polygon_arrays(&values, 3, true, 1).is_err());
    }

    #[test]
    fn check_crack_free_catches_cracks_off_the_bounds() {
        // The square z = 0.5 of the unit box as two triangles: its outer edges lie on the box's faces.
        let square = PolygonMesh {
            points: vec![
                [0.0, 0.0, 0.5],
                [1.0, 0.0, 0.5],
                [1.0, 1.0, 0.5],
                [0.0, 1.0, 0.5],
            ],
            offsets: vec![0, 3, 6],
            connectivity: vec![0, 1, 2, 0, 2, 3],
            labels: vec![[0, 1]; 2],
            ..Default::default()
        };
        let unit = [0.0, 1.0, 0.0, 1.0, 0.0, 1.0];
        assert_eq!(check_crack_free(&square, unit), Ok(5));
        // In a larger box the outer edges are cracks.
        let larger = [-1.0, 1.0, 0.0, 1.0, 0.0, 1.0];
        let e = check_crack_free(&square, larger).unwrap_err();
        assert!(e.contains("[0.0, 0.0, 0.5] - [0.0, 1.0, 0.5]"), "{e}");
        // A missing polygon leaves the diagonal in one polygon: a crack.
        let mut cracked = square.clone();
        cracked.offsets.pop();
        cracked.connectivity.truncate(3);
        cracked.labels.pop();
        assert!(check_crack_free(&cracked, unit)
            .unwrap_err()
            .contains("[0.0, 0.0, 0.5] - [1.0, 1.0, 0.5]"));
        // Edges shared by three polygons (interfaces meeting) are not cracks.
        let mut junction = square;
        junction.offsets.push(9);
        junction.connectivity.extend([0, 2, 1]);
        junction.labels.push([1, 2]);
        assert_eq!(check_crack_free(&junction, unit), Ok(5));
        // Two points at one position (the third polygon uses a copy of corner 2): the polygons
        // meeting there do not connect.
        let mut doubled = junction.clone();
        doubled.points.push([1.0, 1.0, 0.5]);
        doubled.connectivity[7] = 4;
        assert!(check_crack_free(&doubled, unit)
            .unwrap_err()
            .contains("points 2 and 4 are both at [1.0, 1.0, 0.5]"));
        // A corner repeated: an edge of zero length.
        let mut repeated = junction;
        repeated.offsets.push(12);
        repeated.connectivity.extend([0, 1, 1]);
        repeated.labels.push([0, 2]);
        assert!(check_crack_free(&repeated, unit)
            .unwrap_err()
            .contains("to itself"));
    }
}
