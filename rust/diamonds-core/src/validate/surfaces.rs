//! Triangle surfaces: watertight and consistently oriented ([`check_surface`], on plain arrays so that
//! the CLI can check a surface it read), unit normals ([`check_unit_normals`]), and the array
//! consistency of an [`IsoSurface`] ([`check_isosurface_arrays`]).

use super::check_corners;
use super::tetrahedra::check_sources;
use crate::{IsoQuery, IsoSurface};
use rayon::prelude::*;

/// What [`check_surface`] found: the edge counts and the outcome of each property, `Err` naming how
/// many edges break it and one of them.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceReport {
    pub triangles: usize,
    /// Edges in two triangles.
    pub interior_edges: usize,
    /// Edges in one triangle with both ends on one face of the box the surface may be open on.
    pub boundary_edges: usize,
    /// Watertight: every edge is an interior or a boundary edge.
    pub watertight: Result<(), String>,
    /// Consistently oriented: the two triangles of every interior edge traverse it in opposite
    /// directions.
    pub oriented: Result<(), String>,
}

impl SurfaceReport {
    /// Watertight and consistently oriented, or the first failure's message.
    pub fn passed(&self) -> Result<(), String> {
        self.watertight.clone().and(self.oriented.clone())
    }
}

/// Checks the surface made of `triangles` (corners indexing `points`): every corner inside `points`,
/// every point a corner of some triangle and three distinct corners per triangle (else `Err`),
/// then whether every edge is in exactly two triangles traversed in opposite directions
/// (watertight and consistently oriented, in the report).
/// With `open_on` (`[xmin, xmax, ymin, ymax, zmin, zmax]`, e.g. the image's bounds), an edge whose two
/// ends lie on one face of that box (within a millionth of its diagonal) may be in one triangle: the
/// surface may be cut open by the box. Without, the surface must be closed.
pub fn check_surface(
    points: &[[f64; 3]],
    triangles: &[[u32; 3]],
    open_on: Option<[f64; 6]>,
) -> Result<SurfaceReport, String> {
    check_corners(triangles, points.len(), "triangle")?;
    let mut used = vec![false; points.len()];
    for t in triangles {
        for &p in t {
            used[p as usize] = true;
        }
    }
    if let Some(p) = used.iter().position(|&u| !u) {
        return Err(format!(
            "point {p} {:?} is in no triangle ({} such points)",
            points[p],
            used.iter().filter(|&&u| !u).count()
        ));
    }
    if let Some((c, t)) = triangles
        .iter()
        .enumerate()
        .find(|(_, t)| t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
    {
        return Err(format!("triangle {c} is degenerate: {t:?}"));
    }
    let faces = match open_on {
        Some(b) => super::faces_of_bounds(points, &b, super::bounds_eps(&b)),
        None => vec![0; points.len()],
    };
    let edges = super::sorted_edges(triangles.par_iter().map(|t| &t[..]));
    let (mut interior, mut boundary) = (0, 0);
    let (mut open, mut misoriented) = (Vec::new(), Vec::new());
    for group in edges.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
        let (a, b) = (group[0].0, group[0].1);
        match group.len() {
            1 if faces[a as usize] & faces[b as usize] != 0 => boundary += 1,
            2 => {
                interior += 1;
                if group[0].2 == group[1].2 {
                    misoriented.push((a, b));
                }
            }
            k => open.push((a, b, k)),
        }
    }
    let describe = |a: u32, b: u32| {
        format!(
            "{a} {:?} - {b} {:?}",
            points[a as usize], points[b as usize]
        )
    };
    Ok(SurfaceReport {
        triangles: triangles.len(),
        interior_edges: interior,
        boundary_edges: boundary,
        watertight: match open.first() {
            None => Ok(()),
            Some(&(a, b, k)) => Err(format!(
                "{} edges not in exactly two triangles, e.g. edge {} in {k}",
                open.len(),
                describe(a, b)
            )),
        },
        oriented: match misoriented.first() {
            None => Ok(()),
            Some(&(a, b)) => Err(format!(
                "{} edges traversed twice the same way, e.g. edge {}",
                misoriented.len(),
                describe(a, b)
            )),
        },
    })
}

