//! The `progressive` subcommand: `encode` simplifies a tetrahedral `.vtu` into a progressive mesh
//! (base mesh + vertex splits, Labsik et al.) written as a compact stream (`.dpm`, zlib-compressed
//! [`diamonds::progressive::stream`]); `decode` writes any level of a stream, or of any prefix of
//! one, as a `.vtu` with every point array passed through.

use crate::read::tetrahedra;
use crate::{bail, Array, Result, Values};
use diamonds::progressive::stream::{self, PointArray};
use diamonds::progressive::{Params, Reduction, TetInput};
use flate2::read::ZlibDecoder;
use flate2::write::ZlibEncoder;
use std::path::{Path, PathBuf};
use std::time::Instant;
use vtkxml::TetGrid;

/// VTK's value types in the order of the stream's type tags.
const VALUE_TYPES: [&str; 10] = [
    "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64", "Float32", "Float64",
];

/// What `diamonds progressive encode` does.
#[derive(Clone, Debug)]
pub struct EncodeOptions {
    pub input: PathBuf,
    pub output: PathBuf,
    /// The point array of the field error (default: the first single-component one).
    pub array: Option<String>,
    /// Fraction of the tetrahedra to remove (0–1).
    pub target_reduction: f64,
    /// Largest field error (0 = none).
    pub max_field_error: f64,
    pub geometry_weight: f64,
    pub field_weight: f64,
    pub shape_weight: f64,
    pub preserve_boundary: bool,
    /// Boundary tolerance as a fraction of the bounding-box diagonal.
    pub boundary_tolerance: f64,
}

/// Checks a target reduction (a fraction in [0, 1]).
pub fn check_reduction(r: f64) -> Result<()> {
    if !(0.0..=1.0).contains(&r) {
        bail!("the target reduction is {r}; it must be a fraction between 0 and 1");
    }
    Ok(())
}

/// The size of a file in bytes.
fn file_size(path: &Path) -> Result<u64> {
    std::fs::metadata(path)
        .map(|m| m.len())
        .map_err(|e| crate::Error(format!("cannot read '{}': {e}", path.display())))
}

/// Simplifies `opts.input` and writes the stream; returns the report.
pub fn encode(opts: &EncodeOptions) -> Result<String> {
    check_reduction(opts.target_reduction)?;
    vtkxml::checked_extension(&opts.output, "dpm", "output")?;
    let grid = vtkxml::read_unstructured(&opts.input)?;
    let in_file = |e: String| crate::Error(format!("'{}': {e}", opts.input.display()));
    let tets = tetrahedra(&grid).map_err(in_file)?;
    let n = grid.points.len();
    let scalars = match &opts.array {
        Some(name) => grid
            .point_data
            .iter()
            .find(|a| &a.name == name)
            .ok_or_else(|| in_file(format!("no point-data array named '{name}'")))?,
        None => grid
            .point_data
            .iter()
            .find(|a| a.components == 1)
            .ok_or_else(|| in_file("no single-component point-data array to measure the field error on (progressive meshes need scalars)".into()))?,
    };
    if scalars.components != 1 {
        return Err(in_file(format!(
            "point-data array '{}' has {} components; choose a single-component one",
            scalars.name, scalars.components
        )));
    }
    let values: Vec<f64> = (0..n).map(|k| scalars.value(k)).collect();
    let bounds =
        grid.points
            .iter()
            .fold([f64::INFINITY, f64::NEG_INFINITY].repeat(3), |mut b, p| {
                for a in 0..3 {
                    b[2 * a] = b[2 * a].min(p[a]);
                    b[2 * a + 1] = b[2 * a + 1].max(p[a]);
                }
                b
            });
    let diagonal = diamonds::volume::bounds_diagonal(&bounds.try_into().expect("six bounds"));
    let params = Params {
        target_tets: ((1.0 - opts.target_reduction) * tets.len() as f64).round() as usize,
        max_field_error: opts.max_field_error,
        geometry_weight: opts.geometry_weight,
        field_weight: opts.field_weight,
        shape_weight: opts.shape_weight,
        preserve_boundary: opts.preserve_boundary,
        boundary_tolerance: opts.boundary_tolerance * diagonal,
    };
    let start = Instant::now();
    let mut reduction = Reduction::new(
        TetInput {
            points: &grid.points,
            tets: &tets,
            scalars: &values,
        },
        &params,
    )
    .map_err(|e| in_file(e.to_string()))?;
    reduction
        .reduce_to(params.target_tets, &mut |_| true)
        .map_err(|e| in_file(e.to_string()))?;
    if let Some(w) = reduction.shortfall(params.target_tets) {
        eprintln!("warning: '{}': {w}", scalars.name);
    }
    let pm = reduction.into_mesh();
    let seconds = start.elapsed().as_secs_f64();
    let arrays: Vec<PointArray> = grid
        .point_data
        .iter()
        .map(|a| PointArray {
            name: a.name.clone(),
            components: a.components,
            type_tag: VALUE_TYPES
                .iter()
                .position(|&t| t == a.type_name())
                .expect("every vtkxml type is listed") as u8,
            values: (0..a.data.len()).map(|k| a.value(k)).collect(),
        })
        .collect();
    let file = std::fs::File::create(&opts.output)
        .map_err(|e| crate::Error(format!("cannot write '{}': {e}", opts.output.display())))?;
    let mut z = ZlibEncoder::new(
        std::io::BufWriter::new(file),
        flate2::Compression::default(),
    );
    stream::encode(&pm, &arrays, &mut z)?;
    z.finish()
        .map_err(|e| crate::Error(format!("cannot write '{}': {e}", opts.output.display())))?;
    let (vtu, dpm) = (file_size(&opts.input)?, file_size(&opts.output)?);
    let base = pm.error(0);
    Ok(format!(
        "{} tetrahedra, {n} points -> base mesh of {} tetrahedra ({:.1} % reduction) and {} vertex splits in {seconds:.2} s\n\
         field '{}': base mesh max error {:.6e}, RMS {:.6e} at the removed vertices; max boundary distance {:.3e}\n\
         '{}': {dpm} bytes ({:.1} % of the .vtu's {vtu} bytes), every level included",
        tets.len(),
        base.tets,
        100.0 * (1.0 - base.tets as f64 / tets.len() as f64),
        pm.levels(),
        scalars.name,
        base.max_field_error,
        base.rms_field_error,
        base.max_boundary_distance,
        opts.output.display(),
        100.0 * dpm as f64 / vtu as f64,
    ))
}

