//! Measures isodiamond hierarchies for `scripts/bench_isodiamonds.py` (not a test): for one volume,
//! an isosurface at the middle of its range and the interval volume from 30 % to 60 % of it (both
//! moved to half-integers for integer data), the RI and MI hierarchies on the default ladder: their
//! counts and bytes, the indexed full-resolution mesh (Weiss & De Floriani Table 2: 12 B per vertex,
//! 12 B per triangle or 16 B per tetrahedron), and extraction times from the full hierarchy, RI and
//! MI at 1 %, 0.25 % of the diagonal and 0 (Figure 15), alternating, the minimum of `REPEATS`.
//! Prints one JSON object per target.
//!
//!   cargo run --release -p diamonds-cli --example isodiamond_probe -- IN.vti [REPEATS]

use diamonds::isodiamond::{self, Model, Target, DEFAULT_LADDER};
use diamonds::{interval, isosurface, Hierarchy, IsoQuery};
use diamonds_cli::read::read_image;
use diamonds_cli::AsScalarSlice;
use std::time::Instant;

fn seconds(f: impl FnOnce()) -> f64 {
    let start = Instant::now();
    f();
    start.elapsed().as_secs_f64()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 2 {
        eprintln!("usage: isodiamond_probe IN.vti [REPEATS]");
        std::process::exit(2);
    }
    let repeats: usize = args.get(2).map_or(3, |r| r.parse().expect("a count"));
    let image = read_image(std::path::Path::new(&args[1])).expect("a .vti");
    let array = image.scalars(None).expect("scalars");
    let scalars = array.scalar_slice().expect("numbers");
    let grid = image.grid;
    let h = Hierarchy::build_for_isosurfaces(grid, scalars).expect("a hierarchy");
    let (lo, hi) = h.value_range();
    let integer = (0..array.data.len()).all(|k| array.value(k).fract() == 0.0);
    let level = |f: f64| {
        let v = lo + f * (hi - lo);
        if integer {
            v.floor() + 0.5
        } else {
            v
        }
    };
    let diagonal = grid.diagonal();
    let ladder: Vec<f64> = DEFAULT_LADDER.iter().map(|r| r * diagonal).collect();
    for target in [
        Target::Isosurface(level(0.5)),
        Target::IntervalVolume([level(0.3), level(0.6)]),
    ] {
        let start = Instant::now();
        let ri = isodiamond::build(&h, scalars, target, Model::Relevant, &ladder, &mut |_| true)
            .expect("RI");
        let ri_seconds = start.elapsed().as_secs_f64();
        let mi = isodiamond::build(&h, scalars, target, Model::Minimal, &ladder, &mut |_| true)
            .expect("MI");
        let (vertices, cells, indexed) = match target {
            Target::Isosurface(v) => {
                let query = IsoQuery {
                    compute_normals: false,
                    ..IsoQuery::new(v, 0.0)
                };
                let s = isosurface::extract(&h, scalars, &query).expect("a surface");
                let (v, t) = (s.points.len(), s.triangles.len());
                (v, t, 12 * v + 12 * t)
            }
            Target::IntervalVolume(r) => {
                let query = interval::IntervalQuery::new(r, 0.0);
                let iv = interval::extract(&h, scalars, &query).expect("a volume");
                let (v, t) = (iv.points.len(), iv.tets.len());
                (v, t, 12 * v + 16 * t)
            }
        };
        let mut times = Vec::new();
        for relative in [0.01, 0.0025, 0.0] {
            let tol = relative * diagonal;
            let (mut full, mut r, mut m) = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
            let mut count = 0;
            for _ in 0..repeats {
                match target {
                    Target::Isosurface(v) => {
                        let query = IsoQuery {
                            compute_normals: false,
                            ..IsoQuery::new(v, tol)
                        };
                        full = full.min(seconds(|| {
                            count = isosurface::extract(&h, scalars, &query)
                                .unwrap()
                                .triangles
                                .len()
                        }));
                        r = r.min(seconds(|| {
                            assert_eq!(ri.isosurface(tol).unwrap().triangles.len(), count)
                        }));
                        m = m.min(seconds(|| {
                            assert_eq!(mi.isosurface(tol).unwrap().triangles.len(), count)
                        }));
                    }
                    Target::IntervalVolume(range) => {
                        let query = interval::IntervalQuery::new(range, tol);
                        full = full.min(seconds(|| {
                            count = interval::extract(&h, scalars, &query).unwrap().tets.len()
                        }));
                        r = r.min(seconds(|| {
                            assert_eq!(ri.interval_volume(tol).unwrap().tets.len(), count)
                        }));
                        m = m.min(seconds(|| {
                            assert_eq!(mi.interval_volume(tol).unwrap().tets.len(), count)
                        }));
                    }
                }
            }
            times.push(format!(
                "{{\"relative\": {relative}, \"cells\": {count}, \"full\": {full}, \"ri\": {r}, \"mi\": {m}}}"
            ));
        }
        let (rc, mc) = (ri.counts(), mi.counts());
        let (kind, levels) = match target {
            Target::Isosurface(v) => ("isosurface", format!("[{v}]")),
            Target::IntervalVolume([a, b]) => ("interval volume", format!("[{a}, {b}]")),
        };
        println!(
            "{{\"target\": \"{kind}\", \"levels\": {levels}, \"crossings\": {}, \"relevant\": {}, \"creation\": {}, \"active\": {}, \"orphans\": {}, \"vertices\": {vertices}, \"cells\": {cells}, \"indexed_bytes\": {indexed}, \"ri_bytes\": {}, \"mi_bytes\": {}, \"ri_build_seconds\": {ri_seconds}, \"times\": [{}]}}",
            rc.crossings,
            rc.relevant,
            rc.creation,
            rc.active,
            mc.orphans,
            ri.to_bytes().len(),
            mi.to_bytes().len(),
            times.join(", ")
        );
    }
}
