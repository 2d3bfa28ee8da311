//! Selective refinement with closure (Gregorski §4, §8; Weiss & De Floriani §6.3).
//!
//! The current mesh is described by the set of split diamonds. It is conforming exactly when that set is
//! *closed*: a diamond is split only after all its parents (Gregorski §4: "when some of the tetrahedra in D
//! do not exist, it is necessary to create them before D can be split … by splitting the parents of D").
//! A query starts from the base mesh and repeatedly takes the diamond of largest error from the
//! [`SplitQueue`], splitting its unsplit ancestors first, until every diamond of the mesh meets the
//! tolerance or the next split would exceed the tetrahedron budget.
//!
//! Gregorski's queues are bucketed hash tables because any diamond above the tolerance may be split;
//! a budget needs *largest error first*, so our split queue is a binary heap.

use crate::diamond::Diamond;
use crate::lattice::{Lattice, Placement};
use crate::volume::Grid;
use crate::{Error, Result};
use glam::IVec3;
use rayon::prelude::*;
use rustc_hash::FxHashSet;
use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::sync::atomic::{AtomicU64, Ordering as AtomicOrdering};

/// A selective-refinement query.
#[derive(Clone, Debug, PartialEq)]
pub struct Query {
    /// Absolute tolerance in data units; 0 reproduces every sample.
    pub tolerance: f64,
    /// Maximum number of tetrahedra, 0 = no limit. A budget below the base mesh yields the base mesh.
    pub max_tetrahedra: usize,
    /// World-space box `[xmin, xmax, ymin, ymax, zmin, zmax]`: the tolerance applies inside, coarse outside.
    pub region_of_interest: Option<[f64; 6]>,
}

impl Query {
    /// A query for `tolerance` alone.
    pub fn tolerance(tolerance: f64) -> Self {
        Self {
            tolerance,
            max_tetrahedra: 0,
            region_of_interest: None,
        }
    }
}

/// The set of split diamonds: a bitset over the domain's points plus a hash set for the few central
/// vertices outside the domain (diamonds along the far faces).
#[derive(Clone, Debug, PartialEq)]
pub struct SplitSet {
    bits: Vec<u64>,
    outside: FxHashSet<IVec3>,
    lattice: Lattice,
}

impl SplitSet {
    /// The empty set (only the root's six tetrahedra).
    pub fn new(lattice: &Lattice) -> Self {
        let points = (lattice.hi + IVec3::ONE).as_uvec3();
        let n = points.x as usize * points.y as usize * points.z as usize;
        Self {
            bits: vec![0; n.div_ceil(64)],
            outside: FxHashSet::default(),
            lattice: *lattice,
        }
    }

    /// Is `d` split?
    #[inline]
    pub fn contains(&self, d: Diamond) -> bool {
        if self.lattice.in_domain(d.center) {
            let i = self.lattice.index(d.center);
            self.bits[i / 64] >> (i % 64) & 1 == 1
        } else {
            self.outside.contains(&d.center)
        }
    }

    /// Marks `d` split; returns whether it was not split before.
    #[inline]
    pub fn insert(&mut self, d: Diamond) -> bool {
        if self.lattice.in_domain(d.center) {
            let i = self.lattice.index(d.center);
            let bit = 1 << (i % 64);
            let new = self.bits[i / 64] & bit == 0;
            self.bits[i / 64] |= bit;
            new
        } else {
            self.outside.insert(d.center)
        }
    }

    /// Marks `d` unsplit (merged).
    pub(crate) fn remove(&mut self, d: Diamond) {
        if self.lattice.in_domain(d.center) {
            let i = self.lattice.index(d.center);
            self.bits[i / 64] &= !(1 << (i % 64));
        } else {
            self.outside.remove(&d.center);
        }
    }

    /// Number of split diamonds.
    pub fn len(&self) -> usize {
        self.bits
            .iter()
            .map(|w| w.count_ones() as usize)
            .sum::<usize>()
            + self.outside.len()
    }

    /// True when no diamond is split.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Bytes held: one bit per lattice point of the grid and the diamonds centred outside it (a
    /// hash table at its capacity, one control byte per slot).
    pub fn bytes(&self) -> usize {
        self.bits.capacity() * std::mem::size_of::<u64>()
            + self.outside.capacity() * (std::mem::size_of::<IVec3>() + 1)
    }

    /// The lattice the set lives on.
    pub fn lattice(&self) -> &Lattice {
        &self.lattice
    }

    /// The bitset over the domain's points (bit `i` of word `i / 64` for the diamond centred on the
    /// point of [`Lattice::index`] `i`).
    pub(crate) fn domain_bits(&self) -> &[u64] {
        &self.bits
    }
}

/// The mesh every query of a hierarchy starts from (Gregorski §4): for a hierarchy with records, the
/// diamonds straddling a far face of the domain with their closure ([`Refiner::base_mesh`]); for an
/// isosurface-only one, the root.
#[derive(Clone, Debug)]
pub(crate) struct BaseMesh {
    /// Its split diamonds.
    pub(crate) split: SplitSet,
    /// Its tetrahedra inside the domain.
    pub(crate) tets: usize,
    /// The unsplit diamonds with tetrahedra in it, where refinement starts, ordered by bisection
    /// depth, coarsest first (so that the depth sweep of [`refine_concurrent`] takes each depth's
    /// as a slice, with no per-query copy).
    pub(crate) candidates: Vec<Diamond>,
}

