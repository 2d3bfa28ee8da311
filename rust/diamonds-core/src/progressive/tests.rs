//! Properties of progressive meshes on generated tetrahedralised grids: every level manifold with
//! positive volumes, the reported field error bounding the error at every removed vertex (measured
//! here by brute-force point location), replay equal to direct simplification, stops, bad input.

use super::*;
use crate::validate::{boundary_faces, check_manifold_tets, check_no_overlap};
use crate::Error;
use glam::DVec3;
use rustc_hash::FxHashMap;

/// A grid of `n³` cubes over `[0, 1]³`, each cut into the six tetrahedra around its main diagonal
/// (conforming: every cube face is cut along the diagonal through its lowest corner), with the field
/// `field` at the points.
pub(super) struct Generated {
    pub(super) points: Vec<[f64; 3]>,
    pub(super) tets: Vec<[u32; 4]>,
    pub(super) scalars: Vec<f64>,
}

pub(super) fn grid(n: usize, field: impl Fn(DVec3) -> f64) -> Generated {
    let id = |i: usize, j: usize, k: usize| (i + (n + 1) * (j + (n + 1) * k)) as u32;
    let mut points = Vec::new();
    for k in 0..=n {
        for j in 0..=n {
            for i in 0..=n {
                points.push([i, j, k].map(|c| c as f64 / n as f64));
            }
        }
    }
    let mut tets = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let corner = |d: [usize; 3]| id(i + d[0], j + d[1], k + d[2]);
                for perm in [
                    [0, 1, 2],
                    [0, 2, 1],
                    [1, 0, 2],
                    [1, 2, 0],
                    [2, 0, 1],
                    [2, 1, 0],
                ] {
                    let mut d = [0usize; 3];
                    let mut t = [corner(d); 4];
                    for (s, &axis) in perm.iter().enumerate() {
                        d[axis] = 1;
                        t[s + 1] = corner(d);
                    }
                    let x = t.map(|v| DVec3::from_array(points[v as usize]));
                    if (x[1] - x[0]).dot((x[2] - x[0]).cross(x[3] - x[0])) < 0.0 {
                        t.swap(2, 3);
                    }
                    tets.push(t);
                }
            }
        }
    }
    let scalars = points
        .iter()
        .map(|&p| field(DVec3::from_array(p)))
        .collect();
    Generated {
        points,
        tets,
        scalars,
    }
}

fn smooth(p: DVec3) -> f64 {
    (3.0 * p.x).sin() + (2.0 * p.y).cos() * p.z + 0.5 * p.z * p.z
}

impl Generated {
    pub(super) fn input(&self) -> TetInput<'_> {
        TetInput {
            points: &self.points,
            tets: &self.tets,
            scalars: &self.scalars,
        }
    }

    fn simplify(&self, params: &Params) -> Result<ProgressiveMesh> {
        simplify(self.input(), params, &mut |_| true)
    }
}

fn params(target_tets: usize) -> Params {
    Params {
        target_tets,
        boundary_tolerance: 1e-9,
        ..Params::default()
    }
}

/// The level's points and tetrahedra in original coordinates.
fn level(pm: &ProgressiveMesh, l: usize) -> (Vec<[f64; 3]>, Vec<[u32; 4]>, Vec<u32>) {
    let mut r = Replay::new(pm);
    r.set_level(pm, l);
    let mesh = r.mesh(pm.points().len());
    let points = mesh
        .point_ids
        .iter()
        .map(|&v| pm.points()[v as usize])
        .collect();
    (points, mesh.tets, mesh.point_ids)
}

/// Checks level `l` independently: manifold with positive volumes, no two tetrahedra overlapping
/// (probed at every original point), the volume of the unit cube
/// (the boundary is kept exactly), and the field errors ([`check_errors`]).
fn check_level(g: &Generated, pm: &ProgressiveMesh, l: usize) {
    let (points, tets, _) = level(pm, l);
    check_manifold_tets(&points, &tets).unwrap_or_else(|e| panic!("level {l}: {e}"));
    check_no_overlap(&points, &tets, &g.points).unwrap_or_else(|e| panic!("level {l}: {e}"));
    let x = |t: &[u32; 4]| t.map(|v| DVec3::from_array(points[v as usize]));
    let volume: f64 = tets.iter().map(|t| cost::volume6(&x(t)) / 6.0).sum();
    assert!((volume - 1.0).abs() < 1e-9, "level {l}: volume {volume}");
    check_errors(g, pm, l);
}

