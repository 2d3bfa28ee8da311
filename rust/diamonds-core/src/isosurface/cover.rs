//! Every point of a triangle within a distance of a surface, from what is known at its corners: the
//! certificate that lets the two-sided bound ([`super::bound`]) hold at every point of both surfaces,
//! not only at samples.
//!
//! The distance to a surface is 1-Lipschitz, and every point of a triangle lies within `ℓ / √3` of
//! one of its corners (`ℓ` its longest edge: the circumradius of an acute triangle is at most that,
//! and an obtuse one's farthest point is on its longest edge). So a triangle is covered when its
//! corners lie within `reach − ℓ / √3` (*Lipschitz*). The distance to a convex set is convex, so a
//! triangle is also covered when its three corners lie within `reach` of one convex *piece* of the
//! surface — the polygon marching tetrahedra draws in one tetrahedron (*convexity*; no margin, so it
//! settles triangles right at the reach when the surfaces run together). A triangle neither settles
//! is cut into four at its edges' midpoints, down to a floor; one still unsettled there, or with a
//! corner beyond `reach`, is a violation. Only triangles near the reach are cut.

use glam::DVec3;

/// The surface whose distance is measured: its exact distances, and its convex pieces.
pub(super) trait Surface {
    /// A convex piece of the surface.
    type Piece: Copy + PartialEq;
    /// The distance from `p` to a piece of the surface at most `enough` away, if one is found
    /// first, and that piece; else the distance from `p` to the surface and a piece at that
    /// distance when it is at most `reach` (≥ `enough`); otherwise a distance above `reach` and
    /// none.
    fn nearest(&self, p: DVec3, enough: f64, reach: f64) -> (f64, Option<Self::Piece>);
    /// The distance from `p` to `piece`.
    fn distance_to(&self, piece: Self::Piece, p: DVec3) -> f64;
    /// Does `test` hold for a piece within `reach` of `p`? (Each such piece is tried until one
    /// does.)
    fn any_piece(&self, p: DVec3, reach: f64, test: &mut dyn FnMut(Self::Piece) -> bool) -> bool;
}

/// What is known of a point's distance to the surface.
#[derive(Clone, Copy, Debug)]
pub(super) struct Known<P> {
    /// An upper bound on it: from a cheap certificate, or the distance to `piece` when `measured`
    /// ([`Surface::nearest`]).
    pub d: f64,
    pub measured: bool,
    /// A piece at distance `d` (when exact and within the reach).
    pub piece: Option<P>,
}

impl<P> Known<P> {
    /// Nothing known.
    pub const UNKNOWN: Self = Self {
        d: f64::INFINITY,
        measured: false,
        piece: None,
    };

    /// At most `d` away (a cheap certificate, [`super::blocks`]).
    pub fn within(d: f64) -> Self {
        Self {
            d,
            measured: false,
            piece: None,
        }
    }
}

/// Is `p` in `region` (a box, x, y and z ranges), if there is one?
pub(crate) fn in_region(region: Option<[f64; 6]>, p: DVec3) -> bool {
    region.is_none_or(|r| (0..3).all(|a| r[2 * a] <= p[a] && p[a] <= r[2 * a + 1]))
}

/// The check of triangles against `surface`: every point within `reach` of it, cutting parts down
/// to `floor` (longest edge), inside `region` (a box, x, y and z ranges) only when there is one.
pub(super) struct Cover<'s, S: Surface> {
    pub surface: &'s S,
    pub reach: f64,
    pub floor: f64,
    pub region: Option<[f64; 6]>,
}

