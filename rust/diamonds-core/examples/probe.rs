//! Timing probe on a raw u8 volume (x fastest), for profiling the core without VTK:
//!
//! `cargo run --release -p diamonds-core --example probe -- file.u8 nx ny nz tetra TOL...`
//! `cargo run --release -p diamonds-core --example probe -- file.u8 nx ny nz iso ISO1,ISO2,... TOL...`
//! `cargo run --release -p diamonds-core --example probe -- file.u8 nx ny nz isoseq ISO1,ISO2,... TOL...`
//!
//! `cargo run --release -p diamonds-core --example probe -- file.u8 nx ny nz isochange ISO1,ISO2,... TOL[%]...`
//!
//! `isochange` builds the isosurface-only hierarchy and times the first extraction at ISO1 (build
//! included) and then each change to the next isovalue (minimum over `REPEAT` rounds); with
//! `START=current`, changes refine from the current mesh instead of the root.
//! `isoseq` times each isovalue change of the sequence from the root and from the current mesh
//! (minimum over `REPEAT` runs, default 5; the isosurface-error cache is warmed first). A tolerance
//! ending in `%` is a percentage of the data diagonal.
use diamonds::isosurface::{IsoStart, IsoState};
use diamonds::{Grid, Hierarchy, IsoQuery, Query, ScalarSlice};
use std::time::Instant;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 6 {
        eprintln!(
            "usage: probe file.u8 nx ny nz (tetra TOL... | iso ISO1,ISO2,... TOL... | isoseq ISO1,ISO2,... TOL[%]...)"
        );
        std::process::exit(2);
    }
    let data = std::fs::read(&a[1]).expect("readable file");
    let dims = [2, 3, 4].map(|i| a[i].parse().expect("dimension"));
    let parse = |s: &String| -> f64 { s.parse().expect("number") };
    if a[5] == "isochange" {
        iso_change(&data, dims, &a[6], &a[7..]);
        return;
    }
    let t = Instant::now();
    let h =
        Hierarchy::build(Grid::new(dims), ScalarSlice::U8(&data), &mut |_| true).expect("build");
    println!(
        "build {:.3}s, base tets {}",
        t.elapsed().as_secs_f64(),
        h.base_tetrahedra()
    );
    match a[5].as_str() {
        "tetra" => {
            // The filter's path: plan (refine + count), then each output array written once.
            for tol in a[6..].iter().map(parse) {
                let t = Instant::now();
                let plan = h.plan(&Query::tolerance(tol)).expect("plan");
                let planned = t.elapsed().as_secs_f64();
                let (n, np) = (plan.tets(), plan.points());
                let mut conn = vec![0i32; 4 * n];
                let mut offsets = vec![0i32; n + 1];
                let (mut depths, mut errors) = (vec![0u8; n], vec![0f32; n]);
                let mut xyz = vec![0f64; 3 * np];
                let t = Instant::now();
                let max = h
                    .write_tets(&plan, &mut conn, &mut offsets, &mut depths, &mut errors)
                    .expect("tets");
                let tets_s = t.elapsed().as_secs_f64();
                let t = Instant::now();
                let grid = h.grid();
                plan.write_points(|i| grid.point(grid.ijk(i)), &mut xyz)
                    .expect("points");
                let points_s = t.elapsed().as_secs_f64();
                println!(
                    "tol {tol}: {n} tets, {np} points, max error {max}: plan {planned:.3}s, tets {tets_s:.3}s, points {points_s:.3}s = {:.1} M tets/s",
                    n as f64 / (planned + tets_s + points_s) / 1e6
                );
            }
        }
        "isoseq" => {
            let isovalues: Vec<f64> = a[6]
                .split(',')
                .map(|v| v.parse().expect("isovalue"))
                .collect();
            let b = h.grid().bounds();
            let diagonal =
                ((b[1] - b[0]).powi(2) + (b[3] - b[2]).powi(2) + (b[5] - b[4]).powi(2)).sqrt();
            let repeat: usize = std::env::var("REPEAT")
                .ok()
                .and_then(|r| r.parse().ok())
                .unwrap_or(5);
            for tol in &a[7..] {
                let tol = match tol.strip_suffix('%') {
                    Some(p) => parse(&p.to_string()) / 100.0 * diagonal,
                    None => parse(tol),
                };
                let scalars = ScalarSlice::U8(&data);
                // One state per start, its cache warmed with every isovalue of the sequence.
                let mut states = [IsoStart::Root, IsoStart::Current].map(IsoState::with_start);
                for state in &mut states {
                    for &iso in &isovalues {
                        state
                            .extract(&h, scalars, &IsoQuery::new(iso, tol))
                            .expect("isosurface");
                    }
                }
                // Per change, per start: (total, refine) seconds, minimum over the runs.
                let n = isovalues.len();
                let mut best = vec![[(f64::INFINITY, f64::INFINITY); 2]; n];
                let mut info = vec![(0usize, 0usize); n];
                for _ in 0..repeat {
                    for (k, state) in states.iter_mut().enumerate() {
                        state.forget_mesh();
                        for (i, &iso) in isovalues.iter().enumerate() {
                            let t = Instant::now();
                            let s = state
                                .extract(&h, scalars, &IsoQuery::new(iso, tol))
                                .expect("isosurface");
                            let total = t.elapsed().as_secs_f64();
                            let st = state.last().expect("stats");
                            assert_eq!(st.from_current, k == 1 && i > 0);
                            let b = &mut best[i][k];
                            *b = (b.0.min(total), b.1.min(st.refine_seconds));
                            info[i] = (s.triangles.len(), st.split_diamonds);
                        }
                    }
                }
                // The same query again with only the normals toggled: the mesh is reused.
                let (mut again, mut root_again) = (f64::INFINITY, f64::INFINITY);
                let last = IsoQuery::new(isovalues[n - 1], tol);
                let toggled = IsoQuery {
                    compute_normals: false,
                    ..last.clone()
                };
                let state = &mut states[0];
                for _ in 0..repeat {
                    state.forget_mesh();
                    state.extract(&h, scalars, &last).expect("isosurface");
                    let t = Instant::now();
                    state.extract(&h, scalars, &toggled).expect("isosurface");
                    again = again.min(t.elapsed().as_secs_f64());
                    assert!(state.last().expect("stats").reused);
                    state.forget_mesh();
                    let t = Instant::now();
                    state.extract(&h, scalars, &toggled).expect("isosurface");
                    root_again = root_again.min(t.elapsed().as_secs_f64());
                }
                println!(
                    "tol {tol:.3}: normals toggled at {}: {root_again:.4}s from the root, {again:.4}s reusing the mesh",
                    isovalues[n - 1]
                );
                println!(
                    "tol {tol:.3} ({:.2}% of diagonal), min of {repeat} runs, seconds total (refine)",
                    100.0 * tol / diagonal
                );
                println!(
                    "  change           triangles  split      from-root           from-current"
                );
                for i in 0..n {
                    let from = if i == 0 {
                        "-".to_string()
                    } else {
                        isovalues[i - 1].to_string()
                    };
                    let [(rt, rr), (ct, cr)] = best[i];
                    println!(
                        "  {from:>6} -> {:<6} {:>9} {:>7}  {rt:.4} ({rr:.4})    {ct:.4} ({cr:.4})",
                        isovalues[i], info[i].0, info[i].1
                    );
                }
            }
        }
        _ => {
            // One state, so that its cache is kept as the hierarchy's was; each query starts from
            // the root.
            let mut state = IsoState::new();
            for iso in a[6].split(',').map(|v| v.parse::<f64>().expect("isovalue")) {
                for tol in a[7..].iter().map(parse) {
                    let t = Instant::now();
                    let s = state
                        .extract(&h, ScalarSlice::U8(&data), &IsoQuery::new(iso, tol))
                        .expect("isosurface");
                    println!(
                        "iso {iso} tol {tol}: {} triangles, bound {:.3} in {:.3}s",
                        s.triangles.len(),
                        s.error_bound,
                        t.elapsed().as_secs_f64()
                    );
                }
            }
        }
    }
}

