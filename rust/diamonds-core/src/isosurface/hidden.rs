//! Pieces of the surface hidden in coarse tetrahedra (beyond Gregorski §6; the surface samples are
//! those of §6.2): a tetrahedron whose vertices all lie on one side of the isovalue draws nothing,
//! whatever its samples do, and the local error `ae / ‖∇T‖` cannot tell a bulge next to a drawn
//! surface from a speck of noise or a thin branch far from anything. After refining, the hidden
//! samples of the marked leaves ([`super::error`]) that lie farther than the tolerance plus a voxel
//! from the drawn surface are collected, the diamonds on their paths from the root are split, and
//! refinement continues from that mesh — equal to refining from the root with those diamonds
//! infinitely wrong.

use super::error::{child_coordinates, RootTets};
use super::marching::{carries, polygon_centres};
use super::{value, world, Extraction, IsoQuery};
use crate::diamond::{child_of, Diamond};
use crate::lattice::{Lattice, Tet};
use crate::mesh;
use crate::refine::{Refiner, SplitSet};
use crate::scan;
use crate::volume::{Sample, Volume};
use glam::{DMat3, DVec3, IVec3};
use rayon::prelude::*;
use rustc_hash::{FxHashMap, FxHashSet};

impl<T: Sample> Extraction<'_, '_, T> {
    /// `split`, refined for `query` at `tolerance` (> 0) with `criterion`, and its leaves that carry
    /// the surface. When parts of the surface hidden in leaves lie farther than the tolerance (plus a
    /// voxel diagonal) from the surface drawn, the diamonds down to one sample of each such part are
    /// split as well and refinement continues from there, so every part of the full-resolution
    /// surface is drawn within the tolerance.
    pub(super) fn split_hidden(
        &self,
        query: &IsoQuery,
        tolerance: f64,
        split: SplitSet,
        criterion: impl Fn(Diamond) -> f64,
    ) -> (SplitSet, Vec<Tet>) {
        let (volume, isovalues) = (self.volume, &query.isovalues);
        let errors = self.iso_errors(isovalues, tolerance);
        let lattice = *self.lattice();
        // The leaves that carry the surface and those that hide part of it.
        let empty = |t: &Tet| self.misses(isovalues, t);
        let (carriers, hiders): (Vec<_>, Vec<_>) =
            mesh::leaves_where(&lattice, &split, empty, |t| {
                if carries(volume, isovalues, t) {
                    Some((*t, true))
                } else {
                    let hides = Diamond::of_tet(t).is_some_and(|d| errors.hides(&lattice, d));
                    hides.then_some((*t, false))
                }
            })
            .into_iter()
            .partition(|l| l.1);
        let carriers: Vec<Tet> = carriers.into_iter().map(|l| l.0).collect();
        let hiders: Vec<Tet> = hiders.into_iter().map(|l| l.0).collect();
        if hiders.is_empty() {
            return (split, carriers);
        }
        let drawn = polygon_centres(volume, &carriers, isovalues);
        let voxel = DVec3::from(volume.grid.spacing).length();
        let mut far = far_hidden_samples(volume, isovalues, &hiders, &drawn, tolerance + voxel);
        if let Some(roi) = query.region_of_interest {
            // The tolerance applies inside the region only.
            far.retain(|&s| {
                let p = world(volume, s);
                (0..3).all(|a| roi[2 * a] <= p[a] && p[a] <= roi[2 * a + 1])
            });
        }
        if far.is_empty() {
            return (split, carriers);
        }
        // Continue from this mesh: split the diamonds down to each far sample (with closure) and
        // whatever their new children need. Every diamond above the tolerance in the result is
        // reachable from the diamonds split here, so this equals refining from the root with the
        // paths' diamonds infinitely wrong.
        let paths = paths_to(&lattice, &far);
        let forced: FxHashSet<Diamond> = paths.iter().copied().collect();
        let criterion = |d: Diamond| {
            if forced.contains(&d) {
                f64::INFINITY
            } else {
                criterion(d)
            }
        };
        let (split, newly) =
            Refiner::new(lattice, split, 0, &criterion).refine_logged(tolerance, &paths);
        // The carriers now: those still leaves, then the carriers below the leaves just split (the
        // tetrahedra of the newly split diamonds made by splitting a diamond split before), in
        // split order. A tetrahedron's parent diamond is centred at its vertex 2 or 3 (the
        // midpoint of the parent's spine, `diamond::bisect`).
        let newly_split: FxHashSet<Diamond> = newly.iter().copied().collect();
        let was_leaf = |d: &Diamond, t: &Tet| {
            !d.parents(&lattice)
                .iter()
                .any(|p| (p.center == t[2] || p.center == t[3]) && newly_split.contains(p))
        };
        let mut carriers: Vec<Tet> = carriers
            .into_iter()
            .filter(|t| !Diamond::of_tet(t).is_some_and(|d| newly_split.contains(&d)))
            .collect();
        let empty = |t: &Tet| self.misses(isovalues, t);
        let keep = |t: &Tet| carries(volume, isovalues, t).then_some(*t);
        for d in &newly {
            for t in d.tets(&lattice).into_iter().filter(|t| was_leaf(d, t)) {
                carriers.extend(mesh::leaves_below(&lattice, &split, t, &empty, &keep));
            }
        }
        (split, carriers)
    }
}

