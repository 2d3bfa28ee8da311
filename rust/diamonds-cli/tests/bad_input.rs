//! Bad input never panics: every case exits with code 2 and one clear `error: …` line.

mod common;

use common::{diamonds, fixture, s, TempDir};
use diamonds::Grid;
use diamonds_cli::write::write_image;
use diamonds_cli::Array;

/// Runs `diamonds args…`, expects a user error and returns its message.
fn error_of(args: &[&str]) -> String {
    diamonds(args).user_error()
}

fn assert_mentions(message: &str, words: &[&str]) {
    for w in words {
        assert!(message.contains(w), "'{w}' missing from: {message}");
    }
}

#[test]
fn missing_files() {
    let dir = TempDir::new("bad");
    let out = dir.join("out.vtu");
    let e = error_of(&["tetra", "/nonexistent/volume.vti", s(&out)]);
    assert_mentions(&e, &["cannot read", "/nonexistent/volume.vti"]);
    let e = error_of(&[
        "verify",
        "/nonexistent/volume.vti",
        s(&out),
        "--tolerance",
        "1",
    ]);
    assert_mentions(&e, &["cannot read"]);
    let input = fixture("appended_raw.vti");
    let e = error_of(&[
        "verify",
        s(&input),
        "/nonexistent/mesh.vtu",
        "--tolerance",
        "1",
    ]);
    assert_mentions(&e, &["cannot read", "/nonexistent/mesh.vtu"]);
    // An output folder that does not exist.
    let e = error_of(&["tetra", s(&input), "/nonexistent/out.vtu"]);
    assert_mentions(&e, &["cannot write", "/nonexistent/out.vtu"]);
}

#[test]
fn wrong_extensions() {
    let dir = TempDir::new("bad");
    let input = fixture("appended_raw.vti");
    let e = error_of(&["tetra", "picture.png", s(&dir.join("out.vtu"))]);
    assert_mentions(&e, &["unsupported input file", ".vti", ".vtk"]);
    let e = error_of(&["tetra", s(&input), s(&dir.join("out.vtk"))]);
    assert_mentions(&e, &[".vtu"]);
    let e = error_of(&["generate", s(&dir.join("volume.raw"))]);
    assert_mentions(&e, &[".vti"]);
    let e = error_of(&[
        "verify",
        s(&input),
        s(&dir.join("mesh.vtk")),
        "--tolerance",
        "0",
    ]);
    assert_mentions(&e, &[".vtu"]);
    // A .vtu given as the volume.
    let e = error_of(&["tetra", s(&dir.join("mesh.vtu")), s(&dir.join("out.vtu"))]);
    assert_mentions(&e, &["unsupported input file"]);
}

#[test]
fn missing_array_name() {
    let dir = TempDir::new("bad");
    let input = fixture("appended_raw_zlib_blocks.vti");
    let e = error_of(&[
        "tetra",
        s(&input),
        s(&dir.join("o.vtu")),
        "--array",
        "pressure",
    ]);
    assert_mentions(
        &e,
        &[
            "no point-data array named 'pressure'",
            "density",
            "temperature",
            "velocity (3 components)",
        ],
    );
}

#[test]
fn multi_component_arrays() {
    let dir = TempDir::new("bad");
    let out = dir.join("o.vtu");
    let e = error_of(&[
        "tetra",
        s(&fixture("appended_raw.vti")),
        s(&out),
        "--array",
        "velocity",
    ]);
    assert_mentions(&e, &["'velocity' has 3 components", "single-component"]);
    let e = error_of(&["tetra", s(&fixture("vector_only.vti")), s(&out)]);
    assert_mentions(&e, &["no single-component point-data array", "velocity"]);
}

#[test]
fn cell_data_only() {
    let dir = TempDir::new("bad");
    let e = error_of(&[
        "tetra",
        s(&fixture("cell_data_only.vti")),
        s(&dir.join("o.vtu")),
    ]);
    assert_mentions(&e, &["only cell data", "pressure", "point data"]);
}

#[test]
fn nan_in_a_float_volume() {
    let dir = TempDir::new("bad");
    let grid = Grid {
        dims: [4, 3, 2],
        origin: [0.0; 3],
        spacing: [1.0; 3],
    };
    let mut values = vec![1.5f32; grid.len()];
    values[7] = f32::NAN;
    let input = dir.join("nan.vti");
    write_image(&input, &grid, &[Array::scalars("f", values)]).unwrap();
    let e = error_of(&["tetra", s(&input), s(&dir.join("o.vtu"))]);
    assert_mentions(&e, &["non-finite", "NaN", "7"]);
    let mut inf = vec![0.0f64; grid.len()];
    inf[0] = f64::INFINITY;
    write_image(&input, &grid, &[Array::scalars("f", inf)]).unwrap();
    let e = error_of(&["tetra", s(&input), s(&dir.join("o.vtu"))]);
    assert_mentions(&e, &["non-finite"]);
}

