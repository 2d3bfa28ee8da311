//! The subcommands as library functions: [`tetra`], [`iso`], [`generate`], [`verify`] and
//! [`verify_surface`].

use crate::read::{read_image, read_polydata, read_unstructured, tetrahedra};
use crate::write::{
    checked_extension, write_image, write_tets, write_triangles, TetGrid, Triangles,
};
use crate::{bail, interpolated, Array, AsScalarSlice, Number, Result};
use diamonds::refine::check_region;
use diamonds::validate::{
    check_mesh, check_surface, check_tolerance, check_unit_normals, surface_distances,
    SurfaceDistances,
};
use diamonds::{fields, with_volume, Grid, Hierarchy, IsoQuery, Query, TetMesh};
use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of `diamonds tetra`.
#[derive(Clone, Debug, PartialEq)]
pub struct TetraOptions {
    pub input: PathBuf,
    pub output: PathBuf,
    /// Point-data array to mesh (default: the active scalars, else the first scalar array).
    pub array: Option<String>,
    /// Absolute tolerance in data units; 0 = lossless.
    pub tolerance: f64,
    /// Tetrahedron budget; 0 = no limit.
    pub max_tets: usize,
    /// World box `[xmin, xmax, ymin, ymax, zmin, zmax]` where the tolerance applies.
    pub roi: Option<[f64; 6]>,
}

/// What `diamonds tetra` did.
#[derive(Clone, Debug, PartialEq)]
pub struct TetraSummary {
    pub array: String,
    pub dims: [usize; 3],
    pub points: usize,
    pub tets: usize,
    pub max_error: f64,
    pub tolerance: f64,
    /// The `--max-tets` budget (0 = none).
    pub max_tets: usize,
    /// Whether the tolerance applied inside a region of interest only.
    pub roi: bool,
    pub read_seconds: f64,
    pub build_seconds: f64,
    pub query_seconds: f64,
    pub write_seconds: f64,
    pub base_tets: usize,
    pub metadata_bytes_per_voxel: f64,
}

impl fmt::Display for TetraSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [nx, ny, nz] = self.dims;
        write!(
            f,
            "'{}' {nx}x{ny}x{nz}: {} points, {} tetrahedra, max error {} (tolerance {}{}), read {:.3} s, build {:.3} s, query {:.3} s, write {:.3} s, {} base tetrahedra, {:.2} bytes/voxel of metadata",
            self.array,
            self.points,
            self.tets,
            Number(self.max_error),
            Number(self.tolerance),
            match (self.max_error > self.tolerance, self.max_tets, self.roi) {
                (false, ..) => String::new(),
                (true, 0, false) => "; above it".into(),
                (true, 0, true) => "; inside the region of interest".into(),
                (true, n, false) => format!("; raised by the budget of {n} tetrahedra"),
                (true, n, true) => format!(
                    "; inside the region of interest, or raised by the budget of {n} tetrahedra"
                ),
            },
            self.read_seconds,
            self.build_seconds,
            self.query_seconds,
            self.write_seconds,
            self.base_tets,
            self.metadata_bytes_per_voxel
        )
    }
}

fn check_tolerance_value(tolerance: f64) -> Result<()> {
    if !tolerance.is_finite() || tolerance < 0.0 {
        bail!("the tolerance must be a finite number >= 0 (got {tolerance})");
    }
    Ok(())
}

/// The data of the output mesh: `point_arrays` (input point data, one tuple per input point) at the
/// mesh points, cell data `BisectionDepth` and `ApproximationError`, field data `Tolerance`,
/// `NumberOfTetrahedra` and `MaximumError`.
pub fn mesh_arrays<'a>(
    point_arrays: impl IntoIterator<Item = &'a Array>,
    mesh: &TetMesh,
    tolerance: f64,
) -> TetGridData {
    let point_data = point_arrays
        .into_iter()
        .map(|a| a.gather(&mesh.point_ids))
        .collect();
    let cell_data = vec![
        Array::scalars("BisectionDepth", mesh.depths.clone()),
        Array::scalars("ApproximationError", mesh.errors.clone()),
    ];
    let field_data = vec![
        Array::scalars("Tolerance", vec![tolerance]),
        Array::scalars("NumberOfTetrahedra", vec![mesh.tets.len() as i64]),
        Array::scalars("MaximumError", vec![mesh.max_error]),
    ];
    TetGridData {
        point_data,
        cell_data,
        field_data,
    }
}