/// Samples of hidden pieces of the surface that lie farther than `reach` (world units) from the
/// surface drawn: in each leaf of `hiders` (leaves that carry no triangle of some isovalue, in diamonds
/// that hide part of the surface), the samples on the other side of an isovalue the leaf does not
/// carry than the leaf's interpolant, with no point of `drawn` (points on the surface, one per
/// polygon) and no sample chosen before within `reach`.
fn far_hidden_samples<T: Sample>(
    volume: &Volume<'_, T>,
    isovalues: &[f64],
    hiders: &[Tet],
    drawn: &[[f64; 3]],
    reach: f64,
) -> Vec<IVec3> {
    let ball = |t: &Tet| {
        let p = t.map(|q| world(volume, q));
        let centre = (p[0] + p[1] + p[2] + p[3]) / 4.0;
        (
            centre,
            p.iter().map(|q| q.distance(centre)).fold(0.0, f64::max),
        )
    };
    let near = PointGrid::new(reach, drawn);
    // Leaves entirely within `reach` of the surface need no look inside.
    let open: Vec<(&Tet, Vec<f64>)> = hiders
        .par_iter()
        .filter_map(|t| {
            let f = t.map(|p| value(volume, p));
            let min = f[0].min(f[1]).min(f[2].min(f[3]));
            let max = f[0].max(f[1]).max(f[2].max(f[3]));
            let lost: Vec<f64> = isovalues
                .iter()
                .copied()
                .filter(|&v| !(min < v && v <= max))
                .collect();
            let (centre, r) = ball(t);
            (!(lost.is_empty() || r < reach && near.any_within(centre, reach - r)))
                .then_some((t, lost))
        })
        .collect();
    // The hidden samples far from the drawn surface (in parallel), then those far from the ones
    // chosen before them too.
    let candidates: Vec<(IVec3, DVec3)> = open
        .par_iter()
        .flat_map_iter(|(t, lost)| {
            let f = t.map(|p| value(volume, p));
            let e = |i: usize| (t[i] - t[0]).as_dvec3();
            let inverse = DMat3::from_cols(e(1), e(2), e(3)).inverse();
            let near = &near;
            scan::brute_force_points(t)
                .into_iter()
                .filter_map(move |s| {
                    let l = inverse * (s - t[0]).as_dvec3();
                    let interpolated =
                        f[0] + l.x * (f[1] - f[0]) + l.y * (f[2] - f[0]) + l.z * (f[3] - f[0]);
                    let fs = value(volume, s);
                    let hidden = lost.iter().any(|&v| (fs >= v) != (interpolated >= v));
                    let p = world(volume, s);
                    (hidden && !near.any_within(p, reach)).then_some((s, p))
                })
        })
        .collect();
    let mut chosen = PointGrid::new(reach, &[]);
    let mut out = Vec::new();
    for (s, p) in candidates {
        if !chosen.any_within(p, reach) {
            chosen.insert(p);
            out.push(s);
        }
    }
    out
}

