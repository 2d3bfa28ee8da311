//! Isodiamond hierarchies (Weiss & De Floriani §5–§7): one isosurface `f = v` or one interval
//! volume `α ≤ f ≤ β` encoded as the subset of the diamond hierarchy it needs, from which it is
//! extracted at any resolution of a ladder of tolerances without the volume.
//!
//! **Classes and types (§5).** Every sample gets a class: below, at or above `v` (an isosurface), or
//! below `α`, at `α`, inside, at `β`, above `β` (an interval volume); lattice points outside the grid
//! have none. A tetrahedron is *active* when its patch is not empty, decided from the classes alone
//! exactly as [`crate::isosurface`]'s marching tetrahedra and [`crate::interval`]'s clipping decide it
//! from the values. A diamond is *active* when one of its tetrahedra is (then one of its children's
//! is too); *creation* when none of its tetrahedra is but one of its subdivided tetrahedra (the
//! bisected ones, `δ_s`) is — for an isosurface only its central vertex differs (Fig. 10);
//! *relevant* when it is an ancestor of an active diamond and not active. The *RI* hierarchy (§6)
//! stores the active and relevant diamonds (the creation ones are among the relevant), the *MI*
//! hierarchy (§7) the active and creation diamonds only.
//!
//! **What a stored isodiamond carries**, so that extraction needs no field value: its central
//! vertex (the key), the class of that vertex, its type, and one bit per rung of the ladder: whether
//! the full-hierarchy extraction at that rung's tolerance splits it. Our extraction does not stop at
//! Gregorski's error alone (the two-sided bound is checked and forces splits that depend on the
//! tolerance, [`crate::isosurface`]), so a threshold per diamond would not reproduce it; the split
//! set of each rung is stored instead (8 rungs: one byte, where the paper quantises an error to 14
//! bits). A query at tolerance `τ` uses the finest rung whose tolerance is at most `τ`, so its result
//! is the full hierarchy's at that rung (bound `≤ τ`) and the ladder's last rung, 0, is the
//! full-resolution surface or volume. Each *crossing* (an edge of the hierarchy whose end classes
//! lie strictly on both sides of a level, §5.1 "isovertices") is one byte, the position along the
//! edge from its lower-index end quantised to 1/256 (at most 1/512 of the edge away); crossings are
//! listed once each, as the edges of the active subdivided tetrahedra of the split isodiamonds (the
//! tetrahedra every extraction takes its leaves from) in isodiamond order, and found again from the
//! classes, so they need no index. The MI hierarchy lacks some
//! ancestors whose central vertices are vertices of stored diamonds; their classes are stored as
//! *orphan* vertices (§7.3 assigns them the spine's class; storing them is exact and costs about two
//! bytes each). Encoding: [`Isodiamonds::to_bytes`].
//!
//! **Selective refinement (§6.3, §7.3).** The paper walks from the roots (RI: the root diamond;
//! MI: the root and every creation isodiamond, the local roots of §7) through the split
//! isodiamonds. Since each rung stores the full hierarchy's split set, which is closed under
//! parents, the leaves are read off it instead, each isodiamond on its own: every child tetrahedron
//! of an isodiamond split at the rung that is active and whose own diamond is not split is a leaf
//! of the extracted mesh (and the root's active tetrahedra when it is stored and not split). No
//! leaf is missed in MI: an active tetrahedron's diamond is active, and an active leaf's parent is
//! active or creation (Theorem 7.1), so both are stored. Both models give the full hierarchy's
//! leaves, and the surface or volume is made from them by the same marching tetrahedra or
//! clipping (points named by edges, so crack-free).

mod encode;
#[cfg(test)]
mod tests;

use crate::diamond::{bisect, child_of, Diamond};
use crate::hierarchy::{Hierarchy, Progress};
use crate::interval::{self, clip, IntervalQuery, IntervalVolume, PointKey, ALPHA, SAMPLE};
use crate::isosurface::{
    crosses, marching_on_listed_edges, marching_with_sources, source_weight, EdgeKey, EdgePoint,
    IsoState, Marching,
};
use crate::lattice::{Lattice, Tet};
use crate::memory;
use crate::refine::SplitSet;
use crate::volume::{Grid, Sample, ScalarSlice, Volume};
use crate::{with_volume, Error, IsoQuery, IsoSurface, Result};
use arrayvec::ArrayVec;
use glam::{DMat3, DVec3, IVec3};
use rayon::prelude::*;
use rustc_hash::{FxHashMap, FxHashSet};

/// What an isodiamond hierarchy encodes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target {
    /// The isosurface `f = v`.
    Isosurface(f64),
    /// The interval volume `α ≤ f ≤ β` (`α < β`).
    IntervalVolume([f64; 2]),
}

impl Target {
    /// Refuses non-finite levels and empty ranges.
    fn check(self) -> Result<()> {
        match self {
            Target::Isosurface(v) if !v.is_finite() => Err(Error::Parameter(format!(
                "the isovalue must be a finite number (got {v})"
            ))),
            Target::IntervalVolume([a, b]) if !(a.is_finite() && b.is_finite() && a < b) => {
                Err(Error::Parameter(format!(
                    "the range must be two finite numbers with the lower below the upper (got [{a}, {b}])"
                )))
            }
            _ => Ok(()),
        }
    }

    /// The class of a sample value (see the module documentation).
    fn class(self, f: f64) -> u8 {
        match self {
            Target::Isosurface(v) => (f >= v) as u8 + (f > v) as u8,
            Target::IntervalVolume([a, b]) => {
                (f >= a) as u8 + (f > a) as u8 + (f >= b) as u8 + (f > b) as u8
            }
        }
    }

    /// The levels, in data units.
    fn levels(self) -> Vec<f64> {
        match self {
            Target::Isosurface(v) => vec![v],
            Target::IntervalVolume(r) => r.to_vec(),
        }
    }

