//! Sample ranges of 8³ bricks: a superset of any box's range, for the culling of empty diamonds
//! (Gregorski §6.1) without per-diamond records, and the grid cells an isovalue crosses, whose
//! corners are the surface samples the isosurface error is measured at (Gregorski §6.2).

use crate::volume::{Sample, Volume};
use glam::IVec3;
use rayon::prelude::*;

/// Sample ranges of the bricks `[8b, 8b + 8]` per axis (neighbouring bricks share a layer).
pub(super) struct Bricks {
    dims: [usize; 3],
    min: Vec<f64>,
    max: Vec<f64>,
}

const BRICK: usize = 8;

impl Bricks {
    pub(super) fn new<T: Sample>(volume: &Volume<'_, T>) -> Self {
        let g = &volume.grid;
        let dims = g.dims.map(|d| (d - 1).div_ceil(BRICK).max(1));
        let (min, max) = (0..dims[0] * dims[1] * dims[2])
            .into_par_iter()
            .map(|b| {
                let c = [b % dims[0], b / dims[0] % dims[1], b / (dims[0] * dims[1])];
                let lo = c.map(|c| (BRICK * c) as i32);
                let hi = [0, 1, 2].map(|a| (BRICK * (c[a] + 1)).min(g.dims[a] - 1) as i32);
                volume.box_range(IVec3::from(lo), IVec3::from(hi))
            })
            .unzip();
        Self { dims, min, max }
    }

    /// The bricks of the negated samples ([`Volume::negated`]): each range negated.
    pub(super) fn negated(&self) -> Self {
        let negate = |v: &[f64]| v.par_iter().map(|x| -x).collect();
        Self {
            dims: self.dims,
            min: negate(&self.max),
            max: negate(&self.min),
        }
    }

    /// Bytes held: two values per brick.
    pub(super) fn bytes(&self) -> usize {
        (self.min.capacity() + self.max.capacity()) * std::mem::size_of::<f64>()
    }

    /// Number of bricks.
    pub(super) fn count(&self) -> usize {
        self.min.len()
    }
    /// Lower corners (point indices) of the grid cells that `v` crosses (min < v ≤ max over the
    /// corners, as [`super::marching::crosses`]), found in the bricks whose range allows it.
    pub(super) fn cells_crossed<T: Sample>(&self, volume: &Volume<'_, T>, v: f64) -> Vec<u32> {
        let g = &volume.grid;
        let [nx, ny, nz] = g.dims;
        let (sy, sz) = (nx, nx * ny);
        (0..self.min.len())
            .into_par_iter()
            .filter(|&b| self.min[b] < v && v <= self.max[b])
            .flat_map_iter(|b| {
                let (bx, by, bz) = (
                    b % self.dims[0],
                    b / self.dims[0] % self.dims[1],
                    b / (self.dims[0] * self.dims[1]),
                );
                let mut out = Vec::new();
                for z in BRICK * bz..(BRICK * (bz + 1)).min(nz - 1) {
                    for y in BRICK * by..(BRICK * (by + 1)).min(ny - 1) {
                        for x in BRICK * bx..(BRICK * (bx + 1)).min(nx - 1) {
                            let i = g.index(x, y, z);
                            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
                            for c in [i, i + 1, i + sy, i + sy + 1] {
                                for c in [c, c + sz] {
                                    let f = volume.samples[c].to_f64();
                                    lo = lo.min(f);
                                    hi = hi.max(f);
                                }
                            }
                            if lo < v && v <= hi {
                                out.push(i as u32);
                            }
                        }
                    }
                }
                out
            })
            .collect()
    }

    /// A superset of the sample range in the box `[lo, hi]` (lattice coordinates inside the grid).
    pub(super) fn range(&self, lo: IVec3, hi: IVec3) -> (f64, f64) {
        // The last brick of an axis also holds the samples at its far end.
        let last = glam::UVec3::from(self.dims.map(|d| d as u32 - 1));
        let b0 = (lo.as_uvec3() / BRICK as u32).min(last);
        let b1 = ((hi - IVec3::ONE).max(lo).as_uvec3() / BRICK as u32).min(last);
        let (mut a, mut b) = (f64::INFINITY, f64::NEG_INFINITY);
        for z in b0.z..=b1.z {
            for y in b0.y..=b1.y {
                for x in b0.x..=b1.x {
                    let i = x as usize + self.dims[0] * (y as usize + self.dims[1] * z as usize);
                    a = a.min(self.min[i]);
                    b = b.max(self.max[i]);
                }
            }
        }
        (a, b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::Grid;

    #[test]
    fn brick_ranges_hold_every_box() {
        let grid = Grid::new([19, 9, 26]);
        let samples: Vec<i16> = (0..grid.len())
            .map(|i| ((i * 7919) % 1000) as i16)
            .collect();
        let volume = Volume::new(grid, &samples[..]).unwrap();
        let bricks = Bricks::new(&volume);
        let hi = IVec3::new(18, 8, 25);
        for (k, lo) in [
            IVec3::ZERO,
            IVec3::new(3, 1, 8),
            IVec3::new(8, 8, 16),
            IVec3::new(17, 0, 24),
        ]
        .into_iter()
        .enumerate()
        {
            for size in [0, 1, 5, 8, 9, 30] {
                let top = (lo + IVec3::splat(size + k as i32)).min(hi);
                let (a, b) = bricks.range(lo, top);
                for z in lo.z..=top.z {
                    for y in lo.y..=top.y {
                        for x in lo.x..=top.x {
                            let v = volume.at(x as usize, y as usize, z as usize);
                            assert!(a <= v && v <= b, "{lo:?}..{top:?}: {v} outside [{a}, {b}]");
                        }
                    }
                }
            }
        }
    }
}
