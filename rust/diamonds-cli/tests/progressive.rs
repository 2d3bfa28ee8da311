//! `diamonds progressive encode` / `decode` end to end on Adaptive Tetrahedra's output of a generated
//! volume: every decoded level is a manifold tetrahedralisation equal to the library's replay of that
//! level, point data passes through, any prefix of the stream decodes to a valid level, bad input is
//! a clean error. And the shared blunt fin (`../shared/data/tets`): its levels of 50, 90 and 99 %
//! reduction checked independently (manifold, no two tetrahedra overlapping, field error at every removed vertex — at the nearest
//! point of the level for one outside it — within the reported maximum, boundary surface within the
//! boundary tolerance of the original's).
//! Without `../shared` that test passes after printing "skipped", except under `CI=true` or
//! `DIAMONDS_REQUIRE_SHARED=1`, where it fails.

mod common;

use common::{diamonds, field_value, s, shared_file, TempDir};
use diamonds::geometry::{point_triangle_distance, triangle_samples, triangle_tree};
use diamonds::progressive::{simplify, Params, Replay, TetInput};
use diamonds::validate::{boundary_faces, check_manifold_tets, check_no_overlap};
use diamonds_cli::read::{read_unstructured, tetrahedra, Unstructured};
use diamonds_cli::Values;
use glam::DVec3;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// An adaptive tetrahedral mesh of a 17³ Marschner–Lobb volume (Adaptive Tetrahedra, tolerance 4).
fn adaptive_mesh(dir: &TempDir) -> PathBuf {
    let vti = dir.join("ml.vti");
    let vtu = dir.join("ml.vtu");
    diamonds([
        "generate",
        s(&vti),
        "--field",
        "marschner-lobb",
        "--dims",
        "17",
        "17",
        "17",
    ])
    .ok();
    diamonds(["tetra", s(&vti), s(&vtu), "--tolerance", "4"]).ok();
    vtu
}

/// Position bits of a point, to match points across files.
fn key(p: [f64; 3]) -> [u64; 3] {
    p.map(|c| (c + 0.0).to_bits())
}

/// The tetrahedra of `mesh` as sorted corner positions, sorted.
fn canonical(points: &[[f64; 3]], tets: &[[u32; 4]]) -> Vec<[[u64; 3]; 4]> {
    let mut all: Vec<[[u64; 3]; 4]> = tets
        .iter()
        .map(|t| {
            let mut c = t.map(|v| key(points[v as usize]));
            c.sort_unstable();
            c
        })
        .collect();
    all.sort_unstable();
    all
}

fn scalars(grid: &Unstructured, name: &str) -> Vec<f64> {
    let a = grid.point_data.iter().find(|a| a.name == name).unwrap();
    (0..grid.points.len()).map(|k| a.value(k)).collect()
}

