//! The two-sided bound, by a check that refines until it holds (beyond Gregorski §6.2, whose
//! `ae / ‖∇T‖` only estimates the distance: the linear surface of a tetrahedron and the data's surface
//! can be farther apart than it says near the tetrahedron's faces, and a tetrahedron whose vertices
//! all lie on one side of the isovalue hides whatever its samples draw — a speck, a thin branch).
//!
//! Relative to the full-resolution surface `F` ([`super::fine`]) and for every isovalue, after the
//! refinement by the isosurface error, the surface `S` drawn from the carrier leaves is checked:
//! - every vertex of `F` lies within the tolerance of `S`;
//! - every point of [`triangle_samples`] of the triangles of `S` (its vertices and points spaced at
//!   most `h`, the smallest grid spacing) lies within the tolerance of `F` — the output's triangles
//!   ([`super::fine::output_triangles`]): another triangulation of a polygon has other samples.
//!
//! Distances are certified cheaply where possible ([`super::blocks`]): a point of `F` within a block
//! of a sample of `S` is within the tolerance of `S`, and a sample of `S` within a block of a vertex
//! of `F` is within it of `F`. The rest are measured exactly: each vertex of `F` left against the
//! triangles of `S` near it, from an [`rstar`] R-tree of them (stopping at the first within the
//! tolerance), the triangles of
//! `F` within the tolerance of a sample of `S` from the grid cells around it that `F` crosses
//! ([`super::fine::cell_triangles`]). Every point that fails is a *violation*: the leaf holding it is
//! split — the diamonds on the path from the root down to the tetrahedra around the point no larger
//! than the tolerance, or, when the leaf already is, down to the finest tetrahedra — with closure,
//! refinement continues from that mesh, and the check runs again. On the finest tetrahedra `S` is `F`,
//! so this ends; every round splits at least one more diamond. A round after the first checks only
//! what the splits may have changed: the surface of the new carriers and of the carriers that held a
//! violation, and the vertices of F within the tolerance of a carrier that was split (the surface
//! that certified them may be gone) or that were violations; everything else was certified by
//! surface that is still there, against the same `F`.
//!
//! Both directions are checked against the tolerance less a millionth of the volume's diagonal (at
//! most half the tolerance), for rounding (points written in single precision). Points outside the region of interest are not
//! checked (the tolerance applies inside it).

use super::blocks::{bits, set_bit, Blocks};
use super::error::{child_coordinates, tet_size2, RootTets};
use super::fine::{cell_triangles, output_triangles, vertices_from};
use super::marching::carries;
use super::{value, world};
use super::{Extraction, IsoQuery};
use crate::diamond::{child_of, Diamond};
use crate::geometry::{point_triangle_distance, triangle_samples, triangle_tree};
use crate::lattice::Tet;
use crate::mesh;
use crate::refine::{Refiner, SplitSet};
use crate::volume::{Grid, Sample};
use crate::Result;
use glam::{DVec3, IVec3};
use rayon::prelude::*;
use rustc_hash::FxHashSet;
use std::sync::atomic::AtomicU64;

/// The full-resolution surface F of one isovalue as the check reads it.
struct Fine {
    /// Its vertices (inside the region of interest).
    vertices: Vec<DVec3>,
    /// The blocks around its vertices.
    blocks: Blocks,
    /// The grid cells it crosses, a bit per lower corner (point index).
    crossed: Vec<u64>,
}

/// Rounds of checking and splitting at most (each splits at least one diamond; in practice a few).
const MAX_ROUNDS: usize = 64;

