//! View-dependent refinement with a split queue and a merge queue and frame coherence (Gregorski
//! §4, §8; Marchesin §5).
//!
//! The current mesh is a closed split set. Its *split queue* holds the diamonds with tetrahedra in
//! the mesh (unsplit, with a split parent, or the root); its *merge queue* the split diamonds whose
//! children are all unsplit, outside the base mesh. Each frame recomputes the view error of every
//! queued diamond for the new camera (Gregorski §4, step 1) and starts from the previous frame's
//! mesh: it splits (with closure) the diamonds above the working tolerance `τ` and merges those at or
//! below it, largest split error and smallest merge error first, starting with `τ` = the tolerance.
//! Under a tetrahedron budget `τ` rises: when the mesh holds more tetrahedra than the budget, to
//! the smallest merge error; when the largest split would not fit, to that split's error, or to the
//! smallest merge error if that is smaller (merging it makes room). `τ` never falls within a frame,
//! so every diamond is split or merged at most once per frame.
//!
//! **Uniqueness.** The view error never grows from a diamond to its children ([`super::error`]),
//! so the diamonds above any `τ` form a closed set `U(τ)`. A frame ends when no split diamond
//! outside the base mesh is at or below `τ` (the smallest such error is a merge candidate's) and no
//! diamond with tetrahedra is above it: the mesh is then exactly `base ∪ U(τ)`. Each rise keeps `τ`
//! at most `τ* = min { τ ≥ tolerance : base ∪ U(τ) fits the budget }` (every `U(τ')` below it holds
//! the current mesh and the diamond that did not fit), and the end state fits, so `τ = τ*`: the
//! mesh of a frame is `base ∪ U(τ*)` of its view, whatever mesh it started from — the fresh
//! refinement ([`ViewState::new`] then one [`ViewState::update`]), tested. A budget below the base
//! mesh yields the base mesh.
//!
//! Gregorski's queues are bucketed hash tables; a budget needs the largest split error and the
//! smallest merge error, so ours are binary heaps with lazy deletion, beside hash sets of the
//! queued diamonds.

use super::error::{Camera, Metric, View, ViewErrors};
use crate::diamond::Diamond;
use crate::lattice::Placement;
use crate::mesh::MeshPlan;
use crate::refine::{Refiner, SplitSet};
use crate::{Error, Hierarchy, Result};
use rayon::prelude::*;
use rustc_hash::FxHashSet;
use std::cmp::{Ordering, Reverse};
use std::collections::BinaryHeap;
use std::time::Instant;

/// One frame's request.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewQuery {
    pub camera: Camera,
    pub metric: Metric,
    /// View-dependent tolerance in the metric's unit (pixels for [`Metric::ScreenSpace`]), ≥ 0.
    pub tolerance: f64,
    /// Maximum number of tetrahedra, 0 = no limit.
    pub max_tetrahedra: usize,
}

/// What one frame did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameStats {
    /// Diamonds split and merged this frame.
    pub splits: usize,
    pub merges: usize,
    /// Tetrahedra of the mesh after the frame.
    pub tets: usize,
    /// The tolerance reached (`τ*`: above the asked one when the budget bound).
    pub tolerance: f64,
    /// Diamonds whose view error was evaluated (the two queues at the start, then new entries).
    pub evaluated: usize,
    /// Split and merge queues after the frame.
    pub split_queue: usize,
    pub merge_queue: usize,
    /// Wall-clock seconds of the update.
    pub seconds: f64,
}

/// A queue entry: a diamond and its view error this frame.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Entry(f64, Diamond);

impl Eq for Entry {}

impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        let key = |d: Diamond| (d.center.x, d.center.y, d.center.z);
        self.0
            .total_cmp(&other.0)
            .then_with(|| key(self.1).cmp(&key(other.1)))
    }
}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// The view-dependent mesh kept between frames: its split set and its two queues.
#[derive(Clone, Debug)]
pub struct ViewState {
    split: SplitSet,
    tets: usize,
    /// The split queue's diamonds.
    leaves: FxHashSet<Diamond>,
    /// The merge queue's diamonds.
    mergeable: FxHashSet<Diamond>,
}

