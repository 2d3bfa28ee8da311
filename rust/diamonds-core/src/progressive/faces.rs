//! The boundary faces of a reduction's current boundary surface, for the searches of
//! [`super::simplify`]: which faces meet a box, which is nearest a point.
//!
//! A collapse `hec(i → j)` with `i` on the boundary replaces the faces at `i` by faces at `j`. The
//! new faces go into the index one by one; the faces at `i` stay in it, dead with `i`
//! ([`BoundaryFace::is_live`]), because an R-tree removal searches the tree and condenses its nodes
//! (22 % of the 1 M-tet bonsai's reduction profile). Once the dead faces are the majority, the index
//! is rebuilt from its live ones.
//!
//! Two R-trees: the faces of the last rebuild, bulk-loaded and only searched, and the faces made
//! since, inserted one by one. A rebuild by bulk load is several times faster than by insertions
//! (the rebuilds by insertion were 8 % of the 1 M-tet bonsai's reduction), but rstar 0.12's bulk
//! load can leave leaves at different depths, after which an insertion panics ("This is a bug in
//! rstar", georust/rstar PR #239; met on a generated mesh with a jittered boundary): so nothing is
//! ever inserted into a bulk-loaded tree. The trees' shapes change no result: the nearest face is
//! chosen among equally near ones by its corners, and the other searches only ask whether some
//! face meets.

use crate::geometry::closest_point_on_triangle;
use glam::DVec3;
use rstar::{PointDistance, RStarInsertionStrategy, RTree, RTreeObject, RTreeParams, AABB};

/// A face of the current boundary surface in a [`FaceIndex`]: its corners
/// (sorted: faces are equal when their corners are), their positions and its box
/// ([`BoundaryFace::padded_box`], computed once: the R-tree asks for it at every node an
/// insertion or removal visits).
#[derive(Clone, Debug)]
pub(super) struct BoundaryFace {
    pub(super) corners: [u32; 3],
    pub(super) x: [DVec3; 3],
    envelope: AABB<[f64; 3]>,
}

impl BoundaryFace {
    pub(super) fn new(mut corners: [u32; 3], pos: &[DVec3]) -> Self {
        corners.sort_unstable();
        let x = corners.map(|v| pos[v as usize]);
        Self {
            corners,
            x,
            envelope: Self::padded_box(x),
        }
    }

    /// Is the face on the current boundary surface, `removed` telling the removed vertices? A face
    /// leaves the boundary surface only when a corner is removed, and a new face has live corners.
    pub(super) fn is_live(&self, removed: &[bool]) -> bool {
        self.corners.iter().all(|&v| !removed[v as usize])
    }

    /// The face's box thickened by a hundredth of its largest side: a face in an axis plane has a
    /// flat box of no volume, and the R*-tree's insertion, which compares volumes, then builds
    /// nodes that overlap (on the box boundary of a volume's tetrahedra, removals and queries
    /// visited a large part of a side's faces: a third of the reduction's time). Queries take the
    /// faces whose boxes meet and decide exactly, so a larger box changes nothing else.
    fn padded_box([a, b, c]: [DVec3; 3]) -> AABB<[f64; 3]> {
        let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
        let pad = 0.01 * (hi - lo).max_element();
        AABB::from_corners((lo - pad).to_array(), (hi + pad).to_array())
    }
}

impl PartialEq for BoundaryFace {
    fn eq(&self, other: &Self) -> bool {
        self.corners == other.corners
    }
}

impl RTreeObject for BoundaryFace {
    type Envelope = AABB<[f64; 3]>;

    fn envelope(&self) -> Self::Envelope {
        self.envelope
    }
}

impl PointDistance for BoundaryFace {
    fn distance_2(&self, point: &[f64; 3]) -> f64 {
        let p = DVec3::from_array(*point);
        let [a, b, c] = self.x;
        closest_point_on_triangle(p, a, b, c).0.distance_squared(p)
    }
}

/// The parameters of the boundary faces' R-trees: nodes of up to 8 children and no forced
/// reinsertion (R*-tree insertion reinserts a full node's farthest children before splitting it,
/// to improve the tree; rstar's default nodes hold up to 6 with 2 reinserted). Faces are inserted
/// one by one as collapses make them, about as often as the trees are searched: on the blunt fin
/// this cut the insertions by a fifth and slowed no search.
struct FaceTreeParams;

