//! Blocks: the cheap distance certificate of the two-sided bound ([`super::bound`]).
//!
//! World space is cut into cubes (*blocks*) of side `reach / (2√3)`, so that two points in the same
//! block or in neighbouring ones (the 27 around a block) are within `reach` of each other. A set of
//! points is stored as the blocks that hold one of them *grown* by one block in every direction: a
//! point in a grown block is then within `reach` of the set, with one lookup. The set is a dense
//! bitset over the blocks of the grid's bounds (rows padded to 64-bit words, grown by three
//! separable passes of word shifts and ORs); reaches below [`Blocks::dense_reach`] are not offered
//! blocks (the callers measure exact distances instead).

use crate::Result;
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// Largest dense bitset, in blocks (32 MiB).
const MAX_DENSE: usize = 1 << 28;

/// A bitset of `n` bits, all clear.
pub(super) fn bits(n: usize) -> Vec<AtomicU64> {
    (0..n.div_ceil(64)).map(|_| AtomicU64::new(0)).collect()
}

/// Sets bit `i`; returns whether it was clear.
#[inline]
pub(super) fn set_bit(bits: &[AtomicU64], i: usize) -> bool {
    let bit = 1u64 << (i % 64);
    bits[i / 64].fetch_or(bit, Ordering::Relaxed) & bit == 0
}

/// The blocks within one block of a set of points (see the module documentation).
pub(super) struct Blocks {
    origin: DVec3,
    /// The reach the blocks were made for.
    reach: f64,
    side: f64,
    /// Blocks along each axis.
    dims: [usize; 3],
    /// 64-bit words per row of the bitset.
    row: usize,
    /// The grown blocks, a bit each.
    bits: Vec<u64>,
}

impl Blocks {
    /// The smallest reach for which the blocks over the box `[lo, hi]` are a dense bitset (at
    /// most `MAX_DENSE` blocks).
    pub(super) fn dense_reach(lo: DVec3, hi: DVec3) -> f64 {
        // n blocks along an axis of extent e with side s: ⌊e / s⌋ + 1 ≤ e / s + 1.
        let e = (hi - lo).max(DVec3::splat(f64::MIN_POSITIVE));
        let volume = (e.x + 1.0) * (e.y + 1.0) * (e.z + 1.0);
        let mut side = (volume / MAX_DENSE as f64).cbrt();
        while ((e / side).floor() + DVec3::ONE).element_product() > MAX_DENSE as f64 {
            side *= 1.01;
        }
        side * 2.0 * 3f64.sqrt()
    }

    /// The blocks of side `reach / (2√3)` within one block of `points`, over the box `[lo, hi]`
    /// (points outside it may be left out: the certificate then does not apply to them). `reach`
    /// is at least [`Self::dense_reach`] of the box.
    pub(super) fn around(
        lo: DVec3,
        hi: DVec3,
        reach: f64,
        points: impl ParallelIterator<Item = DVec3>,
    ) -> Result<Self> {
        let side = reach / (2.0 * 3f64.sqrt());
        let n = ((hi - lo) / side).floor() + DVec3::ONE;
        // (At most a row more than `MAX_DENSE` when `reach` is `dense_reach`, by rounding.)
        debug_assert!(n.element_product() <= 1.01 * MAX_DENSE as f64, "{n}");
        let dims = [n.x as usize, n.y as usize, n.z as usize];
        let row = dims[0].div_ceil(64);
        let mut blocks = Self {
            origin: lo,
            reach,
            side,
            dims,
            row,
            bits: Vec::new(),
        };
        let marked = bits(row * 64 * dims[1] * dims[2]);
        points.for_each(|p| {
            if let Some(i) = blocks.index(p) {
                set_bit(&marked, i);
            }
        });
        let marked = marked.into_iter().map(AtomicU64::into_inner).collect();
        blocks.bits = blocks.grow(marked)?;
        Ok(blocks)
    }

    /// The reach the blocks were made for.
    pub(super) fn reach(&self) -> f64 {
        self.reach
    }

    /// Is `p` within one block of one of the points (so within `reach` of it)?
    pub(super) fn near(&self, p: DVec3) -> bool {
        self.index(p)
            .is_some_and(|i| self.bits[i / 64] & (1 << (i % 64)) != 0)
    }