/// The data arrays of an output mesh (see [`mesh_arrays`]).
pub struct TetGridData {
    pub point_data: Vec<Array>,
    pub cell_data: Vec<Array>,
    pub field_data: Vec<Array>,
}

/// Reads the input image of `tetra` and `iso`, checks that it holds the array to mesh (refusing it with
/// the file's name in the message) and prints the reader's warnings; returns the image and the seconds
/// it took.
pub(crate) fn read_input(path: &Path, array: Option<&str>) -> Result<(crate::read::Image, f64)> {
    let start = Instant::now();
    let mut image = read_image(path)?;
    let converted = match image.exact_scalars(array) {
        Ok(converted) => converted,
        Err(e) => bail!("'{}': {e}", path.display()),
    };
    for w in image.warnings.iter().chain(&converted) {
        eprintln!("warning: '{}': {w}", path.display());
    }
    Ok((image, start.elapsed().as_secs_f64()))
}

/// `diamonds tetra`: reads the image, builds the hierarchy, queries and writes the `.vtu`.
pub fn tetra(opts: &TetraOptions) -> Result<TetraSummary> {
    check_tolerance_value(opts.tolerance)?;
    checked_extension(&opts.output, "vtu", "output")?;
    let (image, read_seconds) = read_input(&opts.input, opts.array.as_deref())?;
    let array = image.scalars(opts.array.as_deref())?;
    let grid = image.grid;
    let start = Instant::now();
    let hierarchy = Hierarchy::build(grid, array.scalar_slice()?, &mut |_| true)?;
    let build_seconds = start.elapsed().as_secs_f64();
    if let Some(w) = hierarchy.budget_warning(opts.max_tets) {
        eprintln!("warning: '{}': {w}", array.name);
    }
    let start = Instant::now();
    let mesh = hierarchy.query(&Query {
        tolerance: opts.tolerance,
        max_tetrahedra: opts.max_tets,
        region_of_interest: opts.roi,
    })?;
    let query_seconds = start.elapsed().as_secs_f64();
    let start = Instant::now();
    // The meshed array first: it becomes the active scalars of the output.
    let others = image.point_data.iter().filter(|a| !std::ptr::eq(*a, array));
    let data = mesh_arrays(std::iter::once(array).chain(others), &mesh, opts.tolerance);
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
    let write_seconds = start.elapsed().as_secs_f64();
    Ok(TetraSummary {
        array: array.name.clone(),
        dims: grid.dims,
        points: mesh.points.len(),
        tets: mesh.tets.len(),
        max_error: mesh.max_error,
        tolerance: opts.tolerance,
        max_tets: opts.max_tets,
        roi: opts.roi.is_some(),
        read_seconds,
        build_seconds,
        query_seconds,
        write_seconds,
        base_tets: hierarchy.base_tetrahedra(),
        metadata_bytes_per_voxel: hierarchy.metadata_bytes() as f64 / grid.len() as f64,
    })
}

/// The isosurface tolerance of `diamonds iso`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IsoTolerance {
    /// World units.
    Absolute(f64),
    /// Fraction of the diagonal of the image's bounds.
    Relative(f64),
    /// This many voxel diagonals (a voxel diagonal: the diagonal of the bounds over the cube root of
    /// the number of cells).
    VoxelDiagonals(f64),
}

impl IsoTolerance {
    /// The tolerance in world units on `grid`.
    pub fn world(&self, grid: &Grid) -> f64 {
        let diagonal = grid.diagonal();
        match *self {
            IsoTolerance::Absolute(t) => t,
            IsoTolerance::Relative(r) => r * diagonal,
            IsoTolerance::VoxelDiagonals(k) => {
                let cells: f64 = grid.dims.iter().map(|&d| (d - 1) as f64).product();
                k * diagonal / cells.cbrt()
            }
        }
    }
}

/// The default tolerance of `diamonds iso`, as the ParaView filter's: two and a half voxel
/// diagonals. A tetrahedron no larger than the tolerance is never split for the surface (the surface
/// drawn through it stays inside it); past two voxel diagonals the tetrahedra of cubes of 2×2×2
/// cells qualify (their longest edge is two voxel diagonals), past about 2.3 those one bisection
/// coarser, and the surface drops to 0.1–0.4 times Flying Edges' triangles on every shared volume
/// (at one voxel diagonal: 0.3–1.25 times; docs/benchmarks.md, "Isosurface goals").
pub const DEFAULT_ISO_TOLERANCE: IsoTolerance = IsoTolerance::VoxelDiagonals(2.5);

