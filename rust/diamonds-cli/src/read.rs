//! Reading the CLI's inputs: VTK XML files through [`vtkxml`], and legacy `.vtk` image data
//! (`STRUCTURED_POINTS`) through `vtkio`, as an [`Image`] on the core's [`Grid`].
//!
//! Legacy files are read here rather than in `vtkxml`: they are the one thing `vtkio` is needed for, its
//! parser is a pinned pre-release that panics on some malformed input (contained below by swapping the
//! process-wide panic hook, which a library should not do), and `vtkxml` stays an XML crate.

use crate::{bail, Array, AsScalarSlice, Error, Result, Values};
use diamonds::Grid;
use std::path::Path;
use vtkio::model::IOBuffer;
pub use vtkxml::{
    extension, read_polydata, read_structured, read_unstructured, Geometry, PolyData, Structured,
    Unstructured,
};
use vtkxml::{point_count, UniformGrid};

/// A regular grid with its point data, as read from a `.vti` or legacy `.vtk` file.
#[derive(Clone, Debug)]
pub struct Image {
    /// Points, world origin of the first point (extent start included) and spacing.
    pub grid: Grid,
    /// Every point-data array, in file order.
    pub point_data: Vec<Array>,
    /// Names of the cell-data arrays (not loaded: the mesh is built from point data).
    pub cell_arrays: Vec<String>,
    /// The active scalars named by the file (`Scalars="…"`, legacy `SCALARS`).
    pub active_scalars: Option<String>,
    /// Arrays left out while reading (non-numeric types), for the user.
    pub warnings: Vec<String>,
}

/// The cells of an unstructured grid as tetrahedra: refuses other cell types (mixed cells) with the
/// first one named, and more than 2^32 - 1 points.
pub fn tetrahedra(grid: &Unstructured) -> std::result::Result<Vec<[u32; 4]>, String> {
    if let Some(c) = grid.types.iter().position(|&t| t != 10) {
        return Err(format!(
            "cell {c} has VTK type {}, not VTK_TETRA (10): tetrahedra only (apply Tetrahedralize first)",
            grid.types[c]
        ));
    }
    if grid
        .offsets
        .iter()
        .enumerate()
        .any(|(c, &o)| o != 4 * (c + 1))
    {
        return Err("cell offsets are not those of tetrahedra".to_string());
    }
    if u32::try_from(grid.points.len()).is_err() {
        return Err(format!(
            "{} points: at most 2^32 - 1 are supported",
            grid.points.len()
        ));
    }
    Ok(grid
        .connectivity
        .chunks_exact(4)
        .map(|t| [t[0] as u32, t[1] as u32, t[2] as u32, t[3] as u32])
        .collect())
}

/// The core's grid of image data.
fn core_grid(g: UniformGrid) -> Grid {
    Grid {
        dims: g.dims,
        origin: g.origin,
        spacing: g.spacing,
    }
}

/// The core's grid of a structured data set.
pub trait StructuredGrid {
    /// The uniform grid: the image's, or the rectilinear grid's when every axis is uniformly spaced
    /// (refused with the core's message otherwise).
    fn grid(&self) -> Result<Grid>;
}

impl StructuredGrid for Structured {
    fn grid(&self) -> Result<Grid> {
        match &self.geometry {
            Geometry::Uniform(grid) => Ok(core_grid(*grid)),
            Geometry::Rectilinear([x, y, z]) => Ok(Grid::from_coordinates([x, y, z])?),
        }
    }
}

impl Image {
    /// The point-data array to mesh: `name` if given, else the active scalars, else the first
    /// single-component point-data array. Refuses cell-only data and multi-component arrays.
    pub fn scalars(&self, name: Option<&str>) -> Result<&Array> {
        let array = &self.point_data[self.select(name)?];
        array.scalar_slice()?;
        Ok(array)
    }