impl RTreeParams for FaceTreeParams {
    const MIN_SIZE: usize = 3;
    const MAX_SIZE: usize = 8;
    const REINSERTION_COUNT: usize = 0;
    type DefaultInsertionStrategy = RStarInsertionStrategy;
}

/// The faces of the current boundary surface among dead ones of earlier surfaces (see the module
/// documentation).
pub(super) struct FaceIndex {
    /// The live faces at the last rebuild, bulk-loaded: searched, never inserted into.
    loaded: RTree<BoundaryFace, FaceTreeParams>,
    /// The faces made since the last rebuild, inserted one by one.
    added: RTree<BoundaryFace, FaceTreeParams>,
    /// How many faces of both trees are dead.
    dead: usize,
}

impl FaceIndex {
    /// The index of `faces`, all live.
    pub(super) fn new(faces: Vec<BoundaryFace>) -> Self {
        Self {
            loaded: RTree::bulk_load_with_params(faces),
            added: RTree::new_with_params(),
            dead: 0,
        }
    }

    /// Adds a new face of the boundary surface.
    pub(super) fn insert(&mut self, face: BoundaryFace) {
        self.added.insert(face);
    }

    /// Counts `n` more faces as dead, and once the dead faces are the majority rebuilds the index
    /// from the live ones (`removed` telling the removed vertices): it then holds at most twice
    /// the boundary surface (the 1 M-tet bonsai's reduction to 10 % left 2.5 M dead faces, 0.4 GB,
    /// in it otherwise).
    pub(super) fn kill(&mut self, n: usize, removed: &[bool]) {
        self.dead += n;
        if 2 * self.dead > self.len() {
            let faces = self
                .iter()
                .filter(|f| f.is_live(removed))
                .cloned()
                .collect();
            *self = Self::new(faces);
        }
    }

    /// How many faces the index holds, live and dead.
    pub(super) fn len(&self) -> usize {
        self.loaded.size() + self.added.size()
    }

    /// How many of them are dead.
    #[cfg(test)]
    pub(super) fn dead(&self) -> usize {
        self.dead
    }

    /// Every face, live and dead.
    pub(super) fn iter(&self) -> impl Iterator<Item = &BoundaryFace> {
        self.loaded.iter().chain(self.added.iter())
    }

    /// The faces, live and dead, whose boxes meet `envelope`.
    pub(super) fn meeting(&self, envelope: &AABB<[f64; 3]>) -> impl Iterator<Item = &BoundaryFace> {
        self.loaded
            .locate_in_envelope_intersecting(envelope)
            .chain(self.added.locate_in_envelope_intersecting(envelope))
    }

    /// The nearest of the faces for which `accept` holds to `at`, with its squared distance;
    /// between equally near faces, the one with the lowest corners.
    pub(super) fn nearest(
        &self,
        at: DVec3,
        accept: impl Fn(&BoundaryFace) -> bool,
    ) -> Option<(&BoundaryFace, f64)> {
        let at = at.to_array();
        let mut nearest: Option<(&BoundaryFace, f64)> = None;
        for tree in [&self.loaded, &self.added] {
            // Faces come by increasing distance: the first face farther than the nearest ends the
            // search of a tree.
            for (f, d) in tree
                .nearest_neighbor_iter_with_distance_2(&at)
                .filter(|(f, _)| accept(f))
            {
                if nearest.is_some_and(|(_, e)| d > e) {
                    break;
                }
                if is_closer(nearest, f, d) {
                    nearest = Some((f, d));
                }
            }
        }
        nearest
    }
}