#[test]
fn decoded_levels_equal_the_replay_and_pass_point_data_through() {
    let dir = TempDir::new("progressive");
    let vtu = adaptive_mesh(&dir);
    let dpm = dir.join("ml.dpm");
    let encode = |out: &Path, reduction: &str| {
        diamonds([
            "progressive",
            "encode",
            s(&vtu),
            s(out),
            "--target-reduction",
            reduction,
        ])
    };
    let run = encode(&dpm, "0.8");
    assert!(!run.stderr.contains("warning"), "{run:#?}");
    let report = run.ok();
    assert!(report.contains("% of the .vtu's"), "{report}");
    // A target no valid collapse reaches: the stream of the coarsest mesh reached, and a warning.
    let run = encode(&dir.join("all.dpm"), "1");
    assert!(
        run.stderr.contains("the reduction stops at")
            && run.stderr.contains("short of the 0 asked"),
        "{run:#?}"
    );
    run.ok();
    let input = read_unstructured(&vtu).unwrap();
    let tets = tetrahedra(&input).unwrap();
    let name = &input.point_data[0].name;
    let values = scalars(&input, name);
    let pm = simplify(
        TetInput {
            points: &input.points,
            tets: &tets,
            scalars: &values,
        },
        &Params {
            target_tets: (0.2 * tets.len() as f64).round() as usize,
            boundary_tolerance: 1e-3 * diagonal(&input.points),
            ..Params::default()
        },
        &mut |_| true,
    )
    .unwrap();
    let n = pm.levels();
    assert!(pm.error(0).tets as f64 <= 0.2 * tets.len() as f64 + 1.0);
    let by_position: HashMap<[u64; 3], usize> = input
        .points
        .iter()
        .enumerate()
        .map(|(k, &p)| (key(p), k))
        .collect();
    let mut replay = Replay::new(&pm);
    for level in [0, 1, n / 3, n - 1, n] {
        let out = dir.join(&format!("level{level}.vtu"));
        let line = diamonds([
            "progressive",
            "decode",
            s(&dpm),
            "--level",
            &level.to_string(),
            s(&out),
        ])
        .ok();
        assert!(line.starts_with(&format!("level {level} of {n}")), "{line}");
        let decoded = read_unstructured(&out).unwrap();
        let dt = tetrahedra(&decoded).unwrap();
        check_manifold_tets(&decoded.points, &dt).unwrap_or_else(|e| panic!("level {level}: {e}"));
        replay.set_level(&pm, level);
        let mesh = replay.mesh(pm.points().len());
        let points: Vec<[f64; 3]> = mesh
            .point_ids
            .iter()
            .map(|&v| pm.points()[v as usize])
            .collect();
        assert_eq!(
            canonical(&decoded.points, &dt),
            canonical(&points, &mesh.tets),
            "level {level}"
        );
        assert_eq!(field_value(&decoded.field_data, "Level"), level as f64);
        assert_eq!(
            field_value(&decoded.field_data, "MaximumFieldError"),
            pm.error(level).max_field_error
        );
        // Every point array, with its type, at every point.
        assert_eq!(decoded.point_data.len(), input.point_data.len());
        for (a, b) in decoded.point_data.iter().zip(&input.point_data) {
            assert_eq!(
                (&a.name, a.components, a.type_name()),
                (&b.name, b.components, b.type_name())
            );
            for (k, &p) in decoded.points.iter().enumerate() {
                let v = by_position[&key(p)];
                for c in 0..a.components {
                    assert_eq!(a.value(k * a.components + c), b.value(v * b.components + c));
                }
            }
        }
    }
}

fn diagonal(points: &[[f64; 3]]) -> f64 {
    let mut b = [f64::INFINITY, f64::NEG_INFINITY].repeat(3);
    for p in points {
        for a in 0..3 {
            b[2 * a] = b[2 * a].min(p[a]);
            b[2 * a + 1] = b[2 * a + 1].max(p[a]);
        }
    }
    diamonds::volume::bounds_diagonal(&b.try_into().unwrap())
}

#[test]
fn every_prefix_of_a_stream_decodes_to_a_valid_level() {
    let dir = TempDir::new("progressive-prefix");
    let vtu = adaptive_mesh(&dir);
    let dpm = dir.join("ml.dpm");
    diamonds(["progressive", "encode", s(&vtu), s(&dpm)]).ok();
    // Cut the decompressed stream and compress it again, as a transmission cut short would leave it.
    let raw = {
        use std::io::Read;
        let mut out = Vec::new();
        flate2::read::ZlibDecoder::new(std::fs::File::open(&dpm).unwrap())
            .read_to_end(&mut out)
            .unwrap();
        out
    };
    let mut last = 0.0;
    for fraction in [0.3, 0.5, 0.75, 0.9, 1.0] {
        let cut = dir.join("cut.dpm");
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
        std::io::Write::write_all(&mut z, &raw[..(raw.len() as f64 * fraction) as usize]).unwrap();
        std::fs::write(&cut, z.finish().unwrap()).unwrap();
        let out = dir.join("cut.vtu");
        diamonds(["progressive", "decode", s(&cut), s(&out)]).ok();
        let decoded = read_unstructured(&out).unwrap();
        let dt = tetrahedra(&decoded).unwrap();
        check_manifold_tets(&decoded.points, &dt).unwrap_or_else(|e| panic!("{fraction}: {e}"));
        let level = field_value(&decoded.field_data, "Level");
        assert!(level >= last, "{fraction}: level {level} after {last}");
        last = level;
    }
    assert_eq!(
        last,
        field_value(
            &read_unstructured(&dir.join("cut.vtu")).unwrap().field_data,
            "NumberOfLevels"
        )
    );
    // Too short for the base mesh: a clean error.
    let cut = dir.join("short.dpm");
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
    std::io::Write::write_all(&mut z, &raw[..40]).unwrap();
    std::fs::write(&cut, z.finish().unwrap()).unwrap();
    let e = diamonds(["progressive", "decode", s(&cut), s(&dir.join("x.vtu"))]).user_error();
    assert!(e.contains("base mesh"), "{e}");
}