/// An entry of the ordered split queue: a diamond and its error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    error: f64,
    diamond: Diamond,
}

impl Eq for Candidate {}

impl Ord for Candidate {
    fn cmp(&self, other: &Self) -> Ordering {
        self.error.total_cmp(&other.error).then_with(|| {
            let (a, b) = (self.diamond.center, other.diamond.center);
            (a.x, a.y, a.z).cmp(&(b.x, b.y, b.z))
        })
    }
}

impl PartialOrd for Candidate {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// Gregorski's split queue. With a tetrahedron budget it is ordered by error (largest first); with a
/// tolerance alone any diamond above the tolerance may be split next (Gregorski §8), so a stack does.
pub enum SplitQueue {
    Ordered(BinaryHeap<Candidate>),
    Unordered(Vec<Diamond>),
}

impl SplitQueue {
    fn push(&mut self, diamond: Diamond, error: f64) {
        match self {
            SplitQueue::Ordered(heap) => heap.push(Candidate { error, diamond }),
            SplitQueue::Unordered(stack) => stack.push(diamond),
        }
    }

    fn pop(&mut self) -> Option<Diamond> {
        match self {
            SplitQueue::Ordered(heap) => heap.pop().map(|c| c.diamond),
            SplitQueue::Unordered(stack) => stack.pop(),
        }
    }
}

/// The refinement state of one query.
pub(crate) struct Refiner<'h> {
    lattice: Lattice,
    split: SplitSet,
    /// Diamonds whose error was compared with the tolerance already (it does not change).
    considered: SplitSet,
    /// The diamonds split, in order, when asked for.
    log: Option<Vec<Diamond>>,
    /// With [`Refiner::refine_parallel`]: the diamonds to consider whose criterion is not evaluated yet.
    pending: Option<Vec<Diamond>>,
    queue: SplitQueue,
    tets: usize,
    /// Region of interest in lattice coordinates (closed box).
    roi: Option<(glam::DVec3, glam::DVec3)>,
    tolerance: f64,
    /// The diamond error that drives refinement (data units for meshes, world units for isosurfaces).
    criterion: &'h dyn Fn(Diamond) -> f64,
}

impl<'h> Refiner<'h> {
    /// A refiner of `lattice` starting from `split` (with `tets` tetrahedra inside the domain).
    pub(crate) fn new(
        lattice: Lattice,
        split: SplitSet,
        tets: usize,
        criterion: &'h dyn Fn(Diamond) -> f64,
    ) -> Self {
        Self {
            lattice,
            split,
            considered: SplitSet::new(&lattice),
            log: None,
            pending: None,
            queue: SplitQueue::Unordered(Vec::new()),
            tets,
            roi: None,
            tolerance: 0.0,
            criterion,
        }
    }

    /// The split set of the base mesh: every diamond with a tetrahedron straddling a far face of the
    /// domain, with its closure.
    pub(crate) fn base_mesh(lattice: Lattice) -> SplitSet {
        let mut r = Self::new(lattice, SplitSet::new(&lattice), 0, &|_| 0.0);
        let mut stack = vec![Diamond::root(&lattice)];
        let mut closure = Vec::new();
        while let Some(d) = stack.pop() {
            if r.split.contains(d) || d.placement(&lattice) != Placement::Straddling {
                continue;
            }
            Self::closure(&r.lattice, &r.split, d, &mut closure);
            for &a in &closure {
                r.split.insert(a);
                stack.extend(a.children(&lattice));
            }
        }
        r.split
    }

    /// The unsplit diamonds with tetrahedra in the mesh of `split`: the root when unsplit, and the
    /// unsplit children of split diamonds.
    pub(crate) fn candidates(lattice: &Lattice, split: &SplitSet) -> Vec<Diamond> {
        let mut out = Vec::new();
        // A bit per domain point: a diamond is met once per split parent.
        let mut seen = SplitSet::new(lattice);
        let mut stack = vec![Diamond::root(lattice)];
        while let Some(d) = stack.pop() {
            if !seen.insert(d) {
                continue;
            }
            if split.contains(d) {
                stack.extend(d.children(lattice));
            } else if d.placement(lattice) != Placement::Outside {
                out.push(d);
            }
        }
        out
    }

    /// Runs `query` on `grid` from `base` with `criterion` as the diamond error and returns the split
    /// set.
    pub(crate) fn run(
        grid: &Grid,
        base: &BaseMesh,
        query: &Query,
        criterion: &'h dyn Fn(Diamond) -> f64,
    ) -> Result<SplitSet> {
        let mut r = Self::start(grid, base, query, criterion)?;
        r.refine(&base.candidates, query.max_tetrahedra);
        Ok(r.split)
    }

