//! Approximated interfaces and plane cuts drawn from a [`MaterialMesh`] (Gregorski et al. 2002, §5.2.1
//! and §5.5, Figures 11, 15, 16).
//!
//! Inside a tetrahedron the material at a point is the one with the smallest linearly interpolated
//! signed distance `φ_m`. The interface between `a` and `b` is the polygon `{φ_a = φ_b}` clipped to
//! `{φ_a ≤ φ_c}` for every other material `c`; a cut by a plane is split the same way into one polygon
//! per material. Every polygon vertex lies on a *carrier* (an edge, a face or the inside of the
//! tetrahedron) and satisfies a set of equalities; it is computed from the carrier's vertex values
//! alone and identified by (carrier, equalities), so neighbouring tetrahedra produce the same point and
//! the polygons are crack-free, junctions of three or four materials included.

use super::model::WorldTet;
use super::{MaterialMesh, PolygonMesh};
use crate::geometry::{bounds_of, NearPoints};
use crate::{Error, Result};
use arrayvec::ArrayVec;
use glam::DVec3;
use rustc_hash::FxHashMap;

/// A polygon vertex: barycentric coordinates over its carrier (mesh point ids, ascending) and the
/// equalities it satisfies: the materials whose `φ` agree there, and whether it lies on the cut plane.
#[derive(Clone, Debug)]
struct PolyPoint {
    carrier: ArrayVec<u32, 4>,
    lambda: ArrayVec<f64, 4>,
    tied: u32,
    plane: bool,
}

/// The identity of a polygon vertex: carrier (padded), equalities and, for cuts, the owning material.
type Key = ([u32; 4], u32, bool, u8);

impl PolyPoint {
    fn key(&self, owner: u8) -> Key {
        let mut c = [u32::MAX; 4];
        c[..self.carrier.len()].copy_from_slice(&self.carrier);
        (c, self.tied, self.plane, owner)
    }

    /// Interpolates per-point values `f` at this point.
    fn eval(&self, f: &dyn Fn(u32) -> f64) -> f64 {
        self.carrier
            .iter()
            .zip(&self.lambda)
            .map(|(&p, &l)| l * f(p))
            .sum()
    }
}

/// The linear functions of one tetrahedron: `φ_m` per material and the cut plane's signed distance.
struct Functions<'a> {
    mesh: &'a MaterialMesh,
    plane: Option<(DVec3, DVec3)>,
}