#[test]
fn bad_input_is_a_clean_error() {
    let dir = TempDir::new("progressive-bad");
    let vtu = adaptive_mesh(&dir);
    let out = dir.join("o.dpm");
    let e = diamonds([
        "progressive",
        "encode",
        s(&vtu),
        s(&out),
        "--target-reduction",
        "1.5",
    ])
    .user_error();
    assert!(e.contains("target reduction"), "{e}");
    let e = diamonds(["progressive", "encode", s(&vtu), s(&out), "--array", "Nope"]).user_error();
    assert!(e.contains("Nope"), "{e}");
    let e = diamonds([
        "progressive",
        "encode",
        s(&vtu),
        s(&out),
        "--field-weight",
        "nan",
    ])
    .user_error();
    assert!(e.contains("field weight"), "{e}");
    // Mixed cells: one tetrahedron written as a VTK_PYRAMID-typed cell is refused by name.
    let mixed = dir.join("mixed.vtu");
    std::fs::write(&mixed, mixed_cells()).unwrap();
    let e = diamonds(["progressive", "encode", s(&mixed), s(&out)]).user_error();
    assert!(e.contains("VTK_TETRA"), "{e}");
    let garbage = dir.join("garbage.dpm");
    std::fs::write(&garbage, b"not a stream").unwrap();
    let e = diamonds(["progressive", "decode", s(&garbage), s(&dir.join("g.vtu"))]).user_error();
    assert!(e.contains("garbage.dpm"), "{e}");
    let e = diamonds(["progressive", "decode", s(&out), s(&dir.join("g.vti"))]).user_error();
    assert!(e.contains(".vtu"), "{e}");
}

/// An ASCII unstructured grid with a tetrahedron and a pyramid.
fn mixed_cells() -> String {
    r#"<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian">
  <UnstructuredGrid>
    <Piece NumberOfPoints="6" NumberOfCells="2">
      <PointData Scalars="f"><DataArray type="Float32" Name="f" format="ascii">0 1 2 3 4 5</DataArray></PointData>
      <Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">0 0 0 1 0 0 0 1 0 0 0 1 1 1 0 1 1 1</DataArray></Points>
      <Cells>
        <DataArray type="Int64" Name="connectivity" format="ascii">0 1 2 3 1 4 5 3 2</DataArray>
        <DataArray type="Int64" Name="offsets" format="ascii">4 9</DataArray>
        <DataArray type="UInt8" Name="types" format="ascii">10 14</DataArray>
      </Cells>
    </Piece>
  </UnstructuredGrid>
</VTKFile>
"#
    .to_string()
}

/// A bucket grid over tetrahedra's bounding boxes, to find the tetrahedron holding a point.
struct Buckets {
    lo: [f64; 3],
    size: [f64; 3],
    n: usize,
    cells: Vec<Vec<u32>>,
}

impl Buckets {
    fn new(points: &[[f64; 3]], tets: &[[u32; 4]], n: usize) -> Self {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in points {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        let size = std::array::from_fn(|a| ((hi[a] - lo[a]) / n as f64).max(1e-300));
        let mut b = Self {
            lo,
            size,
            n,
            cells: vec![Vec::new(); n * n * n],
        };
        for (t, c) in tets.iter().enumerate() {
            let coords = |a: usize| c.iter().map(move |&v| points[v as usize][a]);
            let l: [usize; 3] =
                std::array::from_fn(|a| b.index(a, coords(a).fold(f64::INFINITY, f64::min)));
            let h: [usize; 3] =
                std::array::from_fn(|a| b.index(a, coords(a).fold(f64::NEG_INFINITY, f64::max)));
            for z in l[2]..=h[2] {
                for y in l[1]..=h[1] {
                    for x in l[0]..=h[0] {
                        b.cells[x + n * (y + n * z)].push(t as u32);
                    }
                }
            }
        }
        b
    }

    fn index(&self, a: usize, x: f64) -> usize {
        (((x - self.lo[a]) / self.size[a]).floor().max(0.0) as usize).min(self.n - 1)
    }

    fn at(&self, p: [f64; 3]) -> &[u32] {
        let [x, y, z] = std::array::from_fn(|a| self.index(a, p[a]));
        &self.cells[x + self.n * (y + self.n * z)]
    }
}

/// Barycentric coordinates of `p` in the tetrahedron `x`.
fn barycentric(x: [[f64; 3]; 4], p: [f64; 3]) -> [f64; 4] {
    let v = |a: [f64; 3], b: [f64; 3]| [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let det = |a: [f64; 3], b: [f64; 3], c: [f64; 3]| {
        a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0])
    };
    let (e1, e2, e3, q) = (v(x[0], x[1]), v(x[0], x[2]), v(x[0], x[3]), v(x[0], p));
    let d = det(e1, e2, e3);
    let (l1, l2, l3) = (det(q, e2, e3) / d, det(e1, q, e3) / d, det(e1, e2, q) / d);
    [1.0 - l1 - l2 - l3, l1, l2, l3]
}

