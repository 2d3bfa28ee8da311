//! `diamonds`: adaptive tetrahedral meshes of volumes by longest-edge bisection (diamond hierarchies).

use clap::{Parser, Subcommand};
use diamonds::isodiamond::Target;
use diamonds::view::{Camera, Direction, Metric};
use diamonds_cli::commands::{
    self, Field, IsoOptions, IsoTolerance, SampleType, TetraOptions, DEFAULT_ISO_TOLERANCE,
};
use diamonds_cli::interval::{self, IntervalOptions};
use diamonds_cli::isodiamonds;
use diamonds_cli::material::{self, MaterialOptions, IMPACT_DIMS};
use diamonds_cli::progressive;
use diamonds_cli::view::{self, ViewOptions};
use std::path::PathBuf;
use std::process::ExitCode;

/// Adaptive tetrahedral meshes of volumes by longest-edge bisection (diamond hierarchies).
///
/// Every mesh point is an input sample; the mesh is conforming and reproduces every sample of the
/// volume within the tolerance (0 = lossless). `iso` extracts crack-free multiresolution isosurfaces
/// from the same hierarchy.
#[derive(Parser, Debug)]
#[command(name = "diamonds", version, propagate_version = true)]
struct Cli {
    /// Worker threads (0 = one per core).
    #[arg(long, global = true, default_value_t = 0, value_name = "N")]
    threads: usize,

    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Build an adaptive tetrahedral mesh (.vtu) of a volume (.vti or legacy .vtk).
    ///
    /// The output holds VTK_TETRA cells whose points are input samples, every input point-data array
    /// at those points, cell data BisectionDepth and ApproximationError, and field data Tolerance,
    /// NumberOfTetrahedra and MaximumError.
    Tetra {
        /// Input image: VTK XML ImageData (.vti) or legacy VTK STRUCTURED_POINTS (.vtk).
        input: PathBuf,
        /// Output unstructured grid (.vtu).
        output: PathBuf,
        /// Point-data array to mesh [default: the active scalars, else the first single-component array].
        #[arg(long, value_name = "NAME")]
        array: Option<String>,
        /// Largest allowed interpolation error, absolute, in data units (0 = lossless).
        #[arg(
            long,
            default_value_t = 0.0,
            value_name = "T",
            allow_hyphen_values = true
        )]
        tolerance: f64,
        /// Largest number of tetrahedra (0 = no limit); refinement stops before exceeding it.
        #[arg(long, default_value_t = 0, value_name = "N")]
        max_tets: usize,
        #[command(flatten)]
        roi: RegionOfInterest,
    },
    /// Extract a multiresolution isosurface (.vtp) of a volume (.vti or legacy .vtk).
    ///
    /// Marching tetrahedra over the adaptive mesh, refined where the surface passes until the
    /// isosurface error (approximation error over gradient magnitude, in world units) is within the
    /// tolerance. The surface is crack-free; at tolerance 0 it is the full-resolution one. The output
    /// holds triangles (Polys), point data Normals (unit, toward increasing values), every other
    /// point array of the input interpolated at the points (as ParaView's Contour) and, with
    /// --scalars, the isovalue of each point named like the input array; field data ErrorBound
    /// (achieved error, world units), NumberOfTriangles and Tolerance (world units).
    Iso {
        /// Input image: VTK XML ImageData (.vti) or legacy VTK STRUCTURED_POINTS (.vtk).
        input: PathBuf,
        /// Output surface (.vtp).
        output: PathBuf,
        /// Isovalue in data units; repeat the option for several surfaces.
        #[arg(
            long = "isovalue",
            required = true,
            value_name = "V",
            allow_hyphen_values = true
        )]
        isovalues: Vec<f64>,
        /// Point-data array to contour [default: the active scalars, else the first single-component array].
        #[arg(long, value_name = "NAME")]
        array: Option<String>,
        #[command(flatten)]
        tolerance: SurfaceTolerance,
        /// Largest number of triangles (0 = no limit): the smallest tolerance whose surface fits.
        #[arg(long, default_value_t = 0, value_name = "N")]
        max_triangles: usize,
        #[command(flatten)]
        roi: RegionOfInterest,
        /// Do not write point normals.
        #[arg(long)]
        no_normals: bool,
        /// Also write the isovalue of each point, named like the input array (Float64).
        #[arg(long)]
        scalars: bool,
        /// Also write the tetrahedra that carry the surface to this unstructured grid (.vtu), with the
        /// point data of `tetra`'s output, cell data BisectionDepth and IsosurfaceError (the isosurface error
        /// of each tetrahedron's diamond, world units) and field data NumberOfTetrahedra and
        /// MaximumError (the largest IsosurfaceError).
        #[arg(long, value_name = "MESH")]
        carrier: Option<PathBuf>,
    },
    /// Extract a multiresolution interval volume {A <= f <= B} (.vtu) of a volume (.vti or legacy
    /// .vtk) as conforming tetrahedra (Weiss & De Floriani sections 2.1 and 5).
    ///
    /// The adaptive mesh is refined as `iso` refines it for the isovalues A and B (both bounding
    /// surfaces within the tolerance of the full-resolution ones); every tetrahedron meeting the
    /// range is clipped to it and split by a rule on global point names, so the mesh conforms. At
    /// tolerance 0 the volume is exactly that of the piecewise-linear field on the finest
    /// tetrahedra. Output: tetrahedra with every point array (interpolated along mesh edges at new
    /// points; the processed one as Float64), cell data Level, field data ErrorBound, Tolerance,
    /// ReachedTolerance, NumberOfTetrahedra and NumberOfLeaves.
    Interval {
        /// Input image: VTK XML ImageData (.vti) or legacy VTK STRUCTURED_POINTS (.vtk).
        input: PathBuf,
        /// Output tetrahedra (.vtu).
        output: PathBuf,
        #[command(flatten)]
        range: ValueRange,
        /// Point-data array [default: the active scalars, else the first single-component array].
        #[arg(long, value_name = "NAME")]
        array: Option<String>,
        #[command(flatten)]
        tolerance: SurfaceTolerance,
        /// Largest number of tetrahedra (0 = no limit): the smallest tolerance whose volume fits.
        #[arg(long, default_value_t = 0, value_name = "N")]
        max_tets: usize,
        #[command(flatten)]
        roi: RegionOfInterest,
    },
    /// Build the view-dependent mesh (.vtu) of a volume for a camera (Gregorski 2002 section 4,
    /// Marchesin 2004).
    ///
    /// Diamonds are split while their view-dependent error exceeds the tolerance: the largest
    /// approximation error of their subtree projected at its nearest distance to the eye, in pixels
    /// (the value range spanning the volume's diagonal) or as error over distance; diamonds outside
    /// the view frustum stay coarse. With --max-tets the tolerance rises until the mesh fits. With
    /// --orbit the camera turns about the view-up axis through the focal point, frame after frame,
    /// each frame starting from the last one's mesh (split and merge queues); the last frame is
    /// written and every frame's splits, merges and time are printed. With --sort the cells are in
    /// exact visibility order from the camera position (the bisection tree as a BSP). Output as
    /// `tetra`'s plus cell data Level (bisection depth / 3); field data Tolerance is the
    /// view-dependent tolerance reached.
    View {
        /// Input image: VTK XML ImageData (.vti) or legacy VTK STRUCTURED_POINTS (.vtk).
        input: PathBuf,
        /// Output unstructured grid (.vtu).
        output: PathBuf,
        /// Point-data array to mesh [default: the active scalars, else the first single-component array].
        #[arg(long, value_name = "NAME")]
        array: Option<String>,
        /// Camera position (world).
        #[arg(long, num_args = 3, required = true, allow_hyphen_values = true, value_names = ["X", "Y", "Z"])]
        position: Vec<f64>,
        /// The point the camera looks at (world).
        #[arg(long, num_args = 3, required = true, allow_hyphen_values = true, value_names = ["X", "Y", "Z"])]
        focal_point: Vec<f64>,
        /// Camera up direction.
        #[arg(long, num_args = 3, default_values_t = [0.0, 0.0, 1.0], allow_hyphen_values = true, value_names = ["X", "Y", "Z"])]
        view_up: Vec<f64>,
        /// Vertical view angle in degrees.
        #[arg(
            long,
            default_value_t = 30.0,
            allow_hyphen_values = true,
            value_name = "DEGREES"
        )]
        view_angle: f64,
        /// Viewport width and height in pixels.
        #[arg(long, num_args = 2, default_values_t = [800, 600], value_names = ["W", "H"])]
        viewport: Vec<u32>,
        /// View-dependent tolerance (pixels with --metric pixels).
        #[arg(
            long,
            default_value_t = 1.0,
            allow_hyphen_values = true,
            value_name = "T"
        )]
        tolerance: f64,
        /// Unit of the view-dependent error.
        #[arg(long, value_enum, default_value_t = ViewMetric::Pixels)]
        metric: ViewMetric,
        /// Largest number of tetrahedra (0 = no limit).
        #[arg(long, default_value_t = 0, value_name = "N")]
        max_tets: usize,
        /// Cell order of the output, from the camera position.
        #[arg(long, value_enum, default_value_t = Sort::None)]
        sort: Sort,
        /// Frames of an orbit before the written frame, and the degrees the camera turns per frame.
        #[arg(long, num_args = 2, allow_hyphen_values = true, value_names = ["FRAMES", "DEGREES"])]
        orbit: Option<Vec<f64>>,
    },
    /// Write a generated volume (.vti) for demos and tests.
    ///
    /// The field on [-1, 1]^3 is normalised to [0, 1] (distances d as (d + 1) / 2) and scaled to 0..255
    /// (i8: -128..127), rounded for integer types. `--field impact` writes the multi-material impact
    /// case instead (Float32 point data "Volume Fraction for Void", "Volume Fraction for Block",
    /// "Volume Fraction for Projectile", "Density" and each material's own density "Density for
    /// Void", "Density for Block", "Density for Projectile", by default on the paper's 32x32x52
    /// points), and `--field tissue --image IN` probabilistic tissue maps of IN's intensity (Float32
    /// "Volume Fraction for Other", "Volume Fraction for Grey", "Volume Fraction for White" and "T1", on
    /// IN's points or resampled onto `--dims` with spacing 1).
    Generate {
        /// Output image (.vti).
        output: PathBuf,
        /// Field to sample.
        #[arg(long, value_enum, default_value_t = Field::MarschnerLobb)]
        field: Field,
        /// Points along x, y and z [default: 65 65 65; impact: 32 32 52].
        #[arg(long, num_args = 3, value_names = ["NX", "NY", "NZ"])]
        dims: Option<Vec<usize>>,
        /// Sample type [default: u8] (not with impact or tissue, which are Float32).
        #[arg(long = "type", value_enum)]
        ty: Option<SampleType>,
        /// The intensity volume (.vti or .vtk, its active scalars) of `--field tissue`.
        #[arg(long, value_name = "IN")]
        image: Option<PathBuf>,
    },
    /// Approximate multi-material data: adaptive tetrahedra with linear interfaces and ghost values.
    ///
    /// Gregorski et al. 2002, section 5, as the ParaView filter "Material Interface Approximation":
    /// interfaces reconstructed from the volume fractions, refined until every interface-mesh vertex
    /// lies within the interface tolerance of its tetrahedron's plane, then until every sample of each
    /// material lies within the field tolerance of that material's linear field (with ghost values)
    /// or of the mixed field's linear interpolation (--no-ghost-values). Input: .vti or uniformly
    /// spaced .vtr, point or cell data (cell data averaged onto the points). Writes OUT.vtu (the
    /// tetrahedra), OUT-interfaces.vtp (the approximated interfaces) and OUT-slice.vtp (a plane cut).
    Material {
        /// Input: VTK XML ImageData (.vti) or RectilinearGrid (.vtr).
        input: PathBuf,
        /// Output base name: writes OUT.vtu, OUT-interfaces.vtp and OUT-slice.vtp.
        #[arg(short, long, value_name = "OUT")]
        output: PathBuf,
        /// Volume-fraction arrays, one per material, comma-separated (a comma followed by a space
        /// belongs to the name, as in CTH's "Volume Fraction for Body, Nose"; the option may also be
        /// repeated) [default: every array whose name contains "fraction"].
        #[arg(long, value_name = "A,B,...")]
        fractions: Vec<String>,
        /// Fields to approximate, comma-separated like --fractions: mixed-cell arrays, or fields given
        /// only per material (a name that is no input array but has --material-fields arrays: its
        /// mixed values are the sum of fraction x per-material value, materials without one count 0).
        #[arg(long, value_name = "F,...")]
        fields: Vec<String>,
        /// Per-material values of the fields, comma-separated like --fractions: arrays named
        /// "<field> for <material>" or "<field> (<material>)" (a material's name from its fraction
        /// array: "Volume Fraction for Armor Plate" gives "Armor Plate"). With ghost values, a
        /// material's own value at its samples is then this value instead of the mixed one. A
        /// <field> not in --fields is a field given only per material ("Mass for Armor Plate,Mass
        /// for Body, Nose" alone gives a field "Mass").
        #[arg(long, value_name = "A,...")]
        material_fields: Vec<String>,
        /// Interface tolerance in world units [default: about one cell diagonal: the diagonal of the
        /// bounds over the cube root of the number of cells, as the ParaView filter].
        #[arg(long, value_name = "T", allow_hyphen_values = true)]
        interface_tolerance: Option<f64>,
        /// Field tolerance in data units (required with --fields or --material-fields).
        #[arg(long, value_name = "T", allow_hyphen_values = true)]
        field_tolerance: Option<f64>,
        /// Plain linear interpolation of the mixed fields instead of one field per material (the
        /// interfaces are not refined for: their error is reported, not bounded).
        #[arg(long)]
        no_ghost_values: bool,
        /// The slice plane: origin and normal [default: through the centre, normal along x].
        #[arg(
            long,
            value_delimiter = ',',
            num_args = 1,
            allow_hyphen_values = true,
            value_name = "OX,OY,OZ,NX,NY,NZ"
        )]
        slice: Option<Vec<f64>>,
        /// Resample a non-uniformly spaced .vtr onto the uniform grid with the same points per axis
        /// (trilinear) instead of refusing it.
        #[arg(long)]
        resample: bool,
    },
    /// Progressive tetrahedral meshes of unstructured grids (Labsik et al.): encode a .vtu as a base
    /// mesh plus vertex splits, decode any level.
    #[command(subcommand)]
    Progressive(ProgressiveCommand),
    /// Isodiamond hierarchies (Weiss & De Floriani sections 5-7): store one isosurface or interval
    /// volume of a volume as the diamonds it needs (.isd), extract it at any tolerance without the
    /// volume.
    #[command(subcommand)]
    Isodiamonds(IsodiamondsCommand),
    /// Check a mesh written by `tetra` against its volume, independently of the hierarchy.
    ///
    /// Checks that the cells are tetrahedra at input sample positions, conforming (every interior face
    /// shared by two), exactly covering the grid's box, that every sample is interpolated within the
    /// tolerance, that the reported errors bound the measured ones and that passed-through point data
    /// equals the input. Exit code 1 when a check fails.
    Verify {
        /// Input image (.vti or .vtk) the mesh was built from.
        input: PathBuf,
        /// Mesh (.vtu) to check.
        mesh: PathBuf,
        /// Point-data array the mesh was built from [default: as for tetra].
        #[arg(long, value_name = "NAME")]
        array: Option<String>,
        /// Tolerance to check, in data units.
        #[arg(long, value_name = "T", allow_hyphen_values = true)]
        tolerance: f64,
        #[command(flatten)]
        region: MeasuredRegion,
    },
    /// Check a surface (.vtp) written by `iso`: watertight, consistently oriented, unit normals and,
    /// with --isovalue, its distance to the full-resolution surface.
    ///
    /// Checks that every polygon is a triangle of three distinct points, that every edge is in exactly
    /// two triangles traversing it in opposite directions (except, with --image, edges on a face of the
    /// image's bounds, which may be in one) and that the Normals, if any, have unit length. With
    /// --isovalue, reports both one-sided Hausdorff distances to the image's full-resolution
    /// marching-tetrahedra surface (the surface `iso --tolerance 0` writes) and, with --tolerance, fails
    /// when either exceeds it. Exit code 1 when a check fails.
    VerifySurface {
        /// Surface (.vtp) to check.
        mesh: PathBuf,
        /// The image (.vti or .vtk) the surface was extracted from: the surface may end on its bounds
        /// [default: the surface must be closed].
        #[arg(long, value_name = "IMAGE")]
        image: Option<PathBuf>,
        /// Also measure both one-sided Hausdorff distances (exact point-triangle distances) between the
        /// surface and the image's full-resolution marching-tetrahedra surface at this isovalue: from
        /// every vertex of that surface and samples of its triangles spaced at most one voxel to
        /// ours, and from every vertex of ours and samples of its triangles spaced at most one voxel
        /// to it. Repeat the option for a surface of several isovalues (measured against all their
        /// full-resolution surfaces together).
        #[arg(long, value_name = "V", requires = "image", allow_hyphen_values = true)]
        isovalue: Vec<f64>,
        /// Fail when either distance exceeds this bound (world units).
        #[arg(
            long,
            value_name = "T",
            requires = "isovalue",
            allow_hyphen_values = true
        )]
        tolerance: Option<f64>,
        /// Point-data array of the image [default: as for iso].
        #[arg(long, value_name = "NAME", requires = "isovalue")]
        array: Option<String>,
        #[command(flatten)]
        region: MeasuredRegion,
    },
    /// Check an interval volume (.vtu) written by `interval` against its image: conforming, values in
    /// the range and, with --tolerance, its bounding surfaces within it of the full-resolution ones.
    ///
    /// Checks that the cells are tetrahedra with positive volumes, every face shared by two or lying
    /// on the image's bounds or on a bounding isosurface (its three values all A or all B), the
    /// array within [A, B] at every point, and reports both one-sided Hausdorff distances between
    /// the bounding surfaces (faces in one tetrahedron at A or at B, off the image's bounds) and
    /// the full-resolution boundary of {A <= f <= B} off the bounds: the marching-tetrahedra
    /// surfaces of A and B (the surfaces `iso --tolerance 0` writes), samples equal to B counted
    /// inside; with --tolerance, fails when either exceeds it (a volume extracted with a region of
    /// interest meets its tolerance only inside the region). Exit code 1 when a check fails.
    VerifyInterval {
        /// The image (.vti or .vtk) the interval volume was extracted from.
        image: PathBuf,
        /// Interval volume (.vtu) to check.
        mesh: PathBuf,
        #[command(flatten)]
        range: ValueRange,
        /// Fail when either distance exceeds this bound (world units).
        #[arg(long, value_name = "T", allow_hyphen_values = true)]
        tolerance: Option<f64>,
        /// Point-data array of the image, also the mesh's [default: as for interval].
        #[arg(long, value_name = "NAME")]
        array: Option<String>,
        #[command(flatten)]
        region: MeasuredRegion,
    },
}

