//! The diamond hierarchy of a distributed image: each rank holds one *piece* (a box of the whole
//! grid's points) and together the ranks compute the serial mesh, partitioned.
//!
//! The core stays free of communication: the caller (the VTK filter, over ParaView's
//! `vtkMultiProcessController`) moves what this module asks for, in four steps.
//!
//! 1. **Samples** ([`PieceLayout::requests`]). The lattice is that of the *whole* grid. A diamond
//!    of scale `s` has its vertices on the stride-`s` sublattice and lies within `s` of its central
//!    vertex (Gregorski §3.1), so two kinds of samples suffice for the diamonds meeting a piece: a
//!    halo of `C` layers around it ([`PieceLayout::stride`], the *coarse stride*, 8 or more) for the
//!    *fine* diamonds (`s < C`), and the stride-`C` sublattice of the whole grid (1/512 of the
//!    samples or fewer) for the vertices of the *coarse* ones (`s ≥ C`). Both are a few boxes
//!    (halo slabs; strided slabs of the sublattice), asked as boxes of the pieces that hold them.
//! 2. **Errors** ([`PieceHierarchy::build`], [`PieceHierarchy::combine_coarse_errors`]). A fine
//!    diamond meeting the piece lies inside the halo: its exact error (Marchesin §4.1) is computed
//!    here, bit for bit as [`crate::Hierarchy::build`] computes it. A coarse diamond may span many
//!    pieces: each piece scans the part of it that it holds ([`crate::scan::scan_tet_part`]), and
//!    the maximum over the pieces (an all-reduce of one `f64` per point of the coarse sublattice) is
//!    its exact error.
//! 3. **Refinement with closure** ([`PieceRefinement`]). Without a budget the serial split set is the
//!    least set that holds the base mesh, is closed under parents and holds every child of a split
//!    diamond whose error exceeds the tolerance (see `Refiner::run_concurrent`). Each piece grows it
//!    from the diamonds it can judge (those meeting it), and sends every diamond it splits to the
//!    pieces its *reach* meets — its bounding box grown by its scale, which holds all its children —
//!    since those pieces judge its children; they insert what they receive and continue. Rounds end
//!    when no piece has anything to send. Every split is one the serial refinement makes, and
//!    every diamond that refinement splits is split by the piece that meets it once it knows its
//!    parent is split: the union is the serial split set, and every piece knows the part of it
//!    that meets the piece.
//! 4. **Output** ([`PieceRefinement::mesh`]). The leaves of the split set are cut between the pieces
//!    by their centroids: a piece owns the leaves whose centroid lies in its half-open cell box
//!    `[lo, hi)`, so each tetrahedron of the serial mesh is written by exactly one piece, with the
//!    whole grid's point indices as point ids (global ids).

use super::{base_mesh, diamond_record, is_root_corner, record};
use crate::diamond::Diamond;
use crate::lattice::{Lattice, Placement, Tet};
use crate::mesh::{Index, MeshPlan, PieceCells, TetMesh};
use crate::refine::{
    grow_concurrent, outside_roi, query_region, refine_concurrent, BaseMesh, Query, SplitSet,
};
use crate::scan::{scan_tet_part, Stencils, TetStats};
use crate::volume::{Grid, Sample, ScalarSlice, Volume};
use crate::{memory, Error, Result};
use glam::{DVec3, IVec3};
use rayon::prelude::*;
use rustc_hash::FxHashSet;

/// A closed box of lattice points, empty when `hi < lo` on some axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PointBox {
    pub lo: IVec3,
    pub hi: IVec3,
}

impl PointBox {
    /// The box of no points.
    pub const EMPTY: Self = Self {
        lo: IVec3::ZERO,
        hi: IVec3::NEG_ONE,
    };

    /// True when the box holds no point.
    pub fn is_empty(&self) -> bool {
        self.hi.cmplt(self.lo).any()
    }

    /// Points per axis.
    pub fn dims(&self) -> [usize; 3] {
        if self.is_empty() {
            return [0; 3];
        }
        let d = self.hi - self.lo + IVec3::ONE;
        [d.x as usize, d.y as usize, d.z as usize]
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.dims().iter().product()
    }

    /// True when `p` lies in the box.
    #[inline]
    pub fn contains(&self, p: IVec3) -> bool {
        p.cmpge(self.lo).all() && p.cmple(self.hi).all()
    }

    /// True when the closed box `[lo, hi]` shares a point with this one.
    #[inline]
    pub fn meets(&self, lo: IVec3, hi: IVec3) -> bool {
        !self.is_empty() && lo.cmple(self.hi).all() && hi.cmpge(self.lo).all()
    }

    /// Index (x fastest) of `p`, a point of the box.
    #[inline]
    pub(crate) fn index(&self, p: IVec3) -> usize {
        let [nx, ny, _] = self.dims();
        let o = (p - self.lo).as_uvec3();
        o.x as usize + nx * (o.y as usize + ny * o.z as usize)
    }
}

/// The points `lo + k·stride` (k ≥ 0 on each axis) up to `hi`: a box of the sublattice of stride
/// `stride` through `lo` (`hi − lo` a multiple of `stride` on every axis), empty when `hi < lo` on
/// some axis. What a piece asks another for ([`PieceLayout::requests`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StridedBox {
    pub lo: IVec3,
    pub hi: IVec3,
    pub stride: i32,
}

impl From<PointBox> for StridedBox {
    fn from(b: PointBox) -> Self {
        Self {
            lo: b.lo,
            hi: b.hi,
            stride: 1,
        }
    }
}

impl StridedBox {
    /// A box from untrusted values (a request received): a positive stride, `hi − lo` a
    /// non-negative multiple of it.
    pub fn checked(lo: IVec3, hi: IVec3, stride: i32) -> Result<Self> {
        let d = hi - lo;
        if stride < 1 || d.min_element() < 0 || d % stride != IVec3::ZERO {
            return Err(Error::Parameter(format!(
                "no box of points from {lo} to {hi} with stride {stride}"
            )));
        }
        Ok(Self { lo, hi, stride })
    }

    /// True when the box holds no point.
    pub fn is_empty(&self) -> bool {
        self.hi.cmplt(self.lo).any()
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        if self.is_empty() {
            return 0;
        }
        let d = ((self.hi - self.lo) / self.stride + IVec3::ONE).as_uvec3();
        d.x as usize * d.y as usize * d.z as usize
    }

    /// The points, x fastest.
    pub fn points(&self) -> impl Iterator<Item = IVec3> + '_ {
        let (lo, s) = (self.lo, self.stride as usize);
        let hi = if self.is_empty() {
            lo - IVec3::ONE
        } else {
            self.hi
        };
        (lo.z..=hi.z).step_by(s).flat_map(move |z| {
            (lo.y..=hi.y)
                .step_by(s)
                .flat_map(move |y| (lo.x..=hi.x).step_by(s).map(move |x| IVec3::new(x, y, z)))
        })
    }

    /// The points of this box inside `b`.
    fn within(&self, b: PointBox) -> Self {
        if b.is_empty() {
            return Self {
                hi: self.lo - IVec3::ONE,
                ..*self
            };
        }
        let s = self.stride;
        let first = (b.lo - self.lo).max(IVec3::ZERO) + IVec3::splat(s - 1);
        let last = b.hi.min(self.hi) - self.lo;
        Self {
            lo: self.lo + first / s * s,
            hi: self.lo
                + IVec3::new(
                    last.x.div_euclid(s),
                    last.y.div_euclid(s),
                    last.z.div_euclid(s),
                ) * s,
            stride: s,
        }
    }

    /// This box without `inner`, a box of its points ([`StridedBox::within`]): at most six
    /// non-empty boxes, slabs below and above it along z, then along y within its z range, then
    /// along x within its y and z ranges.
    fn minus(self, inner: Self) -> Vec<Self> {
        let (o, i, s) = (self, inner, self.stride);
        let part = |lo: IVec3, hi: IVec3| Self { lo, hi, stride: s };
        if i.is_empty() {
            return vec![o];
        }
        [
            part(o.lo, IVec3::new(o.hi.x, o.hi.y, i.lo.z - s)),
            part(IVec3::new(o.lo.x, o.lo.y, i.hi.z + s), o.hi),
            part(
                IVec3::new(o.lo.x, o.lo.y, i.lo.z),
                IVec3::new(o.hi.x, i.lo.y - s, i.hi.z),
            ),
            part(
                IVec3::new(o.lo.x, i.hi.y + s, i.lo.z),
                IVec3::new(o.hi.x, o.hi.y, i.hi.z),
            ),
            part(
                IVec3::new(o.lo.x, i.lo.y, i.lo.z),
                IVec3::new(i.lo.x - s, i.hi.y, i.hi.z),
            ),
            part(
                IVec3::new(i.hi.x + s, i.lo.y, i.lo.z),
                IVec3::new(o.hi.x, i.hi.y, i.hi.z),
            ),
        ]
        .into_iter()
        .filter(|b| !b.is_empty())
        .collect()
    }
}

/// One box of samples a piece asks for ([`PieceLayout::requests`]), and the piece it asks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Request {
    /// The index of the piece that holds the points.
    pub rank: usize,
    pub points: StridedBox,
}

/// Where one piece lies in the whole grid, and which samples of other pieces it needs.
#[derive(Clone, Debug, PartialEq)]
pub struct PieceLayout {
    /// The whole grid.
    grid: Grid,
    lattice: Lattice,
    /// The points this piece holds.
    owned: PointBox,
    /// The owned box with a halo of [`PieceLayout::stride`] layers (clipped to the grid), its low
    /// corner rounded down to a multiple of twice the stride.
    padded: PointBox,
    stride: i32,
}

