//! View-dependent meshes and their exact visibility order (Gregorski §4, §8; Marchesin §4–6).
//!
//! - [`order`]: back-to-front and front-to-back order of a mesh's tetrahedra for an eye position,
//!   from the bisection tree, each bisection plane a BSP plane (Marchesin §6), in linear time.

pub mod order;

pub use order::{BspTree, Direction};
