//! `diamonds generate --field impact` and `diamonds material` end to end: the generated impact case
//! through the binary, its three outputs read back and checked independently (tolerances at every
//! cell, conformity, outputs on the box and on the slice plane), plain interpolation against ghost
//! values, rectilinear grids with cell data, bad inputs, and the CTH data of `../shared` when present.

mod common;

use common::{diamonds, field_value, s, shared_file, TempDir};
use diamonds::material::{MaterialInput, MaterialModel, PolygonMesh};
use diamonds::validate::{check_conforming, check_crack_free};
use diamonds_cli::read::{
    read_polydata, read_structured, read_unstructured, StructuredGrid, Unstructured,
};
use diamonds_cli::write::write_image;
use diamonds_cli::Array;
use std::path::{Path, PathBuf};

const FRACTIONS: &str =
    "Volume Fraction for Void,Volume Fraction for Block,Volume Fraction for Projectile";

/// Tetrahedra of the base mesh of the impact case's lattice: the band of 1-cell tetrahedra along its far
/// faces that every query starts from, since every sample of its 32 × 32 × 52 points is a lattice
/// vertex.
fn impact_base_tetrahedra() -> usize {
    let case = diamonds::fields::impact_case(diamonds_cli::material::IMPACT_DIMS);
    let input = MaterialInput {
        grid: case.grid,
        fractions: case.fractions.iter().map(|f| f.as_slice()).collect(),
        fields: Vec::new(),
        field_names: Vec::new(),
        material_fields: Vec::new(),
        interfaces: None,
    };
    MaterialModel::new(&input).unwrap().base_tetrahedra()
}

fn generate_impact(dir: &TempDir) -> PathBuf {
    let path = dir.join("impact.vti");
    let said = diamonds(["generate", s(&path), "--field", "impact"]).ok();
    assert!(said.contains("32x32x52"), "{said}");
    path
}

fn array<'a>(arrays: &'a [Array], name: &str) -> &'a Array {
    arrays
        .iter()
        .find(|a| a.name == name)
        .unwrap_or_else(|| panic!("no array {name}: {:?}", names(arrays)))
}

fn names(arrays: &[Array]) -> Vec<&str> {
    arrays.iter().map(|a| a.name.as_str()).collect()
}

fn values(a: &Array) -> Vec<f64> {
    (0..a.data.len()).map(|k| a.value(k)).collect()
}

fn outputs(base: &Path) -> [PathBuf; 3] {
    diamonds_cli::material::output_paths(base)
}

/// Tetrahedra only, tiling `bounds` conformingly ([`check_conforming`]: positive volumes summing to
/// the box, every face in two tetrahedra, or in one when it lies in a face of `bounds`).
fn assert_conforming(mesh: &Unstructured, bounds: [f64; 6]) {
    assert!(mesh.types.iter().all(|&t| t == 10), "only VTK_TETRA");
    assert!(mesh
        .offsets
        .iter()
        .enumerate()
        .all(|(c, &o)| o == 4 * (c + 1)));
    let tets: Vec<[u32; 4]> = mesh
        .connectivity
        .chunks_exact(4)
        .map(|t| [t[0], t[1], t[2], t[3]].map(|i| i as u32))
        .collect();
    check_conforming(&mesh.points, &tets, bounds).unwrap_or_else(|e| panic!("{e}"));
}

fn run_material(input: &Path, base: &Path, extra: &[&str]) -> String {
    let mut args = vec!["material", s(input), "-o", s(base)];
    args.extend_from_slice(extra);
    diamonds(args).ok()
}

