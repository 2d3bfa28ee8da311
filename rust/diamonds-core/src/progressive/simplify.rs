//! The reduction algorithm (§3.2): every vertex `p_i` offers its cheapest valid half-edge collapse
//! `hec(p_i → p_j)` to a priority queue ordered by the weighted cost of §3.3; the cheapest is made,
//! and the vertices whose star it changed offer theirs again, until the target is reached or no
//! collapse is left.
//!
//! **Field error.** The queue's field term is the paper's local estimate at `p_i` (Eq. 6, the
//! difference of the field at `p_i` before and after the collapse) raised to the largest error
//! already carried by the tetrahedra around `p_i`. Before a collapse is made its error is measured
//! *exactly*: every removed original vertex lying in the changed region (the star of `p_i`) is
//! located in the new tetrahedra and its error `|f(v) - L(v)|` recomputed; if that exceeds the queued
//! estimate the collapse goes back into the queue at its exact cost. So the reported error of every
//! level is the exact maximum over all removed original vertices, and the maximum field error stop
//! is exact. Each tetrahedron carries the removed vertices inside it.
//!
//! **Vertices outside the mesh.** Where the boundary moved (within the boundary tolerance), a removed
//! vertex can lie outside the simplified mesh; its error is then measured at the *nearest point of
//! the mesh* (on its boundary surface): `|f(v) - L(π(v))|`. The tetrahedron of that boundary face
//! carries it. A collapse that changes the boundary (`p_i` on it: the boundary surface undergoes the
//! edge collapse `p_i → p_j`) can bring a new face nearer to any outside vertex, not only to those
//! its star carries, so the current boundary faces ([`FaceIndex`]) and the outside vertices (each
//! with the ball reaching its nearest point) are kept in R-trees: the outside vertices whose ball
//! meets the new faces are measured again, and the tetrahedra they leave or join outside the
//! collapse's star are recorded in its split, so a replay keeps every tetrahedron's error.
//!
//! **Boundary.** Boundary vertices collapse only along boundary edges (§3.2); the geometric error is
//! the boundary quadric (Eq. 4). With `preserve_boundary`, corners stay, vertices of feature edges
//! move only along them, and every removed boundary vertex is kept within the boundary tolerance of
//! the boundary faces (carried like the field's vertices, by the tetrahedron of the nearest face).

use super::cost::{interpolate, shape_measure, Frame, Quadric};
use super::faces::{is_closer, BoundaryFace, FaceIndex};
use super::input::{Cleaned, Pinches};
use super::record::{LevelError, ProgressiveMesh, VertexSplit};
use super::validity::{feature_edges_at, is_feature_edge, link_condition_from_star, Link};
use super::{Params, TetInput};
use crate::geometry::{
    closest_point_on_triangle, orient2d_along, orient3d, point_triangle_distance, triangles_meet,
};
use crate::hierarchy::Progress;
use crate::{memory, Error, Result};
use glam::DVec3;
use priority_queue::PriorityQueue;
use rayon::prelude::*;
use rstar::primitives::{GeomWithData, Rectangle};
use rstar::{Envelope, PointDistance, RTree, RTreeObject};
use rustc_hash::{FxBuildHasher, FxHashSet};
use std::cmp::Ordering;

/// What the reduction was doing when memory ran out, for [`Error::OutOfMemory`].
const PREPARING: &str = "preparing the progressive mesh (vertex links, boundary, quadrics)";

/// A collapse cost in the queue: the lowest comes first.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Cost(f64);

impl Eq for Cost {}

impl Ord for Cost {
    fn cmp(&self, other: &Self) -> Ordering {
        other.0.total_cmp(&self.0)
    }
}

impl PartialOrd for Cost {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// The best collapse a vertex offers.
#[derive(Clone, Copy, Debug)]
struct Candidate {
    target: u32,
    /// The geometric and shape terms (weighted).
    base: f64,
    /// The whole cost with the field term.
    cost: f64,
    /// Whether the field term is the exact one (measured when the collapse was popped).
    exact: bool,
}

/// Where an original vertex lies on the boundary, for `preserve_boundary`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Interior,
    Surface,
    /// On exactly two feature edges.
    Crease,
    /// On one or more than two feature edges.
    Corner,
}

/// The non-negative errors of the removed vertices, one leaf per original vertex (0 while it is not
/// removed) of a flat max tree, with their sum of squares: setting one is `O(log n)` with no
/// allocation (collapses at coarse levels re-place hundreds of carried vertices each).
struct ErrorTree {
    /// Leaves at `leaves..2 * leaves`, node `k`'s children at `2k` and `2k + 1`.
    node: Vec<f64>,
    leaves: usize,
    sum_squares: f64,
}

impl ErrorTree {
    fn new(n: usize) -> Self {
        let leaves = n.max(1).next_power_of_two();
        Self {
            node: vec![0.0; 2 * leaves],
            leaves,
            sum_squares: 0.0,
        }
    }

    /// Sets the error of `v` to `e`; `old` is its error if it was already counted.
    fn set(&mut self, v: u32, old: Option<f64>, e: f64) {
        if let Some(o) = old {
            self.sum_squares -= o * o;
        }
        self.sum_squares += e * e;
        let mut k = self.leaves + v as usize;
        self.node[k] = e;
        while k > 1 {
            k /= 2;
            let m = self.node[2 * k].max(self.node[2 * k + 1]);
            if self.node[k] == m {
                break;
            }
            self.node[k] = m;
        }
    }

    fn max(&self) -> f64 {
        self.node[1]
    }

    fn rms(&self, n: usize) -> f64 {
        if n == 0 {
            0.0
        } else {
            (self.sum_squares.max(0.0) / n as f64).sqrt()
        }
    }
}

/// A removed original vertex placed in a tetrahedron, with its error there and, for the field, its
/// distance outside the mesh (0 inside).
#[derive(Clone, Copy, Debug)]
struct Placed {
    vertex: u32,
    tet: u32,
    error: f64,
    outside: f64,
}

/// Barycentric coordinates at least this far below 0 put a point outside a tetrahedron (rounding
/// puts points on a face either side of it).
const INSIDE: f64 = -1e-9;

/// A tetrahedron after a collapse: its index, corners and [`Frame`].
type Framed = (u32, [u32; 4], Frame);

/// The mesh after `hec(i → j)` as [`Simplifier::place_field`] needs it: the tetrahedra of `i`'s star
/// that stay (`new`), those around the edge (`removed`), the boundary faces at `j` replacing those at
/// `i` (`new_faces`).
#[derive(Clone, Copy)]
struct After<'a> {
    i: u32,
    new: &'a [Framed],
    removed: &'a [u32],
    new_faces: &'a [BoundaryFace],
}

/// An outside vertex in the R-tree of [`Simplifier::outside`]: the box around the ball reaching its
/// nearest point of the mesh.
type OutsideBall = GeomWithData<Rectangle<[f64; 3]>, u32>;

fn outside_ball(v: u32, p: DVec3, d: f64) -> OutsideBall {
    GeomWithData::new(
        Rectangle::from_corners((p - d).to_array(), (p + d).to_array()),
        v,
    )
}

