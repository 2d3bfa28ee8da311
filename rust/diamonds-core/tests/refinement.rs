//! End-to-end properties of the hierarchy on generated volumes: conformity, exact volume, the tolerance
//! at every sample (independent brute force), lossless at 0, monotone tet counts, budget and region of
//! interest, every sample type.

use diamonds::fields::{marschner_lobb_u8, sample, sphere_distance, unit_grid};
use diamonds::validate::{check_mesh, check_tolerance};
use diamonds::{Grid, Hierarchy, Query, ScalarSlice, Volume};

fn build(grid: Grid, s: ScalarSlice<'_>) -> Hierarchy {
    Hierarchy::build(grid, s, &mut |_| true).expect("build")
}

#[test]
fn tolerance_holds_at_every_sample_on_odd_dims() {
    for dims in [
        [17, 17, 17],
        [33, 20, 17],
        [10, 3, 7],
        [2, 2, 2],
        [40, 9, 26],
        [130, 2, 3],
        [3, 70, 2],
    ] {
        let (g, v) = marschner_lobb_u8(dims);
        let h = build(g, ScalarSlice::U8(&v));
        let vol = Volume::new(g, &v[..]).unwrap();
        let mut last = usize::MAX;
        for tol in [0.0, 0.5, 2.0, 8.0, 40.0, 1000.0] {
            let m = h.query(&Query::tolerance(tol)).unwrap();
            check_mesh(&m, &g).unwrap_or_else(|e| panic!("{dims:?} tol {tol}: {e}"));
            let worst = check_tolerance(&m, &vol, tol, None)
                .unwrap_or_else(|e| panic!("{dims:?} tol {tol}: {e}"));
            assert!(
                m.max_error <= tol,
                "{dims:?}: reported {} > {tol}",
                m.max_error
            );
            assert!(
                worst <= m.max_error + 1e-9,
                "{dims:?}: measured {worst} above the reported bound {}",
                m.max_error
            );
            assert!(
                m.tets.len() <= last,
                "{dims:?}: tet count grew with the tolerance"
            );
            last = m.tets.len();
            if tol == 0.0 {
                assert_eq!(worst, 0.0);
            }
        }
    }
}

#[test]
fn every_sample_type_is_read_in_place() {
    let g = unit_grid([19, 12, 9]);
    let f = |x: f64, y: f64, z: f64| 100.0 * sphere_distance(0.6)(x, y, z);
    let as_f64 = sample(&g, f);
    let check = |s: ScalarSlice<'_>, tol: f64| {
        let h = build(g, s);
        let m = h.query(&Query::tolerance(tol)).unwrap();
        check_mesh(&m, &g).unwrap();
        diamonds::with_volume!(g, s, |v| check_tolerance(&m, &v, tol, None)).unwrap();
        Ok::<usize, diamonds::Error>(m.tets.len())
    };
    let u8s: Vec<u8> = as_f64.iter().map(|v| (v + 128.0) as u8).collect();
    let i8s: Vec<i8> = as_f64.iter().map(|v| *v as i8).collect();
    let u16s: Vec<u16> = as_f64.iter().map(|v| (v * 10.0 + 30000.0) as u16).collect();
    let i16s: Vec<i16> = as_f64.iter().map(|v| (v * 10.0) as i16).collect();
    let u32s: Vec<u32> = as_f64.iter().map(|v| (v * 1000.0 + 1e6) as u32).collect();
    let i32s: Vec<i32> = as_f64.iter().map(|v| (v * 1000.0) as i32).collect();
    let f32s: Vec<f32> = as_f64.iter().map(|v| *v as f32).collect();
    for tol in [0.0, 3.0] {
        check(ScalarSlice::U8(&u8s), tol).unwrap();
        check(ScalarSlice::I8(&i8s), tol).unwrap();
        check(ScalarSlice::U16(&u16s), tol * 10.0).unwrap();
        check(ScalarSlice::I16(&i16s), tol * 10.0).unwrap();
        check(ScalarSlice::U32(&u32s), tol * 1000.0).unwrap();
        check(ScalarSlice::I32(&i32s), tol * 1000.0).unwrap();
        check(ScalarSlice::F32(&f32s), tol).unwrap();
        check(ScalarSlice::F64(&as_f64), tol).unwrap();
    }
}

#[test]
fn linear_field_needs_only_the_base_mesh() {
    let g = unit_grid([33, 33, 33]);
    let v = sample(&g, |x, y, z| 3.0 * x - y + 0.5 * z);
    let h = build(g, ScalarSlice::F64(&v));
    let m = h.query(&Query::tolerance(1e-9)).unwrap();
    assert_eq!(
        m.tets.len(),
        6,
        "a 2^k+1 grid of a linear field is the six base tetrahedra"
    );
    assert_eq!(h.base_tetrahedra(), 6);
}

