//! Selective refinement (stub, being written).

/// A selective-refinement query.
#[derive(Clone, Debug, PartialEq)]
pub struct Query {
    /// Absolute tolerance in data units; 0 reproduces every sample.
    pub tolerance: f64,
    /// Maximum number of tetrahedra, 0 = no limit.
    pub max_tetrahedra: usize,
    /// World-space box `[xmin, xmax, ymin, ymax, zmin, zmax]`: the tolerance applies inside, coarse outside.
    pub region_of_interest: Option<[f64; 6]>,
}
