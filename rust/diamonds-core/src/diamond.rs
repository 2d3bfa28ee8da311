//! Implicit diamond encoding (Weiss & De Floriani §4, Eq. 1; Gregorski §3.1–3.2, §7).
//!
//! A diamond is the cluster of LEB tetrahedra sharing a *spine* (split edge); it is identified by the
//! spine's midpoint, its *central vertex* `c`. Everything else follows from the bits of `c`:
//!
//! - **scale** `s = 2^σ`, `σ` = the fewest trailing zeros among `c`'s coordinates;
//! - **class** (Gregorski's phase/type): the number of coordinates of `c / s` that are odd —
//!   3 odd: a *0-diamond* (cube of side `2s` centred at `c`, 6 tetrahedra around a main diagonal),
//!   2 odd: a *1-diamond* (4 tetrahedra around a face diagonal, `c` a face centre),
//!   1 odd: a *2-diamond* (8 tetrahedra around a cube edge, `c` an edge midpoint);
//! - **orientation** from bit `σ + 1` (the "next two bits" of Eq. 1): a 0-diamond's spine joins the cube
//!   corner whose coordinates are all even multiples of `2s` to the one whose coordinates are all odd
//!   multiples; a 1-diamond's spine is the face diagonal through the face corner whose in-face coordinates
//!   have the parity (in units of `2s`) of the face's normal coordinate. This reproduces the LEB refinement
//!   of the base cube split into 6 tetrahedra around its diagonal `(0,0,0)–(N,N,N)`.
//!
//! Parents and children (Gregorski Table 1) are fixed offsets from `c`, scaled by `s`:
//!
//! | class | tets | parents | children |
//! |---|---|---|---|
//! | 0 | 6 (phase 0, level l) | 3 2-diamonds of level l−1: `E − 2s·e_i·x̂_i` (`E` the even corner) | 6 1-diamonds `c ± s·x̂_i` |
//! | 1 | 4 (phase 1, level l) | 2 0-diamonds `c ± s·n̂` (n̂ the face normal) | 4 2-diamonds `c ± s·û`, `c ± s·v̂` |
//! | 2 | 8 (phase 2, level l) | 4 1-diamonds `c ± s·v̂`, `c ± s·ŵ` | 8 0-diamonds of level l+1 `c + (s/2)(±1,±1,±1)` |
//!
//! Diamonds touching the root cube's boundary keep only their tetrahedra, parents and children inside it.

use crate::lattice::{Lattice, Placement, Tet};
use arrayvec::ArrayVec;
use glam::IVec3;

/// The three similarity classes of diamonds (Gregorski's phases 0, 1, 2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    /// Spine along a cube's main diagonal; 6 tetrahedra.
    Cube = 0,
    /// Spine along a face diagonal; 4 tetrahedra.
    Face = 1,
    /// Spine along a cube edge; 8 tetrahedra.
    Edge = 2,
}

/// A diamond, identified by its central vertex.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Diamond {
    pub center: IVec3,
}

const AXES: [IVec3; 3] = [IVec3::X, IVec3::Y, IVec3::Z];

impl Diamond {
    /// The diamond with the given central vertex.
    #[inline]
    pub const fn new(center: IVec3) -> Self {
        Self { center }
    }

    /// The root diamond: the base cube split into 6 tetrahedra around `(0,0,0)–(N,N,N)`.
    pub fn root(lattice: &Lattice) -> Self {
        Self::new(IVec3::splat(lattice.size() / 2))
    }

    /// The diamond whose spine is the first edge of `t`, or `None` for a tetrahedron of a unit cube
    /// (its spine's midpoint is not a lattice point: it holds no sample but its vertices and is never split).
    #[inline]
    pub fn of_tet(t: &Tet) -> Option<Self> {
        let twice = t[0] + t[1];
        ((twice & IVec3::ONE) == IVec3::ZERO).then(|| Self::new(twice / 2))
    }

