//! Typed sample arrays of a regular grid, borrowed in place (never copied to `f64`).

use crate::{Error, Result};

/// Geometry of a regular grid: points along x, y, z (x fastest), world origin and spacing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    pub dims: [usize; 3],
    pub origin: [f64; 3],
    pub spacing: [f64; 3],
}

impl Grid {
    /// A grid of `dims` points with VTK's default geometry: origin 0, spacing 1.
    pub fn new(dims: [usize; 3]) -> Self {
        Self {
            dims,
            origin: [0.0; 3],
            spacing: [1.0; 3],
        }
    }

    /// Validates dimensions (≥ 2 points per axis) and geometry (finite origin, finite positive spacing).
    pub fn validate(&self) -> Result<()> {
        if self.dims.iter().any(|&d| d < 2) {
            return Err(Error::Dimensions { dims: self.dims });
        }
        let bad_origin = self.origin.iter().any(|o| !o.is_finite());
        let bad_spacing = self.spacing.iter().any(|s| !s.is_finite() || *s <= 0.0);
        if bad_origin || bad_spacing {
            return Err(Error::Geometry {
                origin: self.origin,
                spacing: self.spacing,
            });
        }
        Ok(())
    }

    /// The grid of a rectilinear grid's coordinate arrays, refused unless every axis is uniformly spaced
    /// (to 1e-4 of its mean spacing): the diamond mesh needs a regular grid.
    pub fn from_coordinates(coords: [&[f64]; 3]) -> Result<Self> {
        let mut grid = Self::new(coords.map(|c| c.len()));
        for (a, c) in coords.iter().enumerate() {
            if c.len() < 2 {
                return Err(Error::Dimensions { dims: grid.dims });
            }
            let mean = (c[c.len() - 1] - c[0]) / (c.len() - 1) as f64;
            let uneven = c
                .windows(2)
                .position(|w| ((w[1] - w[0]) - mean).abs() > 1e-4 * mean.abs());
            if let Some(i) = uneven {
                return Err(Error::Parameter(format!(
                    "the {} coordinates are not uniformly spaced (step {} at index {i}, mean {mean}); resample the rectilinear grid to a uniform one first",
                    ["x", "y", "z"][a],
                    c[i + 1] - c[i]
                )));
            }
            grid.origin[a] = c[0];
            grid.spacing[a] = mean;
        }
        grid.validate()?;
        Ok(grid)
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    /// Always false for a validated grid; provided for API symmetry with `len`.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Linear point index of lattice point (i, j, k), x fastest (VTK's order).
    #[inline]
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    /// (i, j, k) of a linear point index.
    #[inline]
    pub fn ijk(&self, index: usize) -> [usize; 3] {
        let i = index % self.dims[0];
        let j = (index / self.dims[0]) % self.dims[1];
        [i, j, index / (self.dims[0] * self.dims[1])]
    }

    /// World position of lattice point (i, j, k).
    #[inline]
    pub fn point(&self, ijk: [usize; 3]) -> [f64; 3] {
        std::array::from_fn(|a| self.origin[a] + self.spacing[a] * ijk[a] as f64)
    }

    /// World bounds `[xmin, xmax, ymin, ymax, zmin, zmax]`.
    pub fn bounds(&self) -> [f64; 6] {
        let hi = self.point([self.dims[0] - 1, self.dims[1] - 1, self.dims[2] - 1]);
        [
            self.origin[0],
            hi[0],
            self.origin[1],
            hi[1],
            self.origin[2],
            hi[2],
        ]
    }

    /// Length of the diagonal of [`Grid::bounds`].
    pub fn diagonal(&self) -> f64 {
        bounds_diagonal(&self.bounds())
    }

    /// How far apart to sample surfaces that are checked against `distance` (a tolerance):
    /// half of it, but no finer than the smallest spacing and no coarser than the largest (on a
    /// grid of equal spacings, that spacing whatever the distance). Every point of a triangle
    /// sampled so ([`crate::geometry::triangle_samples`]) lies within `step / √3` of a sample.
    pub fn sampling_step(&self, distance: f64) -> f64 {
        let smallest = self.spacing.into_iter().fold(f64::INFINITY, f64::min);
        let largest = self.spacing.into_iter().fold(0.0, f64::max);
        (0.5 * distance).clamp(smallest, largest)
    }
}

/// Length of the diagonal of `bounds` (`[xmin, xmax, ymin, ymax, zmin, zmax]`).
pub fn bounds_diagonal(bounds: &[f64; 6]) -> f64 {
    let d = (0..3).map(|a| (bounds[2 * a + 1] - bounds[2 * a]).powi(2));
    d.sum::<f64>().sqrt()
}

/// A sample type the hierarchy can read in place.
pub trait Sample: Copy + Send + Sync + 'static {
    /// The value as `f64` (exact for every integer type up to 32 bits).
    fn to_f64(self) -> f64;
}

