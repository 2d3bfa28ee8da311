//! The material-interface half of the bridge (Gregorski et al. 2002, §5): the Rust side of
//! `vtkMaterialInterfaceApproximation`.
//!
//! What crosses, and nothing else:
//! - in: the grid ([`GridSpec`], or the coordinate arrays of a rectilinear grid through
//!   [`grid_from_coordinates`]), the point volume fractions, fields and per-material fields as `f32`
//!   slices added one by one to a [`MaterialBuilder`] (cxx cannot pass a vector of slices; the builder
//!   copies them, since the kept model outlives the VTK arrays), optional interface triangle meshes as
//!   flat arrays, the query ([`MaterialQuerySpec`]) and the slice plane ([`PlaneSpec`]);
//! - names: which input arrays are read for the selected fractions, fields and per-material fields
//!   is decided here ([`select_material_arrays`], the core's rules: fractions found by name, distinct
//!   selections, material names, per-material arrays matched to (field, material)), so that C++ only
//!   reads the arrays it is told to;
//! - out: an opaque [`MaterialModel`] that the filter keeps between executions, an opaque
//!   [`MaterialMesh`] and [`PolygonMesh`]es with their named [`OutputArrays`] (names, association,
//!   types and values decided by the core, [`diamonds::material::outputs`]), which C++ copies into
//!   VTK arrays in a loop.
//!
//! Every function that can fail runs inside [`guard`] (no panic crosses into C++), and every result
//! is checked for the consistency C++ relies on when it indexes with it
//! ([`check_material_mesh_arrays`], [`check_polygon_arrays`], through [`check_core`]); plain getters
//! of what was checked are infallible.
//!
//! User interface meshes arrive as one triangle soup: points, triangles, a material pair per
//! triangle (two integers: the materials on either side) and optionally normals (per triangle, or
//! per point). The core splits it into one [`InterfaceMesh`] per pair
//! ([`InterfaceMesh::from_soup`]), and validates the input and computes the fields given only per
//! material ([`material::MaterialModel::new`]): the builder only collects the slices.

use std::pin::Pin;

use diamonds::hierarchy::piece::PositionOwner;
use diamonds::material::outputs::{self, ArrayValues, Association};
use diamonds::material::selection::{self, select_arrays, InputArray, SelectionOptions};
use diamonds::material::{self, InterfaceMesh, MaterialField, MaterialInput, MaterialQuery};
use diamonds::validate::{check_material_mesh_arrays, check_polygon_arrays};
use diamonds::Grid;

use crate::ffi::{self, ArrayAssociation, ArrayType, GridSpec, MaterialQuerySpec, PlaneSpec};
use crate::piece::boxes;
use crate::{check_core, guard};

/// Collects the input of a [`MaterialModel`]: the grid, the fractions, fields and per-material fields
/// (copied) and the optional interface meshes.
pub struct MaterialBuilder {
    grid: Grid,
    fractions: Vec<Vec<f32>>,
    /// The mixed fields; `None` for a field given only per material (its mixed values are computed
    /// by the core, see [`MaterialInput::fields`]).
    fields: Vec<Option<Vec<f32>>>,
    /// The names of `fields`, for messages.
    field_names: Vec<String>,
    /// (field, material, values).
    material_fields: Vec<(usize, u8, Vec<f32>)>,
    interfaces: Option<Vec<InterfaceMesh>>,
}

/// Opaque handle on a [`material::MaterialModel`] for C++ (kept between executions).
pub struct MaterialModel {
    model: material::MaterialModel,
    materials: usize,
    fields: usize,
}

/// Opaque handle on a [`material::MaterialMesh`] for C++, checked before it is handed over: a
/// whole mesh, or one MPI rank's share of it with each point's index in the whole mesh.
pub struct MaterialMesh {
    mesh: material::MaterialMesh,
    global_ids: Vec<u64>,
}

/// Opaque handle on a [`material::PolygonMesh`] for C++, checked before it is handed over, with its
/// named arrays (and for one MPI rank's share, each point's index in the whole polygons).
pub struct PolygonMesh {
    polygons: material::PolygonMesh,
    arrays: OutputArrays,
    global_ids: Vec<u64>,
}

/// The named arrays of one output (see [`diamonds::material::outputs`]), read by C++ one by one.
pub struct OutputArrays(Vec<outputs::OutputArray>);

fn grid_of(spec: &GridSpec) -> Grid {
    Grid {
        dims: spec.dims,
        origin: spec.origin,
        spacing: spec.spacing,
    }
}