    /// `σ`: trailing zeros shared by all coordinates of the central vertex (not defined for the origin,
    /// a root corner and no diamond).
    #[inline]
    pub fn sigma(self) -> u32 {
        debug_assert_ne!(
            self.center,
            IVec3::ZERO,
            "the origin is not a central vertex"
        );
        let c = self.center;
        ((c.x | c.y | c.z) as u32).trailing_zeros()
    }

    /// Scale `s = 2^σ`: half the side of the cube the diamond is built on.
    #[inline]
    pub fn scale(self) -> i32 {
        1 << self.sigma()
    }

    /// Similarity class, from the number of odd coordinates of `c / s`.
    #[inline]
    pub fn class(self) -> Class {
        let c = self.center >> IVec3::splat(self.sigma() as i32);
        match (c & IVec3::ONE).element_sum() {
            3 => Class::Cube,
            2 => Class::Face,
            _ => Class::Edge,
        }
    }

    /// Gregorski's level: the root is level 0; every three bisections add one.
    #[inline]
    pub fn level(self, lattice: &Lattice) -> u32 {
        lattice.levels - 1 - self.sigma()
    }

    /// Bisection depth of this diamond's tetrahedra (Gregorski's refinement level `3·level + phase`).
    #[inline]
    pub fn depth(self, lattice: &Lattice) -> u32 {
        3 * self.level(lattice) + self.class() as u32
    }

    /// True for the finest diamonds, whose children would have a non-integer central vertex.
    #[inline]
    pub fn is_finest(self) -> bool {
        self.class() == Class::Edge && self.sigma() == 0
    }

    /// Per-axis sign choosing the corner `c + s·sign` whose coordinate, in units of `2s`, has `parity`.
    #[inline]
    fn corner_sign(self, axis: usize, parity: i32) -> i32 {
        // c_a / s = 2m + 1; (c_a + s) / 2s = m + 1 and (c_a - s) / 2s = m.
        let m = self.center[axis] >> (self.sigma() + 1);
        if (m + 1) & 1 == parity {
            1
        } else {
            -1
        }
    }

    /// The two endpoints of the spine. For a 0-diamond the first one is the *even corner*.
    pub fn spine(self) -> [IVec3; 2] {
        let c = self.center;
        let s = self.scale();
        let h = match self.class() {
            Class::Cube => {
                IVec3::new(
                    self.corner_sign(0, 0),
                    self.corner_sign(1, 0),
                    self.corner_sign(2, 0),
                ) * s
            }
            Class::Face => {
                let (i, j, k) = self.face_axes();
                let parity = (c[k] >> (self.sigma() + 1)) & 1;
                AXES[i] * (s * self.corner_sign(i, parity))
                    + AXES[j] * (s * self.corner_sign(j, parity))
            }
            Class::Edge => AXES[self.edge_axes().0] * s,
        };
        [c + h, c - h]
    }

    /// For a 1-diamond: the two in-face axes (odd) and the normal axis (even).
    #[inline]
    pub(crate) fn face_axes(self) -> (usize, usize, usize) {
        let odd = (self.center >> IVec3::splat(self.sigma() as i32)) & IVec3::ONE;
        match (odd.x, odd.y, odd.z) {
            (0, _, _) => (1, 2, 0),
            (_, 0, _) => (0, 2, 1),
            _ => (0, 1, 2),
        }
    }

    /// For a 2-diamond: the spine axis (odd) and the two other axes (even).
    #[inline]
    fn edge_axes(self) -> (usize, usize, usize) {
        let odd = (self.center >> IVec3::splat(self.sigma() as i32)) & IVec3::ONE;
        match (odd.x, odd.y, odd.z) {
            (1, _, _) => (0, 1, 2),
            (_, 1, _) => (1, 0, 2),
            _ => (2, 0, 1),
        }
    }

