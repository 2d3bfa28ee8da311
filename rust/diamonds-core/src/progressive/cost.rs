//! The parts of the collapse cost of §3.3 (Eq. 2: `ΔE = w_g ΔE_g + w_f ΔE_f + w_s ΔE_s`) and the
//! tetrahedron geometry they need: error quadrics (Garland–Heckbert, Eq. 3–4), the shape measure from
//! the condition number of the equilateral-to-tetrahedron map, volumes and barycentric coordinates.

use glam::{DMat3, DVec3, DVec4};

/// An error quadric `Q` (§3.3, Eq. 3): `p^T Q p` is the sum of the squared distances of `p` to the
/// planes added to it. Symmetric 4×4, stored as its upper triangle.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Quadric([f64; 10]);

impl Quadric {
    /// `K_e = e e^T` for the plane through `a`, `b`, `c` (`e = [n, -n·a]`, `|n| = 1`); zero for a
    /// degenerate triangle.
    pub(super) fn of_plane(a: DVec3, b: DVec3, c: DVec3) -> Self {
        let n = (b - a).cross(c - a).normalize_or_zero();
        let e = DVec4::new(n.x, n.y, n.z, -n.dot(a));
        let mut q = [0.0; 10];
        let mut k = 0;
        for r in 0..4 {
            for s in r..4 {
                q[k] = e[r] * e[s];
                k += 1;
            }
        }
        Self(q)
    }

    /// `Q + other`.
    pub(super) fn add(&mut self, other: &Self) {
        for (a, b) in self.0.iter_mut().zip(other.0) {
            *a += b;
        }
    }

    /// `p^T Q p` with `p = [x, y, z, 1]` (Eq. 4 for the sum `Q_i + Q_j`).
    pub(super) fn eval(&self, p: DVec3) -> f64 {
        let v = [p.x, p.y, p.z, 1.0];
        let mut sum = 0.0;
        let mut k = 0;
        for r in 0..4 {
            for s in r..4 {
                let term = self.0[k] * v[r] * v[s];
                sum += if r == s { term } else { 2.0 * term };
                k += 1;
            }
        }
        sum.max(0.0)
    }
}

/// Six times the signed volume of the tetrahedron `x` (§3.2, Eq. 1).
#[cfg(test)]
pub(super) fn volume6(x: &[DVec3; 4]) -> f64 {
    (x[1] - x[0]).dot((x[2] - x[0]).cross(x[3] - x[0]))
}

/// The shape measure `M(T) = κ(S) - 3` of §3.3, `S = A W^{-1}` the map from the equilateral
/// tetrahedron of unit edges to `x`, `κ` the condition number in the Frobenius norm: 0 for an
/// equilateral tetrahedron (the paper's "1" counts otherwise), growing without bound as the
/// tetrahedron flattens. Invariant under translation, rotation and scaling.
pub(super) fn shape_measure(x: &[DVec3; 4]) -> f64 {
    let a = DMat3::from_cols(x[1] - x[0], x[2] - x[0], x[3] - x[0]);
    let s = a * equilateral_inverse();
    let det = s.determinant();
    if det.abs() < f64::MIN_POSITIVE {
        return f64::INFINITY;
    }
    let frobenius = |m: DMat3| {
        (m.x_axis.length_squared() + m.y_axis.length_squared() + m.z_axis.length_squared()).sqrt()
    };
    (frobenius(s) * frobenius(s.inverse()) - 3.0).max(0.0)
}

/// `W^{-1}`, `W` the map from the right-angled reference tetrahedron to the equilateral one (§3.3).
fn equilateral_inverse() -> DMat3 {
    let w = DMat3::from_cols(
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.5, 3f64.sqrt() / 2.0, 0.0),
        DVec3::new(0.5, 3f64.sqrt() / 6.0, (2.0f64 / 3.0).sqrt()),
    );
    w.inverse()
}

/// A tetrahedron prepared for barycentric coordinates by Cramer's rule: `x[0]`, the cross products
/// of its edge vectors `e1 = x1 - x0`, `e2`, `e3` over six times its signed volume, so that each
/// point costs three dot products (`λ_k = (p - x0)·c_k / (e1·(e2×e3))`).
#[derive(Clone, Copy, Debug)]
pub(super) struct Frame {
    origin: DVec3,
    c: [DVec3; 3],
}