/// What a collapse changes, measured before it is made.
struct Exact {
    removed: Vec<u32>,
    moved: Vec<u32>,
    field: Vec<Placed>,
    boundary: Vec<Placed>,
    max_field: f64,
    /// The boundary surface's edge collapse (`p_i` on the boundary): how many faces at `p_i` go, and
    /// the faces at `p_j` that replace them ([`Simplifier::faces_replacing`]).
    faces_gone: usize,
    new_faces: Vec<BoundaryFace>,
}

/// A tetrahedron around the vertex `i` that a collapse `hec(i → j)` moves, prepared for any `j`:
/// six times the moved tetrahedron's volume is `(p_j - o)·n` (it is affine in `p_j`), so a flipped
/// or flat result is refused after one dot product.
struct Around {
    corners: [u32; 4],
    /// The slot of `i` in `corners`.
    slot: usize,
    x: [DVec3; 4],
    o: DVec3,
    n: DVec3,
    /// The squared length of the longest edge not at `i`.
    fixed2: f64,
}

impl Around {
    fn new(corners: [u32; 4], i: u32, pos: &[DVec3]) -> Self {
        let slot = corners
            .iter()
            .position(|&v| v == i)
            .expect("i is a corner of its star");
        let x = corners.map(|v| pos[v as usize]);
        let [a, b, c] = [1, 2, 3].map(|d| x[(slot + d) % 4]);
        let n = (b - a).cross(c - a);
        // The sign that gives the tetrahedron's own (positive) volume at p_i.
        let n = if (x[slot] - a).dot(n) < 0.0 { -n } else { n };
        let fixed2 = a
            .distance_squared(b)
            .max(a.distance_squared(c))
            .max(b.distance_squared(c));
        Self {
            corners,
            slot,
            x,
            o: a,
            n,
            fixed2,
        }
    }

    /// Is the tetrahedron with `i` moved to `pj` proper: positively oriented, its volume above a
    /// millionth of a millionth of the cube of its longest edge (§3.2, no flipped or degenerate
    /// tetrahedra; the bound `validate::check_manifold_tets` checks)?
    #[inline]
    fn proper_at(&self, pj: DVec3) -> bool {
        let v = (pj - self.o).dot(self.n);
        // Flipped or flat: most refused targets, known before the edge lengths.
        if v <= 0.0 {
            return false;
        }
        let mut l2 = self.fixed2;
        for d in 1..4 {
            l2 = l2.max(pj.distance_squared(self.x[(self.slot + d) % 4]));
        }
        // `v` is six times the volume.
        v > 6e-12 * l2 * l2.sqrt()
    }

    /// With `i` moved to `pj` (a proper place, [`Self::proper_at`]): the barycentric coordinates
    /// of `pi` and the corners' positions (`None` if the volume still rounds to 0).
    #[inline]
    fn moved_to(&self, pj: DVec3, pi: DVec3) -> Option<([f64; 4], [DVec3; 4])> {
        let mut x = self.x;
        x[self.slot] = pj;
        Some((Frame::of(&x)?.0.barycentric(pi), x))
    }
}

/// The state of the reduction.
struct Simplifier {
    params: Params,
    pos: Vec<DVec3>,
    f: Vec<f64>,
    tets: Vec<[u32; 4]>,
    alive: Vec<bool>,
    /// The live tetrahedra around each vertex.
    star: Vec<Vec<u32>>,
    removed: Vec<bool>,
    /// Points no collapse removes ([`Reduction::keeping`]).
    kept: Vec<bool>,
    kind: Vec<Kind>,
    quadric: Vec<Quadric>,
    /// Removed original vertices inside each tetrahedron (field error) and nearest to one of its
    /// boundary faces (boundary distance, with `preserve_boundary`).
    field_bins: Vec<Vec<u32>>,
    boundary_bins: Vec<Vec<u32>>,
    /// The largest field error carried by each tetrahedron.
    tet_max: Vec<f64>,
    field_error: Vec<f64>,
    /// The tetrahedron carrying each removed vertex's field error, and its distance outside the mesh
    /// (0 inside).
    home: Vec<u32>,
    outside_distance: Vec<f64>,
    /// The boundary faces of the current boundary surface, among the dead ones of earlier surfaces
    /// ([`BoundaryFace::is_live`]), and the removed vertices outside the mesh.
    faces: FaceIndex,
    /// The live faces of [`Self::faces`] by their (sorted) corners: whether a face is on the
    /// boundary without counting the tetrahedra around it.
    live_faces: FxHashSet<[u32; 3]>,
    outside: RTree<OutsideBall>,
    boundary_distance: Vec<f64>,
    field_set: ErrorTree,
    boundary_set: ErrorTree,
    /// Normalisations of Eq. 2's terms: squared diagonal and squared value range.
    diagonal2: f64,
    range2: f64,
    queue: PriorityQueue<u32, Cost, FxBuildHasher>,
    offer: Vec<Option<Candidate>>,
    /// Vertices whose star changed since their offer, or queued at an estimate
    /// ([`Simplifier::estimate_all`]): re-evaluated when they come out of the queue (lazy updates:
    /// a vertex's star usually changes several times before its turn).
    dirty: Vec<bool>,
    /// Collapses made so far, and for each vertex how many had been made when its offer was.
    made: usize,
    offered_at: Vec<usize>,
    live: usize,
    removed_count: usize,
    /// The measures of the collapses requeued at their exact cost since the last collapse (vertex,
    /// target, measure): a collapse popped again before any other is made needs no new measure
    /// (about a third of the requeued ones on the blunt fin).
    measured: Vec<(u32, u32, Exact)>,
}

/// The face of `c` without its corner `skip`, in `c`'s order.
fn face(c: [u32; 4], skip: usize) -> [u32; 3] {
    std::array::from_fn(|k| c[if k < skip { k } else { k + 1 }])
}

/// [`face`] with its corners sorted.
fn sorted_face(c: [u32; 4], skip: usize) -> [u32; 3] {
    let mut f = face(c, skip);
    f.sort_unstable();
    f
}

/// Simplifies `input` by half-edge collapses (§3.2) until `params.target_tets` is reached or no valid
/// collapse within `params.max_field_error` is left, and records the result as a progressive mesh:
/// [`Reduction::new`] then [`Reduction::reduce_to`]. `progress` is called on the calling thread;
/// returning `false` aborts with [`Error::Aborted`].
pub fn simplify(
    input: TetInput<'_>,
    params: &Params,
    progress: Progress<'_>,
) -> Result<ProgressiveMesh> {
    let mut reduction = Reduction::new(input, params)?;
    reduction.reduce_to(params.target_tets, progress)?;
    Ok(reduction.into_mesh())
}

/// A reduction under way: the progressive mesh of the collapses made so far and the state that makes
/// the next ones (mesh, priority queue, carried vertices). [`Reduction::reduce_to`] goes only as far
/// as asked and a later call continues the *same* sequence, so a user who asks for 90 % pays for 90 %,
/// and the sequence, reached in any number of steps, is the one a single run makes (the queue and
/// every offer are kept; nothing depends on where a step stopped). The new collapses go below the
/// base mesh: the levels already made keep their meshes, numbered `added` higher
/// ([`Replay::rebase`](super::Replay::rebase)).
pub struct Reduction {
    s: Simplifier,
    pm: ProgressiveMesh,
    exhausted: bool,
    /// How the simplifier's points map to the input's (copies of the pinch points).
    pinches: Pinches,
}

