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

/// The Marschner–Lobb signal on a [`unit_grid`] of `dims`, quantised to bytes (0..=255).
pub fn marschner_lobb_u8(dims: [usize; 3]) -> (Grid, Vec<u8>) {
    let grid = unit_grid(dims);
    let values = sample(&grid, |x, y, z| {
        (marschner_lobb(x, y, z) * 255.0).round() as u8
    });
    (grid, values)
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

/// An analogue of Gregorski et al.'s impact data set (§5.5): a projectile entering a metal block, on a
/// grid of `dims` points over `[0, 12] × [0, 12] × [−16, 4.8]`.
pub struct ImpactCase {
    pub grid: Grid,
    /// Material names, in the order of `fractions`.
    pub names: [&'static str; 3],
    /// Point volume fractions of void, block and projectile (they sum to 1 at every point).
    pub fractions: [Vec<f32>; 3],
    /// Mixed density: `Σ fraction × material density`.
    pub density: Vec<f32>,
    /// Each material's own density at each point (void, block, projectile): the mean over the
    /// sub-samples of that material, or the material's density at the point where no sub-sample is of
    /// it (fraction 0). So `density = Σ fraction × material_density` (to rounding); void's is 0.
    pub material_density: [Vec<f32>; 3],
}

/// The impact case on `dims` points (the paper's grid is `[32, 32, 52]`).
///
/// The grid spans `[0, 12] × [0, 12] × [−16, 4.8]` (origin `[0, 0, −16]`, spacing = extent / (dims − 1)).
/// The impact axis is the z axis, `x = y = 0`: the domain corner, so the grid holds one quarter of an
/// axially symmetric scene (`r = √(x² + y²)`). Three materials, in this order:
/// - **Void** (0), density 0: everything else.
/// - **Block** (1): a metal plate between its back face (about `z = −11`, bulging out under the impact,
///   void behind it) and its top `z ≤ h(r)`. Its top `h` is
///   the plane `z = 0` with a paraboloidal crater of depth 2.4 and radius 3 around the axis and a
///   raised lip (Gaussian ridge of height 0.8 at `r = 3`, width 0.6):
///   `h(r) = −2.4 (1 − (r/3)²)₊ + 0.8 exp(−((r − 3)/0.6)²)`. Density 7.85 (steel) plus a spherical shock
///   shell `3 exp(−((R − 6)/1.2)²)`, `R` the distance from the impact point `(0, 0, −1)`.
/// - **Projectile** (2): a cylinder of radius 1.6 around the z axis, from the top of the domain down to a
///   hemispherical nose whose tip has penetrated to `z = −2.5`. It displaces the block where they
///   overlap (around the tip, `r ≲ 1`); further out a void gap separates the nose from the crater wall,
///   so all three pairs of materials touch and meet along a junction line. Density 17.6 (a tungsten
///   alloy) compressed near the nose: `+ 2 exp(−(z + 2.5)²)`.
///
/// Point volume fractions are the fractions of the dual cell of each point (the box of one spacing
/// centred on it, clipped to the domain) occupied by each material, by 5 × 5 × 5 supersampling: they are
/// multiples of 1/125 and sum to 1. The density at a point is the average over the same sub-samples of
/// the density of the material there (each material's density evaluated at the sub-sample); a
/// material's own density at a point is the average over its sub-samples only.
pub fn impact_case(dims: [usize; 3]) -> ImpactCase {
    use rayon::prelude::*;
    const LO: [f64; 3] = [0.0, 0.0, -16.0];
    const HI: [f64; 3] = [12.0, 12.0, 4.8];
    const SUB: usize = 5;
    let grid = Grid {
        dims,
        origin: LO,
        spacing: std::array::from_fn(|a| (HI[a] - LO[a]) / (dims[a].max(2) - 1) as f64),
    };
    let per_point: Vec<([u32; 3], f64, [f64; 3])> = (0..grid.len())
        .into_par_iter()
        .with_min_len(256)
        .map(|index| {
            let centre = grid.point(grid.ijk(index));
            let lo: [f64; 3] =
                std::array::from_fn(|a| (centre[a] - 0.5 * grid.spacing[a]).max(LO[a]));
            let hi: [f64; 3] =
                std::array::from_fn(|a| (centre[a] + 0.5 * grid.spacing[a]).min(HI[a]));
            let at = |a: usize, s: usize| lo[a] + (hi[a] - lo[a]) * (s as f64 + 0.5) / SUB as f64;
            let mut counts = [0u32; 3];
            let mut density = 0.0;
            let mut own = [0.0f64; 3];
            for k in 0..SUB {
                for j in 0..SUB {
                    for i in 0..SUB {
                        let x = [at(0, i), at(1, j), at(2, k)];
                        let m = impact_material(x);
                        let d = impact_density(m, x);
                        counts[m] += 1;
                        density += d;
                        own[m] += d;
                    }
                }
            }
            let own = std::array::from_fn(|m| match counts[m] {
                0 => impact_density(m, centre),
                c => own[m] / c as f64,
            });
            (counts, density / (SUB * SUB * SUB) as f64, own)
        })
        .collect();
    let total = (SUB * SUB * SUB) as f32;
    let fractions = std::array::from_fn(|m| {
        per_point
            .iter()
            .map(|(c, ..)| c[m] as f32 / total)
            .collect()
    });
    ImpactCase {
        grid,
        names: ["Void", "Block", "Projectile"],
        fractions,
        density: per_point.iter().map(|&(_, d, _)| d as f32).collect(),
        material_density: std::array::from_fn(|m| {
            per_point.iter().map(|(.., own)| own[m] as f32).collect()
        }),
    }
}

/// Probabilistic tissue maps made from an intensity volume (an analogue of brain-tissue maps: grey and
/// white matter and the rest, with the T1 intensity as the field).
pub struct TissueCase {
    pub grid: Grid,
    /// Material names, in the order of `fractions`.
    pub names: [&'static str; 3],
    /// Point volume fractions of other, grey and white (they sum to 1 at every point).
    pub fractions: [Vec<f32>; 3],
    /// The intensity scaled to `0..=255` (the field "T1").
    pub intensity: Vec<f32>,
}

/// The soft thresholds of [`tissue_case`] on the intensity scaled to `0..=255`, and their width.
pub const TISSUE_THRESHOLDS: [f64; 2] = [40.0, 90.0];
pub const TISSUE_WIDTH: f64 = 8.0;

/// Tissue maps from `values` on `source` (any sample type, as `f64`), on `dims` points.
///
/// The intensity is scaled to `0..=255` over its range and, when `dims` differs from the source's,
/// resampled trilinearly onto `dims` points with spacing 1 and origin 0 (the source's index space
/// stretched over the new grid, as a 1 mm tissue map); on the source's dims the source grid is kept.
/// With `s_i = σ((T − t_i) / w)` (logistic, [`TISSUE_THRESHOLDS`] `t_1 < t_2`, width [`TISSUE_WIDTH`]),
/// the fractions are other `1 − s_1`, grey `s_1 − s_2` and white `s_2`: smooth, in `[0, 1]`, summing
/// to 1, with all three pairs touching wherever the intensity climbs steeply.
pub fn tissue_case(source: &Grid, values: &[f64], dims: [usize; 3]) -> TissueCase {
    use rayon::prelude::*;
    let (lo, hi) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let scale = if hi > lo { 255.0 / (hi - lo) } else { 0.0 };
    let grid = if dims == source.dims {
        *source
    } else {
        Grid::new(dims)
    };
    let src = source.dims;
    // Per axis and output index: the source interval and the weight of its upper end.
    let axis = |a: usize| -> Vec<(usize, f64)> {
        (0..dims[a])
            .map(|i| {
                let u = if dims[a] > 1 {
                    i as f64 * (src[a] - 1) as f64 / (dims[a] - 1) as f64
                } else {
                    0.0
                };
                let i0 = (u.floor() as usize).min(src[a].saturating_sub(2));
                (i0, (u - i0 as f64).clamp(0.0, 1.0))
            })
            .collect()
    };
    let w = [axis(0), axis(1), axis(2)];
    let at = |i: usize, j: usize, k: usize| values[source.index(i, j, k)];
    let intensity: Vec<f32> = (0..grid.len())
        .into_par_iter()
        .with_min_len(4096)
        .map(|p| {
            let [i, j, k] = grid.ijk(p);
            let ((i0, ti), (j0, tj), (k0, tk)) = (w[0][i], w[1][j], w[2][k]);
            let (i1, j1, k1) = (
                (i0 + 1).min(src[0] - 1),
                (j0 + 1).min(src[1] - 1),
                (k0 + 1).min(src[2] - 1),
            );
            let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
            let plane = |k: usize| {
                lerp(
                    lerp(at(i0, j0, k), at(i1, j0, k), ti),
                    lerp(at(i0, j1, k), at(i1, j1, k), ti),
                    tj,
                )
            };
            ((lerp(plane(k0), plane(k1), tk) - lo) * scale) as f32
        })
        .collect();
    let soft =
        |t: f32, threshold: f64| 1.0 / (1.0 + (-(t as f64 - threshold) / TISSUE_WIDTH).exp());
    let [t1, t2] = TISSUE_THRESHOLDS;
    let fractions = [
        intensity
            .par_iter()
            .map(|&t| (1.0 - soft(t, t1)) as f32)
            .collect(),
        intensity
            .par_iter()
            .map(|&t| (soft(t, t1) - soft(t, t2)) as f32)
            .collect(),
        intensity.par_iter().map(|&t| soft(t, t2) as f32).collect(),
    ];
    TissueCase {
        grid,
        names: ["Other", "Grey", "White"],
        fractions,
        intensity,
    }
}

/// Radius of the projectile, height of its nose tip, and the centre height of its hemispherical nose.
const PROJECTILE_RADIUS: f64 = 1.6;
const NOSE_TIP: f64 = -2.5;
const NOSE_CENTRE: f64 = NOSE_TIP + PROJECTILE_RADIUS;

/// Height of the block's top surface at distance `r` from the impact axis: crater and lip.
fn block_top(r: f64) -> f64 {
    let (depth, crater, lip, lip_width) = (2.4, 3.0, 0.8, 0.6);
    let bowl = -depth * (1.0 - (r / crater).powi(2)).max(0.0);
    let u = (r - crater) / lip_width;
    // Beyond 6 widths the ridge is below 1e-15.
    bowl + if u.abs() < 6.0 {
        lip * (-u * u).exp()
    } else {
        0.0
    }
}

/// Height of the block's back face at distance `r` from the impact axis: a plate 11 units thick whose
/// back bulges out under the impact.
fn block_bottom(r: f64) -> f64 {
    -11.0 - 1.0 * (-(r / 4.0).powi(2)).exp()
}

/// The material at `x`: 2 (projectile, which wins over the block), 1 (block) or 0 (void).
fn impact_material(x: [f64; 3]) -> usize {
    let r2 = x[0] * x[0] + x[1] * x[1];
    let rp2 = PROJECTILE_RADIUS * PROJECTILE_RADIUS;
    let dz = x[2] - NOSE_CENTRE;
    if r2 <= rp2 && (dz >= 0.0 || r2 + dz * dz <= rp2) {
        2
    } else if x[2] <= block_top(r2.sqrt()) && x[2] >= block_bottom(r2.sqrt()) {
        1
    } else {
        0
    }
}

/// The density of material `m` at `x`.
fn impact_density(m: usize, x: [f64; 3]) -> f64 {
    match m {
        1 => {
            let r = (x[0] * x[0] + x[1] * x[1] + (x[2] + 1.0).powi(2)).sqrt();
            let u = (r - 6.0) / 1.2;
            // Beyond 6 widths the shell is below 1e-15.
            7.85 + if u.abs() < 6.0 {
                3.0 * (-u * u).exp()
            } else {
                0.0
            }
        }
        2 => 17.6 + 2.0 * (-(x[2] - NOSE_TIP).powi(2)).exp(),
        _ => 0.0,
    }
}

#[cfg(test)]
mod impact_tests {
    use super::*;

    #[test]
    fn tissue_case_resamples_and_sums_to_one() {
        // A ramp along x over 5 × 3 × 2 points, spacing 2: scaled to 0..255.
        let source = Grid {
            dims: [5, 3, 2],
            origin: [1.0; 3],
            spacing: [2.0; 3],
        };
        let values: Vec<f64> = (0..source.len()).map(|p| source.ijk(p)[0] as f64).collect();
        let same = tissue_case(&source, &values, source.dims);
        assert_eq!(same.grid, source);
        assert_eq!(same.intensity[4], 255.0);
        let case = tissue_case(&source, &values, [9, 4, 3]);
        assert_eq!(case.grid, Grid::new([9, 4, 3]));
        for p in 0..case.grid.len() {
            let [i, ..] = case.grid.ijk(p);
            assert!((case.intensity[p] as f64 - 255.0 * i as f64 / 8.0).abs() < 1e-3);
            let sum: f32 = case.fractions.iter().map(|f| f[p]).sum();
            assert!((sum - 1.0).abs() < 1e-6);
            assert!(case.fractions.iter().all(|f| (0.0..=1.0).contains(&f[p])));
        }
        // Other below the first threshold, white above the second, grey between.
        let largest = |p: usize| {
            (0..3).max_by(|&a, &b| case.fractions[a][p].total_cmp(&case.fractions[b][p]))
        };
        assert_eq!(
            [0, 2, 4, 8].map(largest),
            [Some(0), Some(1), Some(2), Some(2)]
        );
    }

    #[test]
    fn impact_case_has_three_touching_materials() {
        let case = impact_case([32, 32, 52]);
        let g = &case.grid;
        assert_eq!(g.len(), 32 * 32 * 52);
        assert_eq!(g.origin, [0.0, 0.0, -16.0]);
        let b = g.bounds();
        for (x, e) in b.iter().zip([0.0, 12.0, 0.0, 12.0, -16.0, 4.8]) {
            assert!((x - e).abs() < 1e-12);
        }
        assert_eq!(case.names, ["Void", "Block", "Projectile"]);
        let f = &case.fractions;
        assert!(f.iter().all(|f| f.len() == g.len()) && case.density.len() == g.len());
        for i in 0..g.len() {
            let sum: f32 = f.iter().map(|f| f[i]).sum();
            assert!((sum - 1.0).abs() < 1e-6, "fractions sum to {sum} at {i}");
            assert!(f.iter().all(|f| (0.0..=1.0).contains(&f[i])));
            if f[0][i] == 1.0 {
                assert_eq!(case.density[i], 0.0);
            }
        }
        // Every material is present pure somewhere, and every pair mixes somewhere.
        for (f, name) in f.iter().zip(case.names) {
            assert!(f.contains(&1.0), "no pure {name}");
        }
        for (a, b) in [(0, 1), (0, 2), (1, 2)] {
            let mixed = (0..g.len())
                .filter(|&i| f[a][i] > 0.0 && f[b][i] > 0.0)
                .count();
            assert!(
                mixed > 0,
                "no {}–{} interface",
                case.names[a],
                case.names[b]
            );
        }
        // Densities: steel with a shock shell, the heavier projectile.
        let pure = |m: usize| (0..g.len()).filter(move |&i| f[m][i] == 1.0);
        assert!(pure(1).all(|i| (7.85..=10.86).contains(&case.density[i])));
        assert!(pure(1).any(|i| case.density[i] > 10.0));
        assert!(pure(2).all(|i| (17.6..=19.61).contains(&case.density[i])));
        // Per-material densities: void 0, the mixed density their fraction-weighted sum.
        assert!(case.material_density[0].iter().all(|&d| d == 0.0));
        assert!(pure(1).all(|i| case.material_density[1][i] == case.density[i]));
        for (i, &d) in case.density.iter().enumerate() {
            let sum: f32 = (0..3).map(|m| f[m][i] * case.material_density[m][i]).sum();
            assert!((sum - d).abs() < 1e-4, "{sum} vs {d}");
        }
        assert!(case.material_density[1]
            .iter()
            .all(|d| (7.85..=10.86).contains(d)));
        // Quarter symmetry about the corner axis: the x and y axes play the same role.
        let [nx, ny, _] = g.dims;
        assert_eq!(nx, ny);
        for i in 0..g.len() {
            let [x, y, z] = g.ijk(i);
            let t = g.index(y, x, z);
            assert!((f[2][i] - f[2][t]).abs() < 1e-6 && (f[1][i] - f[1][t]).abs() < 1e-6);
        }
    }
}
