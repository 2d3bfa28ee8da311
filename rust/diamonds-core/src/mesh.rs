//! Extraction of the current mesh: the leaves of the split set inside the domain, with points
//! deduplicated by lattice index (every output point is an input sample).

use crate::diamond::{bisect, signed_volume6, Diamond};
use crate::hierarchy::Hierarchy;
use crate::lattice::{Lattice, Placement, Tet};
use crate::refine::SplitSet;
use rayon::prelude::*;

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

/// Visits the inside leaves below `t`.
fn walk(lattice: &Lattice, split: &SplitSet, t: Tet, visit: &mut impl FnMut(&Tet)) {
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

/// The inside leaves of the split set, in a deterministic order, walked in parallel.
fn leaves(lattice: &Lattice, split: &SplitSet) -> Vec<Tet> {
    // Expand breadth-first until there is enough parallel work.
    let mut frontier: Vec<Tet> = Diamond::root(lattice).tets(lattice).to_vec();
    let mut done = Vec::new();
    while frontier.len() < 1024 {
        let mut next = Vec::with_capacity(2 * frontier.len());
        for t in frontier.drain(..) {
            match lattice.place(&t) {
                Placement::Outside => {}
                _ if is_split(split, &t) => next.extend(bisect(&t)),
                _ => done.push(t),
            }
        }
        if next.is_empty() {
            break;
        }
        frontier = next;
    }
    done.par_extend(frontier.par_iter().flat_map_iter(|&t| {
        let mut out = Vec::new();
        walk(lattice, split, t, &mut |t| out.push(*t));
        out
    }));
    done
}

/// Number of inside leaves of the split set.
pub(crate) fn count_tets(h: &Hierarchy, split: &SplitSet) -> usize {
    leaves(h.lattice(), split).len()
}

/// Builds the output mesh of the split set.
pub(crate) fn extract(h: &Hierarchy, split: &SplitSet) -> TetMesh {
    let lattice = h.lattice();
    let grid = h.grid();
    let tets = leaves(lattice, split);
    // Used points as a bitset over the input points, then ids by rank.
    let mut used = vec![0u64; grid.len().div_ceil(64)];
    for t in &tets {
        for p in t {
            let i = lattice.index(*p);
            used[i / 64] |= 1 << (i % 64);
        }
    }
    let mut rank = Vec::with_capacity(used.len());
    let mut total = 0u32;
    for w in &used {
        rank.push(total);
        total += w.count_ones();
    }
    let id = |i: usize| rank[i / 64] + (used[i / 64] & ((1u64 << (i % 64)) - 1)).count_ones();
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
    let (cells, (levels, errors)): (Vec<[u32; 4]>, (Vec<u8>, Vec<f32>)) = tets
        .par_iter()
        .map(|t| {
            let mut t = *t;
            if signed_volume6(&t) < 0 {
                t.swap(2, 3);
            }
            // A unit-cube tetrahedron is one bisection below the finest diamonds and reproduces its samples.
            let (depth, error) = match Diamond::of_tet(&t) {
                Some(d) => (d.depth(lattice), h.error(d) as f32),
                None => (3 * lattice.levels, 0.0),
            };
            (t.map(|p| id(lattice.index(p))), (depth as u8, error))
        })
        .unzip();
    let max_error = errors.iter().fold(0.0f64, |m, &e| m.max(e as f64));
    TetMesh {
        point_ids,
        points,
        tets: cells,
        levels,
        errors,
        max_error,
    }
}
