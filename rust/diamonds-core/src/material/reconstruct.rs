//! Interface reconstruction from point volume fractions: multi-label Surface Nets.
//!
//! This is what Gregorski et al. (2002, §5.2.1) call "interface reconstruction from volume fractions":
//! the samples are labelled with their dominant material ([`classify`]), and the boundaries between the
//! labels are extracted as triangle meshes, one per pair of touching materials ([`reconstruct`]).
//!
//! The method is multi-label Surface Nets (Gibson 1998, "Constrained elastic surface nets"; Frisken's
//! multi-material generalisation), i.e. dual contouring of the label field:
//! - every grid edge whose two samples carry different labels `a < b` gets a quad *dual* to it, joining
//!   one point in each of the four cells around the edge; the quad goes into the mesh of pair `(a, b)`;
//! - the point of a cell is the average of the crossing points on those of its twelve edges whose labels
//!   differ; the crossing point on an edge `p–q` labelled `a, b` is where `f_a − f_b` (linear along the
//!   edge) vanishes, clamped to the edge. A cell point is the same for every pair mesh that uses it.
//!
//! To let interfaces reach the domain boundary, the grid is closed by *boundary elements*: where a cell
//! around an edge is missing because the edge lies on a boundary face of the grid, the boundary face
//! square takes its place (its point is the average of the crossing points on its four edges), and on an
//! edge of the domain box the edge itself (its crossing point). An element is named by its centre in
//! doubled lattice coordinates (odd = spanning a cell interval along that axis, even = fixed at a
//! boundary coordinate), which is also the key that deduplicates points within a mesh.
//!
//! Why it is crack-free: two consecutive elements around an edge share a grid face square `F` (or, on the
//! boundary, a grid edge lying in the boundary). A quad side joining them is produced once for each edge
//! of `F` with different labels; around the 4-cycle of `F`'s corners the labels change 0, 2, 3 or 4
//! times, never exactly once, so every quad side inside the domain is shared by 2, 3 (a junction of three
//! materials) or 4 quads. Quad diagonals are shared by the two triangles of their quad. The only sides
//! used once join two boundary elements across a grid edge that lies in a boundary plane, so both
//! endpoints, and the side, lie in the domain boundary. With two labels each side is used by exactly two
//! quads (unless a face has a checkerboard of labels), with opposite directions: the meshes are closed
//! and consistently oriented.

use super::InterfaceMesh;
use crate::Grid;
use rayon::prelude::*;

/// Material of each sample: the index of its largest fraction (the lowest index on ties).
///
/// All arrays must have the same length; at most 256 materials. NaN fractions never win.
pub fn classify(fractions: &[&[f32]]) -> Vec<u8> {
    assert!(
        fractions.len() <= 256,
        "at most 256 materials are supported"
    );
    let Some(first) = fractions.first() else {
        return Vec::new();
    };
    let n = first.len();
    assert!(
        fractions.iter().all(|f| f.len() == n),
        "every material needs one fraction per sample"
    );
    (0..n)
        .into_par_iter()
        .with_min_len(4096)
        .map(|i| {
            let mut best = 0u8;
            let mut value = first[i];
            for (m, f) in fractions.iter().enumerate().skip(1) {
                // `!(f <= value)` lets a number replace a NaN; `>` keeps the lowest index on ties.
                if f[i] > value || (value.is_nan() && !f[i].is_nan()) {
                    best = m as u8;
                    value = f[i];
                }
            }
            best
        })
        .collect()
}

