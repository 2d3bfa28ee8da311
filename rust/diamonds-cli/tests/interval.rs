//! `diamonds interval` end to end on a generated Marschner–Lobb volume: the `.vtu` read back is a
//! conforming interval volume (faces in one tetrahedron only on the box or at a bound), its
//! processed array lies in the range and other arrays are interpolated, tetrahedra do not grow with
//! the tolerance, the budget holds, and bad ranges are clear errors.

mod common;

use common::{diamonds, field_value, s, TempDir};
use diamonds::validate::check_interval_volume;
use diamonds_cli::read::{read_unstructured, tetrahedra};
use std::path::Path;

/// `diamonds interval input out --range lo hi args…`: the summary, the mesh read back.
fn interval(input: &Path, out: &Path, range: [f64; 2], args: &[&str]) -> String {
    let range = range.map(|v| v.to_string());
    let mut all = vec![
        "interval",
        s(input),
        s(out),
        "--range",
        &range[0],
        &range[1],
    ];
    all.extend(args);
    diamonds(&all).ok()
}

#[test]
fn interval_volumes_read_back_conforming() {
    let dir = TempDir::new("interval");
    let input = dir.join("ml.vti");
    diamonds(["generate", s(&input), "--dims", "33", "33", "33"]).ok();
    let range = [90.5, 160.5];
    let bounds = [-1.0, 1.0, -1.0, 1.0, -1.0, 1.0];
    let mut counts = Vec::new();
    for tolerance in ["0", "0.02", "0.08"] {
        let out = dir.join(&format!("ml-{tolerance}.vtu"));
        let summary = interval(&input, &out, range, &["--tolerance", tolerance]);
        assert!(
            summary.contains("tetrahedra") && summary.contains("volume"),
            "{summary}"
        );
        let mesh = read_unstructured(&out).unwrap();
        let tets = tetrahedra(&mesh).unwrap();
        let values: Vec<f64> = {
            let a = &mesh.point_data[0];
            (0..a.tuples()).map(|k| a.value(k)).collect()
        };
        assert_eq!(mesh.point_data[0].type_name(), "Float64");
        assert!(values.iter().all(|&v| range[0] <= v && v <= range[1]));
        let report = check_interval_volume(&mesh.points, &values, &tets, bounds, range).unwrap();
        assert!(report.boundary_faces > 0, "{report:?}");
        assert_eq!(
            field_value(&mesh.field_data, "NumberOfTetrahedra"),
            tets.len() as f64
        );
        let error_bound = field_value(&mesh.field_data, "ErrorBound");
        assert!(
            error_bound <= tolerance.parse::<f64>().unwrap(),
            "{error_bound}"
        );
        assert_eq!(mesh.cell_data[0].name, "Level");
        counts.push(tets.len());
    }
    assert!(
        counts.windows(2).all(|w| w[0] >= w[1]) && counts[2] < counts[0],
        "{counts:?}"
    );
    // The budget.
    let out = dir.join("budget.vtu");
    let budget = (counts[0] / 4).to_string();
    interval(
        &input,
        &out,
        range,
        &["--tolerance", "0", "--max-tets", &budget],
    );
    let mesh = read_unstructured(&out).unwrap();
    assert!(mesh.types.len() <= counts[0] / 4);
    assert!(field_value(&mesh.field_data, "ReachedTolerance") > 0.0);
}

#[test]
fn bad_ranges_are_clear_errors() {
    let dir = TempDir::new("interval-bad");
    let input = dir.join("ml.vti");
    diamonds(["generate", s(&input), "--dims", "17", "17", "17"]).ok();
    let out = dir.join("out.vtu");
    for (range, says) in [(["160", "90"], "is empty"), (["nan", "90"], "finite")] {
        let e = diamonds([
            "interval",
            s(&input),
            s(&out),
            "--range",
            range[0],
            range[1],
        ])
        .user_error();
        assert!(e.contains(says), "{range:?}: {e}");
    }
    let e = diamonds([
        "interval",
        s(&input),
        s(&dir.join("out.vtp")),
        "--range",
        "1",
        "2",
    ])
    .user_error();
    assert!(e.contains(".vtu"), "{e}");
    // A range missing the data: a warning and an empty volume.
    let run = diamonds(["interval", s(&input), s(&out), "--range", "1000", "2000"]);
    assert!(run.stderr.contains("misses the data range"), "{run:?}");
    assert!(run.ok().contains(" 0 tetrahedra"));
}