impl PieceLayout {
    /// The piece of the points `owned` (inclusive point indices of the whole grid `grid`; empty
    /// when some `hi < lo`).
    pub fn new(grid: Grid, owned: PointBox) -> Result<Self> {
        grid.validate()?;
        let lattice = Lattice::new(grid.dims)?;
        let owned = if owned.is_empty() {
            PointBox::EMPTY
        } else {
            owned
        };
        if !owned.is_empty() && (owned.lo.min_element() < 0 || owned.hi.cmpgt(lattice.hi).any()) {
            return Err(Error::Parameter(format!(
                "piece {:?}..{:?} lies outside the whole grid of {:?} points",
                owned.lo, owned.hi, grid.dims
            )));
        }
        let stride = coarse_stride(&lattice);
        let padded = if owned.is_empty() {
            PointBox::EMPTY
        } else {
            let align = 2 * stride;
            PointBox {
                lo: ((owned.lo - IVec3::splat(stride)).max(IVec3::ZERO) / align) * align,
                hi: (owned.hi + IVec3::splat(stride)).min(lattice.hi),
            }
        };
        Ok(Self {
            grid,
            lattice,
            owned,
            padded,
            stride,
        })
    }

    /// The whole grid.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The points this piece holds.
    pub fn owned(&self) -> PointBox {
        self.owned
    }

    /// The coarse stride `C`: diamonds of scale `C` or more are *coarse* (errors combined across
    /// pieces), the others *fine* (errors from a halo of `C` layers). The smallest power of two ≥ 8
    /// that keeps the coarse sublattice within 129 points per axis; it depends on the whole grid
    /// only, so that every piece agrees on it.
    pub fn stride(&self) -> i32 {
        self.stride
    }

    /// Points per axis of the coarse sublattice (the whole grid's points at multiples of the stride).
    fn coarse_dims(&self) -> IVec3 {
        self.lattice.hi / self.stride + IVec3::ONE
    }

    fn coarse_len(&self) -> usize {
        let d = self.coarse_dims().as_uvec3();
        d.x as usize * d.y as usize * d.z as usize
    }

    /// The coarse sublattice's points, in index order (x fastest).
    fn coarse_points(&self) -> impl Iterator<Item = IVec3> + '_ {
        let d = self.coarse_dims();
        let c = self.stride;
        (0..d.z).flat_map(move |z| {
            (0..d.y).flat_map(move |y| (0..d.x).map(move |x| IVec3::new(x, y, z) * c))
        })
    }

    /// Index of the coarse diamond centred on `p` (a multiple of the stride) in the coarse sublattice.
    #[inline]
    fn coarse_index(&self, p: IVec3) -> usize {
        let d = self.coarse_dims().as_uvec3();
        let q = (p / self.stride).as_uvec3();
        q.x as usize + d.x as usize * (q.y as usize + d.y as usize * q.z as usize)
    }

    /// The samples this piece needs from the others, as boxes: the padded box outside the owned
    /// box (its halo, up to six slabs) and the coarse sublattice outside the padded box (up to six
    /// strided slabs). None for an empty piece.
    fn needed_boxes(&self) -> Vec<StridedBox> {
        if self.owned.is_empty() {
            return Vec::new();
        }
        let padded = StridedBox::from(self.padded);
        let coarse = StridedBox {
            lo: IVec3::ZERO,
            hi: (self.lattice.hi / self.stride) * self.stride,
            stride: self.stride,
        };
        padded
            .minus(StridedBox::from(self.owned))
            .into_iter()
            .chain(coarse.minus(coarse.within(self.padded)))
            .collect()
    }

    /// What this piece asks of the pieces `pieces` (every piece's points, this one's among them)
    /// for the samples it needs ([`PieceLayout`]'s halo and coarse sublattice): every needed point
    /// exactly once, from the first piece holding it (image pieces share their boundary layers of
    /// points), as boxes, by piece in ascending order. The holders' answers, each box's samples x
    /// fastest, concatenated in this order, are the `fetched` samples of
    /// [`PieceHierarchy::build`]: a few integers per box cross instead of a point index per
    /// sample. An error when some needed point lies in no piece.
    pub fn requests(&self, pieces: &[PointBox]) -> Result<Vec<Request>> {
        let mut out = Vec::new();
        let mut left = self.needed_boxes();
        for (rank, &piece) in pieces.iter().enumerate() {
            let mut rest = Vec::new();
            for b in left {
                let held = b.within(piece);
                if held.is_empty() {
                    rest.push(b);
                } else {
                    out.push(Request { rank, points: held });
                    rest.extend(b.minus(held));
                }
            }
            left = rest;
        }
        match left.first() {
            Some(b) => Err(Error::Parameter(format!(
                "point {} of the whole grid, needed by the piece {:?}..{:?}, lies in no piece",
                b.lo, self.owned.lo, self.owned.hi
            ))),
            None => Ok(out),
        }
    }

    /// The indices (x fastest) among this piece's points of the points of `boxes`, box after box,
    /// each box's points x fastest: where the samples a piece asked for by
    /// [`PieceLayout::requests`] are. An error when a box has points this piece does not hold.
    pub fn box_indices(&self, boxes: &[StridedBox]) -> Result<Vec<i64>> {
        let total = boxes.iter().map(StridedBox::len).sum();
        let mut out = memory::with_capacity(total, "the indices of the points asked for")?;
        for b in boxes {
            let held = b.is_empty() || (self.owned.contains(b.lo) && self.owned.contains(b.hi));
            if !held {
                return Err(Error::Parameter(format!(
                    "points {:?}..{:?} asked for, but this piece holds {:?}..{:?}",
                    b.lo, b.hi, self.owned.lo, self.owned.hi
                )));
            }
            out.extend(b.points().map(|p| self.owned.index(p) as i64));
        }
        Ok(out)
    }

    /// For each whole-grid index of `ids`, the index (x fastest) of that point among the points this
    /// piece holds, or −1 when it holds no such point: where a pass-through array finds the point.
    pub fn local_ids(&self, ids: &[u64]) -> Vec<i64> {
        ids.par_iter()
            .map(|&i| {
                let p = (i < self.grid.len() as u64).then(|| self.lattice.point(i as usize));
                match p {
                    Some(p) if self.owned.contains(p) => self.owned.index(p) as i64,
                    _ => -1,
                }
            })
            .collect()
    }

    /// The reach of `d`: its bounding box grown by its scale, which holds the tetrahedra of all its
    /// children (the pieces that judge them must know that `d` is split).
    #[inline]
    fn reach(d: Diamond) -> (IVec3, IVec3) {
        let (lo, hi) = d.bounds();
        let s = IVec3::splat(d.scale());
        (lo - s, hi + s)
    }

    /// True when `d` has a point in this piece (then this piece knows its error).
    #[inline]
    fn meets(&self, d: Diamond) -> bool {
        let (lo, hi) = d.bounds();
        self.owned.meets(lo, hi)
    }
}

/// The smallest power of two ≥ 8 with at most 128 strides along the longest axis.
fn coarse_stride(lattice: &Lattice) -> i32 {
    let mut c = 8;
    while lattice.hi.max_element() / c > 128 {
        c *= 2;
    }
    c
}

/// Which piece owns each point: the first of `pieces` (closed point boxes) that holds it, or
/// `pieces.len()` when none does. `ids` are whole-grid indices of the points of `lattice`.
pub fn point_owners(lattice: &Lattice, pieces: &[PointBox], ids: &[u64]) -> Vec<u32> {
    ids.par_iter()
        .map(|&i| {
            let p = lattice.point(i as usize);
            pieces
                .iter()
                .position(|b| b.contains(p))
                .unwrap_or(pieces.len()) as u32
        })
        .collect()
}

/// The input points a piece's output takes its point data from — the sources its points
/// interpolate, the lattice points of its tetrahedra — as a table of tuples to fill: the points of
/// the piece's own box first, read from its own arrays, then those other pieces hold, fetched from
/// them. A piece that puts the whole image together for the computation needs, this way, only the
/// processed array whole, not every other point array.
#[derive(Debug, Default)]
pub struct PointSources {
    /// The table's own points: their indices (x fastest) in the piece's box, ascending.
    pub local: Vec<u64>,
    /// The table's other points: their whole-grid indices, ascending.
    pub remote: Vec<u64>,
    /// For each whole-grid index given, its row in the table (`local`, then `remote`).
    pub rows: Vec<u32>,
}

impl PointSources {
    /// The table for the whole-grid indices `ids` of points of `grid` (each as often as the
    /// output uses it), the piece holding the points of `own`.
    pub fn new(grid: &Grid, own: PointBox, ids: &[u64]) -> Result<Self> {
        let n = grid.len() as u64;
        if let Some(bad) = ids.iter().find(|&&i| i >= n) {
            return Err(Error::Parameter(format!(
                "point {bad} lies outside the grid of {n} points"
            )));
        }
        let mut points = memory::copied(ids, "the output's source points")?;
        points.par_sort_unstable();
        points.dedup();
        if points.len() > u32::MAX as usize {
            return Err(Error::Parameter(format!(
                "{} source points: more than a table of 32-bit rows holds",
                points.len()
            )));
        }
        let point = |i: u64| IVec3::from_array(grid.ijk(i as usize).map(|c| c as i32));
        let held = |i: u64| own.contains(point(i));
        let mut local = memory::with_capacity(points.len(), "the piece's own source points")?;
        let mut remote = Vec::new();
        for &i in &points {
            if held(i) {
                local.push(own.index(point(i)) as u64);
            } else {
                remote.push(i);
            }
        }
        // The row of the k-th point: own points keep their order, the others follow them.
        let mut row = memory::filled(points.len(), 0u32, "the source points' rows")?;
        let (mut own_before, mut other_before) = (0u32, local.len() as u32);
        for (slot, &i) in row.iter_mut().zip(&points) {
            let counter = if held(i) {
                &mut own_before
            } else {
                &mut other_before
            };
            *slot = *counter;
            *counter += 1;
        }
        let mut rows = memory::filled(ids.len(), 0u32, "the output's source rows")?;
        rows.par_iter_mut().zip(ids).for_each(|(slot, i)| {
            // Every id is among the points.
            *slot = row[points.binary_search(i).unwrap_or_default()];
        });
        Ok(Self {
            local,
            remote,
            rows,
        })
    }
}

