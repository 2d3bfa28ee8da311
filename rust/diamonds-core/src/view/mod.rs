//! View-dependent meshes and their exact visibility order (Gregorski §4, §6.2, §8; Marchesin §4–6),
//! one module per concern:
//! - [`error`]: the view-dependent error of a diamond (Gregorski's screen-space error in pixels or
//!   Marchesin's `e / d`) over nested bounds, and frustum culling;
//! - [`queues`]: the split and merge queues that carry the mesh from frame to frame under a
//!   tetrahedron budget, each frame ending at the fresh refinement of its view, with per-frame
//!   statistics;
//! - [`order`]: back-to-front and front-to-back order of a mesh's tetrahedra for an eye position,
//!   from the bisection tree, each bisection plane a BSP plane (Marchesin §6), in linear time.

pub mod error;
pub mod order;
pub mod queues;

pub use error::{Camera, Metric, View, ViewErrors};
pub use order::{sorted, BspTree, Direction};
pub use queues::{FrameStats, ViewQuery, ViewState};