/// A builder for a model on `grid` (validated here, so that a 2-D image is refused before any copy).
pub fn new_material_builder(grid: &GridSpec) -> Result<Box<MaterialBuilder>, String> {
    guard("preparing the material input", || {
        let grid = grid_of(grid);
        grid.validate().map_err(|e| e.to_string())?;
        Ok(Box::new(MaterialBuilder {
            grid,
            fractions: Vec::new(),
            fields: Vec::new(),
            field_names: Vec::new(),
            material_fields: Vec::new(),
            interfaces: None,
        }))
    })
}

/// The uniform grid of a rectilinear grid's coordinate arrays; refused (with the core's message) when
/// an axis is not uniformly spaced.
pub fn grid_from_coordinates(x: &[f64], y: &[f64], z: &[f64]) -> Result<GridSpec, String> {
    guard("reading the rectilinear coordinates", || {
        let grid = Grid::from_coordinates([x, y, z]).map_err(|e| e.to_string())?;
        Ok(GridSpec {
            dims: grid.dims,
            origin: grid.origin,
            spacing: grid.spacing,
        })
    })
}

/// The bridge's copy of an input array, allocated fallibly ([`diamonds::memory`]).
fn copy(what: &str, values: &[f32]) -> Result<Vec<f32>, String> {
    diamonds::memory::copied(values, &format!("the copy of {what}")).map_err(|e| e.to_string())
}

impl MaterialBuilder {
    fn check_length(&self, what: &str, values: &[f32]) -> Result<(), String> {
        let expected = self.grid.len();
        if values.len() != expected {
            return Err(format!(
                "the {what} array has {} values but the grid has {expected} points ({:?})",
                values.len(),
                self.grid.dims
            ));
        }
        Ok(())
    }

    /// Adds the volume fraction of the next material (one value per grid point).
    pub fn add_fraction(&mut self, values: &[f32]) -> Result<(), String> {
        guard("copying a volume fraction array", || {
            let what = format!("volume fraction {}", self.fractions.len());
            self.check_length(&what, values)?;
            self.fractions.push(copy(&what, values)?);
            Ok(())
        })
    }

    /// Adds the next field to approximate (one value per grid point), `name` in messages.
    pub fn add_field(&mut self, name: &str, values: &[f32]) -> Result<(), String> {
        guard("copying a field array", || {
            let what = format!("field \"{name}\"");
            self.check_length(&what, values)?;
            self.fields.push(Some(copy(&what, values)?));
            self.field_names.push(name.to_string());
            Ok(())
        })
    }

    /// Adds the next field as one given only per material: its mixed values are `Σ fraction ×
    /// per-material value` over the materials with an array ([`MaterialBuilder::add_material_field`];
    /// the others count 0), computed by the core in [`MaterialBuilder::build`].
    pub fn add_field_from_materials(&mut self, name: &str) -> Result<(), String> {
        guard("adding a per-material field", || {
            self.fields.push(None);
            self.field_names.push(name.to_string());
            Ok(())
        })
    }

    /// Adds the values of field `field` (the index of an [`add_field`](Self::add_field) or
    /// [`add_field_from_materials`](Self::add_field_from_materials) call, in order; possibly a later
    /// one) inside material `material` (index of its fraction array), one value per grid point.
    pub fn add_material_field(
        &mut self,
        field: usize,
        material: usize,
        values: &[f32],
    ) -> Result<(), String> {
        guard("copying a per-material field array", || {
            let what = format!("per-material field {field} of material {material}");
            self.check_length(&what, values)?;
            let material = u8::try_from(material).map_err(|_| {
                format!("per-material field {field}: material {material} is not a material index")
            })?;
            let values = copy(&what, values)?;
            self.material_fields.push((field, material, values));
            Ok(())
        })
    }

    /// Sets the user's interface meshes from a triangle soup (see the module documentation):
    /// `points` (3 per point), `triangles` (3 point indices each), `pairs` (2 materials per triangle:
    /// the normal points from the first into the second), `normals` (empty, 3 per triangle, or with
    /// `point_normals` 3 per point). Without normals the triangles' counter-clockwise winding gives the
    /// direction.
    pub fn set_interfaces(
        &mut self,
        points: &[f64],
        triangles: &[u32],
        pairs: &[i64],
        normals: &[f64],
        point_normals: bool,
    ) -> Result<(), String> {
        guard("reading the interface meshes", || {
            self.interfaces = Some(interface_meshes(
                points,
                triangles,
                pairs,
                normals,
                point_normals,
            )?);
            Ok(())
        })
    }

