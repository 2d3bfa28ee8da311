//! The validity tests of a half-edge collapse `hec(p_i → p_j)` (§3.2): the boundary rule (a boundary
//! vertex moves only along a boundary edge), the link condition (the mesh stays a manifold
//! tetrahedralisation: Dey et al.'s `Lk(i) ∩ Lk(j) = Lk(ij)`, with the boundary closed by a vertex at
//! infinity) and feature edges. Flipped or degenerate tetrahedra are tested where the cost is
//! computed (`Around::proper_at` in [`super::simplify`]), and for a boundary vertex that the new
//! boundary faces meet no other boundary face (`Simplifier::boundary_stays_embedded`: with positive
//! tetrahedra, an embedded boundary means no two tetrahedra overlap).

use glam::DVec3;

/// Two boundary faces meeting at more than this angle (between outward normals) make a feature edge
/// (ParaView's Feature Edges default).
const FEATURE_ANGLE_DEGREES: f64 = 30.0;

/// The link of a vertex `v` in the current mesh, from its star (the tetrahedra around it).
#[derive(Debug, Default)]
pub(super) struct Link {
    /// The vertices adjacent to `v`, sorted.
    verts: Vec<u32>,
    /// The edges `ab` of the triangles `vab`, sorted pairs, deduplicated.
    edges: Vec<[u32; 2]>,
    /// The faces opposite `v` as sorted triples packed by [`tri_key`], in increasing order.
    tris: Vec<u128>,
    /// The boundary faces `vab` as the sorted pair `ab` and the fourth corner of their tetrahedron.
    boundary: Vec<([u32; 2], u32)>,
    /// The vertices `a` of the boundary edges `va`, sorted.
    boundary_verts: Vec<u32>,
}

/// The three corners of `t` other than `v`, in `t`'s order.
fn others(t: [u32; 4], v: u32) -> [u32; 3] {
    let mut o = [0; 3];
    let mut k = 0;
    for c in t {
        if c != v && k < 3 {
            o[k] = c;
            k += 1;
        }
    }
    o
}

fn sorted_pair(a: u32, b: u32) -> [u32; 2] {
    [a.min(b), a.max(b)]
}

/// The sorted triple `t` packed into one integer whose order is the triples' lexicographic one
/// (integers sort and compare faster than arrays).
fn tri_key(t: [u32; 3]) -> u128 {
    (u128::from(t[0]) << 64) | (u128::from(t[1]) << 32) | u128::from(t[2])
}

impl Link {
    /// The link of `v` whose star is the tetrahedra `star` of `tets`.
    pub(super) fn of(tets: &[[u32; 4]], star: &[u32], v: u32) -> Self {
        let mut link = Link {
            verts: Vec::with_capacity(3 * star.len()),
            edges: Vec::with_capacity(3 * star.len()),
            tris: Vec::with_capacity(star.len()),
            ..Link::default()
        };
        // Every face `vab` as its edge `ab` packed into one integer (integers sort faster than
        // arrays); a face seen once is on the boundary.
        let mut faces: Vec<u64> = Vec::with_capacity(3 * star.len());
        for &t in star {
            let o = others(tets[t as usize], v);
            let mut tri = o;
            tri.sort_unstable();
            link.tris.push(tri_key(tri));
            link.verts.extend_from_slice(&o);
            let [a, b, c] = tri;
            for [a, b] in [[a, b], [a, c], [b, c]] {
                faces.push((u64::from(a) << 32) | u64::from(b));
            }
        }
        link.verts.sort_unstable();
        link.verts.dedup();
        link.tris.sort_unstable();
        faces.sort_unstable();
        for group in faces.chunk_by(|x, y| x == y) {
            let ab = [(group[0] >> 32) as u32, group[0] as u32];
            link.edges.push(ab);
            if group.len() == 1 {
                // The fourth corner of the one tetrahedron with the face `vab`.
                let d = star
                    .iter()
                    .map(|&t| others(tets[t as usize], v))
                    .find(|o| o.contains(&ab[0]) && o.contains(&ab[1]))
                    .and_then(|o| o.into_iter().find(|c| !ab.contains(c)))
                    .expect("a face of the link is one of a tetrahedron of the star");
                link.boundary.push((ab, d));
                link.boundary_verts.extend_from_slice(&ab);
            }
        }
        link.boundary_verts.sort_unstable();
        link.boundary_verts.dedup();
        link
    }

    /// The link of an interior vertex `v` as far as the collapse costs need it: its vertices only
    /// (no face is sorted: most vertices of a volume mesh are interior, and their offers are
    /// estimated after every collapse around them). `on_boundary` is `false`; only for `v` not on
    /// the boundary, which a collapse never changes (§3.2: boundary faces only move along the
    /// boundary, interior ones stay interior).
    pub(super) fn of_interior(tets: &[[u32; 4]], star: &[u32], v: u32) -> Self {
        let mut verts = Vec::with_capacity(3 * star.len());
        for &t in star {
            verts.extend_from_slice(&others(tets[t as usize], v));
        }
        verts.sort_unstable();
        verts.dedup();
        Link {
            verts,
            ..Link::default()
        }
    }

