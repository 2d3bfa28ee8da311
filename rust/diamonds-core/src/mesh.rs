//! Extraction of the current mesh: the leaves of the split set inside the domain, with points
//! deduplicated by lattice index (every output point is an input sample).

use crate::diamond::{bisect, signed_volume6, Diamond};
use crate::hierarchy::Hierarchy;
use crate::lattice::{Lattice, Placement, Tet};
use crate::refine::SplitSet;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// The current mesh of a query: deduplicated input points and positively oriented tetrahedra.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TetMesh {
    /// Input point index (x fastest) of each output point, ascending.
    pub point_ids: Vec<usize>,
    /// World coordinates of each output point.
    pub points: Vec<[f64; 3]>,
    /// Tetrahedra as indices into `points`, positively oriented (VTK_TETRA order).
    pub tets: Vec<[u32; 4]>,
    /// Bisection depth of each tetrahedron (0 = the six base tetrahedra; Gregorski's level is depth / 3,
    /// the phase depth mod 3).
    pub levels: Vec<u8>,
    /// Error bound of each tetrahedron: the exact max error of its diamond, rounded up (data units).
    pub errors: Vec<f32>,
    /// Largest value of `errors`.
    pub max_error: f64,
}

/// Is the diamond of `t` split? (Unit-cube tetrahedra never are.)
#[inline]
fn is_split(split: &SplitSet, t: &Tet) -> bool {
    Diamond::of_tet(t).is_some_and(|d| split.contains(d))
}

/// Visits the inside leaves below `t`, depth first.
fn walk(lattice: &Lattice, split: &SplitSet, t: Tet, visit: &mut dyn FnMut(&Tet)) {
    let mut stack = vec![t];
    while let Some(t) = stack.pop() {
        match lattice.place(&t) {
            Placement::Outside => {}
            _ if is_split(split, &t) => stack.extend(bisect(&t)),
            Placement::Inside => visit(&t),
            Placement::Straddling => unreachable!("straddling diamonds are split in the base mesh"),
        }
    }
}

/// Tetrahedra of the split set's first levels (breadth-first) until there is enough parallel work:
/// returns the leaves met on the way and the frontier still to walk.
fn frontier(lattice: &Lattice, split: &SplitSet) -> (Vec<Tet>, Vec<Tet>) {
    let mut frontier: Vec<Tet> = Diamond::root(lattice).tets(lattice).to_vec();
    let mut done = Vec::new();
    while !frontier.is_empty() && frontier.len() < 1024 {
        let mut next = Vec::with_capacity(2 * frontier.len());
        for t in frontier.drain(..) {
            match lattice.place(&t) {
                Placement::Outside => {}
                _ if is_split(split, &t) => next.extend(bisect(&t)),
                _ => done.push(t),
            }
        }
        frontier = next;
    }
    (done, frontier)
}

/// Visits every inside leaf of the split set, in parallel; `visit` gets each frontier subtree's leaves
/// in order and returns that subtree's result.
fn map_leaves<R: Send>(
    lattice: &Lattice,
    split: &SplitSet,
    visit: impl Fn(&mut dyn FnMut(&mut dyn FnMut(&Tet))) -> R + Sync,
) -> Vec<R> {
    let (done, frontier) = frontier(lattice, split);
    let mut out = vec![visit(&mut |emit| done.iter().for_each(&mut *emit))];
    out.par_extend(
        frontier
            .par_iter()
            .map(|&t| visit(&mut |emit| walk(lattice, split, t, emit))),
    );
    out
}

/// Number of inside leaves of the split set.
pub(crate) fn count_tets(h: &Hierarchy, split: &SplitSet) -> usize {
    map_leaves(h.lattice(), split, |leaves| {
        let mut n = 0;
        leaves(&mut |_| n += 1);
        n
    })
    .into_iter()
    .sum()
}

/// A leaf in compact form: its vertices' input point indices (positively oriented), depth and error.
type Leaf = ([u32; 4], u8, f32);

/// Builds the output mesh of the split set.
pub(crate) fn extract(h: &Hierarchy, split: &SplitSet) -> TetMesh {
    let lattice = h.lattice();
    let grid = h.grid();
    let parts: Vec<Vec<Leaf>> = map_leaves(lattice, split, |leaves| {
        let mut out = Vec::new();
        leaves(&mut |t| {
            let mut t = *t;
            if signed_volume6(&t) < 0 {
                t.swap(2, 3);
            }
            // A unit-cube tetrahedron is one bisection below the finest diamonds and reproduces its samples.
            let (depth, error) = match Diamond::of_tet(&t) {
                Some(d) => (d.depth(lattice), h.error(d) as f32),
                None => (3 * lattice.levels, 0.0),
            };
            out.push((t.map(|p| lattice.index(p) as u32), depth as u8, error));
        });
        out
    });
    // Used points as a bitset over the input points, then ids by rank.
    let used: Vec<AtomicU64> = (0..grid.len().div_ceil(64))
        .map(|_| AtomicU64::new(0))
        .collect();
    parts.par_iter().flatten().for_each(|(v, _, _)| {
        for &i in v {
            used[i as usize / 64].fetch_or(1 << (i % 64), Ordering::Relaxed);
        }
    });
    let used: Vec<u64> = used.into_iter().map(AtomicU64::into_inner).collect();
    let mut rank = Vec::with_capacity(used.len());
    let mut total = 0u32;
    for w in &used {
        rank.push(total);
        total += w.count_ones();
    }
    let id = |i: u32| {
        let (w, b) = (i as usize / 64, i % 64);
        rank[w] + (used[w] & ((1u64 << b) - 1)).count_ones()
    };
    let mut point_ids = Vec::with_capacity(total as usize);
    for (w, &bits) in used.iter().enumerate() {
        let mut b = bits;
        while b != 0 {
            point_ids.push(w * 64 + b.trailing_zeros() as usize);
            b &= b - 1;
        }
    }
    let points = point_ids
        .par_iter()
        .map(|&i| grid.point(grid.ijk(i)))
        .collect();
    // Each part fills its own slice of the output arrays.
    let n: usize = parts.iter().map(Vec::len).sum();
    let mut tets = vec![[0u32; 4]; n];
    let mut levels = vec![0u8; n];
    let mut errors = vec![0f32; n];
    let mut slices = Vec::with_capacity(parts.len());
    let (mut t_rest, mut l_rest, mut e_rest) = (&mut tets[..], &mut levels[..], &mut errors[..]);
    for part in parts {
        let (t, tr) = t_rest.split_at_mut(part.len());
        let (l, lr) = l_rest.split_at_mut(part.len());
        let (e, er) = e_rest.split_at_mut(part.len());
        slices.push((part, t, l, e));
        (t_rest, l_rest, e_rest) = (tr, lr, er);
    }
    // Each part is freed as soon as it is copied, keeping the peak near the output's size.
    slices.into_par_iter().for_each(|(part, t, l, e)| {
        for (k, (v, level, error)) in part.into_iter().enumerate() {
            t[k] = v.map(id);
            l[k] = level;
            e[k] = error;
        }
    });
    let max_error = errors.iter().fold(0.0f64, |m, &e| m.max(e as f64));
    TetMesh {
        point_ids,
        points,
        tets,
        levels,
        errors,
        max_error,
    }
}
