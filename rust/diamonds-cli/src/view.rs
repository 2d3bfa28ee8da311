//! `diamonds view`: the view-dependent mesh of a volume for a camera given on the command line,
//! optionally in exact visibility order, and optionally after an orbit of frames carried by the
//! split and merge queues (per-frame statistics printed).

use crate::commands::{mesh_arrays, read_input};
use crate::write::{checked_extension, write_tets, TetGrid};
use crate::{bail, Array, AsScalarSlice, Result};
use diamonds::view::{Camera, Direction, FrameStats, Metric, ViewErrors, ViewQuery, ViewState};
use diamonds::Hierarchy;
use std::fmt;
use std::path::PathBuf;
use std::time::Instant;

/// Options of `diamonds view`.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewOptions {
    pub input: PathBuf,
    pub output: PathBuf,
    /// Point-data array to mesh (default: the active scalars, else the first scalar array).
    pub array: Option<String>,
    pub camera: Camera,
    pub metric: Metric,
    /// View-dependent tolerance (pixels for the screen-space metric).
    pub tolerance: f64,
    /// Tetrahedron budget; 0 = no limit.
    pub max_tets: usize,
    /// Cell order of the output from the camera position, if any.
    pub sort: Option<Direction>,
    /// Frames of an orbit before the written one: the camera turns by `degrees` per frame about
    /// the view-up axis through the focal point.
    pub orbit: Option<(usize, f64)>,
}

/// What `diamonds view` did.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewSummary {
    pub array: String,
    pub points: usize,
    pub tets: usize,
    /// Every frame's statistics, the written one last.
    pub frames: Vec<FrameStats>,
    pub build_seconds: f64,
    /// Seconds to write the last frame's mesh (in visibility order when sorted).
    pub write_seconds: f64,
}

impl fmt::Display for ViewSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let last = self.frames.last().cloned().unwrap_or_default();
        write!(
            f,
            "'{}': {} points, {} tetrahedra, tolerance reached {:.4}, build {:.3} s, refinement {:.1} ms ({} splits, {} merges)",
            self.array,
            self.points,
            self.tets,
            last.tolerance,
            self.build_seconds,
            1e3 * last.seconds,
            last.splits,
            last.merges
        )?;
        write!(f, ", mesh written in {:.1} ms", 1e3 * self.write_seconds)
    }
}

impl ViewSummary {
    /// One line per frame: splits, merges, tetrahedra, tolerance reached, milliseconds.
    pub fn frame_lines(&self) -> Vec<String> {
        self.frames
            .iter()
            .enumerate()
            .map(|(i, s)| {
                format!(
                    "frame {i}: {} splits, {} merges, {} tetrahedra, tolerance {:.4}, {:.2} ms",
                    s.splits,
                    s.merges,
                    s.tets,
                    s.tolerance,
                    1e3 * s.seconds
                )
            })
            .collect()
    }
}

/// `diamonds view`: reads the image, builds the hierarchy and its view bounds, refines for each
/// frame and writes the last frame's mesh (in visibility order when asked).
pub fn view(opts: &ViewOptions) -> Result<ViewSummary> {
    checked_extension(&opts.output, "vtu", "output")?;
    if let Some((frames, degrees)) = opts.orbit {
        if frames == 0 || !degrees.is_finite() {
            bail!("--orbit needs at least one frame and a finite angle (got {frames} frames of {degrees} degrees)");
        }
    }
    let (image, _) = read_input(&opts.input, opts.array.as_deref())?;
    let array = image.scalars(opts.array.as_deref())?;
    let grid = image.grid;
    let start = Instant::now();
    let hierarchy = Hierarchy::build(grid, array.scalar_slice()?, &mut |_| true)?;
    let errors = ViewErrors::new(&hierarchy)?;
    let build_seconds = start.elapsed().as_secs_f64();
    if let Some(w) = hierarchy.budget_warning(opts.max_tets) {
        eprintln!("warning: '{}': {w}", array.name);
    }
    let (extra, degrees) = opts.orbit.unwrap_or((0, 0.0));
    let mut state = ViewState::new(&hierarchy);
    let mut camera = opts.camera;
    let mut frames = Vec::with_capacity(extra + 1);
    for frame in 0..=extra {
        if frame > 0 {
            camera = camera.orbited(degrees)?;
        }
        let query = ViewQuery {
            camera,
            metric: opts.metric,
            tolerance: opts.tolerance,
            max_tetrahedra: opts.max_tets,
        };
        frames.push(state.update(&hierarchy, &errors, &query)?);
    }
    let mut plan = state.plan()?;
    if let Some(direction) = opts.sort {
        // The core writes the tetrahedra in visibility order while it writes them (no tree).
        plan.set_visibility_order(&grid, camera.position, direction)?;
    }
    let start = Instant::now();
    let mesh = plan.to_mesh(&grid, |d| hierarchy.error(d))?;
    let write_seconds = start.elapsed().as_secs_f64();
    let reached = frames.last().map_or(opts.tolerance, |s| s.tolerance);
    let others = image.point_data.iter().filter(|a| !std::ptr::eq(*a, array));
    let mut data = mesh_arrays(std::iter::once(array).chain(others), &mesh, reached);
    let levels: Vec<u8> = mesh.depths.iter().map(|d| d / 3).collect();
    data.cell_data.push(Array::scalars("Level", levels));
    write_tets(
        &opts.output,
        TetGrid {
            points: &mesh.points,
            tets: &mesh.tets,
            point_data: data.point_data,
            cell_data: data.cell_data,
            field_data: data.field_data,
        },
    )?;
    Ok(ViewSummary {
        array: array.name.clone(),
        points: mesh.points.len(),
        tets: mesh.tets.len(),
        frames,
        build_seconds,
        write_seconds,
    })
}