/// The working state of one frame.
struct Frame<'a> {
    state: &'a mut ViewState,
    hierarchy: &'a Hierarchy,
    error: &'a (dyn Fn(Diamond) -> f64 + Sync),
    split_queue: BinaryHeap<Entry>,
    merge_queue: BinaryHeap<Reverse<Entry>>,
    stats: FrameStats,
}

impl ViewState {
    /// The base mesh of `hierarchy`, where a fresh refinement starts.
    pub fn new(hierarchy: &Hierarchy) -> Self {
        let base = hierarchy.base();
        Self {
            split: base.split.clone(),
            tets: base.tets,
            leaves: base.candidates.iter().copied().collect(),
            mergeable: FxHashSet::default(),
        }
    }

    /// Number of tetrahedra of the current mesh.
    pub fn tets(&self) -> usize {
        self.tets
    }

    /// The current split set.
    pub fn split_set(&self) -> &SplitSet {
        &self.split
    }

    /// The current mesh, counted, ready to be written ([`MeshPlan`]).
    pub fn plan(&self) -> Result<MeshPlan> {
        MeshPlan::new(self.split.lattice(), self.split.clone())
    }

    /// Refines and coarsens the current mesh of `hierarchy` for `query` (see the module's
    /// documentation); `errors` are the nested bounds of the same hierarchy.
    pub fn update(
        &mut self,
        hierarchy: &Hierarchy,
        errors: &ViewErrors,
        query: &ViewQuery,
    ) -> Result<FrameStats> {
        let start = Instant::now();
        if errors.lattice() != hierarchy.lattice() || self.split.lattice() != hierarchy.lattice() {
            return Err(Error::Parameter(
                "the view state or its error bounds belong to another hierarchy".into(),
            ));
        }
        if !query.tolerance.is_finite() || query.tolerance < 0.0 {
            return Err(Error::Parameter(format!(
                "the view-dependent tolerance must be a finite number ≥ 0 (got {})",
                query.tolerance
            )));
        }
        let view = View::new(&query.camera, errors, query.metric)?;
        let error = |d: Diamond| view.error(d, errors.subtree_error(d));
        let mut frame = Frame::new(self, hierarchy, &error);
        frame.run(query.tolerance, query.max_tetrahedra);
        let mut stats = frame.stats;
        stats.tets = self.tets;
        stats.split_queue = self.leaves.len();
        stats.merge_queue = self.mergeable.len();
        stats.seconds = start.elapsed().as_secs_f64();
        Ok(stats)
    }
}

impl<'a> Frame<'a> {
    /// Both queues with every queued diamond's error for this view (evaluated in parallel).
    fn new(
        state: &'a mut ViewState,
        hierarchy: &'a Hierarchy,
        error: &'a (dyn Fn(Diamond) -> f64 + Sync),
    ) -> Self {
        let leaves: Vec<Entry> = state
            .leaves
            .par_iter()
            .map(|&d| Entry(error(d), d))
            .collect();
        let merges: Vec<Reverse<Entry>> = state
            .mergeable
            .par_iter()
            .map(|&d| Reverse(Entry(error(d), d)))
            .collect();
        let stats = FrameStats {
            evaluated: leaves.len() + merges.len(),
            ..FrameStats::default()
        };
        Self {
            state,
            hierarchy,
            error,
            split_queue: leaves.into(),
            merge_queue: merges.into(),
            stats,
        }
    }

    /// The split queue's largest entry still queued.
    fn split_top(&mut self) -> Option<Entry> {
        while let Some(&top) = self.split_queue.peek() {
            if self.state.leaves.contains(&top.1) {
                return Some(top);
            }
            self.split_queue.pop();
        }
        None
    }

    /// The merge queue's smallest entry still queued.
    fn merge_top(&mut self) -> Option<Entry> {
        while let Some(&Reverse(top)) = self.merge_queue.peek() {
            if self.state.mergeable.contains(&top.1) {
                return Some(top);
            }
            self.merge_queue.pop();
        }
        None
    }

