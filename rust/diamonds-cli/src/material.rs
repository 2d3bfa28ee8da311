//! `diamonds material` and `diamonds generate --field impact`: material interfaces with ghost values
//! (Gregorski et al. 2002, §5; the core's [`diamonds::material`]), as the ParaView filter "Material
//! Interface Approximation" computes them, from and to VTK files.
//!
//! Input: a `.vti`, or a `.vtr` whose coordinates are uniformly spaced along each axis (a non-uniform
//! one is refused with the core's message, or resampled with `--resample`), with one volume-fraction
//! array per material and optionally fields (mixed, and per material: "<field> for <material>" or
//! "<field> (<material>)", matched by the core's [`diamonds::material::material_fields`], as the
//! filter's MaterialFieldArrays; a <field> not among `--fields` is a field given only per material),
//! as point or cell data. Cell data are converted to point
//! data the way `vtkCellDataToPointData` does: the value at a point is the average of the cells around
//! it (8 inside, fewer on the boundary).
//!
//! Output, with the array names of the ParaView filter: `OUT.vtu` (the tetrahedra), `OUT-interfaces.vtp`
//! (the approximated interfaces) and `OUT-slice.vtp` (a plane cut).

use crate::read::{read_image, read_structured, Geometry, Structured, StructuredGrid};
use crate::write::{write_image, write_polygons, write_tets, Polygons, TetGrid};
use crate::{bail, Array, Result};
use diamonds::fields::{impact_case, tissue_case};
use diamonds::material::outputs::{
    interface_arrays, slice_arrays, tetrahedra_arrays, ArrayValues, Association, OutputArray,
};
use diamonds::material::selection::{select_arrays, InputArray, SelectedArray, SelectionOptions};
use diamonds::material::{MaterialField, MaterialInput, MaterialModel, MaterialQuery, PolygonMesh};
use diamonds::Grid;
use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The grid of the paper's impact data set (§5.5): 32 × 32 × 52 points.
pub const IMPACT_DIMS: [usize; 3] = [32, 32, 52];

/// `diamonds generate --field impact`: writes the impact case on `dims` points as a `.vti` with point
/// data "Density" (mixed), "Volume Fraction for Void", "Volume Fraction for Block", "Volume Fraction
/// for Projectile", and each material's own density "Density for Void", "Density for Block",
/// "Density for Projectile" (void's is 0; `Density = Σ fraction × own density`).
pub fn generate_impact(output: &Path, dims: [usize; 3]) -> Result<String> {
    if let Some(d) = dims.iter().find(|&&d| d < 2) {
        bail!("every dimension needs at least 2 points (got {d} in {dims:?})");
    }
    let points = dims
        .iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .filter(|&n| n <= 1 << 28)
        .ok_or_else(|| crate::Error(format!("{dims:?} points are too many to generate")))?;
    let case = impact_case(dims);
    let mut arrays: Vec<Array> = case
        .names
        .iter()
        .zip(&case.fractions)
        .map(|(name, f)| Array::scalars(format!("Volume Fraction for {name}"), f.clone()))
        .collect();
    arrays.push(Array::scalars("Density", case.density.clone()));
    // Density first: the active scalars.
    arrays.rotate_right(1);
    arrays.extend(
        case.names
            .iter()
            .zip(&case.material_density)
            .map(|(name, d)| Array::scalars(format!("Density for {name}"), d.clone())),
    );
    write_image(output, &case.grid, &arrays)?;
    Ok(format!(
        "wrote '{}': impact case (materials {}; Density, mixed and per material) {}x{}x{} Float32 ({points} points)",
        output.display(),
        case.names.join(", "),
        dims[0],
        dims[1],
        dims[2]
    ))
}

