use diamonds::fields::{marschner_lobb, sample, unit_grid};
use diamonds::{Hierarchy, Query, ScalarSlice};
fn main() {
    let g = unit_grid([33, 33, 33]);
    let v = sample(&g, |x, y, z| {
        (marschner_lobb(x, y, z) * 255.0).round() as u8
    });
    let h = Hierarchy::build(g, ScalarSlice::U8(&v), &mut |_| true).unwrap();
    for tol in [0.0, 1.0, 4.0, 16.0, 32.0, 50.0, 64.0] {
        let m = h.query(&Query::tolerance(tol)).unwrap();
        println!("tol {tol}: {} tets max {}", m.tets.len(), m.max_error);
    }
    for b in [500, 2000, 8000, 20000, 60000] {
        let m = h
            .query(&Query {
                tolerance: 0.0,
                max_tetrahedra: b,
                region_of_interest: None,
            })
            .unwrap();
        println!("budget {b}: {} tets max {}", m.tets.len(), m.max_error);
    }
}