/// Simplifies `path` as the filter does (the whole sequence) and checks the levels of 50, 90 and
/// 99 % reduction, each reached by replay, independently: manifold; no two tetrahedra overlapping
/// (generalized winding number ≤ 1 at every original point); the error of every removed vertex —
/// at its place if a tetrahedron holds it (exact barycentric coordinates), else at the nearest
/// point of the level's boundary surface — within the level's reported maximum, which is their
/// maximum; at 90 %, the boundary surface within the boundary tolerance of the original's.
/// Returns a report line.
fn check_shared(path: &Path, array: &str) -> String {
    let grid = read_unstructured(path).unwrap();
    let tets = tetrahedra(&grid).unwrap();
    let values = scalars(&grid, array);
    let tolerance = 1e-3 * diagonal(&grid.points);
    let start = std::time::Instant::now();
    let pm = simplify(
        TetInput {
            points: &grid.points,
            tets: &tets,
            scalars: &values,
        },
        &Params {
            boundary_tolerance: tolerance,
            ..Params::default()
        },
        &mut |_| true,
    )
    .unwrap();
    let seconds = start.elapsed().as_secs_f64();
    let mut report = format!(
        "{}: {} tets, sequence in {seconds:.1} s",
        path.display(),
        tets.len()
    );
    let mut used = vec![false; grid.points.len()];
    for &v in tets.iter().flatten() {
        used[v as usize] = true;
    }
    let mut replay = Replay::new(&pm);
    for reduction in [0.5, 0.9, 0.99] {
        let level =
            pm.level_for_tets(((1.0 - reduction) * pm.original_tets().len() as f64) as usize);
        replay.set_level(&pm, level);
        let mesh = replay.mesh(grid.points.len());
        let points: Vec<[f64; 3]> = mesh
            .point_ids
            .iter()
            .map(|&v| grid.points[v as usize])
            .collect();
        check_manifold_tets(&points, &mesh.tets).unwrap();
        // No two tetrahedra overlap, probed at every original point besides the level's own.
        let originals: Vec<[f64; 3]> = (0..grid.points.len())
            .filter(|&v| used[v])
            .map(|v| grid.points[v])
            .collect();
        check_no_overlap(&points, &mesh.tets, &originals)
            .unwrap_or_else(|e| panic!("{reduction}: {e}"));
        let reported = pm.error(level);
        assert_eq!(reported.tets, mesh.tets.len());
        let value = |k: u32| values[mesh.point_ids[k as usize] as usize];
        let buckets = Buckets::new(&points, &mesh.tets, 48);
        let faces = boundary_faces(&mesh.tets);
        let tree = triangle_tree(
            faces
                .iter()
                .map(|f| f.map(|k| DVec3::from_array(points[k as usize]))),
        );
        let mut kept = vec![false; grid.points.len()];
        for &v in &mesh.point_ids {
            kept[v as usize] = true;
        }
        let (mut outside, mut max, mut n) = (0, 0.0f64, 0);
        for v in (0..grid.points.len()).filter(|&v| used[v] && !kept[v]) {
            let p = grid.points[v];
            let hit = buckets.at(p).iter().find_map(|&t| {
                let c = mesh.tets[t as usize];
                let b = barycentric(c.map(|k| points[k as usize]), p);
                (b.iter().all(|&x| x >= -1e-9))
                    .then(|| (0..4).map(|k| b[k] * value(c[k])).sum::<f64>())
            });
            let at = hit.unwrap_or_else(|| {
                outside += 1;
                let q = DVec3::from_array(p);
                let face = tree.nearest_neighbor(&p).unwrap();
                let [a, b, c] = face.corners;
                let x = diamonds::geometry::closest_point_on_triangle(q, a, b, c).0;
                let n = (b - a).cross(c - a);
                let w = [
                    (c - b).cross(x - b).dot(n),
                    (a - c).cross(x - c).dot(n),
                    (b - a).cross(x - a).dot(n),
                ];
                let f = faces[face.id as usize];
                (0..3).map(|k| w[k] * value(f[k])).sum::<f64>() / w.iter().sum::<f64>()
            });
            let e = (values[v] - at).abs();
            assert!(
                e <= reported.max_field_error * (1.0 + 1e-9) + 1e-12,
                "{reduction}: vertex {v} has error {e} > reported {reported:?}"
            );
            max = max.max(e);
            n += 1;
        }
        assert!(
            (max - reported.max_field_error).abs() <= 1e-9 * max.max(1.0),
            "{reduction}: measured max {max}, reported {reported:?}"
        );
        report += &format!(
            "; {reduction}: {} tets, max field error {:.4e} (measured at {n} removed vertices, {outside} outside), RMS {:.4e}",
            reported.tets, reported.max_field_error, reported.rms_field_error
        );
        if reduction == 0.9 {
            report += &check_boundary(&grid.points, &tets, &points, &mesh.tets, tolerance);
        }
    }
    report
}

