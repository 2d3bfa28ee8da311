//! The input of a progressive mesh: points, tetrahedra and one scalar field, checked and cleaned
//! before anything is built on them (bad input is an error naming what is wrong, never a panic).
//! Cleaning is what `vtkCleanUnstructuredGrid` does for exactly coincident points: they are merged
//! into the first of them, and the tetrahedra that become flat (repeated corners) are dropped —
//! tetrahedralised curvilinear grids with a singular axis, such as the blunt fin, have them. Then
//! the mesh is cut at its pinches ([`cut_pinches`]: parts meeting only at a point or along an edge,
//! as in the pieces ParaView's redistribution makes), so that the simplifier sees a manifold.

use crate::validate::{boundary_faces, check_manifold_tets};
use crate::{Error, Result};
use rayon::prelude::*;
use rustc_hash::{FxHashMap, FxHashSet};
use std::borrow::Cow;

/// A tetrahedral mesh with the scalar field that drives the field error.
#[derive(Clone, Copy, Debug)]
pub struct TetInput<'a> {
    /// World coordinates of every point.
    pub points: &'a [[f64; 3]],
    /// Tetrahedra as indices into `points`, positively oriented (VTK_TETRA order).
    pub tets: &'a [[u32; 4]],
    /// One value per point.
    pub scalars: &'a [f64],
}

/// The input after cleaning: the tetrahedra on the kept points, cut at the pinches, and the merged
/// points.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct Cleaned<'a> {
    /// The tetrahedra, on the copies of the pinch points ([`Pinches`]) where they are cut.
    pub(super) tets: Vec<[u32; 4]>,
    /// The input's points followed by the copies of the pinch points ([`Pinches::with_copies`]).
    pub(super) points: Cow<'a, [[f64; 3]]>,
    /// `(merged point, the point kept at its position)`.
    pub(super) merged: Vec<(u32, u32)>,
    /// Tetrahedra dropped because merging made them flat.
    pub(super) dropped: usize,
    pub(super) pinches: Pinches,
}

/// The copies [`cut_pinches`] made: point `points + k` is a copy of the pinch point `copies[k]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct Pinches {
    /// The input's number of points.
    pub(super) points: usize,
    pub(super) copies: Vec<u32>,
}

impl Pinches {
    /// The input point that `v` is (`v` itself, or the pinch point a copy was made of).
    pub(super) fn original(&self, v: u32) -> u32 {
        match (v as usize).checked_sub(self.points) {
            Some(k) => self.copies[k],
            None => v,
        }
    }

    /// Puts `tets` back on the input's points (the cut undone).
    pub(super) fn uncut(&self, tets: &mut [[u32; 4]]) {
        if !self.copies.is_empty() {
            tets.par_iter_mut()
                .for_each(|t| *t = t.map(|v| self.original(v)));
        }
    }

    /// `values`, one per input point, followed by one per copy (its pinch point's).
    pub(super) fn with_copies<'v, T: Clone>(&self, values: &'v [T]) -> Cow<'v, [T]> {
        if self.copies.is_empty() {
            return Cow::Borrowed(values);
        }
        let mut all = values.to_vec();
        all.extend(self.copies.iter().map(|&v| values[v as usize].clone()));
        Cow::Owned(all)
    }

    /// The pinch points and their copies, which a reduction keeps: the parts that meet there stay as
    /// they meet.
    pub(super) fn points(&self) -> impl Iterator<Item = u32> + '_ {
        self.copies
            .iter()
            .copied()
            .chain((self.points..self.points + self.copies.len()).map(|v| v as u32))
    }
}