/// Options of `diamonds iso`.
#[derive(Clone, Debug, PartialEq)]
pub struct IsoOptions {
    pub input: PathBuf,
    pub output: PathBuf,
    /// Point-data array to contour (default: as for `tetra`).
    pub array: Option<String>,
    /// One or more isovalues in data units.
    pub isovalues: Vec<f64>,
    pub tolerance: IsoTolerance,
    /// Triangle budget; 0 = no limit.
    pub max_triangles: usize,
    /// World box `[xmin, xmax, ymin, ymax, zmin, zmax]` where the tolerance applies.
    pub roi: Option<[f64; 6]>,
    /// Write point data `Normals`.
    pub normals: bool,
    /// Write the isovalue of each point as point data named like the input array.
    pub scalars: bool,
    /// Also write the tetrahedra carrying the surface to this `.vtu`.
    pub carrier: Option<PathBuf>,
}

/// What `diamonds iso` did.
#[derive(Clone, Debug, PartialEq)]
pub struct IsoSummary {
    pub array: String,
    pub dims: [usize; 3],
    pub isovalues: Vec<f64>,
    pub triangles: usize,
    pub points: usize,
    /// Largest isosurface error of the carrying diamonds, world units.
    pub error_bound: f64,
    /// The tolerance in world units.
    pub tolerance: f64,
    /// Diagonal of the image's bounds, world units.
    pub diagonal: f64,
    /// Triangle budget (0 = none): the error bound may exceed the tolerance to meet it.
    pub max_triangles: usize,
    pub carrier_tets: Option<usize>,
    pub read_seconds: f64,
    pub build_seconds: f64,
    pub extract_seconds: f64,
    pub write_seconds: f64,
}

impl fmt::Display for IsoSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [nx, ny, nz] = self.dims;
        let values: Vec<String> = self.isovalues.iter().map(f64::to_string).collect();
        write!(
            f,
            "'{}' {nx}x{ny}x{nz} at {} {}: {} triangles, {} points, error bound {} (tolerance {} = {:.3} % of the diagonal)",
            self.array,
            if values.len() == 1 { "isovalue" } else { "isovalues" },
            values.join(", "),
            self.triangles,
            self.points,
            self.error_bound,
            self.tolerance,
            100.0 * self.tolerance / self.diagonal
        )?;
        if self.max_triangles > 0 {
            write!(f, ", budget {} triangles", self.max_triangles)?;
        }
        if let Some(n) = self.carrier_tets {
            write!(f, ", {n} carrier tetrahedra")?;
        }
        write!(
            f,
            ", read {:.3} s, build {:.3} s, extract {:.3} s, write {:.3} s",
            self.read_seconds, self.build_seconds, self.extract_seconds, self.write_seconds
        )
    }
}