impl<T: Sample> Extraction<'_, '_, T> {
    /// `split` (refined for `query` at `tolerance` > 0 with `criterion`) refined further until its
    /// surface meets the two-sided bound, and its leaves that carry the surface.
    pub(super) fn certify(
        &self,
        query: &IsoQuery,
        tolerance: f64,
        mut split: SplitSet,
        criterion: impl Fn(Diamond) -> f64,
    ) -> Result<(SplitSet, Vec<Tet>)> {
        let isovalues = &query.isovalues;
        let mut carriers = self.carriers_of(isovalues, &split)?;
        let grid = &self.volume.grid;
        let reach = tolerance - (1e-6 * grid.diagonal()).min(0.5 * tolerance);
        let inside = |p: DVec3| {
            query
                .region_of_interest
                .is_none_or(|r| (0..3).all(|a| r[2 * a] <= p[a] && p[a] <= r[2 * a + 1]))
        };
        // F, per isovalue, once.
        let b = grid.bounds();
        let (lo, hi) = (DVec3::new(b[0], b[2], b[4]), DVec3::new(b[1], b[3], b[5]));
        let fine = isovalues
            .iter()
            .map(|&v| {
                let cells = self.cache.bricks.cells_crossed(self.volume, v);
                let points = super::error::corners_of(grid.dims, &cells);
                let mut vertices = vertices_from(self.volume, v, &points);
                vertices.retain(|&p| inside(p));
                let blocks = Blocks::around(lo, hi, reach, &vertices)?;
                let crossed = bits(grid.len());
                cells.par_iter().for_each(|&c| {
                    set_bit(&crossed, c as usize);
                });
                let crossed = crossed.into_iter().map(AtomicU64::into_inner).collect();
                Ok(Fine {
                    vertices,
                    blocks,
                    crossed,
                })
            })
            .collect::<Result<Vec<Fine>>>()?;
        // What each round checks, per isovalue: the first everything; then what the splits of the
        // round before may have changed (see `Pending`).
        let mut pending: Vec<Pending> = fine.iter().map(|_| Pending::All).collect();
        for _ in 0..MAX_ROUNDS {
            let mut violations = Vec::new();
            let mut far = Vec::with_capacity(isovalues.len());
            for ((&v, fine), pending) in isovalues.iter().zip(&fine).zip(&pending) {
                let found = self.violations(v, &carriers, fine, pending, reach, &inside)?;
                // One per block: the splits a violation causes cover its neighbours in the block.
                let mut seen = FxHashSet::default();
                violations.extend(
                    (found.points.iter().copied()).filter(|&p| seen.insert(fine.blocks.block(p))),
                );
                far.push(found);
            }
            if violations.is_empty() {
                break;
            }
            let forced = self.forced(&split, &violations, tolerance);
            if forced.is_empty() {
                break;
            }
            let (removed, kept);
            (split, carriers, removed, kept) =
                self.force(isovalues, split, carriers, &forced, &criterion, tolerance);
            let near_removed = self.cells_near(&removed, reach);
            let gone: FxHashSet<Tet> = removed.into_iter().collect();
            pending = (far.into_iter().zip(&fine))
                .map(|(far, fine)| {
                    let mut again = carriers[kept..].to_vec();
                    again.extend(far.carriers.into_iter().filter(|t| !gone.contains(t)));
                    let mut vertices: Vec<u32> = (0..fine.vertices.len() as u32)
                        .into_par_iter()
                        .filter(|&i| near_removed.holds(fine.vertices[i as usize]))
                        .collect();
                    vertices.extend(far.vertices);
                    vertices.sort_unstable();
                    vertices.dedup();
                    Pending::Some {
                        carriers: again,
                        vertices,
                    }
                })
                .collect();
        }
        Ok((split, carriers))
    }
}

/// What a round of the check looks at for one isovalue. A point certified in a round stays
/// certified while the surface that certified it is there: splits remove the surface of the
/// carriers they split only, and F does not change.
enum Pending {
    /// Every sample of the surface and every vertex of F (the first round).
    All,
    /// After splits: the samples of the surface of `carriers` (the new carriers, and the old ones
    /// that held a violation and were not split) and the vertices of F numbered `vertices` (those
    /// within the reach of a carrier that was split, whose surface may have certified them, and
    /// those that were violations).
    Some {
        carriers: Vec<Tet>,
        vertices: Vec<u32>,
    },
}

/// The violations of one round for one isovalue.
struct Far {
    /// Every violating point (world).
    points: Vec<DVec3>,
    /// The carriers whose surface holds a violating sample.
    carriers: Vec<Tet>,
    /// The vertices of F that violate (numbers).
    vertices: Vec<u32>,
}