impl Functions<'_> {
    fn phi(&self, m: usize, p: u32) -> f64 {
        self.mesh.material_distance[m][p as usize] as f64
    }

    fn plane(&self, p: u32) -> f64 {
        let (o, n) = self.plane.expect("a cut plane");
        n.dot(DVec3::from_array(self.mesh.points[p as usize]) - o)
    }

    /// The rows `r(p) = 0` a point with these equalities satisfies.
    fn rows(&self, tied: u32, plane: bool) -> ArrayVec<Box<dyn Fn(u32) -> f64 + '_>, 4> {
        let mut rows: ArrayVec<Box<dyn Fn(u32) -> f64 + '_>, 4> = ArrayVec::new();
        let mut set = (0..32).filter(|m| tied & (1 << m) != 0);
        if let Some(first) = set.next() {
            for m in set {
                if rows.is_full() {
                    break;
                }
                rows.push(Box::new(move |p| self.phi(first, p) - self.phi(m, p)));
            }
        }
        if plane && !rows.is_full() {
            rows.push(Box::new(|p| self.plane(p)));
        }
        rows
    }

    /// The point on `carrier` satisfying `tied`/`plane`, when these determine it (as many equalities
    /// as the carrier has dimensions); computed from the carrier's values only.
    fn solve(&self, carrier: &[u32], tied: u32, plane: bool) -> Option<ArrayVec<f64, 4>> {
        let rows = self.rows(tied, plane);
        let k = carrier.len();
        if rows.len() + 1 != k {
            return None;
        }
        // [rows; 1 … 1] λ = [0 … 0, 1], by Gaussian elimination with partial pivoting.
        let mut a = [[0.0f64; 5]; 4];
        for (r, row) in rows.iter().enumerate() {
            for (c, &p) in carrier.iter().enumerate() {
                a[r][c] = row(p);
            }
        }
        a[k - 1][..=k].fill(1.0);
        for col in 0..k {
            let pivot = (col..k).max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs()))?;
            if a[pivot][col].abs() < 1e-30 {
                return None;
            }
            a.swap(col, pivot);
            let pivot_row = a[col];
            for (r, row) in a.iter_mut().enumerate().take(k) {
                if r != col {
                    let f = row[col] / pivot_row[col];
                    for (v, p) in row[col..=k].iter_mut().zip(&pivot_row[col..=k]) {
                        *v -= f * p;
                    }
                }
            }
        }
        let lambda: ArrayVec<f64, 4> = (0..k)
            .map(|c| (a[c][k] / a[c][c]).clamp(0.0, 1.0))
            .collect();
        let sum: f64 = lambda.iter().sum();
        Some(lambda.into_iter().map(|l| l / sum).collect())
    }

    /// The point where `h` vanishes between `p` (h ≤ 0) and `q` (h > 0), with `extra` added to the
    /// equalities both share.
    fn cut(&self, p: &PolyPoint, q: &PolyPoint, h: &dyn Fn(u32) -> f64, extra: u32) -> PolyPoint {
        // Canonical order, so that both tetrahedra sharing the segment compute the same point.
        let (p, q) = if p.key(0) <= q.key(0) { (p, q) } else { (q, p) };
        let mut carrier: ArrayVec<u32, 4> = p.carrier.clone();
        for &c in &q.carrier {
            if !carrier.contains(&c) {
                carrier.push(c);
            }
        }
        carrier.sort_unstable();
        let tied = (p.tied & q.tied) | extra;
        let plane = p.plane && q.plane;
        let lambda = self.solve(&carrier, tied, plane).unwrap_or_else(|| {
            let (hp, hq) = (p.eval(h), q.eval(h));
            let t = if hp != hq { hp / (hp - hq) } else { 0.5 };
            carrier
                .iter()
                .map(|c| {
                    let at = |x: &PolyPoint| {
                        x.carrier
                            .iter()
                            .position(|y| y == c)
                            .map_or(0.0, |i| x.lambda[i])
                    };
                    (1.0 - t) * at(p) + t * at(q)
                })
                .collect()
        });
        PolyPoint {
            carrier,
            lambda,
            tied,
            plane,
        }
    }

    /// The polygon `{g = 0}` of tetrahedron `t` (marching tetrahedra), or `None`; points satisfy
    /// `tied`/`plane`. Vertices with `g ≤ 0` are on the negative side.
    fn section(
        &self,
        t: &[u32; 4],
        g: &dyn Fn(u32) -> f64,
        tied: u32,
        plane: bool,
    ) -> Option<Vec<PolyPoint>> {
        let neg: ArrayVec<usize, 4> = (0..4).filter(|&i| g(t[i]) <= 0.0).collect();
        let pos: ArrayVec<usize, 4> = (0..4).filter(|&i| g(t[i]) > 0.0).collect();
        let edges: ArrayVec<(usize, usize), 4> = match (neg.len(), pos.len()) {
            (1, 3) => pos.iter().map(|&j| (neg[0], j)).collect(),
            (3, 1) => neg.iter().map(|&j| (j, pos[0])).collect(),
            (2, 2) => [
                (neg[0], pos[0]),
                (neg[0], pos[1]),
                (neg[1], pos[1]),
                (neg[1], pos[0]),
            ]
            .into_iter()
            .collect(),
            _ => return None,
        };
        let points = edges
            .iter()
            .map(|&(u, v)| {
                let mut carrier: ArrayVec<u32, 4> = [t[u], t[v]].into_iter().collect();
                carrier.sort_unstable();
                let lambda = self.solve(&carrier, tied, plane).unwrap_or_else(|| {
                    let (gu, gv) = (g(carrier[0]), g(carrier[1]));
                    let s = gu / (gu - gv);
                    [1.0 - s, s].into_iter().collect()
                });
                PolyPoint {
                    carrier,
                    lambda,
                    tied,
                    plane,
                }
            })
            .collect();
        Some(points)
    }

    /// Keeps the part of `poly` where `h ≤ 0` (Sutherland–Hodgman); new points gain `extra`.
    fn clip(&self, poly: Vec<PolyPoint>, h: &dyn Fn(u32) -> f64, extra: u32) -> Vec<PolyPoint> {
        let values: Vec<f64> = poly.iter().map(|p| p.eval(h)).collect();
        if values.iter().all(|&v| v <= 0.0) {
            return poly;
        }
        let mut out = Vec::with_capacity(poly.len() + 1);
        for i in 0..poly.len() {
            let j = (i + 1) % poly.len();
            let (a, b) = (&poly[i], &poly[j]);
            let (ha, hb) = (values[i], values[j]);
            if ha <= 0.0 {
                out.push(a.clone());
                if hb > 0.0 {
                    out.push(self.cut(a, b, h, extra));
                }
            } else if hb <= 0.0 {
                out.push(self.cut(b, a, h, extra));
            }
        }
        out
    }

    fn position(&self, p: &PolyPoint) -> DVec3 {
        p.carrier
            .iter()
            .zip(&p.lambda)
            .map(|(&c, &l)| l * DVec3::from_array(self.mesh.points[c as usize]))
            .sum()
    }

    /// Reverses `poly` unless its normal (Newell) points along `direction`.
    fn orient(&self, poly: &mut [PolyPoint], direction: DVec3) {
        let x: Vec<DVec3> = poly.iter().map(|p| self.position(p)).collect();
        let normal: DVec3 = (0..x.len()).map(|i| x[i].cross(x[(i + 1) % x.len()])).sum();
        if normal.dot(direction) < 0.0 {
            poly.reverse();
        }
    }

    /// Gradient of the linear function with values `g` on tetrahedron `t`.
    fn gradient(&self, t: &[u32; 4], g: &dyn Fn(u32) -> f64) -> DVec3 {
        WorldTet::new(t.map(|p| DVec3::from_array(self.mesh.points[p as usize]))).gradient(t.map(g))
    }
}