/// `diamonds iso`: reads the image, builds the hierarchy, extracts the isosurface(s) and writes the
/// `.vtp` (and the carrier tetrahedra's `.vtu`).
pub fn iso(opts: &IsoOptions) -> Result<IsoSummary> {
    if opts.isovalues.is_empty() {
        bail!("give at least one --isovalue");
    }
    if let Some(v) = opts.isovalues.iter().find(|v| !v.is_finite()) {
        bail!("the isovalue must be a finite number (got {v})");
    }
    match opts.tolerance {
        IsoTolerance::Absolute(t) if !t.is_finite() || t < 0.0 => {
            bail!("the tolerance must be a finite number >= 0 in world units (got {t})")
        }
        IsoTolerance::Relative(r) if !r.is_finite() || r < 0.0 => {
            bail!("the relative tolerance must be a finite fraction >= 0 of the diagonal (got {r})")
        }
        _ => {}
    }
    checked_extension(&opts.output, "vtp", "output")?;
    if let Some(carrier) = &opts.carrier {
        checked_extension(carrier, "vtu", "carrier")?;
    }
    let (image, read_seconds) = read_input(&opts.input, opts.array.as_deref())?;
    let array = image.scalars(opts.array.as_deref())?;
    let grid = image.grid;
    let diagonal = grid.diagonal();
    let tolerance = opts.tolerance.world(&grid);
    let start = Instant::now();
    let hierarchy = Hierarchy::build_for_isosurfaces(grid, array.scalar_slice()?)?;
    let build_seconds = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let surface = diamonds::isosurface::extract(
        &hierarchy,
        array.scalar_slice()?,
        &IsoQuery {
            isovalues: opts.isovalues.clone(),
            tolerance,
            max_triangles: opts.max_triangles,
            region_of_interest: opts.roi,
            compute_normals: opts.normals,
            carrier_tetrahedra: opts.carrier.is_some(),
        },
    )?;
    let extract_seconds = start.elapsed().as_secs_f64();
    for w in &surface.warnings {
        eprintln!("warning: '{}': {w}", array.name);
    }
    let start = Instant::now();
    let mut point_data = Vec::new();
    if opts.scalars {
        point_data.push(Array::scalars(&array.name, surface.values.clone()));
    }
    // Every other point array, interpolated as Adaptive Isosurface (and Contour) does.
    point_data.extend(
        (image.point_data.iter())
            .filter(|a| !std::ptr::eq(*a, array))
            .map(|a| interpolated(a, &surface.sources, &surface.weights)),
    );
    if opts.normals {
        point_data.push(Array {
            name: "Normals".into(),
            components: 3,
            data: surface
                .normals
                .iter()
                .flatten()
                .copied()
                .collect::<Vec<f32>>()
                .into(),
        });
    }
    write_triangles(
        &opts.output,
        Triangles {
            points: &surface.points,
            triangles: &surface.triangles,
            point_data,
            field_data: vec![
                Array::scalars("ErrorBound", vec![surface.error_bound]),
                Array::scalars("NumberOfTriangles", vec![surface.triangles.len() as i64]),
                Array::scalars("Tolerance", vec![tolerance]),
            ],
        },
    )?;
    let carrier_tets = match (&opts.carrier, &surface.carrier) {
        (Some(path), Some(mesh)) => {
            // As `tetra` writes its meshes, but without the data-unit Tolerance of `tetra`, and the
            // errors are the isosurface errors of the tetrahedra's diamonds, in world units (named
            // as Adaptive Isosurface names them).
            let others = image.point_data.iter().filter(|a| !std::ptr::eq(*a, array));
            let mut data = mesh_arrays(std::iter::once(array).chain(others), mesh, 0.0);
            data.field_data.retain(|a| a.name != "Tolerance");
            for a in &mut data.cell_data {
                if a.name == "ApproximationError" {
                    a.name = "IsosurfaceError".into();
                }
            }
            write_tets(
                path,
                TetGrid {
                    points: &mesh.points,
                    tets: &mesh.tets,
                    point_data: data.point_data,
                    cell_data: data.cell_data,
                    field_data: data.field_data,
                },
            )?;
            Some(mesh.tets.len())
        }
        _ => None,
    };
    let write_seconds = start.elapsed().as_secs_f64();
    Ok(IsoSummary {
        array: array.name.clone(),
        dims: grid.dims,
        isovalues: opts.isovalues.clone(),
        triangles: surface.triangles.len(),
        points: surface.points.len(),
        error_bound: surface.error_bound,
        tolerance,
        diagonal,
        max_triangles: opts.max_triangles,
        carrier_tets,
        read_seconds,
        build_seconds,
        extract_seconds,
        write_seconds,
    })
}

/// Generated fields of `diamonds generate`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Field {
    /// Marschner–Lobb test signal (fine ripples around the z axis).
    MarschnerLobb,
    /// Distance to a sphere of radius 0.6.
    Sphere,
    /// Distance to a torus of radii 0.6 and 0.25.
    Torus,
    /// The analogue of Gregorski's impact data set (a projectile entering a block; default 32x32x52
    /// points over [0,12]x[0,12]x[-16,4.8]): volume fractions of Void, Block and Projectile and the
    /// mixed Density, Float32 point data (for `diamonds material`).
    Impact,
    /// Probabilistic tissue maps from an intensity volume (`--image`; on its points, or resampled
    /// onto `--dims` with spacing 1): volume fractions of Other, Grey and White (soft thresholds of
    /// the intensity scaled to 0..255) and the intensity T1, Float32 point data (for `diamonds
    /// material`).
    Tissue,
}

/// Sample types of `diamonds generate`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum SampleType {
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    F32,
    F64,
}