/// A sample read negated: a volume of `−f` without a copy ([`Volume::negated`]).
#[derive(Clone, Copy, Debug)]
#[repr(transparent)]
pub struct Negated<T>(T);

impl<T: Sample> Sample for Negated<T> {
    #[inline(always)]
    fn to_f64(self) -> f64 {
        -self.0.to_f64()
    }
}

// SAFETY: `Negated<T>` is `repr(transparent)` over `T`, its only field.
unsafe impl<T> bytemuck::TransparentWrapper<T> for Negated<T> {}

macro_rules! impl_sample {
    ($($t:ty),*) => {$(
        impl Sample for $t {
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
        }
    )*};
}
impl_sample!(u8, i8, u16, i16, u32, i32, f32, f64);

/// The supported sample types, as VTK names them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScalarType {
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    F32,
    F64,
}

/// A borrowed sample array of any supported type.
#[derive(Clone, Copy, Debug)]
pub enum ScalarSlice<'a> {
    U8(&'a [u8]),
    I8(&'a [i8]),
    U16(&'a [u16]),
    I16(&'a [i16]),
    U32(&'a [u32]),
    I32(&'a [i32]),
    F32(&'a [f32]),
    F64(&'a [f64]),
}

/// Calls `$body` with `$v` bound to a typed [`Volume`] for whichever type `$slice` holds.
#[macro_export]
macro_rules! with_volume {
    ($grid:expr, $slice:expr, |$v:ident| $body:expr) => {
        match $slice {
            $crate::ScalarSlice::U8(s) => {
                let $v = $crate::Volume::new($grid, s)?;
                $body
            }
            $crate::ScalarSlice::I8(s) => {
                let $v = $crate::Volume::new($grid, s)?;
                $body
            }
            $crate::ScalarSlice::U16(s) => {
                let $v = $crate::Volume::new($grid, s)?;
                $body
            }
            $crate::ScalarSlice::I16(s) => {
                let $v = $crate::Volume::new($grid, s)?;
                $body
            }
            $crate::ScalarSlice::U32(s) => {
                let $v = $crate::Volume::new($grid, s)?;
                $body
            }
            $crate::ScalarSlice::I32(s) => {
                let $v = $crate::Volume::new($grid, s)?;
                $body
            }
            $crate::ScalarSlice::F32(s) => {
                let $v = $crate::Volume::new($grid, s)?;
                $body
            }
            $crate::ScalarSlice::F64(s) => {
                let $v = $crate::Volume::new($grid, s)?;
                $body
            }
        }
    };
}

impl ScalarSlice<'_> {
    /// Number of values.
    pub fn len(&self) -> usize {
        match self {
            ScalarSlice::U8(s) => s.len(),
            ScalarSlice::I8(s) => s.len(),
            ScalarSlice::U16(s) => s.len(),
            ScalarSlice::I16(s) => s.len(),
            ScalarSlice::U32(s) => s.len(),
            ScalarSlice::I32(s) => s.len(),
            ScalarSlice::F32(s) => s.len(),
            ScalarSlice::F64(s) => s.len(),
        }
    }

    /// True when there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The sample type.
    pub fn scalar_type(&self) -> ScalarType {
        match self {
            ScalarSlice::U8(_) => ScalarType::U8,
            ScalarSlice::I8(_) => ScalarType::I8,
            ScalarSlice::U16(_) => ScalarType::U16,
            ScalarSlice::I16(_) => ScalarType::I16,
            ScalarSlice::U32(_) => ScalarType::U32,
            ScalarSlice::I32(_) => ScalarType::I32,
            ScalarSlice::F32(_) => ScalarType::F32,
            ScalarSlice::F64(_) => ScalarType::F64,
        }
    }
}

/// The largest sample magnitude accepted: `f64::MAX / 2^40`, about 1.6e296. The exact error of a
/// tetrahedron ([`crate::scan`]) sums products of samples with barycentric numerators of up to
/// 2^33 (lattice coordinates reach 2^24); beyond this limit those sums would overflow to infinity or
/// NaN, and an error that is not a number passes every tolerance test silently.
pub const MAX_MAGNITUDE: f64 = f64::MAX / (1u64 << 40) as f64;

/// A grid with its samples, borrowed.
#[derive(Clone, Copy, Debug)]
pub struct Volume<'a, T> {
    pub grid: Grid,
    pub samples: &'a [T],
}

impl<'a, T: Sample> Volume<'a, T> {
    /// The same samples read as `−f` (no copy): marching tetrahedra on it at `−v` count samples
    /// at `v` as below `v`.
    pub fn negated(&self) -> Volume<'a, Negated<T>> {
        use bytemuck::TransparentWrapper;
        Volume {
            grid: self.grid,
            samples: Negated::wrap_slice(self.samples),
        }
    }

    /// Checks dimensions, geometry and length, and refuses NaN/Inf samples and samples beyond
    /// [`MAX_MAGNITUDE`].
    pub fn new(grid: Grid, samples: &'a [T]) -> Result<Self> {
        grid.validate()?;
        let expected = grid
            .dims
            .iter()
            .try_fold(1usize, |acc, &d| acc.checked_mul(d));
        if expected != Some(samples.len()) {
            return Err(Error::Length {
                len: samples.len(),
                expected: expected.unwrap_or(usize::MAX),
                dims: grid.dims,
            });
        }
        // One pass for both refusals.
        if let Some(index) = samples.iter().position(|s| {
            let v = s.to_f64();
            v.is_nan() || v.abs() > MAX_MAGNITUDE
        }) {
            let (ijk, value) = (grid.ijk(index), samples[index].to_f64());
            return Err(if value.is_finite() {
                Error::Magnitude { index, ijk, value }
            } else {
                Error::NonFinite { index, ijk, value }
            });
        }
        Ok(Self { grid, samples })
    }

    /// Sample at point index `i` (x fastest) as `f64`.
    #[inline]
    pub fn at_index(&self, i: usize) -> f64 {
        self.samples[i].to_f64()
    }

    /// Sample at lattice point (i, j, k) as `f64`.
    #[inline]
    pub fn at(&self, i: usize, j: usize, k: usize) -> f64 {
        self.samples[self.grid.index(i, j, k)].to_f64()
    }

    /// Smallest and largest sample in the box `[lo, hi]` of lattice points (inside the grid).
    pub fn box_range(&self, lo: glam::IVec3, hi: glam::IVec3) -> (f64, f64) {
        let (mut a, mut b) = (f64::INFINITY, f64::NEG_INFINITY);
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                let row = self.grid.index(0, y as usize, z as usize);
                for s in &self.samples[row + lo.x as usize..=row + hi.x as usize] {
                    let v = s.to_f64();
                    a = a.min(v);
                    b = b.max(v);
                }
            }
        }
        (a, b)
    }

    /// Smallest and largest sample.
    pub fn range(&self) -> (f64, f64) {
        self.samples
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), s| {
                let v = s.to_f64();
                (lo.min(v), hi.max(v))
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(dims: [usize; 3]) -> Grid {
        Grid::new(dims)
    }

    #[test]
    fn refuses_flat_grids_and_bad_lengths() {
        assert!(matches!(
            Volume::new(grid([4, 4, 1]), &[0u8; 16]),
            Err(Error::Dimensions { .. })
        ));
        assert!(matches!(
            Volume::new(grid([2, 2, 2]), &[0u8; 7]),
            Err(Error::Length { .. })
        ));
    }

    #[test]
    fn refuses_nan_with_its_position() {
        let mut s = [0.0f32; 8];
        s[5] = f32::NAN;
        match Volume::new(grid([2, 2, 2]), &s) {
            Err(Error::NonFinite { index, ijk, .. }) => {
                assert_eq!(index, 5);
                assert_eq!(ijk, [1, 0, 1]);
            }
            other => panic!("expected NonFinite, got {other:?}"),
        }
    }

    #[test]
    fn refuses_magnitudes_whose_error_arithmetic_overflows() {
        // Smooth data near the largest double: its errors overflowed to NaN and passed as 0.
        let s: Vec<f64> = (0..27).map(|i| 1.5e308 + i as f64 * 1e306).collect();
        match Volume::new(grid([3, 3, 3]), &s) {
            Err(e @ Error::Magnitude { index: 0, .. }) => {
                assert!(e.to_string().contains("overflow"), "{e}")
            }
            other => panic!("expected Magnitude, got {other:?}"),
        }
        let mut s = vec![0.0f64; 8];
        s[3] = -MAX_MAGNITUDE;
        assert!(Volume::new(grid([2, 2, 2]), &s).is_ok());
        s[3] = -MAX_MAGNITUDE * 1.000001;
        assert!(matches!(
            Volume::new(grid([2, 2, 2]), &s),
            Err(Error::Magnitude { index: 3, .. })
        ));
    }

    #[test]
    fn refuses_bad_spacing() {
        let mut g = grid([2, 2, 2]);
        g.spacing[1] = 0.0;
        assert!(matches!(
            Volume::new(g, &[0u8; 8]),
            Err(Error::Geometry { .. })
        ));
    }
}