    /// The bit of the block holding `p`, none outside the box.
    fn index(&self, p: DVec3) -> Option<usize> {
        let b = ((p - self.origin) / self.side).floor().as_i64vec3();
        let [x, y, z] = [0, 1, 2].map(|a| usize::try_from(b[a]).ok().filter(|&c| c < self.dims[a]));
        Some(((z? * self.dims[1] + y?) * self.row) * 64 + x?)
    }

    /// `marked` (rows of `row` words) grown by one block along x, then y, then z.
    fn grow(&self, marked: Vec<u64>) -> Result<Vec<u64>> {
        let row = self.row;
        let [_, ny, nz] = self.dims;
        let mut a = marked;
        a.par_chunks_mut(row).for_each(|r| {
            let w: Vec<u64> = r.to_vec();
            for i in 0..row {
                let below = if i > 0 { w[i - 1] >> 63 } else { 0 };
                let above = if i + 1 < row { w[i + 1] << 63 } else { 0 };
                r[i] = w[i] | (w[i] << 1) | (w[i] >> 1) | below | above;
            }
        });
        let mut b = crate::memory::filled(a.len(), 0u64, "isosurface bound blocks")?;
        // y: a row ORs the rows before and after it in its slice.
        b.par_chunks_mut(row * ny)
            .zip(a.par_chunks(row * ny))
            .for_each(|(out, slice)| {
                for y in 0..ny {
                    for k in y.saturating_sub(1)..(y + 2).min(ny) {
                        for i in 0..row {
                            out[y * row + i] |= slice[k * row + i];
                        }
                    }
                }
            });
        // z: a slice ORs the slices before and after it.
        let plane = row * ny;
        a.par_chunks_mut(plane).enumerate().for_each(|(z, out)| {
            out.fill(0);
            for k in z.saturating_sub(1)..(z + 2).min(nz) {
                for (o, w) in out.iter_mut().zip(&b[k * plane..(k + 1) * plane]) {
                    *o |= w;
                }
            }
        });
        Ok(a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grown_blocks_are_exactly_the_neighbourhoods_of_the_points() {
        // The blocks agree with the definition at every block centre of the box; a point outside
        // the box is left out.
        let (lo, hi) = (DVec3::ZERO, DVec3::new(150.0, 9.0, 7.0));
        let points = [
            DVec3::new(0.1, 0.1, 0.1),
            DVec3::new(63.7, 4.0, 3.0),
            DVec3::new(64.2, 8.9, 6.9),
            DVec3::new(149.9, 0.5, 3.5),
            DVec3::new(200.0, 1.0, 1.0),
        ];
        let reach = 2.0 * 3f64.sqrt(); // blocks of side 1
        let blocks = Blocks::around(lo, hi, reach, points.par_iter().copied()).unwrap();
        assert_eq!(blocks.dims, [151, 10, 8]);
        let mut near = 0;
        for z in 0..8 {
            for y in 0..10 {
                for x in 0..151 {
                    let c = DVec3::new(x as f64 + 0.5, y as f64 + 0.5, z as f64 + 0.5);
                    let expected = points[..4].iter().any(|&p| {
                        let b = p.floor();
                        (b.x - c.x.floor()).abs() <= 1.0
                            && (b.y - c.y.floor()).abs() <= 1.0
                            && (b.z - c.z.floor()).abs() <= 1.0
                    });
                    assert_eq!(blocks.near(c), expected, "at {c}");
                    near += usize::from(expected);
                }
            }
        }
        assert!(near > 27, "blocks near the points: {near}");
        // Within one block means within `reach`.
        assert!(!blocks.near(DVec3::new(-0.5, 0.5, 0.5)));
    }

    #[test]
    fn the_dense_reach_keeps_the_bitset_within_its_size() {
        for hi in [
            DVec3::new(255.0, 255.0, 255.0),
            DVec3::new(2047.0, 2047.0, 1.0),
            DVec3::new(1e-9, 5.0, 1e6),
        ] {
            let reach = Blocks::dense_reach(DVec3::ZERO, hi);
            let blocks = Blocks::around(DVec3::ZERO, hi, reach, rayon::iter::empty()).unwrap();
            let n: usize = blocks.dims.iter().product();
            assert!(n <= MAX_DENSE, "{hi}: {n} blocks");
            if hi.x == hi.z {
                assert!(
                    n > MAX_DENSE / 2,
                    "{hi}: {n} blocks, a reach larger than needed"
                );
            }
        }
    }
}