    /// [`Refiner::run`] for a `query` without a budget, with the split set shared by all threads:
    /// the same split set, found in parallel.
    ///
    /// Without a budget the split set is the least set that holds the base mesh, is closed under
    /// parents (those not outside the domain: the closure of Gregorski §4) and holds every child of a
    /// split diamond, and every unsplit diamond of the base mesh, whose error exceeds the tolerance —
    /// whatever the order of the splits (Gregorski §8: any diamond above the tolerance may go
    /// next). So it is found in two passes over a shared bitset, where an atomic test-and-set
    /// gives each split exactly one owner: one bisection depth after the other, every diamond above
    /// the tolerance with a split parent ([`sweep_depths`]); then the closure of what that pass
    /// split, grown in rounds ([`grow_concurrent`]). Diamonds centred outside the domain are all
    /// split in the base mesh (they straddle a far face) or lie outside it, so the shared part is
    /// the bitset alone.
    pub(crate) fn run_concurrent(
        grid: &Grid,
        base: &BaseMesh,
        query: &Query,
        criterion: &'h (dyn Fn(Diamond) -> f64 + Sync),
    ) -> Result<SplitSet> {
        if query.max_tetrahedra > 0 {
            return Err(Error::Parameter(
                "concurrent refinement takes no tetrahedron budget".into(),
            ));
        }
        let r = Self::start(grid, base, query, criterion)?;
        let (lattice, tolerance, roi) = (r.lattice, r.tolerance, r.roi);
        let error = |d: Diamond| {
            if roi.is_some_and(|roi| outside_roi(roi, &lattice, d)) {
                0.0
            } else {
                criterion(d)
            }
        };
        let mut split = r.split;
        refine_concurrent(&mut split, &base.candidates, tolerance, &error, None, false)?;
        Ok(split)
    }

    /// A refiner of `grid` at `base`, set up for `query` (queue, tolerance, region).
    fn start(
        grid: &Grid,
        base: &BaseMesh,
        query: &Query,
        criterion: &'h dyn Fn(Diamond) -> f64,
    ) -> Result<Self> {
        let roi = query_region(grid, query)?;
        let mut r = Self::new(
            *base.split.lattice(),
            base.split.clone(),
            base.tets,
            criterion,
        );
        r.tolerance = query.tolerance;
        if query.max_tetrahedra > 0 {
            r.queue = SplitQueue::Ordered(BinaryHeap::new());
        }
        r.roi = roi;
        Ok(r)
    }

    /// Runs `query` (no budget) "from the current mesh" `current` (Gregorski §6.1), the split set of an
    /// earlier query from the same `base`, and returns the same split set as [`Refiner::run`].
    ///
    /// Merge pass: of the diamonds split in `current`, only those the new criterion still requires are
    /// kept — the least set that holds the base mesh, is closed under parents and holds every diamond
    /// of `current` above the tolerance with a kept parent. It is found top-down from the base mesh,
    /// through split diamonds of `current` only; every other diamond of `current` is merged. (Gregorski's
    /// bottom-up merge queue — merge a split diamond with no split child once it meets the tolerance —
    /// alone is not enough for the from-root result: it keeps a diamond above the tolerance whose
    /// parents are split only for its own closure, a pair from-root never reaches.) Unsplit diamonds
    /// above the tolerance met on the way are the split queue of the split pass, which then continues
    /// as usual with closure. Every diamond either pass splits is split by from-root too, and the
    /// result is closed with every reachable diamond meeting the tolerance: the least such set, i.e.
    /// from-root's.
    pub(crate) fn rerun(
        grid: &Grid,
        base: &BaseMesh,
        query: &Query,
        criterion: &'h dyn Fn(Diamond) -> f64,
        current: &SplitSet,
    ) -> Result<SplitSet> {
        if query.max_tetrahedra > 0 {
            return Err(Error::Parameter(
                "refinement from the current mesh takes no tetrahedron budget".into(),
            ));
        }
        if current.lattice != *base.split.lattice() {
            return Err(Error::Parameter(
                "the current mesh belongs to another hierarchy".into(),
            ));
        }
        let mut r = Self::start(grid, base, query, criterion)?;
        // Merge pass: keep what is still required among the split diamonds of `current`.
        let mut split_queue = Vec::new();
        let within = |r: &mut Self, d: Diamond, split_queue: &mut Vec<Diamond>| {
            if r.split.contains(d) {
                return;
            }
            if r.error(d) > r.tolerance {
                if current.contains(d) {
                    r.queue.push(d, 0.0);
                } else {
                    split_queue.push(d);
                }
            }
        };
        for &d in &base.candidates {
            within(&mut r, d, &mut split_queue);
        }
        let mut closure = Vec::new();
        while let Some(d) = r.queue.pop() {
            if r.split.contains(d) {
                continue;
            }
            // `current` is closed, so the closure stays inside it.
            Self::closure(&r.lattice, &r.split, d, &mut closure);
            for &a in &closure {
                debug_assert!(current.contains(a));
                r.split.insert(a);
                r.tets += Self::inside_tets(&r.lattice, a);
                for c in a.children(&r.lattice) {
                    within(&mut r, c, &mut split_queue);
                }
            }
        }
        // Split pass from the leaves of the kept mesh.
        r.refine(&split_queue, 0);
        Ok(r.split)
    }

    /// Splits, with closure, every diamond reachable from `candidates` whose criterion exceeds
    /// `tolerance` (no budget). Returns the split set and the number of tetrahedra inside the domain.
    /// (Tests compare with it; the product refines in parallel, [`Refiner::refine_parallel`].)
    #[cfg(test)]
    pub(crate) fn refine_with(
        mut self,
        tolerance: f64,
        candidates: &[Diamond],
    ) -> (SplitSet, usize) {
        self.tolerance = tolerance;
        self.refine(candidates, 0);
        (self.split, self.tets)
    }

    /// [`Refiner::refine_with`], returning the split set and the diamonds split here, in order.
    pub(crate) fn refine_logged(
        mut self,
        tolerance: f64,
        candidates: &[Diamond],
    ) -> (SplitSet, Vec<Diamond>) {
        self.log = Some(Vec::new());
        self.tolerance = tolerance;
        self.refine(candidates, 0);
        (self.split, self.log.unwrap_or_default())
    }

