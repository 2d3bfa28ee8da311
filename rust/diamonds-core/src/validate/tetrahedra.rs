//! Tetrahedra: a [`TetMesh`] against its grid (conformity, exact volume, bounds, and the tolerance at
//! every input sample), any tetrahedra against a box ([`check_conforming`]), and the array consistency
//! of a [`TetMesh`] ([`check_mesh_arrays`]) and a [`MaterialMesh`] ([`check_material_mesh_arrays`]).

use super::check_corners;
use crate::geometry::orient3d;
use crate::interval::IntervalVolume;
use crate::isosurface::in_region;
use crate::material::MaterialMesh;
use crate::volume::{Grid, Sample, Volume};
use crate::TetMesh;
use glam::{DMat3, DVec3, I64Vec3};
use rayon::prelude::*;
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
        || mesh.depths.len() != mesh.tets.len()
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
    check_corners(&mesh.tets, n, "tetrahedron")?;
    let hi = I64Vec3::new(
        grid.dims[0] as i64 - 1,
        grid.dims[1] as i64 - 1,
        grid.dims[2] as i64 - 1,
    );
    let mut volume6 = 0i64;
    for (c, t) in mesh.tets.iter().enumerate() {
        let p = t.map(|v| ijk[v as usize]);
        let det = (p[1] - p[0]).dot((p[2] - p[0]).cross(p[3] - p[0]));
        if det <= 0 {
            return Err(format!(
                "tet {c} {p:?} is degenerate or negatively oriented (6V = {det})"
            ));
        }
        volume6 += det;
    }
    let box6 = 6 * hi.x * hi.y * hi.z;
    if volume6 != box6 {
        return Err(format!(
            "tet volumes sum to {volume6}/6, the box has {box6}/6"
        ));
    }
    let corners = |f: [u32; 3]| f.map(|v| ijk[v as usize]);
    let (interior_faces, boundary_faces) = match_faces(
        &mesh.tets,
        |f| {
            let p = corners(f);
            (0..3).any(|a| p.iter().all(|q| q[a] == 0) || p.iter().all(|q| q[a] == hi[a]))
        },
        |f| format!("{:?}", corners(f)),
        None,
    )?;
    Ok(MeshReport {
        tets: mesh.tets.len(),
        interior_faces,
        boundary_faces,
    })
}

/// Checks that `tets` (corners indexing `points`, VTK_TETRA order) tile exactly the box `bounds`
/// (`[xmin, xmax, ymin, ymax, zmin, zmax]`) conformingly: positive volumes summing to the box's (to a
/// relative 1e-9), every face shared by two tetrahedra unless its corners lie on one face of the box
/// (within a millionth of its diagonal), then by one. For meshes whose vertices are not grid samples
/// (material meshes live on a finer lattice); [`check_mesh`] is the exact check of a [`TetMesh`].
pub fn check_conforming(
    points: &[[f64; 3]],
    tets: &[[u32; 4]],
    bounds: [f64; 6],
) -> Result<MeshReport, String> {
    check_corners(tets, points.len(), "tetrahedron")?;
    let mut volume = 0.0;
    for (c, t) in tets.iter().enumerate() {
        let x = t.map(|v| DVec3::from_array(points[v as usize]));
        let v = (x[1] - x[0]).dot((x[2] - x[0]).cross(x[3] - x[0])) / 6.0;
        if v.is_nan() || v <= 0.0 {
            return Err(format!(
                "tet {c} {x:?} is degenerate or negatively oriented (volume {v})"
            ));
        }
        volume += v;
    }
    let box_volume = (bounds[1] - bounds[0]) * (bounds[3] - bounds[2]) * (bounds[5] - bounds[4]);
    if (volume - box_volume).abs() > 1e-9 * box_volume {
        return Err(format!(
            "tet volumes sum to {volume}, the box has {box_volume}"
        ));
    }
    let faces = super::faces_of_bounds(points, &bounds, super::bounds_eps(&bounds));
    let (interior_faces, boundary_faces) = match_faces(
        tets,
        |f| faces[f[0] as usize] & faces[f[1] as usize] & faces[f[2] as usize] != 0,
        |f| format!("{:?}", f.map(|v| points[v as usize])),
        None,
    )?;
    Ok(MeshReport {
        tets: tets.len(),
        interior_faces,
        boundary_faces,
    })
}