    /// Validates the input and prepares the model (classification, interface reconstruction or
    /// adoption, spatial index).
    pub fn build(&self) -> Result<Box<MaterialModel>, String> {
        guard("preparing the material model", || {
            self.build_model().map(Box::new)
        })
    }

    /// [`Self::build`] without the guard, for Rust callers that have their own. The core validates
    /// the input (number of materials, interface pairs, per-material fields) and computes the fields
    /// given only per material.
    pub fn build_model(&self) -> Result<MaterialModel, String> {
        let input = MaterialInput {
            grid: self.grid,
            fractions: self.fractions.iter().map(Vec::as_slice).collect(),
            fields: self.fields.iter().map(Option::as_deref).collect(),
            field_names: self.field_names.iter().map(String::as_str).collect(),
            material_fields: MaterialField::borrow_all(&self.material_fields),
            interfaces: self.interfaces.clone(),
        };
        let model = material::MaterialModel::new(&input).map_err(|e| e.to_string())?;
        Ok(MaterialModel {
            model,
            materials: self.fractions.len(),
            fields: self.fields.len(),
        })
    }
}

/// The arrays to read for the selected VolumeFractionArrays, FieldArrays and MaterialFieldArrays
/// (see [`diamonds::material::selection::select_arrays`]; `input`: the input's numeric arrays,
/// point data first).
pub fn select_material_arrays(
    input: &[ffi::InputArrayInfo],
    fractions: &[String],
    fields: &[String],
    material_fields: &[String],
) -> Result<ffi::ArraySelection, String> {
    guard("selecting the material arrays", || {
        let input: Vec<InputArray> = input
            .iter()
            .map(|a| InputArray {
                name: &a.name,
                components: a.components,
                cell: a.cell,
            })
            .collect();
        let options = SelectionOptions {
            fractions: "VolumeFractionArrays",
            fields: "FieldArrays",
            material_fields: "MaterialFieldArrays",
        };
        let s = select_arrays(&input, fractions, fields, material_fields, &options)?;
        let array = |a: &selection::SelectedArray| ffi::SelectedArray {
            name: a.name.clone(),
            cell: a.cell,
        };
        Ok(ffi::ArraySelection {
            materials: s.materials,
            fractions: s.fractions.iter().map(array).collect(),
            fields: s
                .fields
                .iter()
                .map(|f| ffi::SelectedField {
                    name: f.name.clone(),
                    from_materials: f.array.is_none(),
                    array: f.array.as_ref().map_or(
                        ffi::SelectedArray {
                            name: String::new(),
                            cell: false,
                        },
                        array,
                    ),
                })
                .collect(),
            material_fields: s
                .material_fields
                .iter()
                .map(|m| ffi::SelectedMaterialField {
                    array: array(&m.array),
                    field: m.field,
                    material: m.material,
                })
                .collect(),
        })
    })
}

/// Splits a triangle soup into one [`InterfaceMesh`] per pair (see [`MaterialBuilder::set_interfaces`]
/// and [`InterfaceMesh::from_soup`]).
pub fn interface_meshes(
    points: &[f64],
    triangles: &[u32],
    pairs: &[i64],
    normals: &[f64],
    point_normals: bool,
) -> Result<Vec<InterfaceMesh>, String> {
    guard("reading the interface meshes", || {
        InterfaceMesh::from_soup(points, triangles, pairs, normals, point_normals)
            .map_err(|e| e.to_string())
    })
}

impl MaterialModel {
    /// Refines to `query` with the C++ progress observer.
    pub fn refine(
        &self,
        query: &MaterialQuerySpec,
        mut progress: Pin<&mut ffi::ProgressObserver>,
    ) -> Result<Box<MaterialMesh>, String> {
        guard("refining the material mesh", || {
            let mut report = crate::reporter(progress.as_mut());
            self.refine_with(query, &mut report).map(Box::new)
        })
    }

    /// [`Self::refine`] with a Rust progress callback; not itself guarded.
    pub fn refine_with(
        &self,
        query: &MaterialQuerySpec,
        progress: &mut dyn FnMut(f64) -> bool,
    ) -> Result<MaterialMesh, String> {
        let mesh = self
            .model
            .refine(&query.into(), progress)
            .map_err(|e| e.to_string())?;
        check_core(check_material_mesh_arrays(
            &mesh,
            self.materials,
            self.fields,
            query.ghost_values,
        ))?;
        Ok(MaterialMesh {
            mesh,
            global_ids: Vec::new(),
        })
    }
}

