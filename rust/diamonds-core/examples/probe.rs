//! Timing probe on a raw u8 volume (x fastest), for profiling the core without VTK:
//!
//! `cargo run --release -p diamonds-core --example probe -- file.u8 nx ny nz tetra TOL...`
//! `cargo run --release -p diamonds-core --example probe -- file.u8 nx ny nz iso ISO1,ISO2,... TOL...`
use diamonds::{Grid, Hierarchy, IsoQuery, Query, ScalarSlice};
use std::time::Instant;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 6 {
        eprintln!("usage: probe file.u8 nx ny nz (tetra TOL... | iso ISO1,ISO2,... TOL...)");
        std::process::exit(2);
    }
    let data = std::fs::read(&a[1]).expect("readable file");
    let dims = [2, 3, 4].map(|i| a[i].parse().expect("dimension"));
    let parse = |s: &String| -> f64 { s.parse().expect("number") };
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
            for tol in a[6..].iter().map(parse) {
                let t = Instant::now();
                let m = h.query(&Query::tolerance(tol)).expect("query");
                println!(
                    "tol {tol}: {} tets, {} points, max error {} in {:.3}s",
                    m.tets.len(),
                    m.points.len(),
                    m.max_error,
                    t.elapsed().as_secs_f64()
                );
            }
        }
        _ => {
            for iso in a[6].split(',').map(|v| v.parse::<f64>().expect("isovalue")) {
                for tol in a[7..].iter().map(parse) {
                    let t = Instant::now();
                    let s = h
                        .isosurface(ScalarSlice::U8(&data), &IsoQuery::new(iso, tol))
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
