//! Isosurface probe: triangle counts and timings on a raw u8 volume:
//! `cargo run --release --example isoprobe -- file.u8 nx ny nz iso1,iso2,... tol...`.
use diamonds::{Grid, Hierarchy, IsoQuery, ScalarSlice};
use std::time::Instant;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let data = std::fs::read(&a[1]).unwrap();
    let dims = [
        a[2].parse().unwrap(),
        a[3].parse().unwrap(),
        a[4].parse().unwrap(),
    ];
    let isos: Vec<f64> = a[5].split(',').map(|v| v.parse().unwrap()).collect();
    let g = Grid::new(dims);
    let t = Instant::now();
    let h = Hierarchy::build(g, ScalarSlice::U8(&data), &mut |_| true).unwrap();
    println!("build {:.3}s", t.elapsed().as_secs_f64());
    for &iso in &isos {
        for tol in a[6..].iter().map(|t| t.parse::<f64>().unwrap()) {
            let t = Instant::now();
            let s = h
                .isosurface(ScalarSlice::U8(&data), &IsoQuery::new(iso, tol))
                .unwrap();
            println!(
                "iso {iso} tol {tol}: {} triangles, bound {:.3} in {:.3}s",
                s.triangles.len(),
                s.error_bound,
                t.elapsed().as_secs_f64()
            );
        }
    }
}
