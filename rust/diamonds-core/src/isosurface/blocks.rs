//! Blocks: the cheap distance certificate of the two-sided bound ([`super::bound`]).
//!
//! World space is cut into cubes (*blocks*) of side `reach / (2√3)`, so that two points in the same
//! block or in neighbouring ones (the 27 around a block) are within `reach` of each other. A set of
//! points is stored as the blocks that hold one of them *grown* by one block in every direction: a
//! point in a grown block is then within `reach` of the set, with one lookup. The set is a dense
//! bitset over the blocks of the grid's bounds (rows padded to 64-bit words, grown by three
//! separable passes of word shifts and ORs), or a hash set of blocks when the dense one would be too
//! large (tolerances far below the grid spacing).

use crate::Result;
use glam::DVec3;
use rayon::prelude::*;
use rustc_hash::FxHashSet;
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
    /// Blocks along each axis (dense bitset) or none (hash set).
    dims: [usize; 3],
    /// 64-bit words per row of the dense bitset.
    row: usize,
    storage: Storage,
}

enum Storage {
    Dense(Vec<u64>),
    Sparse(FxHashSet<[i64; 3]>),
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
    /// (points outside it may be left out: the certificate then does not apply to them).
    pub(super) fn around(
        lo: DVec3,
        hi: DVec3,
        reach: f64,
        points: impl ParallelIterator<Item = DVec3>,
    ) -> Result<Self> {
        let side = reach / (2.0 * 3f64.sqrt());
        let n = ((hi - lo) / side).floor() + DVec3::ONE;
        let dense = n.x * n.y * n.z <= MAX_DENSE as f64;
        let dims = if dense {
            [n.x as usize, n.y as usize, n.z as usize]
        } else {
            [0; 3]
        };
        let row = dims[0].div_ceil(64);
        let mut blocks = Self {
            origin: lo,
            reach,
            side,
            dims,
            row,
            storage: Storage::Sparse(FxHashSet::default()),
        };
        blocks.storage = if dense {
            let marked = bits(row * 64 * dims[1] * dims[2]);
            // (`bits` is small: at most MAX_DENSE bits.)
            points.for_each(|p| {
                if let Some(i) = blocks.dense_index(p) {
                    set_bit(&marked, i);
                }
            });
            let marked = marked.into_iter().map(AtomicU64::into_inner).collect();
            Storage::Dense(blocks.grow(marked)?)
        } else {
            let marked: Vec<[i64; 3]> = points.map(|p| blocks.block(p)).collect();
            let marked: FxHashSet<[i64; 3]> = marked.into_iter().collect();
            let mut grown = FxHashSet::default();
            for [x, y, z] in marked {
                for dz in -1..=1 {
                    for dy in -1..=1 {
                        for dx in -1..=1 {
                            grown.insert([x + dx, y + dy, z + dz]);
                        }
                    }
                }
            }
            Storage::Sparse(grown)
        };
        Ok(blocks)
    }

    /// The reach the blocks were made for.
    pub(super) fn reach(&self) -> f64 {
        self.reach
    }

    /// Is `p` within one block of one of the points (so within `reach` of it)?
    pub(super) fn near(&self, p: DVec3) -> bool {
        match &self.storage {
            Storage::Dense(bits) => self
                .dense_index(p)
                .is_some_and(|i| bits[i / 64] & (1 << (i % 64)) != 0),
            Storage::Sparse(set) => set.contains(&self.block(p)),
        }
    }

    /// The block holding `p`.
    pub(super) fn block(&self, p: DVec3) -> [i64; 3] {
        ((p - self.origin) / self.side)
            .floor()
            .as_i64vec3()
            .to_array()
    }

    /// The bit of the block holding `p` in the dense bitset, none outside it.
    fn dense_index(&self, p: DVec3) -> Option<usize> {
        let b = self.block(p);
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
        // Dense and sparse storage agree with the definition at every block centre of the box.
        let (lo, hi) = (DVec3::ZERO, DVec3::new(150.0, 9.0, 7.0));
        let points = [
            DVec3::new(0.1, 0.1, 0.1),
            DVec3::new(63.7, 4.0, 3.0),
            DVec3::new(64.2, 8.9, 6.9),
            DVec3::new(149.9, 0.5, 3.5),
            DVec3::new(200.0, 1.0, 1.0),
        ];
        let reach = 2.0 * 3f64.sqrt(); // blocks of side 1
        let dense = Blocks::around(lo, hi, reach, points.par_iter().copied()).unwrap();
        assert!(matches!(dense.storage, Storage::Dense(_)));
        let mut sparse = Blocks::around(lo, hi, reach, points.par_iter().copied()).unwrap();
        sparse.storage = Storage::Sparse(
            points
                .iter()
                .flat_map(|&p| {
                    let [x, y, z] = sparse.block(p);
                    (-1..=1).flat_map(move |dz| {
                        (-1..=1)
                            .flat_map(move |dy| (-1..=1).map(move |dx| [x + dx, y + dy, z + dz]))
                    })
                })
                .filter(|&[x, y, z]| x < 151 && y < 10 && z < 8)
                .collect(),
        );
        let mut near = 0;
        for z in 0..8 {
            for y in 0..10 {
                for x in 0..151 {
                    let c = DVec3::new(x as f64 + 0.5, y as f64 + 0.5, z as f64 + 0.5);
                    let expected = points[..4].iter().any(|&p| {
                        let b = sparse.block(p);
                        (b[0] - x).abs() <= 1 && (b[1] - y).abs() <= 1 && (b[2] - z).abs() <= 1
                    });
                    assert_eq!(dense.near(c), expected, "dense at {c}");
                    assert_eq!(sparse.near(c), expected, "sparse at {c}");
                    near += usize::from(expected);
                }
            }
        }
        assert!(near > 27, "blocks near the points: {near}");
        // Within one block means within `reach`.
        assert!(!dense.near(DVec3::new(-0.5, 0.5, 0.5)));
    }
}