/// One crack-free triangle mesh per pair of materials that touch (multi-label Surface Nets, see the
/// module documentation), sorted by pair; pairs without triangles are left out.
///
/// `labels` is the material of each sample of `grid` (usually [`classify`]; each `< fractions.len()`),
/// `fractions` one array per material, one value per sample. Grids with fewer than 2 points along an
/// axis give no meshes. Triangles are wound so that their (counter-clockwise) normal points from material `pair.0`
/// into `pair.1`, i.e. toward the sample labelled `pair.1` of the grid edge the triangle is dual to.
/// Each mesh has its own points, deduplicated; a point of a cell (or boundary element) has the same
/// coordinates in every mesh that uses it, so the union of the meshes is crack-free too: every triangle
/// edge is shared by at least two triangles of the union, except edges lying in the domain boundary.
pub fn reconstruct(grid: &Grid, labels: &[u8], fractions: &[&[f32]]) -> Vec<InterfaceMesh> {
    let n = grid.len();
    assert_eq!(labels.len(), n, "one label per sample");
    assert!(
        fractions.iter().all(|f| f.len() == n),
        "one fraction per sample and material"
    );
    assert!(
        labels.par_iter().all(|&l| (l as usize) < fractions.len()),
        "every label names a material"
    );
    if grid.dims.iter().any(|&d| d < 2) {
        return Vec::new();
    }
    let nets = Nets {
        grid,
        labels,
        fractions,
        doubled: grid.dims.map(|d| 2 * d as u64 - 1),
    };
    let [nx, ny, nz] = grid.dims;

    // 1. The quads, as (pair, four element keys counter-clockwise about the normal), in grid order.
    let mut quads: Vec<(u16, [u64; 4])> = (0..nz)
        .into_par_iter()
        .flat_map_iter(|k| {
            let nets = &nets;
            let mut out = Vec::new();
            for j in 0..ny {
                for i in 0..nx {
                    let ijk = [i, j, k];
                    let p = grid.index(i, j, k);
                    let lp = labels[p];
                    for a in 0..3 {
                        if ijk[a] + 1 >= grid.dims[a] {
                            continue;
                        }
                        let q = p + nets.stride(a);
                        let lq = labels[q];
                        if lp != lq {
                            out.push(nets.quad(ijk, a, lp, lq));
                        }
                    }
                }
            }
            out
        })
        .collect();
    quads.par_sort_by_key(|q| q.0);

    // 2. Per pair: deduplicated points, then two triangles per quad.
    let mut groups = Vec::new();
    let mut start = 0;
    while start < quads.len() {
        let pair = quads[start].0;
        let end = start + quads[start..].partition_point(|q| q.0 == pair);
        groups.push((pair, start..end));
        start = end;
    }
    groups
        .into_par_iter()
        .map(|(pair, range)| {
            let quads = &quads[range];
            let mut keys: Vec<u64> = quads.iter().flat_map(|q| q.1).collect();
            keys.par_sort_unstable();
            keys.dedup();
            let points: Vec<[f64; 3]> = keys.par_iter().map(|&key| nets.point(key)).collect();
            let index = |key: u64| keys.binary_search(&key).expect("every key has a point") as u32;
            let mut triangles = Vec::with_capacity(2 * quads.len());
            for (_, quad) in quads {
                let v = quad.map(index);
                let d2 = |a: u32, b: u32| {
                    let (a, b) = (points[a as usize], points[b as usize]);
                    (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>()
                };
                // Split along the shorter diagonal (better shaped triangles).
                if d2(v[0], v[2]) <= d2(v[1], v[3]) {
                    triangles.push([v[0], v[1], v[2]]);
                    triangles.push([v[0], v[2], v[3]]);
                } else {
                    triangles.push([v[0], v[1], v[3]]);
                    triangles.push([v[1], v[2], v[3]]);
                }
            }
            InterfaceMesh {
                pair: ((pair >> 8) as u8, pair as u8),
                points,
                triangles,
            }
        })
        .collect()
}

/// The label field with its fractions, and the element keys: doubled lattice coordinates
/// `s = (s0, s1, s2)`, `s_a ∈ [0, 2(n_a − 1)]`, packed as `s0 + D0 (s1 + D1 s2)` with `D_a = 2 n_a − 1`.
struct Nets<'a> {
    grid: &'a Grid,
    labels: &'a [u8],
    fractions: &'a [&'a [f32]],
    doubled: [u64; 3],
}