    /// [`Refiner::new`] then splits, with closure, every diamond reachable from `candidates` whose
    /// criterion exceeds `tolerance` (no budget), with the criterion evaluated in parallel: in
    /// rounds, the criterion of every diamond met in the last round (children of split diamonds,
    /// `candidates` first) is evaluated at once, then those above `tolerance` are split with
    /// closure. The split set is that of the sequential refinement (without a budget the order of
    /// splits does not change it). `round` is called on this thread before each round with the number of diamonds
    /// evaluated so far and stops the refinement when it returns `false` (then `None`).
    pub(crate) fn refine_parallel(
        lattice: Lattice,
        split: SplitSet,
        tets: usize,
        (tolerance, candidates): (f64, &[Diamond]),
        criterion: &(dyn Fn(Diamond) -> f64 + Sync),
        round: &mut dyn FnMut(usize) -> bool,
    ) -> Option<(SplitSet, usize)> {
        let mut r = Refiner::new(lattice, split, tets, criterion);
        r.tolerance = tolerance;
        r.pending = Some(Vec::new());
        for &d in candidates {
            r.consider(d);
        }
        let mut evaluated = 0;
        let mut closure = Vec::new();
        loop {
            let mut batch = r.pending.replace(Vec::new()).unwrap_or_default();
            batch.retain(|&d| !r.split.contains(d));
            if batch.is_empty() {
                break;
            }
            if !round(evaluated) {
                return None;
            }
            evaluated += batch.len();
            let errors: Vec<f64> = batch.par_iter().map(|&d| criterion(d)).collect();
            for (d, e) in batch.into_iter().zip(errors) {
                if e > tolerance {
                    r.queue.push(d, e);
                }
            }
            while let Some(d) = r.queue.pop() {
                if r.split.contains(d) {
                    continue;
                }
                Self::closure(&r.lattice, &r.split, d, &mut closure);
                for &a in &closure {
                    r.split(a);
                }
            }
        }
        Some((r.split, r.tets))
    }

    /// Queues `candidates` and splits until the queue is empty or, with `budget > 0`, until the next
    /// split (largest error first) would exceed `budget` tetrahedra.
    fn refine(&mut self, candidates: &[Diamond], budget: usize) {
        let r = self;
        for &d in candidates {
            r.consider(d);
        }
        let mut closure = Vec::new();
        while let Some(d) = r.queue.pop() {
            if r.split.contains(d) {
                continue; // already split through another parent's closure
            }
            Self::closure(&r.lattice, &r.split, d, &mut closure);
            if budget > 0 {
                let added: usize = closure
                    .iter()
                    .map(|&a| Self::inside_tets(&r.lattice, a))
                    .sum();
                if r.tets + added > budget {
                    break;
                }
            }
            for &a in &closure {
                r.split(a);
            }
        }
    }

    /// Splits `d` (its parents must be split) and queues its children.
    fn split(&mut self, d: Diamond) {
        self.split.insert(d);
        if let Some(log) = &mut self.log {
            log.push(d);
        }
        self.tets += Self::inside_tets(&self.lattice, d);
        for c in d.children(&self.lattice) {
            self.consider(c);
        }
    }

    /// Queues `d` if it is unsplit, relevant and above the tolerance.
    fn consider(&mut self, d: Diamond) {
        if self.split.contains(d) || !self.considered.insert(d) {
            return;
        }
        if let Some(pending) = &mut self.pending {
            pending.push(d);
            return;
        }
        let e = self.error(d);
        if e > self.tolerance {
            self.queue.push(d, e);
        }
    }

    /// The error that drives refinement: the criterion inside the region of interest, 0 outside
    /// ([`outside_roi`]).
    fn error(&self, d: Diamond) -> f64 {
        if self
            .roi
            .is_some_and(|roi| outside_roi(roi, &self.lattice, d))
        {
            return 0.0;
        }
        (self.criterion)(d)
    }

    /// Number of `d`'s tetrahedra inside the domain (each becomes two when `d` is split).
    pub(crate) fn inside_tets(lattice: &Lattice, d: Diamond) -> usize {
        let (lo, hi) = d.bounds();
        if lattice.in_domain(lo) && lattice.in_domain(hi) {
            return [6, 4, 8][d.class() as usize];
        }
        d.tet_boxes(lattice)
            .iter()
            .filter(|(lo, hi, _)| lattice.place_box(*lo, *hi) == Placement::Inside)
            .map(|(_, _, n)| n)
            .sum()
    }

    /// `d` and its ancestors unsplit in `split` that touch the domain, parents before children, into
    /// `order`.
    pub(crate) fn closure(
        lattice: &Lattice,
        split: &SplitSet,
        d: Diamond,
        order: &mut Vec<Diamond>,
    ) {
        order.clear();
        let parents = d.parents(lattice);
        if parents.iter().all(|&p| split.contains(p)) {
            order.push(d); // the common case: nothing to close
            return;
        }
        let mut visited = FxHashSet::default();
        // Iterative post-order DFS over unsplit parents.
        let mut stack = vec![(d, false)];
        while let Some((x, expanded)) = stack.pop() {
            if expanded {
                order.push(x);
                continue;
            }
            if !visited.insert(x) {
                continue;
            }
            stack.push((x, true));
            for p in x.parents(lattice) {
                if !split.contains(p)
                    && !visited.contains(&p)
                    && p.placement(lattice) != Placement::Outside
                {
                    stack.push((p, false));
                }
            }
        }
    }
}

