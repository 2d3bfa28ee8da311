//! What isosurface queries keep between calls on one hierarchy and its samples (Gregorski §6.2's
//! `‖∇T‖`, §6.1's culling ranges): brick ranges, gradient magnitudes and the errors of the last
//! isovalues. Owned by an [`IsoState`](super::IsoState).

use super::bricks::Bricks;
use super::error::IsoErrors;
use super::paged::PagedCodes;
use super::{tet_gradient, Extraction};
use crate::diamond::Diamond;
use crate::hierarchy::record::{decode_error, encode_down};
use crate::lattice::{Lattice, Placement};
use crate::volume::{Grid, Sample, Volume};
use crate::Result;
use glam::IVec3;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};

/// What isosurface queries keep: the sample range of 8³ bricks, which bounds the range of any box,
/// the gradient magnitudes of the diamonds measured so far, and the errors of the last isovalues
/// ([`IsoErrors`]), reused while only the tolerance, region, normals or carrier output change.
pub(super) struct IsoCache {
    /// The grid of the samples it was made from.
    grid: Grid,
    pub(super) bricks: Bricks,
    /// By central vertex: the smallest gradient magnitude of the diamond's tetrahedra, rounded down
    /// (bfloat16; [`UNKNOWN`] until a query needs it; stored where queries asked,
    /// [`PagedCodes`]). Shared with the [`Self::negated`] cache: negating the samples keeps every
    /// gradient's magnitude.
    gradients: Arc<PagedCodes>,
    errors: Mutex<Option<Arc<IsoErrors>>>,
}

/// Marks a gradient no query has computed yet.
const UNKNOWN: u16 = u16::MAX;

impl std::fmt::Debug for IsoCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "IsoCache({} bricks)", self.bricks.count())
    }
}

impl IsoCache {
    /// An empty cache for `volume`'s samples (the bricks are computed now).
    pub(super) fn new<T: Sample>(volume: &Volume<'_, T>) -> Self {
        Self {
            grid: volume.grid,
            bricks: Bricks::new(volume),
            gradients: Arc::new(PagedCodes::new(volume.grid.dims, UNKNOWN)),
            errors: Mutex::new(None),
        }
    }

    /// A cache for the negated samples ([`Volume::negated`]): its bricks from these ones', the same
    /// gradients, no errors kept.
    pub(super) fn negated(&self) -> Self {
        Self {
            grid: self.grid,
            bricks: self.bricks.negated(),
            gradients: self.gradients.clone(),
            errors: Mutex::new(None),
        }
    }

    /// Bytes held: the bricks, the gradients and the kept errors.
    pub(super) fn bytes(&self) -> usize {
        let errors = self.errors.lock().unwrap_or_else(|e| e.into_inner());
        self.bricks.bytes() + self.gradients.bytes() + errors.as_ref().map_or(0, |e| e.bytes())
    }

    /// Was it made for samples on `grid`?
    pub(super) fn fits(&self, grid: &Grid) -> bool {
        self.grid == *grid
    }
}

impl<T: Sample> Extraction<'_, '_, T> {
    /// The smallest gradient magnitude (world units) of the inside tetrahedra of `d` (central vertex
    /// in the domain), rounded down, from the cache or computed now.
    pub(super) fn smallest_gradient(&self, d: Diamond) -> f64 {
        let gradients = &self.cache.gradients;
        let mut code = gradients.load(d.center);
        if code == UNKNOWN {
            code = encode_down(smallest_gradient(self.lattice(), self.volume, d));
            gradients.slot(d.center).store(code, Ordering::Relaxed);
        }
        decode_error(code)
    }

    /// The isosurface errors of `isovalues` for a query at `tolerance` (> 0): those of the previous
    /// query when they serve, else measured now down to tetrahedra of the tolerance's size (smaller
    /// diamonds' errors are bounded by their size, hence by the tolerance).
    pub(super) fn iso_errors(&self, isovalues: &[f64], tolerance: f64) -> Result<Arc<IsoErrors>> {
        let (volume, cache) = (self.volume, self.cache);
        let mut kept = cache.errors.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(e) = kept.as_ref().filter(|e| e.serve(isovalues, tolerance)) {
            return Ok(e.clone());
        }
        // The old errors go before the new ones are measured.
        *kept = None;
        // Pieces sharing the work measure at the samples of the cells they own, then take the
        // others' codes ([`super::Partition::share_errors`]).
        let owner = self.partition.map(|p| &p.owner);
        let mut errors = IsoErrors::new(self.lattice(), volume, isovalues, tolerance, |v| {
            let mut cells = cache.bricks.cells_crossed(volume, v);
            if let Some(owner) = owner {
                cells.retain(|&c| owner.owns_cell(volume.grid.ijk(c as usize)));
            }
            cells
        });
        if let Some(partition) = self.partition {
            partition.share_errors(&mut errors)?;
        }
        errors.finalize(self);
        let errors = Arc::new(errors);
        *kept = Some(errors.clone());
        Ok(errors)
    }

    /// A superset of the sample range in the box `[lo, hi]` (lattice coordinates inside the grid).
    pub(super) fn box_range(&self, lo: IVec3, hi: IVec3) -> (f64, f64) {
        self.cache.bricks.range(lo, hi)
    }
}

/// The smallest gradient magnitude (world units) among the inside tetrahedra of `d`.
fn smallest_gradient<T: Sample>(lattice: &Lattice, volume: &Volume<'_, T>, d: Diamond) -> f64 {
    d.tets(lattice)
        .iter()
        .filter(|t| lattice.place(t) == Placement::Inside)
        .map(|t| tet_gradient(volume, t).length())
        .fold(f64::INFINITY, f64::min)
}
