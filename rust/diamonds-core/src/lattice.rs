//! The virtual lattice and the domain box.
//!
//! Diamonds live on a virtual `(2^L + 1)^3` lattice `[0, N]^3`, `N = 2^L`, the smallest one that holds the
//! input grid (Gregorski §7: "embedded in a virtual grid of the proper size"). The input samples occupy the
//! *domain box* `[0, nx-1] × [0, ny-1] × [0, nz-1]` at the lattice's origin corner.
//!
//! **Domain approach — refinement at the far faces.** Every tetrahedron of the hierarchy has lattice-point
//! vertices, so relative to the domain box it is either *inside* (all vertices in the box), *outside*
//! (its interior misses the box) or it *straddles* a far face. Diamonds with a straddling tetrahedron are
//! split unconditionally; their closure forms the *base mesh* (computed once per hierarchy). Outside
//! tetrahedra are dropped. The result covers exactly the box — no geometry outside it, no holes — and
//! every output vertex is an input sample. The price is a band of fine tetrahedra along a far face whose
//! coordinate has low-order one bits (e.g. 255 for 256 points); a grid of `2^k + 1` points per axis has
//! no such band. The band size is reported as [`crate::Hierarchy::base_tetrahedra`].

use crate::{Error, Result};
use glam::IVec3;

/// A tetrahedron of the hierarchy: four lattice points, the first two being its spine (split edge).
pub type Tet = [IVec3; 4];

/// Where a tetrahedron lies relative to the domain box.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Placement {
    /// All four vertices in the domain box.
    Inside,
    /// Its interior misses the domain box (separated along an axis).
    Outside,
    /// Crosses a far face of the domain box: must be refined.
    Straddling,
}

/// Largest supported root cube: coordinates stay far from `i32` overflow in every offset computation.
pub const MAX_LEVELS: u32 = 24;

/// The virtual lattice `[0, N]^3` and the domain box inside it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Lattice {
    /// Largest lattice coordinate of the domain box along each axis (`dims - 1`).
    pub hi: IVec3,
    /// `L`: the root cube has side `N = 2^L`.
    pub levels: u32,
}

impl Lattice {
    /// The smallest virtual lattice holding a grid of `dims` points.
    pub fn new(dims: [usize; 3]) -> Result<Self> {
        if dims.iter().any(|&d| d < 2) {
            return Err(Error::Dimensions { dims });
        }
        let largest = dims.iter().map(|&d| d - 1).max().unwrap_or(1);
        let levels = largest.next_power_of_two().trailing_zeros();
        if levels > MAX_LEVELS {
            return Err(Error::Parameter(format!(
                "{dims:?} points: axes longer than 2^{MAX_LEVELS} + 1 points are not supported"
            )));
        }
        Ok(Self {
            hi: IVec3::new(dims[0] as i32 - 1, dims[1] as i32 - 1, dims[2] as i32 - 1),
            levels: levels.max(1),
        })
    }

    /// Side `N` of the root cube.
    #[inline]
    pub fn size(&self) -> i32 {
        1 << self.levels
    }

    /// True when `p` lies in the root cube `[0, N]^3`.
    #[inline]
    pub fn in_root(&self, p: IVec3) -> bool {
        p.min_element() >= 0 && p.max_element() <= self.size()
    }

    /// True when `p` lies in the domain box.
    #[inline]
    pub fn in_domain(&self, p: IVec3) -> bool {
        p.min_element() >= 0 && p.cmple(self.hi).all()
    }

    /// Linear index (x fastest) of a domain point.
    #[inline]
    pub fn index(&self, p: IVec3) -> usize {
        let d = self.hi + IVec3::ONE;
        p.x as usize + d.x as usize * (p.y as usize + d.y as usize * p.z as usize)
    }

    /// The domain point of linear index `i` (the inverse of [`Lattice::index`]).
    #[inline]
    pub fn point(&self, i: usize) -> IVec3 {
        let d = (self.hi + IVec3::ONE).as_uvec3();
        let (nx, ny) = (d.x as usize, d.y as usize);
        IVec3::new(
            (i % nx) as i32,
            ((i / nx) % ny) as i32,
            (i / (nx * ny)) as i32,
        )
    }

    /// Where `t` lies relative to the domain box. Conservative: a tetrahedron reported as straddling may,
    /// in rare corner configurations, only touch the box; refining it is harmless.
    #[inline]
    pub fn place(&self, t: &Tet) -> Placement {
        let min = t[0].min(t[1]).min(t[2].min(t[3]));
        let max = t[0].max(t[1]).max(t[2].max(t[3]));
        self.place_box(min, max)
    }

    /// Where a tetrahedron with bounding box `[min, max]` lies relative to the domain box (as
    /// [`Lattice::place`]).
    #[inline]
    pub fn place_box(&self, min: IVec3, max: IVec3) -> Placement {
        if max.cmple(self.hi).all() {
            Placement::Inside
        } else if min.cmpge(self.hi).any() {
            Placement::Outside
        } else {
            Placement::Straddling
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn root_is_smallest_power_of_two() {
        assert_eq!(Lattice::new([257, 2, 3]).unwrap().size(), 256);
        assert_eq!(Lattice::new([256, 256, 256]).unwrap().size(), 256);
        assert_eq!(Lattice::new([258, 2, 3]).unwrap().size(), 512);
        assert_eq!(Lattice::new([2, 2, 2]).unwrap().size(), 2);
        assert!(Lattice::new([1, 5, 5]).is_err());
        let l = Lattice::new([5, 3, 4]).unwrap();
        for p in [IVec3::ZERO, IVec3::new(4, 2, 3), IVec3::new(1, 2, 0)] {
            assert_eq!(l.point(l.index(p)), p);
        }
    }

    #[test]
    fn placement() {
        let l = Lattice::new([5, 5, 4]).unwrap(); // hi = (4, 4, 3), N = 4
        let t = |a: [i32; 3], b: [i32; 3]| -> Tet {
            [
                IVec3::from(a),
                IVec3::from(b),
                IVec3::from(a),
                IVec3::from(a),
            ]
        };
        assert_eq!(l.place(&t([0, 0, 0], [4, 4, 3])), Placement::Inside);
        assert_eq!(l.place(&t([0, 0, 3], [4, 4, 4])), Placement::Outside);
        assert_eq!(l.place(&t([0, 0, 2], [4, 4, 4])), Placement::Straddling);
    }
}
