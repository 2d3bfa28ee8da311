//! `diamonds isodiamonds build|extract`: one isosurface or interval volume of a volume stored as a
//! relevant or minimal isodiamond hierarchy (`.isd`, Weiss & De Floriani §6–§7;
//! [`diamonds::isodiamond`]), then extracted from it at any tolerance without the volume.

use crate::commands::{read_input, IsoTolerance};
use crate::write::{checked_extension, write_tets, write_triangles, TetGrid, Triangles};
use crate::{bail, Array, AsScalarSlice, Result};
use diamonds::isodiamond::{self, Counts, Isodiamonds, Model, Target, DEFAULT_LADDER};
use diamonds::Hierarchy;
use std::fmt;
use std::path::PathBuf;
use std::time::Instant;

/// Options of `diamonds isodiamonds build`.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildOptions {
    pub input: PathBuf,
    /// The `.isd` file written.
    pub output: PathBuf,
    /// Point-data array (default: as for `tetra`).
    pub array: Option<String>,
    pub target: Target,
    /// MI instead of RI.
    pub minimal: bool,
    /// Rung tolerances as fractions of the image's diagonal, decreasing (default
    /// [`DEFAULT_LADDER`]); the rung 0 is added.
    pub ladder: Option<Vec<f64>>,
}

/// What `diamonds isodiamonds build` did.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildSummary {
    pub array: String,
    pub minimal: bool,
    pub counts: Counts,
    /// Size of the `.isd` file.
    pub bytes: usize,
    /// Rung tolerances, world units.
    pub ladder: Vec<f64>,
    pub build_seconds: f64,
}

impl fmt::Display for BuildSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let c = &self.counts;
        write!(
            f,
            "'{}': {} hierarchy, {} active, {} creation, {} relevant isodiamonds, {} crossings, {} orphan vertices, {} bytes, rungs {:?}, build {:.3} s",
            self.array,
            if self.minimal { "minimal (MI)" } else { "relevant (RI)" },
            c.active,
            c.creation,
            c.relevant,
            c.crossings,
            c.orphans,
            self.bytes,
            self.ladder,
            self.build_seconds
        )
    }
}

/// Builds the hierarchy of `opts` and writes it.
pub fn build(opts: &BuildOptions) -> Result<BuildSummary> {
    checked_extension(&opts.output, "isd", "output")?;
    let (image, _) = read_input(&opts.input, opts.array.as_deref())?;
    let array = image.scalars(opts.array.as_deref())?;
    let grid = image.grid;
    let fractions = opts.ladder.as_deref().unwrap_or(&DEFAULT_LADDER);
    let ladder: Vec<f64> = fractions.iter().map(|r| r * grid.diagonal()).collect();
    let start = Instant::now();
    let hierarchy = Hierarchy::build_for_isosurfaces(grid, array.scalar_slice()?)?;
    let model = if opts.minimal {
        Model::Minimal
    } else {
        Model::Relevant
    };
    let iso = isodiamond::build(
        &hierarchy,
        array.scalar_slice()?,
        opts.target,
        model,
        &ladder,
        &mut |_| true,
    )?;
    let build_seconds = start.elapsed().as_secs_f64();
    let bytes = iso.to_bytes();
    if let Err(e) = std::fs::write(&opts.output, &bytes) {
        bail!("cannot write '{}': {e}", opts.output.display());
    }
    Ok(BuildSummary {
        array: array.name.clone(),
        minimal: opts.minimal,
        counts: iso.counts(),
        bytes: bytes.len(),
        ladder: iso.ladder().to_vec(),
        build_seconds,
    })
}

/// Reads an `.isd` file.
pub fn read(path: &std::path::Path) -> Result<Isodiamonds> {
    checked_extension(path, "isd", "input")?;
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) => bail!("cannot read '{}': {e}", path.display()),
    };
    Isodiamonds::from_bytes(&bytes).map_err(|e| crate::Error(format!("'{}': {e}", path.display())))
}

/// Options of `diamonds isodiamonds extract`.
#[derive(Clone, Debug, PartialEq)]
pub struct ExtractOptions {
    /// The `.isd` file.
    pub input: PathBuf,
    /// `.vtp` for an isosurface, `.vtu` for an interval volume.
    pub output: PathBuf,
    pub tolerance: IsoTolerance,
}

/// What `diamonds isodiamonds extract` did.
#[derive(Clone, Debug, PartialEq)]
pub struct ExtractSummary {
    /// Triangles or tetrahedra.
    pub cells: usize,
    pub points: usize,
    /// The tolerance asked for and the rung's (the bound of the result), world units.
    pub tolerance: f64,
    pub rung_tolerance: f64,
    pub read_seconds: f64,
    /// Extraction (without writing).
    pub extract_seconds: f64,
}

impl fmt::Display for ExtractSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} cells, {} points, tolerance {} (rung {}), read {:.3} s, extraction {:.3} s",
            self.cells,
            self.points,
            self.tolerance,
            self.rung_tolerance,
            self.read_seconds,
            self.extract_seconds
        )
    }
}

/// Extracts the isosurface (`.vtp`: field data Tolerance, RungTolerance, NumberOfTriangles) or
/// interval volume (`.vtu`: cell data Level, field data Tolerance, RungTolerance,
/// NumberOfTetrahedra) an `.isd` file holds at a tolerance.
pub fn extract(opts: &ExtractOptions) -> Result<ExtractSummary> {
    let start = Instant::now();
    let iso = read(&opts.input)?;
    let read_seconds = start.elapsed().as_secs_f64();
    let tolerance = opts.tolerance.world(iso.grid());
    let rung = iso.ladder()[iso.rung(tolerance)?];
    let field = |n: usize, what: &str| {
        vec![
            Array::scalars("Tolerance", vec![tolerance]),
            Array::scalars("RungTolerance", vec![rung]),
            Array::scalars(what, vec![n as i64]),
        ]
    };
    let (cells, points, extract_seconds) = match iso.target() {
        Target::Isosurface(_) => {
            checked_extension(&opts.output, "vtp", "output (an isosurface)")?;
            let start = Instant::now();
            let s = iso.isosurface(tolerance)?;
            let seconds = start.elapsed().as_secs_f64();
            write_triangles(
                &opts.output,
                Triangles {
                    points: &s.points,
                    triangles: &s.triangles,
                    point_data: Vec::new(),
                    field_data: field(s.triangles.len(), "NumberOfTriangles"),
                },
            )?;
            (s.triangles.len(), s.points.len(), seconds)
        }
        Target::IntervalVolume(_) => {
            checked_extension(&opts.output, "vtu", "output (an interval volume)")?;
            let start = Instant::now();
            let v = iso.interval_volume(tolerance)?;
            let seconds = start.elapsed().as_secs_f64();
            write_tets(
                &opts.output,
                TetGrid {
                    points: &v.points,
                    tets: &v.tets,
                    point_data: Vec::new(),
                    cell_data: vec![Array::scalars("Level", v.levels.clone())],
                    field_data: field(v.tets.len(), "NumberOfTetrahedra"),
                },
            )?;
            (v.tets.len(), v.points.len(), seconds)
        }
    };
    Ok(ExtractSummary {
        cells,
        points,
        tolerance,
        rung_tolerance: rung,
        read_seconds,
        extract_seconds,
    })
}