impl Reduction {
    /// Checks and cleans `input` and prepares the reduction (boundary, quadrics, every vertex's
    /// estimated offer); no collapse is made. `params.target_tets` is not used (see
    /// [`Self::reduce_to`]); `params.max_field_error` holds for every step.
    pub fn new(input: TetInput<'_>, params: &Params) -> Result<Self> {
        Self::keeping(input, params, &[])
    }

    /// [`Self::new`] for a reduction that never removes the points `kept`: for a piece of a
    /// distributed mesh, its [`TetInput::seam_points`], so that the pieces reduced apart stay
    /// conforming together (no collapse changes a face between two pieces: such a face has only
    /// seam points, and a collapse changes only the faces at the point it removes).
    pub fn keeping(input: TetInput<'_>, params: &Params, kept: &[u32]) -> Result<Self> {
        params.check()?;
        if let Some(v) = kept.iter().find(|&&v| v as usize >= input.points.len()) {
            return Err(Error::Parameter(format!(
                "point {v} is to be kept, but the mesh has {} points",
                input.points.len()
            )));
        }
        // The simplifier works on the mesh cut at its pinches (the copies after the input's points);
        // the record names input points only.
        let Cleaned {
            mut tets,
            points,
            merged,
            dropped,
            pinches,
        } = input.clean()?;
        let scalars = pinches.with_copies(input.scalars);
        let cut = TetInput {
            points: &points,
            tets: &tets,
            scalars: &scalars,
        };
        let mut s = Simplifier::new(cut, &tets, params)?;
        for v in kept.iter().copied().chain(pinches.points()) {
            s.kept[v as usize] = true;
        }
        for &(v, kept) in &merged {
            s.seed_merged(v, kept);
        }
        let errors = vec![s.level_error()];
        let original_tet_errors = s.tet_max.clone();
        let all: Vec<u32> = (0..s.pos.len() as u32).collect();
        s.estimate_all(&all);
        memory::check(PREPARING)?;
        pinches.uncut(&mut tets);
        Ok(Self {
            pm: ProgressiveMesh {
                points: input.points.to_vec(),
                tets,
                collapses: Vec::new(),
                errors,
                scalars: input.scalars.to_vec(),
                merged_points: merged.iter().map(|&(v, _)| v).collect(),
                dropped_tets: dropped,
                original_tet_errors,
            },
            s,
            exhausted: false,
            pinches,
        })
    }

    /// Continues the collapse sequence until the mesh has at most `target_tets` tetrahedra or no
    /// valid collapse within the maximum field error is left ([`Self::exhausted`]); returns how many
    /// collapses it added. An abort ([`Error::Aborted`], `progress` returned `false`) keeps the
    /// collapses made until then and leaves the reduction ready to continue.
    pub fn reduce_to(&mut self, target_tets: usize, progress: Progress<'_>) -> Result<usize> {
        let s = &mut self.s;
        let goal = s.live.saturating_sub(target_tets).max(1);
        let start = s.live;
        let before = self.pm.collapses.len();
        let max_field_error = s.params.max_field_error;
        // Level errors in the order the collapses are made (the finest first).
        let mut errors = Vec::new();
        let mut popped = 0usize;
        let outcome = loop {
            if s.live <= target_tets {
                break Ok(());
            }
            // Asked before popping: an abort leaves the queue as it was.
            if popped.is_multiple_of(1024)
                && !progress(((start - s.live) as f64 / goal as f64).min(1.0))
            {
                break Err(Error::Aborted);
            }
            popped += 1;
            let Some((i, _)) = s.queue.pop() else {
                self.exhausted = true;
                break Ok(());
            };
            if std::mem::take(&mut s.dirty[i as usize]) {
                s.offer(i);
                continue;
            }
            let Some(c) = s.offer[i as usize].take() else {
                continue;
            };
            // A collapse requeued at its exact cost with no collapse made since: measured as is.
            let exact = match s.remeasured(i, c.target) {
                Some(exact) => exact,
                None => {
                    // An offer made since the last collapse is still valid: nothing changed.
                    if s.offered_at[i as usize] != s.made && !s.still_valid(i, c.target) {
                        s.offer(i);
                        continue;
                    }
                    let Some(exact) = s.measure(i, c.target) else {
                        continue;
                    };
                    exact
                }
            };
            if max_field_error > 0.0 && exact.max_field > max_field_error {
                continue;
            }
            let cost = c.base + s.field_term(exact.max_field);
            if !c.exact && cost > c.cost {
                s.offer[i as usize] = Some(Candidate {
                    cost,
                    exact: true,
                    ..c
                });
                s.queue.push(i, Cost(cost));
                s.measured.push((i, c.target, exact));
                continue;
            }
            let mut split = s.collapse(i, c.target, exact);
            split.target = self.pinches.original(split.target);
            self.pm.collapses.push(split);
            errors.push(s.level_error());
        };
        // Levels go up from the base mesh: the new ones, coarsest first, below the old ones.
        errors.reverse();
        errors.append(&mut self.pm.errors);
        self.pm.errors = errors;
        outcome?;
        progress(1.0);
        Ok(self.pm.collapses.len() - before)
    }

    /// Is no valid collapse left (the base mesh is as coarse as the reduction goes)?
    pub fn exhausted(&self) -> bool {
        self.exhausted
    }

    /// What the user should know after a reduction to `target_tets`: that it stopped short of it
    /// ([`Self::exhausted`] above the target), where and why; `None` when the target is reached or
    /// the reduction has not gone as far as it can.
    pub fn shortfall(&self, target_tets: usize) -> Option<String> {
        let reached = self.pm.error(0).tets;
        if !self.exhausted || reached <= target_tets {
            return None;
        }
        let input = self.pm.original_tets().len();
        let params = &self.s.params;
        let mut why = String::from(
            "every collapse left would flip or flatten a tetrahedron or break the mesh's manifold structure",
        );
        if params.preserve_boundary {
            why.push_str(
                ", or move the boundary (corners and feature edges stay; a removed boundary vertex must lie within the boundary tolerance of the boundary)",
            );
        }
        if params.max_field_error > 0.0 {
            why.push_str(&format!(
                ", or exceed the maximum field error {}",
                params.max_field_error
            ));
        }
        Some(format!(
            "the reduction stops at {reached} tetrahedra ({:.2} % of the input's {input}), short of the {target_tets} asked: {why}",
            100.0 * reached as f64 / input.max(1) as f64
        ))
    }

    /// The progressive mesh of the collapses made so far (its base mesh the current state).
    pub fn mesh(&self) -> &ProgressiveMesh {
        &self.pm
    }

    pub fn into_mesh(self) -> ProgressiveMesh {
        self.pm
    }
}