impl Nets<'_> {
    fn stride(&self, axis: usize) -> usize {
        match axis {
            0 => 1,
            1 => self.grid.dims[0],
            _ => self.grid.dims[0] * self.grid.dims[1],
        }
    }

    fn key(&self, s: [u64; 3]) -> u64 {
        s[0] + self.doubled[0] * (s[1] + self.doubled[1] * s[2])
    }

    fn unkey(&self, key: u64) -> [u64; 3] {
        let s0 = key % self.doubled[0];
        let rest = key / self.doubled[0];
        [s0, rest % self.doubled[1], rest / self.doubled[1]]
    }

    /// The quad dual to the edge from `ijk` along `axis`, labelled `lp` at `ijk` and `lq` at the other end.
    fn quad(&self, ijk: [usize; 3], axis: usize, lp: u8, lq: u8) -> (u16, [u64; 4]) {
        let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
        // Along `b` and `c`: the cells on both sides, or the boundary (the edge's own coordinate).
        let side = |x: usize| {
            let last = self.grid.dims[x] - 1;
            let j = ijk[x] as u64;
            let lo = if ijk[x] == 0 { 0 } else { 2 * j - 1 };
            let hi = if ijk[x] == last { 2 * j } else { 2 * j + 1 };
            (lo, hi)
        };
        let (b_lo, b_hi) = side(b);
        let (c_lo, c_hi) = side(c);
        let element = |sb: u64, sc: u64| {
            let mut s = [0; 3];
            s[axis] = 2 * ijk[axis] as u64 + 1;
            s[b] = sb;
            s[c] = sc;
            self.key(s)
        };
        // Counter-clockwise about +axis (axis, b, c is right-handed).
        let ring = [
            element(b_lo, c_lo),
            element(b_hi, c_lo),
            element(b_hi, c_hi),
            element(b_lo, c_hi),
        ];
        let (pair, ring) = if lp < lq {
            // Normal along +axis, toward `q`, labelled pair.1.
            ((lp, lq), ring)
        } else {
            ((lq, lp), [ring[0], ring[3], ring[2], ring[1]])
        };
        (((pair.0 as u16) << 8) | pair.1 as u16, ring)
    }

    /// The point of the element with `key`: the average of the crossing points of its edges with
    /// different labels (there is at least one: the edge that asked for the element).
    fn point(&self, key: u64) -> [f64; 3] {
        let s = self.unkey(key);
        let mut sum = [0.0; 3];
        let mut count = 0u32;
        for axis in 0..3 {
            if s[axis] & 1 == 0 {
                continue;
            }
            let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
            // Endpoints along an axis: one fixed coordinate, or both ends of the interval.
            let ends = |x: usize| {
                if s[x] & 1 == 0 {
                    [s[x] / 2, s[x] / 2]
                } else {
                    [s[x] / 2, s[x] / 2 + 1]
                }
            };
            let (eb, ec) = (ends(b), ends(c));
            let nb = if eb[0] == eb[1] { 1 } else { 2 };
            let nc = if ec[0] == ec[1] { 1 } else { 2 };
            for &jb in &eb[..nb] {
                for &jc in &ec[..nc] {
                    let mut ijk = [0usize; 3];
                    ijk[axis] = (s[axis] / 2) as usize;
                    ijk[b] = jb as usize;
                    ijk[c] = jc as usize;
                    if let Some(x) = self.crossing(ijk, axis) {
                        for (t, x) in sum.iter_mut().zip(x) {
                            *t += x;
                        }
                        count += 1;
                    }
                }
            }
        }
        debug_assert!(count > 0, "element {s:?} has no crossing");
        sum.map(|t| t / count.max(1) as f64)
    }

    /// The crossing point on the edge from `ijk` along `axis`, or `None` when its labels agree: where
    /// `f_a − f_b` vanishes (`a`, `b` the labels at the two ends), clamped to the edge.
    fn crossing(&self, ijk: [usize; 3], axis: usize) -> Option<[f64; 3]> {
        let p = self.grid.index(ijk[0], ijk[1], ijk[2]);
        let q = p + self.stride(axis);
        let (la, lb) = (self.labels[p] as usize, self.labels[q] as usize);
        if la == lb {
            return None;
        }
        let g = |x: usize| self.fractions[la][x] as f64 - self.fractions[lb][x] as f64;
        let t = crossing_parameter(g(p), g(q));
        let mut x = self.grid.point(ijk);
        x[axis] += t * self.grid.spacing[axis];
        Some(x)
    }
}

