//! Exact point–triangle geometry shared by the material distances and the isosurface bound: the
//! closest point on a triangle by Voronoi regions (Ericson, *Real-Time Collision Detection*, §5.1.5),
//! and triangles as [`rstar`] R-tree objects whose distance is that exact one.

use glam::DVec3;
use rstar::{PointDistance, RTree, RTreeObject, AABB};

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
/// the Voronoi regions of the vertices, then of the edges, then the face). Degenerate triangles are
/// handled as their longest side.
pub fn closest_point_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> (DVec3, Feature) {
    let ab = b - a;
    let ac = c - a;
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
    // Degenerate (collinear corners): the closest of the three sides.
    let corners = [a, b, c];
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

/// A triangle in an [`rstar::RTree`]: an id (its index in its mesh) and its corners; the tree's
/// distance is the exact point–triangle distance.
#[derive(Clone, Debug)]
pub struct Triangle {
    pub id: u32,
    pub corners: [DVec3; 3],
}

/// An R-tree of `triangles`, each with its index as id.
pub fn triangle_tree(triangles: impl Iterator<Item = [DVec3; 3]>) -> RTree<Triangle> {
    let triangles: Vec<Triangle> = triangles
        .enumerate()
        .map(|(id, corners)| Triangle {
            id: id as u32,
            corners,
        })
        .collect();
    RTree::bulk_load(triangles)
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