/// Triangles in a canonical form for comparing two surfaces on the same points: each rotated so
/// its smallest index comes first (orientation kept), then sorted.
pub fn canonical_triangles(triangles: &[[u32; 3]]) -> Vec<[u32; 3]> {
    let mut out: Vec<[u32; 3]> = triangles
        .iter()
        .map(|t| {
            let k = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
            [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
        })
        .collect();
    out.sort_unstable();
    out
}

/// Checks that every normal has length 1 within `slack` (and is finite); returns how many there are.
pub fn check_unit_normals(
    normals: impl IntoIterator<Item = [f64; 3]>,
    slack: f64,
) -> Result<usize, String> {
    let mut count = 0;
    for (p, n) in normals.into_iter().enumerate() {
        let length = n.iter().map(|c| c * c).sum::<f64>().sqrt();
        if (length - 1.0).abs() > slack || !length.is_finite() {
            return Err(format!("the normal at point {p} has length {length}"));
        }
        count += 1;
    }
    Ok(count)
}

/// The consistency C++ relies on when it copies an [`IsoSurface`] extracted for `query` from an
/// input of `grid_points` points into VTK arrays: one value, source pair and weight (and one normal,
/// when asked for) per point, sources inside the input, triangle corners inside `points`, a carrier
/// exactly when asked for.
pub fn check_isosurface_arrays(
    surface: &IsoSurface,
    query: &IsoQuery,
    grid_points: usize,
) -> Result<(), String> {
    let n_points = surface.points.len();
    check_sources(&surface.sources, &surface.weights, n_points, grid_points)?;
    if surface.values.len() != n_points {
        return Err(format!(
            "{n_points} isosurface points but {} values",
            surface.values.len()
        ));
    }
    let normals = if query.compute_normals { n_points } else { 0 };
    if surface.normals.len() != normals {
        return Err(format!(
            "{n_points} isosurface points but {} normals (normals asked for: {})",
            surface.normals.len(),
            query.compute_normals
        ));
    }
    check_corners(&surface.triangles, n_points, "triangle")?;
    if surface.carrier.is_some() != query.carrier_tetrahedra {
        return Err(format!(
            "carrier tetrahedra asked for: {}, returned: {}",
            query.carrier_tetrahedra,
            surface.carrier.is_some()
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The boundary of the tetrahedron (0,0,0), (1,0,0), (0,1,0), (0,0,1), oriented outwards.
    fn tetrahedron() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let points = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        (points, vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    }

    #[test]
    fn a_closed_oriented_surface_passes() {
        let (points, triangles) = tetrahedron();
        let report = check_surface(&points, &triangles, None).unwrap();
        assert_eq!(report.passed(), Ok(()));
        assert_eq!(
            (
                report.triangles,
                report.interior_edges,
                report.boundary_edges
            ),
            (4, 6, 0)
        );
    }

    #[test]
    fn check_surface_catches_holes_flips_and_bad_triangles() {
        let (points, triangles) = tetrahedron();
        let holed = check_surface(&points, &triangles[1..], None).unwrap();
        assert!(holed
            .watertight
            .unwrap_err()
            .contains("3 edges not in exactly two triangles"));
        assert_eq!(holed.oriented, Ok(()));
        let mut flipped = triangles.clone();
        flipped[2].swap(1, 2);
        let flipped = check_surface(&points, &flipped, None).unwrap();
        assert_eq!(flipped.watertight, Ok(()));
        assert!(flipped
            .oriented
            .unwrap_err()
            .contains("3 edges traversed twice the same way"));
        let mut extra = triangles.clone();
        extra.push([0, 1, 2]);
        assert!(check_surface(&points, &extra, None)
            .unwrap()
            .passed()
            .unwrap_err()
            .contains("in 3"));
        let mut out = triangles.clone();
        out[3][1] = 4;
        assert!(check_surface(&points, &out, None)
            .unwrap_err()
            .contains("refers past the 4 points"));
        let mut unused = points.clone();
        unused.push([2.0, 2.0, 2.0]);
        assert_eq!(
            check_surface(&unused, &triangles, None).unwrap_err(),
            "point 4 [2.0, 2.0, 2.0] is in no triangle (1 such points)"
        );
        let mut degenerate = triangles;
        degenerate[1][2] = 0;
        assert!(check_surface(&points, &degenerate, None)
            .unwrap_err()
            .contains("degenerate"));
    }

    #[test]
    fn surfaces_may_be_open_on_the_faces_of_a_box() {
        let (points, triangles) = tetrahedron();
        // The face z = 0 alone (on the first three points): its three edges lie on the face z = 0
        // of the box.
        let (points, base) = (&points[..3], &triangles[..1]);
        let floor = [-1.0, 1.0, -1.0, 1.0, 0.0, 1.0];
        let report = check_surface(points, base, Some(floor)).unwrap();
        assert_eq!(report.passed(), Ok(()));
        assert_eq!((report.interior_edges, report.boundary_edges), (0, 3));
        assert!(check_surface(points, base, None).unwrap().passed().is_err());
        let below = [-1.0, 1.0, -1.0, 1.0, -1.0, 1.0];
        let report = check_surface(points, base, Some(below)).unwrap();
        assert!(report.watertight.is_err());
        // Without the face x = 0: two of its edges lie on no face of the box, a hole.
        let (points, triangles) = tetrahedron();
        let open = check_surface(&points, &triangles[..3], Some(floor)).unwrap();
        assert!(open.watertight.unwrap_err().starts_with("2 edges"));
    }

    #[test]
    fn check_unit_normals_catches_other_lengths() {
        assert_eq!(
            check_unit_normals([[0.0, 0.0, 1.0], [0.6, 0.8, 0.0]], 1e-9),
            Ok(2)
        );
        let long = check_unit_normals([[0.0, 0.0, 1.0], [0.0, 1.5, 0.0]], 1e-3);
        assert!(long.unwrap_err().contains("point 1 has length 1.5"));
        assert!(check_unit_normals([[f64::NAN, 0.0, 1.0]], 1e-3).is_err());
    }

    #[test]
    fn check_isosurface_arrays_catches_inconsistent_surfaces() {
        let query = IsoQuery {
            isovalues: vec![1.0],
            tolerance: 0.0,
            max_triangles: 0,
            region_of_interest: None,
            compute_normals: true,
            carrier_tetrahedra: false,
        };
        let good = IsoSurface {
            points: vec![[0.0; 3]; 3],
            sources: vec![[0, 0], [1, 2], [3, 3]],
            weights: vec![0.0, 0.5, 0.0],
            normals: vec![[0.0, 0.0, 1.0]; 3],
            triangles: vec![[0, 1, 2]],
            values: vec![1.0; 3],
            error_bound: 0.0,
            carrier: None,
            warnings: Vec::new(),
            point_ids: Vec::new(),
        };
        assert!(check_isosurface_arrays(&good, &query, 4).is_ok());
        let mut bad = good.clone();
        bad.triangles[0][1] = 3;
        assert!(check_isosurface_arrays(&bad, &query, 4)
            .unwrap_err()
            .contains("refers past the 3 points"));
        let mut bad = good.clone();
        bad.normals.pop();
        assert!(check_isosurface_arrays(&bad, &query, 4).is_err());
        let mut bad = good.clone();
        bad.values.pop();
        assert!(check_isosurface_arrays(&bad, &query, 4).is_err());
        let mut bad = good.clone();
        bad.weights.pop();
        assert!(check_isosurface_arrays(&bad, &query, 4).is_err());
        assert!(check_isosurface_arrays(&good, &query, 3)
            .unwrap_err()
            .contains("outside the 3 input points"));
        let carrier = IsoQuery {
            carrier_tetrahedra: true,
            ..query
        };
        assert!(check_isosurface_arrays(&good, &carrier, 4).is_err());
    }
}
