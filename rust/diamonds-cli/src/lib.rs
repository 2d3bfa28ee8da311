//! # diamonds-cli
//!
//! The `diamonds` command line program: adaptive tetrahedral meshes of VTK image data (the core crate
//! [`diamonds`] does the work; this crate reads and writes VTK files and reports).
//!
//! - [`read`]: VTK image data (`.vti` XML, `.vtk` legacy `STRUCTURED_POINTS`), rectilinear grids
//!   (`.vtr`), unstructured grids (`.vtu`) and polygonal data (`.vtp`); the XML files through
//!   [`vtkxml`], legacy files through `vtkio`.
//! - [`write`]: `.vti`, `.vtu` and `.vtp` output through [`vtkxml`].
//! - [`commands`]: the `tetra`, `iso`, `generate`, `verify` and `verify-surface` subcommands as library
//!   functions.
//! - [`isodiamonds`]: the `isodiamonds build` and `extract` subcommands (one isosurface or interval
//!   volume as a relevant or minimal isodiamond hierarchy, `.isd`, extracted without the volume).
//! - [`progressive`]: the `progressive encode` and `decode` subcommands (progressive tetrahedral
//!   meshes of `.vtu` grids, streams valid at any prefix).
//! - [`view`]: the `view` subcommand (a view-dependent mesh for a camera, optionally in exact
//!   visibility order, after an optional orbit).
//! - [`material`]: the `material` subcommand (material interfaces with ghost values) and the impact
//!   case of `generate --field impact`.

pub mod commands;
pub mod interval;
pub mod isodiamonds;
pub mod material;
pub mod progressive;
pub mod read;
pub mod view;
pub mod write;

use diamonds::ScalarSlice;
use std::fmt;
/// The CLI's data arrays are those of [`vtkxml`].
pub use vtkxml::{Array, Values};

/// A number for a report: as Rust writes it (shortest exact form) between 10⁻⁴ and 10¹², with an
/// exponent outside (`5.551115123125783e-17`, not 16 zeros first; `{}` never uses one).
pub struct Number(pub f64);

impl fmt::Display for Number {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let x = self.0.abs();
        if x == 0.0 || !x.is_finite() || (1e-4..1e12).contains(&x) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

/// `a` at points between its samples (`sources` and `weights` of a core result: an isosurface, an
/// interval volume): `(1 − w) a[i] + w a[j]` per component (exactly `a[i]` at a sample), of `a`'s
/// type (integers rounded), as VTK's `InterpolateEdge` does.
pub fn interpolated(a: &Array, sources: &[[u32; 2]], weights: &[f64]) -> Array {
    let c = a.components;
    let mut out = Vec::with_capacity(sources.len() * c);
    for (&[i, j], &w) in sources.iter().zip(weights) {
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

/// An error with a message meant for the end user (printed as `error: <message>`, exit code 2).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Error(pub String);

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Error {}

impl From<vtkxml::Error> for Error {
    fn from(e: vtkxml::Error) -> Self {
        Error(e.0)
    }
}

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

/// The values of an [`Array`] as a sample array the hierarchy can read in place.
pub trait AsScalarSlice {
    /// The samples, refusing 64-bit integers with a message naming the array.
    fn scalar_slice(&self) -> Result<ScalarSlice<'_>>;
}

impl AsScalarSlice for Array {
    fn scalar_slice(&self) -> Result<ScalarSlice<'_>> {
        Ok(match &self.data {
            Values::U8(v) => ScalarSlice::U8(v),
            Values::I8(v) => ScalarSlice::I8(v),
            Values::U16(v) => ScalarSlice::U16(v),
            Values::I16(v) => ScalarSlice::I16(v),
            Values::U32(v) => ScalarSlice::U32(v),
            Values::I32(v) => ScalarSlice::I32(v),
            Values::F32(v) => ScalarSlice::F32(v),
            Values::F64(v) => ScalarSlice::F64(v),
            Values::I64(_) | Values::U64(_) => bail!(
                "point-data array '{}' has type {}, which is not supported (supported: Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64)",
                self.name,
                self.type_name()
            ),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::Number;

    #[test]
    fn numbers_take_an_exponent_only_when_tiny_or_huge() {
        for (x, written) in [
            (0.0, "0"),
            (0.0967, "0.0967"),
            (-2.5, "-2.5"),
            (123456789.0, "123456789"),
            (5.551115123125783e-17, "5.551115123125783e-17"),
            (2.99e-302, "2.99e-302"),
            (-1e300, "-1e300"),
        ] {
            assert_eq!(Number(x).to_string(), written);
        }
    }
}
