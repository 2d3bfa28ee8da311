//! Closest points on interface meshes, with the side of the query point (Gregorski et al. 2002, §5.2.1:
//! the signed distance from a vertex to an interface mesh, positive where the normal at the closest
//! point points toward the vertex).
//!
//! Each mesh gets an R-tree of its triangles ([`rstar`]); a query is a nearest-neighbour search with
//! the exact point–triangle distance ([`crate::geometry::closest_point_on_triangle`]). The side is
//! decided by the normal of the *feature* that holds the closest point: the face normal inside a
//! triangle, the sum of the unit normals of the faces sharing an edge on an edge, and the
//! angle-weighted pseudo-normal (Bærentzen & Aanæs 2005) at a vertex.
//! These pseudo-normals give the correct side for every point off a closed, consistently oriented mesh,
//! also when the closest point is an edge or a vertex, where the face normals of the incident triangles
//! may disagree. Vertices with identical coordinates are welded for this adjacency, so triangle soups
//! work too.

use super::InterfaceMesh;
use crate::geometry::{closest_point_on_triangle, triangle_tree, Feature, Triangle, TriangleTree};
use glam::DVec3;
use rayon::prelude::*;
use rustc_hash::FxHashMap;

/// The closest point of one interface mesh to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Closest {
    /// Euclidean distance (≥ 0).
    pub distance: f64,
    /// The closest point on the mesh.
    pub point: [f64; 3],
    /// +1 when the query point lies on the side the mesh normal points to, −1 on the other side, 0 on the mesh.
    pub side: f64,
}

/// One spatial index per interface mesh.
///
/// Built once, then queried concurrently (it is `Send + Sync`).
pub struct InterfaceIndex {
    meshes: Vec<MeshIndex>,
}

/// The R-tree of one mesh and the normals of its features.
struct MeshIndex {
    tree: TriangleTree,
    /// Per triangle: unit face normal (zero for a degenerate triangle).
    face_normal: Vec<DVec3>,
    /// Per triangle: the pseudo-normals of its edges 0→1, 1→2, 2→0.
    edge_normal: Vec<[DVec3; 3]>,
    /// Per triangle: the pseudo-normals of its three vertices.
    vertex_normal: Vec<[DVec3; 3]>,
}

impl MeshIndex {
    fn new(mesh: &InterfaceMesh) -> Self {
        let points: Vec<DVec3> = mesh.points.iter().map(|&p| DVec3::from_array(p)).collect();
        // Weld identical coordinates (−0 and +0 alike).
        let mut welded_id = FxHashMap::default();
        let weld: Vec<u32> = points
            .iter()
            .map(|p| {
                let key = (*p + DVec3::ZERO).to_array().map(f64::to_bits);
                let next = welded_id.len() as u32;
                *welded_id.entry(key).or_insert(next)
            })
            .collect();
        let welded = welded_id.len();
        let corners = |t: &[u32; 3]| t.map(|v| points[v as usize]);

        let face_normal: Vec<DVec3> = mesh
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = corners(t);
                (b - a).cross(c - a).normalize_or_zero()
            })
            .collect();

        // Vertices: Σ angle × unit face normal. Edges: Σ unit face normals.
        let mut vertex_sum = vec![DVec3::ZERO; welded];
        let mut edge_sum: FxHashMap<(u32, u32), DVec3> = FxHashMap::default();
        for (t, n) in mesh.triangles.iter().zip(&face_normal) {
            let c = corners(t);
            let w = t.map(|v| weld[v as usize]);
            for i in 0..3 {
                let (u, v) = (c[(i + 1) % 3] - c[i], c[(i + 2) % 3] - c[i]);
                let angle = u.cross(v).length().atan2(u.dot(v));
                vertex_sum[w[i] as usize] += angle * *n;
                let (s, e) = (w[i], w[(i + 1) % 3]);
                *edge_sum.entry((s.min(e), s.max(e))).or_default() += *n;
            }
        }
        let mut edge_normal = Vec::with_capacity(mesh.triangles.len());
        let mut vertex_normal = Vec::with_capacity(mesh.triangles.len());
        for t in &mesh.triangles {
            let w = t.map(|v| weld[v as usize]);
            edge_normal.push(std::array::from_fn(|i| {
                let (s, e) = (w[i], w[(i + 1) % 3]);
                edge_sum[&(s.min(e), s.max(e))]
            }));
            vertex_normal.push(w.map(|v| vertex_sum[v as usize]));
        }

        Self {
            tree: triangle_tree(mesh.triangles.iter().map(corners)),
            face_normal,
            edge_normal,
            vertex_normal,
        }
    }

    /// The pseudo-normal of `feature` of triangle `id` (not normalised).
    fn normal(&self, id: u32, feature: Feature) -> DVec3 {
        let id = id as usize;
        match feature {
            Feature::Face => self.face_normal[id],
            Feature::Edge(e) => self.edge_normal[id][e],
            Feature::Vertex(v) => self.vertex_normal[id][v],
        }
    }

    /// `(p − closest) · n̂` for the feature of `triangle` closest to `p`, with the closest point.
    fn side_measure(&self, triangle: &Triangle, p: DVec3) -> (f64, DVec3) {
        let [a, b, c] = triangle.corners;
        let (q, feature) = closest_point_on_triangle(p, a, b, c);
        let n = self.normal(triangle.id, feature).normalize_or_zero();
        ((p - q).dot(n), q)
    }

    fn closest(&self, p: [f64; 3]) -> Option<Closest> {
        let nearest = self.tree.nearest_neighbor(&p)?;
        let p = DVec3::from_array(p);
        let (mut measure, q) = self.side_measure(nearest, p);
        let d2 = q.distance_squared(p);
        if d2 == 0.0 {
            return Some(Closest {
                distance: 0.0,
                point: q.to_array(),
                side: 0.0,
            });
        }
        if measure.abs() <= 1e-9 * d2.sqrt() {
            // A degenerate feature normal (zero-area triangles, or p in the plane of a tie): ask the
            // other triangles at the same distance and trust the clearest answer.
            for t in self
                .tree
                .locate_within_distance(p.to_array(), d2 * (1.0 + 1e-9))
            {
                let (m, _) = self.side_measure(t, p);
                if m.abs() > measure.abs() {
                    measure = m;
                }
            }
        }
        let side = if measure > 0.0 {
            1.0
        } else if measure < 0.0 {
            -1.0
        } else {
            0.0
        };
        Some(Closest {
            distance: d2.sqrt(),
            point: q.to_array(),
            side,
        })
    }
}