/// The first point (x fastest) of a grid of `dims` points that none of `pieces` holds, if any: a
/// grid put together from the pieces' points needs them to cover it. Called with the grid of cells
/// (`dims` − 1) and the pieces' cell boxes (`hi` − 1), it checks the cells.
pub fn first_uncovered(dims: [usize; 3], pieces: &[PointBox]) -> Option<IVec3> {
    let n: usize = dims.iter().product();
    let point = |i: usize| {
        IVec3::new(
            (i % dims[0]) as i32,
            (i / dims[0] % dims[1]) as i32,
            (i / (dims[0] * dims[1])) as i32,
        )
    };
    (0..n)
        .into_par_iter()
        .map(point)
        .find_first(|&p| !pieces.iter().any(|b| b.contains(p)))
}

/// The part of the diamond hierarchy one piece needs: errors of the diamonds that meet it.
#[derive(Debug)]
pub struct PieceHierarchy {
    layout: PieceLayout,
    /// Error codes ([`record::encode_error`]) of the fine diamonds meeting the piece, over the
    /// padded box.
    fine: Vec<u16>,
    /// Errors of the coarse diamonds over the coarse sublattice: this piece's part until
    /// [`PieceHierarchy::combine_coarse_errors`], then the whole errors.
    coarse: Vec<f64>,
    /// Error codes of the coarse diamonds, once combined.
    coarse_codes: Vec<u16>,
    base: BaseMesh,
}

/// Calls `$body` with `$a`, `$b` bound to the slices of two [`ScalarSlice`]s of the same type.
macro_rules! with_same_type {
    ($x:expr, $y:expr, |$a:ident, $b:ident| $body:expr) => {
        match ($x, $y) {
            (ScalarSlice::U8($a), ScalarSlice::U8($b)) => $body,
            (ScalarSlice::I8($a), ScalarSlice::I8($b)) => $body,
            (ScalarSlice::U16($a), ScalarSlice::U16($b)) => $body,
            (ScalarSlice::I16($a), ScalarSlice::I16($b)) => $body,
            (ScalarSlice::U32($a), ScalarSlice::U32($b)) => $body,
            (ScalarSlice::I32($a), ScalarSlice::I32($b)) => $body,
            (ScalarSlice::F32($a), ScalarSlice::F32($b)) => $body,
            (ScalarSlice::F64($a), ScalarSlice::F64($b)) => $body,
            (a, b) => Err(Error::Parameter(format!(
                "the piece's samples are {:?} but the samples received are {:?}",
                a.scalar_type(),
                b.scalar_type()
            ))),
        }
    };
}

impl PieceHierarchy {
    /// Computes the errors of the diamonds that meet the piece of `layout` from its own samples
    /// `local` (its owned box, x fastest) and `fetched` (same type), the samples it asks of the
    /// pieces `pieces` (every piece's points) by [`PieceLayout::requests`], in that order. Coarse
    /// errors are this piece's part until [`PieceHierarchy::combine_coarse_errors`].
    pub fn build(
        layout: PieceLayout,
        pieces: &[PointBox],
        local: ScalarSlice<'_>,
        fetched: ScalarSlice<'_>,
        progress: super::Progress<'_>,
    ) -> Result<Self> {
        let requests = layout.requests(pieces)?;
        with_same_type!(local, fetched, |a, b| Self::build_typed(
            layout, &requests, a, b, progress
        ))
    }

    fn build_typed<T: Sample>(
        layout: PieceLayout,
        requests: &[Request],
        local: &[T],
        fetched: &[T],
        progress: super::Progress<'_>,
    ) -> Result<Self> {
        let asked: usize = requests.iter().map(|r| r.points.len()).sum();
        if local.len() != layout.owned.len() || fetched.len() != asked {
            return Err(Error::Parameter(format!(
                "a piece of {} points with {} samples from other pieces needs {} and {} values \
                 (got {} and {})",
                layout.owned.len(),
                asked,
                layout.owned.len(),
                asked,
                local.len(),
                fetched.len()
            )));
        }
        let base = base_mesh(layout.lattice);
        let mut coarse = vec![0.0; layout.coarse_len()];
        if layout.owned.is_empty() {
            return Ok(Self {
                layout,
                fine: Vec::new(),
                coarse,
                coarse_codes: Vec::new(),
                base,
            });
        }
        let (owned, padded) = (layout.owned, layout.padded);
        // The padded box's samples: own ones row by row, then the halo received; the coarse
        // sublattice's samples outside it in their own array (by coarse index). The requests
        // cover each of these points once.
        let mut samples = memory::filled(padded.len(), local[0], "the piece's samples")?;
        let mut coarse_samples = memory::filled(
            layout.coarse_len(),
            local[0],
            "the coarse sublattice's samples",
        )?;
        let row = owned.dims()[0];
        for (r, own) in local.chunks_exact(row).enumerate() {
            let [_, ny, _] = owned.dims();
            let start = owned.lo + IVec3::new(0, (r % ny) as i32, (r / ny) as i32);
            let at = padded.index(start);
            samples[at..at + row].copy_from_slice(own);
        }
        for (p, &v) in requests.iter().flat_map(|r| r.points.points()).zip(fetched) {
            if padded.contains(p) {
                samples[padded.index(p)] = v;
            } else {
                coarse_samples[layout.coarse_index(p)] = v;
            }
        }
        let grid = Grid {
            dims: padded.dims(),
            origin: [0.0; 3],
            spacing: [1.0; 3],
        };
        let volume = Volume::new(grid, &samples)?;
        if !progress(0.1) {
            return Err(Error::Aborted);
        }
        // Fine diamonds meeting the piece: exact errors from the padded box.
        let lattice = layout.lattice;
        let stencils = Stencils::new(&grid);
        let mut fine = memory::filled(padded.len(), 0u16, "the piece's diamond errors")?;
        let [nx, ny, _] = padded.dims();
        fine.par_chunks_mut(nx).enumerate().for_each(|(r, row)| {
            let (y, z) = ((r % ny) as i32, (r / ny) as i32);
            for (x, code) in row.iter_mut().enumerate() {
                let p = padded.lo + IVec3::new(x as i32, y, z);
                if p == IVec3::ZERO {
                    continue; // no diamond
                }
                let d = Diamond::new(p);
                if d.scale() < layout.stride && layout.meets(d) {
                    let rec = diamond_record(&volume, &lattice, &stencils, (d, padded.lo));
                    *code = rec.error;
                }
            }
        });
        if !progress(0.7) {
            return Err(Error::Aborted);
        }
        // Coarse diamonds meeting the piece: this piece's part of their errors.
        let vertex = |p: IVec3| -> f64 {
            if padded.contains(p) {
                samples[padded.index(p)].to_f64()
            } else {
                debug_assert_eq!(p % layout.stride, IVec3::ZERO, "a coarse vertex");
                coarse_samples[layout.coarse_index(p)].to_f64()
            }
        };
        let parts: Vec<(usize, f64)> = layout
            .coarse_points()
            .collect::<Vec<_>>()
            .into_par_iter()
            .filter(|&p| !is_root_corner(&lattice, p))
            .filter(|&p| layout.meets(Diamond::new(p)))
            .map(|p| -> (usize, f64) {
                let d = Diamond::new(p);
                let mut stats = TetStats::EMPTY;
                for t in d.tets(&lattice) {
                    match lattice.place(&t) {
                        Placement::Inside => {
                            let values = [vertex(t[0]), vertex(t[1]), vertex(t[2]), vertex(t[3])];
                            let part =
                                scan_tet_part(&volume, padded.lo, &t, values, (owned.lo, owned.hi));
                            stats = stats.merge(part);
                        }
                        Placement::Outside => {}
                        // Split in the base mesh, as in the serial hierarchy.
                        Placement::Straddling => return (layout.coarse_index(p), 0.0),
                    }
                }
                (
                    layout.coarse_index(p),
                    if stats.min > stats.max {
                        0.0
                    } else {
                        stats.error
                    },
                )
            })
            .collect();
        for (i, e) in parts {
            coarse[i] = e;
        }
        progress(1.0);
        Ok(Self {
            layout,
            fine,
            coarse,
            coarse_codes: Vec::new(),
            base,
        })
    }

    /// The piece's layout.
    pub fn layout(&self) -> &PieceLayout {
        &self.layout
    }

    /// This piece's part of the coarse diamonds' errors (one per point of the coarse sublattice;
    /// 0 where the piece holds none of a diamond's samples): the maximum over all pieces, element by
    /// element, is what [`PieceHierarchy::combine_coarse_errors`] takes.
    pub fn coarse_errors(&self) -> &[f64] {
        &self.coarse
    }