/// Writes level `level` (clamped to the last one the stream holds) of the stream `input` as `output`
/// (`.vtu`); returns the report.
pub fn decode(input: &Path, level: usize, output: &Path) -> Result<String> {
    vtkxml::checked_extension(output, "vtu", "output")?;
    let file = std::fs::File::open(input)
        .map_err(|e| crate::Error(format!("cannot read '{}': {e}", input.display())))?;
    let d = stream::decode(ZlibDecoder::new(std::io::BufReader::new(file)), level)
        .map_err(|e| crate::Error(format!("'{}': {e}", input.display())))?;
    let mut point_data = Vec::with_capacity(d.arrays.len());
    for a in d.arrays {
        let type_name = VALUE_TYPES.get(a.type_tag as usize).ok_or_else(|| {
            crate::Error(format!(
                "'{}': array '{}' has an unknown type tag {}",
                input.display(),
                a.name,
                a.type_tag
            ))
        })?;
        point_data.push(Array {
            name: a.name,
            components: a.components,
            data: Values::from_f64(type_name, a.values).expect("a listed type"),
        });
    }
    let field = |name: &str, v: f64| Array::scalars(name, vec![v]);
    vtkxml::write_tets(
        output,
        TetGrid {
            points: &d.points,
            tets: &d.tets,
            point_data,
            cell_data: Vec::new(),
            field_data: vec![
                field("Level", d.level as f64),
                field("NumberOfLevels", d.levels as f64),
                field("MaximumFieldError", d.max_field_error),
                field("RMSFieldError", d.rms_field_error),
            ],
        },
    )?;
    let note = if level > d.level {
        format!(
            " (level {level} asked; the stream {})",
            if d.level < d.levels {
                "is cut short"
            } else {
                "ends there"
            }
        )
    } else {
        String::new()
    };
    Ok(format!(
        "level {} of {}{note}: {} tetrahedra, {} points (original {} tetrahedra, {} points), max field error {:.6e}, RMS {:.6e} -> '{}'",
        d.level,
        d.levels,
        d.tets.len(),
        d.points.len(),
        d.original_tets,
        d.original_points,
        d.max_field_error,
        d.rms_field_error,
        output.display()
    ))
}