    /// The levels in class units: classes compare with them as values with the levels.
    fn class_levels(self) -> &'static [f64] {
        match self {
            Target::Isosurface(_) => &[1.0],
            Target::IntervalVolume(_) => &[1.0, 3.0],
        }
    }

    /// Is a tetrahedron with vertex classes `c` active (its patch not empty)? As marching
    /// tetrahedra's `crosses` and [`clip`] decide from values.
    fn active(self, c: [u8; 4]) -> bool {
        if c.contains(&NONE) {
            return false;
        }
        let f = c.map(f64::from);
        match self {
            Target::Isosurface(_) => crosses(&f, 1.0),
            Target::IntervalVolume(_) => {
                let (lo, hi) = (c.iter().min().unwrap(), c.iter().max().unwrap());
                if lo == hi {
                    (1..=3).contains(lo)
                } else {
                    *hi > 1 && *lo < 3
                }
            }
        }
    }
}

/// The two models of the paper.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Model {
    /// Relevant Isodiamond hierarchy (§6): active and relevant isodiamonds.
    Relevant,
    /// Minimal Isodiamond hierarchy (§7): active and creation isodiamonds.
    Minimal,
}

/// Rungs of the ladder at most, its last rung (tolerance 0) included: one split bit each.
pub const MAX_RUNGS: usize = 8;

/// The default ladder, fractions of the grid diagonal (then 0): 4 % down to 1/16 %.
pub const DEFAULT_LADDER: [f64; 7] = [0.04, 0.02, 0.01, 0.005, 0.0025, 0.00125, 0.000625];

/// Class of a lattice point outside the grid.
const NONE: u8 = 7;
/// The class bits and the split bit of an [`Isodiamonds::grid_table`] entry.
const CLASS_BITS: u8 = 7;
const SPLIT_BIT: u8 = 8;
/// Isodiamond types (§5).
const ACTIVE: u8 = 1;
const CREATION: u8 = 2;
const RELEVANT: u8 = 3;

/// A stored isodiamond.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Record {
    /// Its central vertex as a [`key`].
    key: u64,
    /// The class of the central vertex ([`NONE`] outside the grid).
    class: u8,
    /// [`ACTIVE`], [`CREATION`] or [`RELEVANT`].
    kind: u8,
    /// Bit `k`: split by the full hierarchy at rung `k`.
    split: u8,
}

/// How many isodiamonds of each type, crossings and orphan vertices a hierarchy stores.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    pub active: usize,
    pub creation: usize,
    /// Relevant isodiamonds that are not creation ones (0 in an MI hierarchy).
    pub relevant: usize,
    /// Crossings (isovertices), one byte each.
    pub crossings: usize,
    /// Classes of vertices whose isodiamond is not stored (MI only).
    pub orphans: usize,
}

/// An RI or MI hierarchy for one isosurface or interval volume ([module documentation](self)).
#[derive(Clone, Debug)]
pub struct Isodiamonds {
    grid: Grid,
    target: Target,
    model: Model,
    /// Rung tolerances, world units, decreasing, the last 0.
    ladder: Vec<f64>,
    /// Sorted by key.
    records: Vec<Record>,
    /// `(key, class)`, sorted by key.
    orphans: Vec<(u64, u8)>,
    /// Quantised crossings in [`Isodiamonds::crossing_edges`] order.
    crossings: Vec<u8>,
    /// Derived: the lattice, record of each key, crossing of each edge and level.
    lattice: Lattice,
    index: FxHashMap<u64, u32>,
    points: Vec<Crossing>,
}

/// A crossing looked up by its edge (grid indices `i < j`) and level index: 12 bytes, sorted by
/// edge and level (looked up once per output point, by binary search).
#[derive(Clone, Copy, Debug)]
struct Crossing {
    i: u32,
    j: u32,
    level: u8,
    /// Quantised position ([`quantise`]).
    q: u8,
}

impl Crossing {
    fn edge(&self) -> (u32, u32, u8) {
        (self.i, self.j, self.level)
    }
}

/// The key of a lattice point of the root cube.
fn key(lattice: &Lattice, p: IVec3) -> u64 {
    let n = lattice.size() as u64 + 1;
    p.x as u64 + n * (p.y as u64 + n * p.z as u64)
}

/// The lattice point of a key.
fn point(lattice: &Lattice, k: u64) -> IVec3 {
    let n = lattice.size() as u64 + 1;
    IVec3::new((k % n) as i32, (k / n % n) as i32, (k / (n * n)) as i32)
}

/// A corner of the root cube (no diamond has it as central vertex).
fn is_corner(lattice: &Lattice, p: IVec3) -> bool {
    let n = lattice.size();
    (p.cmpeq(IVec3::ZERO) | p.cmpeq(IVec3::splat(n))).all()
}

/// The distinct vertices of a diamond's tetrahedra, in order of appearance.
fn vertices(lattice: &Lattice, d: Diamond) -> Vec<IVec3> {
    let mut out: Vec<IVec3> = Vec::with_capacity(10);
    for t in d.tets(lattice) {
        for p in t {
            if !out.contains(&p) {
                out.push(p);
            }
        }
    }
    out
}

/// The quantised position `t ∈ (0, 1)` of a crossing along its edge.
fn quantise(t: f64) -> u8 {
    (t * 256.0).floor().clamp(0.0, 255.0) as u8
}

/// The position a quantised crossing stands for (the middle of its 1/256 step).
fn dequantise(q: u8) -> f64 {
    (q as f64 + 0.5) / 256.0
}

/// Builds the `model` hierarchy of `target` from `hierarchy` and the samples it was built from
/// (§6.2, §7.2): `ladder` holds the rung tolerances (world units, decreasing, positive, at most
/// [`MAX_RUNGS`] − 1; the rung 0 is added), each rung's split set is the full hierarchy's
/// ([`crate::isosurface::extract`] or [`crate::interval::extract`] at that tolerance).
///
/// `progress` is called on this thread with the fraction done (0 first, then after the types and
/// after each rung's extraction, which take the time: one step each) and stops the build with
/// [`Error::Aborted`] when it returns false.
pub fn build(
    hierarchy: &Hierarchy,
    scalars: ScalarSlice<'_>,
    target: Target,
    model: Model,
    ladder: &[f64],
    progress: Progress<'_>,
) -> Result<Isodiamonds> {
    target.check()?;
    if ladder.len() >= MAX_RUNGS
        || ladder.iter().any(|t| !t.is_finite() || *t <= 0.0)
        || ladder.windows(2).any(|w| w[0] <= w[1])
    {
        return Err(Error::Parameter(format!(
            "the ladder must hold at most {} decreasing positive tolerances (got {ladder:?})",
            MAX_RUNGS - 1
        )));
    }
    if scalars.len() != hierarchy.grid().len() {
        return Err(Error::Length {
            len: scalars.len(),
            expected: hierarchy.grid().len(),
            dims: hierarchy.grid().dims,
        });
    }
    let mut ladder = ladder.to_vec();
    ladder.push(0.0);
    with_volume!(*hierarchy.grid(), scalars, |v| build_from(
        hierarchy, scalars, &v, target, model, ladder, progress
    ))
}