    /// [`Image::scalars`], converting 64-bit integers to `Float64` in place first, as the ParaView
    /// filters do: refused unless every value is exact as a double (within ±2^53). Returns a
    /// warning when it converted.
    pub fn exact_scalars(&mut self, name: Option<&str>) -> Result<Option<String>> {
        let selected = self.select(name)?;
        let array = &mut self.point_data[selected];
        let values: Vec<f64> = match &array.data {
            Values::I64(v) => v.iter().map(|&x| x as f64).collect(),
            Values::U64(v) => v.iter().map(|&x| x as f64).collect(),
            _ => return array.scalar_slice().map(|_| None),
        };
        const EXACT: f64 = 9007199254740992.0; // 2^53
        if let Some(v) = values.iter().find(|v| v.abs() > EXACT) {
            bail!(
                "point-data array '{}' holds 64-bit integers ({}) up to {v}, beyond 2^53 where a conversion to double is inexact; rescale it first",
                array.name,
                array.type_name()
            );
        }
        let warning = format!(
            "point-data array '{}' holds 64-bit integers ({}); they are converted to double (exact: all values are within 2^53)",
            array.name,
            array.type_name()
        );
        array.data = Values::F64(values);
        Ok(Some(warning))
    }

    /// The index of the point-data array [`Image::scalars`] selects.
    fn select(&self, name: Option<&str>) -> Result<usize> {
        let listing = || {
            self.point_data
                .iter()
                .map(Array::describe)
                .collect::<Vec<_>>()
                .join(", ")
        };
        if self.point_data.is_empty() {
            if self.cell_arrays.is_empty() {
                bail!("the image has no point-data arrays");
            }
            bail!(
                "the image has only cell data ({}); the mesh is built from point data: convert it first (ParaView: Cell Data to Point Data)",
                self.cell_arrays.join(", ")
            );
        }
        let array = match name {
            Some(name) => match self.point_data.iter().find(|a| a.name == name) {
                Some(a) => a,
                None if self.cell_arrays.iter().any(|c| c == name) => bail!(
                    "'{name}' is a cell-data array; the mesh is built from point data (point-data arrays: {})",
                    listing()
                ),
                None => bail!(
                    "no point-data array named '{name}' (point-data arrays: {})",
                    listing()
                ),
            },
            None => {
                let active = self
                    .active_scalars
                    .as_deref()
                    .and_then(|s| self.point_data.iter().find(|a| a.name == s))
                    .filter(|a| a.components == 1);
                match active.or_else(|| self.point_data.iter().find(|a| a.components == 1)) {
                    Some(a) => a,
                    None => bail!(
                        "the image has no single-component point-data array (point-data arrays: {}); the mesh needs a scalar field",
                        listing()
                    ),
                }
            }
        };
        if array.components != 1 {
            bail!(
                "point-data array '{}' has {} components; the mesh needs a single-component scalar array (point-data arrays: {})",
                array.name,
                array.components,
                listing()
            );
        }
        Ok(self
            .point_data
            .iter()
            .position(|a| std::ptr::eq(a, array))
            .expect("an array of the image"))
    }
}

/// Reads image data from a `.vti` (VTK XML ImageData) or `.vtk` (legacy STRUCTURED_POINTS) file.
pub fn read_image(path: &Path) -> Result<Image> {
    let ext = extension(path);
    if ext != "vti" && ext != "vtk" {
        bail!(
            "unsupported input file '{}': expected a .vti (VTK XML image data) or .vtk (legacy VTK structured points) file",
            path.display()
        );
    }
    if ext == "vti" {
        let vtkxml::Image {
            grid,
            point_data,
            cell_arrays,
            active_scalars,
            warnings,
        } = vtkxml::read_image(path)?;
        return Ok(Image {
            grid: core_grid(grid),
            point_data,
            cell_arrays,
            active_scalars,
            warnings,
        });
    }
    let bytes =
        std::fs::read(path).map_err(|e| Error(format!("cannot read '{}': {e}", path.display())))?;
    legacy_image(&bytes).map_err(|e| Error(format!("'{}': {e}", path.display())))
}

