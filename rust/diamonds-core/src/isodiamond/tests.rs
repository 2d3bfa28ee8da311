use super::*;
use crate::fields::{marschner_lobb, sample, sphere_distance, torus_distance, unit_grid};
use crate::validate::{canonical_triangles, check_interval_volume, check_surface};
use crate::{interval, isosurface};

fn hierarchy(grid: Grid, values: &[f32]) -> Hierarchy {
    Hierarchy::build_for_isosurfaces(grid, ScalarSlice::F32(values)).unwrap()
}

/// Odd sizes (far faces inside the lattice), a power of two plus one, small and flat grids.
fn volumes() -> Vec<(&'static str, Grid, Vec<f32>)> {
    let ml = |dims| {
        let g = unit_grid(dims);
        let v = sample(&g, |x, y, z| marschner_lobb(x, y, z) as f32);
        (g, v)
    };
    let (g1, v1) = ml([33, 29, 41]);
    let (g2, v2) = ml([17, 17, 17]);
    let g3 = unit_grid([41, 23, 37]);
    let v3 = sample(&g3, |x, y, z| torus_distance(0.55, 0.25)(x, y, z) as f32);
    let g4 = unit_grid([33, 33, 33]);
    let v4 = sample(&g4, |x, y, z| sphere_distance(0.6)(x, y, z) as f32);
    // Bytes: samples equal to the levels.
    let v5: Vec<f32> = v1.iter().map(|f| (f * 10.0).round()).collect();
    vec![
        ("marschner-lobb 33x29x41", g1, v1),
        ("marschner-lobb 17^3", g2, v2),
        ("torus 41x23x37", g3, v3),
        ("sphere 33^3", g4, v4),
        ("rounded marschner-lobb", g1, v5),
    ]
}

fn ladder(grid: &Grid) -> Vec<f64> {
    [0.04, 0.01, 0.0025].map(|f| f * grid.diagonal()).to_vec()
}

/// The `model` hierarchy of `target` on the test [`ladder`], without progress.
fn built(h: &Hierarchy, grid: &Grid, v: &[f32], target: Target, model: Model) -> Isodiamonds {
    build(
        h,
        ScalarSlice::F32(v),
        target,
        model,
        &ladder(grid),
        &mut |_| true,
    )
    .unwrap()
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    DVec3::from(a).distance(DVec3::from(b))
}

/// The same triangles on the same points (indices, values, sources, weights within 1/512), every
/// point within 1/512 of the longest edge a leaf of `grid` can have (the root cube's diagonal) and
/// within one voxel diagonal / 512 at rung 0, plus rounding; watertight and oriented but on the
/// grid's bounds.
fn assert_same_surface(h: &Isodiamonds, full: &IsoSurface, got: &IsoSurface, what: &str) {
    assert_eq!(got.points.len(), full.points.len(), "{what}: points");
    assert_eq!(
        canonical_triangles(&got.triangles),
        canonical_triangles(&full.triangles),
        "{what}: triangles"
    );
    assert_eq!(got.values, full.values, "{what}: values");
    // The same samples per point, at weights within the quantisation of the crossings.
    assert_eq!(got.sources, full.sources, "{what}: sources");
    for (w, v) in got.weights.iter().zip(&full.weights) {
        assert!(
            (w - v).abs() <= 1.0 / 512.0 + 1e-12,
            "{what}: weight {w} vs {v}"
        );
    }
    let g = h.grid();
    let voxel = DVec3::from(g.spacing).length();
    let longest = (h.lattice.size() as f64) * voxel;
    let exact_rung = got.error_bound == 0.0;
    let slack = if exact_rung { voxel } else { longest } / 512.0 + 1e-12;
    for (p, q) in got.points.iter().zip(&full.points) {
        assert!(distance(*p, *q) <= slack, "{what}: {p:?} vs {q:?}");
    }
    if !got.triangles.is_empty() {
        check_surface(&got.points, &got.triangles, Some(g.bounds()))
            .unwrap()
            .passed()
            .unwrap_or_else(|e| panic!("{what}: {e}"));
    }
}

