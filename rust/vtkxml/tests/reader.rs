//! The reader on files written by VTK itself (tests/fixtures, see make_fixtures.py) in every
//! encoding, images and surfaces, and the writer's output read back.

use std::path::{Path, PathBuf};
use vtkxml::{
    read_image, read_polydata, read_unstructured, write_image, write_tets, write_triangles, Array,
    TetGrid, Triangles, UniformGrid, Values,
};

/// A fixture (written by VTK itself, see tests/fixtures/make_fixtures.py).
fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// Every fixture holding the three point arrays.
const ENCODINGS: &[&str] = &[
    "ascii.vti",
    "inline_base64.vti",
    "inline_zlib_header64.vti",
    "appended_raw.vti",
    "appended_raw_zlib_blocks.vti",
    "appended_raw_zlib_header64.vti",
    "appended_base64.vti",
    "appended_base64_zlib_blocks.vti",
    "appended_raw_lz4_blocks.vti",
    "appended_raw_lzma_blocks.vti",
    "appended_raw_zlib_bigendian.vti",
];

#[test]
fn every_encoding_vtk_writes_reads_the_same_image() {
    // Extent 2..6 × 1..4 × 3..5, origin (0.5, -1, 2), spacing (0.25, 0.5, 1.5): the first point is at
    // origin + spacing × extent start.
    let dims = [5, 4, 3];
    let mut density = Vec::new();
    let mut velocity = Vec::new();
    for k in 0..3 {
        for j in 0..4 {
            for i in 0..5 {
                density.push((i + 10 * j + 100 * k - 50) as i16);
                velocity.extend([i as f32, j as f32, k as f32]);
            }
        }
    }
    let temperature: Vec<f32> = density.iter().map(|&d| d as f32 / 4.0).collect();
    for name in ENCODINGS {
        let image = read_image(&fixture(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(
            image.grid,
            UniformGrid {
                dims,
                origin: [1.0, -0.5, 6.5],
                spacing: [0.25, 0.5, 1.5]
            },
            "{name}"
        );
        let names: Vec<_> = image.point_data.iter().map(|a| a.name.as_str()).collect();
        assert_eq!(names, ["density", "temperature", "velocity"], "{name}");
        assert_eq!(image.active_scalars.as_deref(), Some("density"), "{name}");
        let [d, t, v] = &image.point_data[..] else {
            unreachable!()
        };
        assert_eq!(d.data, Values::I16(density.clone()), "{name}: density");
        assert_eq!(
            t.data,
            Values::F32(temperature.clone()),
            "{name}: temperature"
        );
        assert_eq!(v.components, 3, "{name}");
        assert_eq!(v.data, Values::F32(velocity.clone()), "{name}: velocity");
    }
}

#[test]
fn cell_data_of_images_is_named_not_decoded() {
    let image = read_image(&fixture("cell_data_only.vti")).unwrap();
    assert!(image.point_data.is_empty());
    assert_eq!(image.cell_arrays, ["pressure"]);
    let vectors = read_image(&fixture("vector_only.vti")).unwrap();
    assert_eq!(vectors.point_data[0].describe(), "velocity (3 components)");
}

#[test]
fn string_arrays_are_left_out_with_a_warning() {
    let image = read_image(&fixture("with_string_array.vti")).unwrap();
    let names: Vec<_> = image.point_data.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(names, ["density", "temperature", "velocity"]);
    assert_eq!(image.warnings.len(), 1, "{:?}", image.warnings);
    assert!(
        image.warnings[0].contains("'labels'"),
        "{:?}",
        image.warnings
    );
}

#[test]
fn written_images_read_back_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let grid = UniformGrid {
        dims: [3, 4, 5],
        origin: [-1.0 / 3.0, 0.1, 1e-7],
        spacing: [0.1, 2.0 / 7.0, 3.3],
    };
    let n = vtkxml::point_count(grid.dims).unwrap();
    let arrays = vec![
        Array::scalars("u8", (0..n).map(|i| i as u8).collect::<Vec<_>>()),
        Array::scalars("i8", (0..n).map(|i| -(i as i8)).collect::<Vec<_>>()),
        Array::scalars("u16", (0..n).map(|i| 1000 * i as u16).collect::<Vec<_>>()),
        Array::scalars("i16", (0..n).map(|i| -300 * i as i16).collect::<Vec<_>>()),
        Array::scalars("u32", (0..n).map(|i| 1 << (i % 32)).collect::<Vec<u32>>()),
        Array::scalars("i32", (0..n).map(|i| -(i as i32) << 20).collect::<Vec<_>>()),
        Array::scalars("i64", (0..n).map(|i| (i as i64) << 40).collect::<Vec<_>>()),
        Array::scalars("f32", (0..n).map(|i| i as f32 / 3.0).collect::<Vec<_>>()),
        Array::scalars(
            "f64 <&\"name\">",
            (0..n).map(|i| (i as f64).sqrt()).collect::<Vec<_>>(),
        ),
        Array {
            name: "vectors".into(),
            components: 3,
            data: (0..3 * n)
                .map(|i| i as f64 * 0.5)
                .collect::<Vec<_>>()
                .into(),
        },
    ];
    let path = dir.path().join("all.vti");
    write_image(&path, &grid, &arrays).unwrap();
    let image = read_image(&path).unwrap();
    assert_eq!(image.grid, grid, "origin and spacing keep full precision");
    assert_eq!(image.point_data, arrays);
    assert_eq!(image.active_scalars.as_deref(), Some("u8"));
}

/// Writes a tetrahedral mesh to `path` and checks that it reads back exactly.
fn assert_mesh_round_trip(
    path: &std::path::Path,
    points: &[[f64; 3]],
    tets: &[[u32; 4]],
    [point_data, cell_data, field_data]: [Vec<Array>; 3],
) {
    write_tets(
        path,
        TetGrid {
            points,
            tets,
            point_data: point_data.clone(),
            cell_data: cell_data.clone(),
            field_data: field_data.clone(),
        },
    )
    .unwrap();
    let mesh = read_unstructured(path).unwrap();
    assert_eq!(mesh.points, points);
    let corners: Vec<usize> = tets.iter().flatten().map(|&v| v as usize).collect();
    assert_eq!(mesh.connectivity, corners);
    let offsets: Vec<usize> = (1..=tets.len()).map(|c| 4 * c).collect();
    assert_eq!(mesh.offsets, offsets);
    assert_eq!(mesh.types, vec![10; tets.len()]);
    assert_eq!(mesh.point_data, point_data);
    assert_eq!(mesh.cell_data, cell_data);
    assert_eq!(mesh.field_data, field_data);
}

#[test]
fn written_meshes_read_back_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let points = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
    ];
    let point_data = vec![Array::scalars("value", vec![1u8, 2, 3, 4, 5])];
    let cell_data = vec![
        Array::scalars("BisectionDepth", vec![3u8, 4]),
        Array::scalars("ApproximationError", vec![0.5f32, 0.25]),
    ];
    let field_data = vec![
        Array::scalars("Tolerance", vec![0.5f64]),
        Array::scalars("NumberOfTetrahedra", vec![2i64]),
    ];
    let path = dir.path().join("mesh.vtu");
    let tets = [[0, 1, 2, 3], [1, 4, 2, 3]];
    assert_mesh_round_trip(&path, &points, &tets, [point_data, cell_data, field_data]);
}