#[test]
fn generated_impact_case_has_three_materials_and_density() {
    let dir = TempDir::new("impact");
    let path = generate_impact(&dir);
    let data = read_structured(&path).unwrap();
    assert_eq!(data.dims, [32, 32, 52]);
    let grid = data.grid().unwrap();
    let b = grid.bounds();
    assert!(
        (b[1] - 12.0).abs() < 1e-12 && (b[4] + 16.0).abs() < 1e-12 && (b[5] - 4.8).abs() < 1e-9
    );
    let f: Vec<Vec<f64>> = FRACTIONS
        .split(',')
        .map(|n| values(array(&data.point_data, n)))
        .collect();
    for p in 0..grid.len() {
        let sum: f64 = f.iter().map(|v| v[p]).sum();
        assert!((sum - 1.0).abs() < 1e-5, "fractions sum to {sum} at {p}");
    }
    for v in &f {
        assert!(v.contains(&1.0), "every material fills some point");
    }
    let density = values(array(&data.point_data, "Density"));
    assert!(density.iter().all(|d| d.is_finite() && *d >= 0.0));
    // --type does not apply.
    let e = diamonds([
        "generate",
        s(&dir.join("x.vti")),
        "--field",
        "impact",
        "--type",
        "u8",
    ])
    .user_error();
    assert!(e.contains("Float32"), "{e}");
}