impl Simplifier {
    /// Fails with [`Error::OutOfMemory`] once an allocation failed ([`memory::exhausted`]): the
    /// vertex links alone take about a kilobyte per vertex, more than the emergency reserve on large
    /// meshes, so their construction stops at the first vertex after the failure.
    fn new(input: TetInput<'_>, tets: &[[u32; 4]], params: &Params) -> Result<Self> {
        let n = input.points.len();
        let pos: Vec<DVec3> = input.points.iter().map(|&p| DVec3::from_array(p)).collect();
        let mut star = vec![Vec::new(); n];
        for (t, c) in tets.iter().enumerate() {
            for &v in c {
                star[v as usize].push(t as u32);
            }
        }
        memory::check(PREPARING)?;
        let tets = tets.to_vec();
        let links: Option<Vec<Link>> = (0..n as u32)
            .into_par_iter()
            .map(|v| (!memory::exhausted()).then(|| Link::of(&tets, &star[v as usize], v)))
            .collect();
        memory::check(PREPARING)?;
        let links = links.ok_or_else(|| Error::OutOfMemory {
            what: PREPARING.to_string(),
            bytes: 0,
        })?;
        let kind = links
            .par_iter()
            .enumerate()
            .map(
                |(v, l)| match (l.on_boundary(), feature_edges_at(&pos, v as u32, l)) {
                    (false, _) => Kind::Interior,
                    (true, 0) => Kind::Surface,
                    (true, 2) => Kind::Crease,
                    (true, _) => Kind::Corner,
                },
            )
            .collect();
        // Each boundary face once, from its lowest corner's link.
        let mut faces = Vec::new();
        for (v, l) in links.iter().enumerate() {
            let v = v as u32;
            for (a, b, _) in l.boundary_faces().filter(|&(a, b, _)| v < a && v < b) {
                faces.push(BoundaryFace::new([v, a, b], &pos));
            }
        }
        // Q_v: the planes of the boundary faces around v (Eq. 3).
        let quadric = links
            .par_iter()
            .enumerate()
            .map(|(v, l)| {
                let mut q = Quadric::default();
                for (a, b, _) in l.boundary_faces() {
                    let p = |k: u32| pos[k as usize];
                    q.add(&Quadric::of_plane(p(v as u32), p(a), p(b)));
                }
                q
            })
            .collect();
        let (lo, hi) =
            input
                .points
                .iter()
                .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
                    let p = DVec3::from_array(*p);
                    (lo.min(p), hi.max(p))
                });
        let (fmin, fmax) = input
            .scalars
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        let m = tets.len();
        Ok(Self {
            params: params.clone(),
            f: input.scalars.to_vec(),
            alive: vec![true; m],
            removed: vec![false; n],
            kept: vec![false; n],
            kind,
            quadric,
            field_bins: vec![Vec::new(); m],
            boundary_bins: vec![Vec::new(); m],
            tet_max: vec![0.0; m],
            field_error: vec![0.0; n],
            home: vec![u32::MAX; n],
            outside_distance: vec![0.0; n],
            live_faces: faces.iter().map(|f| f.corners).collect(),
            faces: FaceIndex::new(faces),
            outside: RTree::new(),
            boundary_distance: vec![0.0; n],
            field_set: ErrorTree::new(n),
            boundary_set: ErrorTree::new(n),
            diagonal2: (hi - lo).length_squared().max(f64::MIN_POSITIVE),
            range2: ((fmax - fmin) * (fmax - fmin)).max(f64::MIN_POSITIVE),
            queue: PriorityQueue::with_capacity_and_hasher(n, FxBuildHasher),
            offer: vec![None; n],
            dirty: vec![false; n],
            made: 0,
            offered_at: vec![usize::MAX; n],
            live: m,
            removed_count: 0,
            measured: Vec::new(),
            pos,
            tets,
            star,
        })
    }

    /// Counts the merged point `v` as removed from the start, carried by a tetrahedron around the point
    /// `kept` at its position (its error is its value's difference from `kept`'s).
    fn seed_merged(&mut self, v: u32, kept: u32) {
        let Some(&t) = self.star[kept as usize].first() else {
            return; // neither point is in a tetrahedron
        };
        let e = (self.f[v as usize] - self.f[kept as usize]).abs();
        self.removed[v as usize] = true;
        self.removed_count += 1;
        self.kind[v as usize] = self.kind[kept as usize];
        self.field_error[v as usize] = e;
        self.home[v as usize] = t;
        self.field_set.set(v, None, e);
        self.field_bins[t as usize].push(v);
        self.tet_max[t as usize] = self.tet_max[t as usize].max(e);
        if self.params.preserve_boundary && self.kind[v as usize] != Kind::Interior {
            self.boundary_set.set(v, None, 0.0);
            self.boundary_bins[t as usize].push(v);
        }
    }

    fn level_error(&self) -> LevelError {
        LevelError {
            tets: self.live,
            max_field_error: self.field_set.max(),
            rms_field_error: self.field_set.rms(self.removed_count),
            max_boundary_distance: self.boundary_set.max(),
        }
    }

    /// The weighted field term of Eq. 2 for a field error `e` (data units).
    fn field_term(&self, e: f64) -> f64 {
        self.params.field_weight * e * e / self.range2
    }

    /// The corners of `t` with `i` replaced by `j`.
    fn moved_corners(&self, t: u32, i: u32, j: u32) -> [u32; 4] {
        self.tets[t as usize].map(|c| if c == i { j } else { c })
    }

    fn points(&self, c: [u32; 4]) -> [DVec3; 4] {
        c.map(|v| self.pos[v as usize])
    }

    /// The measure of `hec(i → j)` kept when it was requeued at its exact cost, if no collapse was
    /// made since ([`Self::measured`]).
    fn remeasured(&mut self, i: u32, j: u32) -> Option<Exact> {
        let k = self.measured.iter().position(|m| m.0 == i && m.1 == j)?;
        Some(self.measured.swap_remove(k).2)
    }

    /// Recomputes the offer of `v` ([`Self::best`]) and updates the queue.
    fn offer(&mut self, v: u32) {
        let o = self.best(v);
        self.offer[v as usize] = o;
        self.offered_at[v as usize] = self.made;
        match o {
            Some(c) => {
                self.queue.push(v, Cost(c.cost));
            }
            None => {
                self.queue.remove(&v);
            }
        }
    }

    /// Queues `verts` (in parallel) at the cost of their cheapest collapse before the link and
    /// embedding tests ([`Self::candidates`]), a lower bound of their offer's, marked dirty: the
    /// tests run when they come out of the queue, as in lazy quadric simplifiers (most vertices'
    /// stars change again before their turn, and those with no valid collapse are many near the
    /// boundary).
    fn estimate_all(&mut self, verts: &[u32]) {
        let bounds: Vec<Option<f64>> = if verts.len() > 64 {
            verts.par_iter().map(|&v| self.cheapest(v)).collect()
        } else {
            verts.iter().map(|&v| self.cheapest(v)).collect()
        };
        for (&v, bound) in verts.iter().zip(bounds) {
            self.offer[v as usize] = None;
            self.dirty[v as usize] = bound.is_some();
            match bound {
                Some(cost) => {
                    self.queue.push(v, Cost(cost));
                }
                None => {
                    self.queue.remove(&v);
                }
            }
        }
    }

    /// The cost of the cheapest of `v`'s [`Self::candidates`], if any.
    fn cheapest(&self, v: u32) -> Option<f64> {
        let (_, candidates) = self.candidates(v, false)?;
        candidates.iter().map(|c| c.cost).min_by(f64::total_cmp)
    }

    /// The cheapest valid collapse of `i` (§3.2 tests, §3.3 cost with the estimated field term):
    /// the first of its [`Self::candidates`] (cheapest first, ties by target) that passes the link
    /// condition and, `i` on the boundary, keeps the boundary embedded.
    fn best(&self, i: u32) -> Option<Candidate> {
        let (link, mut candidates) = self.candidates(i, true)?;
        candidates.sort_by(|a, b| a.cost.total_cmp(&b.cost).then(a.target.cmp(&b.target)));
        let on_boundary = link.on_boundary();
        candidates.into_iter().find(|c| {
            self.link_ok(i, &link, c.target)
                && (!on_boundary || self.boundary_stays_embedded(i, &link, c.target))
        })
    }

    /// The collapses of `i` that keep every tetrahedron proper and follow the boundary rules, with
    /// their costs (§3.3, the estimated field term), in no order, and `i`'s link: the whole of it
    /// if `full_link`, else for an interior `i` only its vertices ([`Link::of_interior`]; the
    /// estimates need no more).
    fn candidates(&self, i: u32, full_link: bool) -> Option<(Link, Vec<Candidate>)> {
        let preserve = self.params.preserve_boundary;
        if self.removed[i as usize]
            || self.kept[i as usize]
            || (preserve && self.kind[i as usize] == Kind::Corner)
        {
            return None;
        }
        let star = &self.star[i as usize];
        let link = if full_link || self.kind[i as usize] != Kind::Interior {
            Link::of(&self.tets, star, i)
        } else {
            Link::of_interior(&self.tets, star, i)
        };
        let on_boundary = link.on_boundary();
        let carried = star
            .iter()
            .map(|&t| self.tet_max[t as usize])
            .fold(0.0, f64::max);
        let pi = self.pos[i as usize];
        let fi = self.f[i as usize];
        let shaped = self.params.shape_weight > 0.0;
        // Each tetrahedron around `i`, ready for any `j`.
        let ring: Vec<Around> = star
            .iter()
            .map(|&t| Around::new(self.tets[t as usize], i, &self.pos))
            .collect();
        let mut candidates = Vec::with_capacity(link.verts().len());
        for &j in link.verts() {
            // §3.2: a boundary vertex moves only along a boundary edge.
            if on_boundary && !link.boundary_edge_to(j) {
                continue;
            }
            if preserve
                && self.kind[i as usize] == Kind::Crease
                && (!matches!(self.kind[j as usize], Kind::Crease | Kind::Corner)
                    || !is_feature_edge(&self.pos, i, &link, j))
            {
                continue;
            }
            let mut proper = true;
            let (mut shape, mut n) = (0.0, 0usize);
            let (mut inside, mut value) = (f64::NEG_INFINITY, 0.0);
            let pj = self.pos[j as usize];
            // The cheap orientation tests first: most refused targets fail one.
            if !ring
                .iter()
                .all(|r| r.corners.contains(&j) || r.proper_at(pj))
            {
                continue;
            }
            for r in &ring {
                if r.corners.contains(&j) {
                    continue;
                }
                let Some((b, x)) = r.moved_to(pj, pi) else {
                    proper = false;
                    break;
                };
                if shaped {
                    shape += shape_measure(&x);
                }
                n += 1;
                let m = b.iter().copied().fold(f64::INFINITY, f64::min);
                if m > inside {
                    inside = m;
                    let mut f = r.corners.map(|v| self.f[v as usize]);
                    f[r.slot] = self.f[j as usize];
                    value = interpolate(b, f);
                }
            }
            if !proper || n == 0 {
                continue;
            }
            let geometric = if on_boundary {
                let mut q = self.quadric[i as usize];
                q.add(&self.quadric[j as usize]);
                q.eval(self.pos[j as usize])
            } else {
                0.0
            };
            let base = self.params.geometry_weight * geometric / self.diagonal2
                + self.params.shape_weight * shape / n as f64;
            let field = (fi - value).abs().max(carried);
            candidates.push(Candidate {
                target: j,
                base,
                cost: base + self.field_term(field),
                exact: false,
            });
        }
        Some((link, candidates))
    }

    /// The boundary faces at `j` that replace those at `i` (`link` its link) under `hec(i → j)`:
    /// the boundary surface undergoes the edge collapse `i → j`, so the faces at `i` go and those
    /// not at `j` come back at `j`.
    fn faces_replacing(&self, link: &Link, j: u32) -> Vec<BoundaryFace> {
        link.boundary_faces()
            .filter(|&(a, b, _)| a != j && b != j)
            .map(|(a, b, _)| BoundaryFace::new([j, a, b], &self.pos))
            .collect()
    }

    /// Does the boundary surface stay embedded under `hec(i → j)`, `i` on it (`link` its link):
    /// do the faces at `j` replacing those at `i` meet no other boundary face, nor each other,
    /// beyond their shared corners and edges ([`triangles_meet`])? With every tetrahedron
    /// positively oriented, tetrahedra cover each point as often as the boundary surface winds
    /// around it, so an embedded boundary (winding 0 or 1) means no two tetrahedra overlap; the
    /// orientation tests alone let the new faces fold over the boundary next to them (the blunt
    /// fin's near-coincident points along its singular axis at 90 % reduction).
    fn boundary_stays_embedded(&self, i: u32, link: &Link, j: u32) -> bool {
        self.flat_umbrella_stays_embedded(i, link, j) || self.new_faces_meet_no_face(i, link, j)
    }

    /// The test of [`Self::boundary_stays_embedded`] by the faces themselves: the faces at `j`
    /// replacing those at `i` against each other and the boundary faces around them ([`FaceIndex`]).
    fn new_faces_meet_no_face(&self, i: u32, link: &Link, j: u32) -> bool {
        let new = self.faces_replacing(link, j);
        new.iter().enumerate().all(|(k, f)| {
            let meets = |g: &BoundaryFace| triangles_meet((f.corners, f.x), (g.corners, g.x));
            !new[k + 1..].iter().any(meets)
                && !self
                    .faces
                    .meeting(&f.envelope())
                    .any(|g| !g.corners.contains(&i) && g.is_live(&self.removed) && meets(g))
        })
    }

    /// A sufficient condition for [`Self::boundary_stays_embedded`], decided exactly and without
    /// the face index: the boundary faces at `i` form one disk (their far edges one cycle), exactly
    /// coplanar ([`orient3d`]), their tetrahedra all on one side of the plane, and every face
    /// `jab` replacing a face `iab` turns the same way in the plane as `iab` ([`orient2d_along`],
    /// none flat). Then the faces at `j` tile the disk the faces at `i` covered, once: the
    /// faces at `i` bound positive tetrahedra, so their far edges, oriented by their tetrahedra,
    /// form a cycle whose winding number is 1 in the disk and 0 outside, and the triangles from
    /// any point to the edges of a cycle cover each point its winding number times, signed by
    /// their orientation — all of one sign, the fan from `j` covers the disk once. The
    /// faces at `j` are those at `i` on the disk's edge, so they meet the other boundary faces
    /// only where the faces at `i` did, in shared corners and edges. Most boundary vertices of
    /// meshes with plane boundaries (boxes, cut planes) pass this test.
    fn flat_umbrella_stays_embedded(&self, i: u32, link: &Link, j: u32) -> bool {
        let p = |v: u32| self.pos[v as usize];
        let faces: Vec<(u32, u32, u32)> = link.boundary_faces().collect();
        let Some(&(a0, b0, d0)) = faces.first() else {
            return false;
        };
        // One cycle: every far corner on two faces, and a walk from the first face meets them all.
        let on = |v: u32| faces.iter().filter(|f| f.0 == v || f.1 == v).count();
        if faces.len() != link.boundary_vertex_count() || faces.iter().any(|f| on(f.0) != 2) {
            return false;
        }
        let (mut at, mut from, mut steps) = (b0, 0, 1);
        while at != a0 && steps <= faces.len() {
            let Some(k) =
                (0..faces.len()).find(|&k| k != from && (faces[k].0 == at || faces[k].1 == at))
            else {
                return false;
            };
            at = if faces[k].0 == at {
                faces[k].1
            } else {
                faces[k].0
            };
            from = k;
            steps += 1;
        }
        if at != a0 || steps != faces.len() {
            return false;
        }
        let (pi, pa0, pb0) = (p(i), p(a0), p(b0));
        let axis = (pa0 - pi).cross(pb0 - pi).abs().max_position();
        // Signs as orderings against 0 (`f64::signum` gives 1 for 0).
        let sign = |x: f64| x.partial_cmp(&0.0);
        let zero = Some(Ordering::Equal);
        let side = sign(orient3d(pi, pa0, pb0, p(d0)));
        side != zero
            && faces.iter().all(|&(a, b, d)| {
                let turn = sign(orient2d_along(axis, pi, p(a), p(b)));
                orient3d(pi, pa0, pb0, p(a)) == 0.0
                    && orient3d(pi, pa0, pb0, p(b)) == 0.0
                    && sign(orient3d(pi, pa0, pb0, p(d))) == side
                    && turn != zero
                    && (a == j || b == j || sign(orient2d_along(axis, p(j), p(a), p(b))) == turn)
            })
    }

    /// The link condition of `hec(i → j)` (`link` the link of `i`), without `j`'s link
    /// ([`link_condition_from_star`]).
    fn link_ok(&self, i: u32, link: &Link, j: u32) -> bool {
        let star_i = &self.star[i as usize];
        let mut edge = Vec::with_capacity(star_i.len());
        edge.extend(
            star_i
                .iter()
                .copied()
                .filter(|&t| self.tets[t as usize].contains(&j)),
        );
        let j_on_boundary = self.kind[j as usize] != Kind::Interior;
        link_condition_from_star(
            &self.tets,
            &edge,
            (i, link),
            (j, &self.star[j as usize]),
            j_on_boundary,
        )
    }

    /// Is `hec(i → j)` still valid? (Its offer was made before neighbouring collapses changed `j`'s
    /// star.)
    fn still_valid(&self, i: u32, j: u32) -> bool {
        !self.removed[j as usize] && {
            let link = Link::of(&self.tets, &self.star[i as usize], i);
            link.verts().binary_search(&j).is_ok()
                && self.link_ok(i, &link, j)
                && (!link.on_boundary() || self.boundary_stays_embedded(i, &link, j))
        }
    }

    /// Places the removed vertex `v` in the mesh after a collapse ([`After`]): in the new tetrahedron
    /// holding it, else (outside the mesh) at the nearest point of the boundary surface after the
    /// collapse, carried by that face's tetrahedron.
    fn place_field(&self, v: u32, after: &After<'_>) -> Placed {
        let After {
            i,
            new,
            removed,
            new_faces,
        } = *after;
        let p = self.pos[v as usize];
        let fv = self.f[v as usize];
        let mut best = (f64::NEG_INFINITY, 0, [0.0; 4], [0; 4]);
        for &(t, c, frame) in new {
            let b = frame.barycentric(p);
            let m = b.iter().copied().fold(f64::INFINITY, f64::min);
            if m > best.0 {
                best = (m, t, b, c);
            }
        }
        let (m, t, b, c) = best;
        let clamped = Placed {
            vertex: v,
            tet: t,
            error: (fv - interpolate(b, c.map(|k| self.f[k as usize]))).abs(),
            outside: 0.0,
        };
        if m >= INSIDE {
            return clamped;
        }
        // The nearest face after the collapse: the live faces not at `i`, and the new ones.
        let mut nearest = self
            .faces
            .nearest(p, |f| !f.corners.contains(&i) && f.is_live(&self.removed));
        let at = p.to_array();
        for f in new_faces {
            let d = f.distance_2(&at);
            if is_closer(nearest, f, d) {
                nearest = Some((f, d));
            }
        }
        let placed = nearest.and_then(|(face, _)| {
            let [a, b, c] = face.x;
            let q = closest_point_on_triangle(p, a, b, c).0;
            let (t, corners) = self.owner_after(face.corners, removed, new)?;
            let frame = Frame::of(&self.points(corners))?.0;
            let value = interpolate(frame.barycentric(q), corners.map(|k| self.f[k as usize]));
            Some(Placed {
                vertex: v,
                tet: t,
                error: (fv - value).abs(),
                outside: q.distance(p),
            })
        });
        // (A face always has a tetrahedron; the clamped place only guards against the impossible.)
        placed.unwrap_or(clamped)
    }

    /// The tetrahedron with the boundary face `face` after `hec(i → j)` (see [`Self::place_field`]),
    /// with its corners then.
    fn owner_after(
        &self,
        face: [u32; 3],
        removed: &[u32],
        new: &[Framed],
    ) -> Option<(u32, [u32; 4])> {
        let holds = |c: &[u32; 4]| face.iter().all(|v| c.contains(v));
        new.iter()
            .find(|(_, c, _)| holds(c))
            .map(|&(t, c, _)| (t, c))
            .or_else(|| {
                self.star[face[0] as usize]
                    .iter()
                    .find(|t| !removed.contains(t) && holds(&self.tets[**t as usize]))
                    .map(|&t| (t, self.tets[t as usize]))
            })
    }

    /// Measures `hec(i → j)` exactly: the field error of every removed original vertex in the star of
    /// `i` (and of `i`) in the new tetrahedra, and with `preserve_boundary` their distance to the new
    /// boundary faces. `None` if a boundary vertex would leave the tolerance.
    fn measure(&self, i: u32, j: u32) -> Option<Exact> {
        let star = &self.star[i as usize];
        let (removed, moved): (Vec<u32>, Vec<u32>) = star
            .iter()
            .partition(|&&t| self.tets[t as usize].contains(&j));
        let new: Vec<(u32, [u32; 4])> = moved
            .iter()
            .map(|&t| (t, self.moved_corners(t, i, j)))
            .collect();
        if new.is_empty() {
            return None;
        }
        let framed: Vec<Framed> = new
            .iter()
            .map(|&(t, c)| Some((t, c, Frame::of(&self.points(c))?.0)))
            .collect::<Option<_>>()?;
        // With `i` on the boundary, the boundary surface undergoes the edge collapse `i → j`.
        let (faces_gone, new_faces) = if self.kind[i as usize] == Kind::Interior {
            (0, Vec::new())
        } else {
            let link = Link::of(&self.tets, star, i);
            (
                link.boundary_faces().count(),
                self.faces_replacing(&link, j),
            )
        };
        let mut carried: Vec<u32> = std::iter::once(i)
            .chain(
                star.iter()
                    .flat_map(|&t| self.field_bins[t as usize].iter().copied()),
            )
            .collect();
        // Outside vertices elsewhere that a new boundary face comes nearer to.
        if let Some(first) = new_faces.first() {
            let envelope = new_faces.iter().fold(first.envelope(), |e, f| {
                let mut e = e;
                e.merge(&f.envelope());
                e
            });
            carried.extend(
                self.outside
                    .locate_in_envelope_intersecting(&envelope)
                    .map(|ball| ball.data)
                    .filter(|&v| {
                        let at = self.pos[v as usize].to_array();
                        let d = self.outside_distance[v as usize];
                        !star.contains(&self.home[v as usize])
                            && new_faces.iter().any(|f| f.distance_2(&at) <= d * d)
                    }),
            );
        }
        let after = After {
            i,
            new: &framed,
            removed: &removed,
            new_faces: &new_faces,
        };
        let place = |&v: &u32| self.place_field(v, &after);
        // Coarse levels carry hundreds of removed vertices per star: place them in parallel.
        let field: Vec<Placed> = if carried.len() * framed.len() > 1 << 14 {
            carried.par_iter().map(place).collect()
        } else {
            carried.iter().map(place).collect()
        };
        let max_field = field.iter().map(|p| p.error).fold(0.0, f64::max);
        let mut boundary = Vec::new();
        if self.params.preserve_boundary {
            let on_boundary = |v: u32| self.kind[v as usize] != Kind::Interior;
            let carried: Vec<u32> = std::iter::once(i)
                .filter(|&v| on_boundary(v))
                .chain(
                    star.iter()
                        .flat_map(|&t| self.boundary_bins[t as usize].iter().copied()),
                )
                .collect();
            if !carried.is_empty() {
                let faces = self.new_boundary_faces(&new, &new_faces);
                for v in carried {
                    let p = self.pos[v as usize];
                    let (tet, d) = faces
                        .iter()
                        .map(|&(t, f)| (t, point_triangle_distance(p, f)))
                        .min_by(|a, b| a.1.total_cmp(&b.1))?;
                    if d > self.params.boundary_tolerance {
                        return None;
                    }
                    boundary.push(Placed {
                        vertex: v,
                        tet,
                        error: d,
                        outside: 0.0,
                    });
                }
            }
        }
        Some(Exact {
            removed,
            moved,
            field,
            boundary,
            max_field,
            faces_gone,
            new_faces,
        })
    }

    /// The boundary faces of the tetrahedra `new` (after `hec(i → j)`): the collapse keeps every
    /// boundary face without `i` and replaces those at `i` by `new_faces`
    /// ([`Self::faces_replacing`]).
    fn new_boundary_faces(
        &self,
        new: &[(u32, [u32; 4])],
        new_faces: &[BoundaryFace],
    ) -> Vec<(u32, [DVec3; 3])> {
        let mut faces = Vec::new();
        for &(t, c) in new {
            for skip in 0..4 {
                let f = sorted_face(c, skip);
                if self.live_faces.contains(&f) || new_faces.iter().any(|n| n.corners == f) {
                    faces.push((t, face(c, skip).map(|v| self.pos[v as usize])));
                }
            }
        }
        faces
    }

    /// Makes `hec(i → j)` (§3.1) with what [`Self::measure`] found, and re-offers the vertices
    /// around.
    fn collapse(&mut self, i: u32, j: u32, exact: Exact) -> VertexSplit {
        let Exact {
            removed,
            moved,
            field,
            boundary,
            faces_gone,
            new_faces,
            ..
        } = exact;
        let errors_before = removed
            .iter()
            .chain(&moved)
            .map(|&t| self.tet_max[t as usize])
            .collect();
        // Tetrahedra outside the star that outside vertices leave or join.
        let in_star = |t: u32| removed.contains(&t) || moved.contains(&t);
        let mut others: Vec<u32> = field
            .iter()
            .filter(|p| p.vertex != i)
            .map(|p| self.home[p.vertex as usize])
            .chain(field.iter().map(|p| p.tet))
            .filter(|&t| !in_star(t))
            .collect();
        others.sort_unstable();
        others.dedup();
        let others_before: Vec<f64> = others.iter().map(|&t| self.tet_max[t as usize]).collect();
        for p in field.iter().filter(|p| p.vertex != i) {
            let home = self.home[p.vertex as usize];
            if !in_star(home) {
                self.field_bins[home as usize].retain(|&v| v != p.vertex);
            }
        }
        if faces_gone > 0 {
            for &t in removed.iter().chain(&moved) {
                let c = self.tets[t as usize];
                for skip in (0..4).filter(|&k| c[k] != i) {
                    self.live_faces.remove(&sorted_face(c, skip));
                }
            }
        }
        for f in new_faces {
            self.live_faces.insert(f.corners);
            self.faces.insert(f);
        }
        for &t in &removed {
            self.alive[t as usize] = false;
            for v in self.tets[t as usize] {
                if v != i {
                    self.star[v as usize].retain(|&o| o != t);
                }
            }
        }
        for &t in &moved {
            let c = self.moved_corners(t, i, j);
            self.tets[t as usize] = c;
            self.star[j as usize].push(t);
        }
        for &t in removed.iter().chain(&moved) {
            self.field_bins[t as usize].clear();
            self.boundary_bins[t as usize].clear();
            self.tet_max[t as usize] = 0.0;
        }
        self.star[i as usize].clear();
        self.made += 1;
        self.measured.clear();
        self.removed[i as usize] = true;
        self.removed_count += 1;
        // The faces at `i` stay in the index, dead with `i` ([`BoundaryFace::is_live`]).
        self.faces.kill(faces_gone, &self.removed);
        let qi = self.quadric[i as usize];
        self.quadric[j as usize].add(&qi);
        self.live -= removed.len();
        for p in field {
            let v = p.vertex as usize;
            let old = (p.vertex != i).then(|| self.field_error[v]);
            self.field_set.set(p.vertex, old, p.error);
            self.field_error[v] = p.error;
            self.field_bins[p.tet as usize].push(p.vertex);
            self.home[v] = p.tet;
            let m = &mut self.tet_max[p.tet as usize];
            *m = m.max(p.error);
            if p.vertex != i && self.outside_distance[v] > 0.0 {
                self.outside.remove(&outside_ball(
                    p.vertex,
                    self.pos[v],
                    self.outside_distance[v],
                ));
            }
            if p.outside > 0.0 {
                self.outside
                    .insert(outside_ball(p.vertex, self.pos[v], p.outside));
            }
            self.outside_distance[v] = p.outside;
        }
        for &t in &others {
            self.tet_max[t as usize] = self.field_bins[t as usize]
                .iter()
                .map(|&v| self.field_error[v as usize])
                .fold(0.0, f64::max);
        }
        for p in boundary {
            let old = (p.vertex != i).then(|| self.boundary_distance[p.vertex as usize]);
            self.boundary_set.set(p.vertex, old, p.error);
            self.boundary_distance[p.vertex as usize] = p.error;
            self.boundary_bins[p.tet as usize].push(p.vertex);
        }
        self.queue.remove(&i);
        self.offer[i as usize] = None;
        self.dirty[i as usize] = false;
        let mut around: Vec<u32> = self.star[j as usize]
            .iter()
            .chain(&removed)
            .flat_map(|&t| self.tets[t as usize])
            .filter(|&v| !self.removed[v as usize])
            .collect();
        around.sort_unstable();
        around.dedup();
        // Queued vertices are re-evaluated when their turn comes; the others (with no valid collapse
        // before) are queued at their estimate ([`Self::estimate_all`]).
        around.retain(|&v| {
            let queued = self.queue.get(&v).is_some();
            self.dirty[v as usize] |= queued;
            !queued
        });
        self.estimate_all(&around);
        VertexSplit {
            vertex: i,
            target: j,
            errors_after: moved.iter().map(|&t| self.tet_max[t as usize]).collect(),
            errors_before,
            other_errors: others
                .iter()
                .zip(others_before)
                .map(|(&t, before)| (t, before, self.tet_max[t as usize]))
                .collect(),
            removed,
            moved,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progressive::tests::grid;
    use crate::progressive::validity::link_condition;
    use crate::validate::{boundary_faces, check_manifold_tets};

    /// The link condition read from `j`'s star decides as the one from both links for every edge
    /// `ij`, `j` inside or on the boundary, an interior vertex's link has the vertices of its whole
    /// link, and the vertices kept as on the boundary are those whose link is, at several stages
    /// of the reduction of a cube (boundary kept) and of a bent shell (free boundary, moved
    /// within a tenth of its thickness); some of their edges break the link condition.
    #[test]
    fn the_link_condition_from_j_s_star_decides_as_the_one_from_both_links() {
        use crate::progressive::tests::bent;
        let field = |p: DVec3| p.x * p.y + p.z;
        let cases = [
            (grid(5, field), Params::default()),
            (
                bent(5, field),
                Params {
                    preserve_boundary: false,
                    boundary_tolerance: 0.1,
                    ..Params::default()
                },
            ),
        ];
        // Kept and broken edges to interior and boundary vertices.
        let mut counts = [[0usize; 2]; 2];
        for (g, params) in &cases {
            let mut reduction = Reduction::new(g.input(), params).expect("a valid mesh");
            for stage in 1..=4 {
                reduction
                    .reduce_to(g.tets.len() * (5 - stage) / 5, &mut |_| true)
                    .expect("not aborted");
                let s = &reduction.s;
                for i in (0..g.points.len() as u32).filter(|&i| !s.removed[i as usize]) {
                    let li = Link::of(&s.tets, &s.star[i as usize], i);
                    let on_boundary = s.kind[i as usize] != Kind::Interior;
                    assert_eq!(li.on_boundary(), on_boundary, "vertex {i}");
                    if !on_boundary {
                        let lean = Link::of_interior(&s.tets, &s.star[i as usize], i);
                        assert_eq!(lean.verts(), li.verts());
                    }
                    for &j in li.verts() {
                        let edge: Vec<u32> = s.star[i as usize]
                            .iter()
                            .copied()
                            .filter(|&t| s.tets[t as usize].contains(&j))
                            .collect();
                        let lj = Link::of(&s.tets, &s.star[j as usize], j);
                        let both = link_condition(&s.tets, &edge, (i, &li), (j, &lj));
                        let j_on_boundary = s.kind[j as usize] != Kind::Interior;
                        let from_star = link_condition_from_star(
                            &s.tets,
                            &edge,
                            (i, &li),
                            (j, &s.star[j as usize]),
                            j_on_boundary,
                        );
                        assert_eq!(from_star, both, "hec({i} -> {j}) at stage {stage}");
                        counts[usize::from(j_on_boundary)][usize::from(both)] += 1;
                    }
                }
            }
        }
        assert!(
            counts.iter().flatten().all(|&c| c > 0),
            "[[inside broken, kept], [boundary broken, kept]] = {counts:?}"
        );
    }

    /// The live faces of the boundary's index, and the set of live faces, are exactly the boundary
    /// faces of the current mesh (faces of one live tetrahedron), each once, and the dead ones are
    /// at most half the index, at every step of a cube's reduction to a twentieth (collapses on its
    /// sides kill faces and rebuild the index).
    #[test]
    fn the_live_faces_of_the_boundary_tree_and_set_are_the_current_boundary() {
        let g = grid(6, |p| p.x * p.y + p.z);
        let mut reduction = Reduction::new(g.input(), &Params::default()).expect("a valid cube");
        let (mut compacted, mut dead_before) = (false, 0);
        for step in 1..=20 {
            reduction
                .reduce_to(g.tets.len() * (20 - step) / 20, &mut |_| true)
                .expect("not aborted");
            let s = &reduction.s;
            let live_tets: Vec<[u32; 4]> = (0..s.tets.len())
                .filter(|&t| s.alive[t])
                .map(|t| s.tets[t])
                .collect();
            let mut want: Vec<[u32; 3]> = boundary_faces(&live_tets)
                .into_iter()
                .map(|mut f| {
                    f.sort_unstable();
                    f
                })
                .collect();
            want.sort_unstable();
            let mut live: Vec<[u32; 3]> = s
                .faces
                .iter()
                .filter(|f| f.is_live(&s.removed))
                .map(|f| f.corners)
                .collect();
            live.sort_unstable();
            assert_eq!(live, want, "after step {step}");
            let mut set: Vec<[u32; 3]> = s.live_faces.iter().copied().collect();
            set.sort_unstable();
            assert_eq!(set, want, "the set of live faces after step {step}");
            assert_eq!(s.faces.len() - live.len(), s.faces.dead());
            assert!(2 * s.faces.dead() <= s.faces.len());
            compacted |= s.faces.dead() < dead_before;
            dead_before = s.faces.dead();
        }
        assert!(
            compacted,
            "the index was never rebuilt: the test tests nothing"
        );
    }

    /// The flat-umbrella test accepts only collapses the face-by-face test accepts, and decides
    /// most of those on a cube whose bottom side's points are jittered within its plane (some
    /// umbrellas there are not convex: collapses fold them).
    #[test]
    fn a_flat_umbrella_is_accepted_only_where_no_new_face_meets_another() {
        let n = 5;
        let mut g = grid(n, |p| p.x);
        let h = 1.0 / n as f64;
        for (k, p) in g.points.iter_mut().enumerate() {
            let inside = |c: f64| c > 1e-9 && c < 1.0 - 1e-9;
            if p[2] == 0.0 && inside(p[0]) && inside(p[1]) {
                p[0] += 0.3 * h * (k as f64 * 1.7).sin();
                p[1] += 0.3 * h * (k as f64 * 2.3).cos();
            }
        }
        check_manifold_tets(&g.points, &g.tets).expect("a valid jittered cube");
        let params = Params::default();
        let s = Simplifier::new(
            TetInput {
                points: &g.points,
                tets: &g.tets,
                scalars: &g.scalars,
            },
            &g.tets,
            &params,
        )
        .expect("memory is not exhausted");
        let (mut flat, mut embedded, mut folds) = (0, 0, 0);
        for i in 0..g.points.len() as u32 {
            let link = Link::of(&s.tets, &s.star[i as usize], i);
            if !link.on_boundary() {
                continue;
            }
            for &j in link.verts().iter().filter(|&&j| link.boundary_edge_to(j)) {
                let by_faces = s.new_faces_meet_no_face(i, &link, j);
                embedded += usize::from(by_faces);
                folds += usize::from(!by_faces);
                if s.flat_umbrella_stays_embedded(i, &link, j) {
                    assert!(
                        by_faces,
                        "hec({i} -> {j}) accepted as flat but its faces meet"
                    );
                    flat += 1;
                }
            }
        }
        assert!(folds > 0, "no folding collapse: the test tests nothing");
        assert!(2 * flat > embedded, "{flat} of {embedded} decided as flat");
    }
}