/// Grid cells marked in a bitset (a bit per lower corner's point index).
struct Cells<'g> {
    grid: &'g Grid,
    bits: Vec<u64>,
}

impl Cells<'_> {
    /// Is `p` in a marked cell (the one `floor` gives, clamped to the grid)?
    fn holds(&self, p: DVec3) -> bool {
        let g = self.grid;
        let top = DVec3::from(g.dims.map(|d| d as f64 - 2.0));
        let c = ((p - DVec3::from(g.origin)) / DVec3::from(g.spacing)).floor();
        let c = c.clamp(DVec3::ZERO, top);
        let i = g.index(c.x as usize, c.y as usize, c.z as usize);
        self.bits[i / 64] & (1 << (i % 64)) != 0
    }
}

impl<T: Sample> Extraction<'_, '_, T> {
    /// The grid cells within `reach` (world) of the bounding box of one of `tets`.
    fn cells_near(&self, tets: &[Tet], reach: f64) -> Cells<'_> {
        let grid = &self.volume.grid;
        let marked = bits(grid.len());
        let (margin, hi) = (
            reach / DVec3::from(grid.spacing),
            IVec3::from(grid.dims.map(|d| d as i32 - 2)),
        );
        tets.par_iter().for_each(|t| {
            let lo = t[0].min(t[1]).min(t[2].min(t[3])).as_dvec3() - margin;
            let up = t[0].max(t[1]).max(t[2].max(t[3])).as_dvec3() + margin;
            let (lo, up) = (
                lo.floor().as_ivec3().max(IVec3::ZERO),
                up.floor().as_ivec3().min(hi),
            );
            for z in lo.z..=up.z {
                for y in lo.y..=up.y {
                    for x in lo.x..=up.x {
                        set_bit(&marked, grid.index(x as usize, y as usize, z as usize));
                    }
                }
            }
        });
        Cells {
            grid,
            bits: marked.into_iter().map(AtomicU64::into_inner).collect(),
        }
    }
}

