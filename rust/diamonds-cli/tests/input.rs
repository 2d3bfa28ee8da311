//! The CLI's image input on the reader fixtures (../vtkxml/tests/fixtures, see make_fixtures.py):
//! legacy `.vtk` files read like the XML ones, the choice of the array to mesh, surfaces written by
//! VTK verify, corrupt files are errors.

mod common;

use common::{fixture, TempDir};
use diamonds_cli::commands::verify_surface;
use diamonds_cli::read::read_image;

#[test]
fn legacy_files_read_like_xml_and_every_encoding_chooses_the_same_scalars() {
    let xml = read_image(&fixture("ascii.vti")).unwrap();
    for name in ["legacy_ascii.vtk", "legacy_binary.vtk"] {
        let image = read_image(&fixture(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(image.grid, xml.grid, "{name}");
        assert_eq!(image.point_data, xml.point_data, "{name}");
        assert_eq!(image.active_scalars.as_deref(), Some("density"), "{name}");
    }
    for name in [
        "ascii.vti",
        "appended_raw_zlib_blocks.vti",
        "legacy_ascii.vtk",
        "legacy_binary.vtk",
    ] {
        let image = read_image(&fixture(name)).unwrap();
        assert_eq!(image.scalars(None).unwrap().name, "density", "{name}");
        assert_eq!(
            image.scalars(Some("temperature")).unwrap().name,
            "temperature"
        );
    }
}

#[test]
fn cell_data_and_vector_only_images_are_refused_for_meshing() {
    let cells = read_image(&fixture("cell_data_only.vti")).unwrap();
    assert!(cells.point_data.is_empty());
    assert_eq!(cells.cell_arrays, ["pressure"]);
    let e = cells.scalars(None).unwrap_err().0;
    assert!(e.contains("only cell data (pressure)"), "{e}");
    let e = cells.scalars(Some("pressure")).unwrap_err().0;
    assert!(e.contains("cell data"), "{e}");

    let vectors = read_image(&fixture("vector_only.vti")).unwrap();
    let e = vectors.scalars(None).unwrap_err().0;
    assert!(
        e.contains("no single-component") && e.contains("velocity (3 components)"),
        "{e}"
    );
    let e = vectors.scalars(Some("velocity")).unwrap_err().0;
    assert!(e.contains("has 3 components"), "{e}");
}

#[test]
fn vtk_written_surfaces_verify() {
    // A closed, consistently oriented surface with unit normals.
    for name in ["surface_ascii.vtp", "surface_appended_zlib_blocks.vtp"] {
        let report = verify_surface(&fixture(name), None, None).unwrap();
        assert!(report.passed, "{name}: {:#?}", report.lines);
    }
}

#[test]
fn corrupt_files_are_errors_not_panics() {
    let dir = TempDir::new("input");
    let surface = dir.join("bad.vtp");
    let good = std::fs::read(fixture("surface_appended_zlib_blocks.vtp")).unwrap();
    for cut in (0..good.len()).step_by(13) {
        std::fs::write(&surface, &good[..cut]).unwrap();
        let _ = verify_surface(&surface, None, None); // error, never a panic
    }
    let legacy = dir.join("bad.vtk");
    let good = std::fs::read(fixture("legacy_binary.vtk")).unwrap();
    for cut in (0..good.len()).step_by(11) {
        std::fs::write(&legacy, &good[..cut]).unwrap();
        let _ = read_image(&legacy);
    }
}