/// `diamonds view --metric`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum ViewMetric {
    /// Gregorski's screen-space error in pixels.
    Pixels,
    /// Marchesin's approximation error over distance.
    DistanceRatio,
}

/// The range of `interval` and `verify-interval`.
#[derive(clap::Args, Debug)]
struct ValueRange {
    /// The range A B in data units, A < B.
    #[arg(
        long,
        num_args = 2,
        required = true,
        allow_hyphen_values = true,
        value_names = ["A", "B"]
    )]
    range: Vec<f64>,
}

impl ValueRange {
    fn get(&self) -> [f64; 2] {
        [self.range[0], self.range[1]]
    }
}

/// The isosurface tolerance of `iso` and `interval`: absolute, relative or the default.
#[derive(clap::Args, Debug)]
struct SurfaceTolerance {
    /// Largest isosurface error in world units, of every surface (for `interval`: of both bounding
    /// surfaces) (0 = full resolution where a surface passes) [default: two and a half voxel diagonals
    /// (a voxel diagonal: the diagonal of the image's bounds over the cube root of its number of
    /// cells), as the ParaView filters].
    #[arg(
        long,
        value_name = "T",
        allow_hyphen_values = true,
        conflicts_with = "relative_tolerance"
    )]
    tolerance: Option<f64>,
    /// The tolerance as a fraction of the diagonal of the image's bounds (0.01 = 1 %; exclusive with
    /// --tolerance).
    #[arg(long, value_name = "R", allow_hyphen_values = true)]
    relative_tolerance: Option<f64>,
}