/// Arrays of several compressed blocks (256 KiB each, streamed a batch at a time) of every value
/// size read back exactly, and so do the offsets of the arrays after them.
#[test]
fn written_meshes_of_many_blocks_read_back_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let n = 200_003; // points: 4.6 MB of Float64, 19 blocks; connectivity 3.2 MB
    let points: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let x = i as f64;
            [x.sin(), x.cos() * 1e3, x / 7.0]
        })
        .collect();
    let tets: Vec<[u32; 4]> = (0..n as u32 - 3)
        .map(|i| [i, i + 1, i + 2, i + 3])
        .collect();
    let point_data = vec![
        Array::scalars(
            "u8",
            (0..n).map(|i| (i * 7 % 251) as u8).collect::<Vec<_>>(),
        ),
        Array::scalars(
            "i16",
            (0..n).map(|i| (i % 60_000) as i16).collect::<Vec<_>>(),
        ),
    ];
    let cell_data = vec![Array::scalars(
        "f32",
        (0..tets.len()).map(|i| i as f32 * 0.5).collect::<Vec<_>>(),
    )];
    let path = dir.path().join("many.vtu");
    assert_mesh_round_trip(&path, &points, &tets, [point_data, cell_data, Vec::new()]);
    // Nothing but the file itself is left in the directory.
    assert_eq!(file_names(dir.path()), ["many.vtu"]);
}