    /// All tetrahedra of the diamond inside the root cube, spine first.
    pub fn tets(self, lattice: &Lattice) -> ArrayVec<Tet, 8> {
        let c = self.center;
        let s = self.scale();
        let [a, b] = self.spine();
        let mut out = ArrayVec::new();
        match self.class() {
            Class::Cube => {
                // Freudenthal/Kuhn split of the cube around the diagonal a–b: paths a → a+u_i → a+u_i+u_j → b.
                let d = (b - a) / 2; // per-axis signed side, ±s
                for (i, j) in [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)] {
                    let p = a + AXES[i] * (2 * d[i]);
                    let q = p + AXES[j] * (2 * d[j]);
                    out.push([a, b, p, q]);
                }
            }
            Class::Face => {
                let (_, j, k) = self.face_axes();
                let mut h = a - c;
                h[j] = -h[j];
                let others = [c + h, c - h];
                for cube in [c + AXES[k] * s, c - AXES[k] * s] {
                    for &o in &others {
                        out.push([a, b, o, cube]);
                    }
                }
            }
            Class::Edge => {
                let (_, j, k) = self.edge_axes();
                for sj in [s, -s] {
                    for sk in [s, -s] {
                        let fj = c + AXES[j] * sj;
                        let fk = c + AXES[k] * sk;
                        let cube = fj + AXES[k] * sk;
                        out.push([a, b, fj, cube]);
                        out.push([a, b, fk, cube]);
                    }
                }
            }
        }
        out.retain(|t| t.iter().all(|&p| lattice.in_root(p)));
        out
    }

    /// Parent diamonds inside the root cube (none for the root).
    pub fn parents(self, lattice: &Lattice) -> ArrayVec<Diamond, 4> {
        let c = self.center;
        let s = self.scale();
        let mut out = ArrayVec::new();
        if self == Self::root(lattice) {
            return out;
        }
        match self.class() {
            Class::Cube => {
                let [even, odd] = self.spine();
                let toward_odd = (odd - even) / 2; // ±s per axis
                for (a, axis) in AXES.iter().enumerate() {
                    out.push(Self::new(even + *axis * (2 * toward_odd[a])));
                }
            }
            Class::Face => {
                let (_, _, k) = self.face_axes();
                out.push(Self::new(c + AXES[k] * s));
                out.push(Self::new(c - AXES[k] * s));
            }
            Class::Edge => {
                let (_, j, k) = self.edge_axes();
                for axis in [AXES[j], AXES[k]] {
                    out.push(Self::new(c + axis * s));
                    out.push(Self::new(c - axis * s));
                }
            }
        }
        out.retain(|d| lattice.in_root(d.center));
        out
    }

    /// Child diamonds inside the root cube (none for the finest diamonds).
    pub fn children(self, lattice: &Lattice) -> ArrayVec<Diamond, 8> {
        let c = self.center;
        let s = self.scale();
        let mut out = ArrayVec::new();
        match self.class() {
            Class::Cube => {
                for axis in AXES {
                    out.push(Self::new(c + axis * s));
                    out.push(Self::new(c - axis * s));
                }
            }
            Class::Face => {
                let (i, j, _) = self.face_axes();
                for axis in [AXES[i], AXES[j]] {
                    out.push(Self::new(c + axis * s));
                    out.push(Self::new(c - axis * s));
                }
            }
            Class::Edge => {
                if s > 1 {
                    let h = s / 2;
                    for sx in [h, -h] {
                        for sy in [h, -h] {
                            for sz in [h, -h] {
                                out.push(Self::new(c + IVec3::new(sx, sy, sz)));
                            }
                        }
                    }
                }
            }
        }
        out.retain(|d| lattice.in_root(d.center));
        out
    }

    /// Axis-aligned bounds of the diamond: `c ± s` for every class.
    #[inline]
    pub fn bounds(self) -> (IVec3, IVec3) {
        let s = IVec3::splat(self.scale());
        (self.center - s, self.center + s)
    }

    /// The longest edge of the diamond's tetrahedra, the same for all of them, for a grid `spacing`:
    /// the spine, or the edge from a spine end to the cube centre `c ± s` (a 1- or 2-diamond's
    /// tetrahedra have one, the other edges are shorter than either).
    pub fn tet_size(self, spacing: [f64; 3]) -> f64 {
        let s = self.scale() as f64;
        let w = glam::DVec3::from(spacing);
        let [a, b] = self.spine();
        let spine = ((b - a).as_dvec3() * w).length();
        match self.class() {
            Class::Cube => spine,
            Class::Face | Class::Edge => spine.max(s * w.length()),
        }
    }

    /// The bounding boxes of the diamond's tetrahedra inside the root cube, each with the number of
    /// tetrahedra it bounds, without building them: a 0-diamond's six span its cube; a 1-diamond's
    /// span the face along its spine and one half of the cube across it (two per half); a
    /// 2-diamond's span the edge along its spine and one quarter of the cube around it (two per
    /// quarter). Each is exactly the box of its tetrahedra: they hold the spine and a vertex at the
    /// far side of their half or quarter ([`Diamond::tets`]).
    pub fn tet_boxes(self, lattice: &Lattice) -> ArrayVec<(IVec3, IVec3, usize), 4> {
        let (lo, hi) = self.bounds();
        let c = self.center;
        let mut out = ArrayVec::new();
        match self.class() {
            Class::Cube => out.push((lo, hi, 6)),
            Class::Face => {
                let (_, _, k) = self.face_axes();
                let (mut below, mut above) = (hi, lo);
                below[k] = c[k];
                above[k] = c[k];
                out.push((lo, below, 2));
                out.push((above, hi, 2));
            }
            Class::Edge => {
                let (_, j, k) = self.edge_axes();
                for low_j in [true, false] {
                    for low_k in [true, false] {
                        let (mut a, mut b) = (lo, hi);
                        for (axis, low) in [(j, low_j), (k, low_k)] {
                            if low {
                                b[axis] = c[axis];
                            } else {
                                a[axis] = c[axis];
                            }
                        }
                        out.push((a, b, 2));
                    }
                }
            }
        }
        out.retain(|(a, b, _)| lattice.in_root(*a) && lattice.in_root(*b));
        out
    }

    /// Where the diamond lies relative to the domain box (Gregorski §7, "virtual grid"): the worst
    /// placement of its tetrahedra ([`Lattice::place_box`] of each of [`Diamond::tet_boxes`]).
    pub fn placement(self, lattice: &Lattice) -> Placement {
        let mut any_inside = false;
        for (lo, hi, _) in self.tet_boxes(lattice) {
            match lattice.place_box(lo, hi) {
                Placement::Straddling => return Placement::Straddling,
                Placement::Inside => any_inside = true,
                Placement::Outside => {}
            }
        }
        if any_inside {
            Placement::Inside
        } else {
            Placement::Outside
        }
    }
}