/// [`build`] on the typed samples (checked).
fn build_from<T: Sample>(
    hierarchy: &Hierarchy,
    scalars: ScalarSlice<'_>,
    volume: &Volume<'_, T>,
    target: Target,
    model: Model,
    ladder: Vec<f64>,
    progress: Progress<'_>,
) -> Result<Isodiamonds> {
    // Steps: the types, then one per rung.
    let steps = (ladder.len() + 1) as f64;
    let mut step = |done: usize| {
        if progress(done as f64 / steps) {
            Ok(())
        } else {
            Err(Error::Aborted)
        }
    };
    step(0)?;
    let grid = *hierarchy.grid();
    let lattice = *hierarchy.lattice();
    let classes: Vec<u8> = (0..grid.len())
        .into_par_iter()
        .map(|i| target.class(volume.at_index(i)))
        .collect();
    let class_at = |p: IVec3| {
        if lattice.in_domain(p) {
            classes[lattice.index(p)]
        } else {
            NONE
        }
    };
    let tet_active = |t: &Tet| target.active(t.map(class_at));
    // Types of the diamonds centred in the grid (§5); those centred outside have no class at their
    // centre, so neither they nor their subdivided tetrahedra are active.
    let mut kinds: Vec<u8> = (0..grid.len())
        .into_par_iter()
        .map(|i| {
            let p = lattice.point(i);
            if is_corner(&lattice, p) {
                return 0;
            }
            let tets = Diamond::new(p).tets(&lattice);
            if tets.iter().any(tet_active) {
                ACTIVE
            } else if tets.iter().flat_map(bisect).any(|t| tet_active(&t)) {
                CREATION
            } else {
                0
            }
        })
        .collect();
    // RI: every ancestor of an active or creation diamond (§6; a finest diamond's subdivided
    // tetrahedra belong to no diamond, so a creation one there has no active child diamond).
    let mut outside: FxHashSet<IVec3> = FxHashSet::default();
    if model == Model::Relevant {
        let mut stack: Vec<Diamond> = (kinds.iter().enumerate())
            .filter(|(_, &k)| k == ACTIVE || k == CREATION)
            .map(|(i, _)| Diamond::new(lattice.point(i)))
            .collect();
        while let Some(d) = stack.pop() {
            for p in d.parents(&lattice) {
                let new = if lattice.in_domain(p.center) {
                    let k = &mut kinds[lattice.index(p.center)];
                    let new = *k == 0;
                    if new {
                        *k = RELEVANT;
                    }
                    new
                } else {
                    outside.insert(p.center)
                };
                if new {
                    stack.push(p);
                }
            }
        }
    }
    let mut records: Vec<Record> = (kinds.iter().enumerate())
        .filter(|(_, &k)| k == ACTIVE || (k != 0 && model == Model::Relevant) || k == CREATION)
        .map(|(i, &kind)| {
            let p = lattice.point(i);
            Record {
                key: key(&lattice, p),
                class: classes[i],
                kind,
                split: 0,
            }
        })
        .chain(outside.iter().map(|&p| Record {
            key: key(&lattice, p),
            class: NONE,
            kind: RELEVANT,
            split: 0,
        }))
        .collect();
    drop(kinds);
    records.par_sort_unstable_by_key(|r| r.key);
    step(1)?;
    // The split set of every rung, as the full hierarchy refines it.
    for (rung, &tolerance) in ladder.iter().enumerate() {
        let split = full_split_set(hierarchy, scalars, volume, target, tolerance)?;
        records.par_iter_mut().for_each(|r| {
            if split.contains(Diamond::new(point(&lattice, r.key))) {
                r.split |= 1 << rung;
            }
        });
        step(rung + 2)?;
    }
    // Orphans: grid vertices of split isodiamonds (and of the root's tetrahedra) whose own
    // isodiamond is not stored.
    let stored: FxHashSet<u64> = records.iter().map(|r| r.key).collect();
    let root = Diamond::root(&lattice);
    let mut needed: Vec<IVec3> = Vec::new();
    if stored.contains(&key(&lattice, root.center)) {
        needed.extend(vertices(&lattice, root));
    }
    for r in records.iter().filter(|r| r.split != 0) {
        needed.extend(vertices(&lattice, Diamond::new(point(&lattice, r.key))));
    }
    let mut orphans: Vec<(u64, u8)> = needed
        .into_iter()
        .filter(|&p| lattice.in_domain(p) && !stored.contains(&key(&lattice, p)))
        .map(|p| (key(&lattice, p), class_at(p)))
        .collect();
    orphans.par_sort_unstable();
    orphans.dedup();
    let mut h = Isodiamonds::new(grid, target, model, ladder, records, orphans, Vec::new())?;
    let levels = target.levels();
    h.crossings = (h.crossing_edges().iter())
        .map(|&(i, j, l)| {
            let (fa, fb) = (volume.at_index(i as usize), volume.at_index(j as usize));
            quantise((levels[l as usize] - fa) / (fb - fa))
        })
        .collect();
    h.points = h.crossing_map()?;
    Ok(h)
}

/// The split set of the full hierarchy's extraction of `target` at `tolerance`.
fn full_split_set<T: Sample>(
    hierarchy: &Hierarchy,
    scalars: ScalarSlice<'_>,
    volume: &Volume<'_, T>,
    target: Target,
    tolerance: f64,
) -> Result<SplitSet> {
    match target {
        Target::Isosurface(v) => {
            let mut state = IsoState::new();
            let query = IsoQuery {
                compute_normals: false,
                ..IsoQuery::new(v, tolerance)
            };
            state.extract(hierarchy, scalars, &query)?;
            Ok(state.current_split().expect("kept").clone())
        }
        Target::IntervalVolume(range) => {
            interval::split_set(hierarchy, volume, &IntervalQuery::new(range, tolerance))
        }
    }
}