impl From<&MaterialQuerySpec> for MaterialQuery {
    fn from(q: &MaterialQuerySpec) -> Self {
        Self {
            interface_tolerance: q.interface_tolerance,
            field_tolerance: q.field_tolerance,
            ghost_values: q.ghost_values,
        }
    }
}

/// Ownership of cells for the rank at `rank` of `pieces` (every rank's extent) on `grid`.
fn owner(grid: &GridSpec, pieces: &[i64], rank: usize) -> Result<PositionOwner, String> {
    PositionOwner::new(&grid_of(grid), &boxes(pieces)?, rank).map_err(|e| e.to_string())
}

impl MaterialMesh {
    pub fn points(&self) -> &[f64] {
        self.mesh.points.as_flattened()
    }

    pub fn tets(&self) -> &[u32] {
        self.mesh.tets.as_flattened()
    }

    pub fn max_interface_error(&self) -> f64 {
        self.mesh.max_interface_error
    }

    pub fn max_field_error(&self) -> f64 {
        self.mesh.max_field_error
    }

    /// What to tell the user when the mesh misses a tolerance of `query` (see
    /// [`material::MaterialMesh::tolerance_warning`]), empty when it meets both.
    pub fn tolerance_warning(&self, query: &MaterialQuerySpec) -> String {
        self.mesh
            .tolerance_warning(&query.into())
            .unwrap_or_default()
    }

    /// The name of each interface, `"<a>|<b>"` (see [`outputs::interface_names`]).
    pub fn interface_names(&self, materials: &[String]) -> Vec<String> {
        outputs::interface_names(materials, &self.mesh.pairs)
    }

    /// The named arrays of the tetrahedra (see [`outputs::tetrahedra_arrays`]).
    pub fn tetrahedra_arrays(
        &self,
        materials: &[String],
        fields: &[String],
        query: &MaterialQuerySpec,
    ) -> Result<Box<OutputArrays>, String> {
        guard("naming the tetrahedra arrays", || {
            let arrays = outputs::tetrahedra_arrays(&self.mesh, materials, fields, &query.into())?;
            Ok(Box::new(OutputArrays::new(arrays)))
        })
    }

    /// The approximated interfaces, labelled by pair index, with their arrays.
    pub fn interface_polygons(&self) -> Result<Box<PolygonMesh>, String> {
        guard("extracting the interface polygons", || {
            self.interfaces_of(None)
        })
    }

    /// The share of the interfaces the rank at `rank` of `pieces` (every rank's extent, relative
    /// to `grid`, the whole grid) owns, with global point ids.
    pub fn interface_polygons_piece(
        &self,
        grid: &GridSpec,
        pieces: &[i64],
        rank: usize,
    ) -> Result<Box<PolygonMesh>, String> {
        guard("extracting a rank's interface polygons", || {
            self.interfaces_of(Some(&owner(grid, pieces, rank)?))
        })
    }

    fn interfaces_of(&self, owner: Option<&PositionOwner>) -> Result<Box<PolygonMesh>, String> {
        let (polygons, global_ids) = self.share(self.mesh.interface_polygons(), owner, false)?;
        let arrays = OutputArrays::new(outputs::interface_arrays(&self.mesh, &polygons));
        Ok(Box::new(PolygonMesh {
            polygons,
            arrays,
            global_ids,
        }))
    }

    /// `whole` (interfaces, or the cut when `cut`), or the share of it `owner` owns with global
    /// point ids, checked as C++ will index it.
    fn share(
        &self,
        whole: material::PolygonMesh,
        owner: Option<&PositionOwner>,
        cut: bool,
    ) -> Result<(material::PolygonMesh, Vec<u64>), String> {
        let (polygons, global_ids) = match owner {
            Some(o) => whole.piece(o),
            None => (whole, Vec::new()),
        };
        let fields = if cut { self.mesh.fields } else { 0 };
        check_core(check_polygon_arrays(
            &polygons,
            self.mesh.materials,
            cut,
            fields,
        ))?;
        Ok((polygons, global_ids))
    }

    /// The cut by `plane`, labelled by material, with each field (named by `fields`) of the
    /// polygon's material.
    pub fn slice(&self, plane: &PlaneSpec, fields: &[String]) -> Result<Box<PolygonMesh>, String> {
        guard("slicing the material mesh", || {
            self.slice_of(plane, fields, None)
        })
    }