/// Accumulates deduplicated polygons: one point per identity ([`Key`]) and per position and owner
/// (identities that meet at one position, as equalities holding at a mesh vertex reached through
/// different carriers, share the point; positions computed through different carriers differ by a
/// few ulps, so "one position" is up to [`NearPoints`]), no repeated consecutive corners. (Until session
/// 32 positions were compared bit for bit: a junction on the box's edge gave two points 1 ulp apart
/// and a polygon edge of that length.)
struct Builder {
    out: PolygonMesh,
    ids: FxHashMap<Key, u32>,
    at: NearPoints<u8>,
    corners: Vec<u32>,
}

impl Builder {
    fn new(mesh: &MaterialMesh) -> Self {
        let mut out = PolygonMesh::default();
        out.offsets.push(0);
        Self {
            out,
            ids: FxHashMap::default(),
            at: NearPoints::within(&bounds_of(&mesh.points)),
            corners: Vec::new(),
        }
    }

    fn push(&mut self, f: &Functions<'_>, poly: &[PolyPoint], label: [u8; 2], owner: u8) {
        let mesh = f.mesh;
        self.corners.clear();
        for p in poly {
            let id = match self.ids.get(&p.key(owner)) {
                Some(&id) => id,
                None => {
                    let x = f.position(p);
                    let next = self.out.points.len() as u32;
                    let id = self.at.merge(x, owner, next);
                    if id == next {
                        self.out.points.push(x.to_array());
                        for (field, column) in self.out.values.iter_mut().enumerate() {
                            let v = if owner == u8::MAX {
                                p.eval(&|c| mesh.mixed[field][c as usize] as f64)
                            } else {
                                let column = field * mesh.materials + owner as usize;
                                p.eval(&|c| mesh.material_field[column][c as usize] as f64)
                            };
                            column.push(v as f32);
                        }
                    }
                    self.ids.insert(p.key(owner), id);
                    id
                }
            };
            if self.corners.last() != Some(&id) {
                self.corners.push(id);
            }
        }
        while self.corners.len() > 1 && self.corners.first() == self.corners.last() {
            self.corners.pop();
        }
        if self.corners.len() < 3 {
            return;
        }
        self.out.connectivity.extend_from_slice(&self.corners);
        self.out.offsets.push(self.out.connectivity.len() as u32);
        self.out.labels.push(label);
    }
}

