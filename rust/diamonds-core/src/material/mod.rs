//! Material interfaces with ghost values (Gregorski et al. 2002, §5).
//!
//! Multi-material simulation output carries a volume fraction per material at each sample. Linear
//! interpolation across a material interface smears the fields; instead, every tetrahedron of the
//! adaptive mesh carries
//! - the **interfaces** inside it as zero sets of linear signed-distance functions (§5.2.1), and
//! - one **linear field per material**, completed by **ghost values** at the vertices that lie in another
//!   material (§5.2.2–5.2.3), so the field is discontinuous exactly at the approximated interface.
//!
//! The fields are given mixed (one value per sample, e.g. the cell's average density) and optionally
//! per material ([`MaterialField`]: the value inside one material). A material's own value at a sample
//! of that material is its per-material value when given, else the mixed value; ghost values and the
//! field error (with ghost values) use these own values, plain interpolation the mixed fields only.
//! [`naming`] matches per-material arrays to (field, material) by name, as the ParaView filter and the
//! CLI name them; [`selection`] chooses the input arrays and [`outputs`] names the output arrays, the
//! same way for both.
//!
//! Pipeline: point volume fractions → material of each sample (largest fraction) → interface triangle
//! meshes, one per pair of touching materials ([`reconstruct`], or given by the user) → spatial index for
//! closest points ([`distance`]) → selective refinement of a diamond mesh fitted to the data box, first to
//! the interface tolerance, then to the field tolerance (§5.3) → [`MaterialMesh`], from which the
//! approximated interfaces ([`MaterialMesh::interface_polygons`]) and plane cuts ([`MaterialMesh::slice`])
//! are drawn.
//!
//! Differences from the paper, and why:
//! - The mesh is a diamond hierarchy on a lattice `s ≥ 1` levels finer than the data along each axis:
//!   sample `[i, j, k]` is lattice point `[2^s_x i, 2^s_y j, 2^s_z k]`, the grid at the lattice's corner
//!   with a base mesh along the far faces as in Adaptive Tetrahedra ([`crate::lattice`]). Every
//!   sample is a vertex, so the field error can reach 0 at the finest tetrahedra on any grid; `s` is
//!   at least 1 (tetrahedra down to half a cell where interfaces need them), more while the widest
//!   lattice step exceeds the interface tolerance, and larger along coarse axes so that the steps are
//!   about equal in world units (longest-edge bisection halves edges in lattice units: on strongly
//!   anisotropic grids equal shifts left the finest tetrahedra long along the coarse axis), and one
//!   more on every axis at a time while the finest tetrahedra
//!   still miss it (near junctions, where the signed distances vary slowly; as far as the split
//!   sets' memory allows); vertex
//!   values between samples are resampled from the data (§5.1: "the input datasets are resampled at
//!   the vertices of the tetrahedral mesh"). Errors are measured at the data samples (the "native data
//!   elements" of §5.4), exactly, not with the nested bound of Eq. (1)–(2). Refinement evaluates the
//!   diamonds of each round in parallel (`Refiner::refine_parallel`).
//! - Ghost values (§5.2.3) are the least-squares linear extrapolation of the material's samples around
//!   the vertex (the paper's "linear … extrapolation"), falling back to the paper's value at the
//!   nearest point of the material: a field continuous across an interface is continued, a jump kept.
//! - Besides the per-interface signed distance `d_ab`, each vertex has a signed distance `φ_m` to the
//!   boundary of each material `m` (the union of its interface meshes, negative inside `m`). Inside a
//!   tetrahedron the material at a point is the one with the smallest interpolated `φ`; the interface
//!   between `a` and `b` is `{φ_a = φ_b ≤ φ_c ∀c}`. With one value per vertex this is continuous across
//!   faces, so the approximated interfaces are crack-free, junctions of three materials included.

pub mod distance;
mod model;
pub mod naming;
pub mod outputs;
mod piece;
mod polygons;
pub mod reconstruct;
pub mod selection;
mod soup;
#[cfg(test)]
pub(crate) mod tests;

pub use model::{MaterialModel, MAX_MATERIALS};
pub use naming::{
    match_material_fields, material_fields, material_name, material_names, mixed_from_materials,
    MaterialFieldMatch,
};

use crate::Grid;

/// A triangle mesh of the interface between materials `pair.0 < pair.1`. Triangles are wound
/// counter-clockwise seen from `pair.1`'s side: their normal points from material `pair.0` into `pair.1`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct InterfaceMesh {
    /// The two materials (indices into the volume-fraction arrays), `pair.0 < pair.1`.
    pub pair: (u8, u8),
    /// World coordinates.
    pub points: Vec<[f64; 3]>,
    /// Triangles as indices into `points`.
    pub triangles: Vec<[u32; 3]>,
}

/// The value of field `field` inside material `material` at every sample (for example the density of
/// steel, where the mixed field has the density of the steel and void mixture). Read only at the
/// samples whose material (largest fraction) is `material`; other values may be anything.
#[derive(Clone, Copy, Debug)]
pub struct MaterialField<'a> {
    /// Index into [`MaterialInput::fields`].
    pub field: usize,
    /// Index into [`MaterialInput::fractions`].
    pub material: u8,
    /// One value per point of the grid.
    pub values: &'a [f32],
}

