//! One tetrahedron's patch of an interval volume, tetrahedralised by a rule that depends only on
//! global point names, so that the patches of face-adjacent tetrahedra conform (Weiss & De Floriani
//! §2.1, after Nielson and Sung's interval-volume tetrahedralisation, their [14]: a lexicographic
//! order of the vertices decides every diagonal).
//!
//! With the field linear on a tetrahedron `T`, the patch `P = T ∩ {α ≤ f ≤ β}` is a convex polytope.
//! Its vertices are the vertices of `T` whose value lies in `[α, β]` and the points where an edge of
//! `T` crosses `α` or `β` strictly between its ends; these are extreme points of `P` (each is an end of
//! the segment `P` cuts from an edge of `T`), so no three are collinear. Each is named globally by a
//! [`PointKey`]: a sample by its input index, an edge point by its edge's two input indices and the
//! level. Its facets lie in the four faces of `T` and in the planes `f = α` and `f = β`; which facet
//! holds which vertex is decided from the names and the values alone (exact comparisons of input
//! samples with `α` and `β`), never from coordinates.
//!
//! `P` is split by *pulling* from its smallest-named vertex `v₀`: one tetrahedron `(v₀, m, a, b)` per
//! facet `F` not holding `v₀` and edge `ab` of `F` not holding `m`, the smallest vertex of `F` (`F`
//! fanned from `m`). A pulling triangulation restricts to each facet as that facet's own pulling
//! triangulation, which depends only on the facet's vertices; a facet in a shared face of two
//! tetrahedra of a conforming mesh has the same vertices (same samples, same values, same names) on
//! both sides, so the two patches meet face to face. Every tetrahedron made this way has positive
//! volume (`v₀` is not in the plane of `F`, `m` not on the line of `ab`).

use arrayvec::ArrayVec;

/// The global name of a point of an interval volume: `(i, i, SAMPLE)` for input sample `i`, and
/// `(i, j, ALPHA | BETA)` with `i < j` for the point where the edge between samples `i` and `j`
/// crosses `α` or `β`. Tuples order lexicographically: the order the pulling rule uses.
pub type PointKey = (u32, u32, u8);

/// [`PointKey`] level of an input sample.
pub const SAMPLE: u8 = 0;
/// [`PointKey`] level of an edge point at `α`.
pub const ALPHA: u8 = 1;
/// [`PointKey`] level of an edge point at `β`.
pub const BETA: u8 = 2;

/// The least distance, as a fraction of its edge, between a new point and an end of its edge or the
/// other new point on it ([`edge_parameter`]).
pub(crate) const GAP: f64 = 1.0 / (1u64 << 31) as f64;

/// Where the point of `level` ([`ALPHA`] or [`BETA`]) lies on an edge its level crosses strictly,
/// as the fraction of the edge from the end of value `fa` to the end of value `fb`: where the field
/// interpolated along the edge holds the level, but at least [`GAP`] from either end and from the
/// edge's point of the other level. A sample a few rounding errors from a level (a sum of tenths
/// against `0.3`, a byte against `4 + 1 ulp`) would otherwise put the point within about `10⁻¹⁶`
/// of the edge's length from the sample, and the tetrahedra of the patches through it would be too
/// flat for a positive volume in floating point, though the names conform; moved, they keep a
/// thickness of about `GAP` of their size. The point moves at most `2 GAP` of its edge (within
/// `10⁻⁹` of the grid's diagonal, the verifiers' rounding); anywhere else it is bit for bit the
/// point marching tetrahedra places on the edge.
pub(crate) fn edge_parameter(fa: f64, fb: f64, [alpha, beta]: [f64; 2], level: u8) -> f64 {
    let t = |v: f64| (v - fa) / (fb - fa);
    let crosses = |v: f64| fa.min(fb) < v && v < fa.max(fb);
    if !(crosses(alpha) && crosses(beta)) {
        return t(if level == ALPHA { alpha } else { beta }).clamp(GAP, 1.0 - GAP);
    }
    // Both levels cross: the one met first from `fa` is α where the field rises.
    let alpha_first = fb > fa;
    let (first, second) = if alpha_first {
        (t(alpha), t(beta))
    } else {
        (t(beta), t(alpha))
    };
    let first = first.clamp(GAP, 1.0 - 2.0 * GAP);
    if (level == ALPHA) == alpha_first {
        first
    } else {
        second.clamp(first + GAP, 1.0 - GAP)
    }
}

/// Facet bits of a vertex: bit `c` (0..4) for the face of `T` opposite its vertex `c`, [`AT_ALPHA`]
/// and [`AT_BETA`] for the planes `f = α` and `f = β`.
type Facets = u8;
const AT_ALPHA: Facets = 1 << 4;
const AT_BETA: Facets = 1 << 5;