    /// Takes the coarse diamonds' errors, combined over all pieces (element-wise maximum of every
    /// piece's [`PieceHierarchy::coarse_errors`]).
    pub fn combine_coarse_errors(&mut self, combined: &[f64]) -> Result<()> {
        if combined.len() != self.coarse.len() {
            return Err(Error::Parameter(format!(
                "{} combined coarse errors for a coarse sublattice of {} points",
                combined.len(),
                self.coarse.len()
            )));
        }
        if let Some(bad) = combined
            .iter()
            .zip(&self.coarse)
            .find(|(c, own)| !c.is_finite() || *c < *own)
        {
            return Err(Error::Parameter(format!(
                "combined coarse error {} is not a finite maximum of this piece's {}",
                bad.0, bad.1
            )));
        }
        self.coarse.copy_from_slice(combined);
        self.coarse_codes = combined.iter().map(|&e| record::encode_error(e)).collect();
        Ok(())
    }

    /// Error of `d`, a diamond meeting the piece (as [`crate::Hierarchy::error`]).
    #[inline]
    fn error(&self, d: Diamond) -> f64 {
        let l = &self.layout;
        if !l.lattice.in_domain(d.center) {
            0.0
        } else if d.scale() >= l.stride {
            record::decode_error(self.coarse_codes[l.coarse_index(d.center)])
        } else if l.padded.contains(d.center) {
            record::decode_error(self.fine[l.padded.index(d.center)])
        } else {
            0.0
        }
    }

    /// Starts refining for `query` (tolerance and region of interest; no budget): splits, with
    /// closure, what the piece's own diamonds require ([`refine_concurrent`]: the bisection depths
    /// swept where their diamonds meet the piece, then the closure in rounds).
    pub fn start(&self, query: &Query) -> Result<PieceRefinement> {
        if query.max_tetrahedra > 0 {
            return Err(Error::Parameter(
                "a tetrahedron budget is not supported on a distributed image (it orders splits \
                 across all pieces); use a tolerance"
                    .into(),
            ));
        }
        if !self.layout.owned.is_empty() && self.coarse_codes.len() != self.coarse.len() {
            return Err(Error::Parameter(
                "the coarse errors were not combined across the pieces".into(),
            ));
        }
        let roi = query_region(&self.layout.grid, query)?;
        let mut r = PieceRefinement {
            split: self.base.split.clone(),
            tolerance: query.tolerance,
            roi,
            outbox: Vec::new(),
        };
        let owned = self.layout.owned;
        if !owned.is_empty() {
            let judge = |d: Diamond| self.judged_error(roi, d);
            let region = Some((owned.lo, owned.hi));
            let candidates = &self.base.candidates;
            let added =
                refine_concurrent(&mut r.split, candidates, r.tolerance, &judge, region, true)?;
            r.outbox.extend(added);
        }
        Ok(r)
    }

    /// The error of `d` as this piece judges it: its error when it meets the piece and lies in the
    /// region of interest, else 0 (other pieces judge it).
    fn judged_error(&self, roi: Option<(DVec3, DVec3)>, d: Diamond) -> f64 {
        let outside = roi.is_some_and(|roi| outside_roi(roi, &self.layout.lattice, d));
        if outside || !self.layout.meets(d) {
            0.0
        } else {
            self.error(d)
        }
    }

    /// Splits the diamonds of `first` with closure, and every child they expose that this piece
    /// judges above the tolerance ([`crate::refine::grow_concurrent`], in parallel); what it split
    /// goes to the outbox, except the diamonds of `received` (split by other pieces, known there).
    fn grow(
        &self,
        r: &mut PieceRefinement,
        first: Vec<Diamond>,
        received: &[Diamond],
    ) -> Result<()> {
        let (tolerance, roi) = (r.tolerance, r.roi);
        let judge = |d: Diamond| self.judged_error(roi, d);
        let mut added = grow_concurrent(&mut r.split, first, tolerance, &judge, true)?;
        if !received.is_empty() {
            let received: FxHashSet<Diamond> = received.iter().copied().collect();
            added.retain(|d| !received.contains(d));
        }
        r.outbox.extend(added);
        Ok(())
    }

    /// The diamonds split here since the last call, addressed to the pieces that must know them:
    /// one list per piece of `pieces` (every piece's owned box, this one's included), holding the
    /// central vertices (three coordinates each) of the diamonds whose reach meets that piece. A
    /// piece with this one's box (a copy of it) gets none: it splits the same diamonds itself. So a
    /// diamond travels only to the pieces it changes, not to every piece.
    pub fn outgoing(&self, r: &mut PieceRefinement, pieces: &[PointBox]) -> Vec<Vec<i32>> {
        let own = self.layout.owned;
        let mut out = vec![Vec::new(); pieces.len()];
        for d in r.outbox.drain(..) {
            let (lo, hi) = PieceLayout::reach(d);
            for (b, list) in pieces.iter().zip(&mut out) {
                if *b != own && b.meets(lo, hi) {
                    list.extend(d.center.to_array());
                }
            }
        }
        out
    }

    /// Inserts the diamonds other pieces split (central vertices, three coordinates each: the
    /// lists the other pieces' [`PieceHierarchy::outgoing`] addressed to this piece, concatenated)
    /// whose reach meets this piece, and refines on from them. Returns how many were new here.
    pub fn receive(&self, r: &mut PieceRefinement, centers: &[i32]) -> Result<usize> {
        if !centers.len().is_multiple_of(3) {
            return Err(Error::Parameter(format!(
                "{} coordinates received: not three per diamond",
                centers.len()
            )));
        }
        let lattice = &self.layout.lattice;
        let mut work = Vec::new();
        for c in centers.chunks_exact(3) {
            let p = IVec3::new(c[0], c[1], c[2]);
            if !lattice.in_root(p) || p == IVec3::ZERO {
                return Err(Error::Parameter(format!(
                    "received diamond {p:?} lies outside the lattice"
                )));
            }
            let d = Diamond::new(p);
            let (lo, hi) = PieceLayout::reach(d);
            if self.layout.owned.meets(lo, hi) && !r.split.contains(d) {
                work.push(d);
            }
        }
        let new = work.len();
        self.grow(r, work.clone(), &work)?;
        Ok(new)
    }

    /// The tetrahedra of the refined mesh this piece owns, counted but not written yet (a
    /// [`MeshPlan`] that [`Self::write_tets`], [`MeshPlan::write_points`],
    /// [`MeshPlan::write_point_ids`] and [`MeshPlan::gather_piece`] write into the caller's arrays),
    /// points numbered by whole-grid index, ascending: `pieces` are all pieces' owned boxes, this
    /// one's at `me`; a tetrahedron belongs to the first piece whose half-open cell box `[lo, hi)`
    /// holds its centroid (pieces that overlap, e.g. all holding the whole image, output it once).
    /// The plan takes the refinement's split set (no copy of a whole-grid bitset).
    pub fn plan(&self, r: PieceRefinement, pieces: &[PointBox], me: usize) -> Result<MeshPlan> {
        let owned = self.layout.owned;
        if pieces
            .get(me)
            .is_none_or(|b| *b != owned && !(b.is_empty() && owned.is_empty()))
        {
            return Err(Error::Parameter(format!(
                "piece {me} of {} is not this piece {owned:?}",
                pieces.len()
            )));
        }
        let piece = PieceCells {
            owned,
            owner: CellOwner::new(pieces, me)?,
        };
        MeshPlan::of_piece(&self.layout.lattice, r.split, piece)
    }

    /// Writes the tetrahedra of `plan` (made by [`Self::plan`]) with this piece's errors
    /// ([`MeshPlan::write_tets`]); returns the largest error.
    pub fn write_tets<I: Index>(
        &self,
        plan: &MeshPlan,
        connectivity: &mut [I],
        offsets: &mut [I],
        depths: &mut [u8],
        errors: &mut [f32],
    ) -> Result<f64> {
        plan.write_tets(|d| self.error(d), connectivity, offsets, depths, errors)
    }

    /// The tetrahedra of [`Self::plan`] as a [`TetMesh`], with depths and errors as
    /// [`crate::Hierarchy::query`] gives them (the refinement is copied for the plan).
    pub fn mesh(&self, r: &PieceRefinement, pieces: &[PointBox], me: usize) -> Result<TetMesh> {
        self.plan(r.clone(), pieces, me)?
            .to_mesh(&self.layout.grid, |d| self.error(d))
    }
}

/// Which piece owns a cell of the refined mesh (a tetrahedron, or an isosurface's triangles through
/// the tetrahedron that carries them): the first piece whose half-open cell box `[lo, hi)` holds the
/// tetrahedron's centroid. Pieces that cut the grid along shared boundary planes own each cell of the
/// serial mesh exactly once; pieces that overlap (e.g. all holding the whole image) too.
#[derive(Clone, Debug)]
pub struct CellOwner {
    /// This piece's cell box, in four times the lattice coordinates (centroids stay integral).
    own: (IVec3, IVec3),
    /// The cell boxes of the non-empty pieces before it.
    earlier: Vec<(IVec3, IVec3)>,
    /// This piece's place among the pieces.
    me: usize,
}

impl CellOwner {
    /// Ownership for piece `me` of `pieces` (every piece's owned points, in rank order).
    pub fn new(pieces: &[PointBox], me: usize) -> Result<Self> {
        let cells4 = |b: &PointBox| (b.lo * 4, b.hi * 4);
        let own = pieces
            .get(me)
            .ok_or_else(|| Error::Parameter(format!("piece {me} of {} pieces", pieces.len())))?;
        Ok(Self {
            own: if own.is_empty() {
                (IVec3::ZERO, IVec3::ZERO) // holds nothing
            } else {
                cells4(own)
            },
            earlier: pieces[..me]
                .iter()
                .filter(|b| !b.is_empty())
                .map(cells4)
                .collect(),
            me,
        })
    }