/// First extraction (isosurface-only hierarchy build included) and isovalue changes, in seconds.
fn iso_change(data: &[u8], dims: [usize; 3], isovalues: &str, tolerances: &[String]) {
    let isovalues: Vec<f64> = isovalues
        .split(',')
        .map(|v| v.parse().expect("isovalue"))
        .collect();
    let grid = Grid::new(dims);
    let b = grid.bounds();
    let diagonal = ((b[1] - b[0]).powi(2) + (b[3] - b[2]).powi(2) + (b[5] - b[4]).powi(2)).sqrt();
    let repeat: usize = std::env::var("REPEAT")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(3);
    let scalars = ScalarSlice::U8(data);
    for tol in tolerances {
        let tol = match tol.strip_suffix('%') {
            Some(p) => p.parse::<f64>().expect("number") / 100.0 * diagonal,
            None => tol.parse().expect("number"),
        };
        let mut first = f64::INFINITY;
        let mut changes = vec![f64::INFINITY; isovalues.len()];
        let mut cpu = vec![f64::INFINITY; isovalues.len()];
        let mut triangles = vec![0; isovalues.len()];
        for _ in 0..repeat {
            let mut t = Instant::now();
            let mut c = cpu_seconds();
            let h = Hierarchy::build_for_isosurfaces(grid, scalars).expect("build");
            // START=current refines isovalue changes from the current mesh instead of the root.
            let mut state = match std::env::var("START").as_deref() {
                Ok("current") => IsoState::with_start(IsoStart::Current),
                _ => IsoState::new(),
            };
            for (i, &iso) in isovalues.iter().enumerate() {
                let s = state
                    .extract(&h, scalars, &IsoQuery::new(iso, tol))
                    .expect("isosurface");
                let seconds = t.elapsed().as_secs_f64();
                let used = cpu_seconds() - c;
                cpu[i] = cpu[i].min(used);
                if i == 0 {
                    first = first.min(seconds);
                } else {
                    changes[i] = changes[i].min(seconds);
                }
                triangles[i] = s.triangles.len();
                t = Instant::now();
                c = cpu_seconds();
            }
        }
        println!(
            "tol {:.2}% ({tol:.3}): first {first:.3}s, cpu {:.3}s ({} triangles)",
            100.0 * tol / diagonal,
            cpu[0],
            triangles[0]
        );
        for i in 1..isovalues.len() {
            println!(
                "  -> {}: {:.3}s, cpu {:.3}s ({} triangles)",
                isovalues[i], changes[i], cpu[i], triangles[i]
            );
        }
    }
}

/// CPU time of every thread of this process so far, in seconds (Linux: `/proc/self/task/*/schedstat`;
/// 0 elsewhere). Less disturbed by other processes than wall time.
fn cpu_seconds() -> f64 {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return 0.0;
    };
    tasks
        .filter_map(|t| std::fs::read_to_string(t.ok()?.path().join("schedstat")).ok())
        .filter_map(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .sum::<f64>()
        * 1e-9
}