/// Bisects `t` at the midpoint `m` of its spine.
///
/// Tetrahedra keep a vertex order from which each child's spine follows without measuring edges:
/// a 0-class tet `[a, b, p, q]` (spine a cube diagonal, path `a → p → q → b` along cube edges),
/// a 1-class tet `[x, y, w, c]` (spine a face diagonal, `w` the third face corner, `c` the cube centre),
/// a 2-class tet `[p, q, f, c]` (spine a cube edge, `f` a face centre, `c` the cube centre).
/// [`Diamond::tets`] lists tetrahedra in this order, and bisection preserves it (Gregorski Fig. 1):
/// 0 → 1: `[a, q, p, m]`, `[b, p, q, m]`; 1 → 2: `[x, w, m, c]`, `[y, w, m, c]`;
/// 2 → 0 of the next level: `[p, c, m, f]`, `[q, c, m, f]`.
///
/// The children are spelled out per spine class ([`child_layout`]'s table, the class told once):
/// the walks that write a mesh bisect every tetrahedron above its leaves, and the generic
/// [`child_of`] (layout looked up twice, vertices picked by index) cost twice as many instructions.
#[inline]
pub fn bisect(t: &Tet) -> [Tet; 2] {
    let [a, b, c, d] = *t;
    let m = (a + b) / 2;
    match (b - a).cmpne(IVec3::ZERO).bitmask().count_ones() {
        3 => [[a, d, c, m], [b, c, d, m]],
        2 => [[a, c, m, d], [b, c, m, d]],
        _ => [[a, d, m, c], [b, d, m, c]],
    }
}