/// `diamonds generate --field tissue --image IN`: writes the tissue maps of IN's intensity (its active
/// scalars; [`diamonds::fields::tissue_case`]) on IN's points or on `dims` as a `.vti` with point data
/// "T1" and "Volume Fraction for Other", "… for Grey", "… for White".
pub fn generate_tissue(output: &Path, image: &Path, dims: Option<[usize; 3]>) -> Result<String> {
    let input = read_image(image)?;
    let scalars = input.scalars(None)?;
    let dims = dims.unwrap_or(input.grid.dims);
    if let Some(d) = dims.iter().find(|&&d| d < 2) {
        bail!("every dimension needs at least 2 points (got {d} in {dims:?})");
    }
    if dims
        .iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .is_none_or(|n| n > 1 << 28)
    {
        bail!("{dims:?} points are too many to generate");
    }
    let values: Vec<f64> = (0..scalars.tuples()).map(|k| scalars.value(k)).collect();
    let case = tissue_case(&input.grid, &values, dims);
    let mut arrays = vec![Array::scalars("T1", case.intensity)];
    arrays.extend(
        case.names
            .iter()
            .zip(case.fractions)
            .map(|(name, f)| Array::scalars(format!("Volume Fraction for {name}"), f)),
    );
    write_image(output, &case.grid, &arrays)?;
    Ok(format!(
        "wrote '{}': tissue maps of '{}' (materials {}; T1) {}x{}x{} Float32",
        output.display(),
        scalars.name,
        case.names.join(", "),
        dims[0],
        dims[1],
        dims[2]
    ))
}

/// Array names from comma-separated lists: a comma followed by a space belongs to the name (CTH writes
/// "Volume Fraction for Body, Nose"); empty names are dropped.
pub fn split_names(lists: &[String]) -> Vec<String> {
    let mut names = Vec::new();
    for list in lists {
        let mut current = String::new();
        let mut chars = list.chars().peekable();
        while let Some(c) = chars.next() {
            if c == ',' && chars.peek() != Some(&' ') {
                names.push(std::mem::take(&mut current));
            } else {
                current.push(c);
            }
        }
        names.push(current);
    }
    names.retain(|n| !n.is_empty());
    names
}

/// Options of `diamonds material`.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialOptions {
    pub input: PathBuf,
    /// Output base: writes `<base>.vtu`, `<base>-interfaces.vtp`, `<base>-slice.vtp` (a `.vtu`
    /// extension is dropped first).
    pub output: PathBuf,
    /// Volume-fraction arrays, one per material; empty: every array whose name contains "fraction".
    pub fractions: Vec<String>,
    /// Fields to approximate: input arrays, or fields given only per material (computed as
    /// `Σ fraction × per-material value`).
    pub fields: Vec<String>,
    /// Per-material values of the fields: arrays named "<field> for <material>" or
    /// "<field> (<material>)"; a <field> not among `fields` is added after them, as a field given only
    /// per material.
    pub material_fields: Vec<String>,
    /// World units; `None`: about one cell diagonal (as the ParaView filter's panel).
    pub interface_tolerance: Option<f64>,
    /// Data units; required with fields.
    pub field_tolerance: Option<f64>,
    pub ghost_values: bool,
    /// Origin and normal of the slice; `None`: through the centre, normal along x.
    pub slice: Option<[f64; 6]>,
    /// Resample a non-uniform rectilinear grid onto the uniform grid of the same points per axis.
    pub resample: bool,
}

/// What `diamonds material` did.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialSummary {
    pub dims: [usize; 3],
    pub materials: Vec<String>,
    pub fields: Vec<String>,
    pub interfaces: usize,
    pub tets: usize,
    pub interface_tets: usize,
    pub points: usize,
    pub interface_tolerance: f64,
    pub field_tolerance: f64,
    pub max_interface_error: f64,
    pub max_field_error: f64,
    pub ghost_values: bool,
    pub interface_polygons: usize,
    pub slice_polygons: usize,
    pub outputs: [PathBuf; 3],
    pub build_seconds: f64,
    pub refine_seconds: f64,
}

