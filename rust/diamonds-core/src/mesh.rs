//! Mesh extraction (stub, being written).

/// The current mesh of a query: deduplicated input points and positively oriented tetrahedra.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TetMesh {
    /// Input point index (x fastest) of each output point, ascending.
    pub point_ids: Vec<usize>,
    /// World coordinates of each output point.
    pub points: Vec<[f64; 3]>,
    /// Tetrahedra as indices into `points`, positively oriented (VTK_TETRA order).
    pub tets: Vec<[u32; 4]>,
    /// Bisection depth of each tetrahedron (0 = the six base tetrahedra).
    pub levels: Vec<u8>,
    /// Error bound of each tetrahedron: the exact max error of its diamond, rounded up (data units).
    pub errors: Vec<f32>,
    /// Largest value of `errors`.
    pub max_error: f64,
}
