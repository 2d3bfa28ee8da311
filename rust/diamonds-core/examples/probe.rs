//! Quick timing probe on a raw u8 volume: `cargo run --release --example probe -- file.u8 nx ny nz`.
use diamonds::{Grid, Hierarchy, Query, ScalarSlice};
use std::time::Instant;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let data = std::fs::read(&a[1]).unwrap();
    let dims = [
        a[2].parse().unwrap(),
        a[3].parse().unwrap(),
        a[4].parse().unwrap(),
    ];
    let g = Grid {
        dims,
        origin: [0.0; 3],
        spacing: [1.0; 3],
    };
    let t = Instant::now();
    let h = Hierarchy::build(g, ScalarSlice::U8(&data), &mut |_| true).unwrap();
    println!(
        "build {:.3}s base tets {}",
        t.elapsed().as_secs_f64(),
        h.base_tetrahedra()
    );
    let tols: Vec<f64> = a[5..].iter().map(|t| t.parse().unwrap()).collect();
    for &tol in &tols {
        let t = Instant::now();
        let m = h.query(&Query::tolerance(tol)).unwrap();
        println!(
            "tol {tol}: {} tets {} points max {} in {:.3}s",
            m.tets.len(),
            m.points.len(),
            m.max_error,
            t.elapsed().as_secs_f64()
        );
    }
}
