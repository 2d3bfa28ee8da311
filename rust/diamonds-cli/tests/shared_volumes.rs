//! Every real volume in `../shared/data/volumes` (beside the checkout) read with the CLI's reader, meshed
//! at tolerances 0, 2 and 8 and checked independently: conformity, exact volume, sample positions
//! (`check_mesh`) and the tolerance at every sample (`check_tolerance`, brute force).
//!
//! One test per volume so that the harness spreads them over the cores; [`any_other_shared_volume`]
//! covers files added later. Bonsai (256³) is checked at tolerances 2 and 8 in release builds only
//! (a debug build takes minutes: the tests are ignored there); its lossless brute-force check takes
//! several minutes even in release and is ignored, run it with
//! `cargo test --release -p diamonds-cli --test shared_volumes -- --ignored`.
//! Without `../shared` every test passes after printing "skipped: ../shared/data/volumes not found",
//! except under `CI=true` or `DIAMONDS_REQUIRE_SHARED=1` (as `.ci/run` sets), where they fail.

mod common;

use common::{shared_volume, shared_volumes};
use diamonds::validate::{check_mesh, check_tolerance};
use diamonds::{with_volume, Hierarchy, Query};
use diamonds_cli::read::read_image;
use diamonds_cli::AsScalarSlice;
use std::path::Path;
use std::time::Instant;

/// Builds the hierarchy of `path` and checks the meshes at `tolerances`; returns a one-line report.
fn check_volume(path: &Path, tolerances: &[f64]) -> String {
    let name = path.file_name().unwrap().to_string_lossy().into_owned();
    let image = read_image(path).unwrap_or_else(|e| panic!("{name}: {e}"));
    let array = image
        .scalars(None)
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    let grid = image.grid;
    let slice = array.scalar_slice().unwrap();
    let start = Instant::now();
    let h = Hierarchy::build(grid, slice, &mut |_| true).unwrap_or_else(|e| panic!("{name}: {e}"));
    let mut line = format!(
        "{name}: {:?} '{}', build {:.2} s",
        grid.dims,
        array.name,
        start.elapsed().as_secs_f64()
    );
    let mut last = usize::MAX;
    for &tol in tolerances {
        let start = Instant::now();
        let m = h
            .query(&Query::tolerance(tol))
            .unwrap_or_else(|e| panic!("{name} tol {tol}: {e}"));
        check_mesh(&m, &grid).unwrap_or_else(|e| panic!("{name} tol {tol}: {e}"));
        let measured = || -> diamonds::Result<Result<f64, String>> {
            Ok(with_volume!(grid, slice, |v| check_tolerance(
                &m, &v, tol, None
            )))
        };
        let worst = measured()
            .unwrap()
            .unwrap_or_else(|e| panic!("{name} tol {tol}: {e}"));
        assert!(
            m.max_error <= tol,
            "{name}: reported error {} above tolerance {tol}",
            m.max_error
        );
        assert!(
            worst <= m.max_error * (1.0 + 1e-9) + 1e-12,
            "{name} tol {tol}: measured {worst} above the reported bound {}",
            m.max_error
        );
        if tol == 0.0 {
            assert_eq!(
                worst, 0.0,
                "{name}: tolerance 0 must reproduce every sample"
            );
        }
        assert!(
            m.tets.len() <= last,
            "{name}: more tetrahedra at tolerance {tol} than at a smaller one"
        );
        last = m.tets.len();
        line.push_str(&format!(
            "; tol {tol}: {} tets, max error {}, checked in {:.2} s",
            m.tets.len(),
            m.max_error,
            start.elapsed().as_secs_f64()
        ));
    }
    line
}

macro_rules! volume_tests {
    ($($test:ident: $file:literal at $tolerances:expr;)*) => {
        $(
            #[test]
            fn $test() {
                if let Some(path) = shared_volume($file) {
                    println!("{}", check_volume(&path, &$tolerances));
                }
            }
        )*
        /// The files the tests above name.
        const NAMED: &[&str] = &[$($file),*];
    };
}

volume_tests! {
    bucky: "bucky_32x32x32_uint8.vti" at [0.0, 2.0, 8.0];
    fuel: "fuel_64x64x64_uint8.vti" at [0.0, 2.0, 8.0];
    headsq_anisotropic_int16: "headsq_64x64x93_int16.vti" at [0.0, 2.0, 8.0];
    hydrogen_orbital_float32: "hydrogen_orbital_64x64x64_float32.vti" at [0.0, 2.0, 8.0];
    ironprot: "ironprot_68x68x68_uint8.vti" at [0.0, 2.0, 8.0];
    neghip: "neghip_64x64x64_uint8.vti" at [0.0, 2.0, 8.0];
    nucleon: "nucleon_41x41x41_uint8.vti" at [0.0, 2.0, 8.0];
    silicium: "silicium_98x34x34_uint8.vti" at [0.0, 2.0, 8.0];
}

const BONSAI: &str = "bonsai_256x256x256_uint8_lossy.vti";

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "256³ takes minutes in a debug build: run `cargo test --release -p diamonds-cli --test shared_volumes`"
)]
fn bonsai_256_at_tolerance_2() {
    if let Some(path) = shared_volume(BONSAI) {
        println!("{}", check_volume(&path, &[2.0]));
    }
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "256³ takes minutes in a debug build: run `cargo test --release -p diamonds-cli --test shared_volumes`"
)]
fn bonsai_256_at_tolerance_8() {
    if let Some(path) = shared_volume(BONSAI) {
        println!("{}", check_volume(&path, &[8.0]));
    }
}

#[test]
#[ignore = "lossless brute-force check of 256³ takes minutes: `cargo test --release -p diamonds-cli --test shared_volumes -- --ignored`"]
fn bonsai_256_lossless() {
    if let Some(path) = shared_volume(BONSAI) {
        println!("{}", check_volume(&path, &[0.0]));
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
        println!("{}", check_volume(&path, &[0.0, 2.0, 8.0]));
    }
}