impl<'a> MaterialField<'a> {
    /// Views of per-material fields kept as `(field, material, values)`.
    pub fn borrow_all(owned: &'a [(usize, u8, Vec<f32>)]) -> Vec<Self> {
        owned
            .iter()
            .map(|(field, material, values)| MaterialField {
                field: *field,
                material: *material,
                values,
            })
            .collect()
    }
}

/// The input: per-material volume fractions and the fields to approximate, all point data of `grid`.
#[derive(Clone, Debug)]
pub struct MaterialInput<'a> {
    pub grid: Grid,
    /// One array per material (≥ 2), each with one fraction in `[0, 1]` per point; they sum to 1.
    pub fractions: Vec<&'a [f32]>,
    /// Mixed-cell fields to approximate (for example density), one value per point. With ghost values,
    /// a material's own value at its samples is the mixed value unless `material_fields` gives it.
    /// `None` for a field given only per material: its mixed values are `Σ fraction × per-material
    /// value` over the materials `material_fields` gives it for (the others count 0; see
    /// [`mixed_from_materials`]), and at least one must be given.
    pub fields: Vec<Option<&'a [f32]>>,
    /// The names of `fields`, for messages (a field without one is called by its index).
    pub field_names: Vec<&'a str>,
    /// Optional per-material values of the fields, at most one per (field, material). Where given, the
    /// own value of the material (its vertex values, ghost values and the samples its field error is
    /// measured at) comes from it instead of the mixed field; plain interpolation ignores them.
    pub material_fields: Vec<MaterialField<'a>>,
    /// Interface meshes given by the user (for example from a triangle soup,
    /// [`InterfaceMesh::from_soup`]); `None` reconstructs them from the fractions.
    pub interfaces: Option<Vec<InterfaceMesh>>,
}

/// What to refine to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaterialQuery {
    /// Largest distance (world units) from an interface-mesh vertex to its approximating plane.
    pub interface_tolerance: f64,
    /// Largest deviation of a field at a sample from its linear approximation (data units), per material.
    pub field_tolerance: f64,
    /// `false` ignores the materials: plain linear interpolation of the mixed fields (the comparison
    /// the paper makes in Figure 15).
    pub ghost_values: bool,
}

/// The adaptive tetrahedral mesh with its per-vertex interface distances and per-material fields.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MaterialMesh {
    /// Number of materials and of fields of the input.
    pub materials: usize,
    pub fields: usize,
    /// World coordinates of the vertices.
    pub points: Vec<[f64; 3]>,
    /// Positively oriented tetrahedra (VTK_TETRA order).
    pub tets: Vec<[u32; 4]>,
    /// Bisection depth of each tetrahedron.
    pub depths: Vec<u8>,
    /// Material at each vertex.
    pub point_material: Vec<u8>,
    /// Interface pairs present in the input, in the order of `interface_distance`.
    pub pairs: Vec<(u8, u8)>,
    /// `interface_distance[i][v]`: signed distance from vertex `v` to the interface mesh `pairs[i]`,
    /// positive on `pairs[i].1`'s side (§5.2.1).
    pub interface_distance: Vec<Vec<f32>>,
    /// `material_distance[m][v]`: signed distance from vertex `v` to the boundary of material `m`,
    /// negative inside `m`.
    pub material_distance: Vec<Vec<f32>>,
    /// `mixed[f][v]`: field `f` resampled at vertex `v` (trilinear; what plain interpolation uses).
    pub mixed: Vec<Vec<f32>>,
    /// `material_field[f * materials + m][v]`: field `f` of material `m` at vertex `v`: its own value
    /// where `v` lies in `m` (from `m`'s samples of the per-material field when the input gives one,
    /// else of the mixed field), the ghost value elsewhere (§5.2.3). Empty without ghost values.
    pub material_field: Vec<Vec<f32>>,
    /// Per tetrahedron: interface error (world units), field error (data units), bit mask of the
    /// materials present (of the samples inside it and its vertices).
    pub interface_error: Vec<f32>,
    pub field_error: Vec<f32>,
    pub tet_materials: Vec<u32>,
    /// Largest errors over the mesh.
    pub max_interface_error: f64,
    pub max_field_error: f64,
    /// Tetrahedra after the interface pass alone (§5.3 step 2).
    pub interface_tetrahedra: usize,
    /// Whether the mesh was refined with ghost values (per-material fields) or plain interpolation.
    pub ghost_values: bool,
}

/// Polygons with a label: the approximated interfaces (label = pair index) or a plane cut (label = material).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PolygonMesh {
    pub points: Vec<[f64; 3]>,
    /// Polygon `i` is `connectivity[offsets[i]..offsets[i + 1]]`.
    pub offsets: Vec<u32>,
    pub connectivity: Vec<u32>,
    /// Per polygon: the two materials `(a, b)`, `a < b`, of an interface polygon (its normal points from
    /// `a` into `b`); `(m, m)` for the part of a cut lying in material `m`; `(255, 255)` for a cut
    /// without ghost values (the mixed field, not split at interfaces).
    pub labels: Vec<[u8; 2]>,
    /// Per point, per field (cuts only): the field of the polygon's material, `values[f][p]`.
    pub values: Vec<Vec<f32>>,
}
