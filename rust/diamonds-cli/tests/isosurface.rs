//! `diamonds iso` and `diamonds verify-surface` end to end on generated distance fields: watertight and
//! outward-oriented surfaces at tolerances 0, small and large, triangle counts that do not grow with the
//! tolerance, relative and default tolerances, two isovalues, the triangle budget, carrier tetrahedra,
//! region of interest, surfaces open on the image bounds, the `.vtp` read back, and verify-surface
//! catching holes, flipped and degenerate triangles and bad normals.

mod common;

use common::{diamonds, field_value, s, TempDir};
use diamonds_cli::read::{read_polydata, read_unstructured, PolyData};
use diamonds_cli::write::{write_triangles, Triangles};
use diamonds_cli::Array;
use std::path::{Path, PathBuf};

/// Diagonal of the generated volumes' bounds, `[-1, 1]^3`.
const DIAGONAL: f64 = 2.0 * 1.732_050_807_568_877_2;

/// Writes `field` on a `dims` grid of `ty` samples into `dir`.
fn generate(dir: &TempDir, field: &str, ty: &str, dims: [usize; 3]) -> PathBuf {
    let path = dir.join(&format!("{field}_{ty}.vti"));
    let dims = dims.map(|d| d.to_string());
    let mut args = vec![
        "generate",
        s(&path),
        "--field",
        field,
        "--type",
        ty,
        "--dims",
    ];
    args.extend(dims.iter().map(String::as_str));
    diamonds(args).ok();
    path
}

/// `diamonds iso input out args…`: asserts success and returns the summary.
fn iso(input: &Path, out: &Path, args: &[&str]) -> String {
    let mut all = vec!["iso", s(input), s(out)];
    all.extend(args);
    let summary = diamonds(&all).ok();
    for word in ["triangles", "points", "error bound", "build", "extract"] {
        assert!(summary.contains(word), "{word} missing from: {summary}");
    }
    summary
}

/// `diamonds verify-surface out [--image image]`: asserts PASSED and returns the report.
fn verify(out: &Path, image: Option<&Path>) -> String {
    let mut args = vec!["verify-surface", s(out)];
    if let Some(image) = image {
        args.extend(["--image", s(image)]);
    }
    let report = diamonds(args).ok();
    assert!(report.contains("verify-surface: PASSED"), "{report}");
    report
}

/// The triangles of a surface read back.
fn triangles(surface: &PolyData) -> Vec<[usize; 3]> {
    assert!(
        surface
            .offsets
            .iter()
            .enumerate()
            .all(|(c, &o)| o == 3 * (c + 1)),
        "triangles only"
    );
    surface
        .connectivity
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect()
}

/// Reads `out` back and checks it against its field data; returns it and its triangle count.
fn read_surface(out: &Path) -> (PolyData, usize) {
    let surface = read_polydata(out).unwrap_or_else(|e| panic!("{e}"));
    let n = triangles(&surface).len();
    assert_eq!(
        field_value(&surface.field_data, "NumberOfTriangles"),
        n as f64
    );
    assert!(field_value(&surface.field_data, "ErrorBound") >= 0.0);
    if let Some(normals) = surface.point_data.iter().find(|a| a.name == "Normals") {
        assert_eq!(normals.components, 3);
        assert_eq!(normals.type_name(), "Float32");
    }
    (surface, n)
}

