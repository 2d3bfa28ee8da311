//! # Diamonds core
//!
//! Adaptive, conforming tetrahedral meshes of regular grids built by longest-edge bisection (LEB),
//! organised as a *hierarchy of diamonds* (Gregorski et al. 2002, §3; Weiss & De Floriani, §4).
//! This crate knows nothing about VTK: volumes come in as typed slices, meshes go out as plain vectors.
//!
//! Data flow: [`Volume`] → [`Hierarchy::build`] (per-diamond exact error and value range, Marchesin
//! et al. §4.1) → [`Hierarchy::query`] (selective refinement with closure, Gregorski §4) → [`TetMesh`].
//!
//! Modules, each named after the concept it implements, in dependency order (each uses only
//! modules listed before it; the crate root holds [`Error`] and [`Result`]):
//! - [`volume`]: typed, borrowed sample arrays (u8 … f64) with origin and spacing.
//! - [`lattice`]: the virtual `(2^L + 1)^3` lattice that embeds the input grid, and the domain box.
//! - [`diamond`]: the implicit diamond encoding from the central vertex (Weiss & De Floriani §4, Eq. 1).
//! - [`scan`]: integer point enumeration inside a tetrahedron and its exact interpolation error
//!   (Marchesin §4.1).
//! - [`geometry`]: exact point–triangle distances, triangles in R-trees, samples of triangles.
//! - [`refine`]: the split set, the [`refine::SplitQueue`] and selective refinement with closure.
//! - [`memory`]: fallible allocation of the large buffers (a failure is an error, not an abort).
//! - [`mesh`]: extraction of the current mesh as deduplicated points and tetrahedra.
//! - [`hierarchy`]: the precomputed per-diamond records (the error bound) in 2 bytes per voxel
//!   ([`hierarchy::record`]: the record and its codecs) and the base mesh every query starts from.
//! - [`isosurface`]: multiresolution isosurfaces (Gregorski §6), one file per stage: the isosurface
//!   error measured per query at the samples that decide the surface (no precomputation:
//!   [`Hierarchy::build_for_isosurfaces`]), the two-sided bound checked against the full-resolution
//!   surface, marching tetrahedra, and the
//!   [`IsoState`] kept between queries (mesh reuse, isovalue changes "from the current mesh",
//!   measured, §6.1; the isosurface cache). Entry points: [`isosurface::extract`] and
//!   [`IsoState::extract`].
//! - [`interval`]: multiresolution interval volumes `{α ≤ f ≤ β}` (Weiss & De Floriani §2.1, §5):
//!   the isosurface refinement for both bounding surfaces, every leaf that meets the range clipped and
//!   tetrahedralised by a rule on global point names, so patches conform. Entry points:
//!   [`interval::extract`] and [`interval::IntervalState::extract`].
//! - [`isodiamond`]: relevant and minimal isodiamond hierarchies (Weiss & De Floriani §5–§7): one
//!   isosurface or interval volume stored as the isodiamonds it needs, with the full hierarchy's
//!   split set at each rung of a ladder of tolerances, extracted at any rung without the volume;
//!   a compact byte encoding.
//! - [`progressive`]: progressive tetrahedral meshes of unstructured input (Labsik et al.): half-edge
//!   collapses with the weighted cost of §3.3 into a base mesh and vertex splits, replayable to any
//!   level, with the exact field error at every removed vertex.
//! - [`fields`]: generated volumes (Marschner–Lobb, distance fields) for the demo and the tests.
//! - [`material`]: material interfaces with ghost values (Gregorski §5).
//! - [`view`]: view-dependent meshes and the exact visibility order of their tetrahedra from the
//!   bisection tree (Marchesin §6).
//! - [`validate`]: independent checks of tetrahedra, surfaces and polygons (conformity, volume, the
//!   tolerance at every sample, watertight and oriented surfaces, crack-free interfaces, array
//!   consistency) used by the tests, the CLI and the bridge.

pub mod diamond;
pub mod fields;
pub mod geometry;
pub mod hierarchy;
pub mod interval;
pub mod isodiamond;
pub mod isosurface;
pub mod lattice;
pub mod material;
pub mod memory;
pub mod mesh;
pub mod progressive;
pub mod refine;
pub mod scan;
pub mod validate;
pub mod view;
pub mod volume;

pub use hierarchy::{Hierarchy, Progress};
pub use isosurface::{IsoQuery, IsoState, IsoSurface};
pub use mesh::TetMesh;
pub use refine::Query;
pub use volume::{Grid, ScalarSlice, ScalarType, Volume};

/// Everything that can go wrong, with a message meant for the end user.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum Error {
    /// The grid has fewer than 2 points along an axis (2-D images and lines are refused).
    #[error("the image has {dims:?} points; every axis needs at least 2 points (2-D images are not supported: Diamonds builds 3-D meshes)")]
    Dimensions { dims: [usize; 3] },
    /// The sample array does not match the grid.
    #[error("the scalar array has {len} values but the grid has {expected} points ({dims:?})")]
    Length {
        len: usize,
        expected: usize,
        dims: [usize; 3],
    },
    /// Spacing must be finite and positive, origin finite.
    #[error(
        "invalid geometry: origin {origin:?}, spacing {spacing:?} (spacing must be finite and > 0)"
    )]
    Geometry { origin: [f64; 3], spacing: [f64; 3] },
    /// A NaN or infinite sample.
    #[error("the scalar array holds a non-finite value ({value}) at point {index} (i, j, k = {ijk:?}); replace NaN/Inf first")]
    NonFinite {
        index: usize,
        ijk: [usize; 3],
        value: f64,
    },
    /// A sample beyond [`volume::MAX_MAGNITUDE`], where the error arithmetic would overflow.
    #[error("the scalar array holds {value:e} at point {index} (i, j, k = {ijk:?}): beyond ±{:e}, where the error arithmetic would overflow; rescale the array first (e.g. with Calculator)", volume::MAX_MAGNITUDE)]
    Magnitude {
        index: usize,
        ijk: [usize; 3],
        value: f64,
    },
    /// Not enough memory for the hierarchy.
    #[error("the diamond hierarchy for {dims:?} points needs {needed} bytes but only {available} bytes are available")]
    TooLarge {
        dims: [usize; 3],
        needed: u64,
        available: u64,
    },
    /// A large buffer could not be allocated ([`memory`]).
    #[error("not enough memory for {what} ({bytes} bytes could not be allocated)")]
    OutOfMemory { what: String, bytes: u64 },
    /// A query parameter out of range.
    #[error("invalid parameter: {0}")]
    Parameter(String),
    /// An unstructured input mesh the progressive simplification cannot take ([`progressive`]).
    #[error("invalid tetrahedral mesh: {0}")]
    Mesh(String),
    /// A progressive mesh stream that cannot be read ([`progressive::stream`]).
    #[error("invalid progressive mesh stream: {0}")]
    Stream(String),
    /// Isodiamond hierarchy bytes that cannot be read ([`isodiamond`]).
    #[error("invalid isodiamond hierarchy: {0}")]
    Isodiamonds(String),
    /// The two-sided bound of an isosurface could not be established (a defect: the check splits
    /// until it holds, and on the finest tetrahedra it holds by construction).
    #[error("the isosurface could not be certified within its tolerance: {0}; please report this with the data and parameters")]
    Uncertified(String),
    /// The caller asked to stop.
    #[error("aborted")]
    Aborted,
}

/// Result alias of the crate.
pub type Result<T> = std::result::Result<T, Error>;