/// The six edges of a tetrahedron.
pub(crate) const EDGES: [(usize, usize); 6] = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];

/// The tetrahedra of `T ∩ {α ≤ f ≤ β}` for the tetrahedron with input samples `ids` and values `f`,
/// `range = [α, β]` (`α < β`), appended to `out` as point names (orientation not fixed). A
/// tetrahedron whose four values are equal is kept whole when its value is in the range; a patch of
/// zero volume (only touching `α` or `β`) makes nothing.
pub fn clip(ids: [u32; 4], f: [f64; 4], [alpha, beta]: [f64; 2], out: &mut Vec<[PointKey; 4]>) {
    let sample = |i: usize| (ids[i], ids[i], SAMPLE);
    if f.iter().all(|&v| v == f[0]) {
        if alpha <= f[0] && f[0] <= beta {
            out.push([0, 1, 2, 3].map(sample));
        }
        return;
    }
    let lo = f[0].min(f[1]).min(f[2].min(f[3]));
    let hi = f[0].max(f[1]).max(f[2].max(f[3]));
    if !(hi > alpha && lo < beta) {
        return;
    }
    // The vertices of P with their facets; at most 4 samples and 2 points on 4 of the edges.
    let mut vertices: ArrayVec<(PointKey, Facets), 16> = ArrayVec::new();
    let level_bits =
        |v: f64| (if v == alpha { AT_ALPHA } else { 0 }) | (if v == beta { AT_BETA } else { 0 });
    for (i, &v) in f.iter().enumerate() {
        if alpha <= v && v <= beta {
            vertices.push((sample(i), 0b1111 & !(1 << i) | level_bits(v)));
        }
    }
    for (i, j) in EDGES {
        let (a, b) = (f[i].min(f[j]), f[i].max(f[j]));
        for (level, v, bit) in [(ALPHA, alpha, AT_ALPHA), (BETA, beta, AT_BETA)] {
            if a < v && v < b {
                let key = (ids[i].min(ids[j]), ids[i].max(ids[j]), level);
                vertices.push((key, 0b1111 & !(1 << i) & !(1 << j) | bit));
            }
        }
    }
    // The facets as sets of vertices (bit k: vertex k), each once.
    let mut facets: ArrayVec<u16, 6> = ArrayVec::new();
    for bit in 0..6 {
        let members = (vertices.iter().enumerate())
            .filter(|(_, v)| v.1 & (1 << bit) != 0)
            .fold(0u16, |m, (k, _)| m | 1 << k);
        if members.count_ones() >= 3 && !facets.contains(&members) {
            facets.push(members);
        }
    }
    let smallest = |set: u16| {
        (0..vertices.len())
            .filter(|&k| set & (1 << k) != 0)
            .min_by_key(|&k| vertices[k].0)
            .expect("a non-empty set")
    };
    let v0 = smallest((1 << vertices.len()) - 1);
    for &face in facets.iter().filter(|&&face| face & (1 << v0) == 0) {
        let m = smallest(face);
        for &other in facets.iter().filter(|&&other| other != face) {
            let edge = face & other;
            if edge.count_ones() == 2 && edge & (1 << m) == 0 {
                let a = edge.trailing_zeros() as usize;
                let b = 15 - edge.leading_zeros() as usize;
                out.push([v0, m, a, b].map(|k| vertices[k].0));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// Positions of the names of a tetrahedron with corners `x` and values `f` (samples 0..4).
    fn position(x: &[DVec3; 4], f: &[f64; 4], range: [f64; 2], (i, j, level): PointKey) -> DVec3 {
        let (i, j) = (i as usize, j as usize);
        if level == SAMPLE {
            return x[i];
        }
        let v = range[level as usize - 1];
        x[i] + (v - f[i]) / (f[j] - f[i]) * (x[j] - x[i])
    }

    fn volume(p: [DVec3; 4]) -> f64 {
        (p[1] - p[0]).dot((p[2] - p[0]).cross(p[3] - p[0])) / 6.0
    }

    /// The volume of `{x ∈ T: f(x) ≥ v}` by the closed form of the distribution of a linear function
    /// on a simplex (values distinct), independent of [`clip`].
    fn volume_above(total: f64, f: [f64; 4], v: f64) -> f64 {
        let mut s = f;
        s.sort_by(f64::total_cmp);
        let [f0, f1, f2, f3] = s;
        let below = if v <= f0 {
            0.0
        } else if v <= f1 {
            (v - f0).powi(3) / ((f1 - f0) * (f2 - f0) * (f3 - f0))
        } else if v <= f2 {
            (v - f0).powi(3) / ((f1 - f0) * (f2 - f0) * (f3 - f0))
                - (v - f1).powi(3) / ((f1 - f0) * (f2 - f1) * (f3 - f1))
        } else if v <= f3 {
            1.0 - (f3 - v).powi(3) / ((f3 - f0) * (f3 - f1) * (f3 - f2))
        } else {
            1.0
        };
        total * (1.0 - below)
    }

    #[test]
    fn patches_have_positive_volumes_summing_to_the_closed_form() {
        let x = [
            DVec3::ZERO,
            DVec3::new(1.0, 0.1, 0.0),
            DVec3::new(0.2, 1.0, 0.1),
            DVec3::new(0.3, 0.2, 1.0),
        ];
        let total = volume(x);
        let mut rng = fastrand::Rng::with_seed(0x9e3779b97f4a7c15);
        for case in 0..20000 {
            let f = [0; 4].map(|_| rng.f64());
            let (a, b) = (rng.f64(), rng.f64());
            let range = [a.min(b), a.max(b)];
            let mut out = Vec::new();
            clip([0, 1, 2, 3], f, range, &mut out);
            let mut sum = 0.0;
            for t in &out {
                let mut names = t.to_vec();
                names.sort_unstable();
                names.dedup();
                assert_eq!(names.len(), 4, "case {case}: {f:?} {range:?}: {t:?}");
                let v = volume(t.map(|k| position(&x, &f, range, k))).abs();
                assert!(v > 0.0, "case {case}: {f:?} {range:?}: degenerate {t:?}");
                sum += v;
            }
            let want = volume_above(total, f, range[0]) - volume_above(total, f, range[1]);
            assert!(
                (sum - want).abs() <= 1e-9,
                "case {case}: {f:?} {range:?}: {sum} vs {want}"
            );
        }
    }

    #[test]
    fn samples_at_the_levels_and_constant_tetrahedra() {
        // Equal values and samples exactly at α or β: the patch is the part in the closed range.
        let mut out = Vec::new();
        clip([0, 1, 2, 3], [1.0; 4], [0.0, 1.0], &mut out);
        assert_eq!(out.len(), 1);
        out.clear();
        clip([0, 1, 2, 3], [1.0; 4], [1.5, 2.0], &mut out);
        assert!(out.is_empty());
        // Only touching α: nothing.
        clip([0, 1, 2, 3], [0.0, 0.0, 0.0, 1.0], [1.0, 2.0], &mut out);
        assert!(out.is_empty());
        // A face at α, the fourth vertex above β: a tetrahedron cut at β.
        clip([0, 1, 2, 3], [1.0, 1.0, 1.0, 3.0], [1.0, 2.0], &mut out);
        assert_eq!(out.len(), 3);
        // Every vertex at α or β: the tetrahedron itself.
        out.clear();
        clip([0, 1, 2, 3], [1.0, 2.0, 1.0, 2.0], [1.0, 2.0], &mut out);
        assert_eq!(out.len(), 1);
        let mut names = out[0].to_vec();
        names.sort_unstable();
        assert_eq!(names, [0, 1, 2, 3].map(|i| (i, i, SAMPLE)));
    }

    #[test]
    fn shared_faces_are_split_alike() {
        // Two tetrahedra sharing the face (1, 2, 3) with random values and names: the triangles of
        // their patches in that face are the same.
        let mut rng = fastrand::Rng::with_seed(12345);
        for case in 0..5000 {
            let f: [f64; 5] = [0; 5].map(|_| (rng.f64() * 8.0).floor() / 4.0);
            let range = [0.5, 1.25];
            let mut names: Vec<u32> = (0..5).collect();
            for k in (1..5).rev() {
                names.swap(k, (rng.f64() * (k + 1) as f64) as usize);
            }
            let shared: Vec<u32> = names[1..4].to_vec();
            let faces = |ids: [u32; 4], values: [f64; 4]| {
                let mut out = Vec::new();
                clip(ids, values, range, &mut out);
                let on_shared = |k: &PointKey| shared.contains(&k.0) && shared.contains(&k.1);
                let mut faces: Vec<[PointKey; 3]> = Vec::new();
                for t in out {
                    for skip in 0..4 {
                        let mut face: Vec<PointKey> =
                            (0..4).filter(|&i| i != skip).map(|i| t[i]).collect();
                        if face.iter().all(on_shared) {
                            face.sort_unstable();
                            faces.push([face[0], face[1], face[2]]);
                        }
                    }
                }
                faces.sort_unstable();
                faces
            };
            let a = faces(
                [names[0], names[1], names[2], names[3]],
                [f[0], f[1], f[2], f[3]],
            );
            let b = faces(
                [names[4], names[1], names[2], names[3]],
                [f[4], f[1], f[2], f[3]],
            );
            // A shared face at α or β may bound the patch on one side only.
            let level = |v: f64| f[1..4].iter().all(|&x| x == v);
            if !level(range[0]) && !level(range[1]) {
                assert_eq!(a, b, "case {case}: values {f:?}, names {names:?}");
            }
        }
    }
}
