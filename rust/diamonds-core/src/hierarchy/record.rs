//! The per-diamond record and its codec (Weiss & De Floriani §4: "a three-dimensional array" of
//! diamond data; Marchesin §4.1 for the error it bounds).
//!
//! A [`Record`] holds, in 2 bytes, the diamond's **exact** maximum interpolation error, rounded *up* to
//! a bfloat16 ([`encode_error`]) — an upper bound within 0.8 % that is 0 exactly when the error is 0,
//! so tolerance 0 stays lossless. (No sample range: the isosurface queries that would cull by it keep
//! their own brick ranges, `crate::isosurface::cache`, and build no records.)
//!
//! The same bfloat16 code, rounded down ([`encode_down`]), stores the gradient magnitudes the
//! isosurface error divides by (Gregorski §6.2).

/// Per-diamond data, 2 bytes, indexed by the central vertex's point index.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Record {
    /// Upper bound of the exact error, as the high half of an `f32` rounded up (bfloat16).
    pub(super) error: u16,
}

impl Record {
    /// The record of a diamond whose inside tetrahedra have the largest error `error` (0 when it
    /// has none).
    pub(super) fn of(error: f64) -> Self {
        Self {
            error: encode_error(error),
        }
    }
}

/// Encodes a non-negative error as a bfloat16, rounding up.
pub fn encode_error(e: f64) -> u16 {
    debug_assert!(e >= 0.0);
    let mut f = e as f32;
    if (f as f64) < e {
        f = f.next_up();
    }
    let bits = f.to_bits();
    let high = (bits >> 16) as u16;
    if bits & 0xFFFF != 0 {
        high + 1
    } else {
        high
    }
}

/// Encodes a non-negative number as a bfloat16, rounding down (toward zero).
pub fn encode_down(x: f64) -> u16 {
    let mut f = x as f32;
    if f as f64 > x {
        f = f.next_down();
    }
    (f.to_bits() >> 16) as u16
}

/// Decodes [`encode_error`] and [`encode_down`].
#[inline]
pub fn decode_error(code: u16) -> f64 {
    f32::from_bits((code as u32) << 16) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_code_rounds_up_and_keeps_zero() {
        assert_eq!(encode_error(0.0), 0);
        assert_eq!(decode_error(encode_error(0.0)), 0.0);
        for e in [1e-12, 0.3, 0.5, 1.0, 2.0, 3.7, 255.0, 1234.5678, 6.02e23] {
            let d = decode_error(encode_error(e));
            assert!(d >= e && d <= e * (1.0 + 1.0 / 128.0), "{e} -> {d}");
        }
        // Monotone.
        let mut last = 0;
        for i in 0..10_000 {
            let c = encode_error(i as f64 * 0.37);
            assert!(c >= last);
            last = c;
        }
    }
}
