//! The `diamonds` binary end to end: generate → tetra → verify on generated volumes of odd sizes and
//! several types, pass-through of point data, the output's cell and field data, extent/origin/spacing,
//! budget, region of interest, threads, and verify catching a mesh that misses its tolerance.

mod common;

use common::{diamonds, field_value, fixture, s, TempDir};
use diamonds::Grid;
use diamonds_cli::read::{read_image, read_unstructured, Unstructured};
use diamonds_cli::write::write_image;
use diamonds_cli::Array;

/// The field-data value `name` of a mesh.
fn field(mesh: &Unstructured, name: &str) -> f64 {
    field_value(&mesh.field_data, name)
}

fn cell_array<'m>(mesh: &'m Unstructured, name: &str) -> &'m Array {
    mesh.cell_data
        .iter()
        .find(|a| a.name == name)
        .unwrap_or_else(|| panic!("no cell data {name}"))
}

/// Input point index of each mesh point, from its coordinates.
fn input_ids(mesh: &Unstructured, grid: &Grid) -> Vec<usize> {
    mesh.points
        .iter()
        .map(|p| {
            let ijk: [usize; 3] = std::array::from_fn(|a| {
                let f = (p[a] - grid.origin[a]) / grid.spacing[a];
                assert!((f - f.round()).abs() < 1e-9, "{p:?} is not a grid point");
                f.round() as usize
            });
            grid.index(ijk[0], ijk[1], ijk[2])
        })
        .collect()
}

/// Meshes `input` at 0, 2 and 8, verifies each and checks the output's data; returns the tet counts.
fn round_trip(dir: &TempDir, input: &std::path::Path, label: &str) -> Vec<usize> {
    let mut counts = Vec::new();
    for tol in [0.0, 2.0, 8.0] {
        let out = dir.join(&format!("{label}_{tol}.vtu"));
        let summary = diamonds(["tetra", s(input), s(&out), "--tolerance", &tol.to_string()]).ok();
        assert!(
            summary.contains("tetrahedra") && summary.contains("bytes/voxel"),
            "{summary}"
        );
        let report = diamonds(["verify", s(input), s(&out), "--tolerance", &tol.to_string()]).ok();
        assert!(
            report.contains("verify: PASSED"),
            "{label} tol {tol}: {report}"
        );
        assert!(report.contains("conformity: OK"), "{report}");
        let mesh = read_unstructured(&out).unwrap();
        let n = mesh.types.len();
        assert!(mesh.types.iter().all(|&t| t == 10), "VTK_TETRA only");
        assert_eq!(field(&mesh, "NumberOfTetrahedra"), n as f64);
        assert_eq!(field(&mesh, "Tolerance"), tol);
        let max_error = field(&mesh, "MaximumError");
        assert!(max_error <= tol, "{label}: max error {max_error} > {tol}");
        if tol == 0.0 {
            assert_eq!(
                max_error, 0.0,
                "{label}: tolerance 0 must reproduce the samples"
            );
        }
        let levels = cell_array(&mesh, "BisectionDepth");
        let errors = cell_array(&mesh, "ApproximationError");
        assert_eq!((levels.data.len(), errors.data.len()), (n, n));
        let largest = (0..n).map(|c| errors.value(c)).fold(0.0, f64::max);
        assert_eq!(largest, max_error, "MaximumError is the largest cell error");
        counts.push(n);
    }
    assert!(
        counts.windows(2).all(|w| w[0] >= w[1]),
        "{label}: tet counts {counts:?} grow with the tolerance"
    );
    counts
}

#[test]
fn generated_volumes_round_trip_at_tolerances_0_2_8() {
    let dir = TempDir::new("cli");
    for (dims, ty, field) in [
        (["33", "20", "17"], "u8", "marschner-lobb"),
        (["17", "9", "12"], "i16", "torus"),
        (["12", "15", "10"], "f32", "sphere"),
        (["9", "8", "7"], "u16", "marschner-lobb"),
        (["5", "2", "3"], "f64", "torus"),
    ] {
        let label = format!("{field}_{}x{}x{}_{ty}", dims[0], dims[1], dims[2]);
        let input = dir.join(&format!("{label}.vti"));
        let mut args = vec![
            "generate",
            s(&input),
            "--field",
            field,
            "--type",
            ty,
            "--dims",
        ];
        args.extend(dims);
        diamonds(args).ok();
        let image = read_image(&input).unwrap();
        let want: Vec<usize> = dims.iter().map(|d| d.parse().unwrap()).collect();
        assert_eq!(image.grid.dims[..], want[..]);
        let counts = round_trip(&dir, &input, &label);
        assert!(counts[0] > 0);
    }
}