#[test]
fn impact_case_meets_both_tolerances_with_fewer_tets_than_plain_interpolation() {
    let dir = TempDir::new("material");
    let input = generate_impact(&dir);
    let base = dir.join("impact");
    let said = run_material(
        &input,
        &base,
        &[
            "--fractions",
            FRACTIONS,
            "--fields",
            "Density",
            "--interface-tolerance",
            "0.15",
            "--field-tolerance",
            "3",
            "--slice",
            "6,0.8,-4,0,1,0",
        ],
    );
    println!("{said}");
    let [vtu, interfaces, slice] = outputs(&base);
    let mesh = read_unstructured(&vtu).unwrap();
    let n_tets = mesh.types.len();
    // Beyond the base mesh: no more than the paper's 11,990.
    let base_tets = impact_base_tetrahedra();
    assert!(
        n_tets > base_tets && n_tets - base_tets <= 11_990,
        "{n_tets} tetrahedra, {base_tets} in the base mesh (paper: 11,990)"
    );
    assert_eq!(
        field_value(&mesh.field_data, "NumberOfTetrahedra"),
        n_tets as f64
    );
    assert!(field_value(&mesh.field_data, "InterfaceTetrahedra") <= n_tets as f64);
    assert!(field_value(&mesh.field_data, "MaximumInterfaceError") <= 0.15);
    assert!(field_value(&mesh.field_data, "MaximumFieldError") <= 3.0);
    assert_eq!(field_value(&mesh.field_data, "InterfaceTolerance"), 0.15);
    assert_eq!(field_value(&mesh.field_data, "FieldTolerance"), 3.0);
    for (name, tol) in [("InterfaceError", 0.15), ("FieldError", 3.0)] {
        let e = values(array(&mesh.cell_data, name));
        assert_eq!(e.len(), n_tets);
        let worst = e.iter().copied().fold(0.0, f64::max);
        assert!(worst <= tol * (1.0 + 1e-6), "{name} {worst} > {tol}");
    }
    for name in ["Materials", "NumberOfMaterials", "BisectionDepth"] {
        assert_eq!(array(&mesh.cell_data, name).tuples(), n_tets, "{name}");
    }
    let point_names = names(&mesh.point_data);
    for name in [
        "Material",
        "SignedDistance Void|Block",
        "SignedDistance Block",
        "Density",
        "Density (Projectile)",
        "IsGhost (Void)",
    ] {
        assert!(point_names.contains(&name), "{name} in {point_names:?}");
    }
    // One value per vertex and material; IsGhost says which are ghosts. At a vertex of material m
    // whose interpolation cell has only samples of m (those of non-zero trilinear weight), m's own
    // value is the resampled mixed field (elsewhere it is interpolated from m's samples only).
    let data = read_structured(&input).unwrap();
    let grid = data.grid().unwrap();
    let f: Vec<Vec<f64>> = FRACTIONS
        .split(',')
        .map(|n| values(array(&data.point_data, n)))
        .collect();
    let label = |p: usize| (0..3).fold(0, |best, m| if f[m][p] > f[best][p] { m } else { best });
    let material = values(array(&mesh.point_data, "Material"));
    let density = values(array(&mesh.point_data, "Density"));
    let mut uniform_checked = 0;
    for (m, name) in ["Void", "Block", "Projectile"].iter().enumerate() {
        let own = values(array(&mesh.point_data, &format!("Density ({name})")));
        let ghost = values(array(&mesh.point_data, &format!("IsGhost ({name})")));
        assert_eq!(own.len(), material.len());
        for p in 0..material.len() {
            assert_eq!(ghost[p] == 0.0, material[p] == m as f64);
            if material[p] != m as f64 {
                continue;
            }
            let x = mesh.points[p];
            let mut corners = Vec::new();
            let mut base = [0usize; 3];
            let mut t = [0f64; 3];
            for a in 0..3 {
                let u = (x[a] - grid.origin[a]) / grid.spacing[a];
                base[a] = (u.floor().max(0.0) as usize).min(grid.dims[a] - 2);
                t[a] = u - base[a] as f64;
            }
            for c in 0..8 {
                let o = [c & 1, (c >> 1) & 1, c >> 2];
                let w: f64 = (0..3)
                    .map(|a| if o[a] == 1 { t[a] } else { 1.0 - t[a] })
                    .product();
                if w > 1e-9 {
                    corners.push(grid.index(base[0] + o[0], base[1] + o[1], base[2] + o[2]));
                }
            }
            if corners.iter().all(|&c| label(c) == m) {
                uniform_checked += 1;
                assert!(
                    (own[p] - density[p]).abs() <= 1e-4 * density[p].abs().max(1.0),
                    "Density ({name}) {} != Density {} at vertex {p} in a uniform cell",
                    own[p],
                    density[p]
                );
            }
        }
    }
    assert!(
        uniform_checked > 100,
        "{uniform_checked} vertices in uniform cells"
    );
    let bounds = [0.0, 12.0, 0.0, 12.0, -16.0, 4.8];
    assert_conforming(&mesh, bounds);

    // The interfaces: polygons with their pair, no crack (every edge in ≥ 2 polygons, or in the box).
    let polys = read_polydata(&interfaces).unwrap();
    assert!(!polys.offsets.is_empty());
    let a = values(array(&polys.cell_data, "MaterialA"));
    let b = values(array(&polys.cell_data, "MaterialB"));
    assert!(a.iter().zip(&b).all(|(a, b)| a < b && *b <= 2.0));
    let interfaces = PolygonMesh {
        points: polys.points.clone(),
        offsets: std::iter::once(0)
            .chain(polys.offsets.iter().map(|&o| o as u32))
            .collect(),
        connectivity: polys.connectivity.iter().map(|&i| i as u32).collect(),
        labels: a
            .iter()
            .zip(&b)
            .map(|(&a, &b)| [a as u8, b as u8])
            .collect(),
        ..Default::default()
    };
    check_crack_free(&interfaces, bounds).unwrap_or_else(|e| panic!("{e}"));

    // The slice lies on y = 0.8 (through the projectile) and carries per-material density.
    let cut = read_polydata(&slice).unwrap();
    assert!(!cut.offsets.is_empty());
    assert!(cut.points.iter().all(|p| (p[1] - 0.8).abs() < 1e-9));
    let cut_material = values(array(&cut.cell_data, "Material"));
    assert!(cut_material.iter().all(|&m| (0.0..=2.0).contains(&m)));
    for m in 0..3 {
        assert!(
            cut_material.contains(&(m as f64)),
            "material {m} on the slice"
        );
    }
    assert_eq!(array(&cut.point_data, "Density").tuples(), cut.points.len());

    // Plain linear interpolation needs at least 3x more tetrahedra at the same field tolerance.
    let plain_base = dir.join("plain");
    run_material(
        &input,
        &plain_base,
        &[
            "--fields",
            "Density",
            "--interface-tolerance",
            "0.15",
            "--field-tolerance",
            "3",
            "--no-ghost-values",
        ],
    );
    let plain = read_unstructured(&outputs(&plain_base)[0]).unwrap();
    println!(
        "ghost values: {n_tets} tetrahedra; plain interpolation: {}",
        plain.types.len()
    );
    assert!(plain.types.len() - base_tets >= 3 * (n_tets - base_tets));
    assert!(!names(&plain.point_data).contains(&"Density (Block)"));
    let worst = values(array(&plain.cell_data, "FieldError"))
        .into_iter()
        .fold(0.0, f64::max);
    assert!(worst <= 3.0 * (1.0 + 1e-6));
}