    /// This piece's place among the pieces (its rank).
    pub fn me(&self) -> usize {
        self.me
    }

    /// Does this piece own the tetrahedron `t` (lattice coordinates)?
    #[inline]
    pub fn owns(&self, t: &Tet) -> bool {
        self.owns_centroid4(t[0] + t[1] + t[2] + t[3])
    }

    /// Does this piece own the grid cell at `corner` (its lower corner, lattice coordinates of a
    /// grid whose lattice is its own)? The rule for tetrahedra, at the cell's centre.
    #[inline]
    pub fn owns_cell(&self, corner: [usize; 3]) -> bool {
        self.owns_centroid4(IVec3::from(corner.map(|c| c as i32)) * 4 + IVec3::splat(2))
    }

    /// Does this piece own a cell whose centroid is `c4` / 4 (lattice coordinates)?
    #[inline]
    fn owns_centroid4(&self, c4: IVec3) -> bool {
        let holds = |(lo4, hi4): (IVec3, IVec3)| c4.cmpge(lo4).all() && c4.cmplt(hi4).all();
        holds(self.own) && !self.earlier.iter().any(|&b| holds(b))
    }
}

/// Which piece owns a cell of a mesh whose vertices need not be grid points (Material Interface
/// Approximation's tetrahedra on a finer lattice, its interface polygons and plane cuts): the first
/// piece whose half-open cell box `[lo, hi)` holds the cell's centroid (the mean of its vertices) in
/// grid units, as [`CellOwner`] decides for the hierarchy's tetrahedra, with two additions that make
/// every cell owned exactly once whatever the cell and the layout: the whole grid's far faces belong
/// to the boxes that reach them (a cut or an interface may lie on them), and a centroid no piece
/// holds (pieces that leave a gap) goes to the first non-empty piece. Every rank decides with the
/// same floating-point operations on the same cells, so the pieces' shares partition the mesh.
#[derive(Clone, Debug)]
pub struct PositionOwner {
    origin: DVec3,
    spacing: DVec3,
    /// The whole grid's far corner, in grid units.
    far: DVec3,
    /// Every non-empty piece's box in grid units, with its rank, in rank order.
    boxes: Vec<(usize, DVec3, DVec3)>,
    me: usize,
}

impl PositionOwner {
    /// Ownership for piece `me` of `pieces` (every piece's points, relative to `grid`'s first point).
    pub fn new(grid: &Grid, pieces: &[PointBox], me: usize) -> Result<Self> {
        if me >= pieces.len() {
            return Err(Error::Parameter(format!(
                "piece {me} of {} pieces",
                pieces.len()
            )));
        }
        grid.validate()?;
        Ok(Self {
            origin: DVec3::from_array(grid.origin),
            spacing: DVec3::from_array(grid.spacing),
            far: DVec3::from_array(grid.dims.map(|d| d as f64 - 1.0)),
            boxes: pieces
                .iter()
                .enumerate()
                .filter(|(_, b)| !b.is_empty())
                .map(|(r, b)| (r, b.lo.as_dvec3(), b.hi.as_dvec3()))
                .collect(),
            me,
        })
    }

    /// The piece owning a cell with centroid `c` (world coordinates); `None` when every piece is
    /// empty.
    pub fn owner(&self, c: DVec3) -> Option<usize> {
        let u = ((c - self.origin) / self.spacing).clamp(DVec3::ZERO, self.far);
        let holds = |lo: DVec3, hi: DVec3| {
            u.cmpge(lo).all() && (u.cmplt(hi) | (hi.cmpeq(self.far) & u.cmple(hi))).all()
        };
        self.boxes
            .iter()
            .find(|&&(_, lo, hi)| holds(lo, hi))
            .or(self.boxes.first())
            .map(|b| b.0)
    }

    /// Does this piece own the cell with vertices `points` (world coordinates)?
    pub fn owns(&self, points: impl ExactSizeIterator<Item = [f64; 3]>) -> bool {
        let n = points.len().max(1) as f64;
        let c = points.map(DVec3::from_array).sum::<DVec3>() / n;
        self.owner(c) == Some(self.me)
    }
}

/// The split set of one query on one piece, grown in rounds with the other pieces
/// ([`PieceHierarchy::start`], [`PieceHierarchy::outgoing`], [`PieceHierarchy::receive`]).
#[derive(Clone, Debug)]
pub struct PieceRefinement {
    split: SplitSet,
    tolerance: f64,
    roi: Option<(DVec3, DVec3)>,
    /// Diamonds split here and not sent yet.
    outbox: Vec<Diamond>,
}

/// The points used by `cells`, ascending (a point's global id is its index in the
/// whole output), and the map from a whole-output point index to its index in the share.
pub(crate) fn used_points<'a>(
    n_points: usize,
    cells: impl Iterator<Item = &'a [u32]>,
) -> (Vec<u64>, Vec<u32>) {
    let mut used = vec![false; n_points];
    for cell in cells {
        for &v in cell {
            used[v as usize] = true;
        }
    }
    let ids: Vec<u64> = (0..n_points as u64).filter(|&i| used[i as usize]).collect();
    let mut local = vec![u32::MAX; n_points];
    for (k, &i) in ids.iter().enumerate() {
        local[i as usize] = k as u32;
    }
    (ids, local)
}

