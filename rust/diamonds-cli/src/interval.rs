//! `diamonds interval`: the multiresolution interval volume `{α ≤ f ≤ β}` of a volume as tetrahedra
//! (`.vtu`), as the ParaView filter Adaptive Interval Volume extracts it.

use crate::commands::{read_input, IsoTolerance};
use crate::write::{checked_extension, write_tets, TetGrid};
use crate::{Array, AsScalarSlice, Result, Values};
use diamonds::interval::{self, IntervalQuery, IntervalVolume};
use diamonds::Hierarchy;
use std::fmt;
use std::path::PathBuf;
use std::time::Instant;

/// Options of `diamonds interval`.
#[derive(Clone, Debug, PartialEq)]
pub struct IntervalOptions {
    pub input: PathBuf,
    pub output: PathBuf,
    /// Point-data array whose range is extracted (default: as for `tetra`).
    pub array: Option<String>,
    /// `[α, β]`, data units.
    pub range: [f64; 2],
    pub tolerance: IsoTolerance,
    /// Tetrahedron budget; 0 = no limit.
    pub max_tets: usize,
    /// World box `[xmin, xmax, ymin, ymax, zmin, zmax]` where the tolerance applies.
    pub roi: Option<[f64; 6]>,
}

/// What `diamonds interval` did.
#[derive(Clone, Debug, PartialEq)]
pub struct IntervalSummary {
    pub array: String,
    pub tets: usize,
    pub points: usize,
    /// Leaves of the adaptive mesh that meet the range.
    pub leaves: usize,
    /// Sum of the tetrahedra's volumes.
    pub volume: f64,
    /// The tolerance asked for and the one refined for (raised by a budget), world units.
    pub tolerance: f64,
    pub reached_tolerance: f64,
    /// Largest isosurface error of the diamonds carrying a bounding surface, world units.
    pub error_bound: f64,
    pub build_seconds: f64,
    pub extract_seconds: f64,
}

impl fmt::Display for IntervalSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "'{}': {} tetrahedra, {} points ({} leaves), volume {:.6e}, tolerance {:.4} (reached {:.4}), error bound {:.4}, build {:.3} s, extraction {:.3} s",
            self.array,
            self.tets,
            self.points,
            self.leaves,
            self.volume,
            self.tolerance,
            self.reached_tolerance,
            self.error_bound,
            self.build_seconds,
            self.extract_seconds
        )
    }
}

/// Extracts and writes the interval volume of `opts`: every input point array interpolated at the
/// points (the processed one as Float64, exactly α or β at new points; integer arrays rounded),
/// cell data Level, field data ErrorBound, Tolerance, ReachedTolerance, NumberOfTetrahedra and
/// NumberOfLeaves.
pub fn interval(opts: &IntervalOptions) -> Result<IntervalSummary> {
    checked_extension(&opts.output, "vtu", "output")?;
    let (image, _) = read_input(&opts.input, opts.array.as_deref())?;
    let array = image.scalars(opts.array.as_deref())?;
    let grid = image.grid;
    let tolerance = opts.tolerance.world(&grid);
    let start = Instant::now();
    let hierarchy = Hierarchy::build_for_isosurfaces(grid, array.scalar_slice()?)?;
    let build_seconds = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let volume = interval::extract(
        &hierarchy,
        array.scalar_slice()?,
        &IntervalQuery {
            range: opts.range,
            tolerance,
            max_tetrahedra: opts.max_tets,
            region_of_interest: opts.roi,
        },
    )?;
    let extract_seconds = start.elapsed().as_secs_f64();
    for w in &volume.warnings {
        eprintln!("warning: '{}': {w}", array.name);
    }
    let mut point_data = vec![Array::scalars(&array.name, volume.values.clone())];
    point_data.extend(
        (image.point_data.iter())
            .filter(|a| !std::ptr::eq(*a, array))
            .map(|a| interpolated(a, &volume)),
    );
    let n = volume.tets.len();
    write_tets(
        &opts.output,
        TetGrid {
            points: &volume.points,
            tets: &volume.tets,
            point_data,
            cell_data: vec![Array::scalars("Level", volume.levels.clone())],
            field_data: vec![
                Array::scalars("ErrorBound", vec![volume.error_bound]),
                Array::scalars("Tolerance", vec![tolerance]),
                Array::scalars("ReachedTolerance", vec![volume.tolerance]),
                Array::scalars("NumberOfTetrahedra", vec![n as i64]),
                Array::scalars("NumberOfLeaves", vec![volume.leaves as i64]),
            ],
        },
    )?;
    let total = (volume.tets.iter())
        .map(|t| {
            let [a, b, c, d] = t.map(|i| volume.points[i as usize]);
            let [u, v, w] = [b, c, d].map(|p| [0, 1, 2].map(|k| p[k] - a[k]));
            (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
                + u[2] * (v[0] * w[1] - v[1] * w[0]))
                / 6.0
        })
        .sum();
    Ok(IntervalSummary {
        array: array.name.clone(),
        tets: n,
        points: volume.points.len(),
        leaves: volume.leaves,
        volume: total,
        tolerance,
        reached_tolerance: volume.tolerance,
        error_bound: volume.error_bound,
        build_seconds,
        extract_seconds,
    })
}

/// `a` at the points of `volume`: `(1 − w) a[i] + w a[j]` per component (exactly `a[i]` at a
/// sample), of `a`'s type (integers rounded).
fn interpolated(a: &Array, volume: &IntervalVolume) -> Array {
    let c = a.components;
    let mut out = Vec::with_capacity(volume.points.len() * c);
    for (&[i, j], &w) in volume.sources.iter().zip(&volume.weights) {
        for k in 0..c {
            let x = a.value(i as usize * c + k);
            out.push(if w == 0.0 {
                x
            } else {
                (1.0 - w) * x + w * a.value(j as usize * c + k)
            });
        }
    }
    let type_name = a.type_name();
    if !type_name.starts_with("Float") {
        out.iter_mut().for_each(|x| *x = x.round());
    }
    Array {
        name: a.name.clone(),
        components: c,
        data: Values::from_f64(type_name, out).expect("a numeric type"),
    }
}