/// A small `.vtr` in ASCII: `coords` per axis, cell data `cells` (name, values).
fn write_vtr(path: &Path, coords: [&[f64]; 3], cells: &[(&str, Vec<f64>)]) {
    let dims = coords.map(|c| c.len());
    let ext = format!("0 {} 0 {} 0 {}", dims[0] - 1, dims[1] - 1, dims[2] - 1);
    let join = |v: &[f64]| v.iter().map(f64::to_string).collect::<Vec<_>>().join(" ");
    let mut xml = format!(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"RectilinearGrid\" version=\"0.1\" byte_order=\"LittleEndian\">\n<RectilinearGrid WholeExtent=\"{ext}\">\n<Piece Extent=\"{ext}\">\n<PointData>\n</PointData>\n<CellData>\n"
    );
    for (name, v) in cells {
        xml += &format!(
            "<DataArray type=\"Float32\" Name=\"{name}\" format=\"ascii\">{}</DataArray>\n",
            join(v)
        );
    }
    xml += "</CellData>\n<Coordinates>\n";
    for c in coords {
        xml += &format!(
            "<DataArray type=\"Float64\" format=\"ascii\">{}</DataArray>\n",
            join(c)
        );
    }
    xml += "</Coordinates>\n</Piece>\n</RectilinearGrid>\n</VTKFile>\n";
    std::fs::write(path, xml).unwrap();
}

/// Cell fractions of a ball (material "Ball") in void on `coords`.
fn ball_cells(coords: [&[f64]; 3]) -> Vec<(&'static str, Vec<f64>)> {
    let mut ball = Vec::new();
    for k in 0..coords[2].len() - 1 {
        for j in 0..coords[1].len() - 1 {
            for i in 0..coords[0].len() - 1 {
                let c = [
                    0.5 * (coords[0][i] + coords[0][i + 1]),
                    0.5 * (coords[1][j] + coords[1][j + 1]),
                    0.5 * (coords[2][k] + coords[2][k + 1]),
                ];
                let r = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
                ball.push((1.5 - r).clamp(0.0, 1.0));
            }
        }
    }
    let void = ball.iter().map(|f| 1.0 - f).collect();
    vec![
        ("Volume Fraction for Ball", ball),
        ("Void Volume Fraction", void),
        (
            "Pressure",
            (0..(coords[0].len() - 1) * (coords[1].len() - 1) * (coords[2].len() - 1))
                .map(|c| c as f64 * 0.01)
                .collect(),
        ),
    ]
}

#[test]
fn rectilinear_grids_with_cell_data() {
    let dir = TempDir::new("vtr");
    let axis: Vec<f64> = (0..13).map(|i| -3.0 + 0.5 * i as f64).collect();
    let coords = [&axis[..], &axis[..], &axis[..11]];
    let path = dir.join("ball.vtr");
    write_vtr(&path, coords, &ball_cells(coords));
    let data = read_structured(&path).unwrap();
    assert_eq!(data.dims, [13, 13, 11]);
    assert_eq!(data.cell_data.len(), 3);
    assert!(data.point_data.is_empty());
    let grid = data.grid().unwrap();
    assert_eq!(grid.origin, [-3.0; 3]);
    assert_eq!(grid.spacing, [0.5; 3]);
    let base = dir.join("ball");
    let said = run_material(
        &path,
        &base,
        &["--fields", "Pressure", "--field-tolerance", "0.5"],
    );
    assert!(said.contains("materials Ball, Void"), "{said}");
    let mesh = read_unstructured(&outputs(&base)[0]).unwrap();
    assert!(!mesh.types.is_empty());
    assert!(names(&mesh.point_data).contains(&"SignedDistance Ball|Void"));
    assert_conforming(&mesh, [-3.0, 3.0, -3.0, 3.0, -3.0, 2.0]);

    // Non-uniform coordinates: refused with the core's message, or resampled on request.
    let uneven: Vec<f64> = (0..13)
        .map(|i| -3.0 + 0.5 * i as f64 + 0.01 * (i * i) as f64 / 12.0)
        .collect();
    let coords = [&uneven[..], &axis[..], &axis[..11]];
    let path = dir.join("uneven.vtr");
    write_vtr(&path, coords, &ball_cells(coords));
    let e = diamonds(["material", s(&path), "-o", s(&dir.join("u"))]).user_error();
    assert!(e.contains("not uniformly spaced"), "{e}");
    let said = run_material(&path, &dir.join("u"), &["--resample"]);
    assert!(said.contains("tetrahedra"), "{said}");
}