#[test]
fn two_dimensional_images() {
    let dir = TempDir::new("bad");
    for dims in [[8, 8, 1], [1, 5, 5], [6, 1, 1]] {
        let grid = Grid {
            dims,
            origin: [0.0; 3],
            spacing: [1.0; 3],
        };
        let input = dir.join("flat.vti");
        write_image(&input, &grid, &[Array::scalars("v", vec![3u8; grid.len()])]).unwrap();
        let e = error_of(&["tetra", s(&input), s(&dir.join("o.vtu"))]);
        assert_mentions(&e, &["at least 2 points", "2-D"]);
    }
    let e = error_of(&["generate", s(&dir.join("g.vti")), "--dims", "8", "8", "1"]);
    assert_mentions(&e, &["at least 2 points"]);
}

#[test]
fn corrupt_files() {
    let dir = TempDir::new("bad");
    let out = dir.join("o.vtu");
    let vti = dir.join("junk.vti");
    let good = std::fs::read(fixture("appended_raw_zlib_blocks.vti")).unwrap();
    std::fs::write(&vti, &good[..good.len() - 200]).unwrap();
    let e = error_of(&["tetra", s(&vti), s(&out)]);
    assert_mentions(&e, &["junk.vti", "velocity", "truncated"]);
    std::fs::write(&vti, b"not xml at all \x00\xff").unwrap();
    error_of(&["tetra", s(&vti), s(&out)]);
    let vtk = dir.join("junk.vtk");
    std::fs::write(
        &vtk,
        b"# vtk DataFile Version 3.0\nx\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 2",
    )
    .unwrap();
    let e = error_of(&["tetra", s(&vtk), s(&out)]);
    assert_mentions(&e, &["junk.vtk"]);
    // A .vtu that is not a tetrahedral mesh of the volume's kind: an image given as the mesh.
    let mesh = dir.join("image.vtu");
    std::fs::copy(fixture("appended_raw.vti"), &mesh).unwrap();
    let e = error_of(&[
        "verify",
        s(&fixture("appended_raw.vti")),
        s(&mesh),
        "--tolerance",
        "0",
    ]);
    assert_mentions(&e, &["ImageData", "not UnstructuredGrid"]);
}

#[test]
fn invalid_options() {
    let dir = TempDir::new("bad");
    let input = fixture("appended_raw.vti");
    let out = dir.join("o.vtu");
    let e = error_of(&["tetra", s(&input), s(&out), "--tolerance", "-1"]);
    assert_mentions(&e, &["tolerance"]);
    let e = error_of(&["tetra", s(&input), s(&out), "--tolerance", "nan"]);
    assert_mentions(&e, &["tolerance"]);
    let e = error_of(&[
        "tetra",
        s(&input),
        s(&out),
        "--roi",
        "50",
        "60",
        "0",
        "1",
        "0",
        "1",
    ]);
    assert_mentions(&e, &["region of interest", "outside"]);
    let e = error_of(&["tetra", s(&input), s(&out), "--roi", "0", "1"]);
    assert_mentions(&e, &["--roi"]);
    let e = error_of(&["generate", s(&dir.join("g.vti")), "--type", "u128"]);
    assert_mentions(&e, &["u128"]);
    let e = error_of(&["verify", s(&input), s(&out)]);
    assert_mentions(&e, &["--tolerance"]);
    error_of(&["tetra"]);
    error_of(&["frobnicate"]);
}

