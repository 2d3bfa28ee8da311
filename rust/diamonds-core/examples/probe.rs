//! Timing probe on a raw u8 volume (x fastest), for profiling the core without VTK:
//!
//! `cargo run --release -p diamonds-core --example probe -- file.u8 nx ny nz tetra TOL...`
//! `cargo run --release -p diamonds-core --example probe -- file.u8 nx ny nz iso ISO1,ISO2,... TOL...`
//! `cargo run --release -p diamonds-core --example probe -- file.u8 nx ny nz isoseq ISO1,ISO2,... TOL...`
//!
//! `cargo run --release -p diamonds-core --example probe -- file.u8 nx ny nz isochange ISO1,ISO2,... TOL[%]...`
//! `cargo run --release -p diamonds-core --example probe -- file.u8 nx ny nz view BUDGET FRAMES`
//!
//! `view` runs bench_view.py's orbit (6° per frame, 2.2 diagonals away, 400×300 pixels, 30°, Pixel
//! Tolerance 0.5) under a tetrahedron budget and prints, per frame, the milliseconds of the
//! refinement, of the BSP tree built from the mesh plan, of the tree rebuilt from the bisection
//! paths, of one traversal, and of writing the tetrahedra in bisection-path order and in
//! visibility order, with their medians over frames 1 to the last.
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
    if a[5] == "view" {
        view_orbit(&data, dims, parse(&a[6]) as usize, parse(&a[7]) as usize);
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

/// bench_view.py's orbit in the core (see the module's documentation).
fn view_orbit(data: &[u8], dims: [usize; 3], budget: usize, frames: usize) {
    use diamonds::view::{BspTree, Camera, Direction, Metric, ViewErrors, ViewQuery, ViewState};
    let grid = Grid::new(dims);
    let h = Hierarchy::build(grid, ScalarSlice::U8(data), &mut |_| true).expect("build");
    let errors = ViewErrors::new(&h).expect("view errors");
    let b = grid.bounds();
    let center = [0, 2, 4].map(|a| 0.5 * (b[a] + b[a + 1]));
    let radius = 2.2
        * (0..3)
            .map(|a| (b[2 * a + 1] - b[2 * a]).powi(2))
            .sum::<f64>()
            .sqrt();
    let mut state = ViewState::new(&h);
    let ms = |t: Instant| 1e3 * t.elapsed().as_secs_f64();
    let mut rows = Vec::new();
    for frame in 0..frames {
        let a = (6.0 * frame as f64).to_radians();
        let position = [
            center[0] + radius * a.cos(),
            center[1] + radius * a.sin(),
            center[2] + 0.35 * radius,
        ];
        let query = ViewQuery {
            camera: Camera {
                position,
                focal_point: center,
                view_up: [0.0, 0.0, 1.0],
                view_angle: 30.0,
                viewport: [400, 300],
            },
            metric: Metric::ScreenSpace,
            tolerance: 0.5,
            max_tetrahedra: budget,
        };
        let t = Instant::now();
        let stats = state.update(&h, &errors, &query).expect("update");
        let refine = ms(t);
        let plan = state.plan().expect("plan");
        let t = Instant::now();
        let tree = BspTree::new(&plan, &grid).expect("tree");
        let tree_ms = ms(t);
        let paths = tree.paths().expect("paths");
        let t = Instant::now();
        let rebuilt = BspTree::from_paths(&grid, &paths).expect("tree from paths");
        let rebuilt_ms = ms(t);
        let t = Instant::now();
        let order = rebuilt
            .order(position, Direction::BackToFront)
            .expect("order");
        let order_ms = ms(t);
        assert_eq!(order.len(), stats.tets);
        // Writing the tetrahedra as the filter does, in bisection-path order and in visibility
        // order (alternating which goes first).
        let n = plan.tets();
        let (mut conn, mut depths, mut errs) = (vec![0i32; 4 * n], vec![0u8; n], vec![0f32; n]);
        let mut ordered = plan.clone();
        ordered
            .set_visibility_order(&grid, position, Direction::BackToFront)
            .expect("visibility order");
        let mut write = |p: &diamonds::mesh::MeshPlan| {
            let t = Instant::now();
            h.write_tets(p, &mut conn, &mut [], &mut depths, &mut errs)
                .expect("write");
            ms(t)
        };
        let (plain_ms, ordered_ms) = if frame % 2 == 0 {
            let plain = write(&plan);
            (plain, write(&ordered))
        } else {
            let o = write(&ordered);
            (write(&plan), o)
        };
        println!(
            "frame {frame}: {} tets, {} splits, {} merges: refinement {refine:.1} ms, tree from plan {tree_ms:.1} ms, from paths {rebuilt_ms:.1} ms, order {order_ms:.1} ms, write {plain_ms:.1} ms, write in order {ordered_ms:.1} ms",
            stats.tets, stats.splits, stats.merges
        );
        rows.push([refine, tree_ms, rebuilt_ms, order_ms, plain_ms, ordered_ms]);
    }
    let median = |k: usize| {
        let mut v: Vec<f64> = rows.iter().skip(1).map(|r| r[k]).collect();
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
    };
    println!(
        "median over frames 1-{}: refinement {:.1} ms, tree from plan {:.1} ms, from paths {:.1} ms, order {:.1} ms, write {:.1} ms, write in order {:.1} ms",
        frames.saturating_sub(1),
        median(0),
        median(1),
        median(2),
        median(3),
        median(4),
        median(5)
    );
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