impl Isodiamonds {
    /// Assembles a hierarchy from its stored parts and derives its lookups; refuses parts that do
    /// not fit together (decoding).
    fn new(
        grid: Grid,
        target: Target,
        model: Model,
        ladder: Vec<f64>,
        records: Vec<Record>,
        orphans: Vec<(u64, u8)>,
        crossings: Vec<u8>,
    ) -> Result<Self> {
        let bad = |what: String| Err(Error::Isodiamonds(what));
        grid.validate()?;
        target.check()?;
        let lattice = Lattice::new(grid.dims)?;
        let n = lattice.size() as u64 + 1;
        let max_class = match target {
            Target::Isosurface(_) => 2,
            Target::IntervalVolume(_) => 4,
        };
        if ladder.is_empty()
            || ladder.len() > MAX_RUNGS
            || ladder.last() != Some(&0.0)
            || ladder
                .windows(2)
                .any(|w| !w[0].is_finite() || w[1].is_nan() || w[0] <= w[1])
        {
            return bad(format!("a ladder of {} rungs", ladder.len()));
        }
        let mut index = FxHashMap::default();
        for (i, r) in records.iter().enumerate() {
            let p = point(&lattice, r.key);
            if r.key >= n * n * n || is_corner(&lattice, p) {
                return bad(format!(
                    "isodiamond {i} has no central vertex in the lattice"
                ));
            }
            if i > 0 && records[i - 1].key >= r.key {
                return bad(format!("isodiamond {i} is out of order"));
            }
            let expected_none = !lattice.in_domain(p);
            if (r.class == NONE) != expected_none || (r.class != NONE && r.class > max_class) {
                return bad(format!("isodiamond {i} has class {}", r.class));
            }
            let allowed = match model {
                Model::Relevant => [ACTIVE, CREATION, RELEVANT].contains(&r.kind),
                Model::Minimal => [ACTIVE, CREATION].contains(&r.kind),
            };
            if !allowed || (ladder.len() < 8 && r.split >> ladder.len() != 0) {
                return bad(format!(
                    "isodiamond {i} has type {} split {}",
                    r.kind, r.split
                ));
            }
            index.insert(r.key, i as u32);
        }
        for (i, &(k, c)) in orphans.iter().enumerate() {
            let p = point(&lattice, k);
            if k >= n * n * n || !lattice.in_domain(p) || c > max_class {
                return bad(format!("orphan vertex {i} ({k}, class {c})"));
            }
            if i > 0 && orphans[i - 1].0 >= k {
                return bad(format!("orphan vertex {i} is out of order"));
            }
        }
        let mut h = Self {
            grid,
            target,
            model,
            ladder,
            records,
            orphans,
            crossings,
            lattice,
            index,
            points: Vec::new(),
        };
        if !h.crossings.is_empty() {
            h.points = h.crossing_map()?;
        }
        Ok(h)
    }

    /// The crossings by edge and level, from [`Isodiamonds::crossings`].
    fn crossing_map(&self) -> Result<Vec<Crossing>> {
        let edges = self.crossing_edges();
        if edges.len() != self.crossings.len() {
            return Err(Error::Isodiamonds(format!(
                "{} crossings stored for {} crossed edges",
                self.crossings.len(),
                edges.len()
            )));
        }
        let mut points: Vec<Crossing> = (edges.into_iter().zip(self.crossings.iter()))
            .map(|((i, j, level), &q)| Crossing { i, j, level, q })
            .collect();
        points.par_sort_unstable_by_key(Crossing::edge);
        Ok(points)
    }

