//! `diamonds`: adaptive tetrahedral meshes of volumes by longest-edge bisection (diamond hierarchies).

use clap::{Parser, Subcommand};
use diamonds_cli::commands::{
    self, Field, IsoOptions, IsoTolerance, SampleType, TetraOptions, DEFAULT_ISO_TOLERANCE,
};
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
    /// at those points, cell data Level and ApproximationError, and field data Tolerance,
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
            allow_negative_numbers = true
        )]
        tolerance: f64,
        /// Largest number of tetrahedra (0 = no limit); refinement stops before exceeding it.
        #[arg(long, default_value_t = 0, value_name = "N")]
        max_tets: usize,
        /// Region of interest in world coordinates: the tolerance applies inside, the mesh stays coarse
        /// outside.
        #[arg(
            long,
            num_args = 6,
            allow_negative_numbers = true,
            value_names = ["XMIN", "XMAX", "YMIN", "YMAX", "ZMIN", "ZMAX"]
        )]
        roi: Option<Vec<f64>>,
    },
    /// Extract a multiresolution isosurface (.vtp) of a volume (.vti or legacy .vtk).
    ///
    /// Marching tetrahedra over the adaptive mesh, refined where the surface passes until the
    /// isosurface error (approximation error over gradient magnitude, in world units) is within the
    /// tolerance. The surface is crack-free; at tolerance 0 it is the full-resolution one. The output
    /// holds triangles (Polys), point data Normals (unit, toward increasing values) and, with --scalars,
    /// the isovalue of each point named like the input array; field data ErrorBound (achieved error,
    /// world units), NumberOfTriangles and Tolerance (world units).
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
            allow_negative_numbers = true
        )]
        isovalues: Vec<f64>,
        /// Point-data array to contour [default: the active scalars, else the first single-component array].
        #[arg(long, value_name = "NAME")]
        array: Option<String>,
        /// Largest isosurface error in world units (0 = full resolution where the surface passes)
        /// [default: about one voxel diagonal: the diagonal of the image's bounds over the cube root of
        /// its number of cells, as the ParaView filter].
        #[arg(
            long,
            value_name = "T",
            allow_negative_numbers = true,
            conflicts_with = "relative_tolerance"
        )]
        tolerance: Option<f64>,
        /// The tolerance as a fraction of the diagonal of the image's bounds (0.01 = 1 %; exclusive with
        /// --tolerance).
        #[arg(long, value_name = "R", allow_negative_numbers = true)]
        relative_tolerance: Option<f64>,
        /// Largest number of triangles (0 = no limit): the smallest tolerance whose surface fits.
        #[arg(long, default_value_t = 0, value_name = "N")]
        max_triangles: usize,
        /// Region of interest in world coordinates: the tolerance applies inside, the surface stays
        /// coarse outside.
        #[arg(
            long,
            num_args = 6,
            allow_negative_numbers = true,
            value_names = ["XMIN", "XMAX", "YMIN", "YMAX", "ZMIN", "ZMAX"]
        )]
        roi: Option<Vec<f64>>,
        /// Do not write point normals.
        #[arg(long)]
        no_normals: bool,
        /// Also write the isovalue of each point, named like the input array (Float64).
        #[arg(long)]
        scalars: bool,
        /// Also write the tetrahedra that carry the surface to this unstructured grid (.vtu), with the
        /// point and cell data of `tetra`'s output.
        #[arg(long, value_name = "MESH")]
        carrier: Option<PathBuf>,
    },
    /// Write a generated volume (.vti) for demos and tests.
    ///
    /// The field on [-1, 1]^3 is normalised to [0, 1] (distances d as (d + 1) / 2) and scaled to 0..255
    /// (i8: -128..127), rounded for integer types.
    Generate {
        /// Output image (.vti).
        output: PathBuf,
        /// Field to sample.
        #[arg(long, value_enum, default_value_t = Field::MarschnerLobb)]
        field: Field,
        /// Points along x, y and z.
        #[arg(long, num_args = 3, value_names = ["NX", "NY", "NZ"], default_values_t = [65, 65, 65])]
        dims: Vec<usize>,
        /// Sample type.
        #[arg(long = "type", value_enum, default_value_t = SampleType::U8)]
        ty: SampleType,
    },
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
        #[arg(long, value_name = "T", allow_negative_numbers = true)]
        tolerance: f64,
    },
    /// Check a surface (.vtp) written by `iso`: watertight, consistently oriented, unit normals.
    ///
    /// Checks that every polygon is a triangle of three distinct points, that every edge is in exactly
    /// two triangles traversing it in opposite directions (except, with --image, edges on a face of the
    /// image's bounds, which may be in one) and that the Normals, if any, have unit length. Exit code 1
    /// when a check fails.
    VerifySurface {
        /// Surface (.vtp) to check.
        mesh: PathBuf,
        /// The image (.vti or .vtk) the surface was extracted from: the surface may end on its bounds
        /// [default: the surface must be closed].
        #[arg(long, value_name = "IMAGE")]
        image: Option<PathBuf>,
    },
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
            let roi = roi.map(|r| <[f64; 6]>::try_from(r).expect("clap gives 6 values"));
            let summary = commands::tetra(&TetraOptions {
                input,
                output: output.clone(),
                array,
                tolerance,
                max_tets,
                roi,
            })?;
            println!("{}: {summary}", output.display());
        }
        Command::Iso {
            input,
            output,
            isovalues,
            array,
            tolerance,
            relative_tolerance,
            max_triangles,
            roi,
            no_normals,
            scalars,
            carrier,
        } => {
            let roi = roi.map(|r| <[f64; 6]>::try_from(r).expect("clap gives 6 values"));
            let tolerance = match (tolerance, relative_tolerance) {
                (Some(t), _) => IsoTolerance::Absolute(t),
                (None, Some(r)) => IsoTolerance::Relative(r),
                (None, None) => DEFAULT_ISO_TOLERANCE,
            };
            let summary = commands::iso(&IsoOptions {
                input,
                output: output.clone(),
                array,
                isovalues,
                tolerance,
                max_triangles,
                roi,
                normals: !no_normals,
                scalars,
                carrier,
            })?;
            println!("{}: {summary}", output.display());
        }
        Command::Generate {
            output,
            field,
            dims,
            ty,
        } => {
            let dims = <[usize; 3]>::try_from(dims).expect("clap gives 3 values");
            println!("{}", commands::generate(&output, field, dims, ty)?);
        }
        Command::Verify {
            input,
            mesh,
            array,
            tolerance,
        } => {
            let report = commands::verify(&input, &mesh, array.as_deref(), tolerance)?;
            for line in &report.lines {
                println!("{line}");
            }
            if !report.passed {
                return Ok(ExitCode::from(1));
            }
        }
        Command::VerifySurface { mesh, image } => {
            let report = commands::verify_surface(&mesh, image.as_deref())?;
            for line in &report.lines {
                println!("{line}");
            }
            if !report.passed {
                return Ok(ExitCode::from(1));
            }
        }
    }
    Ok(ExitCode::SUCCESS)
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