    /// Splits and merges until the mesh is `base ∪ U(τ*)` (the module's documentation).
    fn run(&mut self, tolerance: f64, budget: usize) {
        let over = |tets: usize| budget > 0 && tets > budget;
        let mut tau = tolerance;
        let mut order = Vec::new();
        loop {
            let merge = self.merge_top();
            if let Some(m) = merge.filter(|m| m.0 <= tau) {
                self.merge(m.1);
                continue;
            }
            if over(self.state.tets) {
                match merge {
                    Some(m) => tau = m.0,
                    None => break, // the base mesh is over the budget
                }
                continue;
            }
            let Some(s) = self.split_top().filter(|s| s.0 > tau) else {
                break;
            };
            let lattice = *self.state.split.lattice();
            Refiner::closure(&lattice, &self.state.split, s.1, &mut order);
            let added: usize = order
                .iter()
                .map(|&a| Refiner::inside_tets(&lattice, a))
                .sum();
            if !over(self.state.tets + added) {
                for &a in &order {
                    self.split(a);
                }
            } else {
                // τ* ≥ the smaller of the two: every mesh below it holds this one and s.
                tau = merge.map_or(s.0, |m| m.0.min(s.0));
            }
        }
        self.stats.tolerance = tau;
    }

    /// Queues `d` for splitting when it has tetrahedra in the mesh.
    fn queue_leaf(&mut self, d: Diamond) {
        if self.state.leaves.insert(d) {
            self.split_queue.push(Entry((self.error)(d), d));
            self.stats.evaluated += 1;
        }
    }

    /// Queues `d` for merging.
    fn queue_mergeable(&mut self, d: Diamond) {
        if self.state.mergeable.insert(d) {
            self.merge_queue.push(Reverse(Entry((self.error)(d), d)));
            self.stats.evaluated += 1;
        }
    }

    /// Splits `d`, whose parents are split.
    fn split(&mut self, d: Diamond) {
        let lattice = *self.state.split.lattice();
        self.state.split.insert(d);
        self.state.tets += Refiner::inside_tets(&lattice, d);
        self.state.leaves.remove(&d);
        for p in d.parents(&lattice) {
            self.state.mergeable.remove(&p);
        }
        for c in d.children(&lattice) {
            if c.placement(&lattice) != Placement::Outside {
                self.queue_leaf(c);
            }
        }
        self.queue_mergeable(d);
        self.stats.splits += 1;
    }