impl fmt::Display for MaterialSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [nx, ny, nz] = self.dims;
        write!(
            f,
            "{nx}x{ny}x{nz}, materials {}, fields [{}]: {} tetrahedra ({} after the interface pass), {} points, interface error {} (tolerance {}), field error {} (tolerance {}), {}; {} interface polygons, {} slice polygons; model {:.3} s, refinement {:.3} s; wrote {}, {}, {}",
            self.materials.join(", "),
            self.fields.join(", "),
            self.tets,
            self.interface_tets,
            self.points,
            self.max_interface_error,
            self.interface_tolerance,
            self.max_field_error,
            self.field_tolerance,
            if self.ghost_values { "ghost values" } else { "plain linear interpolation" },
            self.interface_polygons,
            self.slice_polygons,
            self.build_seconds,
            self.refine_seconds,
            self.outputs[0].display(),
            self.outputs[1].display(),
            self.outputs[2].display()
        )
    }
}

/// The three output paths of `base`.
pub fn output_paths(base: &Path) -> [PathBuf; 3] {
    let base = if crate::read::extension(base) == "vtu" {
        base.with_extension("")
    } else {
        base.to_path_buf()
    };
    let with = |suffix: &str| {
        let mut s = base.clone().into_os_string();
        s.push(suffix);
        PathBuf::from(s)
    };
    [with(".vtu"), with("-interfaces.vtp"), with("-slice.vtp")]
}

/// Point data of a structured grid from cell data: each point takes the average of the cells around
/// it, as `vtkCellDataToPointData` does.
pub fn cell_to_point(dims: [usize; 3], cells: &[f32]) -> Vec<f32> {
    let c = dims.map(|d| d.saturating_sub(1));
    let mut out = vec![0f32; dims[0] * dims[1] * dims[2]];
    if c.contains(&0) {
        return out;
    }
    let range = |i: usize, n: usize| i.saturating_sub(1)..i.min(n - 1) + 1;
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let mut sum = 0f64;
                let mut count = 0u32;
                for ck in range(k, c[2]) {
                    for cj in range(j, c[1]) {
                        for ci in range(i, c[0]) {
                            sum += cells[ci + c[0] * (cj + c[1] * ck)] as f64;
                            count += 1;
                        }
                    }
                }
                out[i + dims[0] * (j + dims[1] * k)] = (sum / count as f64) as f32;
            }
        }
    }
    out
}

