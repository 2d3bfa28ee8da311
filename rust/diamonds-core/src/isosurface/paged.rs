//! A `u16` code per grid point for the isosurface's per-diamond tables (by central vertex: the
//! gradient magnitudes of [`super::cache::IsoCache`], the error codes of
//! [`super::error::IsoErrors`]), stored by bricks allocated on first write.
//!
//! Queries write these codes only where refinement and the surface samples reach — the diamonds
//! near the surface — so whole-grid arrays (2 bytes per point each, 17 GB at 2048³) were mostly
//! never written. A diamond of spine length `L` near the surface has its central vertex within
//! about `L` of it, on the sublattice of stride `L / 2` or so, so bricks of grid points would be
//! touched in a shell as thick as the largest diamonds refinement visits. The points are therefore
//! split into classes by the largest power of two `2^s` dividing all three coordinates (the trailing
//! zeros of `x | y | z`), and class `s` is stored on the sublattice of stride `2^s` in 16³ bricks of
//! that sublattice: a class's shell is about one of its bricks thick, and the bricks written are
//! about those the surface crosses, over all classes 4/3 of the finest's (a class's bricks are 2×
//! wider than the one's before). Reading a brick never written gives the empty code without
//! allocating it.

use glam::{IVec3, UVec3};
use std::sync::atomic::{AtomicU16, AtomicUsize, Ordering};
use std::sync::OnceLock;

/// Bricks have `1 << SHIFT` sublattice points along each axis.
const SHIFT: u32 = 4;
const MASK: u32 = (1 << SHIFT) - 1;
const BRICK: usize = 1 << (3 * SHIFT);
/// Classes `0..=TOP`; the last holds every point whose coordinates `2^TOP` divides (few: one in
/// 2^33).
const TOP: u32 = 11;

/// The bricks of one class: how many along x and y, and where its first is in the table.
#[derive(Clone, Copy, Debug)]
struct Class {
    bricks: [usize; 2],
    first: usize,
}

/// A code per grid point, bricks allocated on first write ([`PagedCodes::slot`]).
pub(super) struct PagedCodes {
    classes: [Class; TOP as usize + 1],
    /// The code of a point never written.
    empty: u16,
    pages: Box<[OnceLock<Box<[AtomicU16]>>]>,
    allocated: AtomicUsize,
}

impl PagedCodes {
    /// Codes for a grid of `dims` points, all `empty`; nothing but the brick table is allocated.
    pub(super) fn new(dims: [usize; 3], empty: u16) -> Self {
        let mut first = 0;
        let classes = std::array::from_fn(|s| {
            // The sublattice of stride 2^s: points 0, 2^s, … up to the last grid point.
            let count = dims.map(|d| ((d - 1) >> s) / (1 << SHIFT) + 1);
            let class = Class {
                bricks: [count[0], count[1]],
                first,
            };
            first += count[0] * count[1] * count[2];
            class
        });
        Self {
            classes,
            empty,
            pages: (0..first).map(|_| OnceLock::new()).collect(),
            allocated: AtomicUsize::new(0),
        }
    }

    /// The brick holding grid point `p` and `p`'s place in it.
    #[inline]
    fn locate(&self, p: IVec3) -> (usize, usize) {
        debug_assert!(p.min_element() >= 0);
        let p = p.as_uvec3();
        let s = (p.x | p.y | p.z).trailing_zeros().min(TOP);
        let class = self.classes[s as usize];
        let q = p >> s;
        let b = q >> SHIFT;
        let o = q & UVec3::splat(MASK);
        let [bx, by] = class.bricks;
        (
            class.first + b.x as usize + bx * (b.y as usize + by * b.z as usize),
            (o.x + (o.y << SHIFT) + (o.z << (2 * SHIFT))) as usize,
        )
    }

    /// The code of grid point `p`.
    #[inline]
    pub(super) fn load(&self, p: IVec3) -> u16 {
        let (b, o) = self.locate(p);
        self.pages[b]
            .get()
            .map_or(self.empty, |page| page[o].load(Ordering::Relaxed))
    }

    /// The code of grid point `p` to write, its brick allocated if it was not.
    #[inline]
    pub(super) fn slot(&self, p: IVec3) -> &AtomicU16 {
        let (b, o) = self.locate(p);
        let page = self.pages[b].get_or_init(|| {
            self.allocated.fetch_add(1, Ordering::Relaxed);
            (0..BRICK).map(|_| AtomicU16::new(self.empty)).collect()
        });
        &page[o]
    }

    /// Bytes held: the brick table and the bricks written.
    pub(super) fn bytes(&self) -> usize {
        std::mem::size_of_val(&*self.pages)
            + self.allocated.load(Ordering::Relaxed) * BRICK * std::mem::size_of::<AtomicU16>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_read_as_written_and_only_written_bricks_are_allocated() {
        // 40 × 17 × 33 points: partial bricks along every axis.
        let dims = [40, 17, 33];
        let codes = PagedCodes::new(dims, 7);
        let table = codes.bytes();
        assert_eq!(codes.load(IVec3::new(39, 16, 32)), 7);
        assert_eq!(codes.bytes(), table, "a read allocates nothing");
        let points: Vec<IVec3> = (0..dims[2] as i32)
            .flat_map(|z| (0..dims[1] as i32).map(move |y| (y, z)))
            .flat_map(|(y, z)| (0..dims[0] as i32).map(move |x| IVec3::new(x, y, z)))
            .collect();
        // Every third point written with its own code, then all read back: no two points share a
        // place.
        for (k, &p) in points.iter().enumerate().filter(|(k, _)| k % 3 == 0) {
            codes.slot(p).store(k as u16 + 100, Ordering::Relaxed);
        }
        for (k, &p) in points.iter().enumerate() {
            let expected = if k % 3 == 0 { k as u16 + 100 } else { 7 };
            assert_eq!(codes.load(p), expected, "point {p}");
        }
        // One point written in a fresh grid allocates one brick.
        let one = PagedCodes::new(dims, 0);
        one.slot(IVec3::new(20, 5, 30))
            .fetch_max(3, Ordering::Relaxed);
        assert_eq!(one.bytes(), table + BRICK * 2);
        assert_eq!(one.load(IVec3::new(20, 5, 30)), 3);
        assert_eq!(one.load(IVec3::new(21, 5, 30)), 0);
    }

    #[test]
    fn a_plane_of_points_allocates_the_bricks_it_crosses_in_each_class() {
        // The plane x = 20 of a 64³ grid: 20 = 4 · 5, so its points are in classes 0 (4 × 4 bricks
        // of 16³ points, those with x in 16..32), 1 (the stride-2 sublattice's 2 × 2 bricks at
        // x / 2 = 10) and 2 (the stride-4 sublattice's one brick at x / 4 = 5).
        let codes = PagedCodes::new([64, 64, 64], 0);
        let table = codes.bytes();
        for z in 0..64 {
            for y in 0..64 {
                codes.slot(IVec3::new(20, y, z)).store(1, Ordering::Relaxed);
            }
        }
        assert_eq!(codes.bytes(), table + (16 + 4 + 1) * BRICK * 2);
        assert_eq!(codes.load(IVec3::new(20, 48, 8)), 1);
        assert_eq!(codes.load(IVec3::new(16, 48, 8)), 0);
    }
}