    /// Merges `d`, a split diamond outside the base mesh whose children are unsplit.
    fn merge(&mut self, d: Diamond) {
        let lattice = *self.state.split.lattice();
        let base = &self.hierarchy.base().split;
        self.state.split.remove(d);
        self.state.tets -= Refiner::inside_tets(&lattice, d);
        self.state.mergeable.remove(&d);
        for c in d.children(&lattice) {
            if !c
                .parents(&lattice)
                .iter()
                .any(|&p| self.state.split.contains(p))
            {
                self.state.leaves.remove(&c);
            }
        }
        for p in d.parents(&lattice) {
            let free = !p
                .children(&lattice)
                .iter()
                .any(|&c| self.state.split.contains(c));
            if free && self.state.split.contains(p) && !base.contains(p) {
                self.queue_mergeable(p);
            }
        }
        self.queue_leaf(d);
        self.stats.merges += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fields::marschner_lobb_u8;
    use crate::validate::{check_back_to_front, check_mesh};
    use crate::view::{BspTree, Direction};
    use crate::{Query, ScalarSlice, TetMesh};
    use std::collections::HashSet;

    fn setup(dims: [usize; 3]) -> (Hierarchy, ViewErrors) {
        let (g, v) = marschner_lobb_u8(dims);
        let h = Hierarchy::build(g, ScalarSlice::U8(&v), &mut |_| true).unwrap();
        let e = ViewErrors::new(&h).unwrap();
        (h, e)
    }

    /// A camera on a circle of `radius` around the z axis at `degrees`, `height` above the centre
    /// of the [-1, 1]³ volume, looking at `target`.
    fn orbit(degrees: f64, radius: f64, height: f64, target: [f64; 3]) -> Camera {
        let a = degrees.to_radians();
        Camera {
            position: [radius * a.cos(), radius * a.sin(), height],
            focal_point: target,
            view_up: [0.0, 0.0, 1.0],
            view_angle: 30.0,
            viewport: [400, 300],
        }
    }

    fn query(camera: Camera, tolerance: f64, max_tetrahedra: usize) -> ViewQuery {
        ViewQuery {
            camera,
            metric: Metric::ScreenSpace,
            tolerance,
            max_tetrahedra,
        }
    }

    fn fresh(h: &Hierarchy, e: &ViewErrors, q: &ViewQuery) -> (ViewState, FrameStats) {
        let mut state = ViewState::new(h);
        let stats = state.update(h, e, q).unwrap();
        (state, stats)
    }

    fn mesh(h: &Hierarchy, state: &ViewState) -> TetMesh {
        state
            .plan()
            .unwrap()
            .to_mesh(h.grid(), |d| h.error(d))
            .unwrap()
    }

    /// The tetrahedra of `mesh` by their grid points.
    fn leaves(mesh: &TetMesh) -> HashSet<[usize; 4]> {
        mesh.tets
            .iter()
            .map(|t| {
                let mut k = t.map(|i| mesh.point_ids[i as usize]);
                k.sort_unstable();
                k
            })
            .collect()
    }

    #[test]
    fn a_frame_is_the_threshold_mesh_of_its_view() {
        // Checked against the from-root refinement (Refiner::run, no queues) with the view error at
        // the tolerance the frame reached, and just below it for the budget.
        let (h, e) = setup([33, 33, 33]);
        let cameras = [
            orbit(30.0, 4.0, 1.0, [0.0; 3]),
            orbit(200.0, 2.2, -0.5, [0.3, 0.2, 0.0]),
            orbit(75.0, 0.3, 0.1, [1.0, 1.0, 0.0]), // inside
            orbit(0.0, 3.0, 0.0, [6.0, 0.0, 0.0]),  // looking away
        ];
        for camera in cameras {
            for (tolerance, budget) in [(2.0, 0), (0.5, 20_000), (0.0, 5_000), (1.0, 10)] {
                let q = query(camera, tolerance, budget);
                let (state, stats) = fresh(&h, &e, &q);
                let view = View::new(&camera, &e, q.metric).unwrap();
                let err = |d: Diamond| view.error(d, e.subtree_error(d));
                let at = |tau: f64| {
                    Refiner::run(h.grid(), h.base(), &Query::tolerance(tau), &err).unwrap()
                };
                let label = format!("{camera:?} {tolerance} {budget}");
                assert!(stats.tolerance >= tolerance, "{label}");
                assert_eq!(state.split_set(), &at(stats.tolerance), "{label}");
                let base = h.base_tetrahedra();
                if budget > 0 {
                    assert!(state.tets() <= budget.max(base), "{label}");
                }
                if stats.tolerance > tolerance && state.tets() > base {
                    // Any smaller tolerance would exceed the budget.
                    let below = at(stats.tolerance.next_down());
                    let tets = MeshPlan::new(h.lattice(), below).unwrap().tets();
                    assert!(tets > budget, "{label}: {tets} ≤ {budget}");
                }
                let m = mesh(&h, &state);
                assert_eq!(m.tets.len(), state.tets(), "{label}");
                check_mesh(&m, h.grid()).unwrap_or_else(|err| panic!("{label}: {err}"));
                let tree = BspTree::new(&state.plan().unwrap(), h.grid()).unwrap();
                let order = tree.order(camera.position, Direction::BackToFront).unwrap();
                check_back_to_front(&m.points, &m.tets, &order, camera.position)
                    .unwrap_or_else(|err| panic!("{label}: {err}"));
            }
        }
        // Culling: from the same place, looking away refines far less than looking at the volume.
        let toward = query(orbit(0.0, 3.0, 0.0, [0.0; 3]), 0.5, 0);
        let away = query(orbit(0.0, 3.0, 0.0, [6.0, 0.0, 0.0]), 0.5, 0);
        let (toward, away) = (fresh(&h, &e, &toward).0, fresh(&h, &e, &away).0);
        assert!(
            4 * away.tets() < toward.tets(),
            "{} vs {}",
            away.tets(),
            toward.tets()
        );
    }

    #[test]
    fn small_moves_change_little_and_give_the_fresh_mesh() {
        let (h, e) = setup([33, 33, 33]);
        for (tolerance, budget) in [(1.5, 0), (0.25, 15_000)] {
            let mut state = ViewState::new(&h);
            let first = query(orbit(0.0, 3.5, 0.8, [0.0; 3]), tolerance, budget);
            state.update(&h, &e, &first).unwrap();
            let mut previous = leaves(&mesh(&h, &state));
            let (mut splits, mut merges, mut worst) = (0, 0, 0.0f64);
            for step in 1..=20 {
                let q = query(orbit(step as f64, 3.5, 0.8, [0.0; 3]), tolerance, budget);
                let stats = state.update(&h, &e, &q).unwrap();
                let (reference, _) = fresh(&h, &e, &q);
                assert_eq!(state.split_set(), reference.split_set(), "step {step}");
                splits += stats.splits;
                merges += stats.merges;
                let now = leaves(&mesh(&h, &state));
                let changed = now.symmetric_difference(&previous).count();
                worst = worst.max(changed as f64 / now.len().max(previous.len()) as f64);
                previous = now;
            }
            assert!(splits > 0 && merges > 0, "the orbit changed nothing");
            assert!(
                worst < 0.1,
                "a 1° step changed {:.1} % of the tetrahedra",
                100.0 * worst
            );
        }
    }

    #[test]
    fn a_hundred_views_end_at_the_fresh_mesh_of_the_last() {
        let (h, e) = setup([25, 33, 17]);
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut state = ViewState::new(&h);
        let mut last = None;
        for frame in 0..100 {
            let target = [next() - 0.5, next() - 0.5, next() - 0.5];
            let radius = 0.2 + 4.0 * next();
            let camera = orbit(360.0 * next(), radius, 2.0 * next() - 1.0, target);
            let budget = [0, 2_000, 8_000, 30_000][frame % 4];
            let q = query(camera, 0.5 + 3.0 * next(), budget);
            state.update(&h, &e, &q).unwrap();
            last = Some(q);
        }
        let last = last.unwrap();
        let (reference, _) = fresh(&h, &e, &last);
        assert_eq!(state.split_set(), reference.split_set());
        check_mesh(&mesh(&h, &state), h.grid()).unwrap();
        // The mesh written in visibility order after the hundred frames (the representation's
        // path) is the fresh refinement's, in the same order, exact face by face.
        let eye = last.camera.position;
        let ordered = |s: &ViewState| {
            let mut plan = s.plan().unwrap();
            plan.set_visibility_order(h.grid(), eye, Direction::BackToFront)
                .unwrap();
            plan.to_mesh(h.grid(), |d| h.error(d)).unwrap()
        };
        let written = ordered(&state);
        assert!(written == ordered(&reference), "not the fresh mesh's order");
        let order: Vec<u32> = (0..written.tets.len() as u32).collect();
        check_back_to_front(&written.points, &written.tets, &order, eye).unwrap();
    }

    #[test]
    fn bad_queries_are_refused() {
        let (h, e) = setup([9, 9, 9]);
        let mut state = ViewState::new(&h);
        let good = query(orbit(10.0, 3.0, 0.0, [0.0; 3]), 1.0, 0);
        for tolerance in [f64::NAN, -1.0, f64::INFINITY] {
            assert!(state
                .update(&h, &e, &ViewQuery { tolerance, ..good })
                .is_err());
        }
        let mut zero = good;
        zero.camera.viewport = [640, 0];
        assert!(state.update(&h, &e, &zero).is_err());
        let (other, other_errors) = setup([9, 9, 17]);
        assert!(state.update(&other, &e, &good).is_err());
        assert!(state.update(&h, &other_errors, &good).is_err());
        assert_eq!(state.tets(), h.base_tetrahedra());
        assert!(state.update(&h, &e, &good).is_ok());
    }
}
