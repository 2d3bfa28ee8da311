//! Writing the CLI's outputs through [`vtkxml`]: images on the core's [`Grid`], tetrahedra and
//! polygons.

use crate::{Array, Result};
use diamonds::Grid;
use std::path::Path;
pub use vtkxml::{
    checked_extension, write_polygons, write_tets, write_triangles, Polygons, TetGrid, Triangles,
};

/// Writes `arrays` (one tuple per grid point) on `grid` as VTK XML image data (extent from 0); the first
/// single-component array is the active scalars.
pub fn write_image(path: &Path, grid: &Grid, arrays: &[Array]) -> Result<()> {
    let grid = vtkxml::UniformGrid {
        dims: grid.dims,
        origin: grid.origin,
        spacing: grid.spacing,
    };
    Ok(vtkxml::write_image(path, &grid, arrays)?)
}