/// Where the vertices of `t`'s child (`first` or second, [`bisect`]'s order) come from: the child is
/// `[t_k, t_a, t_b, t_b]` with the spine's midpoint at position `at_m` (`k` = 0 for the first child).
/// Cube diagonal: `[t_k, t_3, t_2, m]` (first), `[t_k, t_2, t_3, m]`; face diagonal `[t_k, t_2, m, t_3]`;
/// cube edge `[t_k, t_3, m, t_2]`.
#[inline]
pub(crate) fn child_layout(t: &Tet, first: bool) -> (usize, usize, usize) {
    match (t[1] - t[0]).cmpne(IVec3::ZERO).bitmask().count_ones() {
        3 if first => (3, 2, 3),
        3 => (2, 3, 3),
        2 => (2, 3, 2),
        _ => (3, 2, 2),
    }
}

/// The child's version of a per-vertex quantity `x` of its parent, for a child `layout`
/// ([`child_layout`]): `kept` for the kept spine end, `mid` for the spine's midpoint.
#[inline]
pub(crate) fn arrange<X: Copy>(
    layout: (usize, usize, usize),
    x: [X; 4],
    kept: X,
    mid: X,
) -> [X; 4] {
    let (a, b, at_m) = layout;
    let mut out = [kept, x[a], x[b], x[b]];
    out[at_m] = mid;
    out
}

/// [`arrange`] for `t`'s first or second child.
#[inline]
pub(crate) fn child_of<X: Copy>(t: &Tet, first: bool, x: [X; 4], kept: X, mid: X) -> [X; 4] {
    arrange(child_layout(t, first), x, kept, mid)
}

/// Six times the signed volume of `t` (exact).
#[inline]
pub fn signed_volume6(t: &Tet) -> i64 {
    let e = |p: IVec3| p.as_i64vec3() - t[0].as_i64vec3();
    e(t[1]).dot(e(t[2]).cross(e(t[3])))
}