#[test]
fn the_default_volume_is_marschner_lobb_65_u8() {
    let dir = TempDir::new("cli");
    let input = dir.join("default.vti");
    let said = diamonds(["generate", s(&input)]).ok();
    assert!(said.contains("65x65x65"), "{said}");
    let image = read_image(&input).unwrap();
    assert_eq!(image.grid.dims, [65; 3]);
    let a = image.scalars(None).unwrap();
    assert_eq!(a.name, "marschner_lobb");
    let diamonds_cli::Array {
        data: diamonds_cli::Values::U8(v),
        ..
    } = a
    else {
        panic!("u8 expected, got {}", a.type_name());
    };
    assert_eq!((v.iter().min(), v.iter().max()), (Some(&0), Some(&255)));
    let out = dir.join("default.vtu");
    diamonds(["tetra", s(&input), s(&out), "--tolerance", "8"]).ok();
    let report = diamonds(["verify", s(&input), s(&out), "--tolerance", "8"]).ok();
    assert!(report.contains("verify: PASSED"), "{report}");
}

#[test]
fn every_input_point_array_passes_through_unchanged() {
    let dir = TempDir::new("cli");
    let generated = dir.join("one.vti");
    diamonds(["generate", s(&generated), "--dims", "33", "20", "17"]).ok();
    let mut image = read_image(&generated).unwrap();
    let n = image.grid.len();
    // A second scalar array, a vector array and a 64-bit array beside the generated field.
    image.point_data.insert(
        0,
        Array::scalars("index", (0..n as i32).collect::<Vec<_>>()),
    );
    image.point_data.push(Array {
        name: "gradient".into(),
        components: 3,
        data: (0..3 * n)
            .map(|i| i as f32 * 0.25)
            .collect::<Vec<_>>()
            .into(),
    });
    image.point_data.push(Array::scalars(
        "id64",
        (0..n as i64).map(|i| i << 33).collect::<Vec<_>>(),
    ));
    let input = dir.join("many.vti");
    write_image(&input, &image.grid, &image.point_data).unwrap();
    let out = dir.join("many.vtu");
    let said = diamonds([
        "tetra",
        s(&input),
        s(&out),
        "--array",
        "marschner_lobb",
        "--tolerance",
        "2",
    ])
    .ok();
    assert!(said.contains("'marschner_lobb'"), "{said}");
    let mesh = read_unstructured(&out).unwrap();
    let ids = input_ids(&mesh, &image.grid);
    let names: Vec<_> = mesh.point_data.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(
        names,
        ["marschner_lobb", "index", "gradient", "id64"],
        "the meshed array first"
    );
    for out_array in &mesh.point_data {
        let input_array = image
            .point_data
            .iter()
            .find(|a| a.name == out_array.name)
            .unwrap();
        assert_eq!(out_array.components, input_array.components);
        assert_eq!(out_array.type_name(), input_array.type_name());
        let c = out_array.components;
        for (k, &i) in ids.iter().enumerate() {
            for j in 0..c {
                assert_eq!(
                    out_array.value(k * c + j),
                    input_array.value(i * c + j),
                    "{} at mesh point {k} (input point {i})",
                    out_array.name
                );
            }
        }
    }
    let report = diamonds([
        "verify",
        s(&input),
        s(&out),
        "--array",
        "marschner_lobb",
        "--tolerance",
        "2",
    ])
    .ok();
    assert!(
        report.contains("point data: OK (marschner_lobb, index, gradient, id64 equal the input"),
        "{report}"
    );
    // The default array of this file is its first single-component one: "index".
    let out2 = dir.join("index.vtu");
    let said = diamonds(["tetra", s(&input), s(&out2), "--tolerance", "0"]).ok();
    assert!(said.contains("'index'"), "{said}");
}