/// A split set growing in parallel: its bitset over the domain as atomics, so that an atomic
/// test-and-set gives each split exactly one owner; the diamonds centred outside the domain, all
/// split in the base mesh or outside it, are only read.
struct Growing<'s> {
    lattice: Lattice,
    bits: Vec<AtomicU64>,
    outside: &'s FxHashSet<IVec3>,
}

impl<'s> Growing<'s> {
    fn new(split: &'s SplitSet) -> Result<Self> {
        let mut bits =
            crate::memory::with_capacity(split.bits.len(), "the refinement's split set")?;
        bits.extend(split.bits.iter().map(|&w| AtomicU64::new(w)));
        Ok(Self {
            lattice: split.lattice,
            bits,
            outside: &split.outside,
        })
    }

    #[inline]
    fn contains(&self, d: Diamond) -> bool {
        if self.lattice.in_domain(d.center) {
            let i = self.lattice.index(d.center);
            self.bits[i / 64].load(AtomicOrdering::Relaxed) >> (i % 64) & 1 == 1
        } else {
            self.outside.contains(&d.center)
        }
    }

    /// Marks `d`, centred in the domain, split; returns whether this call split it.
    #[inline]
    fn claim(&self, d: Diamond) -> bool {
        let i = self.lattice.index(d.center);
        let bit = 1u64 << (i % 64);
        self.bits[i / 64].fetch_or(bit, AtomicOrdering::Relaxed) & bit == 0
    }

    /// `d`'s parents that the closure still has to split (unsplit, not outside the domain).
    fn unsplit_parents(&self, d: Diamond, into: &mut Vec<Diamond>) {
        into.extend(
            d.parents(&self.lattice)
                .into_iter()
                .filter(|&p| !self.contains(p) && p.placement(&self.lattice) != Placement::Outside),
        );
    }

    fn into_bits(self) -> Vec<u64> {
        self.bits.into_iter().map(AtomicU64::into_inner).collect()
    }
}

/// Grows `split` in parallel rounds (the second pass of [`Refiner::run_concurrent`]): splits the
/// diamonds of `first` (split whatever their error), their unsplit parents not outside the domain,
/// and every child of a diamond split here whose `error` exceeds `tolerance`. When the diamonds of
/// `split` have their unsplit parents in `first` (a closed `split` has none), `split` becomes the
/// least such closed superset of itself, whatever the order of the splits (left as it was on an
/// error). With `record`, returns the diamonds split here, in index order (else
/// nothing: neither collected nor sorted — a sequential sort of millions of diamonds).
pub(crate) fn grow_concurrent(
    split: &mut SplitSet,
    first: Vec<Diamond>,
    tolerance: f64,
    error: &(dyn Fn(Diamond) -> f64 + Sync),
    record: bool,
) -> Result<Vec<Diamond>> {
    let growing = Growing::new(split)?;
    let mut added = grow(&growing, first, tolerance, error, record)?;
    split.bits = growing.into_bits();
    sort_by_index(&split.lattice, &mut added);
    Ok(added)
}

/// Refines the closed split set `split` from its unsplit `candidates` (those of its mesh): splits
/// every diamond the least closed superset holds in which every child of a split diamond, and
/// every candidate, whose `error` exceeds `tolerance` is split ([`Refiner::run_concurrent`]):
/// [`sweep_depths`], then [`grow`] for the closure. With `region` (a box of domain points), only
/// diamonds that meet it can have an `error` above 0. With `record`, returns the diamonds split
/// here, in index order (else nothing).
pub(crate) fn refine_concurrent(
    split: &mut SplitSet,
    candidates: &[Diamond],
    tolerance: f64,
    error: &(dyn Fn(Diamond) -> f64 + Sync),
    region: Option<(IVec3, IVec3)>,
    record: bool,
) -> Result<Vec<Diamond>> {
    let growing = Growing::new(split)?;
    let (missing, mut added) =
        sweep_depths(&growing, candidates, tolerance, error, region, record)?;
    added.append(&mut grow(&growing, missing, tolerance, error, record)?);
    split.bits = growing.into_bits();
    sort_by_index(&split.lattice, &mut added);
    Ok(added)
}

/// Sorts diamonds centred in the domain by the index of their central vertex, in parallel.
fn sort_by_index(lattice: &Lattice, diamonds: &mut [Diamond]) {
    diamonds.par_sort_unstable_by_key(|d| lattice.index(d.center));
}

/// [`grow_concurrent`] on a [`Growing`] split set; with `record`, returns the diamonds split here,
/// unordered.
fn grow(
    split: &Growing,
    first: Vec<Diamond>,
    tolerance: f64,
    error: &(dyn Fn(Diamond) -> f64 + Sync),
    record: bool,
) -> Result<Vec<Diamond>> {
    let lattice = split.lattice;
    let mut round = first;
    let mut added = Vec::new();
    while !round.is_empty() {
        crate::memory::check("the refinement's rounds")?;
        // Per thread: the diamonds to try next round, and the diamonds split in this one.
        let next: Result<(Vec<Diamond>, Vec<Diamond>)> = round
            .par_iter()
            .try_fold(
                Default::default,
                |(mut next, mut here): (Vec<_>, Vec<_>), &d| {
                    if !lattice.in_domain(d.center) {
                        return Err(Error::Parameter(format!(
                        "internal error: diamond {:?} outside the domain is not in the base mesh",
                        d.center
                    )));
                    }
                    if !split.claim(d) {
                        return Ok((next, here)); // split by another diamond of this round
                    }
                    if record {
                        here.push(d);
                    }
                    split.unsplit_parents(d, &mut next);
                    next.extend(
                        d.children(&lattice)
                            .into_iter()
                            .filter(|&c| !split.contains(c) && error(c) > tolerance),
                    );
                    Ok((next, here))
                },
            )
            .try_reduce(Default::default, |(mut a, mut x), (mut b, mut y)| {
                a.append(&mut b);
                x.append(&mut y);
                Ok((a, x))
            });
        let (next, mut here) = next?;
        added.append(&mut here);
        round = next;
    }
    Ok(added)
}

