//! The diamond error of isosurface queries (Gregorski §6.2), with the culling of empty diamonds
//! (§6.1): what refinement compares with the tolerance, and which leaves of a refined mesh carry
//! the surface.

use super::marching::carries;
use super::Extraction;
use crate::diamond::Diamond;
use crate::lattice::{Placement, Tet};
use crate::mesh;
use crate::refine::SplitSet;
use crate::volume::Sample;
use crate::Result;
use glam::IVec3;

/// Boxes of at most this many samples get their exact range where it decides a split.
const SMALL_BOX: i32 = 64;

impl<T: Sample> Extraction<'_, '_, T> {
    /// The diamond error of isosurface queries for `isovalues` at `tolerance`: the isosurface error
    /// measured at the surface samples ([`super::error`]); at tolerance 0, infinite for every
    /// diamond whose sample range may hold an isovalue, so the surface is the full-resolution one.
    pub(super) fn iso_criterion<'a>(
        &'a self,
        isovalues: &'a [f64],
        tolerance: f64,
    ) -> Result<impl Fn(Diamond) -> f64 + 'a> {
        let lattice = *self.lattice();
        let errors = (tolerance > 0.0)
            .then(|| self.iso_errors(isovalues, tolerance))
            .transpose()?;
        // Infinite where the diamond's sample range may hold an isovalue, else 0 (empty, §6.1).
        let non_empty = move |d: Diamond| {
            let (lo, hi) = d.bounds();
            if self.may_hold(isovalues, lo, hi) {
                f64::INFINITY
            } else {
                0.0
            }
        };
        Ok(move |d: Diamond| {
            if !d.bounds().1.cmple(lattice.hi).all() {
                // Near a far face: a diamond straddling it must be split wherever the surface may
                // pass (its tetrahedra have vertices without samples); one outside is never split.
                match d.placement(&lattice) {
                    Placement::Straddling => return non_empty(d),
                    Placement::Outside => return 0.0,
                    Placement::Inside => {}
                }
            }
            match &errors {
                _ if !lattice.in_domain(d.center) => 0.0, // outside the domain
                Some(errors) => errors.refinement_error(self, d),
                None => non_empty(d), // tolerance 0
            }
        })
    }

    /// The leaves of the mesh of `split` that carry the surface of `isovalues`.
    pub(super) fn carriers_of(&self, isovalues: &[f64], split: &SplitSet) -> Result<Vec<Tet>> {
        let empty = |t: &Tet| self.misses(isovalues, t);
        mesh::leaves_where(self.lattice(), split, empty, |t| {
            carries(self.volume, isovalues, t).then_some(*t)
        })
    }

    /// Does the sample range of `t` miss every isovalue? Then so do those of all its descendants.
    /// From the bricks, and for a tetrahedron straddling a far face as [`Extraction::may_hold`] (so
    /// that the walk prunes every unsplit one).
    pub(super) fn misses(&self, isovalues: &[f64], t: &Tet) -> bool {
        let lo = t[0].min(t[1]).min(t[2].min(t[3]));
        let hi = t[0].max(t[1]).max(t[2].max(t[3]));
        if self.lattice().place_box(lo, hi) == Placement::Inside {
            let (a, b) = self.box_range(lo, hi);
            !isovalues.iter().any(|&v| a <= v && v <= b)
        } else {
            !self.may_hold(isovalues, lo, hi)
        }
    }

    /// May the samples in the box `[lo, hi]` (clipped to the grid) hold an isovalue? From the
    /// bricks' range, a superset; for a small box (the fine diamonds along a far face) from the
    /// samples, which spares splits there.
    fn may_hold(&self, isovalues: &[f64], lo: IVec3, hi: IVec3) -> bool {
        let (lo, hi) = (lo.max(IVec3::ZERO), hi.min(self.lattice().hi));
        let holds = |(a, b): (f64, f64)| isovalues.iter().any(|&v| a <= v && v <= b);
        holds(self.box_range(lo, hi))
            && ((hi - lo + IVec3::ONE).element_product() > SMALL_BOX
                || holds(self.volume.box_range(lo, hi)))
    }
}