/// `ORIGIN` and `SPACING` (or `ASPECT_RATIO`) of a legacy header, in full `f64` precision
/// (`vtkio` keeps them as `f32`).
fn legacy_geometry(bytes: &[u8]) -> (Option<[f64; 3]>, Option<[f64; 3]>) {
    let head = &bytes[..bytes.len().min(4096)];
    let text = String::from_utf8_lossy(head);
    let mut origin = None;
    let mut spacing = None;
    for line in text.lines().take(16) {
        let mut words = line.split_ascii_whitespace();
        let key = words.next().unwrap_or("").to_ascii_uppercase();
        let nums: Vec<f64> = words.filter_map(|w| w.parse().ok()).collect();
        let Ok(v) = <[f64; 3]>::try_from(nums) else {
            continue;
        };
        match key.as_str() {
            "ORIGIN" => origin = Some(v),
            "SPACING" | "ASPECT_RATIO" => spacing = Some(v),
            "POINT_DATA" | "CELL_DATA" => break,
            _ => {}
        }
    }
    (origin, spacing)
}

/// vtkio's buffer as values (`None` for bit arrays, which are not numeric arrays to mesh).
fn legacy_values(data: IOBuffer) -> Option<Values> {
    Some(match data {
        IOBuffer::Bit(_) => return None,
        IOBuffer::U8(v) => v.into(),
        IOBuffer::I8(v) => v.into(),
        IOBuffer::U16(v) => v.into(),
        IOBuffer::I16(v) => v.into(),
        IOBuffer::U32(v) => v.into(),
        IOBuffer::I32(v) => v.into(),
        IOBuffer::U64(v) => v.into(),
        IOBuffer::I64(v) => v.into(),
        IOBuffer::F32(v) => v.into(),
        IOBuffer::F64(v) => v.into(),
    })
}

/// Flattens legacy attributes (data arrays and the arrays of FIELD attributes) into arrays and the
/// active scalars; bit arrays are left out with a warning in `warnings`.
fn legacy_arrays(
    attrs: Vec<vtkio::model::Attribute>,
    warnings: &mut Vec<String>,
) -> (Vec<Array>, Option<String>) {
    use vtkio::model::{Attribute, ElementType};
    let mut arrays = Vec::new();
    let mut active = None;
    let mut push = |name: String, components: usize, data: IOBuffer| match legacy_values(data) {
        Some(data) => arrays.push(Array {
            name,
            components,
            data,
        }),
        None => warnings.push(format!(
            "array '{name}' of type Bit left out (not a numeric array)"
        )),
    };
    for a in attrs {
        match a {
            Attribute::DataArray(d) => {
                if active.is_none() && matches!(d.elem, ElementType::Scalars { .. }) {
                    active = Some(d.name.clone());
                }
                push(d.name, d.elem.num_comp() as usize, d.data);
            }
            Attribute::Field { data_array, .. } => {
                for f in data_array {
                    push(f.name, f.elem as usize, f.data);
                }
            }
        }
    }
    (arrays, active)
}

fn legacy_image(bytes: &[u8]) -> Result<Image> {
    use vtkio::model::{Attribute, DataSet, Piece};
    check_legacy_layout(bytes)?;
    // vtkio's legacy parser is third-party code: contain any panic it raises on malformed input.
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let parsed = std::panic::catch_unwind(|| vtkio::Vtk::parse_legacy_be(bytes));
    std::panic::set_hook(hook);
    let vtk = match parsed {
        Ok(Ok(vtk)) => vtk,
        Ok(Err(e)) => bail!("not a readable legacy VTK file: {e}"),
        Err(_) => bail!("not a readable legacy VTK file (the parser failed)"),
    };
    let DataSet::ImageData {
        extent,
        origin,
        spacing,
        pieces,
        ..
    } = vtk.data
    else {
        bail!("the legacy VTK file does not hold STRUCTURED_POINTS");
    };
    let piece = match <[Piece<_>; 1]>::try_from(pieces) {
        Ok([Piece::Inline(p)]) => p,
        _ => bail!("the legacy VTK file must hold exactly one inline piece"),
    };
    let dims = extent.into_dims().map(|d| d as usize);
    let n = point_count(dims)?;
    let (f64_origin, f64_spacing) = legacy_geometry(bytes);
    let mut warnings = Vec::new();
    let (point_data, active_scalars) = legacy_arrays(piece.data.point, &mut warnings);
    let cell_arrays = (piece.data.cell.iter())
        .flat_map(|a| match a {
            Attribute::DataArray(d) => vec![d.name.clone()],
            Attribute::Field { data_array, .. } => {
                data_array.iter().map(|f| f.name.clone()).collect()
            }
        })
        .collect();
    for a in &point_data {
        if a.tuples() != n || a.data.len() != n * a.components {
            bail!(
                "point-data array '{}' has {} values for {n} points",
                a.name,
                a.data.len()
            );
        }
    }
    Ok(Image {
        grid: Grid {
            dims,
            origin: f64_origin.unwrap_or(origin.map(f64::from)),
            spacing: f64_spacing.unwrap_or(spacing.map(f64::from)),
        },
        point_data,
        cell_arrays,
        active_scalars,
        warnings,
    })
}

