//! Exact point–triangle geometry shared by the material distances and the isosurface bound: the
//! closest point on a triangle by Voronoi regions (Ericson, *Real-Time Collision Detection*, §5.1.5),
//! and triangles as [`rstar`] R-tree objects whose distance is that exact one; points merged when
//! they coincide up to rounding ([`NearPoints`]).

use glam::{DVec2, DVec3};
use rstar::{PointDistance, RTree, RTreeObject, AABB};
use rustc_hash::FxHashMap;
use std::hash::Hash;

/// Points closer than this fraction of their set's bounding diagonal are one point: the same
/// position reached by different computations (a polygon vertex through an edge and through a face
/// of the tetrahedron) differs by a few ulps.
pub const COINCIDENT: f64 = 1e-12;

/// Merges points that coincide up to `q` (in every coordinate) and share a tag: a hash grid of
/// cell size `q`, each point looked for in the 27 cells around its own.
pub struct NearPoints<T> {
    q: f64,
    /// Per cell and tag: the points in it, with their ids.
    cells: FxHashMap<Cell<T>, Vec<(DVec3, u32)>>,
}

type Cell<T> = ([i64; 3], T);

impl<T: Copy + Eq + Hash> NearPoints<T> {
    /// For points within `bounds` (`[xmin, xmax, ymin, …]`): `q` is [`COINCIDENT`] of its diagonal.
    pub fn within(bounds: &[f64; 6]) -> Self {
        let q = COINCIDENT * crate::volume::bounds_diagonal(bounds);
        Self {
            q: if q.is_finite() && q > 0.0 { q } else { 1.0 },
            cells: FxHashMap::default(),
        }
    }

    /// The id of a point with `tag` within `q` of `p` merged before, or else `id` (remembered).
    pub fn merge(&mut self, p: DVec3, tag: T, id: u32) -> u32 {
        let cell = (p / self.q).floor().as_i64vec3().to_array();
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let near = [cell[0] + dx, cell[1] + dy, cell[2] + dz];
                    if let Some(points) = self.cells.get(&(near, tag)) {
                        if let Some(&(_, found)) = points
                            .iter()
                            .find(|(x, _)| (*x - p).abs().max_element() <= self.q)
                        {
                            return found;
                        }
                    }
                }
            }
        }
        self.cells.entry((cell, tag)).or_default().push((p, id));
        id
    }
}

/// The bounding box `[xmin, xmax, ymin, …]` of `points` (minima above maxima when there are none).
pub fn bounds_of<'a>(points: impl IntoIterator<Item = &'a [f64; 3]>) -> [f64; 6] {
    let mut b = [f64::INFINITY, f64::NEG_INFINITY].repeat(3);
    for p in points {
        for a in 0..3 {
            b[2 * a] = b[2 * a].min(p[a]);
            b[2 * a + 1] = b[2 * a + 1].max(p[a]);
        }
    }
    b.try_into().expect("six bounds")
}

/// Which part of a triangle holds a closest point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Feature {
    /// Corner 0, 1 or 2.
    Vertex(usize),
    /// Edge `e` joins corners `e` and `(e + 1) % 3`.
    Edge(usize),
    Face,
}