impl InterfaceIndex {
    /// Indexes `meshes` (their order is kept).
    pub fn new(meshes: &[InterfaceMesh]) -> Self {
        Self {
            meshes: meshes.par_iter().map(MeshIndex::new).collect(),
        }
    }

    /// The closest point of mesh `mesh` to `p`; `None` when that mesh has no triangles (or there is no
    /// mesh `mesh`). `side` is 0 only on the mesh (or where every candidate normal is degenerate).
    pub fn closest(&self, mesh: usize, p: [f64; 3]) -> Option<Closest> {
        self.meshes.get(mesh)?.closest(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point with coordinates uniform in `[lo, hi)`.
    fn point(rng: &mut fastrand::Rng, lo: f64, hi: f64) -> [f64; 3] {
        [0; 3].map(|_| lo + (hi - lo) * rng.f64())
    }

    /// A closed, outward-oriented, star-shaped bumpy sphere (UV sphere with radius `r(θ, φ)`).
    fn bumpy_sphere(bump: f64) -> InterfaceMesh {
        let (nt, np) = (18usize, 32usize);
        let mut points = vec![[0.0, 0.0, 1.0]];
        for i in 1..nt {
            let theta = std::f64::consts::PI * i as f64 / nt as f64;
            for j in 0..np {
                let phi = 2.0 * std::f64::consts::PI * j as f64 / np as f64;
                let r = 1.0 + bump * (3.0 * theta).sin() * (4.0 * phi).cos();
                points.push([
                    r * theta.sin() * phi.cos(),
                    r * theta.sin() * phi.sin(),
                    r * theta.cos(),
                ]);
            }
        }
        points.push([0.0, 0.0, -1.0]);
        let south = points.len() as u32 - 1;
        let ring = |i: usize, j: usize| (1 + (i - 1) * np + j % np) as u32;
        let mut triangles = Vec::new();
        for j in 0..np {
            triangles.push([0, ring(1, j), ring(1, j + 1)]);
            triangles.push([south, ring(nt - 1, j + 1), ring(nt - 1, j)]);
        }
        for i in 1..nt - 1 {
            for j in 0..np {
                let (a, b, c, d) = (
                    ring(i, j),
                    ring(i + 1, j),
                    ring(i + 1, j + 1),
                    ring(i, j + 1),
                );
                triangles.push([a, b, c]);
                triangles.push([a, c, d]);
            }
        }
        InterfaceMesh {
            pair: (0, 1),
            points,
            triangles,
        }
    }

    /// The unit cube `[0, 1]³` as a triangle soup (no shared points), normals outward.
    fn cube_soup() -> InterfaceMesh {
        let mut points = Vec::new();
        let mut triangles = Vec::new();
        for axis in 0..3 {
            for side in 0..2 {
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                let corner = |a: f64, b: f64| {
                    let mut p = [0.0; 3];
                    p[axis] = side as f64;
                    p[u] = a;
                    p[v] = b;
                    p
                };
                let base = points.len() as u32;
                points.extend([
                    corner(0.0, 0.0),
                    corner(1.0, 0.0),
                    corner(1.0, 1.0),
                    corner(0.0, 1.0),
                ]);
                // (u, v, axis) is right-handed: counter-clockwise in (u, v) points along +axis.
                if side == 1 {
                    triangles.push([base, base + 1, base + 2]);
                    triangles.push([base, base + 2, base + 3]);
                } else {
                    triangles.push([base, base + 2, base + 1]);
                    triangles.push([base, base + 3, base + 2]);
                }
            }
        }
        InterfaceMesh {
            pair: (0, 1),
            points,
            triangles,
        }
    }

    fn corners(mesh: &InterfaceMesh, t: usize) -> [DVec3; 3] {
        mesh.triangles[t].map(|v| DVec3::from_array(mesh.points[v as usize]))
    }

    /// Brute force: the smallest distance over all triangles.
    fn brute_distance(mesh: &InterfaceMesh, p: DVec3) -> f64 {
        (0..mesh.triangles.len())
            .map(|t| {
                let [a, b, c] = corners(mesh, t);
                closest_point_on_triangle(p, a, b, c).0.distance(p)
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// Inside a closed mesh by the parity of ray crossings (Möller–Trumbore), along an odd direction.
    fn inside(mesh: &InterfaceMesh, p: DVec3) -> bool {
        let dir = DVec3::new(0.5377, 0.3164, 0.7817).normalize();
        let mut hits = 0;
        for t in 0..mesh.triangles.len() {
            let [a, b, c] = corners(mesh, t);
            let (e1, e2) = (b - a, c - a);
            let h = dir.cross(e2);
            let det = e1.dot(h);
            if det.abs() < 1e-14 {
                continue;
            }
            let s = p - a;
            let u = s.dot(h) / det;
            let q = s.cross(e1);
            let v = dir.dot(q) / det;
            let t = e2.dot(q) / det;
            if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0 {
                hits += 1;
            }
        }
        hits % 2 == 1
    }

    #[test]
    fn closest_point_on_triangle_is_the_minimum() {
        let mut rng = fastrand::Rng::with_seed(7);
        for _ in 0..300 {
            let [a, b, c] = [0; 3].map(|_| DVec3::from_array(point(&mut rng, -1.0, 1.0)));
            let p = DVec3::from_array(point(&mut rng, -2.0, 2.0));
            let (q, _) = closest_point_on_triangle(p, a, b, c);
            // q lies in the triangle (barycentric coordinates in [0, 1]).
            let n = (b - a).cross(c - a);
            let area = n.length_squared();
            let u = (c - b).cross(q - b).dot(n) / area;
            let v = (a - c).cross(q - c).dot(n) / area;
            let w = (b - a).cross(q - a).dot(n) / area;
            assert!(u >= -1e-9 && v >= -1e-9 && w >= -1e-9);
            assert!((u + v + w - 1.0).abs() < 1e-9);
            assert!(((q - a).dot(n)).abs() < 1e-9 * n.length());
            // No sample of the triangle is closer.
            let d = q.distance(p);
            let k = 40;
            for i in 0..=k {
                for j in 0..=k - i {
                    let (s, t) = (i as f64 / k as f64, j as f64 / k as f64);
                    let x = a + s * (b - a) + t * (c - a);
                    assert!(x.distance(p) >= d - 1e-12);
                }
            }
        }
        // Degenerate triangles: collinear and a point.
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::X * 2.0);
        let (q, f) = closest_point_on_triangle(DVec3::new(1.5, 1.0, 0.0), a, b, c);
        assert!(q.distance(DVec3::new(1.5, 0.0, 0.0)) < 1e-15, "{q} {f:?}");
        let (q, _) = closest_point_on_triangle(DVec3::ONE, DVec3::X, DVec3::X, DVec3::X);
        assert_eq!(q, DVec3::X);
    }

    #[test]
    fn nearest_matches_brute_force() {
        let closed = bumpy_sphere(0.15);
        // An open mesh: half of the sphere's triangles.
        let mut open = closed.clone();
        open.triangles.truncate(open.triangles.len() / 2);
        open.pair = (1, 2);
        let index = InterfaceIndex::new(&[closed.clone(), open.clone()]);
        let mut rng = fastrand::Rng::with_seed(42);
        for (m, mesh) in [&closed, &open].into_iter().enumerate() {
            for _ in 0..2000 {
                let p = point(&mut rng, -1.8, 1.8);
                let c = index.closest(m, p).unwrap();
                let brute = brute_distance(mesh, DVec3::from_array(p));
                assert!(
                    (c.distance - brute).abs() < 1e-12,
                    "{} vs {brute}",
                    c.distance
                );
                let q = DVec3::from_array(c.point);
                assert!((q.distance(DVec3::from_array(p)) - c.distance).abs() < 1e-12);
                assert!(
                    brute_distance(mesh, q) < 1e-12,
                    "the closest point is on the mesh"
                );
            }
        }
        assert!(index.closest(2, [0.0; 3]).is_none());
        let empty = InterfaceIndex::new(&[InterfaceMesh::default()]);
        assert!(empty.closest(0, [0.0; 3]).is_none());
    }

    #[test]
    fn side_is_correct_near_vertices_and_edges() {
        let mesh = bumpy_sphere(0.25);
        let index = InterfaceIndex::new(std::slice::from_ref(&mesh));
        let mut rng = fastrand::Rng::with_seed(3);
        let mut checked = 0;
        // Points near the vertices (where the closest feature is often a vertex or an edge, and
        // concave regions where face normals disagree) and random points.
        for round in 0..6000 {
            let p = if round % 2 == 0 {
                let v = mesh.points[(rng.f64() * mesh.points.len() as f64) as usize];
                let o = point(&mut rng, -0.08, 0.08);
                [v[0] + o[0], v[1] + o[1], v[2] + o[2]]
            } else {
                point(&mut rng, -1.5, 1.5)
            };
            let c = index.closest(0, p).unwrap();
            if c.distance < 1e-6 {
                continue;
            }
            let expected = if inside(&mesh, DVec3::from_array(p)) {
                -1.0
            } else {
                1.0
            };
            assert_eq!(c.side, expected, "at {p:?}, closest {c:?}");
            checked += 1;
        }
        assert!(checked > 5000);
        let on = index.closest(0, mesh.points[5]).unwrap();
        assert_eq!((on.distance, on.side), (0.0, 0.0));
    }

    #[test]
    fn side_on_a_cube_soup_at_corners_and_edges() {
        let mesh = cube_soup();
        let index = InterfaceIndex::new(&[mesh]);
        let cases: &[([f64; 3], f64, [f64; 3])] = &[
            // Outside, closest to a corner.
            ([1.1, 1.2, 1.3], 1.0, [1.0, 1.0, 1.0]),
            ([-0.1, -0.2, -0.05], 1.0, [0.0, 0.0, 0.0]),
            ([1.01, -0.3, 1.2], 1.0, [1.0, 0.0, 1.0]),
            // Outside, closest to an edge (also the diagonal of a face split).
            ([1.2, 1.3, 0.5], 1.0, [1.0, 1.0, 0.5]),
            ([0.3, -0.1, -0.4], 1.0, [0.3, 0.0, 0.0]),
            ([1.5, 0.2, -0.5], 1.0, [1.0, 0.2, 0.0]),
            // Outside, closest to a face (on a triangle diagonal).
            ([0.4, 0.4, 1.3], 1.0, [0.4, 0.4, 1.0]),
            // Inside, near a corner, an edge and a diagonal.
            ([0.95, 0.97, 0.99], -1.0, [0.95, 0.97, 1.0]),
            ([0.02, 0.03, 0.5], -1.0, [0.0, 0.03, 0.5]),
            ([0.5, 0.5, 0.01], -1.0, [0.5, 0.5, 0.0]),
            ([0.9, 0.9, 0.9], -1.0, [0.9, 0.9, 1.0]),
        ];
        for &(p, side, point) in cases {
            let c = index.closest(0, p).unwrap();
            assert_eq!(c.side, side, "at {p:?}: {c:?}");
            let q = DVec3::from_array(c.point);
            let d = q.distance(DVec3::from_array(point));
            // Inside at (0.9, 0.9, 0.9) three faces tie: any of them.
            assert!(d < 1e-12 || p == [0.9, 0.9, 0.9], "at {p:?}: {c:?}");
            assert!((c.distance - q.distance(DVec3::from_array(p))).abs() < 1e-12);
        }
        // A dense shell of points around the corners.
        let mut rng = fastrand::Rng::with_seed(11);
        for _ in 0..3000 {
            let corner = [rng.f64().round(), rng.f64().round(), rng.f64().round()];
            let o = point(&mut rng, -0.2, 0.2);
            let p = [corner[0] + o[0], corner[1] + o[1], corner[2] + o[2]];
            let inside = p.iter().all(|&x| x > 0.0 && x < 1.0);
            let c = index.closest(0, p).unwrap();
            if c.distance > 1e-9 {
                assert_eq!(c.side, if inside { -1.0 } else { 1.0 }, "at {p:?}: {c:?}");
            }
        }
    }

    #[test]
    fn index_is_send_and_sync() {
        fn check<T: Send + Sync>() {}
        check::<InterfaceIndex>();
    }
}