/// Every diamond of the hierarchy over `lattice`, reached from the root through children (for tests).
#[cfg(test)]
pub(crate) fn all_diamonds(lattice: &Lattice) -> Vec<Diamond> {
    let mut seen = std::collections::HashSet::new();
    let mut stack = vec![Diamond::root(lattice)];
    while let Some(d) = stack.pop() {
        if seen.insert(d) {
            stack.extend(d.children(lattice));
        }
    }
    seen.into_iter().collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::{HashMap, HashSet};

    fn lattice(n: usize) -> Lattice {
        Lattice::new([n + 1; 3]).unwrap()
    }

    fn key(t: &Tet) -> [IVec3; 4] {
        let mut k = *t;
        k.sort_by_key(|p| (p.x, p.y, p.z));
        k
    }

    #[test]
    fn root_is_the_base_cube_in_six_tets() {
        let l = lattice(8);
        let root = Diamond::root(&l);
        assert_eq!(root.class(), Class::Cube);
        assert_eq!(root.level(&l), 0);
        assert_eq!(root.spine(), [IVec3::ZERO, IVec3::splat(8)]);
        let tets = root.tets(&l);
        assert_eq!(tets.len(), 6);
        let v: i64 = tets.iter().map(|t| signed_volume6(t).abs()).sum();
        assert_eq!(v, 6 * 8 * 8 * 8);
    }

    #[test]
    fn every_lattice_point_but_the_corners_is_one_diamond() {
        for n in [2, 4, 8, 16] {
            let l = lattice(n);
            let ds = all_diamonds(&l);
            assert_eq!(ds.len(), (n + 1).pow(3) - 8, "N = {n}");
        }
    }

    #[test]
    fn tet_size_is_the_longest_edge_of_every_tetrahedron() {
        let l = lattice(16);
        for spacing in [
            [1.0, 1.0, 1.0],
            [0.5, 2.0, 3.5],
            [4.0, 0.25, 1.0],
            [1.0, 1.0, 9.0],
        ] {
            let w = glam::DVec3::from(spacing);
            for d in all_diamonds(&l) {
                for t in d.tets(&l) {
                    let longest = (0..4)
                        .flat_map(|i| (i + 1..4).map(move |j| (i, j)))
                        .map(|(i, j)| ((t[i] - t[j]).as_dvec3() * w).length())
                        .fold(0.0, f64::max);
                    let size = d.tet_size(spacing);
                    assert!(
                        (size - longest).abs() <= 1e-12 * longest,
                        "{d:?} {t:?} {spacing:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn tet_boxes_bound_the_tetrahedra_exactly() {
        // Every tetrahedron's bounding box is one of the boxes, which count them, and placements
        // from the boxes equal those from the tetrahedra on domains with straddling far faces.
        let l = lattice(16);
        for d in all_diamonds(&l) {
            let mut boxes: Vec<_> = d
                .tets(&l)
                .iter()
                .map(|t| {
                    let lo = t[0].min(t[1]).min(t[2].min(t[3]));
                    let hi = t[0].max(t[1]).max(t[2].max(t[3]));
                    (lo.to_array(), hi.to_array())
                })
                .collect();
            let mut expected: Vec<_> = d
                .tet_boxes(&l)
                .iter()
                .flat_map(|&(lo, hi, n)| std::iter::repeat_n((lo.to_array(), hi.to_array()), n))
                .collect();
            boxes.sort();
            expected.sort();
            assert_eq!(boxes, expected, "{d:?}");
            for dims in [[17, 17, 17], [12, 17, 9], [10, 6, 15], [16, 16, 16]] {
                let domain = Lattice::new(dims).unwrap();
                let by_tets = d
                    .tets(&l)
                    .iter()
                    .map(|t| domain.place(t))
                    .collect::<Vec<_>>();
                let by_boxes = d
                    .tet_boxes(&l)
                    .iter()
                    .map(|&(lo, hi, _)| domain.place_box(lo, hi))
                    .collect::<Vec<_>>();
                for p in [Placement::Inside, Placement::Outside, Placement::Straddling] {
                    let n_tets = by_tets.iter().filter(|&&q| q == p).count();
                    let n_boxes: usize = d
                        .tet_boxes(&l)
                        .iter()
                        .zip(&by_boxes)
                        .filter(|(_, &q)| q == p)
                        .map(|(b, _)| b.2)
                        .sum();
                    assert_eq!(n_tets, n_boxes, "{d:?} in {dims:?}, {p:?}");
                }
            }
        }
    }

    #[test]
    fn table_1_counts_levels_and_phases() {
        let l = lattice(16);
        for d in all_diamonds(&l) {
            let (tets, parents, children) = match d.class() {
                Class::Cube => (6, 3, 6),
                Class::Face => (4, 2, 4),
                Class::Edge => (8, 4, if d.is_finest() { 0 } else { 8 }),
            };
            let interior =
                d.bounds().0.cmpgt(IVec3::ZERO).all() && d.bounds().1.cmplt(IVec3::splat(16)).all();
            if interior {
                assert_eq!(d.tets(&l).len(), tets, "{d:?}");
                assert_eq!(d.children(&l).len(), children, "{d:?}");
                if d != Diamond::root(&l) {
                    assert_eq!(d.parents(&l).len(), parents, "{d:?}");
                }
            }
            for p in d.parents(&l) {
                // Table 1: parent phase is one less (mod 3); a 0-diamond's parents are one level up.
                assert_eq!(
                    (p.class() as u32 + 1) % 3,
                    d.class() as u32,
                    "{d:?} ← {p:?}"
                );
                assert_eq!(p.depth(&l) + 1, d.depth(&l), "{d:?} ← {p:?}");
            }
        }
    }

    #[test]
    fn parent_and_child_relations_are_mutual() {
        let l = lattice(16);
        for d in all_diamonds(&l) {
            for c in d.children(&l) {
                assert!(c.parents(&l).contains(&d), "{c:?} does not list {d:?}");
            }
            for p in d.parents(&l) {
                assert!(p.children(&l).contains(&d), "{p:?} does not list {d:?}");
            }
        }
    }

    #[test]
    fn each_tet_bisects_into_two_tets_of_its_children() {
        let l = lattice(16);
        for d in all_diamonds(&l) {
            if d.is_finest() {
                continue;
            }
            let children: HashMap<Diamond, HashSet<[IVec3; 4]>> = d
                .children(&l)
                .into_iter()
                .map(|c| (c, c.tets(&l).iter().map(key).collect()))
                .collect();
            for t in d.tets(&l) {
                assert_eq!(Diamond::of_tet(&t), Some(d));
                let [t0, t1] = bisect(&t);
                // The two children partition the parent exactly.
                assert_eq!(
                    signed_volume6(&t0).abs() + signed_volume6(&t1).abs(),
                    signed_volume6(&t).abs()
                );
                assert_ne!(signed_volume6(&t0), 0);
                for child in [t0, t1] {
                    let Some(cd) = Diamond::of_tet(&child) else {
                        assert!(d.is_finest(), "{child:?} of {d:?} is a unit-cube tet");
                        continue;
                    };
                    let tets = children
                        .get(&cd)
                        .unwrap_or_else(|| panic!("{cd:?} not a child of {d:?}"));
                    assert!(tets.contains(&key(&child)), "{child:?} not in {cd:?}");
                }
            }
        }
    }

    #[test]
    fn bisect_orders_the_children_as_the_generic_layout() {
        // Every walk relies on the vertex order of `bisect`'s children; the isosurface walks build
        // children through `child_of` (the same layout, looked up): both agree on every tetrahedron.
        let l = lattice(16);
        for d in all_diamonds(&l) {
            for t in d.tets(&l) {
                let m = (t[0] + t[1]) / 2;
                let generic = [
                    child_of(&t, true, t, t[0], m),
                    child_of(&t, false, t, t[1], m),
                ];
                assert_eq!(bisect(&t), generic, "{t:?}");
            }
        }
    }

    #[test]
    fn full_refinement_tiles_the_cube_conformingly() {
        // Bisect the base tets down to the finest level: 6 tets per unit cube, every interior face shared twice.
        let n = 8;
        let l = lattice(n);
        let mut tets: Vec<Tet> = Diamond::root(&l).tets(&l).to_vec();
        for _ in 0..3 * l.levels {
            tets = tets.iter().flat_map(bisect).collect();
            // The vertex order names each tet's spine: it must be the unique longest edge.
            for t in &tets {
                let spine = (t[0] - t[1]).length_squared();
                for (a, b) in [(0, 2), (0, 3), (1, 2), (1, 3), (2, 3)] {
                    assert!((t[a] - t[b]).length_squared() < spine, "{t:?}");
                }
            }
        }
        assert_eq!(tets.len(), 6 * n * n * n);
        let mut faces: HashMap<[IVec3; 3], usize> = HashMap::new();
        for t in &tets {
            for skip in 0..4 {
                let mut f: Vec<IVec3> = (0..4).filter(|&i| i != skip).map(|i| t[i]).collect();
                f.sort_by_key(|p| (p.x, p.y, p.z));
                *faces.entry([f[0], f[1], f[2]]).or_default() += 1;
            }
        }
        for (f, count) in faces {
            let on_boundary =
                (0..3).any(|a| f.iter().all(|p| p[a] == 0) || f.iter().all(|p| p[a] == n as i32));
            assert_eq!(count, if on_boundary { 1 } else { 2 }, "{f:?}");
        }
    }
}