/// The diamonds to split so that each of `samples` becomes a vertex of the mesh: those of the
/// tetrahedra holding it, from the root down (central vertices in the domain only).
fn paths_to(lattice: &Lattice, samples: &[IVec3]) -> Vec<Diamond> {
    let roots = RootTets::new(lattice);
    let mut out = Vec::new();
    for &s in samples {
        let (k, mut l) = roots.containing(s);
        let mut t = roots.tets[k].0;
        while l.iter().all(|&c| c < 1.0) && ((t[0] + t[1]) & IVec3::ONE) == IVec3::ZERO {
            let m = (t[0] + t[1]) / 2;
            if lattice.in_domain(m) {
                out.push(Diamond::new(m));
            }
            let (first, nl) = child_coordinates(&t, l);
            let k = usize::from(!first);
            (t, l) = (child_of(&t, first, t, t[k], m), nl);
        }
    }
    out
}

/// Points bucketed in cubes of side `side`, to ask whether any lies within a distance (at most the
/// side) of a point.
struct PointGrid {
    side: f64,
    cells: FxHashMap<[i64; 3], Vec<DVec3>>,
}

impl PointGrid {
    fn new(side: f64, points: &[[f64; 3]]) -> Self {
        let mut grid = Self {
            side,
            cells: FxHashMap::default(),
        };
        for &p in points {
            grid.insert(DVec3::from(p));
        }
        grid
    }

    fn key(&self, p: DVec3) -> [i64; 3] {
        (p / self.side).floor().as_i64vec3().to_array()
    }

    fn insert(&mut self, p: DVec3) {
        self.cells.entry(self.key(p)).or_default().push(p);
    }

    /// Is a point within `distance` (at most the side) of `p`?
    fn any_within(&self, p: DVec3, distance: f64) -> bool {
        let [x, y, z] = self.key(p);
        (-1..=1).any(|dz| {
            (-1..=1).any(|dy| {
                (-1..=1).any(|dx| {
                    self.cells
                        .get(&[x + dx, y + dy, z + dz])
                        .is_some_and(|c| c.iter().any(|q| q.distance(p) <= distance))
                })
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hierarchy::Hierarchy;
    use crate::isosurface::cache::IsoCache;
    use crate::isosurface::refine_query;
    use crate::volume::{Grid, ScalarSlice};

    #[test]
    fn carriers_after_forcing_hidden_pieces_are_the_leaves_that_carry() {
        // Single-sample spikes far from a sphere make the hidden-piece pass split more; the
        // carriers it patches in below the leaves it split are the carrying leaves of its mesh.
        let grid = Grid::new([40, 37, 33]);
        let centre = DVec3::new(20.0, 18.0, 16.0);
        let mut v: Vec<f32> = (0..grid.len())
            .map(|i| {
                let [x, y, z] = grid.ijk(i);
                (DVec3::new(x as f64, y as f64, z as f64).distance(centre) - 8.0) as f32
            })
            .collect();
        for [x, y, z] in [
            [3, 4, 30],
            [36, 3, 5],
            [35, 33, 29],
            [4, 34, 6],
            [38, 20, 31],
        ] {
            v[grid.index(x, y, z)] = -0.5;
        }
        let h = Hierarchy::build_for_isosurfaces(grid, ScalarSlice::F32(&v)).unwrap();
        let volume = Volume::new(grid, &v[..]).unwrap();
        let cache = IsoCache::new(&volume);
        let x = Extraction {
            hierarchy: &h,
            volume: &volume,
            cache: &cache,
        };
        let sorted = |ts: &[Tet]| {
            let mut k: Vec<_> = ts.iter().map(|t| t.map(|p| p.to_array())).collect();
            k.sort();
            k
        };
        for tol in [3.0, 6.0, 10.0] {
            let query = IsoQuery::new(0.0, tol);
            let refine = refine_query(&query, tol);
            let criterion = x.iso_criterion(&query.isovalues, tol);
            let plain = Refiner::run(h.grid(), h.base(), &refine, &criterion).unwrap();
            let (split, carriers) = x
                .refine_iso(&query, tol, &mut |c| {
                    Refiner::run(h.grid(), h.base(), &refine, c)
                })
                .unwrap();
            assert!(split.len() > plain.len(), "nothing forced at {tol}");
            let fresh = x.carriers_of(&query.isovalues, &split);
            assert_eq!(sorted(&carriers), sorted(&fresh), "tolerance {tol}");
        }
    }
}