/// Values given at the rectilinear `coords` resampled (trilinearly) at the points of the uniform grid
/// with the same number of points and bounds.
pub fn resample(coords: &[Vec<f64>; 3], values: &[f32]) -> Vec<f32> {
    let dims = [coords[0].len(), coords[1].len(), coords[2].len()];
    // Per axis and output index: the input interval and the weight of its upper end.
    let weights: Vec<Vec<(usize, f64)>> = coords
        .iter()
        .map(|c| {
            let n = c.len();
            (0..n)
                .map(|i| {
                    if n < 2 {
                        return (0, 0.0);
                    }
                    let x = c[0] + (c[n - 1] - c[0]) * i as f64 / (n - 1) as f64;
                    let hi = c.partition_point(|&v| v < x).clamp(1, n - 1);
                    let lo = hi - 1;
                    let t = if c[hi] > c[lo] {
                        ((x - c[lo]) / (c[hi] - c[lo])).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    (lo, t)
                })
                .collect()
        })
        .collect();
    let at = |i: usize, j: usize, k: usize| values[i + dims[0] * (j + dims[1] * k)] as f64;
    let mut out = Vec::with_capacity(values.len());
    for &(k0, tk) in &weights[2] {
        let k1 = (k0 + 1).min(dims[2] - 1);
        for &(j0, tj) in &weights[1] {
            let j1 = (j0 + 1).min(dims[1] - 1);
            for &(i0, ti) in &weights[0] {
                let i1 = (i0 + 1).min(dims[0] - 1);
                let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
                let x00 = lerp(at(i0, j0, k0), at(i1, j0, k0), ti);
                let x10 = lerp(at(i0, j1, k0), at(i1, j1, k0), ti);
                let x01 = lerp(at(i0, j0, k1), at(i1, j0, k1), ti);
                let x11 = lerp(at(i0, j1, k1), at(i1, j1, k1), ti);
                out.push(lerp(lerp(x00, x10, tj), lerp(x01, x11, tj), tk) as f32);
            }
        }
    }
    out
}

/// The point values of the selected array (point data, else cell data converted), as `f32`.
fn point_values(data: &Structured, array: &SelectedArray) -> Result<Vec<f32>> {
    let (arrays, what) = if array.cell {
        (&data.cell_data, "cell")
    } else {
        (&data.point_data, "point")
    };
    let Some(found) = arrays.iter().find(|a| a.name == array.name) else {
        bail!("no {what} array named '{}'", array.name);
    };
    let values: Vec<f32> = (0..found.data.len())
        .map(|k| found.value(k) as f32)
        .collect();
    Ok(if array.cell {
        cell_to_point(data.dims, &values)
    } else {
        values
    })
}

/// `diamonds material`: reads the input, prepares the model, refines and writes the three outputs.
pub fn material(opts: &MaterialOptions) -> Result<MaterialSummary> {
    for (what, t) in [
        ("interface tolerance", opts.interface_tolerance),
        ("field tolerance", opts.field_tolerance),
    ] {
        if let Some(t) = t {
            if !t.is_finite() || t < 0.0 {
                bail!("the {what} must be a finite number >= 0 (got {t})");
            }
        }
    }
    if (!opts.fields.is_empty() || !opts.material_fields.is_empty())
        && opts.field_tolerance.is_none()
    {
        bail!("give --field-tolerance (data units) with --fields or --material-fields");
    }
    if let Some(s) = opts.slice {
        if s.iter().any(|v| !v.is_finite()) || s[3..].iter().all(|&v| v == 0.0) {
            bail!("the slice must be 6 finite numbers ox,oy,oz,nx,ny,nz with a non-zero normal (got {s:?})");
        }
    }
    let outputs = output_paths(&opts.output);
    let data = read_structured(&opts.input)?;
    for w in &data.warnings {
        eprintln!("warning: '{}': {w}", opts.input.display());
    }
    let in_file = |e: crate::Error| crate::Error(format!("'{}': {e}", opts.input.display()));
    Grid::new(data.dims)
        .validate()
        .map_err(|e| in_file(e.into()))?;
    let grid = match (data.grid(), &data.geometry) {
        (Ok(grid), _) => grid,
        (Err(_), Geometry::Rectilinear(c)) if opts.resample => {
            let first = |c: &Vec<f64>| c[0];
            let last = |c: &Vec<f64>| c[c.len() - 1];
            Grid {
                dims: data.dims,
                origin: [first(&c[0]), first(&c[1]), first(&c[2])],
                spacing: std::array::from_fn(|a| {
                    (last(&c[a]) - first(&c[a])) / (data.dims[a] - 1) as f64
                }),
            }
        }
        (Err(e), Geometry::Rectilinear(_)) => {
            return Err(in_file(crate::Error(format!("{e} (or pass --resample)"))))
        }
        (Err(e), _) => return Err(in_file(e)),
    };
    let input: Vec<InputArray> = data
        .point_data
        .iter()
        .map(|a| (a, false))
        .chain(data.cell_data.iter().map(|a| (a, true)))
        .map(|(a, cell)| InputArray {
            name: &a.name,
            components: a.components,
            cell,
        })
        .collect();
    let selection = select_arrays(
        &input,
        &opts.fractions,
        &opts.fields,
        &opts.material_fields,
        &SelectionOptions {
            fractions: "--fractions",
            fields: "--fields",
            material_fields: "--material-fields",
        },
    )
    .map_err(|e| in_file(crate::Error(e)))?;
    let rectilinear = match &data.geometry {
        Geometry::Rectilinear(c) if opts.resample && data.grid().is_err() => Some(c),
        _ => None,
    };
    let load = |array: &SelectedArray| -> Result<Vec<f32>> {
        let v = point_values(&data, array).map_err(in_file)?;
        Ok(match rectilinear {
            Some(c) => resample(c, &v),
            None => v,
        })
    };
    let fraction_values: Vec<Vec<f32>> = selection
        .fractions
        .iter()
        .map(load)
        .collect::<Result<_>>()?;
    // (field, material, values) of each per-material array.
    let material_values: Vec<(usize, u8, Vec<f32>)> = selection
        .material_fields
        .iter()
        .map(|m| Ok((m.field, m.material as u8, load(&m.array)?)))
        .collect::<Result<_>>()?;
    // `None`: a field computed by the core as Σ fraction × own value.
    let field_values: Vec<Option<Vec<f32>>> = selection
        .fields
        .iter()
        .map(|f| f.array.as_ref().map(load).transpose())
        .collect::<Result<_>>()?;
    let fields = selection.field_names();
    let names = selection.materials;

    let start = Instant::now();
    let model = MaterialModel::new(&MaterialInput {
        grid,
        fractions: fraction_values.iter().map(Vec::as_slice).collect(),
        fields: field_values.iter().map(Option::as_deref).collect(),
        field_names: fields.iter().map(String::as_str).collect(),
        material_fields: MaterialField::borrow_all(&material_values),
        interfaces: None,
    })
    .map_err(|e| in_file(e.into()))?;
    let build_seconds = start.elapsed().as_secs_f64();
    let b = grid.bounds();
    // Default: about one cell diagonal (the diagonal over the cube root of the number of cells), as
    // the ParaView filter's panel.
    let diagonal = ((b[1] - b[0]).powi(2) + (b[3] - b[2]).powi(2) + (b[5] - b[4]).powi(2)).sqrt();
    let cells: f64 = grid.dims.iter().map(|&d| (d - 1) as f64).product();
    let interface_tolerance = opts.interface_tolerance.unwrap_or(diagonal / cells.cbrt());
    let field_tolerance = if fields.is_empty() {
        0.0
    } else {
        opts.field_tolerance.unwrap_or(0.0)
    };
    let start = Instant::now();
    let query = MaterialQuery {
        interface_tolerance,
        field_tolerance,
        ghost_values: opts.ghost_values,
    };
    let mesh = model.refine(&query, &mut |_| true)?;
    if let Some(w) = mesh.tolerance_warning(&query) {
        eprintln!("warning: '{}': {w}", opts.input.display());
    }
    let refine_seconds = start.elapsed().as_secs_f64();
    let slice = opts.slice.unwrap_or([
        0.5 * (b[0] + b[1]),
        0.5 * (b[2] + b[3]),
        0.5 * (b[4] + b[5]),
        1.0,
        0.0,
        0.0,
    ]);
    let interfaces = mesh.interface_polygons();
    let cut = mesh.slice(
        [slice[0], slice[1], slice[2]],
        [slice[3], slice[4], slice[5]],
    )?;

    // ---- The three outputs, with the ParaView filter's arrays.
    let [point_data, cell_data, field_data] =
        by_association(tetrahedra_arrays(&mesh, &names, &fields, &query).map_err(crate::Error)?);
    write_tets(
        &outputs[0],
        TetGrid {
            points: &mesh.points,
            tets: &mesh.tets,
            point_data,
            cell_data,
            field_data,
        },
    )?;
    let [point_data, cell_data, field_data] = by_association(interface_arrays(&mesh, &interfaces));
    write_polygon_mesh(&outputs[1], &interfaces, point_data, cell_data, field_data)?;
    let [point_data, cell_data, field_data] = by_association(slice_arrays(
        &cut,
        &fields,
        [slice[0], slice[1], slice[2]],
        [slice[3], slice[4], slice[5]],
    ));
    write_polygon_mesh(&outputs[2], &cut, point_data, cell_data, field_data)?;

    Ok(MaterialSummary {
        dims: grid.dims,
        materials: names,
        fields,
        interfaces: model.interfaces().len(),
        tets: mesh.tets.len(),
        interface_tets: mesh.interface_tetrahedra,
        points: mesh.points.len(),
        interface_tolerance,
        field_tolerance,
        max_interface_error: mesh.max_interface_error,
        max_field_error: mesh.max_field_error,
        ghost_values: opts.ghost_values,
        interface_polygons: interfaces.labels.len(),
        slice_polygons: cut.labels.len(),
        outputs,
        build_seconds,
        refine_seconds,
    })
}

/// The point, cell and field data of an output, as the writer takes them.
fn by_association(arrays: Vec<OutputArray>) -> [Vec<Array>; 3] {
    let mut out: [Vec<Array>; 3] = Default::default();
    for a in arrays {
        let slot = match a.association {
            Association::Point => 0,
            Association::Cell => 1,
            Association::Field => 2,
        };
        out[slot].push(Array {
            name: a.name,
            components: a.components,
            data: match a.values {
                ArrayValues::U8(v) => v.into(),
                ArrayValues::I32(v) => v.into(),
                ArrayValues::U32(v) => v.into(),
                ArrayValues::I64(v) => v.into(),
                ArrayValues::F32(v) => v.into(),
                ArrayValues::F64(v) => v.into(),
            },
        });
    }
    out
}

fn write_polygon_mesh(
    path: &Path,
    polygons: &PolygonMesh,
    point_data: Vec<Array>,
    cell_data: Vec<Array>,
    field_data: Vec<Array>,
) -> Result<()> {
    Ok(write_polygons(
        path,
        Polygons {
            points: &polygons.points,
            offsets: if polygons.labels.is_empty() {
                &[]
            } else {
                &polygons.offsets
            },
            connectivity: &polygons.connectivity,
            point_data,
            cell_data,
            field_data,
        },
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_split_at_commas_without_a_space() {
        let lists = [
            "Void Volume Fraction,Volume Fraction for Body, Nose".to_string(),
            "A,,B".to_string(),
        ];
        assert_eq!(
            split_names(&lists),
            [
                "Void Volume Fraction",
                "Volume Fraction for Body, Nose",
                "A",
                "B"
            ]
        );
    }

    #[test]
    fn output_paths_drop_a_vtu_extension() {
        let [a, b, c] = output_paths(Path::new("out/run.vtu"));
        assert_eq!(a, Path::new("out/run.vtu"));
        assert_eq!(b, Path::new("out/run-interfaces.vtp"));
        assert_eq!(c, Path::new("out/run-slice.vtp"));
        assert_eq!(output_paths(Path::new("x"))[0], Path::new("x.vtu"));
    }

    #[test]
    fn cell_to_point_averages_the_adjacent_cells() {
        // 3 x 2 x 2 points, 2 x 1 x 1 cells with values 1 and 3.
        let p = cell_to_point([3, 2, 2], &[1.0, 3.0]);
        assert_eq!(p.len(), 12);
        for j in 0..2 {
            for k in 0..2 {
                let row = &p[3 * (j + 2 * k)..3 * (j + 2 * k) + 3];
                assert_eq!(row, &[1.0, 2.0, 3.0]);
            }
        }
        // Interior point of a 3^3 grid: the mean of its 8 cells.
        let cells: Vec<f32> = (0..8).map(|c| c as f32).collect();
        let p = cell_to_point([3, 3, 3], &cells);
        assert_eq!(p[13], 3.5);
        assert_eq!(p[0], 0.0);
        assert_eq!(p[26], 7.0);
    }

    #[test]
    fn resample_is_exact_for_linear_data() {
        let coords = [
            vec![0.0, 0.1, 0.5, 1.0],
            vec![0.0, 2.0],
            vec![-1.0, 0.0, 0.2],
        ];
        let f = |x: f64, y: f64, z: f64| 2.0 * x - y + 3.0 * z + 1.0;
        let mut values = Vec::new();
        for &z in &coords[2] {
            for &y in &coords[1] {
                for &x in &coords[0] {
                    values.push(f(x, y, z) as f32);
                }
            }
        }
        let out = resample(&coords, &values);
        let mut k = 0;
        for kz in 0..3 {
            for ky in 0..2 {
                for kx in 0..4 {
                    let x = kx as f64 / 3.0;
                    let y = 2.0 * ky as f64;
                    let z = -1.0 + 1.2 * kz as f64 / 2.0;
                    assert!((out[k] as f64 - f(x, y, z)).abs() < 1e-5, "{k}");
                    k += 1;
                }
            }
        }
    }
}
