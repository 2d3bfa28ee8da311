//! `diamonds interval`: the multiresolution interval volume `{α ≤ f ≤ β}` of a volume as tetrahedra
//! (`.vtu`), as the ParaView filter Adaptive Interval Volume extracts it.

use crate::commands::{finish_as, inside, read_input, IsoTolerance, VerifyReport};
use crate::read::{read_unstructured, tetrahedra};
use crate::write::{checked_extension, write_tets, TetGrid};
use crate::{bail, interpolated, Array, AsScalarSlice, Number, Result};
use diamonds::interval::{self, IntervalQuery};
use diamonds::refine::check_region;
use diamonds::validate::{check_interval_volume, interval_distances};
use diamonds::{with_volume, Hierarchy};
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
            "'{}': {} tetrahedra, {} points ({} leaves), volume {:.6e}, tolerance {} (reached {}), error bound {}, build {:.3} s, extraction {:.3} s",
            self.array,
            self.tets,
            self.points,
            self.leaves,
            self.volume,
            Number(self.tolerance),
            Number(self.reached_tolerance),
            Number(self.error_bound),
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
            .map(|a| interpolated(a, &volume.sources, &volume.weights)),
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

/// Options of `diamonds verify-interval`.
#[derive(Clone, Debug, PartialEq)]
pub struct VerifyIntervalOptions {
    /// The image the interval volume was extracted from.
    pub image: PathBuf,
    /// The interval volume (`.vtu`).
    pub mesh: PathBuf,
    /// `[α, β]`, data units.
    pub range: [f64; 2],
    /// Point-data array of the image (default: as for `interval`); the mesh holds it under the same
    /// name.
    pub array: Option<String>,
    /// Fail when a one-sided Hausdorff distance exceeds it; `None`: report them only.
    pub tolerance: Option<f64>,
    /// Measure from points inside this world-space box only (the query's region of interest).
    pub region: Option<[f64; 6]>,
}

/// `diamonds verify-interval`: checks an interval volume written by `interval` (or by the filter
/// Adaptive Interval Volume) against its image, independently of the hierarchy: tetrahedra with
/// positive volumes forming a conforming mesh (every face in two tetrahedra, or in one on the
/// image's bounds or on a bounding isosurface: [`check_interval_volume`]), the array within
/// `[α, β]` at every point, and both one-sided Hausdorff distances between its bounding surfaces
/// and the full-resolution boundary of `{α ≤ f ≤ β}` ([`interval_distances`]), failed above the
/// tolerance. Unreadable input is an error; a failed check is reported in [`VerifyReport`].
pub fn verify_interval(opts: &VerifyIntervalOptions) -> Result<VerifyReport> {
    let [alpha, beta] = opts.range;
    if !(alpha.is_finite() && beta.is_finite() && alpha < beta) {
        bail!("the range must be two finite numbers A < B (got {alpha} {beta})");
    }
    if let Some(t) = opts.tolerance.filter(|t| !t.is_finite() || *t < 0.0) {
        bail!("the tolerance must be a finite number >= 0 in world units (got {t})");
    }
    let (image, _) = read_input(&opts.image, opts.array.as_deref())?;
    let array = image.scalars(opts.array.as_deref())?;
    let grid = image.grid;
    grid.validate()?;
    if let Some(r) = opts.region {
        check_region(&grid, r)?;
    }
    let mesh = read_unstructured(&opts.mesh)?;
    let mut report = VerifyReport {
        lines: vec![format!(
            "verify-interval '{}' against '{}' (array '{}', range {alpha} {beta})",
            opts.mesh.display(),
            opts.image.display(),
            array.name
        )],
        passed: true,
    };
    let checked = (|| {
        let tets = tetrahedra(&mesh)?;
        let values = mesh
            .point_data
            .iter()
            .find(|a| a.name == array.name && a.components == 1)
            .ok_or_else(|| format!("no point-data array '{}' in the mesh", array.name))?;
        let values: Vec<f64> = (0..mesh.points.len()).map(|k| values.value(k)).collect();
        Ok::<_, String>((tets, values))
    })();
    let described = checked.as_ref().map_err(Clone::clone);
    report.check(
        "cells",
        described
            .map(|(tets, _)| format!("{} tetrahedra, {} points", tets.len(), mesh.points.len())),
    );
    let Ok((tets, values)) = checked else {
        return Ok(finish_as(report, "verify-interval"));
    };
    report.check(
        "conformity",
        check_interval_volume(&mesh.points, &values, &tets, grid.bounds(), opts.range).map(|r| {
            format!(
                "positive volumes, {} interior faces shared by two, {} faces in one on the bounds or a bounding isosurface",
                r.interior_faces, r.boundary_faces
            )
        }),
    );
    report.check(
        "values",
        match values.iter().position(|v| !(alpha..=beta).contains(v)) {
            None => Ok(format!("all {} points within the range", values.len())),
            Some(k) => Err(format!(
                "point {k} at {:?} has the value {}, outside the range",
                mesh.points[k], values[k]
            )),
        },
    );
    let d = with_volume!(grid, array.scalar_slice()?, |v| interval_distances(
        &v,
        opts.range,
        &mesh.points,
        &values,
        &tets,
        opts.region,
        opts.tolerance
    ));
    let fine = format!(
        "full-resolution boundary at {alpha} and {beta}, off the bounds{}",
        inside(opts.region)
    );
    report.distances(&d, (&fine, "the bounding surfaces"), opts.tolerance);
    Ok(finish_as(report, "verify-interval"))
}
