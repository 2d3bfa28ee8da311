//! # vtkxml
//!
//! Reading and writing VTK XML files, including what ParaView writes by default (raw appended data,
//! compressed in blocks), which `vtkio` (0.6.3, 0.7.0-rc2) cannot read.
//!
//! - Reading ([`read_image`], [`read_structured`], [`read_unstructured`], [`read_polydata`]): image
//!   data (`.vti`), rectilinear grids (`.vtr`), unstructured grids (`.vtu`) and the polygons of poly
//!   data (`.vtp`), single-piece, in every encoding VTK writes: ASCII, inline base64, appended raw or
//!   base64, uncompressed or compressed in blocks with zlib, LZ4 or LZMA, 32- or 64-bit headers,
//!   either byte order. Origin, spacing and points keep full `f64` precision.
//! - Writing ([`write_image`], [`write_tets`], [`write_triangles`], [`write_polygons`]): `.vti`,
//!   tetrahedral `.vtu` and polygonal `.vtp` in ParaView's default layout (appended raw, zlib blocks,
//!   64-bit headers) with data-set `<FieldData>`.
//!
//! Arrays are [`Array`]s: a name, a number of components and typed [`Values`].
//!
//! ```no_run
//! let image = vtkxml::read_image(std::path::Path::new("volume.vti"))?;
//! println!("{:?} points", image.grid.dims);
//! for a in &image.point_data {
//!     println!("{}: {} tuples of {}", a.describe(), a.tuples(), a.type_name());
//! }
//! # Ok::<(), vtkxml::Error>(())
//! ```

/// Returns early with an [`Error`] built like `format!`.
macro_rules! bail {
    ($($arg:tt)*) => {
        return Err($crate::Error(format!($($arg)*)))
    };
}

/// `$body` with `$v` bound to the vector of any variant of `$values`.
macro_rules! with_values {
    ($values:expr, $v:ident => $body:expr) => {
        match $values {
            $crate::Values::I8($v) => $body,
            $crate::Values::U8($v) => $body,
            $crate::Values::I16($v) => $body,
            $crate::Values::U16($v) => $body,
            $crate::Values::I32($v) => $body,
            $crate::Values::U32($v) => $body,
            $crate::Values::I64($v) => $body,
            $crate::Values::U64($v) => $body,
            $crate::Values::F32($v) => $body,
            $crate::Values::F64($v) => $body,
        }
    };
}

mod read;
mod write;

pub use read::{
    read_image, read_polydata, read_structured, read_unstructured, Geometry, Image, PolyData,
    Structured, Unstructured,
};
pub use write::{
    checked_extension, write_image, write_polygons, write_tets, write_triangles, Polygons, TetGrid,
    Triangles,
};

use std::path::Path;

/// An error with a message meant for the end user (reading errors name the file).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct Error(pub String);

/// Result alias of the crate.
pub type Result<T> = std::result::Result<T, Error>;

/// The geometry of image data: points per axis, the world position of the first point and the
/// spacing between points (axis-aligned).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UniformGrid {
    pub dims: [usize; 3],
    pub origin: [f64; 3],
    pub spacing: [f64; 3],
}

/// The values of an [`Array`], flat (tuple after tuple), in one of VTK's numeric types.
#[derive(Clone, Debug, PartialEq)]
pub enum Values {
    I8(Vec<i8>),
    U8(Vec<u8>),
    I16(Vec<i16>),
    U16(Vec<u16>),
    I32(Vec<i32>),
    U32(Vec<u32>),
    I64(Vec<i64>),
    U64(Vec<u64>),
    F32(Vec<f32>),
    F64(Vec<f64>),
}

macro_rules! values_from {
    ($($t:ty => $variant:ident),*) => {
        $(impl From<Vec<$t>> for Values {
            fn from(v: Vec<$t>) -> Self {
                Values::$variant(v)
            }
        })*
    };
}

values_from!(i8 => I8, u8 => U8, i16 => I16, u16 => U16, i32 => I32, u32 => U32, i64 => I64,
    u64 => U64, f32 => F32, f64 => F64);