/// Checks that `tets` (corners indexing `points`) form a manifold tetrahedralisation of whatever domain
/// they cover: positive volumes (relative to the cube of the longest edge, so inverted and flat
/// tetrahedra are named), every face shared by one (boundary) or two (interior) tetrahedra, and every
/// edge of the boundary surface shared by exactly two boundary faces (no two parts touching along an
/// edge). For unstructured input and the levels of a progressive mesh, whose domain is not a box.
pub fn check_manifold_tets(points: &[[f64; 3]], tets: &[[u32; 4]]) -> Result<MeshReport, String> {
    check_corners(tets, points.len(), "tetrahedron")?;
    check_positive(points, tets, 1e-12)?;
    let mut boundary: Vec<[u32; 3]> = Vec::new();
    let (interior_faces, boundary_faces) = match_faces(
        tets,
        |_| true,
        |f| format!("{:?}", f.map(|v| points[v as usize])),
        Some(&mut boundary),
    )?;
    let mut edges: Vec<[u32; 2]> = boundary
        .iter()
        .flat_map(|f| [[f[0], f[1]], [f[0], f[2]], [f[1], f[2]]])
        .collect();
    edges.par_sort_unstable();
    if let Some(g) = edges.chunk_by(|a, b| a == b).find(|g| g.len() != 2) {
        return Err(format!(
            "the boundary edge {:?} is shared by {} boundary faces: the mesh is not manifold there",
            g[0].map(|v| points[v as usize]),
            g.len()
        ));
    }
    Ok(MeshReport {
        tets: tets.len(),
        interior_faces,
        boundary_faces,
    })
}

/// Checks that no two of `tets` (corners indexing `points`) overlap, independently of how they are
/// connected: at every probe point `p` — each point of `points`, the centroid of each tetrahedron and
/// each of `extra` — the tetrahedra's generalized winding number `W(p) = Σ_t w_t(p)` is at most 1,
/// and exactly 1 at the centroids. `w_t(p)` is the solid angle of `t`'s boundary seen from `p` over
/// 4π (Van Oosterom–Strackee per face), a face whose plane holds `p` counting 0: 1 inside `t`, ½ on
/// a face, the dihedral angle over 2π on an edge, the corner's solid angle over 4π at a corner, 0
/// outside. Tetrahedra whose interiors are disjoint cover any point at most once, so `W ≤ 1`;
/// where two overlap, every point of the overlap has `W ≥ 2` and a point where one's edge crosses
/// another's interior or face has `W > 1`. Returns the number of probes.
pub fn check_no_overlap(
    points: &[[f64; 3]],
    tets: &[[u32; 4]],
    extra: &[[f64; 3]],
) -> Result<usize, String> {
    use rstar::primitives::GeomWithData;
    use rstar::{RTree, AABB};
    check_corners(tets, points.len(), "tetrahedron")?;
    let x = |t: &[u32; 4]| t.map(|v| DVec3::from_array(points[v as usize]));
    let tree = RTree::bulk_load(
        tets.iter()
            .enumerate()
            .map(|(k, t)| {
                let x = x(t);
                let lo = x[0].min(x[1]).min(x[2]).min(x[3]);
                let hi = x[0].max(x[1]).max(x[2]).max(x[3]);
                GeomWithData::new(
                    rstar::primitives::Rectangle::from_corners(lo.to_array(), hi.to_array()),
                    k as u32,
                )
            })
            .collect(),
    );
    let winding = |p: DVec3| -> f64 {
        let at = p.to_array();
        tree.locate_in_envelope_intersecting(&AABB::from_point(at))
            .map(|r| tet_winding(&x(&tets[r.data as usize]), p))
            .sum()
    };
    let centroids: Vec<DVec3> = tets
        .iter()
        .map(|t| x(t).iter().sum::<DVec3>() / 4.0)
        .collect();
    if let Some((c, w)) = centroids.par_iter().enumerate().find_map_first(|(c, &p)| {
        let w = winding(p);
        ((w - 1.0).abs() > 1e-6).then_some((c, w))
    }) {
        return Err(format!(
            "the centroid of tetrahedron {c} {:?} is covered {w:.6} times: tetrahedra overlap there",
            x(&tets[c]).map(|p| p.to_array())
        ));
    }
    if let Some((p, w)) = points.par_iter().chain(extra).find_map_first(|&p| {
        let w = winding(DVec3::from_array(p));
        (w > 1.0 + 1e-6).then_some((p, w))
    }) {
        return Err(format!(
            "the point {p:?} is covered {w:.6} times: tetrahedra overlap there"
        ));
    }
    Ok(centroids.len() + points.len() + extra.len())
}