impl<T: Sample> Extraction<'_, '_, T> {
    /// The points that break the bound for isovalue `v` on the surface of `carriers`, among those
    /// `pending` names: vertices of F (`fine`) farther than `reach` from the surface, samples of the
    /// surface farther than `reach` from F.
    fn violations(
        &self,
        v: f64,
        carriers: &[Tet],
        fine: &Fine,
        pending: &Pending,
        reach: f64,
        inside: &(dyn Fn(DVec3) -> bool + Sync),
    ) -> Result<Far> {
        let volume = self.volume;
        let grid = &volume.grid;
        // The surface of a carrier as the output draws it: its samples are those of the output's
        // triangles (another triangulation of the polygon covers the same points, but at other
        // samples: checked at those, the output's went 0.348 from F at tolerance 0.3, on a volume
        // of spacings 0.7, 1.3 and 2.1).
        let surface_of = |t: &Tet| {
            let corners = t.map(|q| world(volume, q));
            output_triangles(t, corners, t.map(|q| value(volume, q)), v)
                .into_iter()
                .filter(|t| (t[1] - t[0]).cross(t[2] - t[0]) != DVec3::ZERO)
        };
        let h = grid.spacing.into_iter().fold(f64::INFINITY, f64::min);
        let checked = match pending {
            Pending::All => carriers,
            Pending::Some { carriers, .. } => carriers,
        };
        // The checked surface's triangles with their carriers, marched once: the samples come from
        // them, and so does the R-tree below when every carrier is checked (the first round).
        let checked_triangles: Vec<([DVec3; 3], u32)> = (checked.par_iter().enumerate())
            .flat_map_iter(|(k, t)| surface_of(t).map(move |t| (t, k as u32)))
            .collect();
        let (samples, owners): (Vec<DVec3>, Vec<u32>) = (checked_triangles.par_iter())
            .flat_map_iter(|&(t, k)| {
                triangle_samples(t, h)
                    .filter(|&p| inside(p))
                    .map(move |p| (p, k))
            })
            .unzip();
        let all_triangles = matches!(pending, Pending::All).then_some(checked_triangles);
        // F → S: vertices of F near a block of the checked surface's samples are within `reach` of
        // it (blocks: a point near a block of the other set is within `reach` of it); each of the
        // others is looked up in an R-tree of the triangles of S, stopping at the first within
        // `reach` — most are, so a vertex costs a few distance tests.
        let with_samples = fine.blocks.alike(&samples)?;
        let far_from_samples = |i: &u32| !with_samples.near(fine.vertices[*i as usize]);
        let open: Vec<u32> = match pending {
            Pending::All => (0..fine.vertices.len() as u32)
                .into_par_iter()
                .filter(far_from_samples)
                .collect(),
            Pending::Some { vertices, .. } => vertices
                .par_iter()
                .copied()
                .filter(far_from_samples)
                .collect(),
        };
        let vertices: Vec<u32> = if open.is_empty() {
            Vec::new()
        } else {
            let tree = match all_triangles {
                Some(triangles) => triangle_tree(triangles.into_iter().map(|(t, _)| t)),
                None => {
                    let triangles: Vec<[DVec3; 3]> =
                        carriers.par_iter().flat_map_iter(surface_of).collect();
                    triangle_tree(triangles.into_iter())
                }
            };
            let reach2 = reach * reach;
            open.into_par_iter()
                .filter(|&i| {
                    let p = fine.vertices[i as usize].to_array();
                    tree.locate_within_distance(p, reach2).next().is_none()
                })
                .collect()
        };
        // S → F.
        let (origin, spacing) = (DVec3::from(grid.origin), DVec3::from(grid.spacing));
        let hi = IVec3::from(grid.dims.map(|d| d as i32 - 2));
        let far_samples: Vec<usize> = (0..samples.len())
            .into_par_iter()
            .filter(|&k| !fine.blocks.near(samples[k]))
            .filter(|&k| {
                // The crossed cells around p's, then all those within `reach` of p (lower
                // corners).
                let p = samples[k];
                let cell = |p: DVec3| ((p - origin) / spacing).floor().as_ivec3();
                let near = |lo: IVec3, up: IVec3| {
                    let (lo, up) = (lo.max(IVec3::ZERO), up.min(hi));
                    (lo.z..=up.z).any(|z| {
                        (lo.y..=up.y).any(|y| {
                            (lo.x..=up.x).any(|x| {
                                let i = grid.index(x as usize, y as usize, z as usize);
                                fine.crossed[i / 64] & (1 << (i % 64)) != 0
                                    && cell_triangles(volume, IVec3::new(x, y, z), v)
                                        .iter()
                                        .any(|t| point_triangle_distance(p, *t) <= reach)
                            })
                        })
                    })
                };
                let c = cell(p);
                !(near(c - IVec3::ONE, c + IVec3::ONE) || near(cell(p - reach), cell(p + reach)))
            })
            .collect();
        let mut far_carriers: Vec<u32> = far_samples.iter().map(|&k| owners[k]).collect();
        far_carriers.dedup();
        Ok(Far {
            points: (vertices.iter().map(|&i| fine.vertices[i as usize]))
                .chain(far_samples.iter().map(|&k| samples[k]))
                .collect(),
            carriers: far_carriers.iter().map(|&k| checked[k as usize]).collect(),
            vertices,
        })
    }