    /// The crossed edges and levels `(i, j, level)` (grid indices `i < j`, level index), each once,
    /// in storage order: those of the root's active tetrahedra, then those of the active subdivided
    /// tetrahedra of every isodiamond split at some rung, in isodiamond order (§5.1: the leaves of
    /// any extraction are among these tetrahedra). An edge is listed where it first appears, not
    /// with the diamond that creates it: that one may be neither active nor creation (its
    /// tetrahedra through the edge may straddle a far face of the grid) and missing from an MI
    /// hierarchy.
    fn crossing_edges(&self) -> Vec<(u32, u32, u8)> {
        let lattice = &self.lattice;
        let active = |t: &Tet| self.target.active(t.map(|p| self.class(p)));
        let root = Diamond::root(lattice);
        let mut tets: Vec<Tet> = Vec::new();
        if self.index.contains_key(&key(lattice, root.center)) {
            tets.extend(root.tets(lattice).into_iter().filter(active));
        }
        let levels = self.target.class_levels();
        let mut seen = FxHashSet::default();
        let mut out = Vec::new();
        let mut add = |t: &Tet| {
            for (a, b) in [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)] {
                let (ca, cb) = (self.class(t[a]) as f64, self.class(t[b]) as f64);
                let (ia, ib) = (self.grid_index(t[a]), self.grid_index(t[b]));
                for (l, &level) in levels.iter().enumerate() {
                    let key = (ia.min(ib), ia.max(ib), l as u8);
                    if ((ca < level && cb > level) || (ca > level && cb < level))
                        && seen.insert(key)
                    {
                        out.push(key);
                    }
                }
            }
        };
        tets.iter().for_each(&mut add);
        for r in self.records.iter().filter(|r| r.split != 0) {
            let d = Diamond::new(point(lattice, r.key));
            for t in d.tets(lattice).iter().flat_map(bisect).filter(active) {
                add(&t);
            }
        }
        out
    }

    /// The point index of a grid point.
    fn grid_index(&self, p: IVec3) -> u32 {
        self.lattice.index(p) as u32
    }

    /// The class of a lattice point ([`NONE`] outside the grid or not listed): its isodiamond's,
    /// or its orphan class.
    fn class(&self, p: IVec3) -> u8 {
        if !self.lattice.in_domain(p) {
            return NONE;
        }
        match self.index.get(&key(&self.lattice, p)) {
            Some(&r) => self.records[r as usize].class,
            None => {
                let k = key(&self.lattice, p);
                (self.orphans.binary_search_by_key(&k, |o| o.0)).map_or(NONE, |o| self.orphans[o].1)
            }
        }
    }

    /// Whether stored isodiamond `d` is split at `rung` (`None`: not stored).
    fn split(&self, d: Diamond, rung: usize) -> Option<bool> {
        let r = self.index.get(&key(&self.lattice, d.center))?;
        Some(self.records[*r as usize].split >> rung & 1 == 1)
    }

    /// What the hierarchy encodes.
    pub fn target(&self) -> Target {
        self.target
    }

    /// RI or MI.
    pub fn model(&self) -> Model {
        self.model
    }

    /// The grid it was built on.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The rung tolerances, decreasing, the last 0.
    pub fn ladder(&self) -> &[f64] {
        &self.ladder
    }

    /// Bytes it holds in memory: the stored isodiamonds, orphan classes and crossings, and the
    /// lookups derived from them (hash tables at their capacity, one control byte per slot).
    pub fn memory_bytes(&self) -> usize {
        fn table<K, V>(map: &FxHashMap<K, V>) -> usize {
            map.capacity() * (std::mem::size_of::<(K, V)>() + 1)
        }
        self.records.capacity() * std::mem::size_of::<Record>()
            + self.orphans.capacity() * std::mem::size_of::<(u64, u8)>()
            + self.crossings.capacity()
            + table(&self.index)
            + self.points.capacity() * std::mem::size_of::<Crossing>()
    }

    /// What it stores.
    pub fn counts(&self) -> Counts {
        let of = |kind| self.records.iter().filter(|r| r.kind == kind).count();
        Counts {
            active: of(ACTIVE),
            creation: of(CREATION),
            relevant: of(RELEVANT),
            crossings: self.crossings.len(),
            orphans: self.orphans.len(),
        }
    }

    /// The rung a query at `tolerance` uses: the first whose tolerance is at most `tolerance`.
    pub fn rung(&self, tolerance: f64) -> Result<usize> {
        if !tolerance.is_finite() || tolerance < 0.0 {
            return Err(Error::Parameter(format!(
                "the tolerance must be a finite number ≥ 0 (got {tolerance})"
            )));
        }
        Ok(self
            .ladder
            .iter()
            .position(|&t| t <= tolerance)
            .expect("the last rung is 0"))
    }

    /// The leaves of the mesh at `rung` whose patch is not empty, with the classes of their
    /// vertices (module documentation): the active child tetrahedra of the isodiamonds split at
    /// `rung` whose own diamond is not split there, and the root's active tetrahedra when it is
    /// stored and not split. Read off the stored split set, each isodiamond on its own (in
    /// parallel, in isodiamond order), with no walk from the roots: a diamond that is not stored
    /// has no active child tetrahedron, nor a stored one none outside the mesh, since each rung's
    /// split set is the full hierarchy's (closed under parents). Classes and split bits come from a
    /// [`Isodiamonds::grid_table`] of the extraction (one byte per grid point while it runs).
    fn leaves(&self, rung: usize) -> Result<Vec<(Tet, [u8; 4])>> {
        let lattice = &self.lattice;
        let table = self.grid_table(rung)?;
        let class = |p: IVec3| {
            if lattice.in_domain(p) {
                table[lattice.index(p)] & CLASS_BITS
            } else {
                NONE
            }
        };
        let split = |d: Diamond| {
            if lattice.in_domain(d.center) {
                table[lattice.index(d.center)] & SPLIT_BIT != 0
            } else {
                self.split(d, rung) == Some(true)
            }
        };
        let mut out = Vec::new();
        let root = Diamond::root(lattice);
        if self.split(root, rung) == Some(false) {
            out.extend(
                (root.tets(lattice).into_iter())
                    .map(|t| (t, t.map(class)))
                    .filter(|(_, c)| self.target.active(*c)),
            );
        }
        let inner = (self.records.par_iter())
            .filter(|r| r.split >> rung & 1 == 1)
            .flat_map_iter(|r| {
                let d = Diamond::new(point(lattice, r.key));
                let mut leaves: ArrayVec<(Tet, [u8; 4]), 16> = ArrayVec::new();
                for t in d.tets(lattice) {
                    let ct = t.map(class);
                    for (first, child) in [true, false].into_iter().zip(bisect(&t)) {
                        let kept = ct[if first { 0 } else { 1 }];
                        let c = child_of(&t, first, ct, kept, r.class);
                        if self.target.active(c) && !Diamond::of_tet(&child).is_some_and(split) {
                            leaves.push((child, c));
                        }
                    }
                }
                leaves
            });
        out.par_extend(inner);
        Ok(out)
    }

    /// One byte per grid point for an extraction at `rung`: the class of the point (bits
    /// [`CLASS_BITS`], [`NONE`] when neither its isodiamond nor an orphan class is stored) and
    /// [`SPLIT_BIT`] when its isodiamond is stored and split at `rung`. Looked up by index where
    /// [`Isodiamonds::class`] and [`Isodiamonds::split`] search the hash table.
    fn grid_table(&self, rung: usize) -> Result<Vec<u8>> {
        let mut table = memory::filled(self.grid.len(), NONE, "the isodiamond extraction")?;
        for r in &self.records {
            let p = point(&self.lattice, r.key);
            if self.lattice.in_domain(p) {
                let split = if r.split >> rung & 1 == 1 {
                    SPLIT_BIT
                } else {
                    0
                };
                table[self.lattice.index(p)] = r.class | split;
            }
        }
        for &(k, c) in &self.orphans {
            table[self.lattice.index(point(&self.lattice, k))] = c;
        }
        Ok(table)
    }

    /// The world position of a grid point.
    fn world(&self, i: u32) -> DVec3 {
        DVec3::from(self.grid.point(self.grid.ijk(i as usize)))
    }

    /// The position of the crossing of edge `(i, j)` (`i < j`) at level index `l`.
    fn crossing(&self, i: u32, j: u32, l: u8) -> (DVec3, f64) {
        match self.crossing_index(i, j, l) {
            Some(k) => self.crossing_point(&self.points[k as usize]),
            None => self.position(i, j, 0.5),
        }
    }

    /// The place of the crossing of edge `(i, j)` (`i < j`) at level index `l` in
    /// [`Isodiamonds::points`].
    fn crossing_index(&self, i: u32, j: u32, l: u8) -> Option<u32> {
        let k = self.points.binary_search_by_key(&(i, j, l), Crossing::edge);
        k.ok().map(|k| k as u32)
    }

    /// A lookup of [`Isodiamonds::crossing_index`] for the many edges of one extraction.
    fn crossing_lookup(&self) -> CrossingLookup {
        let runs = (self.grid.len() >> CrossingLookup::RUN) + 1;
        let mut start = Vec::with_capacity(runs + 1);
        let mut k = 0;
        for run in 0..=runs {
            while k < self.points.len() && (self.points[k].i as usize) >> CrossingLookup::RUN < run
            {
                k += 1;
            }
            start.push(k as u32);
        }
        CrossingLookup {
            keys: (self.points.iter())
                .map(|c| CrossingLookup::key(c.i, c.j, c.level))
                .collect(),
            start,
        }
    }

    /// The position of a stored crossing and its weight along the edge.
    fn crossing_point(&self, c: &Crossing) -> (DVec3, f64) {
        self.position(c.i, c.j, dequantise(c.q))
    }

    /// The point at `t` along edge `(i, j)` from `i`, and `t`.
    fn position(&self, i: u32, j: u32, t: f64) -> (DVec3, f64) {
        let (a, b) = (self.world(i), self.world(j));
        (a + t * (b - a), t)
    }

    /// The isosurface at `tolerance` (at the rung [`Isodiamonds::rung`] picks): marching tetrahedra
    /// on the leaves, as [`crate::isosurface::extract`] draws it at that rung (same triangles on the
    /// same edges; points within 1/512 of their edge). No normals; [`IsoSurface::error_bound`] is
    /// the rung's tolerance (the full hierarchy's bound there).
    pub fn isosurface(&self, tolerance: f64) -> Result<IsoSurface> {
        self.isosurface_at(self.rung(tolerance)?)
    }

    /// [`Isodiamonds::isosurface`] at `rung`.
    fn isosurface_at(&self, rung: usize) -> Result<IsoSurface> {
        let Target::Isosurface(_) = self.target else {
            return Err(Error::Parameter(
                "this isodiamond hierarchy encodes an interval volume, not an isosurface".into(),
            ));
        };
        let (leaves, classes): (Vec<Tet>, Vec<[u8; 4]>) = self.leaves(rung)?.into_iter().unzip();
        // Straight from the stored crossings unless a vertex holds the isovalue (then points join
        // at samples, as marching tetrahedra on the values joins them).
        let lookup = self.crossing_lookup();
        let listed = marching_on_listed_edges(
            &leaves,
            self.target.class_levels(),
            |k, _| classes[k].map(f64::from),
            |p| self.grid_index(p),
            self.points.len(),
            |(i, j, l)| lookup.find(i, j, l as u8),
        )?;
        let mut surface = match listed {
            Some((used, triangles)) => {
                let v = self.target.levels()[0];
                let crossings: Vec<(&Crossing, DVec3, f64)> = (used.par_iter())
                    .map(|&k| {
                        let c = &self.points[k as usize];
                        let (p, t) = self.crossing_point(c);
                        (c, p, t)
                    })
                    .collect();
                let (sources, weights) = crossings
                    .iter()
                    .map(|&(c, _, t)| source_weight(c.i, c.j, t))
                    .unzip();
                IsoSurface {
                    points: crossings.iter().map(|c| c.1.to_array()).collect(),
                    sources,
                    weights,
                    values: vec![v; used.len()],
                    triangles,
                    ..IsoSurface::default()
                }
            }
            None => marching_with_sources(&OnClasses(self), &leaves, false)?.0,
        };
        surface.error_bound = self.ladder[rung];
        Ok(surface)
    }

    /// The isosurface of `query` as a filter asks for it: its one isovalue must be this
    /// hierarchy's. [`Isodiamonds::isosurface`] at its tolerance; with a triangle budget, the
    /// finest rung at or above that tolerance whose surface fits (the coarsest rung, with a warning,
    /// when none does); with normals, those of the surface itself (the area-weighted mean of its
    /// triangles' normals at each point, toward increasing values: no field values are stored to
    /// take the gradient from). Refuses a region of interest and carrier tetrahedra.
    pub fn isosurface_query(&self, query: &IsoQuery) -> Result<IsoSurface> {
        let Target::Isosurface(v) = self.target else {
            return self.isosurface_at(0); // refused there
        };
        if query.isovalues.len() != 1 || query.isovalues[0].to_bits() != v.to_bits() {
            return Err(Error::Parameter(format!(
                "this isodiamond hierarchy encodes the isosurface {v}, not {:?}",
                query.isovalues
            )));
        }
        Self::refuse_unsupported(query.region_of_interest.is_some(), query.carrier_tetrahedra)?;
        let (mut surface, warning) = self.within_budget(
            query.tolerance,
            query.max_triangles,
            |rung| self.isosurface_at(rung),
            |s| s.triangles.len(),
        )?;
        surface.warnings.extend(warning);
        surface.warnings.extend(self.empty_warning());
        if query.compute_normals {
            surface.normals = area_weighted_normals(&surface.points, &surface.triangles);
        }
        Ok(surface)
    }

    /// The interval volume of `query` as a filter asks for it: its range must be this hierarchy's.
    /// [`Isodiamonds::interval_volume`] at its tolerance; with a tetrahedron budget, the finest rung
    /// at or above that tolerance whose volume fits (the coarsest rung, with a warning, when none
    /// does), as [`crate::interval::extract`] raises the tolerance. Refuses a region of interest.
    pub fn interval_volume_query(&self, query: &IntervalQuery) -> Result<IntervalVolume> {
        let Target::IntervalVolume(range) = self.target else {
            return self.interval_volume_at(0); // refused there
        };
        if query.range.map(f64::to_bits) != range.map(f64::to_bits) {
            return Err(Error::Parameter(format!(
                "this isodiamond hierarchy encodes the interval volume {range:?}, not {:?}",
                query.range
            )));
        }
        Self::refuse_unsupported(query.region_of_interest.is_some(), false)?;
        let (mut volume, warning) = self.within_budget(
            query.tolerance,
            query.max_tetrahedra,
            |rung| self.interval_volume_at(rung),
            |v| v.tets.len(),
        )?;
        volume.warnings.extend(warning);
        volume.warnings.extend(self.empty_warning());
        Ok(volume)
    }

    /// A warning when the hierarchy stores no isodiamond: no tetrahedron at any resolution has a
    /// patch, i.e. the isovalue or range misses the samples (as the full hierarchy's queries warn;
    /// the data range itself is not stored).
    fn empty_warning(&self) -> Option<String> {
        let what = match self.target {
            Target::Isosurface(v) => format!("the isovalue {v}"),
            Target::IntervalVolume([a, b]) => format!("the range [{a}, {b}]"),
        };
        self.records.is_empty().then(|| {
            format!(
                "{what} misses the data range: the isodiamond hierarchy is empty, so is the output"
            )
        })
    }

    /// What isodiamond extraction does not offer (filters ask before building a hierarchy, so that
    /// the user does not wait for a build whose extraction is refused). A region of interest: the full hierarchy's result
    /// for a box comes from its two-sided bound check inside the box, which reads the samples and
    /// splits according to the mesh the box makes ([`crate::isosurface`]); the stored split sets
    /// are the whole image's, without the samples, so they cannot reproduce it.
    pub fn refuse_unsupported(region: bool, carrier: bool) -> Result<()> {
        let (what, why) = if region {
            ("a region of interest", "it stores the whole image's split set per rung of its ladder, not the samples the full hierarchy's bound check reads inside the region")
        } else if carrier {
            (
                "carrier tetrahedra",
                "it stores one split set per rung of its ladder, for the whole image",
            )
        } else {
            return Ok(());
        };
        Err(Error::Parameter(format!(
            "{what} is not available with an isodiamond hierarchy ({why}): use the full hierarchy"
        )))
    }

    /// `extract` at the rung of `tolerance`, or with a `budget` (> 0) at the finest rung from there
    /// toward the coarsest whose result's `size` fits, with a warning when even the coarsest does
    /// not.
    fn within_budget<R>(
        &self,
        tolerance: f64,
        budget: usize,
        extract: impl Fn(usize) -> Result<R>,
        size: impl Fn(&R) -> usize,
    ) -> Result<(R, Option<String>)> {
        let mut rung = self.rung(tolerance)?;
        loop {
            let out = extract(rung)?;
            if budget == 0 || size(&out) <= budget {
                return Ok((out, None));
            }
            if rung == 0 {
                let warning = format!(
                    "the budget of {budget} cannot be met: the coarsest rung of the isodiamond hierarchy (tolerance {}) gives {}",
                    self.ladder[0],
                    size(&out)
                );
                return Ok((out, Some(warning)));
            }
            rung -= 1;
        }
    }

    /// The interval volume at `tolerance` (at the rung [`Isodiamonds::rung`] picks): every leaf
    /// clipped as [`crate::interval::extract`] clips it at that rung (same tetrahedra on the same
    /// points; new points within 1/512 of their edge). `values` is empty (no field values are
    /// stored); `error_bound` and `tolerance` are the rung's.
    pub fn interval_volume(&self, tolerance: f64) -> Result<IntervalVolume> {
        self.interval_volume_at(self.rung(tolerance)?)
    }

    /// [`Isodiamonds::interval_volume`] at `rung`: the leaves clipped as [`interval::assemble`]
    /// clips and numbers them, but straight from the stored crossings (already in name order):
    /// each leaf's points are found once among them or marked in a bit set of the grid (samples),
    /// and the two merged in name order, with no sort.
    fn interval_volume_at(&self, rung: usize) -> Result<IntervalVolume> {
        let Target::IntervalVolume(range) = self.target else {
            return Err(Error::Parameter(
                "this isodiamond hierarchy encodes an isosurface, not an interval volume".into(),
            ));
        };
        const MISSING: u32 = u32::MAX;
        let lattice = self.lattice;
        let lookup = self.crossing_lookup();
        // Per run of leaves: the tetrahedra of their patches as slots (a sample's grid index, or
        // a crossing's place among the stored ones; bit `c` of `samples`: corner `c` is a
        // sample), their leaves' depths, the leaves that gave some.
        #[derive(Default)]
        struct Run {
            slots: Vec<[u32; 4]>,
            samples: Vec<u8>,
            depths: Vec<u8>,
            leaves: usize,
        }
        let runs: Vec<Run> = (self.leaves(rung)?.par_chunks(4096))
            .map(|chunk| {
                let mut run = Run::default();
                let mut patch = Vec::new();
                for (t, c) in chunk {
                    patch.clear();
                    clip(
                        t.map(|p| self.grid_index(p)),
                        c.map(f64::from),
                        [1.0, 3.0],
                        &mut patch,
                    );
                    if patch.is_empty() {
                        continue;
                    }
                    run.leaves += 1;
                    let depth = interval::depth(&lattice, t);
                    let mut found: ArrayVec<((u32, u32, u8), u32), 16> = ArrayVec::new();
                    for tet in &patch {
                        let mut samples = 0;
                        run.slots.push(std::array::from_fn(|corner| {
                            let (i, j, level) = tet[corner];
                            if level == SAMPLE {
                                samples |= 1 << corner;
                                return i;
                            }
                            let edge = (i, j, level - ALPHA);
                            if let Some(f) = found.iter().find(|f| f.0 == edge) {
                                return f.1;
                            }
                            let k = lookup.find(i, j, level - ALPHA).unwrap_or(MISSING);
                            let _ = found.try_push((edge, k));
                            k
                        }));
                        run.samples.push(samples);
                        run.depths.push(depth);
                    }
                }
                run
            })
            .collect();
        let n: usize = runs.iter().map(|r| r.slots.len()).sum();
        let mut slots: Vec<[u32; 4]> = memory::with_capacity(n, "the interval volume tetrahedra")?;
        let mut kinds: Vec<u8> = memory::with_capacity(n, "the interval volume tetrahedra")?;
        let mut levels: Vec<u8> = memory::with_capacity(n, "the interval volume levels")?;
        let mut leaves = 0;
        for run in runs {
            slots.extend(run.slots);
            kinds.extend(run.samples);
            levels.extend(run.depths);
            leaves += run.leaves;
        }
        // The samples and crossings used.
        let mut samples = memory::filled(
            self.grid.len().div_ceil(64),
            0u64,
            "the interval volume points",
        )?;
        let mut crossing_id =
            memory::filled(self.points.len(), MISSING, "the interval volume points")?;
        for (t, &kind) in slots.iter().zip(&kinds) {
            for (c, &s) in t.iter().enumerate() {
                if kind >> c & 1 == 1 {
                    samples[s as usize / 64] |= 1 << (s % 64);
                } else if s == MISSING {
                    return Err(Error::Isodiamonds(
                        "a crossed edge of a leaf has no stored crossing".into(),
                    ));
                } else {
                    crossing_id[s as usize] = 0;
                }
            }
        }
        // The point names in name order: the edge points from lower samples, then each sample,
        // then its own edge points. A sample's point is found by its rank among the used ones
        // (those in the words before it, and in its word below it).
        let mut rank = Vec::with_capacity(samples.len());
        let mut used = 0u32;
        for w in &samples {
            rank.push(used);
            used += w.count_ones();
        }
        let sample_rank = |i: u32| {
            let (w, b) = (i as usize / 64, i % 64);
            rank[w] + (samples[w] & ((1u64 << b) - 1)).count_ones()
        };
        let mut sample_id = Vec::with_capacity(used as usize);
        let mut keys: Vec<PointKey> = Vec::new();
        let mut k = 0;
        let mut crossings_below = |keys: &mut Vec<PointKey>, end: u32| {
            while k < self.points.len() && self.points[k].i < end {
                if crossing_id[k] != MISSING {
                    crossing_id[k] = keys.len() as u32;
                    let c = self.points[k];
                    keys.push((c.i, c.j, c.level + ALPHA));
                }
                k += 1;
            }
        };
        for (w, &word) in samples.iter().enumerate() {
            let mut bits = word;
            while bits != 0 {
                let i = (64 * w) as u32 + bits.trailing_zeros();
                bits &= bits - 1;
                crossings_below(&mut keys, i);
                sample_id.push(keys.len() as u32);
                keys.push((i, i, SAMPLE));
            }
        }
        crossings_below(&mut keys, u32::MAX);
        (slots.par_iter_mut().zip(&kinds)).for_each(|(t, &kind)| {
            for (c, s) in t.iter_mut().enumerate() {
                *s = if kind >> c & 1 == 1 {
                    sample_id[sample_rank(*s) as usize]
                } else {
                    crossing_id[*s as usize]
                };
            }
        });
        let place = |(i, j, level): PointKey| {
            if level == SAMPLE {
                return (self.world(i), 0.0, 0.0);
            }
            let (p, w) = self.crossing(i, j, level - ALPHA);
            (p, w, range[(level - ALPHA) as usize])
        };
        let mut result = interval::assemble_numbered(&keys, slots, levels, leaves, place)?;
        result.values = Vec::new();
        result.tolerance = self.ladder[rung];
        result.error_bound = self.ladder[rung];
        Ok(result)
    }
}