/// Is `f`, at squared distance `d`, nearer than `nearest` (ties broken by the lowest sorted
/// corners, so that the choice depends on the faces alone, not on the trees' order)?
pub(super) fn is_closer(nearest: Option<(&BoundaryFace, f64)>, f: &BoundaryFace, d: f64) -> bool {
    nearest.is_none_or(|(g, e)| d.total_cmp(&e).then(f.corners.cmp(&g.corners)).is_lt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rstar::Envelope;

    /// The faces of a jittered grid of triangles in the plane z = 0 and a few off it.
    fn faces(n: usize, shift: f64) -> (Vec<DVec3>, Vec<BoundaryFace>) {
        let mut pos = Vec::new();
        for k in 0..(n + 1) * (n + 1) {
            let (x, y) = ((k % (n + 1)) as f64, (k / (n + 1)) as f64);
            let z = if k % 7 == 0 { 0.3 * shift } else { 0.0 };
            pos.push(DVec3::new(x + 0.2 * (k as f64 * 1.3).sin(), y + shift, z));
        }
        let v = |x: usize, y: usize| (y * (n + 1) + x) as u32;
        let mut faces = Vec::new();
        for y in 0..n {
            for x in 0..n {
                faces.push(BoundaryFace::new([v(x, y), v(x + 1, y), v(x, y + 1)], &pos));
                faces.push(BoundaryFace::new(
                    [v(x + 1, y), v(x + 1, y + 1), v(x, y + 1)],
                    &pos,
                ));
            }
        }
        (pos, faces)
    }

    /// Bulk-loaded faces of every count up to 200, then faces inserted (never into the bulk-loaded
    /// tree, which rstar 0.12 may have built with leaves at different depths), some killed: the
    /// nearest accepted face and the faces meeting a box are those a scan of every face finds, and
    /// a rebuild keeps exactly the live faces.
    #[test]
    fn the_two_trees_answer_as_a_scan_of_every_face() {
        for count in (1..=200).step_by(7) {
            let (_, all) = faces(10, 0.0);
            let (_, more) = faces(4, 0.5);
            let mut index = FaceIndex::new(all[..count].to_vec());
            for f in &more {
                index.insert(f.clone());
            }
            let every: Vec<&BoundaryFace> = all[..count].iter().chain(&more).collect();
            assert_eq!(index.len(), every.len());
            let accept = |f: &BoundaryFace| f.corners[0] % 3 != 1;
            for q in 0..40 {
                let at = DVec3::new(
                    0.37 * q as f64 - 2.0,
                    0.29 * q as f64 - 1.0,
                    0.1 * (q % 5) as f64,
                );
                let got = index.nearest(at, accept).map(|(f, d)| (f.corners, d));
                let want = every
                    .iter()
                    .filter(|f| accept(f))
                    .map(|f| (*f, f.distance_2(&at.to_array())))
                    .fold(None, |best, (f, d)| {
                        if is_closer(best, f, d) {
                            Some((f, d))
                        } else {
                            best
                        }
                    })
                    .map(|(f, d)| (f.corners, d));
                assert_eq!(got, want, "{count} faces, point {at}");
                let envelope = AABB::from_corners(
                    (at - 0.8).to_array(),
                    (at + DVec3::new(1.5, 0.8, 0.8)).to_array(),
                );
                let mut met: Vec<[u32; 3]> = index.meeting(&envelope).map(|f| f.corners).collect();
                let mut scanned: Vec<[u32; 3]> = every
                    .iter()
                    .filter(|f| f.envelope().intersects(&envelope))
                    .map(|f| f.corners)
                    .collect();
                met.sort_unstable();
                scanned.sort_unstable();
                assert_eq!(met, scanned, "{count} faces, box at {at}");
            }
            // Removing the even vertices kills most faces: the index is rebuilt from the others.
            let mut removed = vec![false; 200];
            for v in (0..200).filter(|v| v % 2 == 0) {
                removed[v] = true;
            }
            let live: Vec<[u32; 3]> = every
                .iter()
                .filter(|f| f.is_live(&removed))
                .map(|f| f.corners)
                .collect();
            index.kill(every.len() - live.len(), &removed);
            let mut kept: Vec<[u32; 3]> = index
                .iter()
                .filter(|f| f.is_live(&removed))
                .map(|f| f.corners)
                .collect();
            kept.sort_unstable();
            let mut live = live;
            live.sort_unstable();
            assert_eq!(kept, live, "{count} faces");
            assert!(2 * (every.len() - live.len()) > every.len());
            assert_eq!(index.len(), live.len(), "rebuilt from the live faces");
            assert_eq!(index.dead(), 0);
        }
    }
}