#[test]
fn invalid_iso_options() {
    let dir = TempDir::new("bad");
    let input = fixture("appended_raw.vti");
    let out = dir.join("o.vtp");
    let iso = |extra: &[&str]| {
        let mut args = vec!["iso", s(&input), s(&out)];
        args.extend(extra);
        error_of(&args)
    };
    let e = iso(&[]);
    assert_mentions(&e, &["--isovalue"]);
    for bad in ["--isovalue=nan", "--isovalue=inf", "--isovalue=-inf"] {
        let e = iso(&["--isovalue", "1", bad]);
        assert_mentions(&e, &["isovalue", "finite"]);
    }
    let e = iso(&["--isovalue", "x"]);
    assert_mentions(&e, &["--isovalue", "'x'"]);
    let e = iso(&["--isovalue", "1", "--tolerance", "-1"]);
    assert_mentions(&e, &["tolerance", ">= 0", "-1"]);
    let e = iso(&["--isovalue", "1", "--tolerance", "nan"]);
    assert_mentions(&e, &["tolerance", "finite"]);
    let e = iso(&["--isovalue", "1", "--relative-tolerance", "-0.01"]);
    assert_mentions(&e, &["relative tolerance", ">= 0", "diagonal"]);
    let e = iso(&[
        "--isovalue",
        "1",
        "--tolerance",
        "1",
        "--relative-tolerance",
        "0.01",
    ]);
    assert_mentions(
        &e,
        &["--tolerance", "--relative-tolerance", "cannot be used with"],
    );
    let e = iso(&["--isovalue", "1", "--max-triangles=-5"]);
    assert_mentions(&e, &["--max-triangles"]);
    let e = iso(&["--isovalue", "1", "--roi", "50", "60", "0", "1", "0", "1"]);
    assert_mentions(&e, &["region of interest", "outside"]);
    let e = iso(&["--isovalue", "1", "--array", "velocity"]);
    assert_mentions(&e, &["'velocity' has 3 components"]);
    // Wrong extensions, found before any work.
    let e = error_of(&["iso", s(&input), s(&dir.join("o.vtu")), "--isovalue", "1"]);
    assert_mentions(&e, &["output", ".vtp"]);
    let e = iso(&["--isovalue", "1", "--carrier", s(&dir.join("c.vtp"))]);
    assert_mentions(&e, &["carrier", ".vtu"]);
    let e = error_of(&["iso", "/nonexistent/volume.vti", s(&out), "--isovalue", "1"]);
    assert_mentions(&e, &["cannot read", "/nonexistent/volume.vti"]);
    assert!(!out.exists(), "no output after an error");
}

#[test]
fn invalid_verify_surface_input() {
    let dir = TempDir::new("bad");
    let e = error_of(&["verify-surface", "/nonexistent/surface.vtp"]);
    assert_mentions(&e, &["cannot read", "/nonexistent/surface.vtp"]);
    let e = error_of(&["verify-surface", s(&fixture("appended_raw.vti"))]);
    assert_mentions(&e, &["unsupported surface file", ".vtp"]);
    // An image given as the surface, and a surface given as the image.
    let image_as_surface = dir.join("image.vtp");
    std::fs::copy(fixture("appended_raw.vti"), &image_as_surface).unwrap();
    let e = error_of(&["verify-surface", s(&image_as_surface)]);
    assert_mentions(&e, &["ImageData", "not PolyData"]);
    let surface = dir.join("s.vtp");
    diamonds([
        "iso",
        s(&fixture("appended_raw.vti")),
        s(&surface),
        "--isovalue",
        "0.5",
    ])
    .ok();
    let e = error_of(&["verify-surface", s(&surface), "--image", s(&surface)]);
    assert_mentions(&e, &["unsupported input file"]);
    // Truncated.
    let good = std::fs::read(&surface).unwrap();
    std::fs::write(&surface, &good[..good.len() - 40]).unwrap();
    error_of(&["verify-surface", s(&surface)]);
}

/// A `.vti` declaring 4000³ points (256 GB of Float32) that holds 8 values, in `format` with
/// `data` (and `header_type`, `compressor`): refused with the counts before anything that size is
/// allocated, by `tetra`, `iso` and `material`.
#[test]
fn declared_sizes_beyond_the_data_are_refused_before_allocating() {
    let dir = TempDir::new("bad");
    let cases = [
        ("ascii", "", "0 1 2 3 4 5 6 7"),
        (
            "binary",
            r#"header_type="UInt64""#,
            "IAAAAAAAAAAAAAAAAACAPwAAAEAAAEBAAACAQAAAoEAAAMBAAADgQA==",
        ),
        (
            "binary",
            r#"header_type="UInt64" compressor="vtkZLibDataCompressor""#,
            "AQAAAAAAAAAAAMqaOwAAAAAAAAAAAAAAHQAAAAAAAAA=eJxjYACBBnsg4QBEQNwAxAuA+AAQP3AAADvHBUA=",
        ),
        (
            "binary",
            r#"header_type="UInt64" compressor="vtkLZ4DataCompressor""#,
            "AQAAAAAAAAAAAMqaOwAAAAAAAAAAAAAAIgAAAAAAAAA=8BEAAAAAAACAPwAAAEAAAEBAAACAQAAAoEAAAMBAAADgQA==",
        ),
    ];
    for (format, attributes, data) in cases {
        let input = dir.join("huge.vti");
        std::fs::write(
            &input,
            format!(
                r#"<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" {attributes}>
  <ImageData WholeExtent="0 3999 0 3999 0 3999" Origin="0 0 0" Spacing="1 1 1">
  <Piece Extent="0 3999 0 3999 0 3999">
    <PointData Scalars="f">
      <DataArray type="Float32" Name="f" format="{format}">{data}</DataArray>
    </PointData>
  </Piece>
  </ImageData>
</VTKFile>"#
            ),
        )
        .unwrap();
        for command in [
            vec!["tetra", s(&input), s(&dir.join("o.vtu"))],
            vec!["iso", s(&input), s(&dir.join("o.vtp")), "--isovalue", "1"],
            vec!["material", s(&input), "-o", s(&dir.join("m"))],
        ] {
            let e = error_of(&command);
            assert_mentions(&e, &["huge.vti", "'f'"]);
            assert!(
                e.contains("64000000000") || e.contains("256000000000"),
                "{format} {attributes}: the declared count missing from: {e}"
            );
        }
    }
}

