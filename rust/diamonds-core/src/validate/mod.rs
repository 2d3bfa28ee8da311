//! Independent checks of the core's outputs, written without the hierarchy's own machinery (no
//! diamonds, no [`crate::scan`]), one module per kind of output:
//! - [`tetrahedra`]: a [`crate::TetMesh`] against its grid (conformity, exact volume, every vertex an
//!   input sample, the tolerance at every sample), any tetrahedra against a box (conformity, volume),
//!   interval volumes (conformity, faces left open only on the box or the bounding isosurfaces),
//!   and the array consistency of a [`crate::TetMesh`] and a [`crate::material::MaterialMesh`];
//! - [`surfaces`]: a triangle surface given as plain arrays (watertight and consistently oriented,
//!   optionally open on the faces of a box; unit normals), and the array consistency of a
//!   [`crate::IsoSurface`];
//! - [`hausdorff`]: both one-sided Hausdorff distances between a surface and the full-resolution
//!   marching-tetrahedra surface of a volume (the isosurface bound), exact point–triangle distances;
//! - [`polygons`]: crack-free polygons (material interfaces) and the array consistency of a
//!   [`crate::material::PolygonMesh`];
//! - [`visibility`]: back-to-front orders of tetrahedra for an eye position, face by face.
//!
//! The `check_*_arrays` functions are *structural*: lengths and index ranges, what C++ relies on when it
//! indexes VTK arrays with a result. They are cheap and the bridge runs them on every result it hands
//! over. The others are *geometric* and used by the tests and the CLI's `verify` and `verify-surface`.
//! Every check returns `Err` with a message naming the first violation found. Two helpers put meshes in a
//! comparable form for tests: [`canonical_triangles`] and [`boundary_faces`].

pub mod hausdorff;
pub mod polygons;
pub mod surfaces;
pub mod tetrahedra;
pub mod visibility;

pub use hausdorff::{farthest, interval_distances, surface_distances, Farthest, SurfaceDistances};
pub use polygons::{check_crack_free, check_polygon_arrays};
pub use surfaces::{
    canonical_triangles, check_isosurface_arrays, check_surface, check_unit_normals, SurfaceReport,
};
pub use tetrahedra::{
    boundary_faces, bounding_faces, check_conforming, check_interval_arrays, check_interval_volume,
    check_manifold_tets, check_material_mesh_arrays, check_mesh, check_mesh_arrays,
    check_no_overlap, check_tolerance, MeshReport,
};
pub use visibility::{check_back_to_front, VisibilityReport};

use rayon::prelude::*;

/// Checks that every corner of `cells` (named `what` in the message) is below `n_points`.
fn check_corners<const N: usize>(
    cells: &[[u32; N]],
    n_points: usize,
    what: &str,
) -> Result<(), String> {
    match cells
        .iter()
        .find(|c| c.iter().any(|&v| v as usize >= n_points))
    {
        Some(c) => Err(format!("{what} {c:?} refers past the {n_points} points")),
        None => Ok(()),
    }
}

/// The faces of `bounds` (`[xmin, xmax, ymin, ymax, zmin, zmax]`) each point lies on within `eps`, one
/// bit per face in the order of `bounds`.
fn faces_of_bounds(points: &[[f64; 3]], bounds: &[f64; 6], eps: f64) -> Vec<u8> {
    points
        .par_iter()
        .map(|p| faces_of_point(p, bounds, eps))
        .collect()
}

/// The faces of `bounds` (bit `f` for bound `f`, as [`faces_of_bounds`]) within `eps` of `p`.
fn faces_of_point(p: &[f64; 3], bounds: &[f64; 6], eps: f64) -> u8 {
    (0..6)
        .filter(|&f| (p[f / 2] - bounds[f]).abs() <= eps)
        .fold(0, |m, f| m | 1 << f)
}

/// A tolerance for "on a face of `bounds`": a millionth of its diagonal.
fn bounds_eps(bounds: &[f64; 6]) -> f64 {
    1e-6 * crate::volume::bounds_diagonal(bounds)
}

/// Every edge of the closed `polygons` (lists of point ids) as `(smaller id, larger id, whether the
/// polygon goes from the smaller one)`, sorted: the uses of one edge are adjacent (`chunk_by`).
fn sorted_edges<'a>(polygons: impl ParallelIterator<Item = &'a [u32]>) -> Vec<(u32, u32, bool)> {
    let mut edges: Vec<(u32, u32, bool)> = polygons
        .flat_map_iter(|p| {
            (0..p.len()).map(move |i| {
                let (a, b) = (p[i], p[(i + 1) % p.len()]);
                (a.min(b), a.max(b), a < b)
            })
        })
        .collect();
    edges.par_sort_unstable();
    edges
}