/// The first pass of [`Refiner::run_concurrent`]: one bisection depth after the other, coarsest
/// first, splits every unsplit diamond centred in the domain whose `error` exceeds `tolerance` and
/// one of whose parents is split — the `candidates` of the base mesh (ordered by depth, coarsest
/// first, as [`BaseMesh::candidates`]: each depth's are a slice of them) and the children of the diamonds
/// split at the depth before (all parents of a diamond are one depth coarser, so each depth is
/// decided once, in parallel, whatever the order). Every diamond split here is one the least closed
/// split set holds; returns the parents their closure still needs (possibly repeated), which
/// [`grow`] splits with all they entail, and with `record` the diamonds split here (unordered).
/// With `region` (a box of domain points that every diamond above 0 meets), a depth is scanned
/// only where its diamonds meet the box.
///
/// A depth is found either by visiting those children, or by scanning all the diamonds of the
/// depth — a sublattice of the domain's points, read in memory order — when there would be at
/// least as many children to visit (counted with repeats, up to 8 per diamond split) as diamonds
/// of the depth: at fine tolerances, where most fine diamonds are split, visiting each through
/// its parents costs scattered reads of errors and split bits, several times per diamond. (Scanned
/// or visited, a diamond costs about the same on bonsai 256³.)
fn sweep_depths(
    split: &Growing,
    candidates: &[Diamond],
    tolerance: f64,
    error: &(dyn Fn(Diamond) -> f64 + Sync),
    region: Option<(IVec3, IVec3)>,
    record: bool,
) -> Result<(Vec<Diamond>, Vec<Diamond>)> {
    let lattice = split.lattice;
    let depth_of = |d: &Diamond| d.depth(&lattice) as usize;
    debug_assert!(
        candidates
            .windows(2)
            .all(|w| depth_of(&w[0]) <= depth_of(&w[1])),
        "candidates ordered by depth"
    );
    let mut rest = candidates;
    let above = |d: Diamond| !split.contains(d) && error(d) > tolerance;
    // Splits `d` (unsplit, above the tolerance, with a split parent) unless another thread did,
    // into `new`, with its parents still unsplit into `missing`.
    let claim = |(mut new, mut missing): (Vec<Diamond>, Vec<Diamond>), d: Diamond| {
        if split.claim(d) {
            split.unsplit_parents(d, &mut missing);
            new.push(d);
        }
        (new, missing)
    };
    let join = |(mut a, mut x): (Vec<Diamond>, Vec<Diamond>), (mut b, mut y)| {
        a.append(&mut b);
        x.append(&mut y);
        (a, x)
    };
    let mut new: Vec<Diamond> = Vec::new();
    let (mut missing, mut added) = (Vec::new(), Vec::new());
    for depth in 0..3 * lattice.levels as usize {
        crate::memory::check("the refinement's depths")?;
        // The candidates of this depth: a prefix of the rest, since they are ordered by depth.
        let (base, later) = rest.split_at(rest.partition_point(|d| depth_of(d) == depth));
        rest = later;
        if record {
            added.extend_from_slice(&new);
        }
        let layer = Layer::of_depth(&lattice, depth, region);
        let children = base.len() + 8 * new.len();
        let scan = depth > 0 && children >= layer.len();
        let (found, mut closure) = if scan {
            layer
                .planes()
                .fold(Default::default, |mut acc, plane| {
                    for c in layer.plane(plane) {
                        let d = Diamond::new(c);
                        if above(d) && d.parents(&lattice).iter().any(|&p| split.contains(p)) {
                            acc = claim(acc, d);
                        }
                    }
                    acc
                })
                .reduce(Default::default, join)
        } else {
            base.par_iter()
                .copied()
                .chain(new.par_iter().flat_map_iter(|d| d.children(&lattice)))
                .filter(|&d| lattice.in_domain(d.center) && above(d))
                .fold(Default::default, claim)
                .reduce(Default::default, join)
        };
        new = found;
        missing.append(&mut closure);
    }
    if record {
        added.append(&mut new);
    }
    Ok((missing, added))
}

/// The diamonds of one bisection depth centred in the domain (or those that meet a box): for scale
/// `s`, the central vertices `c` whose coordinates over `s` are all odd (cube diamonds), two of them
/// odd (face diamonds) or one (edge diamonds), the others even ([`Diamond::class`]).
struct Layer {
    /// The box the central vertices lie in.
    lo: IVec3,
    hi: IVec3,
    scale: i32,
    /// Which coordinates are odd multiples of the scale, one bit per axis, per orientation.
    odd: &'static [u8],
}