#[test]
fn budget_takes_the_largest_errors_first() {
    let (g, v) = marschner_lobb_u8([33, 33, 33]);
    let h = build(g, ScalarSlice::U8(&v));
    let vol = Volume::new(g, &v[..]).unwrap();
    let full = h.query(&Query::tolerance(0.0)).unwrap();
    let mut last_tets = 0;
    let mut errors = Vec::new();
    for budget in [500, 2000, 20000, 100000] {
        let q = Query {
            tolerance: 0.0,
            max_tetrahedra: budget,
            region_of_interest: None,
        };
        let m = h.query(&q).unwrap();
        check_mesh(&m, &g).unwrap();
        assert!(
            m.tets.len() <= budget.max(h.base_tetrahedra()),
            "{} > {budget}",
            m.tets.len()
        );
        assert!(m.tets.len() < full.tets.len());
        // The reported bound really bounds the error.
        let worst = check_tolerance(&m, &vol, m.max_error, None).unwrap();
        assert!(worst <= m.max_error);
        // A larger budget continues the same split sequence. (The max error is not strictly monotone:
        // a child diamond's exact error can exceed its parent's, up to twice, Marchesin §4.2.)
        assert!(m.tets.len() >= last_tets);
        last_tets = m.tets.len();
        errors.push(m.max_error);
    }
    assert!(errors[3] < 0.75 * errors[0], "{errors:?}");
}

#[test]
fn region_of_interest_refines_inside_only() {
    let (g, v) = marschner_lobb_u8([33, 33, 33]);
    let h = build(g, ScalarSlice::U8(&v));
    let vol = Volume::new(g, &v[..]).unwrap();
    let roi = [-1.0, 0.0, -1.0, 0.0, -1.0, 0.0];
    let q = Query {
        tolerance: 2.0,
        max_tetrahedra: 0,
        region_of_interest: Some(roi),
    };
    let m = h.query(&q).unwrap();
    check_mesh(&m, &g).unwrap();
    let full = h.query(&Query::tolerance(2.0)).unwrap();
    assert!(m.tets.len() < full.tets.len());
    // The tolerance holds at every sample inside the region, not outside it.
    check_tolerance(&m, &vol, 2.0, Some(roi)).unwrap();
    assert!(check_tolerance(&m, &vol, 2.0, None).is_err());
    // And the whole mesh is still a valid approximation with its own reported bound.
    check_tolerance(&m, &vol, m.max_error, None).unwrap();
    // ROI outside the bounds is refused.
    let q = Query {
        region_of_interest: Some([5.0, 6.0, 5.0, 6.0, 5.0, 6.0]),
        ..q
    };
    assert!(h
        .query(&q)
        .unwrap_err()
        .to_string()
        .contains("outside the data bounds"));
}

#[test]
fn bad_parameters_are_refused() {
    let (g, v) = marschner_lobb_u8([9, 9, 9]);
    let h = build(g, ScalarSlice::U8(&v));
    for tol in [-1.0, f64::NAN, f64::INFINITY] {
        let e = h.query(&Query::tolerance(tol)).unwrap_err();
        assert!(e.to_string().contains("tolerance"), "{e}");
    }
    let e = Hierarchy::build(unit_grid([9, 9, 1]), ScalarSlice::U8(&v[..81]), &mut |_| {
        true
    })
    .unwrap_err();
    assert!(e.to_string().contains("at least 2 points"), "{e}");
}

#[test]
fn far_faces_cost_is_a_band_of_fine_tets() {
    // 2^k + 1 points: no band; 2^k points: a band along the three far faces.
    let aligned = build(
        unit_grid([65, 65, 65]),
        ScalarSlice::U8(&vec![7; 65 * 65 * 65]),
    );
    let band = build(
        unit_grid([64, 64, 64]),
        ScalarSlice::U8(&vec![7; 64 * 64 * 64]),
    );
    assert_eq!(aligned.base_tetrahedra(), 6);
    let m = band.query(&Query::tolerance(0.0)).unwrap();
    check_mesh(&m, band.grid()).unwrap();
    assert_eq!(
        m.tets.len(),
        band.base_tetrahedra(),
        "a constant field needs nothing beyond the base mesh"
    );
    assert!(band.base_tetrahedra() < 6 * 63 * 63 * 63 / 10);
}