/// Where the crossings whose lower end lies in each run of 2^[`CrossingLookup::RUN`] grid indices
/// begin among the sorted crossings, and the crossings as one number each ([`CrossingLookup::key`],
/// in the same order): an edge is looked for among the few of its run.
struct CrossingLookup {
    keys: Vec<u64>,
    start: Vec<u32>,
}

impl CrossingLookup {
    const RUN: usize = 4;

    /// Edge `(i, j)` and level index `l` as one number, ordered as [`Crossing::edge`].
    fn key(i: u32, j: u32, l: u8) -> u64 {
        (i as u64) << 33 | (j as u64) << 1 | l as u64
    }

    /// [`Isodiamonds::crossing_index`].
    fn find(&self, i: u32, j: u32, l: u8) -> Option<u32> {
        let run = i as usize >> Self::RUN;
        let (a, b) = (self.start[run] as usize, self.start[run + 1] as usize);
        let key = Self::key(i, j, l);
        (self.keys[a..b].iter())
            .position(|&k| k == key)
            .map(|k| (a + k) as u32)
    }
}

/// Unit point normals of a surface: at each point the sum of its triangles' normals weighted by
/// their areas (the cross product of two edges), so they point where the triangles do; a point
/// whose triangles are all degenerate gets no direction (zero).
fn area_weighted_normals(points: &[[f64; 3]], triangles: &[[u32; 3]]) -> Vec<[f32; 3]> {
    let mut sums = vec![DVec3::ZERO; points.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| DVec3::from(points[i as usize]));
        let n = (b - a).cross(c - a);
        for &i in t {
            sums[i as usize] += n;
        }
    }
    sums.iter()
        .map(|n| n.normalize_or_zero().as_vec3().to_array())
        .collect()
}