impl Layer {
    /// The diamonds of `depth`, with `region` those whose bounds (`c ± s`) meet that box.
    fn of_depth(lattice: &Lattice, depth: usize, region: Option<(IVec3, IVec3)>) -> Self {
        let sigma = lattice.levels - 1 - (depth / 3) as u32;
        let scale = 1 << sigma;
        let (lo, hi) = region.map_or((IVec3::ZERO, lattice.hi), |(lo, hi)| {
            (
                (lo - IVec3::splat(scale)).max(IVec3::ZERO),
                (hi + IVec3::splat(scale)).min(lattice.hi),
            )
        });
        Self {
            lo,
            hi,
            scale,
            odd: [&[0b111][..], &[0b011, 0b101, 0b110], &[0b001, 0b010, 0b100]][depth % 3],
        }
    }

    /// The coordinates along `axis` of the orientation `odd`: odd or even multiples of the scale.
    fn axis(&self, odd: u8, axis: usize) -> std::iter::StepBy<std::ops::Range<i32>> {
        // `lo` ≥ 0: `of_depth` clamps it. The first multiple of `s` at or above `lo` of the wanted
        // parity:
        let (s, lo) = (self.scale, self.lo[axis]);
        let mut first = (lo + s - 1) / s * s;
        if (first / s) & 1 != (odd >> axis & 1) as i32 {
            first += s;
        }
        (first..self.hi[axis] + 1).step_by(2 * s as usize)
    }

    /// Number of diamonds.
    fn len(&self) -> usize {
        self.odd
            .iter()
            .map(|&o| (0..3).map(|a| self.axis(o, a).len()).product::<usize>())
            .sum()
    }

    /// The layer's planes, in parallel: each orientation's z coordinates (no list is built: a
    /// large grid has millions of rows per depth).
    fn planes(&self) -> impl ParallelIterator<Item = (u8, i32)> + '_ {
        self.odd.par_iter().flat_map(move |&o| {
            let zs = self.axis(o, 2);
            let (first, n) = (zs.clone().next().unwrap_or(0), zs.len());
            let step = 2 * self.scale;
            (0..n as i32)
                .into_par_iter()
                .map(move |k| (o, first + k * step))
        })
    }

    /// The central vertices of plane `z` of orientation `o`, in memory order.
    fn plane(&self, (o, z): (u8, i32)) -> impl Iterator<Item = IVec3> + '_ {
        self.axis(o, 1)
            .flat_map(move |y| self.axis(o, 0).map(move |x| IVec3::new(x, y, z)))
    }
}

/// Checks the tolerance of `query` and returns its region of interest in lattice coordinates of
/// `grid` (closed box), if any.
pub(crate) fn query_region(
    grid: &Grid,
    query: &Query,
) -> Result<Option<(glam::DVec3, glam::DVec3)>> {
    if !query.tolerance.is_finite() || query.tolerance < 0.0 {
        return Err(Error::Parameter(format!(
            "tolerance must be a finite number ≥ 0 (got {})",
            query.tolerance
        )));
    }
    query
        .region_of_interest
        .map(|roi| lattice_box(grid, roi))
        .transpose()
}

/// Whether `d` lies outside the region of interest `(lo, hi)` (lattice coordinates), so that its
/// error does not count — unless it straddles a far face, which the criterion may require to split.
pub(crate) fn outside_roi(
    (lo, hi): (glam::DVec3, glam::DVec3),
    lattice: &Lattice,
    d: Diamond,
) -> bool {
    let (dlo, dhi) = d.bounds();
    (dlo.as_dvec3().cmpgt(hi).any() || dhi.as_dvec3().cmplt(lo).any())
        && d.placement(lattice) != Placement::Straddling
}

/// Refuses a region of interest (a world-space box: x, y and z ranges) that is not finite with
/// min ≤ max on every axis, or that misses the bounds of `g`.
pub fn check_region(g: &Grid, roi: [f64; 6]) -> Result<()> {
    let b = g.bounds();
    let valid = roi.iter().all(|v| v.is_finite()) && (0..3).all(|a| roi[2 * a] <= roi[2 * a + 1]);
    if !valid {
        return Err(Error::Parameter(format!(
            "region of interest {roi:?} must be finite with min ≤ max on every axis"
        )));
    }
    if (0..3).any(|a| roi[2 * a] > b[2 * a + 1] || roi[2 * a + 1] < b[2 * a]) {
        return Err(Error::Parameter(format!(
            "region of interest {roi:?} lies outside the data bounds {b:?}"
        )));
    }
    Ok(())
}