#[test]
fn extent_origin_and_spacing_are_honoured() {
    let dir = TempDir::new("cli");
    // Extent 2..6 × 1..4 × 3..5 from origin (0.5, -1, 2) with spacing (0.25, 0.5, 1.5): the points span
    // [1, 2] × [-0.5, 1] × [6.5, 9.5]; the legacy file stores the shifted origin itself.
    for name in [
        "appended_raw_zlib_blocks.vti",
        "legacy_binary.vtk",
        "ascii.vti",
    ] {
        let input = fixture(name);
        let out = dir.join("extent.vtu");
        diamonds(["tetra", s(&input), s(&out)]).ok();
        let mesh = read_unstructured(&out).unwrap();
        for a in 0..3 {
            let lo = mesh
                .points
                .iter()
                .map(|p| p[a])
                .fold(f64::INFINITY, f64::min);
            let hi = mesh
                .points
                .iter()
                .map(|p| p[a])
                .fold(f64::NEG_INFINITY, f64::max);
            let want = [[1.0, 2.0], [-0.5, 1.0], [6.5, 9.5]][a];
            assert_eq!([lo, hi], want, "{name}: axis {a}");
        }
        let report = diamonds(["verify", s(&input), s(&out), "--tolerance", "0"]).ok();
        assert!(report.contains("verify: PASSED"), "{name}: {report}");
    }
}

#[test]
fn every_reader_fixture_meshes_and_verifies() {
    let dir = TempDir::new("cli");
    let mut seen = 0;
    for entry in std::fs::read_dir(fixture("")).unwrap() {
        let input = entry.unwrap().path();
        let name = input.file_name().unwrap().to_string_lossy().into_owned();
        let ext = input.extension().unwrap_or_default();
        if (ext != "vti" && ext != "vtk") || name.contains("only") {
            continue;
        }
        let out = dir.join(&format!("{name}.vtu"));
        for (array, tol) in [("density", "0"), ("temperature", "0.5")] {
            diamonds([
                "tetra",
                s(&input),
                s(&out),
                "--array",
                array,
                "--tolerance",
                tol,
            ])
            .ok();
            let report = diamonds([
                "verify",
                s(&input),
                s(&out),
                "--array",
                array,
                "--tolerance",
                tol,
            ])
            .ok();
            assert!(report.contains("verify: PASSED"), "{name}: {report}");
        }
        seen += 1;
    }
    assert_eq!(seen, 14);
}

#[test]
fn non_numeric_arrays_are_left_out_with_a_warning() {
    let dir = TempDir::new("cli");
    let input = fixture("with_string_array.vti");
    let out = dir.join("strings.vtu");
    let run = diamonds(["tetra", s(&input), s(&out)]);
    assert_eq!(run.code, 0, "{run:#?}");
    assert!(
        run.stderr.contains("warning: '")
            && run
                .stderr
                .contains("array 'labels' of type String left out"),
        "{run:#?}"
    );
    let mesh = read_unstructured(&out).unwrap();
    let names: Vec<_> = mesh.point_data.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(names, ["density", "temperature", "velocity"]);
}

