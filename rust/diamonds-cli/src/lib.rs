//! # diamonds-cli
//!
//! The `diamonds` command line program: adaptive tetrahedral meshes of VTK image data (the core crate
//! [`diamonds`] does the work; this crate reads and writes VTK files and reports).
//!
//! - [`read`]: VTK image data (`.vti` XML, `.vtk` legacy `STRUCTURED_POINTS`), rectilinear grids
//!   (`.vtr`), unstructured grids
//!   (`.vtu`) and polygonal data (`.vtp`), every encoding VTK writes.
//! - [`write`]: `.vti`, `.vtu` and `.vtp` output (appended, zlib-compressed, with field data).
//! - [`commands`]: the `tetra`, `iso`, `generate`, `verify` and `verify-surface` subcommands as library
//!   functions.
//! - [`material`]: the `material` subcommand (material interfaces with ghost values) and the impact
//!   case of `generate --field impact`.

pub mod commands;
pub mod material;
pub mod read;
pub mod write;

use diamonds::ScalarSlice;
use vtkio::model::IOBuffer;

/// An error with a message meant for the end user (printed as `error: <message>`, exit code 2).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Error(pub String);

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Error {}

impl From<diamonds::Error> for Error {
    fn from(e: diamonds::Error) -> Self {
        Error(e.to_string())
    }
}

/// Result alias of the crate.
pub type Result<T> = std::result::Result<T, Error>;

/// Returns early with an [`Error`] built like `format!`.
#[macro_export]
macro_rules! bail {
    ($($arg:tt)*) => {
        return Err($crate::Error(format!($($arg)*)))
    };
}

/// A named data array: `components` values per tuple (point or cell), stored flat.
#[derive(Clone, Debug, PartialEq)]
pub struct Array {
    pub name: String,
    pub components: usize,
    pub data: IOBuffer,
}

impl Array {
    /// A one-component array.
    pub fn scalars(name: impl Into<String>, data: impl Into<IOBuffer>) -> Self {
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
        match &self.data {
            IOBuffer::Bit(_) => "Bit",
            IOBuffer::U8(_) => "UInt8",
            IOBuffer::I8(_) => "Int8",
            IOBuffer::U16(_) => "UInt16",
            IOBuffer::I16(_) => "Int16",
            IOBuffer::U32(_) => "UInt32",
            IOBuffer::I32(_) => "Int32",
            IOBuffer::U64(_) => "UInt64",
            IOBuffer::I64(_) => "Int64",
            IOBuffer::F32(_) => "Float32",
            IOBuffer::F64(_) => "Float64",
        }
    }

    /// The tuples at `ids`, in that order (bit arrays are not supported and give `None`).
    pub fn gather(&self, ids: &[usize]) -> Option<Array> {
        fn pick<T: Copy>(v: &[T], ids: &[usize], c: usize) -> Vec<T> {
            let mut out = Vec::with_capacity(ids.len() * c);
            for &i in ids {
                out.extend_from_slice(&v[i * c..(i + 1) * c]);
            }
            out
        }
        let c = self.components;
        let data = match &self.data {
            IOBuffer::Bit(_) => return None,
            IOBuffer::U8(v) => IOBuffer::U8(pick(v, ids, c)),
            IOBuffer::I8(v) => IOBuffer::I8(pick(v, ids, c)),
            IOBuffer::U16(v) => IOBuffer::U16(pick(v, ids, c)),
            IOBuffer::I16(v) => IOBuffer::I16(pick(v, ids, c)),
            IOBuffer::U32(v) => IOBuffer::U32(pick(v, ids, c)),
            IOBuffer::I32(v) => IOBuffer::I32(pick(v, ids, c)),
            IOBuffer::U64(v) => IOBuffer::U64(pick(v, ids, c)),
            IOBuffer::I64(v) => IOBuffer::I64(pick(v, ids, c)),
            IOBuffer::F32(v) => IOBuffer::F32(pick(v, ids, c)),
            IOBuffer::F64(v) => IOBuffer::F64(pick(v, ids, c)),
        };
        Some(Array {
            name: self.name.clone(),
            components: c,
            data,
        })
    }

    /// The values as a sample array the hierarchy can read in place.
    pub fn scalar_slice(&self) -> Result<ScalarSlice<'_>> {
        Ok(match &self.data {
            IOBuffer::U8(v) => ScalarSlice::U8(v),
            IOBuffer::I8(v) => ScalarSlice::I8(v),
            IOBuffer::U16(v) => ScalarSlice::U16(v),
            IOBuffer::I16(v) => ScalarSlice::I16(v),
            IOBuffer::U32(v) => ScalarSlice::U32(v),
            IOBuffer::I32(v) => ScalarSlice::I32(v),
            IOBuffer::F32(v) => ScalarSlice::F32(v),
            IOBuffer::F64(v) => ScalarSlice::F64(v),
            _ => bail!(
                "point-data array '{}' has type {}, which is not supported (supported: Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64)",
                self.name,
                self.type_name()
            ),
        })
    }

    /// Value `k` as `f64` (for reports and comparisons).
    pub fn value(&self, k: usize) -> f64 {
        match &self.data {
            IOBuffer::Bit(v) => ((v[k / 8] >> (7 - k % 8)) & 1) as f64,
            IOBuffer::U8(v) => v[k] as f64,
            IOBuffer::I8(v) => v[k] as f64,
            IOBuffer::U16(v) => v[k] as f64,
            IOBuffer::I16(v) => v[k] as f64,
            IOBuffer::U32(v) => v[k] as f64,
            IOBuffer::I32(v) => v[k] as f64,
            IOBuffer::U64(v) => v[k] as f64,
            IOBuffer::I64(v) => v[k] as f64,
            IOBuffer::F32(v) => v[k] as f64,
            IOBuffer::F64(v) => v[k],
        }
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
