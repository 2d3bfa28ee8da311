//! Integer point enumeration inside a tetrahedron and its exact interpolation error (Marchesin §4.1).
//!
//! Marchesin et al. enumerate the lattice points of an LEB tetrahedron slice by slice. We scan rows
//! along x instead: for each `(y, z)` the row's x-interval is cut by the four face half-spaces, using
//! the *barycentric numerators* `B_i(p) = n_i · p + b_i` (integer coefficients; `B_i(p) = det · λ_i(p)`).
//! A point is inside (closed) iff every `B_i(p) ≥ 0` — exact integer tests, no epsilon.
//!
//! The linear interpolant satisfies `det · L(p) = Σ B_i(p) f_i`, so the error at a sample is
//! `|det · f(p) − Σ B_i(p) f_i| / det`. For samples of up to 16-bit integers every term is an integer
//! below 2^53 and the `f64` arithmetic is exact (coefficients are first divided by `s²`, `s` the
//! tetrahedron's scale): an error of zero is reported as exactly zero. For 32-bit and floating-point
//! samples the result carries the usual `f64` rounding (relative 1e-16).

use crate::lattice::Tet;
use crate::volume::{Sample, Volume};
use glam::{I64Vec3, IVec3};

/// What a scan of a tetrahedron finds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TetStats {
    /// Largest `|f(p) − L(p)|` over the samples `p` in the closed tetrahedron.
    pub error: f64,
    /// Smallest sample in the closed tetrahedron.
    pub min: f64,
    /// Largest sample in the closed tetrahedron.
    pub max: f64,
}

impl TetStats {
    /// Neutral element of [`TetStats::merge`].
    pub const EMPTY: Self = Self {
        error: 0.0,
        min: f64::INFINITY,
        max: f64::NEG_INFINITY,
    };

