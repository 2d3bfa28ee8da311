//! Every real volume in `../shared/data/volumes` (beside the checkout) contoured by `diamonds iso` at the
//! middle of its data range (half-grey for integer data), at tolerance 0 and 0.5, 1, 2 and 4 % of the
//! diagonal, and for integer data also at the sample value above the middle at 1 %, and checked by
//! `diamonds verify-surface --image --isovalue --tolerance`: triangles of distinct points, every edge in
//! two triangles traversed both ways except on the image's bounds, unit normals, both one-sided
//! Hausdorff distances to the full-resolution surface within the tolerance (the two-sided bound); the
//! error bound within the tolerance, fewer triangles than at full resolution.
//!
//! Isovalues equal to samples (headsq's middle value) make one point per sample at the isovalue (see
//! `isovalues_equal_to_samples_keep_a_consistent_orientation` in tests/isosurface.rs).
//!
//! One test per volume so that the harness spreads them over the cores; [`any_other_shared_volume`]
//! covers files added later. Bonsai (256³) runs at 1 % in release builds only (about 10 s with the
//! distances); its
//! full-resolution surface (2 M triangles, about 10 s more) is ignored, run it with
//! `cargo test --release -p diamonds-cli --test shared_volumes_isosurface -- --ignored`.
//! Without `../shared` every test passes after printing "skipped: ../shared/data/volumes not found",
//! except under `CI=true` or `DIAMONDS_REQUIRE_SHARED=1` (as `.ci/run` sets), where they fail.

mod common;

use common::{diamonds, field_value, s, shared_volume, shared_volumes, TempDir};
use diamonds_cli::read::{read_image, read_polydata};
use std::path::Path;
use std::time::Instant;

/// Tolerance 0, 0.5, 1, 2 and 4 % of the diagonal.
const ALL: &[(&str, &str)] = &[
    ("--tolerance", "0"),
    ("--relative-tolerance", "0.005"),
    ("--relative-tolerance", "0.01"),
    ("--relative-tolerance", "0.02"),
    ("--relative-tolerance", "0.04"),
];

/// Contours `path` at the middle of its range at `tolerances` (option, value; increasing) and, for
/// integer data with several tolerances, at the sample value above the middle at 1 %; verifies each
/// (the two-sided bound included); returns a report, one line per isovalue.
fn check_volume(path: &Path, tolerances: &[(&str, &str)]) -> String {
    let name = path.file_name().unwrap().to_string_lossy().into_owned();
    let image = read_image(path).unwrap_or_else(|e| panic!("{name}: {e}"));
    let array = image
        .scalars(None)
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    let (lo, hi) = (0..array.data.len())
        .map(|k| array.value(k))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    let middle = 0.5 * (lo + hi);
    let integer = (0..array.data.len()).all(|k| array.value(k).fract() == 0.0);
    let mut lines = vec![check_isovalue(path, middle, tolerances)];
    if integer && middle.ceil() != middle && tolerances.len() > 1 {
        lines.push(check_isovalue(path, middle.ceil(), &ALL[2..3]));
    }
    lines.join("\n")
}

/// [`check_volume`] at one isovalue.
fn check_isovalue(path: &Path, middle: f64, tolerances: &[(&str, &str)]) -> String {
    let name = path.file_name().unwrap().to_string_lossy().into_owned();
    let image = read_image(path).unwrap();
    let array = image.scalars(None).unwrap();
    let on_samples = (0..array.data.len()).any(|k| array.value(k) == middle);
    let isovalue = middle.to_string();
    let dir = TempDir::new("shared-iso");
    let mut line = format!(
        "{name}: '{}' at {isovalue}{}",
        array.name,
        if on_samples { " (a sample value)" } else { "" }
    );
    let mut full = usize::MAX;
    for &(option, tol) in tolerances {
        let start = Instant::now();
        let out = dir.join("surface.vtp");
        let summary = diamonds([
            "iso",
            s(path),
            s(&out),
            "--isovalue",
            &isovalue,
            option,
            tol,
        ])
        .ok();
        let surface = read_polydata(&out).unwrap();
        let tolerance = field_value(&surface.field_data, "Tolerance").to_string();
        let run = diamonds([
            "verify-surface",
            s(&out),
            "--image",
            s(path),
            "--isovalue",
            &isovalue,
            "--tolerance",
            &tolerance,
        ]);
        let report = run.stdout.clone();
        for check in ["triangles", "watertight", "normals", "distance"] {
            assert!(
                report.contains(&format!("  {check}: OK")),
                "{name} {option} {tol}: {run:#?}"
            );
        }
        assert_eq!(run.code, 0, "{name} {option} {tol}: {run:#?}");
        assert!(report.contains("verify-surface: PASSED"), "{report}");
        let n = surface.offsets.len();
        assert!(n > 0, "{name}: empty surface at the middle of the range");
        let bound = field_value(&surface.field_data, "ErrorBound");
        let tolerance = field_value(&surface.field_data, "Tolerance");
        assert!(
            bound <= tolerance,
            "{name}: error bound {bound} > tolerance {tolerance}"
        );
        if tol == "0" {
            full = n;
        } else {
            assert!(
                n < full,
                "{name}: not fewer triangles at {tol} than at full resolution"
            );
        }
        let distance = report
            .lines()
            .find(|l| l.contains("distance"))
            .unwrap_or_default()
            .trim();
        line.push_str(&format!(
            "; {option} {tol}: {n} triangles, error bound {bound}, {distance}, {:.2} s ({})",
            start.elapsed().as_secs_f64(),
            summary.find("build").map_or("", |i| summary[i..].trim())
        ));
    }
    line
}

macro_rules! volume_tests {
    ($($test:ident: $file:literal;)*) => {
        $(
            #[test]
            fn $test() {
                if let Some(path) = shared_volume($file) {
                    println!("{}", check_volume(&path, ALL));
                }
            }
        )*
        /// The files the tests above name.
        const NAMED: &[&str] = &[$($file),*];
    };
}

volume_tests! {
    bucky: "bucky_32x32x32_uint8.vti";
    fuel: "fuel_64x64x64_uint8.vti";
    headsq_anisotropic_int16: "headsq_64x64x93_int16.vti";
    hydrogen_orbital_float32: "hydrogen_orbital_64x64x64_float32.vti";
    ironprot: "ironprot_68x68x68_uint8.vti";
    neghip: "neghip_64x64x64_uint8.vti";
    nucleon: "nucleon_41x41x41_uint8.vti";
    silicium: "silicium_98x34x34_uint8.vti";
}

const BONSAI: &str = "bonsai_256x256x256_uint8_lossy.vti";

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "256³ takes minutes in a debug build: run `cargo test --release -p diamonds-cli --test shared_volumes_isosurface`"
)]
fn bonsai_256_at_1_percent() {
    if let Some(path) = shared_volume(BONSAI) {
        println!("{}", check_volume(&path, &ALL[2..3]));
    }
}

#[test]
#[ignore = "2 M triangles, about 10 s: `cargo test --release -p diamonds-cli --test shared_volumes_isosurface -- --ignored`"]
fn bonsai_256_full_resolution() {
    if let Some(path) = shared_volume(BONSAI) {
        println!("{}", check_volume(&path, &ALL[..1]));
    }
}

/// Volumes added to `../shared/data/volumes` after these tests were written.
#[test]
fn any_other_shared_volume() {
    let Some(files) = shared_volumes() else {
        return;
    };
    for path in files {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if NAMED.contains(&name.as_str()) || name == BONSAI {
            continue;
        }
        println!("{}", check_volume(&path, ALL));
    }
}