/// `--material-fields` alone defines the fields it names: "Density for Void,..." gives a field
/// "Density" given only per material (mixed = Σ fraction × value), the "Density" input array unused.
#[test]
fn material_fields_alone_define_their_field() {
    let dir = TempDir::new("material-implicit");
    let input = generate_impact(&dir);
    let base = dir.join("implicit");
    let densities = "Density for Void,Density for Block,Density for Projectile";
    let said = run_material(
        &input,
        &base,
        &[
            "--fractions",
            FRACTIONS,
            "--material-fields",
            densities,
            "--field-tolerance",
            "3",
        ],
    );
    assert!(said.contains("fields [Density]"), "{said}");
    let mesh = read_unstructured(&outputs(&base)[0]).unwrap();
    let point_names = names(&mesh.point_data);
    for name in ["Density", "Density (Void)", "Density (Projectile)"] {
        assert!(point_names.contains(&name), "{name} in {point_names:?}");
    }
    assert!(field_value(&mesh.field_data, "MaximumFieldError") <= 3.0);
    let e = diamonds([
        "material",
        s(&input),
        "-o",
        s(&dir.join("e")),
        "--material-fields",
        densities,
    ])
    .user_error();
    assert!(e.contains("--field-tolerance"), "{e}");
}

#[test]
fn bad_inputs_are_clear_errors() {
    let dir = TempDir::new("material-bad");
    let input = generate_impact(&dir);
    let out = dir.join("o");
    let error = |extra: &[&str]| {
        let mut args = vec!["material", s(&input), "-o", s(&out)];
        args.extend_from_slice(extra);
        diamonds(args).user_error()
    };
    let e = error(&["--fractions", "Volume Fraction for Void,No Such Array"]);
    assert!(
        e.contains("No Such Array") && e.contains("point arrays"),
        "{e}"
    );
    let e = error(&["--fractions", "Volume Fraction for Void"]);
    assert!(e.contains("between 2 and"), "{e}");
    let e = error(&[
        "--fractions",
        "Volume Fraction for Void,Volume Fraction for Block",
    ]);
    assert!(e.contains("sum to 1"), "{e}");
    let e = error(&["--interface-tolerance", "-1"]);
    assert!(e.contains("interface tolerance"), "{e}");
    let e = error(&["--fields", "Density", "--field-tolerance", "-0.5"]);
    assert!(e.contains("field tolerance"), "{e}");
    let e = error(&["--fields", "Density"]);
    assert!(e.contains("--field-tolerance"), "{e}");
    let e = error(&[
        "--fields",
        "Volume Fraction for Void",
        "--field-tolerance",
        "1",
    ]);
    assert!(e.contains("twice"), "{e}");
    let e = error(&["--slice", "1,2,3"]);
    assert!(e.contains("6"), "{e}");
    let e = error(&["--slice", "1,2,3,0,0,0"]);
    assert!(e.contains("normal"), "{e}");

    // NaN in a fraction, and a 2-D image.
    let data = read_structured(&input).unwrap();
    let grid = data.grid().unwrap();
    let mut arrays = data.point_data.clone();
    let mut void: Vec<f32> = (0..grid.len()).map(|k| arrays[1].value(k) as f32).collect();
    void[100] = f32::NAN;
    arrays[1] = Array::scalars(arrays[1].name.clone(), void);
    let nan = dir.join("nan.vti");
    write_image(&nan, &grid, &arrays).unwrap();
    let e = diamonds(["material", s(&nan), "-o", s(&out)]).user_error();
    assert!(
        e.contains("[NaN") || e.contains("NaN") || e.contains("non-finite"),
        "{e}"
    );
    let flat_grid = diamonds::Grid {
        dims: [8, 8, 1],
        ..grid
    };
    let flat = dir.join("flat.vti");
    let two: Vec<Array> = ["Volume Fraction for A", "Volume Fraction for B"]
        .iter()
        .map(|n| Array::scalars(*n, vec![0.5f32; 64]))
        .collect();
    write_image(&flat, &flat_grid, &two).unwrap();
    let e = diamonds(["material", s(&flat), "-o", s(&out)]).user_error();
    assert!(e.contains("at least 2 points"), "{e}");
    let e = diamonds(["material", s(&dir.join("missing.vti")), "-o", s(&out)]).user_error();
    assert!(e.contains("cannot read"), "{e}");
}