    /// The diamonds to split for `violations` (world points): for each, the diamonds on the path from
    /// the root to the tetrahedron holding it below its leaf in `split` that is no larger than
    /// `tolerance` — or, when the leaf already is, to the finest tetrahedron holding it. In order,
    /// each once; none when every point lies in a finest leaf.
    fn forced(&self, split: &SplitSet, violations: &[DVec3], tolerance: f64) -> Vec<Diamond> {
        let lattice = *self.lattice();
        let grid = &self.volume.grid;
        let (origin, spacing) = (DVec3::from(grid.origin), DVec3::from(grid.spacing));
        let top = lattice.hi.as_dvec3();
        let roots = RootTets::new(&lattice);
        let tolerance2 = tolerance * tolerance;
        let paths: Vec<Vec<Diamond>> = violations
            .par_iter()
            .map(|&p| {
                let u = ((p - origin) / spacing).clamp(DVec3::ZERO, top);
                let (k, mut l) = roots.containing(u);
                let mut t = roots.tets[k].0;
                let step = |t: &Tet, l: [f64; 4], m: IVec3| {
                    let (first, nl) = child_coordinates(t, l);
                    (child_of(t, first, *t, t[usize::from(!first)], m), nl)
                };
                // Down to the leaf.
                while let Some(d) = Diamond::of_tet(&t).filter(|&d| split.contains(d)) {
                    (t, l) = step(&t, l, d.center);
                }
                // Below it, to no larger than the tolerance; to the finest if it already is.
                let to_finest = tet_size2(&grid.spacing, &t) <= tolerance2;
                let mut path = Vec::new();
                let mut below = false;
                while let Some(d) = Diamond::of_tet(&t) {
                    if below && !to_finest && tet_size2(&grid.spacing, &t) <= tolerance2 {
                        break;
                    }
                    below = true;
                    if lattice.in_domain(d.center) {
                        path.push(d);
                    }
                    (t, l) = step(&t, l, d.center);
                }
                path
            })
            .collect();
        let mut seen = FxHashSet::default();
        paths
            .into_iter()
            .flatten()
            .filter(|&d| seen.insert(d))
            .collect()
    }
}

impl<T: Sample> Extraction<'_, '_, T> {
    /// `split` with the `forced` diamonds split too (with closure) and refinement by `criterion` at
    /// `tolerance` continued from there, and its leaves that carry the surface of `isovalues`
    /// (`carriers`, those of `split`, patched: those still leaves first, their number last), and the
    /// carriers that were split.
    fn force(
        &self,
        isovalues: &[f64],
        split: SplitSet,
        carriers: Vec<Tet>,
        forced: &[Diamond],
        criterion: &dyn Fn(Diamond) -> f64,
        tolerance: f64,
    ) -> (SplitSet, Vec<Tet>, Vec<Tet>, usize) {
        let (volume, lattice) = (self.volume, *self.lattice());
        // Continue from this mesh: split the forced diamonds (with closure) and whatever their new
        // children need. Every diamond above the tolerance in the result is reachable from the
        // diamonds split here, so this equals refining from the root with the forced diamonds
        // infinitely wrong.
        let forced_set: FxHashSet<Diamond> = forced.iter().copied().collect();
        let criterion = |d: Diamond| {
            if forced_set.contains(&d) {
                f64::INFINITY
            } else {
                criterion(d)
            }
        };
        let (split, newly) =
            Refiner::new(lattice, split, 0, &criterion).refine_logged(tolerance, forced);
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
        let (removed, mut carriers): (Vec<Tet>, Vec<Tet>) = carriers
            .into_iter()
            .partition(|t| Diamond::of_tet(t).is_some_and(|d| newly_split.contains(&d)));
        let kept = carriers.len();
        let empty = |t: &Tet| self.misses(isovalues, t);
        let keep = |t: &Tet| carries(volume, isovalues, t).then_some(*t);
        for d in &newly {
            for t in d.tets(&lattice).into_iter().filter(|t| was_leaf(d, t)) {
                carriers.extend(mesh::leaves_below(&lattice, &split, t, &empty, &keep));
            }
        }
        (split, carriers, removed, kept)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hierarchy::Hierarchy;
    use crate::isosurface::cache::IsoCache;
    use crate::isosurface::refine_query;
    use crate::volume::{Grid, ScalarSlice, Volume};

    #[test]
    fn carriers_after_forcing_are_the_leaves_that_carry() {
        // Single-sample spikes far from a sphere make the check split more; the carriers patched in
        // below the leaves it split are the carrying leaves of its mesh.
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
            let fresh = x.carriers_of(&query.isovalues, &split).unwrap();
            assert_eq!(sorted(&carriers), sorted(&fresh), "tolerance {tol}");
        }
    }
}