/// Converts a world-space box to lattice coordinates, refusing boxes that miss the grid.
fn lattice_box(g: &Grid, roi: [f64; 6]) -> Result<(glam::DVec3, glam::DVec3)> {
    check_region(g, roi)?;
    let to_lattice = |a: usize, v: f64| (v - g.origin[a]) / g.spacing[a];
    Ok((
        glam::DVec3::new(
            to_lattice(0, roi[0]),
            to_lattice(1, roi[2]),
            to_lattice(2, roi[4]),
        ),
        glam::DVec3::new(
            to_lattice(0, roi[1]),
            to_lattice(1, roi[3]),
            to_lattice(2, roi[5]),
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hierarchy::base_mesh;

    #[test]
    fn concurrent_refinement_splits_what_sequential_refinement_splits() {
        // Grids with and without a base mesh, an error that is not monotone along the hierarchy
        // (closures split extra parents), with and without a region of interest; the depths are
        // both scanned (fine tolerances) and visited through their parents' children (coarse).
        for dims in [[13, 9, 11], [17, 17, 17], [33, 5, 20], [2, 2, 2]] {
            let grid = crate::fields::unit_grid(dims);
            let lattice = Lattice::new(dims).unwrap();
            let base = base_mesh(lattice);
            let criterion = |d: Diamond| {
                let c = d.center;
                let h = (c.x * 73 + c.y * 37 + c.z * 11).rem_euclid(17) as f64;
                if lattice.in_domain(c) {
                    h * d.scale() as f64 / 8.0
                } else {
                    0.0
                }
            };
            for tolerance in [0.0, 0.5, 2.0, 6.0] {
                for roi in [None, Some([0.1, 0.4, 0.0, 1.0, 0.5, 0.9])] {
                    let query = Query {
                        region_of_interest: roi,
                        ..Query::tolerance(tolerance)
                    };
                    let sequential = Refiner::run(&grid, &base, &query, &criterion).unwrap();
                    let concurrent =
                        Refiner::run_concurrent(&grid, &base, &query, &criterion).unwrap();
                    assert_eq!(concurrent, sequential, "{dims:?} {query:?}");
                }
            }
            let budget = Query {
                max_tetrahedra: 10,
                ..Query::tolerance(0.0)
            };
            assert!(Refiner::run_concurrent(&grid, &base, &budget, &criterion).is_err());
        }
    }

    /// The diamonds of a [`Layer`], checked against its length.
    fn layer_diamonds(layer: &Layer) -> Vec<Diamond> {
        let planes: Vec<(u8, i32)> = layer.planes().collect();
        let out: Vec<Diamond> = planes
            .into_iter()
            .flat_map(|plane| layer.plane(plane).map(Diamond::new))
            .collect();
        assert_eq!(layer.len(), out.len());
        out
    }

    #[test]
    fn layers_hold_each_diamond_of_the_domain_once_at_its_depth() {
        for dims in [[13, 9, 11], [17, 17, 17], [33, 5, 20], [2, 2, 2], [5, 3, 2]] {
            let lattice = Lattice::new(dims).unwrap();
            let mut seen = FxHashSet::default();
            for depth in 0..3 * lattice.levels as usize {
                let all = layer_diamonds(&Layer::of_depth(&lattice, depth, None));
                for &d in &all {
                    assert!(lattice.in_domain(d.center), "{dims:?} {d:?}");
                    assert_eq!(d.depth(&lattice) as usize, depth, "{dims:?} {d:?}");
                    assert!(seen.insert(d.center), "{dims:?} {d:?} twice");
                }
                // With a region: exactly those whose bounds meet it.
                for (lo, hi) in [
                    ([1, 0, 2], [4, 3, 5]),
                    ([0, 0, 0], [0, 0, 0]),
                    ([3, 1, 1], [12, 8, 10]),
                ] {
                    let (lo, hi) = (IVec3::from(lo), IVec3::from(hi).min(lattice.hi));
                    let meets = |d: &Diamond| {
                        let (a, b) = d.bounds();
                        a.cmple(hi).all() && b.cmpge(lo).all()
                    };
                    let expected: Vec<Diamond> = all.iter().copied().filter(meets).collect();
                    let clipped = layer_diamonds(&Layer::of_depth(&lattice, depth, Some((lo, hi))));
                    assert_eq!(clipped, expected, "{dims:?} depth {depth} {lo} {hi}");
                }
            }
            // Every domain point but the root cube's corners is a central vertex.
            let points: usize = dims.iter().product();
            let corners = (0..8)
                .filter(|c| {
                    lattice.in_domain(IVec3::new(c & 1, c >> 1 & 1, c >> 2) * lattice.size())
                })
                .count();
            assert_eq!(seen.len(), points - corners, "{dims:?}");
        }
    }

    #[test]
    fn parallel_refinement_splits_what_sequential_refinement_splits() {
        // A grid that is not 2^k + 1 points (a base mesh along the far faces) and an error that
        // shrinks with the diamond's scale but not monotonically, so closures split extra parents.
        let lattice = Lattice::new([13, 9, 11]).unwrap();
        let base = base_mesh(lattice);
        let criterion = |d: Diamond| {
            let c = d.center;
            let h = (c.x * 73 + c.y * 37 + c.z * 11).rem_euclid(17) as f64;
            h * d.scale() as f64 / 8.0
        };
        for tolerance in [0.5, 2.0, 6.0] {
            let (sequential, tets) =
                Refiner::new(lattice, base.split.clone(), base.tets, &criterion)
                    .refine_with(tolerance, &base.candidates);
            let mut rounds = 0;
            let (parallel, parallel_tets) = Refiner::refine_parallel(
                lattice,
                base.split.clone(),
                base.tets,
                (tolerance, &base.candidates),
                &criterion,
                &mut |_| {
                    rounds += 1;
                    true
                },
            )
            .unwrap();
            assert!(sequential.len() > base.split.len(), "tolerance {tolerance}");
            assert_eq!(parallel, sequential, "tolerance {tolerance}");
            assert_eq!(parallel_tets, tets);
            assert!(rounds > 1);
        }
        // Stopped by its round callback.
        let stopped = Refiner::refine_parallel(
            lattice,
            base.split.clone(),
            base.tets,
            (0.5, &base.candidates),
            &criterion,
            &mut |evaluated| evaluated == 0,
        );
        assert!(stopped.is_none());
    }
}