/// The boundary at one level: every vertex of the original's boundary surface within the boundary
/// tolerance of the level's (the bound the reduction keeps), and the level's boundary, sampled at
/// the tolerance, near the original's (measured: nothing bounds how far a face cuts a corner).
fn check_boundary(
    original_points: &[[f64; 3]],
    original: &[[u32; 4]],
    points: &[[f64; 3]],
    tets: &[[u32; 4]],
    tolerance: f64,
) -> String {
    let surface = |points: &[[f64; 3]], tets: &[[u32; 4]]| -> Vec<[DVec3; 3]> {
        boundary_faces(tets)
            .iter()
            .map(|f| f.map(|v| DVec3::from_array(points[v as usize])))
            .collect()
    };
    let original = surface(original_points, original);
    let simplified = surface(points, tets);
    let tree = triangle_tree(simplified.iter().copied());
    let to_simplified = original
        .iter()
        .flatten()
        .map(|&p| {
            let t = tree.nearest_neighbor(&p.to_array()).unwrap();
            point_triangle_distance(p, t.corners)
        })
        .fold(0.0, f64::max);
    assert!(
        to_simplified <= tolerance * (1.0 + 1e-9),
        "an original boundary vertex is {to_simplified} from the simplified boundary (tolerance {tolerance})"
    );
    let tree = triangle_tree(original.iter().copied());
    let to_original = simplified
        .iter()
        .flat_map(|&t| triangle_samples(t, tolerance))
        .map(|p| {
            let t = tree.nearest_neighbor(&p.to_array()).unwrap();
            point_triangle_distance(p, t.corners)
        })
        .fold(0.0, f64::max);
    format!(
        ", boundary Hausdorff {to_simplified:.3e} (original to simplified, tolerance {tolerance:.3e}) / {to_original:.3e} (back)"
    )
}

#[test]
fn the_blunt_fin_at_50_90_and_99_percent() {
    let Some(path) = shared_file("data/tets/bluntfin_tets.vtu") else {
        return;
    };
    println!("{}", check_shared(&path, "Density"));
}

#[test]
fn values_keep_their_types() {
    // Values::from_f64 restores every listed type exactly for values of that type.
    for (name, v) in [
        ("Int8", -3.0),
        ("UInt16", 65535.0),
        ("Int32", -7.0),
        ("Float32", 0.1f32 as f64),
    ] {
        let values = Values::from_f64(name, vec![v]).unwrap();
        assert_eq!(values.type_name(), name);
        assert_eq!(values.get(0), v);
    }
    assert!(Values::from_f64("String", vec![]).is_none());
}
