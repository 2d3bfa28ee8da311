//! The named arrays of the three outputs of a material approximation, shared by the ParaView filter
//! (through the bridge) and the CLI so that both write the same arrays, in the same order, with the
//! same names and types; each writes them as a loop over [`OutputArray`]s.
//!
//! - tetrahedra ([`tetrahedra_arrays`]): point data `Material`, `SignedDistance <a>|<b>` per interface,
//!   `SignedDistance <m>` per material, each field and, with ghost values, `<field> (<m>)` per
//!   material, then `IsGhost (<m>)`; cell data `InterfaceError`, `FieldError`, `Materials`,
//!   `NumberOfMaterials`, `BisectionDepth`; field data the tolerances, the errors reached and the counts;
//! - interfaces ([`interface_arrays`]): cell data `Interface` (index of the polygon's pair among the
//!   mesh's pairs, named by [`interface_names`]), `MaterialA`, `MaterialB`; field data
//!   `NumberOfPolygons`;
//! - slice ([`slice_arrays`]): cell data `Material` (-1 without ghost values), point data each field;
//!   field data `SlicePlane` (origin and normal).

use super::{MaterialMesh, MaterialQuery, PolygonMesh};

/// Which data of the output an array belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Association {
    Point,
    Cell,
    Field,
}

/// The values of an output array, of the type it is written with.
#[derive(Clone, Debug, PartialEq)]
pub enum ArrayValues {
    U8(Vec<u8>),
    I32(Vec<i32>),
    U32(Vec<u32>),
    I64(Vec<i64>),
    F32(Vec<f32>),
    F64(Vec<f64>),
}

