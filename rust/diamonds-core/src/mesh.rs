//! Extraction of the current mesh: the leaves of the split set inside the domain, with points
//! deduplicated by lattice index (every output point is an input sample).

use crate::diamond::{bisect, signed_volume6, Diamond};
use crate::lattice::{Lattice, Placement, Tet};
use crate::memory;
use crate::refine::SplitSet;
use crate::volume::Grid;
use crate::Result;
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
    pub depths: Vec<u8>,
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
    walk_pruned(lattice, split, t, &|_| false, visit);
}

/// [`walk`], skipping the subtrees of the tetrahedra for which `prune` holds.
fn walk_pruned(
    lattice: &Lattice,
    split: &SplitSet,
    t: Tet,
    prune: &dyn Fn(&Tet) -> bool,
    visit: &mut dyn FnMut(&Tet),
) {
    let mut stack = vec![t];
    while let Some(t) = stack.pop() {
        match lattice.place(&t) {
            Placement::Outside => {}
            _ if prune(&t) => {}
            _ if is_split(split, &t) => stack.extend(bisect(&t)),
            Placement::Inside => visit(&t),
            Placement::Straddling => unreachable!("straddling diamonds are split in the base mesh"),
        }
    }
}

/// Subtrees of the split set, in order, enough for parallel work: the tetrahedra of its first levels
/// (breadth-first) until there are about a thousand; a leaf met on the way is its own subtree.
fn subtrees(lattice: &Lattice, split: &SplitSet) -> Vec<Tet> {
    let mut frontier: Vec<Tet> = Diamond::root(lattice).tets(lattice).to_vec();
    let mut leaves = Vec::new();
    while !frontier.is_empty() && frontier.len() < 1024 {
        let mut next = Vec::with_capacity(2 * frontier.len());
        for t in frontier.drain(..) {
            match lattice.place(&t) {
                Placement::Outside => {}
                _ if is_split(split, &t) => next.extend(bisect(&t)),
                _ => leaves.push(t),
            }
        }
        frontier = next;
    }
    leaves.append(&mut frontier);
    leaves
}

/// What `keep` makes of the inside leaves of the split set (those it keeps), in a deterministic
/// order (depth first); subtrees of tetrahedra for which `prune` holds are skipped.
pub(crate) fn leaves_where<X: Send>(
    lattice: &Lattice,
    split: &SplitSet,
    prune: impl Fn(&Tet) -> bool + Sync,
    keep: impl Fn(&Tet) -> Option<X> + Sync,
) -> Vec<X> {
    subtrees(lattice, split)
        .into_par_iter()
        .flat_map_iter(|t| leaves_below(lattice, split, t, &prune, &keep))
        .collect()
}

/// [`leaves_where`] below the tetrahedron `t` of the hierarchy (`t` itself when it is a leaf), on
/// the current thread. Replacing a leaf of a coarser split set by its leaves here keeps the order
/// of [`leaves_where`].
pub(crate) fn leaves_below<X>(
    lattice: &Lattice,
    split: &SplitSet,
    t: Tet,
    prune: &dyn Fn(&Tet) -> bool,
    keep: &dyn Fn(&Tet) -> Option<X>,
) -> Vec<X> {
    let mut out = Vec::new();
    walk_pruned(lattice, split, t, prune, &mut |t| out.extend(keep(t)));
    out
}

/// Number of inside leaves of the split set.
pub(crate) fn count_tets(lattice: &Lattice, split: &SplitSet) -> usize {
    subtrees(lattice, split)
        .into_par_iter()
        .map(|t| {
            let mut n = 0;
            walk(lattice, split, t, &mut |_| n += 1);
            n
        })
        .sum()
}

/// Builds the output mesh of the split set on `grid`, each tetrahedron with the `error` of its
/// diamond, in two parallel walks, with no intermediate copy of the tetrahedra: the first counts
/// each subtree's leaves and marks the points they use, the second writes each subtree's leaves
/// into its own slice of the output.
pub(crate) fn extract(
    lattice: &Lattice,
    grid: &Grid,
    split: &SplitSet,
    error: impl Fn(Diamond) -> f64 + Sync,
) -> Result<TetMesh> {
    let roots = subtrees(lattice, split);
    // Pass 1: counts, and used points as a bitset over the input points.
    let words = grid.len().div_ceil(64);
    let mut used = memory::with_capacity(words, "the mesh's point set")?;
    used.extend((0..words).map(|_| AtomicU64::new(0)));
    let counts: Vec<usize> = roots
        .par_iter()
        .map(|&t| {
            let mut n = 0;
            walk(lattice, split, t, &mut |t| {
                n += 1;
                for p in t {
                    let i = lattice.index(*p);
                    used[i / 64].fetch_or(1 << (i % 64), Ordering::Relaxed);
                }
            });
            n
        })
        .collect();
    // Point ids by rank in the bitset.
    let used: Vec<u64> = used.into_iter().map(AtomicU64::into_inner).collect();
    let mut rank = memory::with_capacity(used.len(), "the mesh's point ids")?;
    let mut total = 0u32;
    for w in &used {
        rank.push(total);
        total += w.count_ones();
    }
    let id = |i: usize| rank[i / 64] + (used[i / 64] & ((1u64 << (i % 64)) - 1)).count_ones();
    let mut point_ids = memory::with_capacity(total as usize, "the mesh's point ids")?;
    for (w, &bits) in used.iter().enumerate() {
        let mut b = bits;
        while b != 0 {
            point_ids.push(w * 64 + b.trailing_zeros() as usize);
            b &= b - 1;
        }
    }
    let mut points = memory::with_capacity(point_ids.len(), "the mesh's points")?;
    points.par_extend(point_ids.par_iter().map(|&i| grid.point(grid.ijk(i))));
    // Pass 2: each subtree fills its own slices of the output arrays.
    let n: usize = counts.iter().sum();
    let mut tets = memory::filled(n, [0u32; 4], "the mesh's tetrahedra")?;
    let mut depths = memory::filled(n, 0u8, "the mesh's depths")?;
    let mut errors = memory::filled(n, 0f32, "the mesh's errors")?;
    let mut jobs = Vec::with_capacity(roots.len());
    let (mut t_rest, mut d_rest, mut e_rest) = (&mut tets[..], &mut depths[..], &mut errors[..]);
    for (&root, &count) in roots.iter().zip(&counts) {
        let (t, tr) = t_rest.split_at_mut(count);
        let (d, dr) = d_rest.split_at_mut(count);
        let (e, er) = e_rest.split_at_mut(count);
        jobs.push((root, t, d, e));
        (t_rest, d_rest, e_rest) = (tr, dr, er);
    }
    jobs.into_par_iter().for_each(|(root, t, d, e)| {
        let mut k = 0;
        walk(lattice, split, root, &mut |leaf| {
            let mut leaf = *leaf;
            if signed_volume6(&leaf) < 0 {
                leaf.swap(2, 3);
            }
            // A unit-cube tetrahedron is one bisection below the finest diamonds and reproduces
            // its samples.
            let (depth, error) = match Diamond::of_tet(&leaf) {
                Some(d) => (d.depth(lattice), error(d) as f32),
                None => (3 * lattice.levels, 0.0),
            };
            t[k] = leaf.map(|p| id(lattice.index(p)));
            d[k] = depth as u8;
            e[k] = error;
            k += 1;
        });
    });
    let max_error = errors.iter().fold(0.0f64, |m, &e| m.max(e as f64));
    Ok(TetMesh {
        point_ids,
        points,
        tets,
        depths,
        errors,
        max_error,
    })
}