/// Cuts `tets` (corners below `n`) at their pinches and returns the pinch point of each copy made
/// (copy `k` is point `n + k`). A point is a pinch when its tetrahedra fall apart into groups that
/// share no face at the point: parts of the mesh that meet only there, or only along an edge through
/// it. Each group after the first (in the order of its first tetrahedron) gets a copy of the point.
/// The cut mesh then has a manifold boundary wherever the input's parts only touched, and a
/// reduction that keeps the pinch points and their copies ([`Pinches::points`]) leaves the
/// parts meeting as they did: mapped back to the input's points, every level is the cut level.
fn cut_pinches(n: usize, tets: &mut [[u32; 4]]) -> Result<Vec<u32>> {
    let mut start = vec![0usize; n + 1];
    for &v in tets.iter().flatten() {
        start[v as usize + 1] += 1;
    }
    for v in 0..n {
        start[v + 1] += start[v];
    }
    let mut star = vec![0u32; start[n]];
    let mut next = start.clone();
    for (t, c) in tets.iter().enumerate() {
        for &v in c {
            star[next[v as usize]] = t as u32;
            next[v as usize] += 1;
        }
    }
    // For each pinch point, the groups of its star after the first.
    fn root(parent: &mut [usize], mut k: usize) -> usize {
        while parent[k] != k {
            parent[k] = parent[parent[k]];
            k = parent[k];
        }
        k
    }
    let later: Vec<(u32, Vec<Vec<u32>>)> = (0..n)
        .into_par_iter()
        .map_init(
            || (Vec::new(), Vec::new()),
            |(parent, edges): &mut (Vec<usize>, Vec<([u32; 2], usize)>), v| {
                let around = &star[start[v]..start[v + 1]];
                // Two tetrahedra share a face at `v` when they share an edge of `v`'s link.
                edges.clear();
                for (k, &t) in around.iter().enumerate() {
                    let c = tets[t as usize];
                    let at = c.iter().position(|&w| w == v as u32).unwrap_or(0);
                    let o = [c[(at + 1) % 4], c[(at + 2) % 4], c[(at + 3) % 4]];
                    for (a, b) in [(o[0], o[1]), (o[0], o[2]), (o[1], o[2])] {
                        edges.push(([a.min(b), a.max(b)], k));
                    }
                }
                edges.sort_unstable();
                parent.clear();
                parent.extend(0..around.len());
                for pair in edges.windows(2).filter(|w| w[0].0 == w[1].0) {
                    let (ra, rb) = (root(parent, pair[0].1), root(parent, pair[1].1));
                    parent[ra.max(rb)] = ra.min(rb);
                }
                if (1..around.len()).all(|k| root(parent, k) == 0) {
                    return None;
                }
                let mut groups: Vec<(usize, Vec<u32>)> = Vec::new();
                for (k, &t) in around.iter().enumerate() {
                    let r = root(parent, k);
                    match groups.iter_mut().find(|(g, _)| *g == r) {
                        Some((_, g)) => g.push(t),
                        None => groups.push((r, vec![t])),
                    }
                }
                Some((
                    v as u32,
                    groups.into_iter().skip(1).map(|(_, g)| g).collect(),
                ))
            },
        )
        .flatten()
        .collect();
    let mut copies = Vec::new();
    for (v, groups) in later {
        for group in groups {
            let copy = u32::try_from(n + copies.len())
                .ok()
                .filter(|&c| c != u32::MAX)
                .ok_or_else(|| {
                    Error::Mesh(format!(
                        "{n} points and the copies of the pinch points: at most 2^32 - 1 are supported"
                    ))
                })?;
            copies.push(v);
            for t in group {
                for c in &mut tets[t as usize] {
                    if *c == v {
                        *c = copy;
                    }
                }
            }
        }
    }
    Ok(copies)
}

impl<'a> TetInput<'a> {
    /// The corners of the mesh's boundary faces (faces of one tetrahedron), ascending.
    pub fn boundary_points(&self) -> Vec<u32> {
        let mut points: Vec<u32> = boundary_faces(self.tets).into_iter().flatten().collect();
        points.sort_unstable();
        points.dedup();
        points
    }

    /// For a piece of a distributed mesh, what it sends each other piece so that their shared
    /// points are found ([`Self::seam_points`]): its `boundary` points ([`Self::boundary_points`])
    /// inside the bounds of piece `q` (`boxes[q]`: min and max per axis, VTK order; an empty piece's
    /// minima above its maxima), for every `q` but `me`. Returns how many go to each piece and
    /// their coordinates, piece after piece. A point two pieces share lies in both pieces' bounds,
    /// so nothing a piece needs is left out, and a piece receives only its neighbours' points near
    /// it, not every piece's whole boundary.
    pub fn seam_messages(
        &self,
        boundary: &[u32],
        boxes: &[[f64; 6]],
        me: usize,
    ) -> (Vec<usize>, Vec<[f64; 3]>) {
        let inside =
            |b: &[f64; 6], p: &[f64; 3]| (0..3).all(|a| b[2 * a] <= p[a] && p[a] <= b[2 * a + 1]);
        // The boundary's own bounds: the pieces whose bounds miss them (most, on many ranks) are
        // skipped without a look at each point.
        let own = crate::geometry::bounds_of(
            boundary.iter().filter_map(|&v| self.points.get(v as usize)),
        );
        let meets =
            |b: &[f64; 6]| (0..3).all(|a| b[2 * a] <= own[2 * a + 1] && own[2 * a] <= b[2 * a + 1]);
        let mut counts = vec![0; boxes.len()];
        let mut coordinates = Vec::new();
        for (q, b) in boxes
            .iter()
            .enumerate()
            .filter(|&(q, b)| q != me && meets(b))
        {
            let before = coordinates.len();
            coordinates.extend(
                boundary
                    .iter()
                    .filter_map(|&v| self.points.get(v as usize))
                    .filter(|p| inside(b, p)),
            );
            counts[q] = coordinates.len() - before;
        }
        (counts, coordinates)
    }