#[test]
fn isosurfaces_equal_the_full_hierarchy_at_every_rung_and_between() {
    for (name, grid, v) in volumes() {
        let h = hierarchy(grid, &v);
        let (lo, hi) = h.value_range();
        for isovalue in [0.5 * (lo + hi), lo + 0.3 * (hi - lo)] {
            let target = Target::Isosurface(isovalue.round().max(lo + 1e-3));
            let mut sizes = Vec::new();
            for model in [Model::Relevant, Model::Minimal] {
                let iso = built(&h, &grid, &v, target, model);
                sizes.push((iso.counts(), iso.to_bytes().len()));
                let Target::Isosurface(value) = target else {
                    unreachable!()
                };
                for (rung, &tol) in iso.ladder().iter().enumerate() {
                    let query = IsoQuery {
                        compute_normals: false,
                        ..IsoQuery::new(value, tol)
                    };
                    let full = isosurface::extract(&h, ScalarSlice::F32(&v), &query).unwrap();
                    let what = format!("{name} {model:?} at {value} rung {rung}");
                    let got = iso.isosurface(tol).unwrap();
                    assert!(!got.triangles.is_empty() || full.triangles.is_empty());
                    assert_same_surface(&iso, &full, &got, &what);
                    // Between this rung and the coarser one: this rung's surface.
                    if rung > 0 {
                        let between = 0.6 * tol + 0.4 * iso.ladder()[rung - 1];
                        assert_eq!(iso.rung(between).unwrap(), rung);
                        assert_eq!(iso.isosurface(between).unwrap(), got, "{what}");
                    }
                }
            }
            let ((ri, ri_bytes), (mi, mi_bytes)) = (sizes[0], sizes[1]);
            assert_eq!(ri.active, mi.active, "{name}");
            assert_eq!(ri.creation, mi.creation, "{name}");
            assert_eq!(mi.relevant, 0);
            // RI holds every ancestor: its only orphans are root corners in the grid.
            assert!(ri.orphans <= 8, "{name}: {} orphans in RI", ri.orphans);
            assert_eq!(
                ri.crossings, mi.crossings,
                "{name}: the same isovertices (§7.2)"
            );
            assert!(
                mi_bytes < ri_bytes,
                "{name}: MI {mi_bytes} B, RI {ri_bytes} B"
            );
        }
    }
}

/// Marching straight from the stored crossings gives the points, values and triangles, in order,
/// of marching tetrahedra on the classes wherever no vertex of a leaf holds the isovalue; where
/// one does (integer samples at an integer isovalue) it declines, and the latter runs.
#[test]
fn marching_from_stored_crossings_equals_marching_on_classes() {
    let (mut taken, mut declined) = (0, 0);
    for (name, grid, v) in volumes() {
        let h = hierarchy(grid, &v);
        let (lo, hi) = h.value_range();
        for value in [0.5 * (lo + hi), (0.5 * (lo + hi)).round()] {
            for model in [Model::Relevant, Model::Minimal] {
                let target = Target::Isosurface(value);
                let iso = built(&h, &grid, &v, target, model);
                for rung in 0..iso.ladder().len() {
                    let (leaves, classes): (Vec<Tet>, Vec<[u8; 4]>) =
                        iso.leaves(rung).unwrap().into_iter().unzip();
                    let generic = marching_with_sources(&OnClasses(&iso), &leaves, false)
                        .unwrap()
                        .0;
                    let lookup = iso.crossing_lookup();
                    let listed = marching_on_listed_edges(
                        &leaves,
                        target.class_levels(),
                        |k, _| classes[k].map(f64::from),
                        |p| iso.grid_index(p),
                        iso.points.len(),
                        |(i, j, l)| lookup.find(i, j, l as u8),
                    )
                    .unwrap();
                    match listed {
                        Some(_) => taken += 1,
                        None => declined += 1,
                    }
                    let got = iso.isosurface_at(rung).unwrap();
                    let what = format!("{name} {model:?} at {value} rung {rung}");
                    assert_eq!(got.points, generic.points, "{what}");
                    assert_eq!(got.values, generic.values, "{what}");
                    assert_eq!(got.sources, generic.sources, "{what}");
                    assert_eq!(got.weights, generic.weights, "{what}");
                    assert_eq!(got.triangles, generic.triangles, "{what}");
                }
            }
        }
    }
    assert!(
        taken > 0 && declined > 0,
        "{taken} taken, {declined} declined"
    );
}