    /// Union of two scans.
    #[inline]
    pub fn merge(self, other: Self) -> Self {
        Self {
            error: self.error.max(other.error),
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }
}

/// Barycentric numerator planes of a tetrahedron: `B_i(p) = normals[i] · p + offsets[i]`.
struct Planes {
    normals: [I64Vec3; 4],
    offsets: [i64; 4],
    det: i64,
}

impl Planes {
    fn new(t: &Tet) -> Self {
        let v = t.map(|p| p.as_i64vec3());
        // Every edge vector of an LEB tetrahedron is a multiple of its scale s (a power of two);
        // dividing the normals by s² keeps all products small and exact.
        let or = (1..4).fold(0i64, |acc, i| {
            let e = (v[i] - v[0]).abs();
            acc | e.x | e.y | e.z
        });
        let s2 = 1i64 << (2 * or.trailing_zeros());
        let mut normals = [I64Vec3::ZERO; 4];
        let mut offsets = [0i64; 4];
        let mut det = 0;
        for i in 0..4 {
            let [a, b, c] = [(i + 1) % 4, (i + 2) % 4, (i + 3) % 4].map(|j| v[j]);
            let mut n = (b - a).cross(c - a) / s2;
            let at_vertex = n.dot(v[i] - a);
            if at_vertex < 0 {
                n = -n;
            }
            det = at_vertex.abs();
            normals[i] = n;
            offsets[i] = -n.dot(a);
        }
        Self {
            normals,
            offsets,
            det,
        }
    }
}

#[inline]
fn ceil_div(a: i64, b: i64) -> i64 {
    -((-a).div_euclid(b))
}

/// Scans the samples of `volume` inside the closed tetrahedron `t` (all vertices must be samples).
pub fn scan_tet<T: Sample>(volume: &Volume<'_, T>, t: &Tet) -> TetStats {
    let planes = Planes::new(t);
    let values = t.map(|p| volume.at(p.x as usize, p.y as usize, p.z as usize));
    let det = planes.det as f64;
    // Slope of Σ B_i f_i along x.
    let slope: f64 = (0..4).map(|i| planes.normals[i].x as f64 * values[i]).sum();
    let lo = t[0].min(t[1]).min(t[2].min(t[3]));
    let hi = t[0].max(t[1]).max(t[2].max(t[3]));
    let dims = volume.grid.dims;
    let mut stats = TetStats::EMPTY;
    let mut worst = 0.0f64;
    for z in lo.z..=hi.z {
        for y in lo.y..=hi.y {
            let (mut x0, mut x1) = (lo.x as i64, hi.x as i64);
            let mut base = 0.0;
            for i in 0..4 {
                let n = planes.normals[i];
                let r = n.y * y as i64 + n.z * z as i64 + planes.offsets[i];
                match n.x {
                    a if a > 0 => x0 = x0.max(ceil_div(-r, a)),
                    a if a < 0 => x1 = x1.min(r.div_euclid(-a)),
                    _ if r < 0 => x1 = x0 - 1,
                    _ => {}
                }
                base += r as f64 * values[i];
            }
            if x0 > x1 {
                continue;
            }
            let row = dims[0] * (y as usize + dims[1] * z as usize);
            let samples = &volume.samples[row + x0 as usize..=row + x1 as usize];
            let mut numerator = base + slope * x0 as f64;
            for s in samples {
                let f = s.to_f64();
                worst = worst.max((det * f - numerator).abs());
                stats.min = stats.min.min(f);
                stats.max = stats.max.max(f);
                numerator += slope;
            }
        }
    }
    stats.error = worst / det;
    stats
}

/// Lattice points of the closed tetrahedron, by brute force over its bounding box with `f64`
/// barycentric coordinates (slow; used to test [`scan_tet`]).
pub fn brute_force_points(t: &Tet) -> Vec<IVec3> {
    let lo = t[0].min(t[1]).min(t[2].min(t[3]));
    let hi = t[0].max(t[1]).max(t[2].max(t[3]));
    let v = t.map(|p| p.as_dvec3());
    let m = glam::DMat3::from_cols(v[1] - v[0], v[2] - v[0], v[3] - v[0]);
    let inv = m.inverse();
    let mut out = Vec::new();
    for z in lo.z..=hi.z {
        for y in lo.y..=hi.y {
            for x in lo.x..=hi.x {
                let p = IVec3::new(x, y, z);
                let l = inv * (p.as_dvec3() - v[0]);
                if l.min_element() >= -1e-9 && l.element_sum() <= 1.0 + 1e-9 {
                    out.push(p);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diamond::Diamond;
    use crate::lattice::Lattice;
    use crate::volume::Grid;

    fn noise(n: usize) -> Vec<u16> {
        // Deterministic pseudo-random samples (xorshift).
        let mut x = 0x2545_f491_4f6c_dd1du64;
        (0..n)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                (x % 4096) as u16
            })
            .collect()
    }

    #[test]
    fn matches_brute_force_on_every_tet_of_a_16_cube() {
        let n = 16usize;
        let grid = Grid {
            dims: [n + 1; 3],
            origin: [0.0; 3],
            spacing: [1.0; 3],
        };
        let samples = noise(grid.len());
        let vol = Volume::new(grid, &samples).unwrap();
        let l = Lattice::new(grid.dims).unwrap();
        let mut stack = vec![Diamond::root(&l)];
        let mut seen = std::collections::HashSet::new();
        let mut tets = 0;
        while let Some(d) = stack.pop() {
            if !seen.insert(d) {
                continue;
            }
            stack.extend(d.children(&l));
            for t in d.tets(&l) {
                tets += 1;
                let got = scan_tet(&vol, &t);
                // Independent evaluation: f64 barycentric interpolation at brute-force points.
                let v = t.map(|p| p.as_dvec3());
                let inv = glam::DMat3::from_cols(v[1] - v[0], v[2] - v[0], v[3] - v[0]).inverse();
                let f = t.map(|p| vol.at(p.x as usize, p.y as usize, p.z as usize));
                let mut want = TetStats::EMPTY;
                for p in brute_force_points(&t) {
                    let l = inv * (p.as_dvec3() - v[0]);
                    let interp =
                        f[0] * (1.0 - l.element_sum()) + f[1] * l.x + f[2] * l.y + f[3] * l.z;
                    let s = vol.at(p.x as usize, p.y as usize, p.z as usize);
                    want = want.merge(TetStats {
                        error: (s - interp).abs(),
                        min: s,
                        max: s,
                    });
                }
                assert!(
                    (got.error - want.error).abs() <= 1e-9 * want.error.max(1.0),
                    "{t:?}: {got:?} vs {want:?}"
                );
                assert_eq!((got.min, got.max), (want.min, want.max), "{t:?}");
            }
        }
        assert!(tets > 1000);
    }

    #[test]
    fn linear_field_has_exactly_zero_error() {
        let n = 32usize;
        let grid = Grid {
            dims: [n + 1; 3],
            origin: [0.0; 3],
            spacing: [1.0; 3],
        };
        let samples: Vec<i16> = (0..grid.len())
            .map(|i| {
                let [x, y, z] = grid.ijk(i);
                (3 * x as i32 - 2 * y as i32 + 5 * z as i32 - 40) as i16
            })
            .collect();
        let vol = Volume::new(grid, &samples).unwrap();
        let l = Lattice::new(grid.dims).unwrap();
        for t in Diamond::root(&l).tets(&l) {
            let st = scan_tet(&vol, &t);
            assert_eq!(st.error, 0.0);
        }
    }
}