impl SurfaceTolerance {
    fn get(&self) -> IsoTolerance {
        match (self.tolerance, self.relative_tolerance) {
            (Some(t), _) => IsoTolerance::Absolute(t),
            (None, Some(r)) => IsoTolerance::Relative(r),
            (None, None) => DEFAULT_ISO_TOLERANCE,
        }
    }
}

/// The region of interest of `tetra`, `iso` and `interval`.
#[derive(clap::Args, Debug)]
struct RegionOfInterest {
    /// Region of interest in world coordinates: the tolerance applies inside, the result stays coarse
    /// outside.
    #[arg(
        long,
        num_args = 6,
        allow_hyphen_values = true,
        value_names = ["XMIN", "XMAX", "YMIN", "YMAX", "ZMIN", "ZMAX"]
    )]
    roi: Option<Vec<f64>>,
}

impl RegionOfInterest {
    fn get(&self) -> Option<[f64; 6]> {
        six(&self.roi)
    }
}

/// The region of interest of `verify`, `verify-surface` and `verify-interval`.
#[derive(clap::Args, Debug)]
struct MeasuredRegion {
    /// Check the tolerance inside this box only (world coordinates): give the region of interest
    /// the result was made with, inside which its tolerance holds. `verify` checks the samples
    /// inside it, `verify-surface` and `verify-interval` measure the distances from the points
    /// inside it.
    #[arg(
        long,
        num_args = 6,
        allow_hyphen_values = true,
        value_names = ["XMIN", "XMAX", "YMIN", "YMAX", "ZMIN", "ZMAX"]
    )]
    roi: Option<Vec<f64>>,
}