/// The point of triangle `abc` closest to `p`, and the feature it lies on (Ericson 2005, §5.1.5:
/// the Voronoi regions of the vertices, then of the edges, then the face). Needles, thinner than
/// 10⁻⁴ of their longest side, and collinear corners go to [`closest_point_on_needle`]: the region
/// tests subtract products of dot products of nearly parallel sides and lose about
/// `ε L² / width` (4·10⁻⁸ on a needle 2⁻³¹ of its length wide, against 2·10⁻¹⁰ exactly).
pub fn closest_point_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> (DVec3, Feature) {
    let ab = b - a;
    let ac = c - a;
    let longest2 = ab
        .length_squared()
        .max(ac.length_squared())
        .max((c - b).length_squared());
    if ab.cross(ac).length_squared() < 1e-8 * longest2 * longest2 {
        return closest_point_on_needle(p, [a, b, c]);
    }
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, Feature::Vertex(0));
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (b, Feature::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 && d1 - d3 > 0.0 {
        let v = d1 / (d1 - d3);
        return (a + v * ab, Feature::Edge(0));
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (c, Feature::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 && d2 - d6 > 0.0 {
        let w = d2 / (d2 - d6);
        return (a + w * ac, Feature::Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    let (e, f) = (d4 - d3, d5 - d6);
    if va <= 0.0 && e >= 0.0 && f >= 0.0 && e + f > 0.0 {
        let w = e / (e + f);
        return (b + w * (c - b), Feature::Edge(1));
    }
    let sum = va + vb + vc;
    if sum > 0.0 && sum.is_finite() {
        let v = vb / sum;
        let w = vc / sum;
        return (a + ab * v + ac * w, Feature::Face);
    }
    closest_side(p, [a, b, c])
}

/// [`closest_point_on_triangle`] for a needle or collinear corners: in the orthonormal frame of its
/// longest side (`e1`) and of the rest of the third corner orthogonal to it (`e2`, orthogonalised
/// twice), the projection of `p` is off by about `ε |p − u|` along `e1` and `e2` only, so the
/// test that it falls inside holds to that; there the closest point is the projection; elsewhere
/// it is on a side, found in 3D.
fn closest_point_on_needle(p: DVec3, corners: [DVec3; 3]) -> (DVec3, Feature) {
    let side = |e: usize| (corners[e], corners[(e + 1) % 3]);
    let longest = (0..3)
        .max_by(|&i, &j| {
            let (length, other) = (side(i), side(j));
            (length.0.distance_squared(length.1)).total_cmp(&other.0.distance_squared(other.1))
        })
        .expect("three sides");
    let (u, v) = side(longest);
    let q = corners[(longest + 2) % 3] - u;
    let e1 = (v - u).normalize_or_zero();
    let mut w = q - q.dot(e1) * e1;
    w -= w.dot(e1) * e1;
    let e2 = w.normalize_or_zero();
    if e1 != DVec3::ZERO && e2 != DVec3::ZERO {
        let plane = |x: DVec3| DVec2::new(x.dot(e1), x.dot(e2));
        let (pu, vu, qu) = (plane(p - u), plane(v - u), plane(q));
        // Strictly left of each side of the counter-clockwise triangle (0, vu, qu): inside.
        let left = |a: DVec2, b: DVec2| (b - a).perp_dot(pu - a) > 0.0;
        if left(DVec2::ZERO, vu) && left(vu, qu) && left(qu, DVec2::ZERO) {
            return (u + pu.x * e1 + pu.y * e2, Feature::Face);
        }
    }
    closest_side(p, corners)
}

/// The point of the sides of the triangle with `corners` closest to `p`, and its feature.
fn closest_side(p: DVec3, corners: [DVec3; 3]) -> (DVec3, Feature) {
    (0..3)
        .map(|e| {
            let (s, t) = (corners[e], corners[(e + 1) % 3]);
            let d = t - s;
            let len2 = d.length_squared();
            let u = if len2 > 0.0 {
                ((p - s).dot(d) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let feature = if u == 0.0 {
                Feature::Vertex(e)
            } else if u == 1.0 {
                Feature::Vertex((e + 1) % 3)
            } else {
                Feature::Edge(e)
            };
            (s + u * d, feature)
        })
        .min_by(|x, y| x.0.distance_squared(p).total_cmp(&y.0.distance_squared(p)))
        .expect("three sides")
}

/// The exact distance from `p` to the triangle `abc` (its closest point, [`closest_point_on_triangle`]).
#[inline]
pub fn point_triangle_distance(p: DVec3, [a, b, c]: [DVec3; 3]) -> f64 {
    closest_point_on_triangle(p, a, b, c).0.distance(p)
}

/// Is the triangle `t` of positive area (its corners not collinear)?
pub fn has_area(t: &[DVec3; 3]) -> bool {
    (t[1] - t[0]).cross(t[2] - t[0]) != DVec3::ZERO
}

/// A triangle as its corners' bits, sorted ([`triangle_key`]).
pub(crate) type TriangleKey = [[u64; 3]; 3];

/// The key of a triangle: the same for the same three points in any order, bit for bit.
pub(crate) fn triangle_key(t: &[[f64; 3]; 3]) -> TriangleKey {
    let mut k = t.map(|p| p.map(f64::to_bits));
    k.sort_unstable();
    k
}

/// A triangle in an [`rstar::RTree`]: an id (its index in its mesh) and its corners; the tree's
/// distance is the exact point–triangle distance.
#[derive(Clone, Debug)]
pub struct Triangle {
    pub id: u32,
    pub corners: [DVec3; 3],
}

/// Node sizes of the triangle R-trees: up to 24 children (rstar's default is 6). Nearest-triangle
/// and within-distance queries walk fewer levels: the Material Interface signed distances (§5.2.1)
/// took 5-7 % less CPU on the 197×233×189 tissue case, the isosurface bound's checks 3-8 % less on
/// bonsai, with the same results.
pub struct TriangleParams;

impl rstar::RTreeParams for TriangleParams {
    const MIN_SIZE: usize = 8;
    const MAX_SIZE: usize = 24;
    const REINSERTION_COUNT: usize = 8;
    type DefaultInsertionStrategy = rstar::RStarInsertionStrategy;
}

/// An R-tree of triangles.
pub type TriangleTree = RTree<Triangle, TriangleParams>;

/// An R-tree of `triangles`, each with its index as id.
pub fn triangle_tree(triangles: impl Iterator<Item = [DVec3; 3]>) -> TriangleTree {
    let triangles: Vec<Triangle> = triangles
        .enumerate()
        .map(|(id, corners)| Triangle {
            id: id as u32,
            corners,
        })
        .collect();
    RTree::bulk_load_with_params(triangles)
}

impl RTreeObject for Triangle {
    type Envelope = AABB<[f64; 3]>;

    fn envelope(&self) -> Self::Envelope {
        let [a, b, c] = self.corners;
        AABB::from_corners(a.min(b).min(c).to_array(), a.max(b).max(c).to_array())
    }
}

impl PointDistance for Triangle {
    fn distance_2(&self, point: &[f64; 3]) -> f64 {
        let p = DVec3::from_array(*point);
        let [a, b, c] = self.corners;
        closest_point_on_triangle(p, a, b, c).0.distance_squared(p)
    }
}

/// Points of the triangle with `corners` spaced at most `spacing` apart (> 0): its corners and the
/// nodes of its subdivision into `n²` triangles similar to it, `n` = ⌈longest edge / spacing⌉.
/// Every point of the triangle lies within `spacing / √3` of one of them (a triangle's points lie
/// within its longest edge over √3 of a corner).
pub fn triangle_samples(corners: [DVec3; 3], spacing: f64) -> impl Iterator<Item = DVec3> {
    let [a, b, c] = corners;
    let longest = a.distance(b).max(b.distance(c)).max(c.distance(a));
    let n = (longest / spacing).ceil().max(1.0) as usize;
    (0..=n).flat_map(move |i| {
        (0..=n - i).map(move |j| {
            let (s, t) = (i as f64 / n as f64, j as f64 / n as f64);
            a + s * (b - a) + t * (c - a)
        })
    })
}

/// The `n²` triangles of the subdivision whose nodes [`triangle_samples`] lists (`count` of them),
/// as indices into that list, each with the orientation of the whole triangle.
pub fn sample_triangles(count: usize) -> impl Iterator<Item = [usize; 3]> {
    // count = (n + 1)(n + 2) / 2; row i holds n + 1 − i nodes.
    let n = (((8 * count + 1) as f64).sqrt().round() as usize - 3) / 2;
    let node = move |i: usize, j: usize| i * (n + 1) - i * i.saturating_sub(1) / 2 + j;
    (0..n).flat_map(move |i| {
        (0..n - i).flat_map(move |j| {
            let up = [node(i, j), node(i + 1, j), node(i, j + 1)];
            let down =
                (i + j + 2 <= n).then(|| [node(i + 1, j), node(i + 1, j + 1), node(i, j + 1)]);
            std::iter::once(up).chain(down)
        })
    })
}

/// The sign of the exact orientation of `d` against the plane through `a`, `b`, `c` (Shewchuk's
/// adaptive predicate, [`robust::orient3d`]): positive if `d` lies below it (`a`, `b`, `c`
/// counter-clockwise seen from above), negative above, 0 exactly when the four are coplanar.
pub fn orient3d(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    let c3 = |p: DVec3| robust::Coord3D {
        x: p.x,
        y: p.y,
        z: p.z,
    };
    robust::orient3d(c3(a), c3(b), c3(c), c3(d))
}

/// The sign of the exact orientation of the triangle `abc` projected along the axis `axis` (0, 1
/// or 2) onto the other two, in cyclic order ([`robust::orient2d`]): positive counter-clockwise,
/// 0 exactly when the projections are collinear. For coplanar points the projection along an axis
/// not parallel to their plane is an affine bijection, so these signs are the in-plane
/// orientations, all with one sense.
pub fn orient2d_along(axis: usize, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
    let c2 = |p: DVec3| robust::Coord { x: p[u], y: p[w] };
    robust::orient2d(c2(a), c2(b), c2(c))
}

/// Do the triangles `s` and `t`, two faces of one triangulated surface, meet other than in the
/// corners they share (given by index: corners with equal ids are the same point)? Sharing an edge,
/// they do when they lie in one plane on the same side of it (folded onto each other); sharing a
/// corner or nothing, when an edge of one not through a shared corner meets the other (the segment
/// where two triangles meet ends on such edges: Möller's test by edges, closed, in the plane for
/// coplanar pairs). Distances below `1e-9` of the longer triangle's longest edge count as 0.
pub fn triangles_meet(s: ([u32; 3], [DVec3; 3]), t: ([u32; 3], [DVec3; 3])) -> bool {
    let longest = |x: &[DVec3; 3]| {
        x[0].distance(x[1])
            .max(x[1].distance(x[2]))
            .max(x[2].distance(x[0]))
    };
    let eps = 1e-9 * longest(&s.1).max(longest(&t.1));
    // The shared corners as pairs of slots (no allocation: this runs for every candidate face).
    let mut shared = [(0usize, 0usize); 3];
    let mut count = 0;
    for a in 0..3 {
        for b in 0..3 {
            if s.0[a] == t.0[b] && count < 3 {
                shared[count] = (a, b);
                count += 1;
            }
        }
    }
    let shared = &shared[..count];
    match count {
        3 => true,
        2 => {
            // The corners not on the shared edge: folded if `t`'s lies in `s`'s plane on `c`'s side.
            let c = (0..3).find(|&a| shared.iter().all(|p| p.0 != a)).unwrap();
            let d = (0..3).find(|&b| shared.iter().all(|p| p.1 != b)).unwrap();
            let (a, b) = (s.1[shared[0].0], s.1[shared[1].0]);
            let (pc, pd) = (s.1[c], t.1[d]);
            let n = (b - a).cross(pc - a);
            let n_len = n.length();
            n_len > 0.0
                && ((pd - a).dot(n) / n_len).abs() <= eps
                && n.dot((b - a).cross(pd - a)) > 0.0
        }
        _ => {
            // The edges of `x` not through its shared corner `mine` (at most one) against `y`.
            let edges_hit = |x: &[DVec3; 3], mine: Option<usize>, y: [DVec3; 3]| {
                (0..3).any(|e| {
                    let (a, b) = (e, (e + 1) % 3);
                    mine != Some(a) && mine != Some(b) && segment_meets_triangle(x[a], x[b], y, eps)
                })
            };
            let first = shared.first();
            edges_hit(&s.1, first.map(|p| p.0), t.1) || edges_hit(&t.1, first.map(|p| p.1), s.1)
        }
    }
}

/// Does the segment `pq` meet the closed triangle `x` (distances below `eps` counting as 0)?
fn segment_meets_triangle(p: DVec3, q: DVec3, x: [DVec3; 3], eps: f64) -> bool {
    let n = (x[1] - x[0]).cross(x[2] - x[0]);
    let n_len = n.length();
    if n_len == 0.0 {
        return false;
    }
    let n = n / n_len;
    let (dp, dq) = ((p - x[0]).dot(n), (q - x[0]).dot(n));
    if (dp > eps && dq > eps) || (dp < -eps && dq < -eps) {
        return false;
    }
    // Project onto the plane's dominant axes; the triangle counter-clockwise there.
    let axis = n.abs().max_position();
    let flat = |v: DVec3| {
        let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
        glam::DVec2::new(v[u], v[w])
    };
    let mut t = x.map(flat);
    let cross = |o: glam::DVec2, a: glam::DVec2, b: glam::DVec2| (a - o).perp_dot(b - o);
    if cross(t[0], t[1], t[2]) < 0.0 {
        t.swap(1, 2);
    }
    // Distances in the plane: the projection shrinks lengths by at most √3.
    let inside = |v: glam::DVec2| {
        (0..3).all(|e| {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            cross(a, b, v) >= -eps * a.distance(b)
        })
    };
    if dp.abs() > eps || dq.abs() > eps {
        // Crossing the plane (or touching it at one end): test the crossing point.
        let at = if dp.abs() <= eps {
            p
        } else if dq.abs() <= eps {
            q
        } else {
            p + (q - p) * (dp / (dp - dq))
        };
        return inside(flat(at));
    }
    // In the plane: an end inside, or the segment crossing an edge.
    let (a2, b2) = (flat(p), flat(q));
    if inside(a2) || inside(b2) {
        return true;
    }
    (0..3).any(|e| {
        let (c, d) = (t[e], t[(e + 1) % 3]);
        let (o1, o2) = (cross(a2, b2, c), cross(a2, b2, d));
        if o1 == 0.0 && o2 == 0.0 {
            // Collinear (edges along one line, as on a box's edges): do their extents overlap?
            let along = |v: glam::DVec2| v.dot(b2 - a2);
            let (lo, hi) = (along(a2).min(along(b2)), along(a2).max(along(b2)));
            return along(c).max(along(d)) >= lo && along(c).min(along(d)) <= hi;
        }
        let (o3, o4) = (cross(c, d, a2), cross(c, d, b2));
        o1 * o2 <= 0.0 && o3 * o4 <= 0.0
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri(ids: [u32; 3], x: [[f64; 3]; 3]) -> ([u32; 3], [DVec3; 3]) {
        (ids, x.map(DVec3::from_array))
    }

    #[test]
    fn sample_triangles_tile_the_triangle_with_small_similar_ones() {
        let t = [
            DVec3::new(0.3, -1.0, 2.0),
            DVec3::new(4.1, 0.5, 1.0),
            DVec3::new(-0.7, 2.2, 0.4),
        ];
        let area = |t: [DVec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]);
        for spacing in [10.0, 2.0, 0.9, 0.31] {
            let samples: Vec<DVec3> = triangle_samples(t, spacing).collect();
            let parts: Vec<[usize; 3]> = sample_triangles(samples.len()).collect();
            let n = (samples.len() as f64 * 2.0).sqrt().floor() as usize - 1;
            assert_eq!(parts.len(), n * n, "{spacing}");
            let mut sum = DVec3::ZERO;
            for p in &parts {
                let p = p.map(|i| samples[i]);
                assert!((0..3).all(|i| p[i].distance(p[(i + 1) % 3]) <= spacing + 1e-12));
                // Same orientation: the normals add up to the whole's.
                assert!(area(p).dot(area(t)) > 0.0);
                sum += area(p);
            }
            assert!(
                (sum - area(t)).length() < 1e-9 * area(t).length(),
                "{spacing}"
            );
            // Every node is a corner of a part.
            let mut used = vec![false; samples.len()];
            parts.iter().flatten().for_each(|&i| used[i] = true);
            assert!(used.into_iter().all(|u| u));
        }
    }

    #[test]
    fn triangles_meet_beyond_shared_corners_only_when_they_cross_or_fold() {
        let base = tri([0, 1, 2], [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        // Disjoint, crossing, touching at a corner of one.
        let above = tri(
            [3, 4, 5],
            [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]],
        );
        assert!(!triangles_meet(base, above));
        let crossing = tri(
            [3, 4, 5],
            [[0.2, 0.2, -1.0], [0.2, 0.2, 1.0], [0.3, 0.1, 1.0]],
        );
        assert!(triangles_meet(base, crossing));
        assert!(triangles_meet(crossing, base));
        // Coplanar: overlapping or apart.
        let overlapping = tri(
            [3, 4, 5],
            [[0.2, 0.2, 0.0], [2.0, 0.2, 0.0], [0.2, 2.0, 0.0]],
        );
        assert!(triangles_meet(base, overlapping));
        let apart = tri(
            [3, 4, 5],
            [[2.0, 2.0, 0.0], [3.0, 2.0, 0.0], [2.0, 3.0, 0.0]],
        );
        assert!(!triangles_meet(base, apart));
        // An edge along the line of the other's edge (two sides of a box along its edge): apart,
        // or overlapping.
        let along = tri(
            [3, 4, 5],
            [[2.0, 0.0, 0.0], [3.0, 0.0, 0.0], [3.0, 0.0, 1.0]],
        );
        assert!(!triangles_meet(base, along));
        assert!(!triangles_meet(along, base));
        let overlapping_along = tri(
            [3, 4, 5],
            [[0.5, 0.0, 0.0], [3.0, 0.0, 0.0], [3.0, 0.0, 1.0]],
        );
        assert!(triangles_meet(base, overlapping_along));
        assert!(triangles_meet(overlapping_along, base));
        // Sharing corner 0: apart, or the other's far edge crossing the first.
        let fan = tri([0, 4, 5], [[0.0; 3], [0.0, 0.0, 1.0], [-1.0, 0.0, 1.0]]);
        assert!(!triangles_meet(base, fan));
        let through = tri([0, 4, 5], [[0.0; 3], [0.3, 0.3, 1.0], [0.3, 0.3, -1.0]]);
        assert!(triangles_meet(base, through));
        // Sharing the edge 0–1: a hinge, or folded onto the first in its plane.
        let hinge = tri([0, 1, 5], [[0.0; 3], [1.0, 0.0, 0.0], [0.5, 0.0, 1.0]]);
        assert!(!triangles_meet(base, hinge));
        let unfolded = tri([0, 1, 5], [[0.0; 3], [1.0, 0.0, 0.0], [0.5, -1.0, 0.0]]);
        assert!(!triangles_meet(base, unfolded));
        let folded = tri([1, 0, 5], [[1.0, 0.0, 0.0], [0.0; 3], [0.5, 0.3, 0.0]]);
        assert!(triangles_meet(base, folded));
    }

    #[test]
    fn distances_to_needles_are_exact() {
        // Needles (0, 0, 0), (1, 0, 0), (1/2, w, 0), turned and moved at random: a point above the
        // needle (0.1 < x < 0.9, w/100 < y < w/10) is |z| from it, on the face; one beside its
        // long base side (−w/10 < y < −w/100) is √(y² + z²) from it, on that side. Ericson's
        // region tests alone were off by up to about 10⁻¹⁶ / w. (Whether the closest point is on
        // the face or on a side is decided within about `ε |z| / w` of the needle's sides: checked
        // where that is below w/100.)
        let mut rng = fastrand::Rng::with_seed(31);
        for w in [1e-3, 1e-6, 2f64.powi(-31), 1e-12, 1e-15] {
            for _ in 0..2000 {
                let axis = DVec3::new(rng.f64() - 0.5, rng.f64() - 0.5, rng.f64() - 0.5);
                let turn = glam::DQuat::from_axis_angle(axis.normalize(), 6.0 * rng.f64());
                let shift = DVec3::new(rng.f64(), rng.f64(), rng.f64()) * 10.0;
                let place = |x: DVec3| turn * x + shift;
                let [a, b, c] = [DVec3::ZERO, DVec3::X, DVec3::new(0.5, w, 0.0)].map(place);
                let (x, z) = (0.1 + 0.8 * rng.f64(), (rng.f64() - 0.5) * 1e-3);
                let y = (0.01 + 0.09 * rng.f64()) * w * if rng.bool() { 1.0 } else { -1.0 };
                let (q, feature) = closest_point_on_triangle(place(DVec3::new(x, y, z)), a, b, c);
                let d = q.distance(place(DVec3::new(x, y, z)));
                let want = if y > 0.0 { z.abs() } else { y.hypot(z) };
                assert!(
                    (d - want).abs() < 1e-14,
                    "w {w}: {d} vs {want} at {x} {y} {z}"
                );
                if y > 0.0 && w >= 1e-6 {
                    assert_eq!(feature, Feature::Face, "w {w} at {x} {y} {z}");
                }
            }
        }
    }
}