    /// The share of the cut the rank at `rank` of `pieces` owns (see
    /// [`MaterialMesh::interface_polygons_piece`]), with global point ids.
    pub fn slice_piece(
        &self,
        plane: &PlaneSpec,
        fields: &[String],
        grid: &GridSpec,
        pieces: &[i64],
        rank: usize,
    ) -> Result<Box<PolygonMesh>, String> {
        guard("slicing a rank's share of the material mesh", || {
            self.slice_of(plane, fields, Some(&owner(grid, pieces, rank)?))
        })
    }

    fn slice_of(
        &self,
        plane: &PlaneSpec,
        fields: &[String],
        owner: Option<&PositionOwner>,
    ) -> Result<Box<PolygonMesh>, String> {
        let whole = self
            .mesh
            .slice(plane.origin, plane.normal)
            .map_err(|e| e.to_string())?;
        let (polygons, global_ids) = self.share(whole, owner, true)?;
        let arrays = OutputArrays::new(outputs::slice_arrays(
            &polygons,
            fields,
            plane.origin,
            plane.normal,
        ));
        Ok(Box::new(PolygonMesh {
            polygons,
            arrays,
            global_ids,
        }))
    }

    /// The share of this (whole) mesh the rank at `rank` of `pieces` owns: the tetrahedra whose
    /// centroid its cells hold ([`PositionOwner`]), with global point ids.
    pub fn piece(
        &self,
        grid: &GridSpec,
        pieces: &[i64],
        rank: usize,
    ) -> Result<Box<MaterialMesh>, String> {
        guard("extracting a rank's share of the material mesh", || {
            let (mesh, global_ids) = self.mesh.piece(&owner(grid, pieces, rank)?);
            check_core(check_material_mesh_arrays(
                &mesh,
                self.mesh.materials,
                self.mesh.fields,
                self.mesh.ghost_values,
            ))?;
            Ok(Box::new(MaterialMesh { mesh, global_ids }))
        })
    }

    /// For a share ([`MaterialMesh::piece`]): each point's index in the whole mesh; empty for a
    /// whole mesh.
    pub fn global_point_ids(&self) -> &[u64] {
        &self.global_ids
    }

    /// The mesh as the core returned it.
    pub fn inner(&self) -> &material::MaterialMesh {
        &self.mesh
    }
}

impl PolygonMesh {
    pub fn points(&self) -> &[f64] {
        self.polygons.points.as_flattened()
    }

    /// One offset per polygon plus one into `connectivity()` (empty when there is no polygon).
    pub fn offsets(&self) -> &[u32] {
        &self.polygons.offsets
    }

    pub fn connectivity(&self) -> &[u32] {
        &self.polygons.connectivity
    }

    pub fn arrays(&self) -> &OutputArrays {
        &self.arrays
    }

    /// For a share: each point's index in the whole polygons; empty for whole polygons.
    pub fn global_point_ids(&self) -> &[u64] {
        &self.global_ids
    }

    /// The polygons as the core returned them.
    pub fn inner(&self) -> &material::PolygonMesh {
        &self.polygons
    }
}

impl OutputArrays {
    fn new(arrays: Vec<outputs::OutputArray>) -> Self {
        Self(arrays)
    }