impl Field {
    /// Array name in the generated file.
    pub fn array_name(self) -> &'static str {
        match self {
            Field::MarschnerLobb => "marschner_lobb",
            Field::Sphere => "sphere_distance",
            Field::Torus => "torus_distance",
            Field::Impact => "Density",
            Field::Tissue => "T1",
        }
    }

    /// The field at a point of `[-1, 1]^3`, normalised to `[0, 1]` (distances: `(d + 1) / 2`, clamped);
    /// `None` for the material cases, which are not one field on `[-1, 1]^3`.
    pub fn normalised(self, x: f64, y: f64, z: f64) -> Option<f64> {
        Some(
            match self {
                Field::MarschnerLobb => fields::marschner_lobb(x, y, z),
                Field::Sphere => (fields::sphere_distance(0.6)(x, y, z) + 1.0) / 2.0,
                Field::Torus => (fields::torus_distance(0.6, 0.25)(x, y, z) + 1.0) / 2.0,
                Field::Impact | Field::Tissue => return None,
            }
            .clamp(0.0, 1.0),
        )
    }
}

/// Samples `field` on `grid` as `ty`: the normalised value scaled to 0..255 (`i8`: -128..127), rounded
/// for integer types. The impact case is not one field: see [`crate::material::generate_impact`].
pub fn generate_array(field: Field, grid: &Grid, ty: SampleType) -> Result<Array> {
    if matches!(field, Field::Impact | Field::Tissue) {
        bail!("the impact and tissue cases have several arrays: write them with `diamonds generate --field impact` or `--field tissue`");
    }
    let v = fields::sample(grid, |x, y, z| {
        255.0 * field.normalised(x, y, z).unwrap_or(0.0)
    });
    let name = field.array_name();
    Ok(match ty {
        SampleType::U8 => {
            Array::scalars(name, v.iter().map(|f| f.round() as u8).collect::<Vec<_>>())
        }
        SampleType::I8 => Array::scalars(
            name,
            v.iter()
                .map(|f| (f.round() - 128.0) as i8)
                .collect::<Vec<_>>(),
        ),
        SampleType::U16 => {
            Array::scalars(name, v.iter().map(|f| f.round() as u16).collect::<Vec<_>>())
        }
        SampleType::I16 => {
            Array::scalars(name, v.iter().map(|f| f.round() as i16).collect::<Vec<_>>())
        }
        SampleType::U32 => {
            Array::scalars(name, v.iter().map(|f| f.round() as u32).collect::<Vec<_>>())
        }
        SampleType::I32 => {
            Array::scalars(name, v.iter().map(|f| f.round() as i32).collect::<Vec<_>>())
        }
        SampleType::F32 => Array::scalars(name, v.iter().map(|&f| f as f32).collect::<Vec<_>>()),
        SampleType::F64 => Array::scalars(name, v),
    })
}

/// `diamonds generate`: writes `field` sampled on a `dims` grid spanning `[-1, 1]^3`.
pub fn generate(
    output: &std::path::Path,
    field: Field,
    dims: [usize; 3],
    ty: SampleType,
) -> Result<String> {
    if let Some(d) = dims.iter().find(|&&d| d < 2) {
        bail!("every dimension needs at least 2 points (got {d} in {dims:?})");
    }
    let points = dims
        .iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .filter(|&n| n <= 1 << 31)
        .ok_or_else(|| crate::Error(format!("{dims:?} points are too many to generate")))?;
    let grid = fields::unit_grid(dims);
    let array = generate_array(field, &grid, ty)?;
    write_image(output, &grid, &[array])?;
    Ok(format!(
        "wrote '{}': {} {}x{}x{} {:?} ({points} points)",
        output.display(),
        field.array_name(),
        dims[0],
        dims[1],
        dims[2],
        ty
    ))
}

/// Outcome of `diamonds verify`: the report lines and whether every check passed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VerifyReport {
    pub lines: Vec<String>,
    pub passed: bool,
}

impl VerifyReport {
    /// The line of both one-sided distances `d` between `surface` and the full-resolution one
    /// (`fine`, whose triangles are counted): a check when there is a `tolerance`, else a report.
    pub(crate) fn distances(
        &mut self,
        d: &SurfaceDistances,
        (fine, surface): (&str, &str),
        tolerance: Option<f64>,
    ) {
        let measured = format!(
            "{fine} ({} triangles, {} of them in {surface} too, at distance 0): from its {} vertices and samples to {surface} {}, from the {} vertices and samples of {surface} to it {} (every point of either within {} more)",
            d.fine_triangles,
            d.shared_triangles,
            d.fine_vertices,
            d.fine_to_surface.distance,
            d.surface_samples,
            d.surface_to_fine.distance,
            Number(d.slack)
        );
        match tolerance {
            Some(t) => {
                self.check(
                    "distance",
                    d.check(t)
                        .map(|()| format!("{measured}; both within the tolerance {t}"))
                        .map_err(|e| format!("{e}; {measured}")),
                );
            }
            None => self.lines.push(format!("  distance: {measured}")),
        }
    }