    /// The points of `boundary` ([`Self::boundary_points`]) at the position of one of `others`
    /// (equal coordinates, bit for bit up to the sign of 0). For a piece of a distributed mesh
    /// with `others` the boundary points the other pieces sent it ([`Self::seam_messages`]), these
    /// are where the piece meets another: every point two pieces share is on both pieces'
    /// boundaries. A reduction that keeps them ([`super::Reduction::keeping`]) changes no face
    /// between pieces, so the pieces' meshes stay conforming together.
    pub fn seam_points(&self, boundary: &[u32], others: &[[f64; 3]]) -> Vec<u32> {
        // `+ 0.0` makes -0 into +0.
        let key = |p: &[f64; 3]| p.map(|c| (c + 0.0).to_bits());
        let others: FxHashSet<[u64; 3]> = others.iter().map(key).collect();
        boundary
            .iter()
            .copied()
            .filter(|&v| {
                self.points
                    .get(v as usize)
                    .is_some_and(|p| others.contains(&key(p)))
            })
            .collect()
    }

    /// Checks and cleans the input: at least one tetrahedron, fewer than 2^32 points, one finite
    /// value and finite coordinates per point, corners inside the points; coincident points merged
    /// and the tetrahedra that repeat a corner then (flat ones) dropped; then a manifold
    /// tetrahedralisation with positive volumes once cut at the pinches ([`cut_pinches`],
    /// [`check_manifold_tets`]). Tetrahedra that repeat a corner in the input are flat too:
    /// ParaView's redistribution merges the coincident points of the blunt fin's pieces and leaves
    /// such tetrahedra.
    pub(super) fn clean(&self) -> Result<Cleaned<'a>> {
        let n = self.points.len();
        if self.tets.is_empty() {
            return Err(Error::Mesh("the mesh has no tetrahedra".into()));
        }
        if u32::try_from(n).is_err() {
            return Err(Error::Mesh(format!(
                "{n} points: at most 2^32 - 1 are supported"
            )));
        }
        if self.scalars.len() != n {
            return Err(Error::Mesh(format!(
                "the scalar array has {} values but the mesh has {n} points",
                self.scalars.len()
            )));
        }
        if let Some((k, v)) = self
            .scalars
            .iter()
            .enumerate()
            .find(|(_, v)| !v.is_finite())
        {
            return Err(Error::Mesh(format!(
                "the scalar array holds a non-finite value ({v}) at point {k}; replace NaN/Inf first"
            )));
        }
        if let Some((k, p)) = self
            .points
            .iter()
            .enumerate()
            .find(|(_, p)| p.iter().any(|c| !c.is_finite()))
        {
            return Err(Error::Mesh(format!(
                "point {k} has non-finite coordinates {p:?}"
            )));
        }
        if let Some((c, t)) = self
            .tets
            .iter()
            .enumerate()
            .find(|(_, t)| t.iter().any(|&v| v as usize >= n))
        {
            return Err(Error::Mesh(format!(
                "tetrahedron {c} {t:?} refers past the {n} points"
            )));
        }
        let mut first: FxHashMap<[u64; 3], u32> = FxHashMap::default();
        let mut keep: Vec<u32> = (0..n as u32).collect();
        let mut merged = Vec::new();
        let mut used = vec![false; n];
        for t in self.tets {
            for &v in t {
                used[v as usize] = true;
            }
        }
        for v in (0..n).filter(|&v| used[v]) {
            let key = self.points[v].map(|c| (c + 0.0).to_bits());
            let k = *first.entry(key).or_insert(v as u32);
            if k != v as u32 {
                keep[v] = k;
                merged.push((v as u32, k));
            }
        }
        let before = self.tets.len();
        let mut tets: Vec<[u32; 4]> = self
            .tets
            .iter()
            .map(|t| t.map(|v| keep[v as usize]))
            .filter(|t| (0..4).all(|a| (a + 1..4).all(|b| t[a] != t[b])))
            .collect();
        if tets.is_empty() {
            return Err(Error::Mesh(
                "every tetrahedron is flat (coincident corners)".into(),
            ));
        }
        let dropped = before - tets.len();
        let copies = cut_pinches(n, &mut tets)?;
        let pinches = Pinches { points: n, copies };
        let points = pinches.with_copies(self.points);
        check_manifold_tets(&points, &tets).map_err(Error::Mesh)?;
        Ok(Cleaned {
            tets,
            points,
            merged,
            dropped,
            pinches,
        })
    }
}