/// The generalized winding number of the tetrahedron `x` at `p` (see [`check_no_overlap`]): its
/// faces' solid angles seen from `p` over 4π, a face whose plane holds `p` (to a relative 1e-13)
/// counting 0.
fn tet_winding(x: &[DVec3; 4], p: DVec3) -> f64 {
    let volume6 = (x[1] - x[0]).dot((x[2] - x[0]).cross(x[3] - x[0]));
    let sign = if volume6 < 0.0 { -1.0 } else { 1.0 };
    // Faces oriented outward for a positive tetrahedron.
    let faces = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];
    let mut omega = 0.0;
    for f in faces {
        let [a, b, c] = f.map(|k| x[k] - p);
        let (la, lb, lc) = (a.length(), b.length(), c.length());
        let det = a.dot(b.cross(c));
        if det.abs() <= 1e-13 * la * lb * lc {
            continue;
        }
        let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
        omega += 2.0 * det.atan2(den);
    }
    sign * omega / (4.0 * std::f64::consts::PI)
}

/// Checks that every tetrahedron has a volume above `relative` times the cube of its longest edge
/// (so inverted and flat ones are named); at `relative` 0, that its corners are positively oriented,
/// exactly ([`orient3d`]: a thin tetrahedron's volume from the usual formula can be off by
/// more than itself).
fn check_positive(points: &[[f64; 3]], tets: &[[u32; 4]], relative: f64) -> Result<(), String> {
    match tets.par_iter().enumerate().find_map_first(|(c, t)| {
        let x = t.map(|v| DVec3::from_array(points[v as usize]));
        let v = (x[1] - x[0]).dot((x[2] - x[0]).cross(x[3] - x[0])) / 6.0;
        let longest = (0..4)
            .flat_map(|a| (a + 1..4).map(move |b| (a, b)))
            .map(|(a, b)| x[a].distance(x[b]))
            .fold(0.0, f64::max);
        let positive = if relative > 0.0 {
            v > relative * longest.powi(3)
        } else {
            x.iter().all(|p| p.is_finite()) && orient3d(x[1], x[2], x[3], x[0]) > 0.0
        };
        (!positive).then_some((c, x, v))
    }) {
        Some((c, x, v)) => Err(format!(
            "tetrahedron {c} {:?} is inverted or degenerate (volume {v})",
            x.map(|p| p.to_array())
        )),
        None => Ok(()),
    }
}

/// Checks that `tets` (corners indexing `points`, `values` the field at each point) form a conforming
/// interval volume of `[α, β] = range` inside the box `bounds`: positive volumes, every face shared by
/// two tetrahedra, or by one when it lies on one face of the box (within a millionth of its diagonal)
/// or on a bounding isosurface (its three values all `α` or all `β`). Returns the face counts; the
/// volume is the caller's to compare.
pub fn check_interval_volume(
    points: &[[f64; 3]],
    values: &[f64],
    tets: &[[u32; 4]],
    bounds: [f64; 6],
    [alpha, beta]: [f64; 2],
) -> Result<MeshReport, String> {
    check_corners(tets, points.len(), "tetrahedron")?;
    if values.len() != points.len() {
        return Err(format!(
            "{} values for {} points",
            values.len(),
            points.len()
        ));
    }
    check_positive(points, tets, 0.0)?;
    let faces = super::faces_of_bounds(points, &bounds, super::bounds_eps(&bounds));
    let (interior_faces, boundary_faces) = match_faces(
        tets,
        |f| {
            let at = |level: f64| f.iter().all(|&v| values[v as usize] == level);
            faces[f[0] as usize] & faces[f[1] as usize] & faces[f[2] as usize] != 0
                || at(alpha)
                || at(beta)
        },
        |f| {
            format!(
                "{:?} (values {:?})",
                f.map(|v| points[v as usize]),
                f.map(|v| values[v as usize])
            )
        },
        // A face on a bounding isosurface may also be interior (a plateau at α between two
        // tetrahedra in the range): listing the boundary faces lets such faces be shared by two.
        Some(&mut Vec::new()),
    )?;
    Ok(MeshReport {
        tets: tets.len(),
        interior_faces,
        boundary_faces,
    })
}