impl MeasuredRegion {
    fn get(&self) -> Option<[f64; 6]> {
        six(&self.roi)
    }
}

/// The six values clap gives a `--roi`.
fn six(roi: &Option<Vec<f64>>) -> Option<[f64; 6]> {
    roi.as_ref()
        .map(|r| <[f64; 6]>::try_from(r.as_slice()).expect("clap gives 6 values"))
}

/// `diamonds view --sort`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum Sort {
    /// The mesh's own order.
    None,
    /// Farthest tetrahedron first.
    BackToFront,
    /// Nearest tetrahedron first.
    FrontToBack,
}

fn run(cli: Cli) -> diamonds_cli::Result<ExitCode> {
    if cli.threads > 0 {
        rayon::ThreadPoolBuilder::new()
            .num_threads(cli.threads)
            .build_global()
            .map_err(|e| {
                diamonds_cli::Error(format!("cannot start {} threads: {e}", cli.threads))
            })?;
    }
    match cli.command {
        Command::Tetra {
            input,
            output,
            array,
            tolerance,
            max_tets,
            roi,
        } => {
            let summary = commands::tetra(&TetraOptions {
                input,
                output: output.clone(),
                array,
                tolerance,
                max_tets,
                roi: roi.get(),
            })?;
            println!("{}: {summary}", output.display());
        }
        Command::Iso {
            input,
            output,
            isovalues,
            array,
            tolerance,
            max_triangles,
            roi,
            no_normals,
            scalars,
            carrier,
        } => {
            let summary = commands::iso(&IsoOptions {
                input,
                output: output.clone(),
                array,
                isovalues,
                tolerance: tolerance.get(),
                max_triangles,
                roi: roi.get(),
                normals: !no_normals,
                scalars,
                carrier,
            })?;
            println!("{}: {summary}", output.display());
        }
        Command::Interval {
            input,
            output,
            range,
            array,
            tolerance,
            max_tets,
            roi,
        } => {
            let summary = interval::interval(&IntervalOptions {
                input,
                output: output.clone(),
                array,
                range: range.get(),
                tolerance: tolerance.get(),
                max_tets,
                roi: roi.get(),
            })?;
            println!("{}: {summary}", output.display());
        }
        Command::View {
            input,
            output,
            array,
            position,
            focal_point,
            view_up,
            view_angle,
            viewport,
            tolerance,
            metric,
            max_tets,
            sort,
            orbit,
        } => {
            let three = |v: Vec<f64>| <[f64; 3]>::try_from(v).expect("clap gives 3 values");
            let orbit = match orbit {
                None => None,
                Some(o) if o[0] >= 1.0 && o[0].fract() == 0.0 => Some((o[0] as usize, o[1])),
                Some(o) => {
                    return Err(diamonds_cli::Error(format!(
                        "--orbit needs a whole number of frames ≥ 1 (got {})",
                        o[0]
                    )))
                }
            };
            let summary = view::view(&ViewOptions {
                input,
                output: output.clone(),
                array,
                camera: Camera {
                    position: three(position),
                    focal_point: three(focal_point),
                    view_up: three(view_up),
                    view_angle,
                    viewport: <[u32; 2]>::try_from(viewport).expect("clap gives 2 values"),
                },
                metric: match metric {
                    ViewMetric::Pixels => Metric::ScreenSpace,
                    ViewMetric::DistanceRatio => Metric::DistanceRatio,
                },
                tolerance,
                max_tets,
                sort: match sort {
                    Sort::None => None,
                    Sort::BackToFront => Some(Direction::BackToFront),
                    Sort::FrontToBack => Some(Direction::FrontToBack),
                },
                orbit,
            })?;
            if summary.frames.len() > 1 {
                for line in summary.frame_lines() {
                    println!("{line}");
                }
            }
            println!("{}: {summary}", output.display());
        }
        Command::Generate {
            output,
            field,
            dims,
            ty,
            image,
        } => {
            let dims = dims.map(|d| <[usize; 3]>::try_from(d).expect("clap gives 3 values"));
            if image.is_some() != (field == Field::Tissue) {
                return Err(diamonds_cli::Error(
                    "--image goes with --field tissue, and --field tissue needs --image".into(),
                ));
            }
            let material_case = matches!(field, Field::Impact | Field::Tissue);
            if material_case && ty.is_some_and(|t| t != SampleType::F32) {
                return Err(diamonds_cli::Error(
                    "the impact and tissue cases are Float32: leave out --type".into(),
                ));
            }
            if let Some(image) = image {
                println!("{}", material::generate_tissue(&output, &image, dims)?);
            } else if field == Field::Impact {
                println!(
                    "{}",
                    material::generate_impact(&output, dims.unwrap_or(IMPACT_DIMS))?
                );
            } else {
                println!(
                    "{}",
                    commands::generate(
                        &output,
                        field,
                        dims.unwrap_or([65, 65, 65]),
                        ty.unwrap_or(SampleType::U8)
                    )?
                );
            }
        }
        Command::Material {
            input,
            output,
            fractions,
            fields,
            material_fields,
            interface_tolerance,
            field_tolerance,
            no_ghost_values,
            slice,
            resample,
        } => {
            let slice = match slice {
                None => None,
                Some(s) => Some(<[f64; 6]>::try_from(s).map_err(|s| {
                    diamonds_cli::Error(format!(
                        "--slice needs 6 comma-separated numbers ox,oy,oz,nx,ny,nz (got {})",
                        s.len()
                    ))
                })?),
            };
            let summary = material::material(&MaterialOptions {
                input,
                output,
                fractions: material::split_names(&fractions),
                fields: material::split_names(&fields),
                material_fields: material::split_names(&material_fields),
                interface_tolerance,
                field_tolerance,
                ghost_values: !no_ghost_values,
                slice,
                resample,
            })?;
            println!("{summary}");
        }
        Command::Progressive(ProgressiveCommand::Encode {
            input,
            output,
            array,
            target_reduction,
            max_field_error,
            geometry_weight,
            field_weight,
            shape_weight,
            free_boundary,
            boundary_tolerance,
        }) => {
            let report = progressive::encode(&progressive::EncodeOptions {
                input,
                output,
                array,
                target_reduction,
                max_field_error,
                geometry_weight,
                field_weight,
                shape_weight,
                preserve_boundary: !free_boundary,
                boundary_tolerance,
            })?;
            println!("{report}");
        }
        Command::Progressive(ProgressiveCommand::Decode {
            input,
            level,
            output,
        }) => {
            println!(
                "{}",
                progressive::decode(&input, level.unwrap_or(usize::MAX), &output)?
            );
        }
        Command::Isodiamonds(IsodiamondsCommand::Build {
            input,
            output,
            isovalue,
            range,
            minimal,
            array,
            ladder,
        }) => {
            let target = match (isovalue, range) {
                (Some(v), _) => Target::Isosurface(v),
                (None, Some(r)) => Target::IntervalVolume([r[0], r[1]]),
                (None, None) => unreachable!("clap requires one"),
            };
            let summary = isodiamonds::build(&isodiamonds::BuildOptions {
                input,
                output: output.clone(),
                array,
                target,
                minimal,
                ladder,
            })?;
            println!("{}: {summary}", output.display());
        }
        Command::Isodiamonds(IsodiamondsCommand::Extract {
            input,
            output,
            tolerance,
        }) => {
            let summary = isodiamonds::extract(&isodiamonds::ExtractOptions {
                input,
                output: output.clone(),
                tolerance: tolerance.get(),
            })?;
            println!("{}: {summary}", output.display());
        }
        Command::Verify {
            input,
            mesh,
            array,
            tolerance,
            region,
        } => {
            let report =
                commands::verify(&input, &mesh, array.as_deref(), tolerance, region.get())?;
            return Ok(printed(&report));
        }
        Command::VerifySurface {
            mesh,
            image,
            isovalue,
            tolerance,
            array,
            region,
        } => {
            if region.roi.is_some() && isovalue.is_empty() {
                diamonds_cli::bail!(
                    "--roi needs --isovalue: it restricts the distances to the full-resolution surface"
                );
            }
            let bound = (!isovalue.is_empty()).then_some(commands::SurfaceBound {
                isovalues: isovalue,
                array,
                tolerance,
                region: region.get(),
            });
            let report = commands::verify_surface(&mesh, image.as_deref(), bound.as_ref())?;
            return Ok(printed(&report));
        }
        Command::VerifyInterval {
            image,
            mesh,
            range,
            tolerance,
            array,
            region,
        } => {
            let report = interval::verify_interval(&interval::VerifyIntervalOptions {
                image,
                mesh,
                range: range.get(),
                array,
                tolerance,
                region: region.get(),
            })?;
            return Ok(printed(&report));
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Prints a check's report; exit code 1 when a check failed.
fn printed(report: &commands::VerifyReport) -> ExitCode {
    for line in &report.lines {
        println!("{line}");
    }
    if report.passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

#[derive(Subcommand, Debug)]
enum IsodiamondsCommand {
    /// Build the relevant (RI, default) or minimal (MI, --minimal) isodiamond hierarchy of an
    /// isosurface or interval volume of a volume (.vti or legacy .vtk) and write it (.isd).
    ///
    /// Stores, per isodiamond, its central vertex's class and whether the full hierarchy (`iso` or
    /// `interval`) splits it at each rung of a ladder of tolerances (the rung 0 included), and one
    /// byte per edge crossing; `extract` then gives, at a tolerance, the full hierarchy's surface
    /// or volume at the finest rung not above it (points within 1/512 of their mesh edge).
    Build {
        /// Input image: VTK XML ImageData (.vti) or legacy VTK STRUCTURED_POINTS (.vtk).
        input: PathBuf,
        /// Output hierarchy (.isd).
        output: PathBuf,
        /// The isovalue of an isosurface.
        #[arg(
            long,
            value_name = "V",
            allow_hyphen_values = true,
            conflicts_with = "range",
            required_unless_present = "range"
        )]
        isovalue: Option<f64>,
        /// The range A B of an interval volume {A <= f <= B}, A < B.
        #[arg(
            long,
            num_args = 2,
            allow_hyphen_values = true,
            value_names = ["A", "B"]
        )]
        range: Option<Vec<f64>>,
        /// The minimal hierarchy (active and creation isodiamonds only) instead of the relevant one.
        #[arg(long)]
        minimal: bool,
        /// Point-data array [default: the active scalars, else the first single-component array].
        #[arg(long, value_name = "NAME")]
        array: Option<String>,
        /// Rung tolerances as fractions of the image's diagonal, decreasing, at most 7 (the rung 0
        /// is added) [default: 0.04,0.02,0.01,0.005,0.0025,0.00125,0.000625].
        #[arg(long, value_delimiter = ',', value_name = "R,...")]
        ladder: Option<Vec<f64>>,
    },
    /// Extract the isosurface (.vtp) or interval volume (.vtu) an isodiamond hierarchy (.isd) holds,
    /// at a tolerance (the finest rung not above it), without the volume.
    Extract {
        /// Input hierarchy (.isd).
        input: PathBuf,
        /// Output: triangles (.vtp) for an isosurface, tetrahedra (.vtu) for an interval volume.
        output: PathBuf,
        #[command(flatten)]
        tolerance: SurfaceTolerance,
    },
}