/// Walks the header lines and data of a legacy file before `vtkio` reads it: `vtkio` reserves the
/// counts the file declares before reading them (a small file declaring 4000³ points aborts the
/// process) and reports a short or malformed array as a parser internal ("Parse error: Digit").
/// Refuses, naming the line, the array, what was expected and what was found: a `POINT_DATA`
/// count that is not the number of points, an array with fewer values (bytes, for binary files)
/// than declared, and a value that is not a number. Keywords it does not know end the walk
/// (`vtkio` judges the rest).
fn check_legacy_layout(bytes: &[u8]) -> Result<()> {
    let mut c = Cursor {
        bytes,
        pos: 0,
        line: 1,
    };
    for _ in 0..2 {
        c.skip_line(); // the version line and the title
    }
    let binary = match c.token() {
        Some(t) => t.eq_ignore_ascii_case("BINARY"),
        None => return Ok(()),
    };
    let mut points: Option<u64> = None;
    let mut tuples = 0u64;
    while let Some(word) = c.token() {
        let line = c.line;
        let key = word.to_ascii_uppercase();
        let numbers = |c: &mut Cursor, k: usize| -> Vec<u64> {
            (0..k)
                .filter_map(|_| c.token().and_then(|t| t.parse().ok()))
                .collect()
        };
        // (array name, type, values per tuple, tuples)
        let array = match key.as_str() {
            "DATASET" => {
                c.token();
                continue;
            }
            "DIMENSIONS" => {
                let d = numbers(&mut c, 3);
                points = (d.len() == 3).then(|| d.iter().product());
                continue;
            }
            "SPACING" | "ASPECT_RATIO" | "ORIGIN" => {
                numbers(&mut c, 3);
                continue;
            }
            "POINT_DATA" | "CELL_DATA" => {
                let n = numbers(&mut c, 1).first().copied();
                let Some(n) = n else {
                    bail!("line {line}: {key} needs a count");
                };
                if let (Some(p), "POINT_DATA") = (points, key.as_str()) {
                    if n != p {
                        bail!("line {line}: POINT_DATA {n}, but DIMENSIONS make {p} points");
                    }
                }
                tuples = n;
                continue;
            }
            "SCALARS" => {
                let (name, ty) = (c.word(), c.word());
                // An optional component count, then an optional LOOKUP_TABLE line.
                let save = (c.pos, c.line);
                let components = match c.token().map(|t| t.parse::<u64>()) {
                    Some(Ok(k)) => k,
                    _ => {
                        (c.pos, c.line) = save;
                        1
                    }
                };
                let save = (c.pos, c.line);
                if c.token()
                    .is_some_and(|t| t.eq_ignore_ascii_case("LOOKUP_TABLE"))
                {
                    c.token();
                } else {
                    (c.pos, c.line) = save;
                }
                (name, ty, components, tuples)
            }
            "VECTORS" | "NORMALS" => (c.word(), c.word(), 3, tuples),
            "TENSORS" => (c.word(), c.word(), 9, tuples),
            "TEXTURE_COORDINATES" => {
                let (name, k, ty) = (c.word(), numbers(&mut c, 1), c.word());
                (name, ty, k.first().copied().unwrap_or(1), tuples)
            }
            "COLOR_SCALARS" => {
                let (name, k) = (c.word(), numbers(&mut c, 1));
                let ty = if binary { "unsigned_char" } else { "float" };
                (
                    name,
                    ty.to_string(),
                    k.first().copied().unwrap_or(1),
                    tuples,
                )
            }
            "FIELD" => {
                c.token();
                let k = numbers(&mut c, 1).first().copied().unwrap_or(0);
                for _ in 0..k {
                    let name = c.word();
                    let d = numbers(&mut c, 2);
                    let ty = c.word();
                    let [components, n] = <[u64; 2]>::try_from(d).map_err(|_| {
                        Error(format!(
                            "line {}: field array '{name}' needs its components, tuples and type",
                            c.line
                        ))
                    })?;
                    c.values(binary, &name, &ty, components, n)?;
                }
                continue;
            }
            _ => return Ok(()),
        };
        let (name, ty, components, n) = array;
        c.values(binary, &name, &ty, components, n)?;
    }
    Ok(())
}