    pub(crate) fn check(
        &mut self,
        what: &str,
        outcome: std::result::Result<String, String>,
    ) -> bool {
        match outcome {
            Ok(detail) => {
                self.lines.push(format!("  {what}: OK ({detail})"));
                true
            }
            Err(detail) => {
                self.lines.push(format!("  {what}: FAILED: {detail}"));
                self.passed = false;
                false
            }
        }
    }
}

/// The input point index of each mesh point, found from its coordinates.
fn point_ids(points: &[[f64; 3]], grid: &Grid) -> std::result::Result<Vec<usize>, String> {
    points
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let mut ijk = [0usize; 3];
            for a in 0..3 {
                let f = (p[a] - grid.origin[a]) / grid.spacing[a];
                let i = f.round();
                if (f - i).abs() > 1e-6 || i < 0.0 || i >= grid.dims[a] as f64 {
                    return Err(format!(
                        "mesh point {k} at {p:?} is not a point of the input grid"
                    ));
                }
                ijk[a] = i as usize;
            }
            Ok(grid.index(ijk[0], ijk[1], ijk[2]))
        })
        .collect()
}

/// `diamonds verify`: checks `mesh` (a `.vtu` written by `tetra`) against the image independently of the
/// hierarchy (`diamonds::validate`): conforming tetrahedra exactly covering the grid's box at its sample
/// positions, the tolerance at every sample, the reported error bounds, the passed-through point data.
/// Unreadable input is an error; a failed check is reported in [`VerifyReport`].
pub fn verify(
    input: &std::path::Path,
    mesh_path: &std::path::Path,
    array: Option<&str>,
    tolerance: f64,
    region: Option<[f64; 6]>,
) -> Result<VerifyReport> {
    check_tolerance_value(tolerance)?;
    let mut image = read_image(input)?;
    let in_file = |e: crate::Error| crate::Error(format!("'{}': {e}", input.display()));
    image.exact_scalars(array).map_err(in_file)?;
    let scalars = image.scalars(array).map_err(in_file)?;
    let slice = scalars.scalar_slice()?;
    let grid = image.grid;
    grid.validate()?;
    if let Some(r) = region {
        check_region(&grid, r)?;
    }
    let ugrid = read_unstructured(mesh_path)?;
    let [nx, ny, nz] = grid.dims;
    let inside = region.map_or(String::new(), |r| format!(" inside {r:?}"));
    let mut report = VerifyReport {
        lines: vec![format!(
            "verify '{}' against '{}' (array '{}', {nx}x{ny}x{nz} points, tolerance {tolerance}{inside})",
            mesh_path.display(),
            input.display(),
            scalars.name
        )],
        passed: true,
    };
    // Cells: tetrahedra only.
    let n_cells = ugrid.types.len();
    let tets = tetrahedra(&ugrid);
    let cells_ok = tets
        .as_ref()
        .map(|_| format!("{n_cells} tetrahedra, {} points", ugrid.points.len()))
        .map_err(Clone::clone);
    if !report.check("cells", cells_ok) {
        return Ok(finish(report));
    }
    let ids = match point_ids(&ugrid.points, &grid) {
        Ok(ids) => ids,
        Err(e) => {
            report.check("points", Err(e));
            return Ok(finish(report));
        }
    };
    let cell_values = |name: &str| -> Option<&Array> {
        ugrid
            .cell_data
            .iter()
            .find(|a| a.name == name && a.components == 1)
    };
    let errors: Vec<f32> = match cell_values("ApproximationError") {
        Some(a) => (0..n_cells).map(|c| a.value(c) as f32).collect(),
        None => vec![0.0; n_cells],
    };
    let mesh = TetMesh {
        point_ids: ids,
        points: ugrid.points.clone(),
        tets: tets.unwrap_or_default(),
        depths: match cell_values("BisectionDepth") {
            Some(a) => (0..n_cells).map(|c| a.value(c) as u8).collect(),
            None => vec![0; n_cells],
        },
        max_error: errors.iter().fold(0.0f64, |m, &e| m.max(e as f64)),
        errors,
    };
    let conforming = report.check(
        "conformity",
        check_mesh(&mesh, &grid).map(|r| {
            format!(
                "{} tetrahedra at input sample positions, {} interior faces shared by two, {} boundary faces, volumes sum to the box",
                r.tets, r.interior_faces, r.boundary_faces
            )
        }),
    );
    if conforming {
        let measured = with_volume!(grid, slice, |v| check_tolerance(
            &mesh, &v, tolerance, region
        ));
        let samples = match region {
            None => format!("all {} samples", grid.len()),
            Some(_) => format!("the samples{inside}"),
        };
        let ok = report.check(
            "tolerance",
            measured
                .clone()
                .map(|worst| {
                    let (worst, within) = (Number(worst), worst <= tolerance);
                    let tolerance = Number(tolerance);
                    match within {
                        true => format!("{samples} within {worst} <= {tolerance}"),
                        false => format!(
                            "{samples} within {worst}: the tolerance {tolerance} and the interpolation's rounding"
                        ),
                    }
                }),
        );
        if ok && cell_values("ApproximationError").is_some() {
            let worst = measured.unwrap_or(0.0);
            let bound = mesh.max_error;
            report.check(
                "error bounds",
                if worst <= bound * (1.0 + 1e-9) + 1e-12 {
                    Ok(format!("measured {worst} <= reported {bound}"))
                } else {
                    Err(format!(
                        "measured error {worst} exceeds the reported bound {bound}"
                    ))
                },
            );
        }
    }
    // Passed-through point data.
    let mut same = Vec::new();
    let mut differ = None;
    for out in &ugrid.point_data {
        let Some(inp) = image
            .point_data
            .iter()
            .find(|a| a.name == out.name && a.components == out.components)
        else {
            continue;
        };
        let c = out.components;
        let bad = mesh.point_ids.iter().enumerate().find_map(|(k, &i)| {
            (0..c)
                .find(|&j| inp.value(i * c + j) != out.value(k * c + j))
                .map(|_| k)
        });
        match bad {
            None => same.push(out.name.clone()),
            Some(k) => {
                differ = Some(format!(
                    "point-data array '{}' differs from the input at mesh point {k}",
                    out.name
                ));
                break;
            }
        }
    }
    if let Some(d) = differ {
        report.check("point data", Err(d));
    } else if !same.is_empty() {
        report.check(
            "point data",
            Ok(format!(
                "{} equal the input at the mesh points",
                same.join(", ")
            )),
        );
    }
    Ok(finish(report))
}