impl<S: Surface> Cover<'_, S> {
    /// Is `p` in the region?
    fn counts(&self, p: DVec3) -> bool {
        in_region(self.region, p)
    }

    /// May the triangle `t` have points in the region (does its bounding box meet it)?
    fn touches(&self, t: &[DVec3; 3]) -> bool {
        let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
        (self.region).is_none_or(|r| (0..3).all(|a| r[2 * a] <= hi[a] && lo[a] <= r[2 * a + 1]))
    }

    /// A point of the triangle `t` (a corner of it or of a part) where the bound is broken or not
    /// certified, or none when every point of it lies within the reach of the surface. `known` is
    /// what is known at its corners and gets what this learns of them. Parts outside the region
    /// are not checked; a part cut to the floor that meets the region and is still unsettled is
    /// reported by its worst corner, outside the region when none is in it (then within `floor` of
    /// it), so no sliver along the region's boundary goes unchecked.
    pub fn violation(&self, t: [DVec3; 3], known: &mut [Known<S::Piece>; 3]) -> Option<DVec3> {
        if !self.touches(&t) {
            return None;
        }
        let longest = t[0]
            .distance(t[1])
            .max(t[1].distance(t[2]))
            .max(t[2].distance(t[0]));
        let margin = longest / 3f64.sqrt();
        if known.iter().all(|k| k.d + margin <= self.reach) {
            return None;
        }
        // Measured for this triangle's margin, which bounds its parts' too; a piece near one
        // corner is often near enough to the others.
        let enough = self.reach - margin;
        let mut hint = known.iter().find_map(|k| k.piece);
        for (k, &p) in known.iter_mut().zip(&t) {
            if let Some(piece) = hint.filter(|_| !k.measured) {
                let d = self.surface.distance_to(piece, p);
                if d <= enough {
                    *k = Known {
                        d,
                        measured: true,
                        piece: Some(piece),
                    };
                }
            }
            if !k.measured {
                let (d, piece) = self.surface.nearest(p, enough, self.reach);
                *k = Known {
                    d,
                    measured: true,
                    piece,
                };
                hint = hint.or(piece);
            }
        }
        let worst_of = |counted: bool| {
            (0..3)
                .filter(|&i| !counted || self.counts(t[i]))
                .max_by(|&i, &j| known[i].d.total_cmp(&known[j].d))
        };
        let worst = worst_of(true);
        if let Some(i) = worst.filter(|&i| known[i].d > self.reach) {
            return Some(t[i]);
        }
        if known.iter().all(|k| k.d + margin <= self.reach) {
            return None;
        }
        // Convexity: one piece within the reach of all three corners — a corner's own first, then
        // any within the reach of the first corner.
        let holds_all = |piece: S::Piece| {
            (0..3).all(|i| {
                known[i].piece == Some(piece) || self.surface.distance_to(piece, t[i]) <= self.reach
            })
        };
        if known.iter().filter_map(|k| k.piece).any(holds_all)
            || (self.surface).any_piece(t[0], self.reach, &mut |piece| holds_all(piece))
        {
            return None;
        }
        if longest <= self.floor {
            return worst.or_else(|| worst_of(false)).map(|i| t[i]);
        }
        let [a, b, c] = t;
        let (ab, bc, ca) = ((a + b) / 2.0, (b + c) / 2.0, (c + a) / 2.0);
        let [ka, kb, kc] = *known;
        let u = Known::UNKNOWN;
        // The middle part first shares no corner with `t`: its midpoints are learnt once, here.
        let mut mid = [u, u, u];
        self.violation([ab, bc, ca], &mut mid)
            .or_else(|| self.violation([a, ab, ca], &mut [ka, mid[0], mid[2]]))
            .or_else(|| self.violation([ab, b, bc], &mut [mid[0], kb, mid[1]]))
            .or_else(|| self.violation([ca, bc, c], &mut [mid[2], mid[1], kc]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::point_triangle_distance;

    /// A surface of triangles, each its own piece.
    struct Soup(Vec<[DVec3; 3]>);

    impl Surface for Soup {
        type Piece = usize;
        fn nearest(&self, p: DVec3, _: f64, reach: f64) -> (f64, Option<usize>) {
            let (i, d) = (self.0.iter().enumerate())
                .map(|(i, &t)| (i, point_triangle_distance(p, t)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap();
            (d, (d <= reach).then_some(i))
        }
        fn distance_to(&self, piece: usize, p: DVec3) -> f64 {
            point_triangle_distance(p, self.0[piece])
        }
        fn any_piece(&self, p: DVec3, reach: f64, test: &mut dyn FnMut(usize) -> bool) -> bool {
            (0..self.0.len()).any(|i| self.distance_to(i, p) <= reach && test(i))
        }
    }

    /// The largest distance to `s` from a dense sample of `t`.
    fn sampled_max(s: &Soup, t: [DVec3; 3]) -> f64 {
        crate::geometry::triangle_samples(t, 0.01)
            .map(|p| s.nearest(p, 0.0, f64::INFINITY).0)
            .fold(0.0, f64::max)
    }

    #[test]
    fn a_covered_triangle_is_certified_and_an_uncovered_one_is_not() {
        // A triangle above two pieces meeting in a ridge: its corners are close to them, its
        // middle is the farthest point. Reaches on both sides of the true maximum.
        let s = Soup(vec![
            [
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(4.0, 0.0, 0.0),
                DVec3::new(0.0, 4.0, -1.0),
            ],
            [
                DVec3::new(4.0, 0.0, 0.0),
                DVec3::new(4.0, 4.0, 0.0),
                DVec3::new(0.0, 4.0, -1.0),
            ],
        ]);
        let t = [
            DVec3::new(0.5, 0.5, 0.3),
            DVec3::new(3.5, 0.5, 0.3),
            DVec3::new(0.5, 3.5, 0.3),
        ];
        let truth = sampled_max(&s, t);
        for reach in [truth * 1.02, truth * 1.2, truth * 3.0] {
            let cover = Cover {
                surface: &s,
                reach,
                floor: 1e-3,
                region: None,
            };
            let mut k = [Known::UNKNOWN; 3];
            assert_eq!(cover.violation(t, &mut k), None, "{reach}");
            assert!(k.iter().all(|k| k.measured && k.d <= reach));
        }
        for reach in [truth * 0.98, truth * 0.5] {
            let cover = Cover {
                surface: &s,
                reach,
                floor: 1e-3,
                region: None,
            };
            let p = cover
                .violation(t, &mut [Known::UNKNOWN; 3])
                .expect("the bound is broken");
            // The point reported is where the triangle comes close to the reach.
            assert!(
                s.nearest(p, 0.0, f64::INFINITY).0 > reach - 2e-3,
                "{reach}: {p}"
            );
        }
        // A cheap upper bound with room for the margin settles it without exact distances.
        let cover = Cover {
            surface: &s,
            reach: 10.0,
            floor: 1e-3,
            region: None,
        };
        let mut k = [Known::within(1.0); 3];
        assert_eq!(cover.violation(t, &mut k), None);
        assert!(k.iter().all(|k| !k.measured));
        // Points outside the region are not checked; inside it they are, also in a slab through the
        // triangle thinner than its parts at the floor, with no corner of any part inside it.
        for (region, broken) in [
            ([5.0, 6.0, 0.0, 4.0, -1.0, 1.0], false),
            ([0.0, 4.0, 0.0, 4.0, 0.0, 0.2], false),
            ([1.0, 2.0, 1.0, 2.0, 0.0, 1.0], true),
            ([2.0001, 2.0002, -1.0, 5.0, -1.0, 1.0], true),
        ] {
            let cover = Cover {
                surface: &s,
                reach: truth * 0.5,
                floor: 1e-3,
                region: Some(region),
            };
            let found = cover.violation(t, &mut [Known::UNKNOWN; 3]);
            assert_eq!(found.is_some(), broken, "{region:?}");
            let (lo, hi) = (
                DVec3::new(region[0], region[2], region[4]),
                DVec3::new(region[1], region[3], region[5]),
            );
            assert!(
                found.is_none_or(|p| p.clamp(lo, hi).distance(p) <= cover.floor),
                "{region:?}: {found:?}"
            );
        }
    }

    #[test]
    fn convexity_settles_a_triangle_at_the_reach() {
        // A triangle parallel to a piece at exactly the reach: no Lipschitz margin is left, one
        // piece holds all corners, so no cutting is needed.
        let s = Soup(vec![[
            DVec3::new(-1.0, -1.0, 0.0),
            DVec3::new(9.0, -1.0, 0.0),
            DVec3::new(-1.0, 9.0, 0.0),
        ]]);
        let t = [
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(5.0, 0.0, 1.0),
            DVec3::new(0.0, 5.0, 1.0),
        ];
        let cover = Cover {
            surface: &s,
            reach: 1.0,
            floor: 100.0, // no cutting at all
            region: None,
        };
        assert_eq!(cover.violation(t, &mut [Known::UNKNOWN; 3]), None);
    }
}
