//! Per-diamond precomputation (stub, being written).
use crate::{Grid, Query, Result, ScalarSlice, TetMesh};

/// Progress callback: called on the calling thread with a fraction in [0, 1]; return `false` to abort.
pub type Progress<'a> = &'a mut dyn FnMut(f64) -> bool;

/// The diamond hierarchy of one volume.
pub struct Hierarchy {
    grid: Grid,
}

impl Hierarchy {
    /// Builds the hierarchy (exact per-diamond error and range) for `scalars` on `grid`.
    pub fn build(grid: Grid, scalars: ScalarSlice<'_>, progress: Progress<'_>) -> Result<Self> {
        let _ = (scalars, progress);
        todo!("{grid:?}")
    }
    /// Extracts the adaptive mesh for `query`.
    pub fn query(&self, query: &Query) -> Result<TetMesh> {
        todo!("{query:?}")
    }
    /// The grid.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }
    /// Bytes of per-diamond metadata.
    pub fn metadata_bytes(&self) -> usize {
        todo!()
    }
    /// Tetrahedra of the base mesh (domain-conforming refinement only).
    pub fn base_tetrahedra(&self) -> usize {
        todo!()
    }
}
