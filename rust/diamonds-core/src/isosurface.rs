//! Multiresolution isosurfaces from the diamond hierarchy (Gregorski §6, §6.1–6.2; Weiss & De Floriani §2.1, §5.1).

use crate::{Hierarchy, Result, ScalarSlice, TetMesh};

/// An isosurface query.
#[derive(Clone, Debug, PartialEq)]
pub struct IsoQuery {
    /// One or more isovalues, in data units.
    pub isovalues: Vec<f64>,
    /// Isosurface error bound in world units (Gregorski §6.2: approximation error over gradient
    /// magnitude, clamped to the tetrahedron's size); 0 = full resolution wherever the surface passes.
    pub tolerance: f64,
    /// Maximum number of triangles, 0 = no limit.
    pub max_triangles: usize,
    /// World-space box `[xmin, xmax, ymin, ymax, zmin, zmax]`: the tolerance applies inside, coarse outside.
    pub region_of_interest: Option<[f64; 6]>,
    /// Compute point normals from the gradient at the lattice points.
    pub compute_normals: bool,
    /// Also return the tetrahedra that carry the surface.
    pub carrier_tetrahedra: bool,
}

/// An extracted isosurface.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IsoSurface {
    /// World coordinates of each point.
    pub points: Vec<[f64; 3]>,
    /// Unit normals toward increasing values (empty unless asked for).
    pub normals: Vec<[f32; 3]>,
    /// Triangles, oriented so that their normal points toward increasing values.
    pub triangles: Vec<[u32; 3]>,
    /// The isovalue of each point.
    pub values: Vec<f64>,
    /// Largest isosurface error (world units) of the diamonds carrying the surface.
    pub error_bound: f64,
    /// The tetrahedra carrying the surface, when asked for.
    pub carrier: Option<TetMesh>,
}

impl Hierarchy {
    /// Extracts the isosurface(s) of `query` from the adaptive mesh; `scalars` must be the samples the
    /// hierarchy was built from.
    pub fn isosurface(&self, scalars: ScalarSlice<'_>, query: &IsoQuery) -> Result<IsoSurface> {
        todo!("{:?} {:?}", scalars.len(), query)
    }
}