#[test]
fn interval_volumes_equal_the_full_hierarchy_at_every_rung() {
    for (name, grid, v) in volumes() {
        let h = hierarchy(grid, &v);
        let (lo, hi) = h.value_range();
        let range = [lo + 0.35 * (hi - lo), lo + 0.6 * (hi - lo)].map(f64::round);
        let range = if range[0] < range[1] {
            range
        } else {
            [lo + 0.35 * (hi - lo), lo + 0.6 * (hi - lo)]
        };
        for model in [Model::Relevant, Model::Minimal] {
            let iso = built(&h, &grid, &v, Target::IntervalVolume(range), model);
            for (rung, &tol) in iso.ladder().iter().enumerate() {
                let what = format!("{name} {model:?} {range:?} rung {rung}");
                let full =
                    interval::extract(&h, ScalarSlice::F32(&v), &IntervalQuery::new(range, tol))
                        .unwrap();
                let got = iso.interval_volume(tol).unwrap();
                assert!(!full.tets.is_empty(), "{what}");
                if got.sources != full.sources {
                    let only = |a: &[[u32; 2]], b: &[[u32; 2]]| {
                        a.iter()
                            .filter(|x| !b.contains(x))
                            .take(5)
                            .copied()
                            .collect::<Vec<_>>()
                    };
                    panic!(
                        "{what}: {} vs {} points, only here {:?}, only in full {:?}",
                        got.sources.len(),
                        full.sources.len(),
                        only(&got.sources, &full.sources),
                        only(&full.sources, &got.sources)
                    );
                }
                let sorted = |tets: &[[u32; 4]], levels: &[u8]| {
                    let mut t: Vec<([u32; 4], u8)> = (tets.iter().zip(levels))
                        .map(|(t, &l)| {
                            let mut t = *t;
                            t.sort_unstable();
                            (t, l)
                        })
                        .collect();
                    t.sort_unstable();
                    t
                };
                assert_eq!(
                    sorted(&got.tets, &got.levels),
                    sorted(&full.tets, &full.levels),
                    "{what}: tetrahedra"
                );
                for (k, [i, j]) in got.sources.iter().enumerate() {
                    let edge = distance(
                        grid.point(grid.ijk(*i as usize)),
                        grid.point(grid.ijk(*j as usize)),
                    );
                    let d = distance(got.points[k], full.points[k]);
                    assert!(d <= edge / 512.0 + 1e-12, "{what}: point {k} {d} off");
                    assert!((got.weights[k] - full.weights[k]).abs() <= 1.0 / 512.0 + 1e-12);
                }
                // Conforming with the true values at the points (the same names as the full one's).
                check_interval_volume(&got.points, &full.values, &got.tets, grid.bounds(), range)
                    .unwrap_or_else(|e| panic!("{what}: {e}"));
                assert!(got.values.is_empty());
            }
        }
    }
}

/// MI surfaces have no two triangles that cross (§7: the closure on the creation isodiamonds'
/// children keeps patches from overlapping): every pair of triangles whose boxes meet and that share
/// no point is checked by exact segment–triangle tests on the quantised positions.
#[test]
fn minimal_isosurfaces_do_not_self_intersect() {
    // The check finds two triangles that cross.
    let crossing = IsoSurface {
        points: vec![
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [0.0, 2.0, 0.0],
            [0.5, 0.5, -1.0],
            [0.5, 0.5, 1.0],
            [3.0, 3.0, 0.0],
        ],
        triangles: vec![[0, 1, 2], [3, 4, 5]],
        ..IsoSurface::default()
    };
    assert_eq!(self_intersections(&crossing), 1);
    for (name, grid, v) in volumes().into_iter().take(3) {
        let h = hierarchy(grid, &v);
        let (lo, hi) = h.value_range();
        let target = Target::Isosurface(0.5 * (lo + hi));
        let iso = built(&h, &grid, &v, target, Model::Minimal);
        for &tol in iso.ladder() {
            let s = iso.isosurface(tol).unwrap();
            let crossing = self_intersections(&s);
            assert_eq!(crossing, 0, "{name} at {tol}: {crossing} crossing pairs");
        }
    }
}

/// Pairs of triangles sharing no point where an edge of one passes through the other's interior.
fn self_intersections(s: &IsoSurface) -> usize {
    let p = |i: u32| DVec3::from(s.points[i as usize]);
    let boxes: Vec<(DVec3, DVec3)> = (s.triangles.iter())
        .map(|t| {
            let q = t.map(p);
            (q[0].min(q[1]).min(q[2]), q[0].max(q[1]).max(q[2]))
        })
        .collect();
    // Sweep along x.
    let mut order: Vec<usize> = (0..boxes.len()).collect();
    order.sort_by(|&a, &b| boxes[a].0.x.total_cmp(&boxes[b].0.x));
    let mut count = 0;
    for (k, &a) in order.iter().enumerate() {
        for &b in &order[k + 1..] {
            if boxes[b].0.x > boxes[a].1.x {
                break;
            }
            let (ta, tb) = (s.triangles[a], s.triangles[b]);
            if ta.iter().any(|i| tb.contains(i))
                || (boxes[a].0.cmpgt(boxes[b].1) | boxes[b].0.cmpgt(boxes[a].1)).any()
            {
                continue;
            }
            let (qa, qb) = (ta.map(p), tb.map(p));
            let pierces = |q: [DVec3; 3], r: [DVec3; 3]| {
                (0..3).any(|e| segment_hits_triangle(q[e], q[(e + 1) % 3], r))
            };
            if pierces(qa, qb) || pierces(qb, qa) {
                count += 1;
            }
        }
    }
    count
}