#[test]
fn verify_interval_measures_the_bounding_surfaces_against_the_full_resolution_ones() {
    let dir = TempDir::new("verify-interval");
    let input = dir.join("ml.vti");
    // Bytes: samples equal to both ends of an integer range.
    diamonds([
        "generate",
        s(&input),
        "--dims",
        "33",
        "31",
        "29",
        "--type",
        "u8",
    ])
    .ok();
    let range = [100.0, 160.0];
    let verify = |mesh: &Path, range: [&str; 2], tolerance: &str| {
        diamonds([
            "verify-interval",
            s(&input),
            s(mesh),
            "--range",
            range[0],
            range[1],
            "--tolerance",
            tolerance,
        ])
    };
    let mut coarse = None;
    for tolerance in ["0", "0.02", "0.08"] {
        let out = dir.join(&format!("ml-{tolerance}.vtu"));
        interval(&input, &out, range, &["--tolerance", tolerance]);
        let report = verify(&out, ["100", "160"], tolerance).ok();
        for check in ["cells: OK", "conformity: OK", "values: OK", "distance: OK"] {
            assert!(report.contains(check), "{tolerance}: {report}");
        }
        assert!(report.ends_with("verify-interval: PASSED\n"), "{report}");
        coarse = Some(out);
    }
    // Ends one ulp inside the samples' values: edges from samples at 100 and 160 cross them within
    // 10⁻¹⁶ of the sample, and tetrahedra there had zero or negative volume. Now positive, and the
    // bound holds.
    let off = [100f64.next_up(), 160f64.next_down()];
    let written = off.map(|v| v.to_string());
    for tolerance in ["0", "0.08"] {
        let out = dir.join(&format!("ml-ulp-{tolerance}.vtu"));
        interval(&input, &out, off, &["--tolerance", tolerance]);
        let report = verify(&out, [&written[0], &written[1]], tolerance).ok();
        assert!(
            report.ends_with("verify-interval: PASSED\n"),
            "{tolerance}: {report}"
        );
    }
    // The coarse volume misses a smaller tolerance, and another range's checks.
    let coarse = coarse.unwrap();
    let run = verify(&coarse, ["100", "160"], "0.001");
    assert_eq!(run.code, 1, "{run:?}");
    assert!(run.stdout.contains("distance: FAILED"), "{run:?}");
    let run = verify(&coarse, ["101", "160"], "0.08");
    assert_eq!(run.code, 1, "{run:?}");
    assert!(run.stdout.contains("values: FAILED"), "{run:?}");
    // A volume exact inside a region of interest: it passes tolerance 0 measured there only.
    let roi = dir.join("ml-roi.vtu");
    let region = ["-1", "0", "-1", "1", "-1", "1"];
    let mut args = vec!["--tolerance", "0", "--roi"];
    args.extend(region);
    interval(&input, &roi, range, &args);
    let run = verify(&roi, ["100", "160"], "0");
    assert_eq!(run.code, 1, "{run:?}");
    let mut args = vec![
        "verify-interval",
        s(&input),
        s(&roi),
        "--range",
        "100",
        "160",
        "--tolerance",
        "0",
        "--roi",
    ];
    args.extend(region);
    let report = diamonds(args).ok();
    assert!(
        report.contains("distance: OK") && report.contains("measured inside [-1.0, 0.0"),
        "{report}"
    );
    // Bad arguments are user errors.
    let e = verify(&coarse, ["160", "100"], "0.08").user_error();
    assert!(e.contains("A < B"), "{e}");
    let e = verify(&coarse, ["100", "160"], "-1").user_error();
    assert!(e.contains("tolerance"), "{e}");
}