/// How a report names the region distances were measured in (nothing without one).
pub(crate) fn inside(region: Option<[f64; 6]>) -> String {
    region.map_or_else(String::new, |r| format!(", measured inside {r:?}"))
}

fn finish(report: VerifyReport) -> VerifyReport {
    finish_as(report, "verify")
}

/// Appends `<command>: PASSED` or `<command>: FAILED`.
pub(crate) fn finish_as(mut report: VerifyReport, command: &str) -> VerifyReport {
    let outcome = if report.passed { "PASSED" } else { "FAILED" };
    report.lines.push(format!("{command}: {outcome}"));
    report
}

/// The full-resolution comparison of `diamonds verify-surface`: the surface against the
/// full-resolution marching-tetrahedra surface of its image's `array` at `isovalue`.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceBound {
    pub isovalues: Vec<f64>,
    /// Point-data array of the image [default: the active scalars, else the first scalar array].
    pub array: Option<String>,
    /// Fail when either one-sided Hausdorff distance exceeds it; `None`: report them only.
    pub tolerance: Option<f64>,
    /// Measure from points inside this world-space box only (the query's region of interest).
    pub region: Option<[f64; 6]>,
}

/// `diamonds verify-surface`: checks a triangle surface (`.vtp`): triangles with three distinct points,
/// every edge in two triangles traversed in opposite directions (watertight and consistently
/// oriented), except edges on a face of `image`'s bounds, which may border one triangle; unit `Normals`
/// when the file has them (the checks of `diamonds::validate::surfaces`). With `bound` (and `image`),
/// also both one-sided Hausdorff distances between the surface and the image's full-resolution
/// surface (`diamonds::validate::hausdorff`), failed above the tolerance. Unreadable input is an error;
/// a failed check is reported in [`VerifyReport`].
pub fn verify_surface(
    mesh_path: &Path,
    image: Option<&Path>,
    bound: Option<&SurfaceBound>,
) -> Result<VerifyReport> {
    let image = match image {
        Some(path) => {
            let image = read_image(path)?;
            image.grid.validate()?;
            Some((path, image))
        }
        None if bound.is_some() => {
            bail!("--isovalue needs --image: the volume the surface was extracted from")
        }
        None => None,
    };
    if let Some(b) = bound {
        if let Some(v) = b.isovalues.iter().find(|v| !v.is_finite()) {
            bail!("the isovalue must be a finite number (got {v})");
        }
        if let Some(t) = b.tolerance.filter(|t| !t.is_finite() || *t < 0.0) {
            bail!("the tolerance must be a finite number >= 0 in world units (got {t})");
        }
    }
    let bounds = image.as_ref().map(|(_, image)| image.grid.bounds());
    let image_path = image.as_ref().map(|(path, _)| *path);
    let surface = read_polydata(mesh_path)?;
    let n = surface.offsets.len();
    let mut report = VerifyReport {
        lines: vec![format!(
            "verify-surface '{}' ({n} polygons, {} points){}",
            mesh_path.display(),
            surface.points.len(),
            match image_path {
                Some(path) => format!(", open only on the bounds of '{}'", path.display()),
                None => ", closed".to_string(),
            }
        )],
        passed: true,
    };
    let checked = (|| {
        if let Some(c) = (0..n).find(|&c| surface.offsets[c] != 3 * (c + 1)) {
            return Err(format!("polygon {c} is not a triangle"));
        }
        if let Some(a) = surface
            .field_data
            .iter()
            .find(|a| a.name == "NumberOfTriangles")
        {
            if a.data.len() != 1 || a.value(0) != n as f64 {
                return Err(format!(
                    "field data NumberOfTriangles says {} for {n} triangles",
                    a.value(0)
                ));
            }
        }
        let corner =
            |i: usize| u32::try_from(i).map_err(|_| format!("point id {i} beyond 32 bits"));
        let triangles = surface
            .connectivity
            .chunks_exact(3)
            .map(|t| Ok([corner(t[0])?, corner(t[1])?, corner(t[2])?]))
            .collect::<std::result::Result<Vec<[u32; 3]>, String>>()?;
        check_surface(&surface.points, &triangles, bounds).map(|report| (report, triangles))
    })();
    let described = checked.as_ref().map_err(Clone::clone);
    report.check(
        "triangles",
        described.map(|_| format!("{n} triangles, three distinct points each")),
    );
    let Ok((checked, triangles)) = checked else {
        return Ok(finish_as(report, "verify-surface"));
    };
    report.check(
        "watertight",
        checked.watertight.map(|()| {
            format!(
                "{} edges in two triangles, {} edges on the image bounds in one",
                checked.interior_edges, checked.boundary_edges
            )
        }),
    );
    report.check(
        "orientation",
        checked
            .oriented
            .map(|()| "every shared edge traversed once each way".to_string()),
    );
    match surface.point_data.iter().find(|a| a.name == "Normals") {
        None => report.lines.push("  normals: none in the file".to_string()),
        Some(normals) if normals.components != 3 => {
            report.check(
                "normals",
                Err(format!(
                    "Normals has {} components, 3 expected",
                    normals.components
                )),
            );
        }
        Some(normals) => {
            let vectors =
                (0..surface.points.len()).map(|p| [0, 1, 2].map(|a| normals.value(3 * p + a)));
            report.check(
                "normals",
                check_unit_normals(vectors, 1e-3).map(|count| format!("{count} unit normals")),
            );
        }
    }
    if let (Some(b), Some((_, image))) = (bound, &image) {
        let array = image.scalars(b.array.as_deref())?;
        if let Some(r) = b.region {
            check_region(&image.grid, r)?;
        }
        let d = with_volume!(image.grid, array.scalar_slice()?, |v| surface_distances(
            &v,
            &b.isovalues,
            &surface.points,
            &triangles,
            b.region,
            b.tolerance
        ));
        let at: Vec<String> = b.isovalues.iter().map(f64::to_string).collect();
        let fine = format!(
            "full-resolution surface of '{}' at {}{}",
            array.name,
            at.join(" and "),
            inside(b.region)
        );
        report.distances(&d, (&fine, "the surface"), b.tolerance);
    }
    Ok(finish_as(report, "verify-surface"))
}