/// The bounding faces of an interval volume (`tets`, `values` the field at each point) at `levels`:
/// its [`boundary_faces`] whose three values all equal one of them.
pub fn bounding_faces(tets: &[[u32; 4]], values: &[f64], levels: &[f64]) -> Vec<[u32; 3]> {
    let at = |f: &[u32; 3], level: f64| f.iter().all(|&v| values[v as usize] == level);
    (boundary_faces(tets).into_iter())
        .filter(|f| levels.iter().any(|&level| at(f, level)))
        .collect()
}

/// The faces of `tets` used by only one of them, each with its corners in its tetrahedron's order
/// (faces 012, 013, 023, 123), sorted by their sorted corners. A test helper: the boundary surface of
/// a mesh that may not fill a box (a simplified mesh, an interval volume).
pub fn boundary_faces(tets: &[[u32; 4]]) -> Vec<[u32; 3]> {
    let mut faces: Vec<([u32; 3], [u32; 3])> = tets
        .iter()
        .flat_map(|t| {
            [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]].map(|f| {
                let corners = f.map(|k| t[k]);
                let mut key = corners;
                key.sort_unstable();
                (key, corners)
            })
        })
        .collect();
    faces.sort_unstable();
    faces
        .chunk_by(|a, b| a.0 == b.0)
        .filter(|g| g.len() == 1)
        .map(|g| g[0].1)
        .collect()
}

/// Checks that every face of `tets` (corners sorted) is shared by two of them, or by one when
/// `on_boundary` says it lies on the boundary of the domain; `describe` names a face in the message.
/// Returns the numbers of interior and boundary faces.
fn match_faces(
    tets: &[[u32; 4]],
    on_boundary: impl Fn([u32; 3]) -> bool,
    describe: impl Fn([u32; 3]) -> String,
    mut boundary_faces: Option<&mut Vec<[u32; 3]>>,
) -> Result<(usize, usize), String> {
    let mut faces: Vec<[u32; 3]> = tets
        .par_iter()
        .flat_map_iter(|t| {
            (0..4).map(move |skip| {
                let mut f = [0u32; 3];
                for (k, i) in (0..4).filter(|&i| i != skip).enumerate() {
                    f[k] = t[i];
                }
                f.sort_unstable();
                f
            })
        })
        .collect();
    faces.par_sort_unstable();
    let (mut interior, mut boundary) = (0, 0);
    for group in faces.chunk_by(|a, b| a == b) {
        let f = group[0];
        let on_boundary = on_boundary(f);
        // Without a box (`boundary_faces` given), any face used once is on the boundary and any
        // face used twice is interior.
        let free = boundary_faces.is_some();
        match (group.len(), on_boundary) {
            (2, false) => interior += 1,
            (2, true) if free => interior += 1,
            (1, true) => {
                boundary += 1;
                if let Some(faces) = boundary_faces.as_deref_mut() {
                    faces.push(f);
                }
            }
            (count, _) => {
                return Err(format!(
                    "face {} is shared by {count} tets (boundary: {on_boundary}): the mesh is not conforming",
                    describe(f)
                ))
            }
        }
    }
    Ok((interior, boundary))
}

