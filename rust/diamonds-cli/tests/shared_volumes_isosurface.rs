//! Every real volume in `../shared/data/volumes` (beside the checkout) contoured by `diamonds iso` at the
//! middle of its data range, at tolerance 0 and 1 % of the diagonal, and checked by `diamonds
//! verify-surface --image`: triangles of distinct points, every edge in two triangles traversed both ways
//! except on the image's bounds, unit normals; the error bound within the tolerance, fewer triangles at
//! 1 %.
//!
//! Isovalues equal to samples (headsq's middle value) make one point per sample at the isovalue (see
//! `isovalues_equal_to_samples_keep_a_consistent_orientation` in tests/isosurface.rs).
//!
//! One test per volume so that the harness spreads them over the cores; [`any_other_shared_volume`]
//! covers files added later. Bonsai (256³) runs at 1 % in release builds only (about 5 s); its
//! full-resolution surface (2 M triangles, about 10 s more) is ignored, run it with
//! `cargo test --release -p diamonds-cli --test shared_volumes_isosurface -- --ignored`.
//! Without `../shared` every test passes after printing "skipped: ../shared/data/volumes not found",
//! except under `CI=true` or `DIAMONDS_REQUIRE_SHARED=1` (as `.ci/run` sets), where they fail.

mod common;

use common::{diamonds, field_value, s, shared_volume, shared_volumes, TempDir};
use diamonds_cli::read::{read_image, read_polydata};
use std::path::Path;
use std::time::Instant;

/// Tolerance 0 and 1 % of the diagonal.
const BOTH: &[(&str, &str)] = &[("--tolerance", "0"), ("--relative-tolerance", "0.01")];

/// Contours `path` at the middle of its range at `tolerances` (option, value; increasing), verifies each;
/// returns a one-line report.
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
    let on_samples = (0..array.data.len()).any(|k| array.value(k) == middle);
    let isovalue = middle.to_string();
    let dir = TempDir::new("shared-iso");
    let mut line = format!(
        "{name}: '{}' at {isovalue}{}",
        array.name,
        if on_samples { " (a sample value)" } else { "" }
    );
    let mut last = usize::MAX;
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
        let run = diamonds(["verify-surface", s(&out), "--image", s(path)]);
        let report = run.stdout.clone();
        for check in ["triangles", "watertight", "normals"] {
            assert!(
                report.contains(&format!("  {check}: OK")),
                "{name} {option} {tol}: {run:#?}"
            );
        }
        assert_eq!(run.code, 0, "{name} {option} {tol}: {run:#?}");
        assert!(report.contains("verify-surface: PASSED"), "{report}");
        let surface = read_polydata(&out).unwrap();
        let n = surface.offsets.len();
        assert!(n > 0, "{name}: empty surface at the middle of the range");
        let bound = field_value(&surface.field_data, "ErrorBound");
        let tolerance = field_value(&surface.field_data, "Tolerance");
        assert!(
            bound <= tolerance,
            "{name}: error bound {bound} > tolerance {tolerance}"
        );
        assert!(
            n <= last,
            "{name}: more triangles at {tol} than at a smaller tolerance"
        );
        last = n;
        let watertight = report
            .lines()
            .find(|l| l.contains("watertight"))
            .unwrap_or_default()
            .trim();
        line.push_str(&format!(
            "; {option} {tol}: {n} triangles, error bound {bound}, {watertight}, {:.2} s ({})",
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
                    println!("{}", check_volume(&path, BOTH));
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
        println!("{}", check_volume(&path, &BOTH[1..]));
    }
}

#[test]
#[ignore = "2 M triangles, about 10 s: `cargo test --release -p diamonds-cli --test shared_volumes_isosurface -- --ignored`"]
fn bonsai_256_full_resolution() {
    if let Some(path) = shared_volume(BONSAI) {
        println!("{}", check_volume(&path, &BOTH[..1]));
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
        println!("{}", check_volume(&path, BOTH));
    }
}