/// `values` at `ids` (one value per whole-output point or cell).
pub(crate) fn pick<T: Copy>(values: &[T], ids: &[u64]) -> Vec<T> {
    ids.iter().map(|&i| values[i as usize]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fields::{marschner_lobb, sample, sphere_distance, torus_distance, unit_grid};
    use crate::isosurface::Partition;
    use crate::validate::check_surface;
    use crate::{Hierarchy, IsoQuery, IsoState, IsoSurface};

    /// The pieces of a `k`-way split of the points along each axis (shared boundary planes, as
    /// VTK's extent translator cuts images).
    fn pieces(dims: [usize; 3], cuts: [usize; 3]) -> Vec<PointBox> {
        let bounds = |n: usize, k: usize| -> Vec<(i32, i32)> {
            (0..k)
                .map(|i| (((n - 1) * i / k) as i32, ((n - 1) * (i + 1) / k) as i32))
                .collect()
        };
        let mut out = Vec::new();
        for (z0, z1) in bounds(dims[2], cuts[2]) {
            for (y0, y1) in bounds(dims[1], cuts[1]) {
                for (x0, x1) in bounds(dims[0], cuts[0]) {
                    out.push(PointBox {
                        lo: IVec3::new(x0, y0, z0),
                        hi: IVec3::new(x1, y1, z1),
                    });
                }
            }
        }
        out
    }

    /// Every piece's hierarchy, built as the filter builds it (samples fetched, coarse errors
    /// combined), with the communication done here.
    fn build_pieces(grid: Grid, samples: &[f32], boxes: &[PointBox]) -> Vec<PieceHierarchy> {
        let mut hierarchies: Vec<PieceHierarchy> = boxes
            .iter()
            .map(|&b| {
                let layout = PieceLayout::new(grid, b).unwrap();
                let mut local = Vec::new();
                for z in b.lo.z..=b.hi.z {
                    for y in b.lo.y..=b.hi.y {
                        for x in b.lo.x..=b.hi.x {
                            local.push(samples[grid.index(x as usize, y as usize, z as usize)]);
                        }
                    }
                }
                let fetched: Vec<f32> = layout
                    .requests(boxes)
                    .unwrap()
                    .iter()
                    .flat_map(|r| r.points.points())
                    .map(|p| samples[layout.lattice.index(p)])
                    .collect();
                PieceHierarchy::build(
                    layout,
                    boxes,
                    ScalarSlice::F32(&local),
                    ScalarSlice::F32(&fetched),
                    &mut |_| true,
                )
                .unwrap()
            })
            .collect();
        let mut combined = vec![0.0f64; hierarchies[0].coarse_errors().len()];
        for h in &hierarchies {
            for (c, e) in combined.iter_mut().zip(h.coarse_errors()) {
                *c = c.max(*e);
            }
        }
        for h in &mut hierarchies {
            h.combine_coarse_errors(&combined).unwrap();
        }
        hierarchies
    }

    /// The pieces' meshes for `query`, each computed as the filter does, with every
    /// communication done here.
    fn distributed(
        grid: Grid,
        samples: &[f32],
        boxes: &[PointBox],
        query: &Query,
    ) -> (Vec<TetMesh>, usize) {
        let hierarchies = build_pieces(grid, samples, boxes);
        let mut states: Vec<_> = hierarchies
            .iter()
            .map(|h| h.start(query).unwrap())
            .collect();
        let mut rounds = 0;
        loop {
            // What each piece sent to each piece: sent[from][to].
            let sent: Vec<Vec<Vec<i32>>> = hierarchies
                .iter()
                .zip(&mut states)
                .map(|(h, r)| h.outgoing(r, boxes))
                .collect();
            if sent.iter().flatten().all(Vec::is_empty) {
                break;
            }
            rounds += 1;
            for (to, (h, r)) in hierarchies.iter().zip(&mut states).enumerate() {
                let received: Vec<i32> = sent.iter().flat_map(|s| s[to].iter().copied()).collect();
                h.receive(r, &received).unwrap();
            }
        }
        let meshes = hierarchies
            .iter()
            .zip(&states)
            .enumerate()
            .map(|(me, (h, r))| {
                let mesh = h.mesh(r, boxes, me).unwrap();
                assert_passes_point_data(h, r, boxes, me, &mesh);
                mesh
            })
            .collect();
        (meshes, rounds)
    }

    /// A point array passed through piece `me`'s plan, its own points' tuples from its box and the
    /// others' from those fetched for [`MeshPlan::remote_point_ids`], holds each point's value (here
    /// its grid index, 8 bytes); fetched values of the wrong size are refused.
    fn assert_passes_point_data(
        h: &PieceHierarchy,
        r: &PieceRefinement,
        boxes: &[PointBox],
        me: usize,
        mesh: &TetMesh,
    ) {
        let plan = h.plan(r.clone(), boxes, me).unwrap();
        let (own, lattice) = (boxes[me], h.layout.lattice);
        let held = |i: usize| own.contains(lattice.point(i));
        let value = |i: usize| (i as u64).to_le_bytes();
        let local: Vec<u8> = (0..h.layout.grid.len())
            .filter(|&i| held(i))
            .flat_map(value)
            .collect();
        let remote = plan.remote_point_ids().unwrap();
        let expected: Vec<u64> = mesh
            .point_ids
            .iter()
            .filter(|&&i| !held(i))
            .map(|&i| i as u64)
            .collect();
        assert_eq!(remote, expected, "piece {me}");
        let fetched: Vec<u8> = remote.iter().flat_map(|&i| value(i as usize)).collect();
        let mut target = vec![0u8; 8 * plan.points()];
        plan.gather_piece(&local, &fetched, 8, &mut target).unwrap();
        let gathered: Vec<usize> = target
            .chunks_exact(8)
            .map(|c| u64::from_le_bytes(c.try_into().unwrap()) as usize)
            .collect();
        assert_eq!(gathered, mesh.point_ids, "piece {me}");
        let short = &fetched[..fetched.len().saturating_sub(8)];
        assert!(plan.gather_piece(&local, short, 8, &mut target).is_err() || fetched.is_empty());
    }

    /// Tetrahedra as sorted whole-grid point ids, with depth and error, sorted.
    fn cells(meshes: &[&TetMesh]) -> Vec<([usize; 4], u8, u32)> {
        let mut out: Vec<_> = meshes
            .iter()
            .flat_map(|m| {
                m.tets
                    .iter()
                    .zip(&m.depths)
                    .zip(&m.errors)
                    .map(|((t, &d), &e)| {
                        let mut ids = t.map(|i| m.point_ids[i as usize]);
                        ids.sort_unstable();
                        (ids, d, e.to_bits())
                    })
            })
            .collect();
        out.sort_unstable();
        out
    }

    fn field(grid: Grid) -> Vec<f32> {
        (0..grid.len())
            .map(|i| {
                let [x, y, z] = grid.ijk(i).map(|v| v as f32);
                (0.31 * x).sin() * 40.0 + (0.17 * y * z).cos() * 25.0 + 0.05 * x * y
            })
            .collect()
    }

    #[test]
    fn pieces_together_give_the_serial_mesh() {
        for (dims, cuts) in [
            ([33, 33, 33], [2, 1, 1]),
            ([41, 29, 37], [1, 2, 2]),
            ([65, 20, 19], [3, 1, 1]),
            ([30, 31, 47], [2, 2, 2]),
        ] {
            let grid = Grid::new(dims);
            let samples = field(grid);
            let serial = Hierarchy::build(grid, ScalarSlice::F32(&samples), &mut |_| true).unwrap();
            let boxes = pieces(dims, cuts);
            for query in [
                Query::tolerance(0.0),
                Query::tolerance(2.0),
                Query::tolerance(9.0),
                Query {
                    region_of_interest: Some([3.0, 12.0, 0.0, 9.0, 4.0, 20.0]),
                    ..Query::tolerance(1.0)
                },
            ] {
                let whole = serial.query(&query).unwrap();
                let (meshes, rounds) = distributed(grid, &samples, &boxes, &query);
                let parts: Vec<&TetMesh> = meshes.iter().collect();
                assert!(
                    meshes.iter().all(|m| !m.tets.is_empty()),
                    "{dims:?} {query:?}"
                );
                assert_eq!(
                    cells(&parts),
                    cells(&[&whole]),
                    "{dims:?} in {cuts:?} pieces, {query:?} ({rounds} rounds)"
                );
                for m in &meshes {
                    for (p, &i) in m.points.iter().zip(&m.point_ids) {
                        assert_eq!(*p, grid.point(grid.ijk(i)));
                    }
                }
            }
        }
    }

    #[test]
    fn every_piece_knows_the_serial_error_of_every_diamond_meeting_it() {
        // Integer and floating-point samples; pieces with halos cut by the grid and not.
        let dims = [45, 38, 41];
        let grid = Grid::new(dims);
        let samples = field(grid);
        let serial = Hierarchy::build(grid, ScalarSlice::F32(&samples), &mut |_| true).unwrap();
        let boxes = pieces(dims, [3, 2, 1]);
        let hierarchies = build_pieces(grid, &samples, &boxes);
        let lattice = Lattice::new(dims).unwrap();
        let (mut fine, mut coarse) = (0, 0);
        for h in &hierarchies {
            for i in 1..grid.len() {
                let d = Diamond::new(lattice.point(i));
                if h.layout.meets(d) && d.placement(&lattice) == Placement::Inside {
                    assert_eq!(
                        h.error(d),
                        serial.error(d),
                        "{:?} in {:?}",
                        d,
                        h.layout.owned
                    );
                    if d.scale() >= h.layout.stride {
                        coarse += 1;
                    } else {
                        fine += 1;
                    }
                }
            }
        }
        assert!(coarse > 50 && fine > 10_000, "{coarse} coarse, {fine} fine");
    }

    #[test]
    fn overlapping_pieces_output_each_tetrahedron_once() {
        // Every rank holding the whole image, and pieces overlapping by more than a plane.
        let dims = [21, 18, 25];
        let grid = Grid::new(dims);
        let samples = field(grid);
        let whole = PointBox {
            lo: IVec3::ZERO,
            hi: IVec3::new(20, 17, 24),
        };
        let overlapping = vec![
            PointBox {
                lo: IVec3::ZERO,
                hi: IVec3::new(14, 17, 24),
            },
            PointBox {
                lo: IVec3::new(6, 0, 0),
                hi: IVec3::new(20, 17, 24),
            },
        ];
        let query = Query::tolerance(2.0);
        let serial = Hierarchy::build(grid, ScalarSlice::F32(&samples), &mut |_| true).unwrap();
        let want = cells(&[&serial.query(&query).unwrap()]);
        for boxes in [vec![whole; 3], overlapping] {
            let (meshes, _) = distributed(grid, &samples, &boxes, &query);
            let parts: Vec<&TetMesh> = meshes.iter().collect();
            assert_eq!(cells(&parts), want, "{boxes:?}");
        }
    }

    #[test]
    fn an_empty_piece_takes_part_and_owns_nothing() {
        let dims = [17, 17, 17];
        let grid = Grid::new(dims);
        let samples = field(grid);
        let mut boxes = pieces(dims, [2, 1, 1]);
        boxes.push(PointBox::EMPTY);
        let query = Query::tolerance(3.0);
        let (meshes, _) = distributed(grid, &samples, &boxes, &query);
        assert!(meshes[2].tets.is_empty() && meshes[2].points.is_empty());
        let serial = Hierarchy::build(grid, ScalarSlice::F32(&samples), &mut |_| true).unwrap();
        let parts: Vec<&TetMesh> = meshes.iter().collect();
        assert_eq!(cells(&parts), cells(&[&serial.query(&query).unwrap()]));
    }

    /// Every rank's part of the Adaptive Isosurface of `query`, computed as the filter does
    /// ([`IsoState::extract_shared`]): every piece's points are gathered on every rank
    /// ([`first_uncovered`] checks that they cover the grid), which puts the whole image together,
    /// and the pieces run at once, one thread each, sharing the bound's check through their
    /// exchanges (empty pieces too: they take part in every exchange and own nothing). Returns the
    /// parts and how many times a piece sent violations.
    fn iso_pieces(
        grid: Grid,
        samples: &[f32],
        boxes: &[PointBox],
        query: &IsoQuery,
    ) -> (Vec<IsoSurface>, usize) {
        assert_eq!(first_uncovered(grid.dims, boxes), None);
        let mut whole = vec![f32::NAN; grid.len()];
        for b in boxes {
            for z in b.lo.z..=b.hi.z {
                for y in b.lo.y..=b.hi.y {
                    for x in b.lo.x..=b.hi.x {
                        let i = grid.index(x as usize, y as usize, z as usize);
                        whole[i] = samples[i];
                    }
                }
            }
        }
        assert!(whole.iter().all(|v| !v.is_nan()));
        let h = Hierarchy::build_for_isosurfaces(grid, ScalarSlice::F32(&whole)).unwrap();
        crate::isosurface::threads::run_pieces(boxes.len(), |me, member| {
            let partition = Partition::new(CellOwner::new(boxes, me).unwrap(), member);
            IsoState::new()
                .extract_shared(&h, ScalarSlice::F32(&whole), query, &partition)
                .unwrap()
        })
    }

    /// A triangle as its corners' coordinate bits, rotated to start at the smallest (orientation
    /// kept).
    fn coordinate_triangle(points: &[[f64; 3]], t: &[u32; 3]) -> [[u64; 3]; 3] {
        let c = t.map(|i| points[i as usize].map(f64::to_bits));
        let k = (0..3).min_by_key(|&k| c[k]).unwrap();
        [c[k], c[(k + 1) % 3], c[(k + 2) % 3]]
    }

    /// Checks the pieces' parts of the surface against the serial surface: the union of their
    /// triangles is the serial one as a set of coordinate triangles, each once; every point's
    /// global id names the serial point with the same coordinates, normal, value, sources and
    /// weight; merged by global ids or by coordinates, the union is watertight and consistently
    /// oriented (open only on the grid's faces) exactly as the serial surface is. Returns the
    /// triangles per piece.
    fn check_iso_union(serial: &IsoSurface, parts: &[IsoSurface], grid: &Grid) -> Vec<usize> {
        let mut want: Vec<_> = (serial.triangles.iter())
            .map(|t| coordinate_triangle(&serial.points, t))
            .collect();
        want.sort_unstable();
        let mut got: Vec<_> = (parts.iter())
            .flat_map(|s| {
                s.triangles
                    .iter()
                    .map(|t| coordinate_triangle(&s.points, t))
            })
            .collect();
        got.sort_unstable();
        assert_eq!(got.len(), want.len(), "triangle count");
        assert!(got == want, "the union differs from the serial surface");
        let mut merged = Vec::new();
        for s in parts {
            assert_eq!(s.point_ids.len(), s.points.len());
            for (k, &g) in s.point_ids.iter().enumerate() {
                let g = g as usize;
                assert_eq!(
                    s.points[k].map(f64::to_bits),
                    serial.points[g].map(f64::to_bits)
                );
                assert_eq!(s.values[k].to_bits(), serial.values[g].to_bits());
                assert_eq!(s.normals[k], serial.normals[g]);
                assert_eq!(s.sources[k], serial.sources[g]);
                assert_eq!(s.weights[k].to_bits(), serial.weights[g].to_bits());
            }
            merged.extend(
                s.triangles
                    .iter()
                    .map(|t| t.map(|i| s.point_ids[i as usize] as u32)),
            );
            if !s.triangles.is_empty() {
                assert_eq!(s.error_bound.to_bits(), serial.error_bound.to_bits());
            }
        }
        let bounds = Some(grid.bounds());
        let whole = check_surface(&serial.points, &serial.triangles, bounds).unwrap();
        let by_id = check_surface(&serial.points, &merged, bounds).unwrap();
        assert_eq!(by_id, whole);
        // By coordinates: the points of all pieces, one per distinct position.
        let mut positions: Vec<[u64; 3]> = (parts.iter())
            .flat_map(|s| s.points.iter().map(|p| p.map(f64::to_bits)))
            .collect();
        positions.sort_unstable();
        positions.dedup();
        let id = |p: &[f64; 3]| positions.binary_search(&p.map(f64::to_bits)).unwrap() as u32;
        let by_position: Vec<[u32; 3]> = (parts.iter())
            .flat_map(|s| {
                s.triangles
                    .iter()
                    .map(|t| t.map(|i| id(&s.points[i as usize])))
            })
            .collect();
        let points: Vec<[f64; 3]> = positions.iter().map(|p| p.map(f64::from_bits)).collect();
        let report = check_surface(&points, &by_position, bounds).unwrap();
        report.passed().unwrap();
        whole.passed().unwrap();
        parts.iter().map(|s| s.triangles.len()).collect()
    }

    #[test]
    fn isosurface_pieces_together_give_the_serial_surface() {
        let sphere = sphere_distance(0.6);
        let torus = torus_distance(0.55, 0.25);
        /// Name, points per axis, cuts per axis, field, isovalues.
        type Case<'a> = (
            &'a str,
            [usize; 3],
            [usize; 3],
            &'a dyn Fn(f64, f64, f64) -> f64,
            &'a [f64],
        );
        let cases: [Case; 4] = [
            ("sphere", [33, 29, 41], [2, 1, 1], &sphere, &[0.0]),
            ("torus", [41, 23, 37], [1, 3, 1], &torus, &[0.0, 0.08]),
            (
                "marschner-lobb",
                [37, 33, 29],
                [3, 1, 1],
                &marschner_lobb,
                &[0.5],
            ),
            ("sphere", [31, 35, 27], [1, 1, 2], &sphere, &[-0.1]),
        ];
        let mut exchanged = 0;
        for (name, dims, cuts, f, isovalues) in cases {
            let grid = unit_grid(dims);
            let samples = sample(&grid, |x, y, z| f(x, y, z) as f32);
            let boxes = pieces(dims, cuts);
            let h = Hierarchy::build_for_isosurfaces(grid, ScalarSlice::F32(&samples)).unwrap();
            let d = grid.diagonal();
            let budget = IsoQuery {
                max_triangles: 1500,
                ..IsoQuery::new(isovalues[0], 0.001 * d)
            };
            for query in [0.0, 0.004 * d, 0.02 * d]
                .map(|tolerance| IsoQuery {
                    isovalues: isovalues.to_vec(),
                    ..IsoQuery::new(0.0, tolerance)
                })
                .into_iter()
                .chain([budget])
            {
                let serial = IsoState::new()
                    .extract(&h, ScalarSlice::F32(&samples), &query)
                    .unwrap();
                let (parts, sent) = iso_pieces(grid, &samples, &boxes, &query);
                let what = format!("{name} {dims:?} in {cuts:?}, {query:?}");
                let counts = check_iso_union(&serial, &parts, &grid);
                assert!(
                    counts.iter().all(|&n| n > 0),
                    "{what}: a piece owns no triangle ({counts:?})"
                );
                exchanged += sent;
            }
        }
        // The pieces found violations and exchanged them: each piece's alone would not give the
        // serial surface.
        assert!(exchanged > 0);
    }

    #[test]
    fn isosurface_pieces_overlapping_or_empty_own_each_triangle_once() {
        let dims = [25, 21, 23];
        let grid = unit_grid(dims);
        let samples = sample(&grid, |x, y, z| sphere_distance(0.6)(x, y, z) as f32);
        let h = Hierarchy::build_for_isosurfaces(grid, ScalarSlice::F32(&samples)).unwrap();
        let query = IsoQuery {
            carrier_tetrahedra: true,
            ..IsoQuery::new(0.0, 0.01 * grid.diagonal())
        };
        let serial = IsoState::new()
            .extract(&h, ScalarSlice::F32(&samples), &query)
            .unwrap();
        let whole = PointBox {
            lo: IVec3::ZERO,
            hi: IVec3::new(24, 20, 22),
        };
        let overlapping = vec![
            PointBox {
                lo: IVec3::ZERO,
                hi: IVec3::new(15, 20, 22),
            },
            PointBox {
                lo: IVec3::new(8, 0, 0),
                hi: IVec3::new(24, 20, 22),
            },
        ];
        let mut with_empty = pieces(dims, [2, 1, 1]);
        with_empty.insert(1, PointBox::EMPTY);
        for boxes in [vec![whole; 3], overlapping, with_empty] {
            let (parts, _) = iso_pieces(grid, &samples, &boxes, &query);
            check_iso_union(&serial, &parts, &grid);
            // The carrier tetrahedra too: each once.
            let carriers = |meshes: &[&TetMesh]| {
                let mut c: Vec<[usize; 4]> = (meshes.iter())
                    .flat_map(|m| {
                        m.tets.iter().map(|t| {
                            let mut ids = t.map(|i| m.point_ids[i as usize]);
                            ids.sort_unstable();
                            ids
                        })
                    })
                    .collect();
                c.sort_unstable();
                c
            };
            let owned: Vec<&TetMesh> = parts.iter().filter_map(|s| s.carrier.as_ref()).collect();
            assert_eq!(
                carriers(&owned),
                carriers(&[serial.carrier.as_ref().unwrap()]),
                "{boxes:?}"
            );
        }
        assert!(CellOwner::new(&pieces(dims, [2, 1, 1]), 2).is_err());
    }

    #[test]
    fn owners_are_the_first_piece_holding_a_point() {
        let dims = [9, 5, 5];
        let boxes = pieces(dims, [2, 1, 1]);
        let grid = Grid::new(dims);
        let ids = [0u64, 4, 5, grid.index(8, 4, 4) as u64];
        let lattice = Lattice::new(dims).unwrap();
        assert_eq!(point_owners(&lattice, &boxes, &ids), vec![0, 0, 1, 1]);
        assert_eq!(point_owners(&lattice, &boxes[1..], &[0]), vec![1]);
    }

    /// A piece holding a box inside a 9 × 5 × 5 grid: the grid, the box and its layout.
    fn held_piece() -> (Grid, PointBox, PieceLayout) {
        let grid = Grid::new([9, 5, 5]);
        let held = PointBox {
            lo: IVec3::new(4, 1, 2),
            hi: IVec3::new(8, 3, 4),
        };
        (grid, held, PieceLayout::new(grid, held).unwrap())
    }

    #[test]
    fn local_ids_index_the_held_points_only() {
        let (grid, _, layout) = held_piece();
        let ids: Vec<u64> = (0..grid.len() as u64 + 2).collect();
        let local = layout.local_ids(&ids);
        // Every held point once, numbered x fastest over the held box; the others (and indices
        // past the grid) −1.
        let mut expected = vec![-1i64; ids.len()];
        let mut next = 0;
        for z in 2..=4 {
            for y in 1..=3 {
                for x in 4..=8 {
                    expected[grid.index(x, y, z)] = next;
                    next += 1;
                }
            }
        }
        assert_eq!(local, expected);
        let nothing = PieceLayout::new(grid, PointBox::EMPTY).unwrap();
        assert!(nothing.local_ids(&ids).iter().all(|&i| i == -1));
    }

    #[test]
    fn point_sources_give_each_id_the_row_of_its_point() {
        let (grid, held, layout) = held_piece();
        // Points inside and outside the box, repeated and unordered, as edge sources are.
        let ids: Vec<u64> = [
            (5, 2, 3),
            (0, 0, 0),
            (8, 3, 4),
            (5, 2, 3),
            (3, 2, 3),
            (0, 0, 0),
        ]
        .iter()
        .map(|&(x, y, z)| grid.index(x, y, z) as u64)
        .collect();
        let sources = PointSources::new(&grid, held, &ids).unwrap();
        let own: Vec<u64> = layout
            .local_ids(&ids)
            .into_iter()
            .filter(|&i| i >= 0)
            .map(|i| i as u64)
            .collect();
        let mut unique_own = own.clone();
        unique_own.sort_unstable();
        unique_own.dedup();
        assert_eq!(sources.local, unique_own);
        assert_eq!(
            sources.remote,
            vec![0, grid.index(3, 2, 3) as u64],
            "the other points once each, ascending"
        );
        // The table's row of each id holds that id's point.
        let table: Vec<u64> = (sources.local.iter().map(|&k| {
            let [nx, ny] = [5, 3];
            let k = k as usize;
            grid.index(4 + k % nx, 1 + k / nx % ny, 2 + k / (nx * ny)) as u64
        }))
        .chain(sources.remote.iter().copied())
        .collect();
        let looked_up: Vec<u64> = sources.rows.iter().map(|&r| table[r as usize]).collect();
        assert_eq!(looked_up, ids);
        // A piece holding nothing fetches every point; an id past the grid is an error.
        let none = PointSources::new(&grid, PointBox::EMPTY, &ids).unwrap();
        assert!(none.local.is_empty() && none.remote.len() == 4);
        assert!(PointSources::new(&grid, held, &[grid.len() as u64]).is_err());
    }

    #[test]
    fn bad_pieces_and_messages_are_refused() {
        let grid = Grid::new([9, 9, 9]);
        let outside = PointBox {
            lo: IVec3::ZERO,
            hi: IVec3::splat(9),
        };
        assert!(PieceLayout::new(grid, outside).is_err());
        let own = PointBox {
            lo: IVec3::ZERO,
            hi: IVec3::splat(4),
        };
        let layout = PieceLayout::new(grid, own).unwrap();
        let rest = PointBox {
            lo: IVec3::ZERO,
            hi: IVec3::splat(8),
        };
        let pieces = [own, rest];
        let asked: usize = layout
            .requests(&pieces)
            .unwrap()
            .iter()
            .map(|r| r.points.len())
            .sum();
        // Points that no piece holds.
        assert!(layout.requests(&[own]).is_err());
        let local = vec![0u8; 125];
        let wrong = vec![0u16; asked];
        let err = PieceHierarchy::build(
            layout.clone(),
            &pieces,
            ScalarSlice::U8(&local),
            ScalarSlice::U16(&wrong),
            &mut |_| true,
        )
        .unwrap_err();
        assert!(err.to_string().contains("U16"), "{err}");
        let short = vec![0u8; 3];
        assert!(PieceHierarchy::build(
            layout.clone(),
            &pieces,
            ScalarSlice::U8(&local),
            ScalarSlice::U8(&short),
            &mut |_| true
        )
        .is_err());
        let fetched = vec![0u8; asked];
        let mut h = PieceHierarchy::build(
            layout,
            &pieces,
            ScalarSlice::U8(&local),
            ScalarSlice::U8(&fetched),
            &mut |_| true,
        )
        .unwrap();
        assert!(
            h.start(&Query::tolerance(1.0)).is_err(),
            "coarse errors not combined"
        );
        assert!(h.combine_coarse_errors(&[1.0]).is_err());
        let combined = h.coarse_errors().to_vec();
        h.combine_coarse_errors(&combined).unwrap();
        let budget = Query {
            max_tetrahedra: 100,
            ..Query::tolerance(1.0)
        };
        assert!(h.start(&budget).is_err());
        let mut r = h.start(&Query::tolerance(1.0)).unwrap();
        assert!(h.receive(&mut r, &[1, 2]).is_err());
        assert!(h.receive(&mut r, &[100, 0, 0]).is_err());
    }

    /// The whole-grid points a piece needs from the others, listed point by point: its padded box
    /// outside its own, and the coarse sublattice outside the padded box.
    fn needed_points(layout: &PieceLayout) -> Vec<IVec3> {
        if layout.owned.is_empty() {
            return Vec::new();
        }
        let (p, o) = (layout.padded, layout.owned);
        let mut out = Vec::new();
        for z in p.lo.z..=p.hi.z {
            for y in p.lo.y..=p.hi.y {
                for x in p.lo.x..=p.hi.x {
                    let q = IVec3::new(x, y, z);
                    if !o.contains(q) {
                        out.push(q);
                    }
                }
            }
        }
        out.extend(layout.coarse_points().filter(|&q| !p.contains(q)));
        out
    }

    #[test]
    fn requests_ask_each_needed_point_once_of_the_first_piece_holding_it() {
        let mut layouts = vec![
            (Grid::new([33, 33, 33]), pieces([33, 33, 33], [2, 1, 1])),
            (Grid::new([41, 29, 37]), pieces([41, 29, 37], [1, 2, 2])),
            (Grid::new([65, 20, 19]), pieces([65, 20, 19], [3, 1, 1])),
            (Grid::new([30, 31, 47]), pieces([30, 31, 47], [2, 2, 2])),
            (Grid::new([37, 45, 29]), pieces([37, 45, 29], [4, 1, 1])),
            (Grid::new([50, 51, 52]), pieces([50, 51, 52], [1, 3, 1])),
            (Grid::new([47, 35, 61]), pieces([47, 35, 61], [2, 1, 2])),
            (Grid::new([300, 9, 11]), pieces([300, 9, 11], [3, 1, 1])),
        ];
        // An empty piece among others, and pieces overlapping by more than one layer.
        let mut with_empty = pieces([39, 33, 35], [1, 1, 3]);
        with_empty.insert(1, PointBox::EMPTY);
        layouts.push((Grid::new([39, 33, 35]), with_empty));
        let whole = PointBox {
            lo: IVec3::ZERO,
            hi: IVec3::new(40, 34, 36),
        };
        let mut overlapping = pieces([41, 35, 37], [2, 2, 1]);
        overlapping[1].lo.x -= 5;
        overlapping.push(whole);
        layouts.push((Grid::new([41, 35, 37]), overlapping));
        for (grid, boxes) in &layouts {
            let lattice = Lattice::new(grid.dims).unwrap();
            for (me, &own) in boxes.iter().enumerate() {
                let layout = PieceLayout::new(*grid, own).unwrap();
                let requests = layout.requests(boxes).unwrap();
                let what = format!("piece {me} of {boxes:?}");
                assert!(
                    requests.windows(2).all(|w| w[0].rank <= w[1].rank),
                    "{what}"
                );
                let asked: Vec<(IVec3, usize)> = requests
                    .iter()
                    .flat_map(|r| r.points.points().map(move |p| (p, r.rank)))
                    .collect();
                // Every point from the first piece holding it, never from this one.
                for &(p, rank) in &asked {
                    let first = point_owners(&lattice, boxes, &[lattice.index(p) as u64]);
                    assert_eq!(first, vec![rank as u32], "{p} {what}");
                    assert_ne!(rank, me, "{what}");
                }
                // Every needed point exactly once.
                let key = |p: &IVec3| (p.z, p.y, p.x);
                let mut got: Vec<IVec3> = asked.iter().map(|&(p, _)| p).collect();
                got.sort_unstable_by_key(key);
                let mut want = needed_points(&layout);
                want.sort_unstable_by_key(key);
                assert_eq!(got, want, "{what}");
                // A few boxes per piece asked, not a point each.
                assert!(
                    requests.len() <= 12 * boxes.len(),
                    "{what}: {}",
                    requests.len()
                );
                // The holder finds the points of each box, in the box's order.
                for r in &requests {
                    let holder = PieceLayout::new(*grid, boxes[r.rank]).unwrap();
                    let ids: Vec<u64> =
                        r.points.points().map(|p| lattice.index(p) as u64).collect();
                    assert_eq!(
                        holder.box_indices(&[r.points]).unwrap(),
                        holder.local_ids(&ids),
                        "{what}"
                    );
                }
            }
        }
    }

    #[test]
    fn boxes_asked_of_a_piece_that_does_not_hold_them_are_refused() {
        let grid = Grid::new([20, 20, 20]);
        let own = PointBox {
            lo: IVec3::new(0, 0, 0),
            hi: IVec3::new(10, 19, 19),
        };
        let layout = PieceLayout::new(grid, own).unwrap();
        let inside = StridedBox::checked(IVec3::new(2, 0, 0), IVec3::new(10, 16, 8), 8).unwrap();
        assert_eq!(inside.len(), 2 * 3 * 2);
        assert_eq!(layout.box_indices(&[inside]).unwrap().len(), 12);
        let across = StridedBox::checked(IVec3::new(8, 0, 0), IVec3::new(12, 0, 0), 1).unwrap();
        assert!(layout.box_indices(&[inside, across]).is_err());
        assert!(StridedBox::checked(IVec3::ZERO, IVec3::new(7, 8, 8), 8).is_err());
        assert!(StridedBox::checked(IVec3::ZERO, IVec3::ONE, 0).is_err());
        assert!(StridedBox::checked(IVec3::ONE, IVec3::ZERO, 1).is_err());
    }
}