/// The consistency C++ relies on when it indexes VTK arrays with a [`TetMesh`]: one level and one
/// error per tetrahedron, tetrahedron corners inside `points`, point ids inside the `grid_points`
/// input points.
pub fn check_mesh_arrays(mesh: &TetMesh, grid_points: usize) -> Result<(), String> {
    let n_tets = mesh.tets.len();
    if mesh.depths.len() != n_tets || mesh.errors.len() != n_tets {
        return Err(format!(
            "{n_tets} tetrahedra but {} depths and {} errors",
            mesh.depths.len(),
            mesh.errors.len()
        ));
    }
    if let Some(id) = mesh.point_ids.iter().find(|&&id| id >= grid_points) {
        return Err(format!(
            "point id {id} outside the {grid_points} input points"
        ));
    }
    check_corners(&mesh.tets, mesh.point_ids.len(), "tetrahedron")
}

/// The consistency C++ relies on when it builds VTK arrays from an [`IntervalVolume`]: one source
/// pair and weight per point, one value per point or none (an isodiamond hierarchy's), one level per tetrahedron, corners inside the points, sources
/// inside the `grid_points` input points.
pub fn check_interval_arrays(volume: &IntervalVolume, grid_points: usize) -> Result<(), String> {
    let (n_points, n_tets) = (volume.points.len(), volume.tets.len());
    // No values from an isodiamond hierarchy, which stores none.
    if !(volume.values.is_empty() || volume.values.len() == n_points) {
        return Err(format!(
            "{n_points} points but {} values",
            volume.values.len()
        ));
    }
    if volume.levels.len() != n_tets {
        return Err(format!(
            "{n_tets} tetrahedra but {} levels",
            volume.levels.len()
        ));
    }
    check_sources(&volume.sources, &volume.weights, n_points, grid_points)?;
    check_corners(&volume.tets, n_points, "tetrahedron")
}

/// One source pair and weight for each of `n_points` points, the sources inside the `grid_points`
/// input points (what C++ interpolates the input's point arrays from).
pub(crate) fn check_sources(
    sources: &[[u32; 2]],
    weights: &[f64],
    n_points: usize,
    grid_points: usize,
) -> Result<(), String> {
    let per_point = [("sources", sources.len()), ("weights", weights.len())];
    if let Some((what, n)) = per_point.iter().find(|(_, n)| *n != n_points) {
        return Err(format!("{n_points} points but {n} {what}"));
    }
    if let Some(s) = (sources.iter()).find(|s| s.iter().any(|&i| i as usize >= grid_points)) {
        return Err(format!(
            "point source {s:?} outside the {grid_points} input points"
        ));
    }
    Ok(())
}

/// The consistency C++ relies on when it builds VTK arrays from a [`MaterialMesh`] refined from an
/// input of `materials` materials and `fields` fields: one value per point or tetrahedron in every
/// array, corners inside `points`, materials and pairs below `materials`, one distance array per pair
/// and material, one mixed field per field and, with `ghost_values`, one per field and material
/// (without, those may be left out or given anyway).
pub fn check_material_mesh_arrays(
    mesh: &MaterialMesh,
    materials: usize,
    fields: usize,
    ghost_values: bool,
) -> Result<(), String> {
    let (n_points, n_tets) = (mesh.points.len(), mesh.tets.len());
    if mesh.materials != materials || mesh.fields != fields {
        return Err(format!(
            "the mesh reports {} materials and {} fields, the input had {materials} and {fields}",
            mesh.materials, mesh.fields
        ));
    }
    let per_tet = [
        ("depths", mesh.depths.len()),
        ("interface errors", mesh.interface_error.len()),
        ("field errors", mesh.field_error.len()),
        ("material masks", mesh.tet_materials.len()),
    ];
    if let Some((what, n)) = per_tet.iter().find(|(_, n)| *n != n_tets) {
        return Err(format!("{n_tets} tetrahedra but {n} {what}"));
    }
    if mesh.point_material.len() != n_points {
        return Err(format!(
            "{n_points} points but {} point materials",
            mesh.point_material.len()
        ));
    }
    check_corners(&mesh.tets, n_points, "tetrahedron")?;
    if let Some(m) = mesh
        .point_material
        .iter()
        .find(|&&m| m as usize >= materials)
    {
        return Err(format!("point material {m} of {materials} materials"));
    }
    if let Some(p) = mesh
        .pairs
        .iter()
        .find(|p| p.0 >= p.1 || p.1 as usize >= materials)
    {
        return Err(format!("interface pair {p:?} of {materials} materials"));
    }
    let arrays = [
        (
            "interface distance",
            &mesh.interface_distance,
            mesh.pairs.len(),
        ),
        ("material distance", &mesh.material_distance, materials),
        ("mixed field", &mesh.mixed, fields),
        (
            "material field",
            &mesh.material_field,
            if ghost_values { fields * materials } else { 0 },
        ),
    ];
    for (what, list, count) in arrays {
        let optional = what == "material field" && !ghost_values;
        if list.len() != count && !(optional && list.len() == fields * materials) {
            return Err(format!("{} {what} arrays, {count} expected", list.len()));
        }
        if let Some(a) = list.iter().find(|a| a.len() != n_points) {
            return Err(format!(
                "a {what} array has {} values for {n_points} points",
                a.len()
            ));
        }
    }
    Ok(())
}