impl ArrayValues {
    /// Number of values (tuples × components).
    pub fn len(&self) -> usize {
        match self {
            Self::U8(v) => v.len(),
            Self::I32(v) => v.len(),
            Self::U32(v) => v.len(),
            Self::I64(v) => v.len(),
            Self::F32(v) => v.len(),
            Self::F64(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// One named array of an output.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputArray {
    pub name: String,
    pub association: Association,
    pub components: usize,
    pub values: ArrayValues,
    /// Whether it is the active scalars of its data.
    pub active_scalars: bool,
}

impl OutputArray {
    fn new(name: impl Into<String>, association: Association, values: ArrayValues) -> Self {
        Self {
            name: name.into(),
            association,
            components: 1,
            values,
            active_scalars: false,
        }
    }

    fn active(self) -> Self {
        Self {
            active_scalars: true,
            ..self
        }
    }
}

/// The name of each interface of `pairs`: `"<a>|<b>"` with the material names.
pub fn interface_names<S: AsRef<str>>(materials: &[S], pairs: &[(u8, u8)]) -> Vec<String> {
    pairs
        .iter()
        .map(|&(a, b)| {
            let name = |m: u8| materials.get(m as usize).map_or("?", |s| s.as_ref());
            format!("{}|{}", name(a), name(b))
        })
        .collect()
}

/// The arrays of the tetrahedra: `materials` and `fields` name the mesh's materials and fields
/// (an error when their numbers differ from the mesh's); `query` is the query as the user gave it
/// (its tolerances are written as field data).
pub fn tetrahedra_arrays<S: AsRef<str>>(
    mesh: &MaterialMesh,
    materials: &[S],
    fields: &[S],
    query: &MaterialQuery,
) -> Result<Vec<OutputArray>, String> {
    use ArrayValues::{F32, F64, I32, I64, U32, U8};
    use Association::{Cell, Field, Point};
    if materials.len() != mesh.materials || fields.len() != mesh.fields {
        return Err(format!(
            "internal error: the mesh has {} materials and {} fields for {} and {} names",
            mesh.materials,
            mesh.fields,
            materials.len(),
            fields.len()
        ));
    }
    let materials: Vec<&str> = materials.iter().map(AsRef::as_ref).collect();
    let mut out = vec![OutputArray::new(
        "Material",
        Point,
        I32(mesh.point_material.iter().map(|&m| m as i32).collect()),
    )
    .active()];
    for (name, d) in interface_names(&materials, &mesh.pairs)
        .iter()
        .zip(&mesh.interface_distance)
    {
        out.push(OutputArray::new(
            format!("SignedDistance {name}"),
            Point,
            F32(d.clone()),
        ));
    }
    for (name, d) in materials.iter().zip(&mesh.material_distance) {
        out.push(OutputArray::new(
            format!("SignedDistance {name}"),
            Point,
            F32(d.clone()),
        ));
    }
    let per_material = mesh.ghost_values && !mesh.material_field.is_empty();
    for (f, field) in fields.iter().map(AsRef::as_ref).enumerate() {
        out.push(OutputArray::new(field, Point, F32(mesh.mixed[f].clone())));
        if per_material {
            for (m, name) in materials.iter().enumerate() {
                out.push(OutputArray::new(
                    format!("{field} ({name})"),
                    Point,
                    F32(mesh.material_field[f * materials.len() + m].clone()),
                ));
            }
        }
    }
    if per_material {
        for (m, name) in materials.iter().enumerate() {
            out.push(OutputArray::new(
                format!("IsGhost ({name})"),
                Point,
                U8(mesh
                    .point_material
                    .iter()
                    .map(|&p| u8::from(p as usize != m))
                    .collect()),
            ));
        }
    }
    out.extend([
        OutputArray::new("InterfaceError", Cell, F32(mesh.interface_error.clone())),
        OutputArray::new("FieldError", Cell, F32(mesh.field_error.clone())),
        OutputArray::new("Materials", Cell, U32(mesh.tet_materials.clone())),
        OutputArray::new(
            "NumberOfMaterials",
            Cell,
            U8(mesh
                .tet_materials
                .iter()
                .map(|m| m.count_ones() as u8)
                .collect()),
        ),
        OutputArray::new("BisectionDepth", Cell, U8(mesh.depths.clone())),
        OutputArray::new(
            "InterfaceTolerance",
            Field,
            F64(vec![query.interface_tolerance]),
        ),
        OutputArray::new("FieldTolerance", Field, F64(vec![query.field_tolerance])),
        OutputArray::new(
            "MaximumInterfaceError",
            Field,
            F64(vec![mesh.max_interface_error]),
        ),
        OutputArray::new("MaximumFieldError", Field, F64(vec![mesh.max_field_error])),
        OutputArray::new(
            "NumberOfTetrahedra",
            Field,
            I64(vec![mesh.tets.len() as i64]),
        ),
        OutputArray::new(
            "InterfaceTetrahedra",
            Field,
            I64(vec![mesh.interface_tetrahedra as i64]),
        ),
        OutputArray::new(
            "UseGhostValues",
            Field,
            I32(vec![query.ghost_values as i32]),
        ),
    ]);
    Ok(out)
}

/// The arrays of the approximated interfaces of `mesh` (`polygons`, from
/// [`MaterialMesh::interface_polygons`]).
pub fn interface_arrays(mesh: &MaterialMesh, polygons: &PolygonMesh) -> Vec<OutputArray> {
    use Association::{Cell, Field};
    let pair_index = |&[a, b]: &[u8; 2]| {
        mesh.pairs
            .iter()
            .position(|&p| p == (a, b))
            .map_or(-1, |i| i as i32)
    };
    let material =
        |side: usize| ArrayValues::I32(polygons.labels.iter().map(|l| l[side] as i32).collect());
    vec![
        OutputArray::new(
            "Interface",
            Cell,
            ArrayValues::I32(polygons.labels.iter().map(pair_index).collect()),
        )
        .active(),
        OutputArray::new("MaterialA", Cell, material(0)),
        OutputArray::new("MaterialB", Cell, material(1)),
        OutputArray::new(
            "NumberOfPolygons",
            Field,
            ArrayValues::I64(vec![polygons.labels.len() as i64]),
        ),
    ]
}

/// The arrays of the cut `slice` (from [`MaterialMesh::slice`] by the plane through `origin` with
/// `normal`), whose value arrays are the fields named `fields`.
pub fn slice_arrays<S: AsRef<str>>(
    slice: &PolygonMesh,
    fields: &[S],
    origin: [f64; 3],
    normal: [f64; 3],
) -> Vec<OutputArray> {
    let material = slice
        .labels
        .iter()
        .map(|l| if l[0] == u8::MAX { -1 } else { l[0] as i32 })
        .collect();
    let mut out =
        vec![OutputArray::new("Material", Association::Cell, ArrayValues::I32(material)).active()];
    for (values, name) in slice.values.iter().zip(fields) {
        out.push(OutputArray::new(
            name.as_ref(),
            Association::Point,
            ArrayValues::F32(values.clone()),
        ));
    }
    let mut plane = origin.to_vec();
    plane.extend(normal);
    out.push(OutputArray {
        components: 6,
        ..OutputArray::new("SlicePlane", Association::Field, ArrayValues::F64(plane))
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::tests::one_tetrahedron_mesh as mesh;

    fn names(arrays: &[OutputArray], association: Association) -> Vec<&str> {
        arrays
            .iter()
            .filter(|a| a.association == association)
            .map(|a| a.name.as_str())
            .collect()
    }

    const QUERY: MaterialQuery = MaterialQuery {
        interface_tolerance: 0.15,
        field_tolerance: 3.0,
        ghost_values: true,
    };

    #[test]
    fn tetrahedra_arrays_are_named_by_material_and_field() {
        let materials = ["Void", "Steel"];
        let arrays = tetrahedra_arrays(&mesh(true), &materials, &["Density"], &QUERY).unwrap();
        assert_eq!(
            names(&arrays, Association::Point),
            [
                "Material",
                "SignedDistance Void|Steel",
                "SignedDistance Void",
                "SignedDistance Steel",
                "Density",
                "Density (Void)",
                "Density (Steel)",
                "IsGhost (Void)",
                "IsGhost (Steel)"
            ]
        );
        assert_eq!(
            names(&arrays, Association::Cell),
            [
                "InterfaceError",
                "FieldError",
                "Materials",
                "NumberOfMaterials",
                "BisectionDepth"
            ]
        );
        assert_eq!(names(&arrays, Association::Field).len(), 7);
        let find = |name: &str| arrays.iter().find(|a| a.name == name).unwrap();
        assert!(find("Material").active_scalars);
        assert_eq!(
            find("IsGhost (Steel)").values,
            ArrayValues::U8(vec![1, 1, 0, 0])
        );
        assert_eq!(find("NumberOfMaterials").values, ArrayValues::U8(vec![2]));
        assert_eq!(find("FieldTolerance").values, ArrayValues::F64(vec![3.0]));
        // Without ghost values: the mixed fields only.
        let plain = tetrahedra_arrays(&mesh(false), &materials, &["Density"], &QUERY).unwrap();
        assert_eq!(names(&plain, Association::Point).len(), 5);
        assert!(tetrahedra_arrays(&mesh(true), &materials, &[] as &[&str], &QUERY).is_err());
    }

    #[test]
    fn polygons_are_labelled_by_pair_and_material() {
        let polygons = PolygonMesh {
            points: vec![[0.0; 3]; 3],
            offsets: vec![0, 3, 6],
            connectivity: vec![0, 1, 2, 0, 2, 1],
            labels: vec![[0, 1], [1, 2]],
            values: vec![],
        };
        let arrays = interface_arrays(&mesh(true), &polygons);
        assert_eq!(arrays[0].values, ArrayValues::I32(vec![0, -1]));
        assert_eq!(arrays[2].values, ArrayValues::I32(vec![1, 2]));
        let cut = PolygonMesh {
            labels: vec![[1, 1], [255, 255]],
            values: vec![vec![7.0; 3]],
            ..polygons
        };
        let arrays = slice_arrays(&cut, &["Density"], [1.0, 2.0, 3.0], [0.0, 0.0, 1.0]);
        assert_eq!(arrays[0].values, ArrayValues::I32(vec![1, -1]));
        assert_eq!(arrays[1].name, "Density");
        assert_eq!(arrays[2].components, 6);
        assert_eq!(interface_names(&["A", "B", "C"], &[(0, 2)]), ["A|C"]);
    }
}