/// The names of the files in `dir`.
fn file_names(dir: &std::path::Path) -> Vec<std::ffi::OsString> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect()
}

/// A write that fails (here: an array whose length does not match, or a directory that does not
/// exist) leaves an earlier file at the path as it was, and no partial file.
#[test]
fn failed_writes_leave_earlier_files_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("kept.vtu");
    std::fs::write(&path, b"earlier").unwrap();
    let points = [[0.0; 3]; 4];
    let grid = |point_data| TetGrid {
        points: &points,
        tets: &[[0, 1, 2, 3]],
        point_data,
        cell_data: Vec::new(),
        field_data: Vec::new(),
    };
    let short = vec![Array::scalars("short", vec![1u8, 2])];
    assert!(write_tets(&path, grid(short)).is_err());
    assert_eq!(std::fs::read(&path).unwrap(), b"earlier");
    let missing = dir.path().join("no such directory").join("mesh.vtu");
    let err = write_tets(&missing, grid(Vec::new())).unwrap_err();
    assert!(err.0.contains("cannot write"), "{err}");
    assert_eq!(file_names(dir.path()), ["kept.vtu"]);
}

#[test]
fn vtk_written_surfaces_read_the_same() {
    let ascii = read_polydata(&fixture("surface_ascii.vtp")).unwrap();
    let appended = read_polydata(&fixture("surface_appended_zlib_blocks.vtp")).unwrap();
    for (name, s) in [("ascii", &ascii), ("appended", &appended)] {
        assert_eq!((s.points.len(), s.offsets.len()), (34, 64), "{name}");
        assert!(s.offsets.iter().enumerate().all(|(c, &o)| o == 3 * (c + 1)));
        for p in &s.points {
            let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            assert!((r - 0.5).abs() < 1e-6, "{name}: {p:?} off the sphere");
        }
        let normals = &s.point_data[0];
        assert_eq!((normals.name.as_str(), normals.components), ("Normals", 3));
        assert_eq!(normals.type_name(), "Float32");
    }
    assert_eq!(ascii.connectivity, appended.connectivity);
    for (a, b) in ascii.points.iter().zip(&appended.points) {
        assert!((0..3).all(|k| (a[k] - b[k]).abs() < 1e-6), "{a:?} {b:?}");
    }
    let e = read_polydata(&fixture("lines.vtp")).unwrap_err().0;
    assert!(e.contains("1 lines") && e.contains("only polygons"), "{e}");
    let e = read_polydata(&fixture("ascii.vti")).unwrap_err().0;
    assert!(e.contains("unsupported surface file"), "{e}");
}

#[test]
fn written_surfaces_read_back_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let points = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0 / 3.0, 0.0],
        [0.0, 0.0, 1e-9],
    ];
    let triangles = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
    let point_data = vec![
        Array::scalars("value", vec![0.5f64, 0.5, 0.75, 0.75]),
        Array {
            name: "Normals".into(),
            components: 3,
            data: vec![
                0.0f32, 0.0, -1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.6, 0.8, 0.0,
            ]
            .into(),
        },
    ];
    let field_data = vec![
        Array::scalars("ErrorBound", vec![0.125f64]),
        Array::scalars("NumberOfTriangles", vec![4i64]),
    ];
    let path = dir.path().join("surface.vtp");
    write_triangles(
        &path,
        Triangles {
            points: &points,
            triangles: &triangles,
            point_data: point_data.clone(),
            field_data: field_data.clone(),
        },
    )
    .unwrap();
    let text = String::from_utf8_lossy(&std::fs::read(&path).unwrap()).into_owned();
    assert!(
        text.contains("<PointData Scalars=\"value\" Normals=\"Normals\">"),
        "active scalars and normals"
    );
    let surface = read_polydata(&path).unwrap();
    assert_eq!(surface.points, points);
    assert_eq!(surface.connectivity, [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3]);
    assert_eq!(surface.offsets, [3, 6, 9, 12]);
    assert_eq!(surface.point_data, point_data);
    assert!(surface.cell_data.is_empty());
    assert_eq!(surface.field_data, field_data);
    // An empty surface too.
    write_triangles(
        &path,
        Triangles {
            points: &[],
            triangles: &[],
            point_data: Vec::new(),
            field_data: Vec::new(),
        },
    )
    .unwrap();
    let surface = read_polydata(&path).unwrap();
    assert!(surface.points.is_empty() && surface.offsets.is_empty());
    // Wrong extension, wrong data length.
    assert!(write_triangles(
        &dir.path().join("surface.vtu"),
        Triangles {
            points: &points,
            triangles: &triangles,
            point_data: Vec::new(),
            field_data: Vec::new(),
        },
    )
    .is_err());
    assert!(write_triangles(
        &path,
        Triangles {
            points: &points,
            triangles: &triangles,
            point_data: vec![Array::scalars("short", vec![1u8])],
            field_data: Vec::new(),
        },
    )
    .is_err());
}