    /// The vertices adjacent to `v`.
    pub(super) fn verts(&self) -> &[u32] {
        &self.verts
    }

    /// Is `v` on the boundary of the mesh?
    pub(super) fn on_boundary(&self) -> bool {
        !self.boundary.is_empty()
    }

    /// Is the edge from `v` to `a` on the boundary?
    pub(super) fn boundary_edge_to(&self, a: u32) -> bool {
        self.boundary_verts.binary_search(&a).is_ok()
    }

    /// How many vertices `a` the boundary edges `va` reach.
    pub(super) fn boundary_vertex_count(&self) -> usize {
        self.boundary_verts.len()
    }

    /// The boundary faces `vab` as `(a, b, fourth corner)`.
    pub(super) fn boundary_faces(&self) -> impl Iterator<Item = (u32, u32, u32)> + '_ {
        self.boundary.iter().map(|&([a, b], d)| (a, b, d))
    }
}

/// Does every element of both sorted `a` and `b` lie in sorted `within`?
#[cfg(test)]
fn common_within<T: Ord>(a: &[T], b: &[T], within: &[T]) -> bool {
    a.iter()
        .filter(|x| b.binary_search(x).is_ok())
        .all(|x| within.binary_search(x).is_ok())
}

/// Do the sorted `a` and `b` share no element?
#[cfg(test)]
fn disjoint<T: Ord>(a: &[T], b: &[T]) -> bool {
    !a.iter().any(|x| b.binary_search(x).is_ok())
}

/// The link of the edge `ij` from the tetrahedra `edge_tets` around it: its vertices (sorted), its
/// edges (sorted pairs) and the vertices `a` of its boundary faces `ija` (faces seen once).
struct EdgeLink {
    verts: Vec<u32>,
    edges: Vec<[u32; 2]>,
    boundary: Vec<u32>,
}

impl EdgeLink {
    fn of(tets: &[[u32; 4]], edge_tets: &[u32], i: u32, j: u32) -> Self {
        let mut verts = Vec::with_capacity(2 * edge_tets.len());
        let mut edges = Vec::with_capacity(edge_tets.len());
        for &t in edge_tets {
            let mut ab = others(tets[t as usize], i).into_iter().filter(|&c| c != j);
            let (a, b) = (ab.next().unwrap_or(j), ab.next().unwrap_or(j));
            verts.extend([a, b]);
            edges.push(sorted_pair(a, b));
        }
        verts.sort_unstable();
        // A face `ija` seen once around the edge is on the boundary.
        let boundary = verts
            .chunk_by(|a, b| a == b)
            .filter(|g| g.len() == 1)
            .map(|g| g[0])
            .collect();
        verts.dedup();
        edges.sort_unstable();
        Self {
            verts,
            edges,
            boundary,
        }
    }
}

/// The link condition of the collapse of the edge `ij` (§3.2, "the mesh stays a manifold"): with
/// `li`, `lj` the links of `i` and `j` and `edge_tets` the tetrahedra around `ij`, the simplices
/// common to both links are those of the edge's link, the boundary closed by a vertex ω at infinity
/// (joined to every boundary simplex): common vertices, edges and faces of `Lk(i)` and `Lk(j)` lie in
/// `Lk(ij)` (which has no faces), and likewise for the simplices joined to ω — if both ends are on
/// the boundary the edge is, a vertex `a` with boundary edges `ia` and `ja` spans a boundary face
/// `ija`, and no boundary edge `ab` has both `iab` and `jab` as boundary faces. The reduction uses
/// the equivalent [`link_condition_from_star`]; this one, from both links, is its reference.
#[cfg(test)]
pub(super) fn link_condition(
    tets: &[[u32; 4]],
    edge_tets: &[u32],
    (i, li): (u32, &Link),
    (j, lj): (u32, &Link),
) -> bool {
    let edge = EdgeLink::of(tets, edge_tets, i, j);
    let edge_on_boundary = !edge.boundary.is_empty();
    let strip =
        |v: &[u32], other: u32| -> Vec<u32> { v.iter().copied().filter(|&a| a != other).collect() };
    let (vi, vj) = (strip(&li.verts, j), strip(&lj.verts, i));
    let (bi, bj) = (strip(&li.boundary_verts, j), strip(&lj.boundary_verts, i));
    let boundary_edges = |l: &Link| -> Vec<[u32; 2]> { l.boundary.iter().map(|b| b.0).collect() };
    common_within(&vi, &vj, &edge.verts)
        && common_within(&li.edges, &lj.edges, &edge.edges)
        && disjoint(&li.tris, &lj.tris)
        && (!li.on_boundary() || !lj.on_boundary() || edge_on_boundary)
        && common_within(&bi, &bj, &edge.boundary)
        && disjoint(&boundary_edges(li), &boundary_edges(lj))
}

