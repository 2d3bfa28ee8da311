//! `diamonds view` end to end: the written mesh is conforming and, with --sort, in exact visibility
//! order from the camera position (checked face by face); the budget holds; an orbit ends with the
//! mesh a single view from its last camera gives; bad cameras are clean errors.

mod common;

use common::{diamonds, field_value, s, TempDir};
use diamonds::validate::{check_back_to_front, check_conforming};
use diamonds_cli::read::read_unstructured;
use std::collections::BTreeSet;

/// The tetrahedra, points and cell array `name` of a written mesh.
struct Mesh {
    points: Vec<[f64; 3]>,
    tets: Vec<[u32; 4]>,
    tolerance: f64,
    levels: Vec<f64>,
    depths: Vec<f64>,
}

fn read(path: &std::path::Path) -> Mesh {
    let m = read_unstructured(path).unwrap();
    assert!(m.types.iter().all(|&t| t == 10), "VTK_TETRA only");
    let tets = m
        .connectivity
        .chunks_exact(4)
        .map(|c| [c[0] as u32, c[1] as u32, c[2] as u32, c[3] as u32])
        .collect();
    let cells = |name: &str| {
        let a = m.cell_data.iter().find(|a| a.name == name).unwrap();
        (0..a.data.len()).map(|k| a.value(k)).collect()
    };
    Mesh {
        tolerance: field_value(&m.field_data, "Tolerance"),
        levels: cells("Level"),
        depths: cells("BisectionDepth"),
        points: m.points,
        tets,
    }
}

/// The tetrahedra as sets of corner coordinates (order-independent).
fn shapes(m: &Mesh) -> BTreeSet<Vec<[u64; 3]>> {
    m.tets
        .iter()
        .map(|t| {
            let mut k: Vec<[u64; 3]> = t
                .iter()
                .map(|&i| m.points[i as usize].map(f64::to_bits))
                .collect();
            k.sort_unstable();
            k
        })
        .collect()
}

const BOUNDS: [f64; 6] = [-1.0, 1.0, -1.0, 1.0, -1.0, 1.0];

#[test]
fn sorted_view_meshes_are_conforming_and_in_visibility_order() {
    let dir = TempDir::new("view");
    let input = dir.join("ml.vti");
    diamonds(["generate", s(&input), "--dims", "33", "33", "33"]).ok();
    let out = dir.join("view.vtu");
    // Outside, inside the volume, and on the plane x = 0 of many faces.
    for eye in [[3.0, -2.0, 1.5], [0.2, 0.1, -0.3], [0.0, -4.0, 0.5]] {
        let mut by_direction = Vec::new();
        for sort in ["back-to-front", "front-to-back", "none"] {
            let mut args: Vec<String> = ["view", s(&input), s(&out), "--tolerance", "4"]
                .map(String::from)
                .to_vec();
            args.push("--position".into());
            args.extend(eye.map(|c| c.to_string()));
            args.extend(["--focal-point", "0", "0", "0", "--max-tets", "40000"].map(String::from));
            args.extend(["--sort".to_string(), sort.to_string()]);
            diamonds(&args).ok();
            let m = read(&out);
            assert!(
                m.tets.len() <= 40_000 && m.tets.len() > 1000,
                "{}",
                m.tets.len()
            );
            assert!(m.tolerance >= 4.0);
            check_conforming(&m.points, &m.tets, BOUNDS).unwrap();
            for (level, depth) in m.levels.iter().zip(&m.depths) {
                assert_eq!(*level, (*depth / 3.0).floor());
            }
            let mut order: Vec<u32> = (0..m.tets.len() as u32).collect();
            if sort == "front-to-back" {
                order.reverse();
            }
            let faces = check_back_to_front(&m.points, &m.tets, &order, eye);
            if sort == "none" {
                assert!(
                    faces.is_err(),
                    "the mesh's own order is no visibility order"
                );
            } else {
                assert!(faces.unwrap().checked > 0);
            }
            by_direction.push(shapes(&m));
        }
        // Sorting reorders the same tetrahedra.
        assert!(by_direction.windows(2).all(|w| w[0] == w[1]));
    }
}

#[test]
fn an_orbit_ends_with_the_mesh_of_its_last_camera() {
    let dir = TempDir::new("view-orbit");
    let input = dir.join("ml.vti");
    diamonds(["generate", s(&input), "--dims", "25", "33", "17"]).ok();
    let (orbit, single) = (dir.join("orbit.vtu"), dir.join("single.vtu"));
    let common = [
        "--focal-point",
        "0",
        "0",
        "0",
        "--tolerance",
        "2",
        "--max-tets",
        "20000",
    ];
    let stdout = diamonds(
        [
            "view",
            s(&input),
            s(&orbit),
            "--position",
            "3",
            "0",
            "1",
            "--orbit",
            "6",
            "5",
        ]
        .iter()
        .chain(&common),
    )
    .ok();
    assert_eq!(
        stdout.lines().filter(|l| l.starts_with("frame ")).count(),
        7
    );
    // Six turns of 5° about z through the focal point: 30°.
    let a = 30f64.to_radians();
    let position = [3.0 * a.cos(), 3.0 * a.sin(), 1.0].map(|c| c.to_string());
    let mut args = vec!["view".to_string(), s(&input).into(), s(&single).into()];
    args.push("--position".into());
    args.extend(position);
    args.extend(common.map(String::from));
    diamonds(&args).ok();
    assert_eq!(shapes(&read(&orbit)), shapes(&read(&single)));
}

#[test]
fn bad_cameras_are_clean_errors() {
    let dir = TempDir::new("view-bad");
    let input = dir.join("ml.vti");
    diamonds(["generate", s(&input), "--dims", "9", "9", "9"]).ok();
    let out = dir.join("out.vtu");
    let run = |extra: &[&str]| {
        let mut args = vec!["view", s(&input), s(&out)];
        args.extend_from_slice(extra);
        diamonds(args)
    };
    let camera = ["--position", "3", "0", "0", "--focal-point", "0", "0", "0"];
    for (extra, message) in [
        (&["--viewport", "0", "100"][..], "viewport"),
        (&["--view-angle", "180"][..], "view angle"),
        (&["--tolerance", "nan"][..], "tolerance"),
        (&["--view-up", "1", "0", "0"][..], "parallel"),
        (&["--orbit", "0", "5"][..], "orbit"),
    ] {
        let args: Vec<&str> = camera.iter().chain(extra).copied().collect();
        let err = run(&args).user_error();
        assert!(err.contains(message), "{extra:?}: {err}");
    }
    let same = ["--position", "0", "0", "0", "--focal-point", "0", "0", "0"];
    assert!(run(&same).user_error().contains("same point"));
    // A budget below the coarsest mesh (the root cube's six tetrahedra): a warning, not an error.
    let budget: Vec<&str> = camera.iter().chain(&["--max-tets", "3"]).copied().collect();
    let warned = run(&budget);
    assert!(
        warned.stderr.contains(
            "the budget of 3 tetrahedra cannot be met: the coarsest mesh of this 9×9×9 image has 6"
        ),
        "{warned:#?}"
    );
    warned.ok();
    let nan = [
        "--position",
        "NaN",
        "0",
        "0",
        "--focal-point",
        "0",
        "0",
        "0",
    ];
    assert!(run(&nan).user_error().contains("finite"));
}