/// The error of every removed original vertex of level `l`, measured by brute force: `|f(v) - L(x)|`
/// with `L` the level's interpolant and `x` the vertex itself if a tetrahedron holds it (exact
/// barycentric coordinates, all ≥ -1e-9), else the nearest point of the level's boundary surface
/// (evaluated on that face). Returns the errors and how many vertices were outside.
fn measured_errors(g: &Generated, pm: &ProgressiveMesh, l: usize) -> (Vec<f64>, usize) {
    let (points, tets, ids) = level(pm, l);
    let x = |t: &[u32; 4]| t.map(|v| DVec3::from_array(points[v as usize]));
    let value = |k: u32| g.scalars[ids[k as usize] as usize];
    let boundary = boundary_faces(&tets);
    let mut kept = vec![false; g.points.len()];
    for &v in &ids {
        kept[v as usize] = true;
    }
    let (mut errors, mut outside) = (Vec::new(), 0);
    for v in (0..g.points.len()).filter(|&v| !kept[v]) {
        let p = DVec3::from_array(g.points[v]);
        let inside = tets.iter().find_map(|t| {
            let b = cost::barycentric(&x(t), p);
            b.iter()
                .all(|&c| c >= -1e-9)
                .then(|| (0..4).map(|k| b[k] * value(t[k])).sum::<f64>())
        });
        let at = inside.unwrap_or_else(|| {
            outside += 1;
            let (_, q, f) = boundary
                .iter()
                .map(|f| {
                    let [a, b, c] = f.map(|k| DVec3::from_array(points[k as usize]));
                    let q = crate::geometry::closest_point_on_triangle(p, a, b, c).0;
                    (q.distance(p), q, *f)
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .unwrap();
            // The face's linear interpolant at q, by the areas of the sub-triangles.
            let [a, b, c] = f.map(|k| DVec3::from_array(points[k as usize]));
            let n = (b - a).cross(c - a);
            let w = [
                (c - b).cross(q - b).dot(n),
                (a - c).cross(q - c).dot(n),
                (b - a).cross(q - a).dot(n),
            ];
            (0..3).map(|k| w[k] * value(f[k])).sum::<f64>() / w.iter().sum::<f64>()
        });
        errors.push((g.scalars[v] - at).abs());
    }
    (errors, outside)
}
/// Checks the errors of level `l` ([`measured_errors`]): every one at most the reported maximum,
/// which is their maximum, their RMS the reported one, the largest per-tetrahedron error of the
/// replayed level the maximum too. Returns how many removed vertices were outside the level.
fn check_errors(g: &Generated, pm: &ProgressiveMesh, l: usize) -> usize {
    let (errors, outside) = measured_errors(g, pm, l);
    let reported = pm.error(l);
    for &e in &errors {
        assert!(
            e <= reported.max_field_error + 1e-9,
            "level {l}: a removed vertex has error {e} > reported {reported:?} ({outside} outside)"
        );
    }
    let max = errors.iter().copied().fold(0.0, f64::max);
    assert!(
        (max - reported.max_field_error).abs() < 1e-9,
        "level {l}: max {max} vs {reported:?}"
    );
    let rms = if errors.is_empty() {
        0.0
    } else {
        (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt()
    };
    assert!(
        (rms - reported.rms_field_error).abs() < 1e-6,
        "level {l}: rms {rms} vs {reported:?}"
    );
    let mut r = Replay::new(pm);
    r.set_level(pm, l);
    let per_tet = r.field_errors();
    assert_eq!(per_tet.len(), reported.tets);
    let largest = per_tet.iter().copied().fold(0.0, f64::max);
    assert!(
        (largest - max).abs() < 1e-9,
        "level {l}: per-tetrahedron errors up to {largest}, measured {max}"
    );
    outside
}

#[test]
fn every_level_is_manifold_and_its_error_bounds_every_removed_vertex() {
    let g = grid(5, smooth);
    let pm = g.simplify(&params(0)).unwrap();
    let n = pm.levels();
    assert!(
        pm.error(0).tets < g.tets.len() / 5,
        "base mesh {:?}",
        pm.error(0)
    );
    assert_eq!(pm.error(n).tets, g.tets.len());
    assert_eq!(pm.error(n).max_field_error, 0.0);
    for l in (0..=n).step_by(7).chain([0, 1, n - 1, n]) {
        check_level(&g, &pm, l);
    }
}

#[test]
fn a_linear_field_simplifies_without_field_error() {
    let g = grid(4, |p| 2.0 * p.x - p.y + 3.0 * p.z);
    let pm = g.simplify(&params(0)).unwrap();
    assert!(pm.error(0).tets <= 12, "{:?}", pm.error(0));
    assert!(pm.error(0).max_field_error < 1e-12, "{:?}", pm.error(0));
    check_level(&g, &pm, 0);
}

#[test]
fn replay_to_a_level_equals_simplifying_directly_to_it() {
    let g = grid(4, smooth);
    let pm = g.simplify(&params(0)).unwrap();
    let n = pm.levels();
    let mut r = Replay::new(&pm);
    // Down to the base, up to the original, down to k again: each move replays splits or collapses.
    assert_eq!(r.set_level(&pm, 0), n);
    assert_eq!(r.tets(), pm.error(0).tets);
    assert_eq!(r.set_level(&pm, n), n);
    assert_eq!(r.mesh(g.points.len()).tets, g.tets);
    for k in [n / 3, n / 2, 2 * n / 3] {
        r.set_level(&pm, k);
        let direct = g.simplify(&params(pm.error(k).tets)).unwrap();
        let mut base = Replay::new(&direct);
        base.set_level(&direct, 0);
        assert_eq!(direct.levels(), n - k);
        assert_eq!(
            base.mesh(g.points.len()),
            r.mesh(g.points.len()),
            "level {k}"
        );
        assert_eq!(direct.error(0), pm.error(k));
    }
}

/// The filter simplifies only as far as asked and continues later: the sequence made in steps
/// (after an abort too) is the one a single run makes, each step's the one a run to its target
/// makes, and a cursor on the mesh keeps its mesh while levels go in below the base.
#[test]
fn a_reduction_continued_in_steps_makes_the_sequence_of_one_run() {
    let g = grid(4, smooth);
    let whole = g.simplify(&params(0)).unwrap();
    let mut r = Reduction::new(g.input(), &params(0)).unwrap();
    assert_eq!(r.reduce_to(0, &mut |_| false), Err(Error::Aborted));
    assert_eq!(r.mesh().levels(), 0);
    let mut replay = Replay::new(r.mesh());
    let m = g.tets.len();
    for target in [3 * m / 4, m / 2, m / 10, 0] {
        let before = r.mesh().levels();
        let at = replay.mesh(g.points.len());
        let added = r.reduce_to(target, &mut |_| true).unwrap();
        assert_eq!(r.mesh().levels(), before + added);
        assert!(r.mesh().error(0).tets <= target || r.exhausted());
        assert_eq!(
            &g.simplify(&params(target)).unwrap(),
            r.mesh(),
            "to {target}"
        );
        replay.rebase(r.mesh());
        assert_eq!(replay.mesh(g.points.len()), at, "the cursor's mesh kept");
        replay.set_level(r.mesh(), 0);
        assert_eq!(replay.tets(), r.mesh().error(0).tets);
    }
    assert!(r.exhausted());
    // Asked for 0 tetrahedra, the reduction stopped short: said, with where and why; a target it
    // reached is not.
    let reached = r.mesh().error(0).tets;
    assert!(reached > 0);
    let said = r.shortfall(0).expect("short of 0 tetrahedra");
    assert!(
        said.contains(&format!("stops at {reached} tetrahedra"))
            && said.contains(&format!("of the input's {m})"))
            && said.contains("short of the 0 asked")
            && said.contains("boundary tolerance"),
        "{said}"
    );
    assert_eq!(r.shortfall(reached), None);
    assert_eq!(r.into_mesh(), whole);
}

#[test]
fn the_maximum_field_error_stops_the_reduction() {
    let g = grid(5, smooth);
    let limit = 0.02;
    let pm = g
        .simplify(&Params {
            max_field_error: limit,
            ..params(0)
        })
        .unwrap();
    let free = g.simplify(&params(0)).unwrap();
    assert!(free.error(0).max_field_error > limit);
    assert!(pm.levels() > 0 && pm.levels() < free.levels());
    for l in 0..=pm.levels() {
        assert!(pm.error(l).max_field_error <= limit, "{:?}", pm.error(l));
    }
    check_level(&g, &pm, 0);
}

#[test]
fn a_target_count_is_reached() {
    let g = grid(5, smooth);
    let target = g.tets.len() / 4;
    let pm = g.simplify(&params(target)).unwrap();
    let reached = pm.error(0).tets;
    assert!(
        reached <= target && reached + 12 > target,
        "reached {reached}, target {target}"
    );
    assert_eq!(pm.level_for_tets(target), 0);
    assert_eq!(pm.level_for_tets(g.tets.len()), pm.levels());
}

#[test]
fn a_free_boundary_moves_within_its_quadric_cost_and_stays_manifold() {
    let g = grid(4, smooth);
    let pm = g
        .simplify(&Params {
            preserve_boundary: false,
            ..params(0)
        })
        .unwrap();
    for l in [0, pm.levels() / 2] {
        let (points, tets, _) = level(&pm, l);
        check_manifold_tets(&points, &tets).unwrap_or_else(|e| panic!("level {l}: {e}"));
    }
}

#[test]
fn bad_input_is_refused_with_a_message() {
    let g = grid(2, smooth);
    let run = |points: &[[f64; 3]], tets: &[[u32; 4]], scalars: &[f64], params: &Params| {
        simplify(
            TetInput {
                points,
                tets,
                scalars,
            },
            params,
            &mut |_| true,
        )
        .unwrap_err()
    };
    let p = Params::default();
    let mut inverted = g.tets.clone();
    inverted[3].swap(0, 1);
    let e = run(&g.points, &inverted, &g.scalars, &p);
    assert!(
        matches!(&e, Error::Mesh(m) if m.contains("inverted")),
        "{e}"
    );
    let mut nan = g.scalars.clone();
    nan[5] = f64::NAN;
    let e = run(&g.points, &g.tets, &nan, &p);
    assert!(
        matches!(&e, Error::Mesh(m) if m.contains("non-finite")),
        "{e}"
    );
    let e = run(&g.points, &g.tets, &g.scalars[1..], &p);
    assert!(matches!(&e, Error::Mesh(m) if m.contains("values")), "{e}");
    let e = run(&g.points, &[], &g.scalars, &p);
    assert!(matches!(&e, Error::Mesh(_)), "{e}");
    // Three tetrahedra on one face: not manifold.
    let pts = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.2, 0.2, 1.0],
        [0.2, 0.2, -1.0],
        [0.3, 0.3, 2.0],
    ];
    let tets = [[0, 1, 2, 3], [0, 2, 1, 4], [0, 1, 2, 5]];
    let e = run(&pts, &tets, &[0.0; 6], &p);
    assert!(
        matches!(&e, Error::Mesh(m) if m.contains("shared by 3")),
        "{e}"
    );
    for bad in [
        Params {
            field_weight: f64::NAN,
            ..Params::default()
        },
        Params {
            max_field_error: -1.0,
            ..Params::default()
        },
        Params {
            geometry_weight: 0.0,
            field_weight: 0.0,
            shape_weight: 0.0,
            ..Params::default()
        },
    ] {
        let e = run(&g.points, &g.tets, &g.scalars, &bad);
        assert!(matches!(e, Error::Parameter(_)), "{e}");
    }
}

#[test]
fn abort_is_an_error() {
    let g = grid(6, smooth);
    let e = simplify(g.input(), &params(0), &mut |_| false).unwrap_err();
    assert_eq!(e, Error::Aborted);
}
#[test]
fn coincident_points_are_merged_and_flat_tetrahedra_dropped() {
    let mut g = grid(3, smooth);
    // A copy of point 0 (a corner) used by a flat tetrahedron on the boundary face at z = 0, and by
    // one of the corner's tetrahedra in place of the corner.
    g.points.push(g.points[0]);
    g.scalars.push(g.scalars[0] + 0.25);
    let d = (g.points.len() - 1) as u32;
    let t = g.tets.iter().position(|t| t.contains(&0)).unwrap();
    g.tets[t] = g.tets[t].map(|v| if v == 0 { d } else { v });
    g.tets.push([0, d, 1, 4]);
    let pm = g.simplify(&params(0)).unwrap();
    assert_eq!(pm.cleaning(), (1, 1));
    assert_eq!(pm.original_tets().len(), g.tets.len() - 1);
    let n = pm.levels();
    // The merged point's value differs by 0.25 from the kept one's: the original level says so.
    assert!(
        (pm.error(n).max_field_error - 0.25).abs() < 1e-12,
        "{:?}",
        pm.error(n)
    );
    for l in [0, n / 2, n] {
        check_level(&g, &pm, l);
    }
}

#[test]
fn a_shape_weight_changes_the_order_and_keeps_every_level_valid() {
    let g = grid(4, smooth);
    let shaped = g
        .simplify(&Params {
            shape_weight: 1e-3,
            ..params(0)
        })
        .unwrap();
    let plain = g.simplify(&params(0)).unwrap();
    assert_ne!(shaped.error(0), plain.error(0));
    for l in [0, shaped.levels() / 2] {
        check_level(&g, &shaped, l);
    }
}

/// Progressive isosurfaces (§4): moving the level by splits and collapses keeps the surface equal to
/// marching tetrahedra on that level's mesh, watertight inside the cube, consistently oriented and
/// facing increasing values; the interval tree finds exactly the tetrahedra a linear scan finds.
#[test]
fn the_progressive_isosurface_equals_marching_tetrahedra_at_every_level() {
    use isosurface::{march_level, ProgressiveIsosurface};
    let g = grid(5, smooth);
    let pm = g.simplify(&params(0)).unwrap();
    let n = pm.levels();
    let isovalues = [0.4, 1.1];
    let mut replay = Replay::new(&pm);
    replay.set_level(&pm, 0);
    let mut iso = ProgressiveIsosurface::new(&pm, &replay, &isovalues).unwrap();
    let mut triangles_seen = 0;
    let mut jumped = [0; 2];
    for level in [1, 2, 5, n / 3, n / 2, n / 4, n, 3 * n / 4, 0, n - 1, n - 2] {
        // Both ways of moving: split by split, or a jump with the tree and surface rebuilt.
        jumped[usize::from(replay.jumps_to(&pm, level))] += 1;
        iso.set_level(&pm, &mut replay, level);
        assert_eq!(replay.level(), level);
        let reference = march_level(&pm, &replay, &isovalues);
        assert_eq!(iso.edge_triangles(), reference, "level {level}");
        let surface = iso.surface(&pm);
        triangles_seen += surface.triangles.len();
        let report = crate::validate::check_surface(
            &surface.points,
            &surface.triangles,
            Some([0.0, 1.0, 0.0, 1.0, 0.0, 1.0]),
        )
        .unwrap();
        report
            .passed()
            .unwrap_or_else(|e| panic!("level {level}: {e}"));
        for t in iso.edge_triangles() {
            let x = t.map(|p| {
                let (a, b) = (pm.points()[p.below as usize], pm.points()[p.above as usize]);
                let (fa, fb) = (g.scalars[p.below as usize], g.scalars[p.above as usize]);
                let s = (isovalues[p.iso as usize] - fa) / (fb - fa);
                DVec3::from_array(a).lerp(DVec3::from_array(b), s)
            });
            let normal = (x[1] - x[0]).cross(x[2] - x[0]);
            let up = DVec3::from_array(pm.points()[t[0].above as usize])
                - DVec3::from_array(pm.points()[t[0].below as usize]);
            assert!(normal.dot(up) >= -1e-12, "level {level}: {t:?} faces down");
        }
        // The interval tree against a linear scan, at vertex values and between them.
        let mut values: Vec<f64> = g.scalars.iter().step_by(17).copied().collect();
        values.extend([-10.0, 10.0, 0.4, 0.77]);
        for v in values {
            let mut found = iso.tree().crossing(v);
            found.sort_unstable();
            let scan: Vec<u32> = replay
                .live_tets()
                .filter(|(_, c)| {
                    let f = c.map(|k| g.scalars[k as usize]);
                    let lo = f.iter().copied().fold(f64::INFINITY, f64::min);
                    let hi = f.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                    lo < v && v <= hi
                })
                .map(|(t, _)| t)
                .collect();
            assert_eq!(found, scan, "level {level}, isovalue {v}");
        }
        assert_eq!(iso.tree().len(), replay.tets());
    }
    assert!(triangles_seen > 100, "{triangles_seen} triangles");
    assert!(
        jumped[0] >= 3 && jumped[1] >= 3,
        "replays, jumps: {jumped:?}"
    );
    // A new isovalue: through the tree or a scan, the same surface.
    let mut scanned = iso.clone();
    iso.set_isovalues(&pm, &replay, &[0.9], true).unwrap();
    scanned.set_isovalues(&pm, &replay, &[0.9], false).unwrap();
    assert_eq!(iso.edge_triangles(), scanned.edge_triangles());
    assert_eq!(iso.edge_triangles(), march_level(&pm, &replay, &[0.9]));
    assert!(iso.set_isovalues(&pm, &replay, &[f64::NAN], true).is_err());
}

/// [`grid`] bent into a quarter of a thick cylinder shell: `(x, y, z)` → radius `1 + x`, angle
/// `πy/2`, height `z`, so its inner and outer walls are curved and a simplified boundary leaves
/// removed vertices outside the mesh.
pub(super) fn bent(n: usize, field: impl Fn(DVec3) -> f64) -> Generated {
    let mut g = grid(n, |_| 0.0);
    for p in &mut g.points {
        let (r, a) = (1.0 + p[0], std::f64::consts::FRAC_PI_2 * p[1]);
        *p = [r * a.cos(), r * a.sin(), p[2]];
    }
    g.scalars = g
        .points
        .iter()
        .map(|&p| field(DVec3::from_array(p)))
        .collect();
    g
}

#[test]
fn removed_vertices_outside_a_curved_boundary_are_within_the_reported_error() {
    let g = bent(6, |p| (4.0 * p.x + 3.0 * p.y).cos() + p.z);
    let pm = g
        .simplify(&Params {
            boundary_tolerance: 0.1,
            ..params(0)
        })
        .unwrap();
    // Every level, each reached by replay from the original.
    let mut outside = 0;
    for l in 0..=pm.levels() {
        let (points, tets, _) = level(&pm, l);
        check_manifold_tets(&points, &tets).unwrap_or_else(|e| panic!("level {l}: {e}"));
        check_no_overlap(&points, &tets, &g.points).unwrap_or_else(|e| panic!("level {l}: {e}"));
        outside += check_errors(&g, &pm, l);
    }
    assert!(
        outside > 0,
        "no removed vertex ended outside: the test tests nothing"
    );
}

/// The union of pieces' tetrahedra (original point ids) and whether it is conforming as the cube:
/// no face of more than two tetrahedra, and every face of one tetrahedron on the cube's boundary
/// (its three points on one side of the unit cube), so no face of a piece is left open inside.
fn conforming_union(g: &Generated, pieces: &[Vec<[u32; 4]>]) -> std::result::Result<(), String> {
    let mut faces: FxHashMap<[u32; 3], usize> = FxHashMap::default();
    for t in pieces.iter().flatten() {
        for skip in 0..4 {
            let mut f: Vec<u32> = (0..4).filter(|&k| k != skip).map(|k| t[k]).collect();
            f.sort_unstable();
            *faces.entry([f[0], f[1], f[2]]).or_default() += 1;
        }
    }
    for (f, n) in faces {
        let on_side = (0..3).any(|a| {
            [0.0, 1.0]
                .iter()
                .any(|&s| f.iter().all(|&v| g.points[v as usize][a] == s))
        });
        if n > 2 || (n == 1 && !on_side) {
            return Err(format!("face {f:?} of {n} tetrahedra"));
        }
    }
    Ok(())
}

/// A cube cut into two pieces along the plane x = 0.5 (its tetrahedra by their centroids), each
/// reduced on its own to a fifth as a rank of a distributed run would: keeping its seam points (its
/// boundary points the other piece has too), the pieces' meshes together are conforming at the
/// levels tried, and every seam point is still there; reduced without keeping them (the seam is
/// flat: collapses along it are allowed), they are not.
#[test]
fn pieces_reduced_apart_keeping_their_seam_points_stay_conforming() {
    let g = grid(6, |p| (3.0 * p.x).sin() + p.y * p.z);
    let centroid_x = |t: &[u32; 4]| t.iter().map(|&v| g.points[v as usize][0]).sum::<f64>() / 4.0;
    let (left, right): (Vec<[u32; 4]>, Vec<[u32; 4]>) =
        g.tets.iter().partition(|t| centroid_x(t) < 0.5);
    fn piece<'a>(g: &'a Generated, tets: &'a [[u32; 4]]) -> TetInput<'a> {
        TetInput {
            points: &g.points,
            tets,
            scalars: &g.scalars,
        }
    }
    // What each piece sends the other: its boundary points inside the other's bounds (on this
    // grid, the points at x = 0.5 and, from the right piece, nothing beyond).
    let pieces = [piece(&g, &left), piece(&g, &right)];
    let boundaries = pieces.map(|p| p.boundary_points());
    let mut boxes: Vec<[f64; 6]> = pieces
        .iter()
        .map(|p| {
            crate::geometry::bounds_of(p.tets.iter().flatten().map(|&v| &g.points[v as usize]))
        })
        .collect();
    // Two more ranks: one whose piece is far away, one with an empty piece.
    boxes.push([5.0, 6.0, 0.0, 1.0, 0.0, 1.0]);
    boxes.push(
        [f64::INFINITY, f64::NEG_INFINITY]
            .repeat(3)
            .try_into()
            .unwrap(),
    );
    let sent = [0, 1].map(|k| pieces[k].seam_messages(&boundaries[k], &boxes, k));
    for (k, (counts, coordinates)) in sent.iter().enumerate() {
        assert_eq!(counts.len(), 4, "a count per rank");
        assert_eq!(counts[k], 0, "a piece sends itself nothing");
        assert_eq!(counts[2..], [0, 0], "nor the far and the empty pieces");
        assert_eq!(counts.iter().sum::<usize>(), coordinates.len());
        assert!(
            coordinates.len() < boundaries[k].len(),
            "only the boundary points near the other piece are sent"
        );
    }
    let seams = [
        pieces[0].seam_points(&boundaries[0], &sent[1].1),
        pieces[1].seam_points(&boundaries[1], &sent[0].1),
    ];
    assert!(
        !seams[0].is_empty() && seams[0] == seams[1],
        "the pieces share their seam"
    );
    // Everything both pieces' whole boundaries have in common is found from the messages.
    let all = |k: usize| -> Vec<[f64; 3]> {
        boundaries[k]
            .iter()
            .map(|&v| g.points[v as usize])
            .collect()
    };
    assert_eq!(seams[0], pieces[0].seam_points(&boundaries[0], &all(1)));
    assert_eq!(seams[1], pieces[1].seam_points(&boundaries[1], &all(0)));
    let reduce = |tets: &[[u32; 4]], kept: &[u32]| {
        let mut r = Reduction::keeping(piece(&g, tets), &params(0), kept).unwrap();
        r.reduce_to(tets.len() / 5, &mut |_| true).unwrap();
        r.into_mesh()
    };
    let level_tets = |pm: &ProgressiveMesh, l: usize| -> Vec<[u32; 4]> {
        let (_, tets, ids) = level(pm, l);
        tets.iter().map(|t| t.map(|k| ids[k as usize])).collect()
    };
    let kept = [reduce(&left, &seams[0]), reduce(&right, &seams[1])];
    for pm in &kept {
        assert!(pm.levels() > 0, "the piece was reduced");
        let (_, _, ids) = level(pm, 0);
        assert!(
            seams[0].iter().all(|v| ids.binary_search(v).is_ok()),
            "seam points kept"
        );
    }
    for (a, b) in [
        (0, 0),
        (kept[0].levels() / 2, kept[1].levels()),
        (kept[0].levels(), 0),
    ] {
        conforming_union(&g, &[level_tets(&kept[0], a), level_tets(&kept[1], b)])
            .unwrap_or_else(|e| panic!("levels {a} and {b}: {e}"));
    }
    let apart = [reduce(&left, &[]), reduce(&right, &[])];
    assert!(
        conforming_union(&g, &[level_tets(&apart[0], 0), level_tets(&apart[1], 0)]).is_err(),
        "without their seam points kept the pieces crack apart: the test tests nothing"
    );
}

/// Three grids of cubes, the second meeting the first only along an edge and the third only at a
/// corner (their coincident points merged by the cleaning): the input is not manifold there. The
/// reduction cuts it at these pinches and keeps the pinch points, so every level is the three parts,
/// each a manifold mesh of its unit cube, meeting as they did; the errors bound every removed vertex.
#[test]
fn parts_meeting_at_an_edge_or_a_corner_are_reduced_apart() {
    let cube = grid(3, smooth);
    let shifts = [DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0), DVec3::splat(-1.0)];
    let mut g = Generated {
        points: Vec::new(),
        tets: Vec::new(),
        scalars: Vec::new(),
    };
    for shift in shifts {
        let base = g.points.len() as u32;
        for p in &cube.points {
            let p = DVec3::from_array(*p) + shift;
            g.points.push(p.to_array());
            g.scalars.push(smooth(p));
        }
        g.tets.extend(cube.tets.iter().map(|t| t.map(|v| v + base)));
    }
    // Without the cut, the mesh is refused as it was before pinches were handled.
    assert!(check_manifold_tets(&g.points, &merged_tets(&g)).is_err());
    let pm = g.simplify(&params(0)).unwrap();
    assert!(pm.levels() > 100, "{} levels", pm.levels());
    let pinch = |p: &[f64; 3]| (p[0] == 1.0 && p[1] == 1.0) || *p == [0.0; 3];
    let part = |c: DVec3| {
        shifts
            .iter()
            .position(|&s| (c - s).cmpge(DVec3::ZERO).all() && (c - s).cmple(DVec3::ONE).all())
            .expect("a centroid outside the three cubes")
    };
    for l in [0, pm.levels() / 3, pm.levels()] {
        let (points, tets, _) = level(&pm, l);
        let mut parts = vec![Vec::new(); 3];
        for t in &tets {
            let c = t
                .iter()
                .map(|&v| DVec3::from_array(points[v as usize]))
                .sum::<DVec3>()
                / 4.0;
            parts[part(c)].push(*t);
        }
        for (part, pinches) in parts.iter().zip([5, 4, 1]) {
            let mut corners: Vec<u32> = part.iter().flatten().copied().collect();
            corners.sort_unstable();
            corners.dedup();
            let kept = corners
                .iter()
                .filter(|&&v| pinch(&points[v as usize]))
                .count();
            assert_eq!(kept, pinches, "level {l}: each part keeps its pinch points");
            check_manifold_tets(&points, part).unwrap_or_else(|e| panic!("level {l}: {e}"));
            let x = |t: &[u32; 4]| t.map(|v| DVec3::from_array(points[v as usize]));
            let volume: f64 = part.iter().map(|t| cost::volume6(&x(t)) / 6.0).sum();
            assert!((volume - 1.0).abs() < 1e-9, "level {l}: volume {volume}");
        }
        check_no_overlap(&points, &tets, &g.points).unwrap_or_else(|e| panic!("level {l}: {e}"));
        check_errors(&g, &pm, l);
    }
}

/// `g`'s tetrahedra with coincident points merged into the first.
fn merged_tets(g: &Generated) -> Vec<[u32; 4]> {
    let mut first: FxHashMap<[u64; 3], u32> = FxHashMap::default();
    let keep: Vec<u32> = g
        .points
        .iter()
        .enumerate()
        .map(|(v, p)| *first.entry(p.map(f64::to_bits)).or_insert(v as u32))
        .collect();
    g.tets.iter().map(|t| t.map(|v| keep[v as usize])).collect()
}