/// Checks that every input sample lies in some tetrahedron of `mesh` and that the linear interpolation
/// of every tetrahedron containing it is within `tolerance` of it — of the samples inside `region`
/// (a world-space box, x, y and z ranges) when there is one: a query with a region of interest
/// meets its tolerance there. Returns the largest error found (inside `region`).
/// Brute force over each tetrahedron's bounding box with `f64` barycentric coordinates, in parallel.
pub fn check_tolerance<T: Sample>(
    mesh: &TetMesh,
    volume: &Volume<'_, T>,
    tolerance: f64,
    region: Option<[f64; 6]>,
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
                            if !in_region(region, DVec3::from(grid.point([x, y, z]))) {
                                continue;
                            }
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
        check_tolerance(&mesh, &volume, 20.0, None).unwrap();
        // A missing tetrahedron: a hole.
        let mut holed = mesh.clone();
        holed.tets.pop();
        holed.depths.pop();
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
        assert!(check_tolerance(&mesh, &other, 20.0, None)
            .unwrap_err()
            .contains("tolerance"));
    }

    /// One tetrahedron on input points 0 to 3, for the array checks (its geometry is not looked at).
    fn one_tet() -> TetMesh {
        TetMesh {
            point_ids: vec![0, 1, 2, 3],
            points: vec![[0.0; 3]; 4],
            tets: vec![[0, 1, 2, 3]],
            depths: vec![0],
            errors: vec![0.0],
            max_error: 0.0,
        }
    }

    #[test]
    fn check_mesh_arrays_catches_inconsistent_meshes() {
        let good = one_tet();
        assert!(check_mesh_arrays(&good, 8).is_ok());
        assert!(check_mesh_arrays(&good, 3)
            .unwrap_err()
            .contains("point id 3 outside the 3 input points"));
        let mut bad = good.clone();
        bad.tets[0][2] = 4;
        assert!(check_mesh_arrays(&bad, 8)
            .unwrap_err()
            .contains("refers past the 4 points"));
        let mut bad = good;
        bad.depths.clear();
        assert!(check_mesh_arrays(&bad, 8).unwrap_err().contains("0 depths"));
    }

    /// The unit cube cut into six tetrahedra around its diagonal (0,0,0)–(1,1,1), positively oriented.
    fn cube() -> (Vec<[f64; 3]>, Vec<[u32; 4]>) {
        let points = (0..8)
            .map(|i| [(i & 1) as f64, (i >> 1 & 1) as f64, (i >> 2) as f64])
            .collect();
        let tets = vec![
            [0, 1, 3, 7],
            [0, 3, 2, 7],
            [0, 2, 6, 7],
            [0, 6, 4, 7],
            [0, 4, 5, 7],
            [0, 5, 1, 7],
        ];
        (points, tets)
    }

    #[test]
    fn check_conforming_catches_holes_flips_and_bad_indices() {
        let (points, tets) = cube();
        let unit = [0.0, 1.0, 0.0, 1.0, 0.0, 1.0];
        let report = check_conforming(&points, &tets, unit).unwrap();
        assert_eq!(
            (report.tets, report.interior_faces, report.boundary_faces),
            (6, 6, 12)
        );
        let holed = &tets[1..];
        assert!(check_conforming(&points, holed, unit)
            .unwrap_err()
            .contains("volumes sum"));
        let mut flipped = tets.clone();
        flipped[2].swap(0, 1);
        assert!(check_conforming(&points, &flipped, unit)
            .unwrap_err()
            .contains("negatively"));
        let mut out = tets.clone();
        out[5][3] = 8;
        assert!(check_conforming(&points, &out, unit)
            .unwrap_err()
            .contains("refers past the 8 points"));
        // The same volume in the wrong box: faces on the cube's boundary are not on the box's.
        let shifted = [0.0, 1.0, 0.0, 1.0, -0.5, 0.5];
        assert!(check_conforming(&points, &tets, shifted)
            .unwrap_err()
            .contains("not conforming"));
    }

    #[test]
    fn check_material_mesh_arrays_catches_inconsistent_meshes() {
        let good = crate::material::tests::one_tetrahedron_mesh(true);
        assert!(check_material_mesh_arrays(&good, 2, 1, true).is_ok());
        assert!(check_material_mesh_arrays(&good, 2, 1, false).is_ok());
        assert!(check_material_mesh_arrays(&good, 3, 1, true).is_err());
        let mut bad = good.clone();
        bad.material_field.clear();
        assert!(check_material_mesh_arrays(&bad, 2, 1, true).is_err());
        assert!(check_material_mesh_arrays(&bad, 2, 1, false).is_ok());
        let mut bad = good.clone();
        bad.tets[0][3] = 4;
        assert!(check_material_mesh_arrays(&bad, 2, 1, true)
            .unwrap_err()
            .contains("refers past"));
        let mut bad = good.clone();
        bad.point_material[0] = 2;
        assert!(check_material_mesh_arrays(&bad, 2, 1, true).is_err());
        let mut bad = good.clone();
        bad.pairs[0] = (1, 0);
        assert!(check_material_mesh_arrays(&bad, 2, 1, true).is_err());
        let mut bad = good.clone();
        bad.field_error.push(0.0);
        assert!(check_material_mesh_arrays(&bad, 2, 1, true).is_err());
        let mut bad = good.clone();
        bad.mixed[0].pop();
        assert!(check_material_mesh_arrays(&bad, 2, 1, true).is_err());
        let mut bad = good;
        bad.interface_distance.push(vec![0.0; 4]);
        assert!(check_material_mesh_arrays(&bad, 2, 1, true).is_err());
    }

    #[test]
    fn winding_numbers_count_cover_and_overlap() {
        let x = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
        let w = |p: [f64; 3]| tet_winding(&x, DVec3::from_array(p));
        assert!((w([0.1, 0.1, 0.1]) - 1.0).abs() < 1e-12);
        assert!((w([0.2, 0.2, 0.0]) - 0.5).abs() < 1e-12);
        assert!(w([2.0, 0.1, 0.1]).abs() < 1e-12);
        // On the edge along x, where the faces meet at a right angle.
        assert!((w([0.5, 0.0, 0.0]) - 0.25).abs() < 1e-12);
        // At the right-angled corner: an eighth of the sphere.
        assert!((w([0.0, 0.0, 0.0]) - 0.125).abs() < 1e-12);
        // The unit cube in six tetrahedra around its diagonal: no overlap.
        let (points, tets) = cube();
        check_manifold_tets(&points, &tets).unwrap();
        assert_eq!(check_no_overlap(&points, &tets, &[]), Ok(8 + 6));
        // Two positive tetrahedra on a shared face, the second folded back over the first: manifold
        // and positive, but overlapping.
        let points = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.2, 0.2, 0.5],
        ];
        let tets = [[0, 1, 2, 3], [0, 2, 1, 4]];
        let tets = tets.map(|t| {
            let x = t.map(|v| DVec3::from_array(points[v as usize]));
            if (x[1] - x[0]).dot((x[2] - x[0]).cross(x[3] - x[0])) < 0.0 {
                [t[0], t[2], t[1], t[3]]
            } else {
                t
            }
        });
        check_manifold_tets(&points, &tets).unwrap();
        let e = check_no_overlap(&points, &tets, &[]).unwrap_err();
        assert!(e.contains("overlap"), "{e}");
    }
}