/// Marching tetrahedra on the classes of an isosurface hierarchy: the same polygons as on the
/// values (the classes compare with 1 as the values with the isovalue), points at the crossings.
struct OnClasses<'a>(&'a Isodiamonds);

impl Marching for OnClasses<'_> {
    fn levels(&self) -> &[f64] {
        self.0.target.class_levels()
    }

    fn values(&self, t: &Tet) -> [f64; 4] {
        t.map(|p| self.0.class(p) as f64)
    }

    fn index(&self, p: IVec3) -> u32 {
        self.0.grid_index(p)
    }

    fn point(&self, (ia, ib, l): EdgeKey, _: bool) -> EdgePoint {
        let h = self.0;
        let at = |i: u32| h.class(h.lattice.point(i as usize)) == 1;
        // An end that holds the isovalue is the point, as on the values.
        let (position, weight) = if at(ib) {
            (h.world(ib), 1.0)
        } else if at(ia) {
            (h.world(ia), 0.0)
        } else {
            h.crossing(ia, ib, l as u8)
        };
        EdgePoint {
            position,
            weight,
            value: h.target.levels()[l as usize],
            normal: None,
        }
    }

    fn tet_normal(&self, t: &Tet) -> DVec3 {
        let p = t.map(|q| self.0.world(self.0.grid_index(q)));
        let f = self.values(t);
        let m = DMat3::from_cols(p[1] - p[0], p[2] - p[0], p[3] - p[0]);
        (m.transpose().inverse() * DVec3::new(f[1] - f[0], f[2] - f[0], f[3] - f[0]))
            .normalize_or_zero()
    }
}
