//! Measures a progressive mesh for `scripts/bench_progressive.py` (not a test): simplifies a `.vtu`
//! as the filter does (to the coarsest mesh, shape weight 0, boundary tolerance 0.001 of the
//! diagonal), then times level changes by replay and isovalue changes on a level with and without
//! the interval tree (Labsik Table 1). Prints one JSON object.
//!
//!   cargo run --release -p diamonds-cli --example progressive_probe -- IN.vtu ARRAY ISOVALUE

use diamonds::progressive::isosurface::ProgressiveIsosurface;
use diamonds::progressive::{self, Params, Replay, TetInput};
use diamonds_cli::read::tetrahedra;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 4 {
        eprintln!("usage: progressive_probe IN.vtu ARRAY ISOVALUE");
        std::process::exit(2);
    }
    let grid = vtkxml::read_unstructured(std::path::Path::new(&args[1])).expect("a .vtu");
    let tets = tetrahedra(&grid).expect("tetrahedra");
    let array = grid
        .point_data
        .iter()
        .find(|a| a.name == args[2])
        .expect("the array");
    let values: Vec<f64> = (0..grid.points.len()).map(|k| array.value(k)).collect();
    let isovalue: f64 = args[3].parse().expect("an isovalue");
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in &grid.points {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let diagonal = diamonds::volume::bounds_diagonal(&[lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]]);
    let params = Params {
        boundary_tolerance: 1e-3 * diagonal,
        ..Params::default()
    };
    let start = Instant::now();
    let pm = progressive::simplify(
        TetInput {
            points: &grid.points,
            tets: &tets,
            scalars: &values,
        },
        &params,
        &mut |_| true,
    )
    .expect("simplified");
    let simplify_s = start.elapsed().as_secs_f64();
    // Two cursors: one as the filter without an isosurface, one carrying the isosurface.
    let mut replay = Replay::new(&pm);
    let mut carrier = Replay::new(&pm);
    let mut surface = ProgressiveIsosurface::new(&pm, &carrier, &[isovalue]).expect("isosurface");
    let mut levels = Vec::new();
    for reduction in [0.5, 0.9, 0.99, 0.5] {
        let target = ((1.0 - reduction) * tets.len() as f64).round() as usize;
        let level = pm.level_for_tets(target);
        // The level change as the filter makes it: replay, then the level as arrays.
        let t = Instant::now();
        let steps = replay.set_level(&pm, level);
        let mesh = replay.mesh(pm.points().len());
        let errors = replay.field_errors();
        let change_s = t.elapsed().as_secs_f64();
        // The same change carrying the isosurface (§4.3: only the tetrahedra of each split).
        let t = Instant::now();
        surface.set_level(&pm, &mut carrier, level);
        let carried_s = t.elapsed().as_secs_f64();
        // An isovalue change on this level through the interval tree and by a scan of every
        // tetrahedron (Table 1).
        let t = Instant::now();
        surface
            .set_isovalues(&pm, &carrier, &[isovalue * 1.0001], true)
            .expect("isovalue");
        let tree_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        surface
            .set_isovalues(&pm, &carrier, &[isovalue], false)
            .expect("isovalue");
        let scan_s = t.elapsed().as_secs_f64();
        let triangles = surface.edge_triangles().len();
        let e = pm.error(level);
        levels.push(format!(
            "{{\"reduction\": {reduction}, \"level\": {level}, \"tets\": {}, \"points\": {}, \"steps\": {steps}, \"change_s\": {change_s:.6}, \"carried_s\": {carried_s:.6}, \"max_error\": {:e}, \"rms_error\": {:e}, \"max_tet_error\": {:e}, \"boundary\": {:e}, \"triangles\": {triangles}, \"iso_tree_s\": {tree_s:.6}, \"iso_scan_s\": {scan_s:.6}}}",
            mesh.tets.len(),
            mesh.point_ids.len(),
            e.max_field_error,
            e.rms_field_error,
            errors.iter().copied().fold(0.0, f64::max),
            e.max_boundary_distance,
        ));
    }
    println!(
        "{{\"tets\": {}, \"simplify_s\": {simplify_s:.3}, \"levels\": [{}]}}",
        tets.len(),
        levels.join(", ")
    );
}