/// `../shared/data/multimaterial/cth_armor_impact.vtr` (CTH, non-uniform along x and z): refused as
/// is, approximated after resampling. Skipped with a message when `../shared` is absent.
#[test]
fn cth_armor_impact_when_present() {
    let Some(path) = shared_file("data/multimaterial/cth_armor_impact.vtr") else {
        return;
    };
    let data = read_structured(&path).unwrap();
    assert_eq!(data.dims, [129, 65, 65]);
    for name in [
        "Volume Fraction for Armor Plate",
        "Volume Fraction for Body, Nose",
        "Void Volume Fraction",
        "Pressure",
    ] {
        assert!(names(&data.cell_data).contains(&name), "{name}");
    }
    let dir = TempDir::new("cth");
    let base = dir.join("cth");
    let e = diamonds(["material", s(&path), "-o", s(&base)]).user_error();
    assert!(e.contains("not uniformly spaced"), "{e}");
    let said = run_material(
        &path,
        &base,
        &[
            "--resample",
            "--fractions",
            "Void Volume Fraction,Volume Fraction for Armor Plate,Volume Fraction for Body, Nose",
            "--interface-tolerance",
            "0.1",
        ],
    );
    println!("{said}");
    assert!(said.contains("Armor Plate") && said.contains("Body, Nose") && said.contains("Void"));
    let mesh = read_unstructured(&outputs(&base)[0]).unwrap();
    let worst = values(array(&mesh.cell_data, "InterfaceError"))
        .into_iter()
        .fold(0.0, f64::max);
    assert!(worst <= 0.1 * (1.0 + 1e-6));
    assert!(!read_polydata(&outputs(&base)[1])
        .unwrap()
        .offsets
        .is_empty());
}

/// Tissue maps of two shared volumes resampled onto 65×33×17 points (spacing 1) at an interface
/// tolerance of half the spacing: the lattice one level finer than the data has its finest
/// tetrahedra as wide as the tolerance, and near junctions of materials they missed it (neghip:
/// 1.30, silicium: 0.63) without a word; a finer lattice is tried where they do. Skipped with a
/// message when `../shared` is absent.
#[test]
fn tissue_maps_reach_an_interface_tolerance_of_half_the_spacing_when_present() {
    for volume in ["neghip_64x64x64_uint8", "silicium_98x34x34_uint8"] {
        let Some(image) = shared_file(&format!("data/volumes/{volume}.vti")) else {
            return;
        };
        let dir = TempDir::new("tissue-half");
        let input = dir.join("tissue.vti");
        diamonds([
            "generate",
            "--field",
            "tissue",
            "--image",
            s(&image),
            "--dims",
            "65",
            "33",
            "17",
            s(&input),
        ])
        .ok();
        let base = dir.join("tissue");
        let said = run_material(
            &input,
            &base,
            &[
                "--fractions",
                "Volume Fraction for Other,Volume Fraction for Grey,Volume Fraction for White",
                "--fields",
                "T1",
                "--interface-tolerance",
                "0.5",
                "--field-tolerance",
                "4",
            ],
        );
        let mesh = read_unstructured(&outputs(&base)[0]).unwrap();
        let worst = |name: &str| {
            values(array(&mesh.cell_data, name))
                .into_iter()
                .fold(0.0, f64::max)
        };
        assert!(worst("InterfaceError") <= 0.5, "{volume}: {said}");
        assert!(worst("FieldError") <= 4.0, "{volume}: {said}");
    }
}