#[test]
fn corrupt_files_are_errors_not_panics() {
    let dir = tempfile::tempdir().unwrap();
    let good = std::fs::read(fixture("appended_raw_zlib_blocks.vti")).unwrap();
    let header_end = good
        .windows(15)
        .position(|w| w == b"<AppendedData e")
        .unwrap();
    let data_end = good
        .windows(15)
        .rposition(|w| w == b"</AppendedData>")
        .unwrap();
    // Truncations of the binary part, and bytes flipped in it.
    let path = dir.path().join("bad.vti");
    for cut in (header_end..data_end - 8).step_by(7) {
        std::fs::write(&path, &good[..cut]).unwrap();
        assert!(
            read_image(&path).is_err(),
            "truncated at {cut} was accepted"
        );
    }
    for at in (header_end + 40..good.len() - 20).step_by(5) {
        let mut bad = good.clone();
        bad[at] ^= 0x5a;
        std::fs::write(&path, &bad).unwrap();
        let _ = read_image(&path); // error or (if the flip hit padding) data, never a panic
    }
    for junk in [
        &b""[..],
        b"<VTKFile",
        b"\x00\x01\x02",
        b"<a><b></a>",
        b"<VTKFile type=\"ImageData\"/>",
    ] {
        std::fs::write(&path, junk).unwrap();
        assert!(read_image(&path).is_err(), "{junk:?} was accepted");
    }
    let surface = dir.path().join("bad.vtp");
    let good = std::fs::read(fixture("surface_appended_zlib_blocks.vtp")).unwrap();
    for cut in (0..good.len()).step_by(13) {
        std::fs::write(&surface, &good[..cut]).unwrap();
        let _ = read_polydata(&surface); // error, never a panic
    }
}

#[test]
fn written_polygons_read_back_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let points = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.5, 0.5, 1.0],
    ];
    // A quad and a triangle.
    let offsets = [0, 4, 7];
    let connectivity = [0, 1, 2, 3, 0, 1, 4];
    let point_data = vec![Array::scalars("height", vec![0.0f32, 0.0, 0.0, 0.0, 1.0])];
    let cell_data = vec![Array::scalars("Material", vec![-1i32, 2])];
    let field_data = vec![Array {
        name: "SlicePlane".into(),
        components: 6,
        data: vec![0.0f64, 0.0, 0.5, 0.0, 0.0, 1.0].into(),
    }];
    let path = dir.path().join("polygons.vtp");
    vtkxml::write_polygons(
        &path,
        vtkxml::Polygons {
            points: &points,
            offsets: &offsets,
            connectivity: &connectivity,
            point_data: point_data.clone(),
            cell_data: cell_data.clone(),
            field_data: field_data.clone(),
        },
    )
    .unwrap();
    let polygons = read_polydata(&path).unwrap();
    assert_eq!(polygons.points, points);
    assert_eq!(polygons.connectivity, [0, 1, 2, 3, 0, 1, 4]);
    assert_eq!(polygons.offsets, [4, 7]);
    assert_eq!(polygons.point_data, point_data);
    assert_eq!(polygons.cell_data, cell_data);
    assert_eq!(polygons.field_data, field_data);
}