#[test]
fn legacy_files_that_do_not_match_their_header_say_where() {
    let dir = TempDir::new("bad");
    let header = "# vtk DataFile Version 3.0\nbad\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 2 2\nORIGIN 0 0 0\nSPACING 1 1 1\n";
    let cases = [
        // Too few values.
        (
            "POINT_DATA 8\nSCALARS density float 1\nLOOKUP_TABLE default\n1 2 3 4 5\n",
            &["'density'", "needs 8 values", "ends after 5"][..],
        ),
        // Not a number.
        (
            "POINT_DATA 8\nSCALARS density float\nLOOKUP_TABLE default\n1 2 3 x 5 6 7 8\n",
            &["'density'", "line 10", "'x'", "not a number"][..],
        ),
        // A point count that is not the grid's.
        (
            "POINT_DATA 9\nSCALARS density float\nLOOKUP_TABLE default\n1 2 3 4 5 6 7 8 9\n",
            &["line 8", "POINT_DATA 9", "8 points"][..],
        ),
        // A field array short of values.
        (
            "POINT_DATA 8\nFIELD FieldData 1\ntemperature 1 8 double\n1 2 3\n",
            &["'temperature'", "needs 8 values", "ends after 3"][..],
        ),
    ];
    let vtk = dir.join("bad.vtk");
    for (body, words) in cases {
        std::fs::write(&vtk, format!("{header}{body}")).unwrap();
        let e = error_of(&["tetra", s(&vtk), s(&dir.join("o.vtu"))]);
        assert_mentions(&e, &["bad.vtk"]);
        assert_mentions(&e, words);
        assert!(!e.contains("Parse error"), "{e}");
    }
    // 4000³ points declared, 8 values given, binary: refused before vtkio reserves the declared size.
    let mut huge = b"# vtk DataFile Version 3.0\nbad\nBINARY\nDATASET STRUCTURED_POINTS\nDIMENSIONS 4000 4000 4000\nORIGIN 0 0 0\nSPACING 1 1 1\nPOINT_DATA 64000000000\nSCALARS f float 1\nLOOKUP_TABLE default\n".to_vec();
    huge.extend(std::iter::repeat_n(0u8, 32));
    std::fs::write(&vtk, huge).unwrap();
    let e = error_of(&["tetra", s(&vtk), s(&dir.join("o.vtu"))]);
    assert_mentions(&e, &["'f'", "256000000000 bytes", "32 bytes left"]);
}

#[test]
fn int64_arrays_are_converted_like_the_plugin_does() {
    let dir = TempDir::new("bad");
    let grid = Grid {
        dims: [5, 4, 3],
        origin: [0.0; 3],
        spacing: [1.0; 3],
    };
    let input = dir.join("counts.vti");
    let counts: Vec<i64> = (0..grid.len() as i64).map(|i| i * i - 7).collect();
    write_image(&input, &grid, &[Array::scalars("counts", counts)]).unwrap();
    let out = dir.join("o.vtu");
    let run = diamonds(["tetra", s(&input), s(&out), "--tolerance", "0"]);
    assert!(
        run.stderr
            .contains("'counts' holds 64-bit integers (Int64)")
            && run.stderr.contains("converted to double"),
        "{run:#?}"
    );
    run.ok();
    let said = diamonds(["verify", s(&input), s(&out), "--tolerance", "0"]).ok();
    assert!(said.contains("counts"), "{said}");
    let run = diamonds([
        "iso",
        s(&input),
        s(&dir.join("o.vtp")),
        "--isovalue",
        "100.5",
    ]);
    run.ok();
    // Beyond 2^53 a double is inexact: refused, as in the plugin.
    let big: Vec<u64> = (0..grid.len() as u64).map(|i| i + (1 << 60)).collect();
    write_image(&input, &grid, &[Array::scalars("big", big)]).unwrap();
    let e = error_of(&["tetra", s(&input), s(&out)]);
    assert_mentions(&e, &["'big'", "UInt64", "2^53"]);
}