/// [`link_condition`] read from `j`'s star (`star_j`) without building `Lk(j)` (the test runs for
/// every target a vertex's offer tries): each vertex, edge and face of `Lk(j)` (a face of a
/// tetrahedron around `j`) is looked up in the sorted `Lk(i)`. For `j` on the boundary
/// (`j_on_boundary`) the simplices joined to ω are decided from `Lk(i)`'s few boundary simplices,
/// each looked up around `j`: a boundary edge `ab` of `Lk(i)` must not span a boundary face `jab`
/// (the face `jab` of exactly one tetrahedron around `j`), and a vertex `a` of a boundary edge `ia`
/// that also has the boundary edge `ja` ([`edge_on_boundary`]) must lie in the edge's boundary.
/// No sort, no allocation beyond the edge's link.
pub(super) fn link_condition_from_star(
    tets: &[[u32; 4]],
    edge_tets: &[u32],
    (i, li): (u32, &Link),
    (j, star_j): (u32, &[u32]),
    j_on_boundary: bool,
) -> bool {
    let edge = EdgeLink::of(tets, edge_tets, i, j);
    let has = |x: &[u32], a: u32| x.binary_search(&a).is_ok();
    let common_within_edge = star_j.iter().all(|&t| {
        let o = others(tets[t as usize], j);
        let mut tri = o;
        tri.sort_unstable();
        let [a, b, c] = tri;
        li.tris.binary_search(&tri_key(tri)).is_err()
            && o.iter()
                .all(|&v| v == i || !has(&li.verts, v) || has(&edge.verts, v))
            && [[a, b], [a, c], [b, c]]
                .iter()
                .all(|e| li.edges.binary_search(e).is_err() || edge.edges.binary_search(e).is_ok())
    });
    if !common_within_edge || !j_on_boundary {
        return common_within_edge;
    }
    let around_j = |a: u32, b: u32| {
        star_j
            .iter()
            .filter(|&&t| {
                let c = &tets[t as usize];
                c.contains(&a) && c.contains(&b)
            })
            .count()
    };
    (!li.on_boundary() || !edge.boundary.is_empty())
        && li
            .boundary
            .iter()
            .all(|&([a, b], _)| a == j || b == j || around_j(a, b) != 1)
        && li
            .boundary_verts
            .iter()
            .all(|&a| a == j || has(&edge.boundary, a) || !edge_on_boundary(tets, star_j, j, a))
}

/// Is the edge `ja` on the boundary (`star_j` the tetrahedra around `j`): is a face `jab` one of
/// only one tetrahedron around the edge (a vertex `b` seen once in the edge's link)?
fn edge_on_boundary(tets: &[[u32; 4]], star_j: &[u32], j: u32, a: u32) -> bool {
    let around = || {
        star_j
            .iter()
            .map(|&t| tets[t as usize])
            .filter(|c| c.contains(&a))
    };
    around().any(|c| {
        c.iter()
            .filter(|&&b| b != j && b != a)
            .any(|&b| around().filter(|o| o.contains(&b)).count() == 1)
    })
}

/// The outward normal (not normalised) of the boundary face `vab` whose tetrahedron's fourth corner
/// is `d`.
fn outward_normal(pos: &[DVec3], v: u32, a: u32, b: u32, d: u32) -> DVec3 {
    let p = |k: u32| pos[k as usize];
    let n = (p(a) - p(v)).cross(p(b) - p(v));
    if n.dot(p(d) - p(v)) > 0.0 {
        -n
    } else {
        n
    }
}

/// Is the boundary edge `vw` (`link` the link of `v`) a feature edge: do its two boundary faces
/// meet at more than [`FEATURE_ANGLE_DEGREES`]?
pub(super) fn is_feature_edge(pos: &[DVec3], v: u32, link: &Link, w: u32) -> bool {
    let normals: Vec<DVec3> = link
        .boundary_faces()
        .filter(|&(a, b, _)| a == w || b == w)
        .map(|(a, b, d)| outward_normal(pos, v, a, b, d).normalize_or_zero())
        .collect();
    normals.len() == 2 && normals[0].dot(normals[1]) < FEATURE_ANGLE_DEGREES.to_radians().cos()
}

/// How many feature edges of the boundary meet at `v` (0 for an interior vertex).
pub(super) fn feature_edges_at(pos: &[DVec3], v: u32, link: &Link) -> usize {
    link.boundary_verts
        .iter()
        .filter(|&&w| is_feature_edge(pos, v, link, w))
        .count()
}