#[derive(Subcommand, Debug)]
enum ProgressiveCommand {
    /// Simplify a tetrahedral mesh (.vtu) by half-edge collapses into a progressive mesh stream (.dpm).
    ///
    /// The stream holds the base mesh, then one vertex split per removed vertex: any prefix decodes to
    /// a valid mesh. Every kept vertex is an original one, with all its point arrays. The field error
    /// reported is the exact maximum over the removed original vertices.
    Encode {
        /// Input unstructured grid of tetrahedra (.vtu).
        input: PathBuf,
        /// Output stream (.dpm).
        output: PathBuf,
        /// Point-data array of the field error [default: the first single-component one].
        #[arg(long, value_name = "NAME")]
        array: Option<String>,
        /// Fraction of the tetrahedra to remove (0-1), like Decimate's.
        #[arg(
            long,
            default_value_t = 0.9,
            value_name = "R",
            allow_hyphen_values = true
        )]
        target_reduction: f64,
        /// Largest field error at a removed vertex, data units (0 = no limit).
        #[arg(
            long,
            default_value_t = 0.0,
            value_name = "E",
            allow_hyphen_values = true
        )]
        max_field_error: f64,
        /// Weight of the geometric (boundary quadric) error.
        #[arg(
            long,
            default_value_t = 1.0,
            value_name = "W",
            allow_hyphen_values = true
        )]
        geometry_weight: f64,
        /// Weight of the field error.
        #[arg(
            long,
            default_value_t = 1.0,
            value_name = "W",
            allow_hyphen_values = true
        )]
        field_weight: f64,
        /// Weight of the shape error (condition number; 0 = only the validity tests keep shapes).
        #[arg(
            long,
            default_value_t = 0.0,
            value_name = "W",
            allow_hyphen_values = true
        )]
        shape_weight: f64,
        /// Let the boundary move (only the quadric error limits it) instead of keeping corners, feature
        /// edges and the boundary tolerance.
        #[arg(long)]
        free_boundary: bool,
        /// Largest distance of a removed boundary vertex from the boundary, as a fraction of the
        /// bounding-box diagonal.
        #[arg(
            long,
            default_value_t = 1e-3,
            value_name = "F",
            allow_hyphen_values = true
        )]
        boundary_tolerance: f64,
    },
    /// Write one level of a progressive mesh stream (.dpm) as a .vtu.
    ///
    /// Level 0 is the base mesh; the last level is the original. A stream cut short gives its last
    /// complete level. Field data: Level, NumberOfLevels, MaximumFieldError, RMSFieldError.
    Decode {
        /// Input stream (.dpm).
        input: PathBuf,
        /// Level to decode [default: the last, the original mesh].
        #[arg(long, value_name = "L")]
        level: Option<usize>,
        /// Output unstructured grid (.vtu).
        output: PathBuf,
    },
}

fn main() -> ExitCode {
    // A panic is a bug, never the answer to bad input: report it in one line, without a backtrace.
    std::panic::set_hook(Box::new(|info| {
        eprintln!("error: internal error (please report): {info}");
    }));
    let cli = Cli::parse();
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