/// Does the segment `ab` cross the interior of triangle `t` (strictly, with a relative margin)?
fn segment_hits_triangle(a: DVec3, b: DVec3, t: [DVec3; 3]) -> bool {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let (da, db) = (n.dot(a - t[0]), n.dot(b - t[0]));
    let eps = 1e-9 * n.length() * (b - a).length();
    if !((da > eps && db < -eps) || (da < -eps && db > eps)) {
        return false;
    }
    let x = a + (b - a) * (da / (da - db));
    let side = |i: usize| n.dot((t[(i + 1) % 3] - t[i]).cross(x - t[i]));
    let m = 1e-9 * n.length_squared();
    (0..3).all(|i| side(i) > m)
}

#[test]
fn saved_hierarchies_extract_the_same() {
    let (name, grid, v) = volumes().swap_remove(2);
    let h = hierarchy(grid, &v);
    let (lo, hi) = h.value_range();
    for target in [
        Target::Isosurface(0.0),
        Target::IntervalVolume([lo + 0.1 * (hi - lo), 0.0]),
    ] {
        for model in [Model::Relevant, Model::Minimal] {
            let iso = built(&h, &grid, &v, target, model);
            let bytes = iso.to_bytes();
            let back = Isodiamonds::from_bytes(&bytes).unwrap();
            assert_eq!(back.to_bytes(), bytes, "{name}");
            assert_eq!(back.counts(), iso.counts());
            assert_eq!((back.target(), back.model()), (target, model));
            assert_eq!(back.ladder(), iso.ladder());
            for &tol in iso.ladder() {
                match target {
                    Target::Isosurface(_) => {
                        assert_eq!(back.isosurface(tol).unwrap(), iso.isosurface(tol).unwrap())
                    }
                    Target::IntervalVolume(_) => assert_eq!(
                        back.interval_volume(tol).unwrap(),
                        iso.interval_volume(tol).unwrap()
                    ),
                }
            }
            // Every truncation and a flipped magic are errors, not panics.
            for n in 0..bytes.len() {
                assert!(Isodiamonds::from_bytes(&bytes[..n]).is_err(), "{n} bytes");
            }
            let mut longer = bytes.clone();
            longer.push(0);
            assert!(Isodiamonds::from_bytes(&longer).is_err());
            let mut other = bytes.clone();
            other[0] = b'X';
            assert!(matches!(
                Isodiamonds::from_bytes(&other),
                Err(Error::Isodiamonds(_))
            ));
        }
    }
}

#[test]
fn bad_input_is_refused() {
    let (_, grid, v) = volumes().swap_remove(1);
    let h = hierarchy(grid, &v);
    let s = ScalarSlice::F32(&v);
    let l = ladder(&grid);
    let m = Model::Minimal;
    for target in [
        Target::Isosurface(f64::NAN),
        Target::IntervalVolume([0.5, 0.5]),
        Target::IntervalVolume([0.6, 0.5]),
        Target::IntervalVolume([f64::NEG_INFINITY, 0.5]),
    ] {
        assert!(matches!(
            build(&h, s, target, m, &l, &mut |_| true),
            Err(Error::Parameter(_))
        ));
    }
    let t = Target::Isosurface(0.5);
    for bad in [vec![0.1, 0.2], vec![0.1, 0.0], vec![f64::NAN], vec![0.1; 8]] {
        assert!(matches!(
            build(&h, s, t, m, &bad, &mut |_| true),
            Err(Error::Parameter(_))
        ));
    }
    let short = ScalarSlice::F32(&v[1..]);
    assert!(matches!(
        build(&h, short, t, m, &l, &mut |_| true),
        Err(Error::Length { .. })
    ));
    // Progress: from 0 to 1, one report per rung after the types; false stops the build.
    let mut seen = Vec::new();
    let iso = build(&h, s, t, m, &l, &mut |f| {
        seen.push(f);
        true
    })
    .unwrap();
    assert_eq!(seen.len(), l.len() + 3, "{seen:?}");
    assert!(seen[0] == 0.0 && seen[seen.len() - 1] == 1.0, "{seen:?}");
    assert!(seen.windows(2).all(|w| w[0] < w[1]), "{seen:?}");
    for stop in [-1.0, 0.5] {
        assert_eq!(
            build(&h, s, t, m, &l, &mut |f| f <= stop).unwrap_err(),
            Error::Aborted
        );
    }
    assert!(iso.interval_volume(0.1).is_err());
    assert!(iso.isosurface(-1.0).is_err());
    assert!(iso.isosurface(f64::NAN).is_err());
    let iv = built(&h, &grid, &v, Target::IntervalVolume([0.2, 0.5]), m);
    assert!(iv.isosurface(0.1).is_err());
    // A range missing the data: nothing stored, empty extraction.
    let none = built(&h, &grid, &v, Target::IntervalVolume([5.0, 6.0]), m);
    assert_eq!(none.counts(), Counts::default());
    assert!(none.interval_volume(0.0).unwrap().tets.is_empty());
}