/// A position in a legacy file, with its line number.
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
    line: usize,
}

impl<'a> Cursor<'a> {
    fn skip_line(&mut self) {
        while self.pos < self.bytes.len() {
            self.pos += 1;
            if self.bytes[self.pos - 1] == b'\n' {
                self.line += 1;
                return;
            }
        }
    }

    /// The next whitespace-separated word.
    fn token(&mut self) -> Option<&'a str> {
        while self.pos < self.bytes.len() && self.bytes[self.pos].is_ascii_whitespace() {
            self.line += usize::from(self.bytes[self.pos] == b'\n');
            self.pos += 1;
        }
        let start = self.pos;
        while self.pos < self.bytes.len() && !self.bytes[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        let bytes: &'a [u8] = self.bytes;
        (self.pos > start).then(|| std::str::from_utf8(&bytes[start..self.pos]).unwrap_or("?"))
    }

    /// The next word, owned (empty at the end of the file).
    fn word(&mut self) -> String {
        self.token().unwrap_or("").to_string()
    }

    /// Steps over the values of array `name`: `components × tuples` numbers (ASCII) or as many
    /// values of `ty` in bytes after the header line (binary).
    fn values(
        &mut self,
        binary: bool,
        name: &str,
        ty: &str,
        components: u64,
        tuples: u64,
    ) -> Result<()> {
        let line = self.line;
        let count = components.saturating_mul(tuples);
        let expected = format!(
            "array '{name}' ({ty}, declared on line {line}) needs {count} values ({tuples} tuples × {components} components)"
        );
        if binary {
            let size: u64 = match ty.to_ascii_lowercase().as_str() {
                "bit" => {
                    self.skip_line();
                    let bytes = count.div_ceil(8);
                    return self.skip_bytes(bytes, &expected);
                }
                "char" | "unsigned_char" => 1,
                "short" | "unsigned_short" => 2,
                "int" | "unsigned_int" | "float" => 4,
                _ => 8,
            };
            self.skip_line();
            return self.skip_bytes(count.saturating_mul(size), &expected);
        }
        for found in 0..count {
            let at = self.line;
            match self.token() {
                None => bail!("{expected}; the file ends after {found}"),
                Some(t) if t.parse::<f64>().is_err() => {
                    bail!("{expected}; line {at} holds '{t}' after {found}, not a number")
                }
                Some(_) => {}
            }
        }
        Ok(())
    }

    fn skip_bytes(&mut self, n: u64, expected: &str) -> Result<()> {
        let left = (self.bytes.len() - self.pos) as u64;
        if n > left {
            bail!("{expected}: {n} bytes, but the file has {left} bytes left");
        }
        self.pos += n as usize;
        Ok(())
    }
}