impl Values {
    /// Number of values.
    pub fn len(&self) -> usize {
        with_values!(self, v => v.len())
    }

    /// Whether there is no value.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Value `k` as `f64` (rounded for 64-bit integers beyond 2^53).
    #[allow(clippy::unnecessary_cast)] // one cast for every type, `f64` included
    pub fn get(&self, k: usize) -> f64 {
        with_values!(self, v => v[k] as f64)
    }

    /// VTK's name of the value type (`UInt8`, `Float32`, …).
    pub fn type_name(&self) -> &'static str {
        match self {
            Values::I8(_) => "Int8",
            Values::U8(_) => "UInt8",
            Values::I16(_) => "Int16",
            Values::U16(_) => "UInt16",
            Values::I32(_) => "Int32",
            Values::U32(_) => "UInt32",
            Values::I64(_) => "Int64",
            Values::U64(_) => "UInt64",
            Values::F32(_) => "Float32",
            Values::F64(_) => "Float64",
        }
    }

    /// The values of the type named by `type_name` (one of [`Values::type_name`]'s names) converted
    /// from `f64` (`as` casts: exact for values that came from that type).
    pub fn from_f64(type_name: &str, v: Vec<f64>) -> Option<Values> {
        fn cast<T>(v: Vec<f64>, f: impl Fn(f64) -> T) -> Vec<T> {
            v.into_iter().map(f).collect()
        }
        Some(match type_name {
            "Int8" => Values::I8(cast(v, |x| x as i8)),
            "UInt8" => Values::U8(cast(v, |x| x as u8)),
            "Int16" => Values::I16(cast(v, |x| x as i16)),
            "UInt16" => Values::U16(cast(v, |x| x as u16)),
            "Int32" => Values::I32(cast(v, |x| x as i32)),
            "UInt32" => Values::U32(cast(v, |x| x as u32)),
            "Int64" => Values::I64(cast(v, |x| x as i64)),
            "UInt64" => Values::U64(cast(v, |x| x as u64)),
            "Float32" => Values::F32(cast(v, |x| x as f32)),
            "Float64" => Values::F64(v),
            _ => return None,
        })
    }
}

/// A named data array: `components` values per tuple (point or cell), stored flat.
#[derive(Clone, Debug, PartialEq)]
pub struct Array {
    pub name: String,
    pub components: usize,
    pub data: Values,
}

impl Array {
    /// A one-component array.
    pub fn scalars(name: impl Into<String>, data: impl Into<Values>) -> Self {
        Self {
            name: name.into(),
            components: 1,
            data: data.into(),
        }
    }

    /// Number of tuples.
    pub fn tuples(&self) -> usize {
        self.data.len() / self.components.max(1)
    }

    /// VTK's name of the value type.
    pub fn type_name(&self) -> &'static str {
        self.data.type_name()
    }

    /// The tuples at `ids`, in that order.
    pub fn gather(&self, ids: &[usize]) -> Array {
        let c = self.components;
        let data = with_values!(&self.data, v => {
            let mut out = Vec::with_capacity(ids.len() * c);
            for &i in ids {
                out.extend_from_slice(&v[i * c..(i + 1) * c]);
            }
            Values::from(out)
        });
        Array {
            name: self.name.clone(),
            components: c,
            data,
        }
    }

    /// Value `k` as `f64` (for reports and comparisons).
    pub fn value(&self, k: usize) -> f64 {
        self.data.get(k)
    }

    /// `name (3 components)` or `name` for messages.
    pub fn describe(&self) -> String {
        if self.components == 1 {
            self.name.clone()
        } else {
            format!("{} ({} components)", self.name, self.components)
        }
    }
}

/// Lower-case extension of `path` (empty without one): the readers and writers check it.
pub fn extension(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// Number of points of a grid of `dims` points per axis (or of cells, given cells per axis), refusing
/// overflow.
pub fn point_count(dims: [usize; 3]) -> Result<usize> {
    dims.iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .ok_or_else(|| Error(format!("grid of {dims:?} points is too large")))
}