#[test]
fn budget_region_of_interest_and_threads() {
    let dir = TempDir::new("cli");
    let input = dir.join("ml.vti");
    diamonds(["generate", s(&input), "--dims", "33", "33", "33"]).ok();
    let count = |out: &std::path::Path| read_unstructured(out).unwrap().types.len();

    let full = dir.join("full.vtu");
    diamonds(["tetra", s(&input), s(&full)]).ok();
    let lossless = count(&full);

    let budget = dir.join("budget.vtu");
    let run = diamonds(["tetra", s(&input), s(&budget), "--max-tets", "5000"]);
    assert!(!run.stderr.contains("warning"), "{run:#?}");
    // The summary says why its error is above the (default, 0) tolerance.
    let summary = run.ok();
    assert!(
        summary.contains("(tolerance 0; raised by the budget of 5000 tetrahedra)"),
        "{summary}"
    );
    let mesh = read_unstructured(&budget).unwrap();
    assert!(mesh.types.len() <= 5000, "{} > 5000", mesh.types.len());
    // A budget below the coarsest mesh (the root cube's six tetrahedra here; on a 32³ image the
    // band along its far faces): that mesh, and a warning that says so.
    let band = dir.join("band.vti");
    diamonds(["generate", s(&band), "--dims", "32", "32", "32"]).ok();
    let coarse = dir.join("coarse.vtu");
    for (image, coarsest) in [(&input, 6usize), (&band, 0)] {
        let run = diamonds(["tetra", s(image), s(&coarse), "--max-tets", "5"]);
        assert!(
            run.stderr
                .contains("warning: 'marschner_lobb': the budget of 5 tetrahedra cannot be met"),
            "{run:#?}"
        );
        run.ok();
        let tets = count(&coarse);
        assert!(tets > 5 && (coarsest == 0 || tets == coarsest), "{tets}");
    }
    // The mesh meets the error it reports.
    let reached = field(&mesh, "MaximumError").to_string();
    let report = diamonds(["verify", s(&input), s(&budget), "--tolerance", &reached]).ok();
    assert!(report.contains("verify: PASSED"), "{report}");

    let roi = dir.join("roi.vtu");
    diamonds([
        "tetra",
        s(&input),
        s(&roi),
        // Negative values in any float syntax, exponents included.
        "--roi",
        "-1",
        "0",
        "-1e0",
        "0",
        "-1",
        "-5e-1",
    ])
    .ok();
    let in_roi = count(&roi);
    assert!(in_roi < lossless, "{in_roi} !< {lossless}");
    // Lossless inside the region (the default tolerance 0), coarse outside it.
    let box_ = ["--roi", "-1", "0", "-1", "0", "-1", "-0.5"];
    let verify = |extra: &[&str]| {
        let mut args = vec!["verify", s(&input), s(&roi), "--tolerance", "0"];
        args.extend_from_slice(extra);
        diamonds(args)
    };
    let report = verify(&box_).ok();
    assert!(
        report.contains("conformity: OK")
            && report.contains("tolerance: OK (the samples inside [-1.0, 0.0, -1.0, 0.0, -1.0, -0.5] within 0 <= 0)"),
        "{report}"
    );
    let outside = verify(&[]);
    assert!(outside.stdout.contains("tolerance: FAILED"), "{outside:#?}");
    let e = verify(&["--roi", "5", "6", "5", "6", "5", "6"]).user_error();
    assert!(e.contains("lies outside the data bounds"), "{e}");

    let one = dir.join("one_thread.vtu");
    diamonds(["--threads", "1", "tetra", s(&input), s(&one)]).ok();
    diamonds(["tetra", "--threads", "2", s(&input), s(&one)]).ok();
    assert_eq!(
        count(&one),
        lossless,
        "the mesh does not depend on the thread count"
    );
    assert_eq!(std::fs::read(&one).unwrap(), std::fs::read(&full).unwrap());
}

#[test]
fn verify_fails_with_exit_code_1_on_a_mesh_that_misses_the_tolerance() {
    let dir = TempDir::new("cli");
    let input = dir.join("ml.vti");
    diamonds(["generate", s(&input), "--dims", "17", "17", "17"]).ok();
    let out = dir.join("coarse.vtu");
    diamonds(["tetra", s(&input), s(&out), "--tolerance", "40"]).ok();
    let run = diamonds(["verify", s(&input), s(&out), "--tolerance", "2"]);
    assert_eq!(run.code, 1, "{run:#?}");
    assert!(run.stdout.contains("tolerance: FAILED"), "{run:#?}");
    assert!(run.stdout.contains("verify: FAILED"), "{run:#?}");

    // A mesh of another volume: its points are not this grid's samples, or it misses the box.
    let other = dir.join("other.vti");
    diamonds(["generate", s(&other), "--dims", "9", "9", "9"]).ok();
    let run = diamonds(["verify", s(&other), s(&out), "--tolerance", "255"]);
    assert_eq!(run.code, 1, "{run:#?}");
    assert!(run.stdout.contains("FAILED"), "{run:#?}");
}

#[test]
fn help_describes_every_command_and_option() {
    let top = diamonds(["--help"]).ok();
    for word in ["tetra", "generate", "verify", "--threads"] {
        assert!(top.contains(word), "{word} missing from --help:\n{top}");
    }
    let tetra = diamonds(["tetra", "--help"]).ok();
    for word in [
        "--array",
        "--tolerance",
        "--max-tets",
        "--roi",
        "lossless",
        "no limit",
    ] {
        assert!(
            tetra.contains(word),
            "{word} missing from tetra --help:\n{tetra}"
        );
    }
    let generate = diamonds(["generate", "--help"]).ok();
    for word in [
        "marschner-lobb",
        "sphere",
        "torus",
        "--dims",
        "--type",
        "u8",
        "f32",
    ] {
        assert!(
            generate.contains(word),
            "{word} missing from generate --help:\n{generate}"
        );
    }
    let verify = diamonds(["verify", "--help"]).ok();
    assert!(
        verify.contains("--tolerance") && verify.contains("Exit code 1"),
        "{verify}"
    );
}