    pub fn len(&self) -> usize {
        self.0.len()
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    fn nth(&self, i: usize) -> Result<&outputs::OutputArray, String> {
        self.0
            .get(i)
            .ok_or_else(|| format!("output array {i} asked for, but there are {}", self.0.len()))
    }

    pub fn info(&self, i: usize) -> Result<ffi::OutputArrayInfo, String> {
        guard("reading the output arrays", || {
            let a = self.nth(i)?;
            Ok(ffi::OutputArrayInfo {
                name: a.name.clone(),
                association: match a.association {
                    Association::Point => ArrayAssociation::Point,
                    Association::Cell => ArrayAssociation::Cell,
                    Association::Field => ArrayAssociation::Field,
                },
                components: a.components,
                value_type: match a.values {
                    ArrayValues::U8(_) => ArrayType::U8,
                    ArrayValues::I32(_) => ArrayType::I32,
                    ArrayValues::U32(_) => ArrayType::U32,
                    ArrayValues::I64(_) => ArrayType::I64,
                    ArrayValues::F32(_) => ArrayType::F32,
                    ArrayValues::F64(_) => ArrayType::F64,
                },
                active_scalars: a.active_scalars,
            })
        })
    }

    pub fn bytes(&self, i: usize) -> Result<&[u8], String> {
        guard("reading the output arrays", || {
            Ok(match &self.nth(i)?.values {
                ArrayValues::U8(v) => v,
                ArrayValues::I32(v) => bytemuck::cast_slice(v),
                ArrayValues::U32(v) => bytemuck::cast_slice(v),
                ArrayValues::I64(v) => bytemuck::cast_slice(v),
                ArrayValues::F32(v) => bytemuck::cast_slice(v),
                ArrayValues::F64(v) => bytemuck::cast_slice(v),
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use diamonds::fields::impact_case;

    fn spec(grid: &Grid) -> GridSpec {
        GridSpec {
            dims: grid.dims,
            origin: grid.origin,
            spacing: grid.spacing,
        }
    }

    /// Two triangles of the plane z = 0 (counter-clockwise seen from above).
    const POINTS: [f64; 12] = [0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.];
    const TRIANGLES: [u32; 6] = [0, 1, 2, 0, 2, 3];

    /// The soup is split by the core (its tests cover the orientation); the bridge passes it
    /// through and its messages back.
    #[test]
    fn interface_soup_through_the_bridge() {
        let meshes = interface_meshes(&POINTS, &TRIANGLES, &[0, 1, 2, 1], &[], false).unwrap();
        assert_eq!(
            meshes,
            InterfaceMesh::from_soup(&POINTS, &TRIANGLES, &[0, 1, 2, 1], &[], false).unwrap()
        );
        assert_eq!(meshes.len(), 2);
        assert!(
            interface_meshes(&POINTS, &TRIANGLES, &[0, 1, 0], &[], false)
                .unwrap_err()
                .contains("material-pair")
        );
    }

    #[test]
    fn builder_refuses_bad_input() {
        let bad = GridSpec {
            dims: [4, 4, 1],
            origin: [0.0; 3],
            spacing: [1.0; 3],
        };
        assert!(new_material_builder(&bad)
            .err()
            .unwrap()
            .contains("at least 2 points"));
        let grid = GridSpec {
            dims: [3, 3, 3],
            origin: [0.0; 3],
            spacing: [1.0; 3],
        };
        let mut b = new_material_builder(&grid).unwrap();
        assert!(b
            .add_fraction(&[0.5; 26])
            .unwrap_err()
            .contains("26 values"));
        assert!(b
            .add_field("Density", &[0.5; 28])
            .unwrap_err()
            .contains("28 values"));
        b.add_fraction(&[1.0; 27]).unwrap();
        assert!(b.build().err().unwrap().contains("at least 2 materials"));
        b.add_fraction(&[0.0; 27]).unwrap();
        b.set_interfaces(&POINTS, &TRIANGLES, &[0, 2, 0, 2], &[], false)
            .unwrap();
        assert!(b.build().err().unwrap().contains("material 2"));
    }

    #[test]
    fn rectilinear_coordinates() {
        let g =
            grid_from_coordinates(&[0.0, 0.5, 1.0], &[1.0, 2.0], &[-1.0, 0.0, 1.0, 2.0]).unwrap();
        assert_eq!(g.dims, [3, 2, 4]);
        assert_eq!(g.origin, [0.0, 1.0, -1.0]);
        assert_eq!(g.spacing, [0.5, 1.0, 1.0]);
        let uneven = grid_from_coordinates(&[0.0, 0.5, 1.5], &[1.0, 2.0], &[0.0, 1.0]);
        assert!(uneven.err().unwrap().contains("not uniformly spaced"));
        assert!(grid_from_coordinates(&[0.0], &[1.0, 2.0], &[0.0, 1.0]).is_err());
    }

    fn tiny_mesh() -> material::MaterialMesh {
        material::MaterialMesh {
            materials: 2,
            fields: 1,
            points: vec![[0.0; 3]; 4],
            tets: vec![[0, 1, 2, 3]],
            depths: vec![0],
            point_material: vec![0, 0, 1, 1],
            pairs: vec![(0, 1)],
            interface_distance: vec![vec![0.0; 4]],
            material_distance: vec![vec![0.0; 4]; 2],
            mixed: vec![vec![0.0; 4]],
            material_field: vec![vec![0.0; 4]; 2],
            interface_error: vec![0.0],
            field_error: vec![0.0],
            tet_materials: vec![3],
            interface_tetrahedra: 1,
            ghost_values: true,
            ..Default::default()
        }
    }

    #[test]
    fn output_arrays_read_in_place() {
        let mesh = MaterialMesh {
            mesh: tiny_mesh(),
            global_ids: Vec::new(),
        };
        assert_eq!(mesh.points().len(), 12);
        assert_eq!(mesh.tets(), &[0, 1, 2, 3]);
        let names = |list: &[&str]| list.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let (materials, fields) = (names(&["A", "B"]), names(&["F"]));
        assert_eq!(mesh.interface_names(&materials), ["A|B"]);
        let query = MaterialQuerySpec {
            interface_tolerance: 0.5,
            field_tolerance: 1.0,
            ghost_values: true,
        };
        let arrays = mesh.tetrahedra_arrays(&materials, &fields, &query).unwrap();
        let material = arrays.info(0).unwrap();
        assert_eq!(material.name, "Material");
        assert_eq!(material.association, ArrayAssociation::Point);
        assert_eq!(material.value_type, ArrayType::I32);
        assert!(material.active_scalars);
        assert_eq!(
            arrays.bytes(0).unwrap(),
            bytemuck::cast_slice::<i32, u8>(&[0, 0, 1, 1])
        );
        assert!(arrays.info(arrays.len()).is_err());
        assert!(arrays.bytes(arrays.len()).is_err());
        assert!(mesh.tetrahedra_arrays(&fields, &fields, &query).is_err());
    }

    /// The impact case through the bridge, as the filter drives it. Needs the core's material
    /// module.
    #[test]
    fn impact_case_through_the_bridge() {
        let case = impact_case([16, 16, 26]);
        let mut b = new_material_builder(&spec(&case.grid)).unwrap();
        for f in &case.fractions {
            b.add_fraction(f).unwrap();
        }
        b.add_field("Density", &case.density).unwrap();
        let model = b.build().unwrap();
        assert!(model.model.interfaces().len() >= 2);
        let query = MaterialQuerySpec {
            interface_tolerance: 0.3,
            field_tolerance: 3.0,
            ghost_values: true,
        };
        let mut reports = 0;
        let mesh = model
            .refine_with(&query, &mut |f| {
                assert!((0.0..=1.0).contains(&f));
                reports += 1;
                true
            })
            .unwrap();
        assert!(reports > 0);
        let n_points = mesh.points().len() / 3;
        let n_tets = mesh.tets().len() / 4;
        assert!(n_points > 0 && n_tets > 0);
        assert!(mesh.max_interface_error() <= 0.3 + 1e-9);
        assert!(mesh.max_field_error() <= 3.0 + 1e-9);
        assert!(mesh
            .inner()
            .interface_error
            .iter()
            .all(|&e| e <= 0.3 + 1e-6));
        assert_eq!(mesh.inner().material_field[2].len(), n_points);
        let interfaces = mesh.interface_polygons().unwrap();
        assert!(!interfaces.inner().labels.is_empty());
        let cell_arrays = (0..interfaces.arrays().len())
            .map(|i| interfaces.arrays().info(i).unwrap())
            .filter(|a| a.association == ArrayAssociation::Cell)
            .count();
        assert_eq!(cell_arrays, 3, "Interface, MaterialA, MaterialB");
        let b = case.grid.bounds();
        let plane = PlaneSpec {
            origin: [
                0.5 * (b[0] + b[1]),
                0.5 * (b[2] + b[3]),
                0.5 * (b[4] + b[5]),
            ],
            normal: [0.0, 1.0, 0.0],
        };
        let slice = mesh.slice(&plane, &["Density".to_string()]).unwrap();
        assert!(!slice.inner().labels.is_empty());
        assert_eq!(slice.inner().values.len(), 1);
        assert_eq!(slice.arrays().info(1).unwrap().name, "Density");
        for p in slice.points().chunks(3) {
            assert!((p[1] - plane.origin[1]).abs() < 1e-9);
        }
        // Abort: an error, no mesh.
        let aborted = model.refine_with(&query, &mut |_| false);
        assert_eq!(aborted.err().as_deref(), Some("aborted"));
        // A negative tolerance: the core's message.
        let negative = MaterialQuerySpec {
            interface_tolerance: -1.0,
            ..query
        };
        assert!(model.refine_with(&negative, &mut |_| true).is_err());
    }

    /// Per-material densities through the bridge, and a field given only per material (its mixed
    /// values: the fraction-weighted sum).
    #[test]
    fn per_material_fields_through_the_bridge() {
        let case = impact_case([16, 16, 26]);
        let fractions: Vec<String> = case
            .names
            .iter()
            .map(|m| format!("Volume Fraction for {m}"))
            .collect();
        let arrays: Vec<String> = case
            .names
            .iter()
            .map(|m| format!("Density for {m}"))
            .collect();
        let input: Vec<ffi::InputArrayInfo> = fractions
            .iter()
            .chain(&arrays)
            .map(|name| ffi::InputArrayInfo {
                name: name.clone(),
                components: 1,
                cell: false,
            })
            .collect();
        let fields = vec!["Density".to_string()];
        // The field is not an input array: computed from the per-material arrays.
        let selected = select_material_arrays(&input, &[], &fields, &arrays).unwrap();
        assert_eq!(selected.materials, case.names);
        assert_eq!(selected.fractions.len(), 3);
        assert!(selected.fields[0].from_materials);
        let pairs: Vec<[usize; 2]> = selected
            .material_fields
            .iter()
            .map(|m| [m.field, m.material])
            .collect();
        assert_eq!(pairs, [[0, 0], [0, 1], [0, 2]]);
        // Without the field: the arrays define it.
        let implicit = select_material_arrays(&input, &fractions, &[], &arrays).unwrap();
        assert_eq!(implicit.fields[0].name, "Density");
        let e = select_material_arrays(&input, &[], &fields, &["Density for Steel".to_string()])
            .unwrap_err();
        assert!(
            e.starts_with("MaterialFieldArrays: ") && e.contains("\"Density (Projectile)\""),
            "{e}"
        );
        let query = MaterialQuerySpec {
            interface_tolerance: 0.3,
            field_tolerance: 3.0,
            ghost_values: true,
        };
        let builder = |mixed: bool, materials: &[usize]| {
            let mut b = new_material_builder(&spec(&case.grid)).unwrap();
            for f in &case.fractions {
                b.add_fraction(f).unwrap();
            }
            if mixed {
                b.add_field("Density", &case.density).unwrap();
            } else {
                b.add_field_from_materials("Density").unwrap();
            }
            for &m in materials {
                b.add_material_field(0, m, &case.material_density[m])
                    .unwrap();
            }
            b
        };
        let given = builder(true, &[0, 1, 2]).build().unwrap();
        let mesh = given.refine_with(&query, &mut |_| true).unwrap();
        assert!(mesh.max_field_error() <= 3.0);
        let void = &mesh.inner().material_field[0];
        assert!(void.iter().all(|&d| d == 0.0));
        // Only per material, void left out (it counts 0): the mixed field is the generated density
        // (compared through plain interpolation, which uses the mixed field only).
        let derived = builder(false, &[1, 2]).build().unwrap();
        let plain = MaterialQuerySpec {
            ghost_values: false,
            ..query
        };
        let d = derived.refine_with(&plain, &mut |_| true).unwrap();
        let m = given.refine_with(&plain, &mut |_| true).unwrap();
        assert_eq!(d.tets(), m.tets());
        for (a, b) in d.inner().mixed[0].iter().zip(&m.inner().mixed[0]) {
            assert!((a - b).abs() < 1e-4, "{a} vs {b}");
        }
        // Errors: no array for a per-material-only field, a field or material out of range, a
        // wrong length.
        assert!(builder(false, &[])
            .build()
            .err()
            .unwrap()
            .contains("none was given"));
        let mut b = builder(true, &[]);
        b.add_material_field(1, 0, &case.density).unwrap();
        assert!(b.build().err().unwrap().contains("1 fields"));
        let mut b = builder(true, &[]);
        b.add_material_field(0, 3, &case.density).unwrap();
        assert!(b.build().err().unwrap().contains("3 materials"));
        assert!(b.add_material_field(0, 300, &case.density).is_err());
        assert!(b
            .add_material_field(0, 0, &[1.0; 4])
            .unwrap_err()
            .contains("4 values"));
    }

    #[test]
    fn fractions_not_summing_to_one_are_refused_or_normalised() {
        let case = impact_case([9, 9, 14]);
        let mut b = new_material_builder(&spec(&case.grid)).unwrap();
        for f in &case.fractions {
            b.add_fraction(&f.iter().map(|v| v * 0.5).collect::<Vec<_>>())
                .unwrap();
        }
        // Either a clear error or a model: never a panic (the guard would say "internal error").
        match b.build() {
            Ok(_) => {}
            Err(e) => assert!(!e.contains("internal error"), "{e}"),
        }
    }
}