/// Where the linear function with values `gp` (≥ 0 normally) at 0 and `gq` (≤ 0) at 1 vanishes, in `[0, 1]`;
/// the midpoint when that is undefined.
fn crossing_parameter(gp: f64, gq: f64) -> f64 {
    let denominator = gp - gq;
    let t = gp / denominator;
    if denominator > 0.0 && t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.5
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use std::collections::HashMap;

    /// Fractions of materials 0 (outside) and 1 (inside `inside`) in the dual cell of each point,
    /// supersampled `n³` times.
    fn two_materials(grid: &Grid, n: usize, inside: impl Fn([f64; 3]) -> bool) -> Vec<Vec<f32>> {
        let mut f1 = vec![0f32; grid.len()];
        for (idx, f) in f1.iter_mut().enumerate() {
            let c = grid.point(grid.ijk(idx));
            let mut count = 0;
            for s in 0..n * n * n {
                let sub = [s % n, (s / n) % n, s / (n * n)];
                let x: [f64; 3] = std::array::from_fn(|a| {
                    c[a] + grid.spacing[a] * ((sub[a] as f64 + 0.5) / n as f64 - 0.5)
                });
                count += inside(x) as usize;
            }
            *f = count as f32 / (n * n * n) as f32;
        }
        vec![f1.iter().map(|f| 1.0 - f).collect(), f1]
    }

    fn grid(dims: [usize; 3], origin: f64, spacing: f64) -> Grid {
        Grid {
            dims,
            origin: [origin; 3],
            spacing: [spacing; 3],
        }
    }

    fn run(grid: &Grid, fractions: &[Vec<f32>]) -> (Vec<u8>, Vec<InterfaceMesh>) {
        let f: Vec<&[f32]> = fractions.iter().map(|f| f.as_slice()).collect();
        let labels = classify(&f);
        let meshes = reconstruct(grid, &labels, &f);
        (labels, meshes)
    }

    /// The counter-clockwise (unnormalised) normal of a triangle.
    fn normal([a, b, c]: [DVec3; 3]) -> DVec3 {
        (b - a).cross(c - a)
    }

    /// Directed edge counts of a mesh.
    fn directed_edges(mesh: &InterfaceMesh) -> HashMap<(u32, u32), usize> {
        let mut edges = HashMap::new();
        for t in &mesh.triangles {
            for e in 0..3 {
                *edges.entry((t[e], t[(e + 1) % 3])).or_default() += 1;
            }
        }
        edges
    }

    /// Undirected edges of the union of the meshes, by point coordinates (bit patterns).
    fn union_edges(meshes: &[InterfaceMesh]) -> HashMap<([u64; 3], [u64; 3]), usize> {
        let mut edges = HashMap::new();
        for m in meshes {
            for t in &m.triangles {
                for e in 0..3 {
                    let a = m.points[t[e] as usize].map(f64::to_bits);
                    let b = m.points[t[(e + 1) % 3] as usize].map(f64::to_bits);
                    *edges.entry((a.min(b), a.max(b))).or_default() += 1;
                }
            }
        }
        edges
    }

    fn on_boundary(grid: &Grid, x: [f64; 3]) -> bool {
        let b = grid.bounds();
        (0..3).any(|a| {
            let tol = 1e-9 * grid.spacing[a];
            (x[a] - b[2 * a]).abs() < tol || (x[a] - b[2 * a + 1]).abs() < tol
        })
    }

    #[test]
    fn classify_takes_the_largest_and_the_lowest_on_ties() {
        let a = [0.5, 0.2, 0.3, 0.0, f32::NAN];
        let b = [0.5, 0.7, 0.3, 0.4, 0.1];
        let c = [0.0, 0.1, 0.4, 0.6, 0.1];
        assert_eq!(classify(&[&a, &b, &c]), vec![0, 1, 2, 2, 1]);
    }

    #[test]
    fn sphere_is_closed_oriented_and_encloses_its_volume() {
        let r = 0.62;
        let g = grid([24, 24, 24], -1.0, 2.0 / 23.0);
        let fractions = two_materials(&g, 6, |x| DVec3::from(x).length_squared() < r * r);
        let (labels, meshes) = run(&g, &fractions);
        assert_eq!(meshes.len(), 1);
        let mesh = &meshes[0];
        assert_eq!(mesh.pair, (0, 1));

        // Closed and consistently oriented: each edge once in each direction.
        let edges = directed_edges(mesh);
        for (&(a, b), &count) in &edges {
            assert_eq!(count, 1, "edge {a}-{b} used {count} times in one direction");
            assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}-{b} has no twin");
        }
        // No unused or duplicate points.
        let mut used = vec![false; mesh.points.len()];
        mesh.triangles
            .iter()
            .flatten()
            .for_each(|&v| used[v as usize] = true);
        assert!(used.iter().all(|&u| u));

        // Normals point toward the samples labelled pair.1 (material 1, inside the sphere): inward.
        let mut volume = 0.0;
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|v| DVec3::from(mesh.points[v as usize]));
            let n = normal([a, b, c]);
            let centre = (a + b + c) / 3.0;
            if n.length_squared() > 1e-20 {
                assert!(n.dot(centre) < 0.0, "normal points outward at {centre:?}");
            }
            volume += a.dot(b.cross(c)) / 6.0;
        }
        // Inward normals: the divergence theorem gives minus the volume.
        let exact = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
        assert!(
            (-volume - exact).abs() < 0.03 * exact,
            "volume {} vs {exact}",
            -volume
        );
        assert!(labels.contains(&1));
    }

    #[test]
    fn quads_point_toward_pair_one_on_a_plane() {
        // Material 1 above an oblique plane, 0 below: every triangle normal has a positive component
        // along the plane normal (toward material 1).
        let g = grid([9, 10, 11], 0.0, 1.0);
        let plane_normal = DVec3::new(0.3, -0.5, 0.81);
        let d = |x: [f64; 3]| DVec3::from(x).dot(plane_normal) - 4.0;
        let fractions = two_materials(&g, 4, |x| d(x) > 0.0);
        let (_, meshes) = run(&g, &fractions);
        assert_eq!(meshes.len(), 1);
        for t in &meshes[0].triangles {
            let corners = t.map(|v| DVec3::from(meshes[0].points[v as usize]));
            assert!(normal(corners).dot(plane_normal) >= 0.0);
        }
        // The plane crosses the domain: its open edges lie in the domain boundary.
        let m = &meshes[0];
        let edges = directed_edges(m);
        for &(a, b) in edges.keys() {
            if !edges.contains_key(&(b, a)) {
                assert!(on_boundary(&g, m.points[a as usize]));
                assert!(on_boundary(&g, m.points[b as usize]));
            }
        }
    }

    #[test]
    fn three_materials_are_crack_free_with_junctions() {
        // Material 0 below z = 0, 1 above, 2 in a sphere across the plane, inside the domain.
        let g = grid([21, 21, 21], -1.0, 0.1);
        let n = 4;
        let mut fractions = vec![vec![0f32; g.len()]; 3];
        for idx in 0..g.len() {
            let c = g.point(g.ijk(idx));
            let mut counts = [0usize; 3];
            for s in 0..n * n * n {
                let sub = [s % n, (s / n) % n, s / (n * n)];
                let x: [f64; 3] = std::array::from_fn(|a| {
                    c[a] + g.spacing[a] * ((sub[a] as f64 + 0.5) / n as f64 - 0.5)
                });
                let m = if DVec3::from(x).length_squared() < 0.5 * 0.5 {
                    2
                } else if x[2] > 0.013 {
                    1
                } else {
                    0
                };
                counts[m] += 1;
            }
            for (f, c) in fractions.iter_mut().zip(counts) {
                f[idx] = c as f32 / (n * n * n) as f32;
            }
        }
        let (_, meshes) = run(&g, &fractions);
        let pairs: Vec<_> = meshes.iter().map(|m| m.pair).collect();
        assert_eq!(pairs, vec![(0, 1), (0, 2), (1, 2)]);

        let edges = union_edges(&meshes);
        let mut junctions = 0;
        for (&(a, b), &count) in &edges {
            let (a, b) = (a.map(f64::from_bits), b.map(f64::from_bits));
            if count < 2 {
                assert!(
                    on_boundary(&g, a) && on_boundary(&g, b),
                    "crack at {a:?}-{b:?}"
                );
            }
            junctions += (count == 3) as usize;
        }
        assert!(junctions > 20, "{junctions} junction edges");

        // The junction edges are exactly the open edges of the pair meshes inside the domain, and
        // each pair mesh is consistently oriented (no edge twice in the same direction).
        for m in &meshes {
            let directed = directed_edges(m);
            assert!(directed.values().all(|&c| c == 1));
            for &(a, b) in directed.keys() {
                if !directed.contains_key(&(b, a)) {
                    let (pa, pb) = (m.points[a as usize], m.points[b as usize]);
                    let key = {
                        let (ka, kb) = (pa.map(f64::to_bits), pb.map(f64::to_bits));
                        (ka.min(kb), ka.max(kb))
                    };
                    let shared = edges[&key];
                    assert!(
                        shared == 3 || (on_boundary(&g, pa) && on_boundary(&g, pb)),
                        "open edge of {:?} shared by {shared}",
                        m.pair
                    );
                }
            }
        }
    }

    #[test]
    fn material_touching_the_boundary_reaches_it() {
        // A ball of material 1 centred on a corner of the domain and another across a face.
        let g = grid([15, 13, 12], 0.0, 0.25);
        let fractions = two_materials(&g, 4, |x| {
            let x = DVec3::from(x);
            x.length_squared() < 1.3 * 1.3 || x.distance_squared(DVec3::new(3.5, 1.5, 1.4)) < 0.6
        });
        let (_, meshes) = run(&g, &fractions);
        assert_eq!(meshes.len(), 1);
        let m = &meshes[0];
        let edges = directed_edges(m);
        let mut open = 0;
        for &(a, b) in edges.keys() {
            if !edges.contains_key(&(b, a)) {
                open += 1;
                let (pa, pb) = (m.points[a as usize], m.points[b as usize]);
                // Both ends in the same boundary plane.
                let bounds = g.bounds();
                let same_plane = (0..6).any(|f| {
                    let tol = 1e-9;
                    (pa[f / 2] - bounds[f]).abs() < tol && (pb[f / 2] - bounds[f]).abs() < tol
                });
                assert!(
                    same_plane,
                    "open edge {pa:?}-{pb:?} not in a boundary plane"
                );
            }
        }
        assert!(open > 10);
        // The interface reaches the corner ball's three boundary faces.
        for a in 0..3 {
            assert!(m
                .points
                .iter()
                .any(|p| p[a] == 0.0 && DVec3::from(*p).length_squared() < 1.5 * 1.5));
        }
    }

    #[test]
    fn crossing_points_lie_on_their_edges() {
        let g = grid([7, 6, 5], 0.5, 0.3);
        // Three materials with random-ish fractions.
        let mut fractions = vec![vec![0f32; g.len()]; 3];
        let mut state = 12345u64;
        let mut rand = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        for idx in 0..g.len() {
            let w = [rand(), rand(), rand()];
            let s: f32 = w.iter().sum();
            for (f, w) in fractions.iter_mut().zip(w) {
                f[idx] = w / s;
            }
        }
        let f: Vec<&[f32]> = fractions.iter().map(|f| f.as_slice()).collect();
        let labels = classify(&f);
        let nets = Nets {
            grid: &g,
            labels: &labels,
            fractions: &f,
            doubled: g.dims.map(|d| 2 * d as u64 - 1),
        };
        let mut crossings = 0;
        for idx in 0..g.len() {
            let ijk = g.ijk(idx);
            for a in 0..3 {
                if ijk[a] + 1 >= g.dims[a] {
                    continue;
                }
                let Some(x) = nets.crossing(ijk, a) else {
                    continue;
                };
                crossings += 1;
                let p = g.point(ijk);
                for c in 0..3 {
                    if c == a {
                        assert!(x[c] >= p[c] && x[c] <= p[c] + g.spacing[c]);
                    } else {
                        assert_eq!(x[c], p[c]);
                    }
                }
                // f_a − f_b vanishes there (linear interpolation), unless clamped.
                let q = idx + nets.stride(a);
                let (la, lb) = (labels[idx] as usize, labels[q] as usize);
                let t = (x[a] - p[a]) / g.spacing[a];
                let gp = f[la][idx] as f64 - f[lb][idx] as f64;
                let gq = f[la][q] as f64 - f[lb][q] as f64;
                assert!(gp >= 0.0 && gq <= 0.0);
                assert!((gp + t * (gq - gp)).abs() < 1e-9);
            }
        }
        assert!(crossings > 50);
        let meshes = reconstruct(&g, &labels, &f);
        // Crack-free in the union sense even for noise.
        for (&(a, b), &count) in &union_edges(&meshes) {
            if count < 2 {
                assert!(on_boundary(&g, a.map(f64::from_bits)));
                assert!(on_boundary(&g, b.map(f64::from_bits)));
            }
        }
        // Sorted pairs, each with triangles.
        assert!(meshes.windows(2).all(|w| w[0].pair < w[1].pair));
        assert!(meshes
            .iter()
            .all(|m| !m.triangles.is_empty() && m.pair.0 < m.pair.1));
    }

    #[test]
    fn crossing_parameter_is_clamped() {
        assert_eq!(crossing_parameter(1.0, -1.0), 0.5);
        assert_eq!(crossing_parameter(0.0, 0.0), 0.5);
        assert_eq!(crossing_parameter(0.0, -1.0), 0.0);
        assert_eq!(crossing_parameter(-1.0, -2.0), 0.0);
        assert_eq!(crossing_parameter(3.0, 1.0), 1.0);
        assert!((crossing_parameter(1.0, -3.0) - 0.25).abs() < 1e-15);
    }
}
