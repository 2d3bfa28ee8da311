//! Generated volumes: the embedded defaults of the demo and the tests (no download needed).

use crate::Grid;
use std::f64::consts::PI;

/// A grid of `dims` points spanning `[-1, 1]` on every axis.
pub fn unit_grid(dims: [usize; 3]) -> Grid {
    Grid {
        dims,
        origin: [-1.0; 3],
        spacing: dims.map(|d| 2.0 / (d.max(2) - 1) as f64),
    }
}

/// Samples `f(x, y, z)` at the world positions of `grid`'s points (x fastest).
pub fn sample<T>(grid: &Grid, f: impl Fn(f64, f64, f64) -> T) -> Vec<T> {
    (0..grid.len())
        .map(|i| {
            let [x, y, z] = grid.point(grid.ijk(i));
            f(x, y, z)
        })
        .collect()
}

/// The Marschner–Lobb test signal on `[-1, 1]^3` (Marschner & Lobb 1994, `f_M = 6`, `α = 1/4`),
/// values in `[0, 1]`: a standard stress test for reconstruction, with fine ripples around the z axis.
pub fn marschner_lobb(x: f64, y: f64, z: f64) -> f64 {
    let (fm, alpha) = (6.0, 0.25);
    let r = (x * x + y * y).sqrt();
    let rho = (2.0 * PI * fm * (PI * r / 2.0).cos()).cos();
    (1.0 - (PI * z / 2.0).sin() + alpha * (1.0 + rho)) / (2.0 * (1.0 + alpha))
}

/// Distance to the sphere of radius `r` centred at the origin (negative inside).
pub fn sphere_distance(r: f64) -> impl Fn(f64, f64, f64) -> f64 {
    move |x, y, z| (x * x + y * y + z * z).sqrt() - r
}

/// Distance to the torus of radii `big` (centre circle, in the xy plane) and `small` (tube).
pub fn torus_distance(big: f64, small: f64) -> impl Fn(f64, f64, f64) -> f64 {
    move |x, y, z| {
        let q = (x * x + y * y).sqrt() - big;
        (q * q + z * z).sqrt() - small
    }
}