fn normal_at(surface: &PolyData, p: usize) -> [f64; 3] {
    let normals = surface
        .point_data
        .iter()
        .find(|a| a.name == "Normals")
        .expect("Normals");
    std::array::from_fn(|a| normals.value(3 * p + a))
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Direction of increasing distance at `p`: away from the sphere's centre, or from the torus's core
/// circle (radius 0.6 in the xy plane).
fn outward(field: &str, p: [f64; 3]) -> [f64; 3] {
    match field {
        "sphere" => p,
        _ => {
            let r = (p[0] * p[0] + p[1] * p[1]).sqrt();
            sub(p, [0.6 * p[0] / r, 0.6 * p[1] / r, 0.0])
        }
    }
}

#[test]
fn sphere_and_torus_at_tolerances_0_small_large() {
    let dir = TempDir::new("iso");
    // 127.5 is distance 0: the sphere of radius 0.6 and the torus of radii 0.6 and 0.25, both closed
    // inside the box.
    for (field, ty) in [("sphere", "f32"), ("torus", "u8"), ("sphere", "i16")] {
        let input = generate(&dir, field, ty, [33, 30, 35]);
        let mut counts = Vec::new();
        for tol in [0.0, 0.02, 0.2] {
            let label = format!("{field} {ty} tol {tol}");
            let out = dir.join(&format!("{field}_{ty}_{tol}.vtp"));
            let tol_arg = tol.to_string();
            let summary = iso(
                &input,
                &out,
                &["--isovalue", "127.5", "--tolerance", &tol_arg, "--scalars"],
            );
            assert!(summary.contains("at isovalue 127.5"), "{summary}");
            let report = verify(&out, Some(&input));
            assert!(
                report.contains("watertight: OK") && report.contains("normals: OK"),
                "{report}"
            );
            assert!(
                report.contains(" 0 edges on the image bounds in one"),
                "{label}: closed surface: {report}"
            );
            verify(&out, None);
            let (surface, n) = read_surface(&out);
            assert!(n > 0, "{label}: empty surface");
            assert_eq!(field_value(&surface.field_data, "Tolerance"), tol);
            let bound = field_value(&surface.field_data, "ErrorBound");
            assert!(bound <= tol, "{label}: error bound {bound} > tolerance");
            if tol == 0.0 {
                assert_eq!(bound, 0.0, "{label}");
            }
            // The scalar, named like the input array: the isovalue at every point.
            let name = if field == "sphere" {
                "sphere_distance"
            } else {
                "torus_distance"
            };
            let scalars = surface.point_data.iter().find(|a| a.name == name).unwrap();
            assert_eq!(scalars.data.len(), surface.points.len());
            assert!((0..scalars.data.len()).all(|k| scalars.value(k) == 127.5));
            // Normals and triangles toward increasing values: outward.
            for (p, &x) in surface.points.iter().enumerate() {
                let n = normal_at(&surface, p);
                assert!(dot(n, outward(field, x)) > 0.0, "{label}: normal at {x:?}");
            }
            for t in triangles(&surface) {
                let [a, b, c] = t.map(|i| surface.points[i]);
                let centroid = std::array::from_fn(|k| (a[k] + b[k] + c[k]) / 3.0);
                let normal = cross(sub(b, a), sub(c, a));
                assert!(
                    dot(normal, outward(field, centroid)) > 0.0,
                    "{label}: inward triangle {t:?}"
                );
            }
            counts.push(n);
        }
        assert!(
            counts.windows(2).all(|w| w[0] >= w[1]),
            "{field} {ty}: triangle counts {counts:?} grow with the tolerance"
        );
        assert!(
            counts[2] * 4 < counts[0],
            "{field} {ty}: {counts:?}: the large tolerance hardly coarsens"
        );
    }
}

#[test]
fn relative_tolerances_are_fractions_of_the_diagonal_and_the_default_one_voxel() {
    let dir = TempDir::new("iso");
    let input = generate(&dir, "sphere", "f32", [33, 33, 33]);
    let out = dir.join("relative.vtp");
    let summary = iso(
        &input,
        &out,
        &["--isovalue", "127.5", "--relative-tolerance", "0.01"],
    );
    assert!(summary.contains("= 1.000 % of the diagonal"), "{summary}");
    let (surface, relative) = read_surface(&out);
    let tol = field_value(&surface.field_data, "Tolerance");
    assert!((tol - 0.01 * DIAGONAL).abs() < 1e-12, "{tol}");
    let absolute = dir.join("absolute.vtp");
    iso(
        &input,
        &absolute,
        &["--isovalue", "127.5", "--tolerance", &tol.to_string()],
    );
    assert_eq!(read_surface(&absolute).1, relative);

    let out = dir.join("default.vtp");
    let summary = iso(&input, &out, &["--isovalue", "127.5"]);
    // Two and a half voxel diagonals (a voxel diagonal: the diagonal over the cube root of the 32³
    // cells).
    assert!(summary.contains("= 7.812 % of the diagonal"), "{summary}");
    let (surface, _) = read_surface(&out);
    let tol = field_value(&surface.field_data, "Tolerance");
    assert!((tol - 2.5 * DIAGONAL / 32.0).abs() < 1e-12, "{tol}");
    verify(&out, Some(&input));
}

#[test]
fn two_isovalues_make_two_surfaces() {
    let dir = TempDir::new("iso");
    let input = generate(&dir, "sphere", "f32", [33, 33, 33]);
    // Distances -0.2 and 0.25: spheres of radii 0.4 and 0.85.
    let (inner, outer) = ("102", "159.375");
    let count = |values: &[&str], tol: &str| {
        let out = dir.join("two.vtp");
        let mut args = vec!["--tolerance", tol, "--scalars"];
        for v in values {
            args.extend(["--isovalue", v]);
        }
        let summary = iso(&input, &out, &args);
        verify(&out, Some(&input));
        // Within the tolerance of the full-resolution surfaces of its isovalues, all together; not
        // of one of them alone when it has two.
        let mut check = vec!["verify-surface", s(&out), "--image", s(&input)];
        check.extend(["--tolerance", tol]);
        let run = |isovalues: &[&str]| {
            let mut args = check.clone();
            for v in isovalues {
                args.extend(["--isovalue", v]);
            }
            diamonds(args)
        };
        let report = run(values).ok();
        assert!(report.contains("verify-surface: PASSED"), "{report}");
        if values.len() > 1 {
            let one = run(&values[..1]);
            assert_eq!(one.code, 1, "{one:#?}");
        }
        let (surface, n) = read_surface(&out);
        let scalars = surface
            .point_data
            .iter()
            .find(|a| a.name == "sphere_distance")
            .unwrap();
        let mut seen: Vec<f64> = (0..scalars.data.len()).map(|k| scalars.value(k)).collect();
        seen.sort_by(f64::total_cmp);
        seen.dedup();
        let want: Vec<f64> = values.iter().map(|v| v.parse().unwrap()).collect();
        assert_eq!(seen, want, "{summary}");
        n
    };
    // At tolerance 0 both surfaces are the full-resolution ones: the union of two single runs.
    assert_eq!(
        count(&[inner, outer], "0"),
        count(&[inner], "0") + count(&[outer], "0")
    );
    let both = count(&[inner, outer], "0.05");
    assert!(both < count(&[inner, outer], "0"));
}

#[test]
fn triangle_budget_is_honoured() {
    let dir = TempDir::new("iso");
    let input = generate(&dir, "torus", "f32", [41, 41, 41]);
    let out = dir.join("full.vtp");
    iso(&input, &out, &["--isovalue", "127.5", "--tolerance", "0"]);
    let full = read_surface(&out).1;
    for budget in [full / 10, full / 3] {
        let out = dir.join("budget.vtp");
        let budget_arg = budget.to_string();
        let summary = iso(
            &input,
            &out,
            &[
                "--isovalue",
                "127.5",
                "--tolerance",
                "0",
                "--max-triangles",
                &budget_arg,
            ],
        );
        assert!(
            summary.contains(&format!("budget {budget} triangles")),
            "{summary}"
        );
        let (surface, n) = read_surface(&out);
        assert!(
            n <= budget && n > budget / 4,
            "{n} triangles for a budget of {budget}"
        );
        assert!(field_value(&surface.field_data, "ErrorBound") > 0.0);
        verify(&out, Some(&input));
    }
    // A budget the tolerance already meets changes nothing.
    let out = dir.join("loose.vtp");
    let budget = (full + 1).to_string();
    iso(
        &input,
        &out,
        &[
            "--isovalue",
            "127.5",
            "--tolerance",
            "0",
            "--max-triangles",
            &budget,
        ],
    );
    assert_eq!(read_surface(&out).1, full);
}

#[test]
fn carrier_tetrahedra_region_of_interest_and_no_normals() {
    let dir = TempDir::new("iso");
    let input = generate(&dir, "sphere", "u8", [33, 33, 33]);
    let out = dir.join("carried.vtp");
    let carrier = dir.join("carrier.vtu");
    let summary = iso(
        &input,
        &out,
        &[
            "--isovalue",
            "127.5",
            "--tolerance",
            "0.05",
            "--carrier",
            s(&carrier),
        ],
    );
    assert!(summary.contains("carrier tetrahedra"), "{summary}");
    let (_, n) = read_surface(&out);
    let mesh = read_unstructured(&carrier).unwrap();
    assert!(mesh.types.iter().all(|&t| t == 10), "VTK_TETRA only");
    let tets = mesh.types.len();
    assert!(
        tets > 0 && tets <= n,
        "{tets} carrier tetrahedra for {n} triangles"
    );
    assert_eq!(
        field_value(&mesh.field_data, "NumberOfTetrahedra"),
        tets as f64
    );
    let values = &mesh.point_data[0];
    assert_eq!(values.name, "sphere_distance");
    for t in mesh.connectivity.chunks_exact(4) {
        let f = t.iter().map(|&p| values.value(p));
        let (lo, hi) = f.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
        assert!(
            lo < 127.5 && 127.5 <= hi,
            "carrier tetrahedron {t:?} misses the surface"
        );
    }
    assert!(mesh.cell_data.iter().any(|a| a.name == "BisectionDepth"));
    // The isosurface error of each carrier's diamond, world units: within the tolerance, the
    // largest is the surface's ErrorBound; no data-unit ApproximationError.
    let errors = mesh
        .cell_data
        .iter()
        .find(|a| a.name == "IsosurfaceError")
        .expect("cell data IsosurfaceError");
    assert_eq!(errors.tuples(), tets);
    let largest = (0..tets).map(|k| errors.value(k)).fold(0.0, f64::max);
    assert!(
        largest > 0.0 && largest <= 0.05,
        "largest IsosurfaceError {largest}"
    );
    assert_eq!(largest, field_value(&mesh.field_data, "MaximumError"));
    assert_eq!(
        largest,
        field_value(&read_surface(&out).0.field_data, "ErrorBound")
    );
    assert!(!mesh
        .cell_data
        .iter()
        .any(|a| a.name == "ApproximationError"));

    // Full resolution inside the region of interest only.
    let full = dir.join("full.vtp");
    iso(&input, &full, &["--isovalue", "127.5", "--tolerance", "0"]);
    let roi = dir.join("roi.vtp");
    let region = ["--roi", "0", "1", "-1", "1", "-1", "1"];
    let mut args = vec!["--isovalue", "127.5", "--tolerance", "0"];
    args.extend(region);
    iso(&input, &roi, &args);
    let (in_roi, all) = (read_surface(&roi).1, read_surface(&full).1);
    assert!(in_roi < all, "{in_roi} !< {all}");
    verify(&roi, Some(&input));
    // Its tolerance holds inside the region: measured there, both distances are 0; measured
    // everywhere, the coarse part outside fails.
    let bound = |region: &[&str]| {
        let mut args = vec![
            "verify-surface",
            s(&roi),
            "--image",
            s(&input),
            "--isovalue",
            "127.5",
            "--tolerance",
            "0",
        ];
        args.extend_from_slice(region);
        diamonds(args)
    };
    let run = bound(&region);
    assert_eq!(run.code, 0, "{run:#?}");
    assert!(run.stdout.contains("measured inside [0.0, 1.0"), "{run:#?}");
    let run = bound(&[]);
    assert_eq!(run.code, 1, "{run:#?}");
    assert!(bound(&["--roi", "5", "6", "-1", "1", "-1", "1"])
        .user_error()
        .contains("outside the data bounds"));
    let mut args = vec!["verify-surface", s(&roi), "--image", s(&input)];
    args.extend(region);
    let run = diamonds(args);
    let e = run.user_error();
    assert!(e.contains("--roi needs --isovalue"), "{e}");

    let bare = dir.join("bare.vtp");
    iso(&input, &bare, &["--isovalue", "127.5", "--no-normals"]);
    let (surface, _) = read_surface(&bare);
    assert!(surface.point_data.is_empty(), "{:?}", surface.point_data);
    let report = verify(&bare, None);
    assert!(report.contains("normals: none"), "{report}");
}

#[test]
fn surfaces_open_on_the_image_bounds() {
    let dir = TempDir::new("iso");
    let input = generate(&dir, "sphere", "f32", [25, 30, 27]);
    // Distance 0.5: the sphere of radius 1.1 leaves the box [-1, 1]^3 through its six faces.
    for tol in ["0", "0.05"] {
        let out = dir.join("open.vtp");
        iso(&input, &out, &["--isovalue", "191.25", "--tolerance", tol]);
        let report = verify(&out, Some(&input));
        assert!(
            !report.contains(" 0 edges on the image bounds"),
            "tol {tol}: {report}"
        );
        let run = diamonds(["verify-surface", s(&out)]);
        assert_eq!(
            run.code, 1,
            "without --image the surface must be closed: {run:#?}"
        );
        assert!(run.stdout.contains("watertight: FAILED"), "{run:#?}");
    }
}

#[test]
fn verify_surface_catches_holes_flips_degenerate_triangles_and_bad_normals() {
    let dir = TempDir::new("iso");
    let input = generate(&dir, "torus", "f32", [25, 25, 25]);
    let good = dir.join("good.vtp");
    iso(
        &input,
        &good,
        &["--isovalue", "127.5", "--tolerance", "0.02"],
    );
    verify(&good, Some(&input));
    let (surface, _) = read_surface(&good);
    let original: Vec<[u32; 3]> = triangles(&surface)
        .iter()
        .map(|t| t.map(|i| i as u32))
        .collect();
    let broken = dir.join("broken.vtp");
    let write = |tris: &[[u32; 3]], normals: Array| {
        write_triangles(
            &broken,
            Triangles {
                points: &surface.points,
                triangles: tris,
                point_data: vec![normals],
                field_data: Vec::new(),
            },
        )
        .unwrap();
    };
    let normals = surface.point_data[0].clone();
    let fails = |what: &str| {
        let run = diamonds(["verify-surface", s(&broken), "--image", s(&input)]);
        assert_eq!(run.code, 1, "{what}: {run:#?}");
        assert!(
            run.stdout.contains(&format!("{what}: FAILED"))
                && run.stdout.contains("verify-surface: FAILED"),
            "{what}: {run:#?}"
        );
    };
    write(&original[1..], normals.clone());
    fails("watertight");
    let mut flipped = original.clone();
    flipped[7].swap(1, 2);
    write(&flipped, normals.clone());
    fails("orientation");
    let mut degenerate = original.clone();
    degenerate[3][2] = degenerate[3][0];
    write(&degenerate, normals.clone());
    fails("triangles");
    let diamonds_cli::Values::F32(mut v) = normals.data.clone() else {
        panic!("Float32 normals")
    };
    v[4] *= 1.5;
    write(
        &original,
        Array {
            data: v.into(),
            ..normals.clone()
        },
    );
    fails("normals");
    // The intact surface written the same way passes.
    write(&original, normals);
    verify(&broken, Some(&input));
}

#[test]
fn verify_surface_measures_both_distances_to_the_full_resolution_surface() {
    let dir = TempDir::new("iso");
    let input = generate(&dir, "torus", "u8", [29, 25, 27]);
    let full = dir.join("full.vtp");
    iso(&input, &full, &["--isovalue", "127.5", "--tolerance", "0"]);
    let with = |surface: &Path, extra: &[&str]| {
        let mut args = vec!["verify-surface", s(surface), "--image", s(&input)];
        args.extend_from_slice(extra);
        diamonds(args)
    };
    // The full-resolution surface is at distance 0 from itself, within rounding.
    let run = with(&full, &["--isovalue", "127.5", "--tolerance", "0"]);
    assert_eq!(run.code, 0, "{run:#?}");
    assert!(
        run.stdout
            .contains("  distance: OK (full-resolution surface of"),
        "{run:#?}"
    );
    // Another isovalue's surface is far from it: reported without --tolerance, failed with one.
    let run = with(&full, &["--isovalue", "120.5"]);
    assert_eq!(run.code, 0, "{run:#?}");
    assert!(
        run.stdout
            .contains("  distance: full-resolution surface of"),
        "{run:#?}"
    );
    let run = with(&full, &["--isovalue", "120.5", "--tolerance", "0.01"]);
    assert_eq!(run.code, 1, "{run:#?}");
    assert!(
        run.stdout
            .contains("distance: FAILED: a point of the full-resolution surface lies")
            && run.stdout.contains("verify-surface: FAILED"),
        "{run:#?}"
    );
    // --isovalue needs --image; a tolerance must be a number >= 0.
    let run = diamonds(["verify-surface", s(&full), "--isovalue", "1"]);
    assert_eq!(run.code, 2, "{run:#?}");
    assert!(with(&full, &["--isovalue", "1", "--tolerance", "-1"])
        .user_error()
        .contains("tolerance"));
}

#[test]
fn surfaces_on_thin_slices_are_sampled_as_their_tolerance_needs() {
    // Spacings 1, 1 and 0.02: the verifier samples triangles half the tolerance apart (held
    // between the smallest and the largest spacing), not 0.02 apart whatever the tolerance, which
    // made 10³ times as many samples per triangle here and took minutes and gigabytes on larger
    // images. Its slack (how far a point may lie from a sample) says so.
    let dir = TempDir::new("iso");
    let input = dir.join("slices.vti");
    let grid = diamonds::Grid {
        dims: [25, 25, 41],
        origin: [0.0, 0.0, 0.0],
        spacing: [1.0, 1.0, 0.02],
    };
    let ellipsoid: Vec<f32> = (0..grid.len())
        .map(|i| {
            let [x, y, z] = grid.point(grid.ijk(i));
            let q = ((x - 12.0) / 8.0).powi(2) + ((y - 11.0) / 7.0).powi(2);
            (q + ((z - 0.4) / 0.3).powi(2)).sqrt() as f32
        })
        .collect();
    diamonds_cli::write::write_image(&input, &grid, &[Array::scalars("e", ellipsoid)]).unwrap();
    for (tolerance, step) in [(0.0, 0.02), (0.6, 0.3), (5.0, 1.0)] {
        let out = dir.join(&format!("slices-{tolerance}.vtp"));
        let t = tolerance.to_string();
        iso(&input, &out, &["--isovalue", "1", "--tolerance", &t]);
        let report = diamonds([
            "verify-surface",
            s(&out),
            "--image",
            s(&input),
            "--isovalue",
            "1",
            "--tolerance",
            &t,
        ])
        .ok();
        assert!(report.contains("verify-surface: PASSED"), "{report}");
        let slack: f64 = report
            .split("(every point of either within ")
            .nth(1)
            .and_then(|r| r.split(" more)").next())
            .and_then(|x| x.parse().ok())
            .unwrap_or_else(|| panic!("no slack in {report}"));
        let expected = step / 3f64.sqrt();
        assert!((slack - expected).abs() < 1e-12, "{tolerance}: {slack}");
    }
}

#[test]
fn isovalues_equal_to_samples_keep_a_consistent_orientation() {
    let dir = TempDir::new("iso");
    let input = generate(&dir, "sphere", "u8", [33, 33, 33]);
    for (isovalue, tol) in [("128", "0"), ("100", "0"), ("128", "0.05")] {
        let out = dir.join("on_samples.vtp");
        iso(&input, &out, &["--isovalue", isovalue, "--tolerance", tol]);
        let report = verify(&out, Some(&input));
        assert!(report.contains("orientation: OK"), "{report}");
    }
}

#[test]
fn help_describes_iso_and_verify_surface() {
    let top = diamonds(["--help"]).ok();
    for word in ["iso", "verify-surface"] {
        assert!(top.contains(word), "{word} missing from --help:\n{top}");
    }
    let help = diamonds(["iso", "--help"]).ok();
    for word in [
        "--isovalue",
        "--array",
        "--tolerance",
        "--relative-tolerance",
        "--max-triangles",
        "--roi",
        "--no-normals",
        "--scalars",
        "--carrier",
        "two and a half voxel diagonals",
        "world units",
        "no limit",
        "ErrorBound",
    ] {
        assert!(
            help.contains(word),
            "{word} missing from iso --help:\n{help}"
        );
    }
    let help = diamonds(["verify-surface", "--help"]).ok();
    assert!(
        help.contains("--image") && help.contains("Exit code 1"),
        "{help}"
    );
}

#[test]
fn every_other_point_array_is_interpolated_onto_the_surface() {
    // A sphere distance with the coordinates (linear: interpolated, they are the points) and an
    // integer label beside it, on a grid with an origin and unequal spacings.
    let dir = TempDir::new("iso-arrays");
    let mut grid = diamonds::Grid::new([21, 17, 19]);
    grid.origin = [-1.0, -0.9, -1.1];
    grid.spacing = [0.1, 0.12, 0.115];
    let mut distance = Vec::new();
    let mut position = Vec::new();
    let mut label = Vec::new();
    for k in 0..19 {
        for j in 0..17 {
            for i in 0..21 {
                let p = grid.point([i, j, k]);
                distance.push((p.iter().map(|c| c * c).sum::<f64>()).sqrt() as f32);
                position.extend(p);
                label.push((p[0] > 0.1) as i32);
            }
        }
    }
    let input = dir.join("arrays.vti");
    diamonds_cli::write::write_image(
        &input,
        &grid,
        &[
            Array::scalars("distance", distance),
            Array {
                name: "position".into(),
                components: 3,
                data: position.into(),
            },
            Array::scalars("label", label),
        ],
    )
    .unwrap();
    for (tol, scalars) in [("0", false), ("0.1", true)] {
        let out = dir.join("arrays.vtp");
        let mut args = vec![
            "--array",
            "distance",
            "--isovalue",
            "0.7",
            "--tolerance",
            tol,
        ];
        if scalars {
            args.push("--scalars");
        }
        iso(&input, &out, &args);
        let (surface, n) = read_surface(&out);
        assert!(n > 100);
        let names: Vec<&str> = surface.point_data.iter().map(|a| a.name.as_str()).collect();
        assert_eq!(
            names.contains(&"distance"),
            scalars,
            "the contoured array only with --scalars: {names:?}"
        );
        let array = |name: &str| surface.point_data.iter().find(|a| a.name == name).unwrap();
        let position = array("position");
        assert_eq!((position.components, position.type_name()), (3, "Float64"));
        for (p, point) in surface.points.iter().enumerate() {
            for c in 0..3 {
                let d = (position.value(3 * p + c) - point[c]).abs();
                assert!(
                    d <= 1e-12,
                    "tol {tol}: point {p} {point:?}, position {d} off"
                );
            }
        }
        let label = array("label");
        assert_eq!(label.type_name(), "Int32");
        let ones = (0..surface.points.len())
            .filter(|&p| label.value(p) == 1.0)
            .count();
        let zeros = (0..surface.points.len())
            .filter(|&p| label.value(p) == 0.0)
            .count();
        assert!(ones > 0 && zeros > 0 && ones + zeros == surface.points.len());
    }
}