impl Frame {
    /// The frame of `x` and six times its signed volume (`None` if that is 0).
    #[inline]
    pub(super) fn of(x: &[DVec3; 4]) -> Option<(Self, f64)> {
        let (e1, e2, e3) = (x[1] - x[0], x[2] - x[0], x[3] - x[0]);
        let c1 = e2.cross(e3);
        let v = e1.dot(c1);
        if v == 0.0 || !v.is_finite() {
            return None;
        }
        let r = 1.0 / v;
        let c = [c1 * r, e3.cross(e1) * r, e1.cross(e2) * r];
        Some((Self { origin: x[0], c }, v))
    }

    /// Barycentric coordinates of `p`.
    #[inline]
    pub(super) fn barycentric(&self, p: DVec3) -> [f64; 4] {
        let d = p - self.origin;
        let l = [d.dot(self.c[0]), d.dot(self.c[1]), d.dot(self.c[2])];
        [1.0 - l[0] - l[1] - l[2], l[0], l[1], l[2]]
    }
}

/// Barycentric coordinates of `p` in the tetrahedron `x` (any orientation, not degenerate).
#[cfg(test)]
pub(super) fn barycentric(x: &[DVec3; 4], p: DVec3) -> [f64; 4] {
    Frame::of(x).map_or([0.25; 4], |(f, _)| f.barycentric(p))
}

/// The value at barycentric coordinates `b` of the linear interpolant of `f`. Coordinates outside
/// the tetrahedron are clamped to it first (negative ones set to 0, the rest rescaled), so a point
/// outside the mesh gets the value of the nearest place of its tetrahedron.
pub(super) fn interpolate(b: [f64; 4], f: [f64; 4]) -> f64 {
    if b.iter().all(|&c| c >= 0.0) {
        return (0..4).map(|k| b[k] * f[k]).sum();
    }
    let c = b.map(|c| c.max(0.0));
    let sum: f64 = c.iter().sum();
    (0..4).map(|k| c[k] * f[k]).sum::<f64>() / sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quadric_measures_squared_plane_distances() {
        let mut q = Quadric::of_plane(DVec3::ZERO, DVec3::X, DVec3::Y); // z = 0
        q.add(&Quadric::of_plane(DVec3::ZERO, DVec3::Y, DVec3::Z)); // x = 0
        let p = DVec3::new(2.0, 5.0, -3.0);
        assert!((q.eval(p) - (9.0 + 4.0)).abs() < 1e-12);
    }

    #[test]
    fn shape_measure_is_zero_for_equilateral_and_grows_when_flat() {
        let eq = [
            DVec3::ZERO,
            DVec3::X,
            DVec3::new(0.5, 3f64.sqrt() / 2.0, 0.0),
            DVec3::new(0.5, 3f64.sqrt() / 6.0, (2.0f64 / 3.0).sqrt()),
        ];
        assert!(shape_measure(&eq).abs() < 1e-9);
        let scaled = eq.map(|p| 7.0 * p + DVec3::splat(3.0));
        assert!(shape_measure(&scaled).abs() < 1e-9);
        let corner = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
        let mut flat = corner;
        flat[3].z = 1e-3;
        assert!(shape_measure(&corner) > 0.1);
        assert!(shape_measure(&flat) > 100.0 * shape_measure(&corner));
    }

    #[test]
    fn interpolation_is_linear_inside_and_clamped_outside() {
        let x = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
        let f = [1.0, 3.0, 5.0, 7.0]; // 1 + 2x + 4y + 6z
        let p = DVec3::new(0.2, 0.3, 0.1);
        let b = barycentric(&x, p);
        assert!((interpolate(b, f) - (1.0 + 0.4 + 1.2 + 0.6)).abs() < 1e-12);
        let outside = barycentric(&x, DVec3::new(-1.0, 0.0, 0.0));
        assert!((interpolate(outside, f) - 1.0).abs() < 1e-12);
    }
}