impl MaterialMesh {
    /// The material with the smallest `φ` at mesh point `p` (lowest index on ties).
    fn winner(&self, p: u32) -> usize {
        (0..self.materials)
            .min_by(|&a, &b| {
                self.material_distance[a][p as usize]
                    .total_cmp(&self.material_distance[b][p as usize])
                    .then(a.cmp(&b))
            })
            .unwrap_or(0)
    }

    /// The approximated interfaces: in each tetrahedron the polygons `{φ_a = φ_b ≤ φ_c}`; points on
    /// shared edges and faces are shared, so the result is crack-free. Polygons are oriented from `a`
    /// into `b`.
    pub fn interface_polygons(&self) -> PolygonMesh {
        let f = Functions {
            mesh: self,
            plane: None,
        };
        let mut b = Builder::new(self);
        for t in &self.tets {
            let w = t.map(|p| self.winner(p));
            if w.iter().all(|&x| x == w[0]) {
                continue; // one material throughout: φ_w is the smallest everywhere inside
            }
            for a in 0..self.materials {
                for c in a + 1..self.materials {
                    let g = |p: u32| f.phi(a, p) - f.phi(c, p);
                    let tied = (1 << a) | (1 << c);
                    let Some(mut poly) = f.section(t, &g, tied, false) else {
                        continue;
                    };
                    for o in (0..self.materials).filter(|&o| o != a && o != c) {
                        poly = f.clip(poly, &|p| f.phi(a, p) - f.phi(o, p), 1 << o);
                        if poly.len() < 3 {
                            break;
                        }
                    }
                    if poly.len() >= 3 {
                        f.orient(&mut poly, f.gradient(t, &g));
                        b.push(&f, &poly, [a as u8, c as u8], 0);
                    }
                }
            }
        }
        b.out
    }

    /// The cut of the mesh by the plane through `origin` with `normal`, split at the approximated
    /// interfaces; each polygon carries its material's own field (Figure 16). Without ghost values the
    /// cut is not split and carries the mixed fields.
    pub fn slice(&self, origin: [f64; 3], normal: [f64; 3]) -> Result<PolygonMesh> {
        let (o, n) = (DVec3::from_array(origin), DVec3::from_array(normal));
        // Scaled by its largest component first: the squared length of a normal with components
        // of 1e155 overflows, that of 1e-300 underflows.
        let largest = n.abs().max_element();
        if !o.is_finite() || !n.is_finite() || largest == 0.0 {
            return Err(Error::Parameter(format!(
                "the slice plane needs a finite origin and a non-zero normal (got {origin:?}, {normal:?})"
            )));
        }
        let n = (n / largest).normalize();
        let f = Functions {
            mesh: self,
            plane: Some((o, n)),
        };
        let mut b = Builder::new(self);
        b.out.values = vec![Vec::new(); self.fields];
        let plane = |p: u32| f.plane(p);
        for t in &self.tets {
            let Some(poly) = f.section(t, &plane, 0, true) else {
                continue;
            };
            let w = t.map(|p| self.winner(p));
            if !self.ghost_values {
                let mut poly = poly;
                f.orient(&mut poly, n);
                b.push(&f, &poly, [u8::MAX; 2], u8::MAX);
                continue;
            }
            let single = w.iter().all(|&x| x == w[0]);
            for m in 0..self.materials {
                if single && m != w[0] {
                    continue;
                }
                let mut part = poly.clone();
                if !single {
                    for c in (0..self.materials).filter(|&c| c != m) {
                        part = f.clip(part, &|p| f.phi(m, p) - f.phi(c, p), (1 << m) | (1 << c));
                        if part.len() < 3 {
                            break;
                        }
                    }
                }
                if part.len() >= 3 {
                    f.orient(&mut part, n);
                    b.push(&f, &part, [m as u8; 2], m as u8);
                }
            }
        }
        Ok(b.out)
    }
}
