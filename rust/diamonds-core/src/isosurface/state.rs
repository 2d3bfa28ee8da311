//! Isosurfaces across isovalue changes: the state a caller keeps between queries (Gregorski §6.1,
//! "starting at the root diamond or starting from the current mesh").
//!
//! [`IsoState`] holds the split set of the last query and the parameters it was refined for. A new
//! query with the same tolerance and region of interest (only the isovalues changed) can start from
//! that mesh (`Refiner::rerun`: a merge pass that keeps what the new isovalues still require, then the
//! usual split pass); the result is the same split set, hence the same surface, as from the root. A
//! query whose refinement parameters did not change at all (only normals or carrier output toggled)
//! reuses the split set without refining. Budget queries and tolerance or region changes start from
//! the root.
//!
//! The state also owns the [`IsoCache`] (brick ranges, gradient magnitudes, the errors of the last
//! isovalues), so it belongs to one hierarchy and the samples it was built from.
//!
//! Which start is faster was measured (see [`IsoState::extract`]): from the root, so
//! [`IsoStart::Root`] is the default; [`IsoStart::Current`] remains for callers and probes.

use super::cache::IsoCache;
use super::{check, refine_query, Extraction, IsoQuery, IsoSurface, Partition};
use crate::diamond::Diamond;
use crate::hierarchy::Hierarchy;
use crate::lattice::{Placement, Tet};
use crate::mesh;
use crate::refine::{Refiner, SplitSet};
use crate::volume::{Sample, ScalarSlice, Volume};
use crate::{with_volume, Result};
use glam::IVec3;
use std::time::Instant;

/// Where an isovalue change starts refining.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum IsoStart {
    /// From the base mesh, as [`super::extract`]: the measured default (see [`IsoState::extract`]).
    #[default]
    Root,
    /// From the current mesh whenever only the isovalues changed.
    Current,
}

/// What the last [`IsoState::extract`] call did (for probes and tests).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct IsoStats {
    /// The split set was reused as is (same isovalues, tolerance and region).
    pub reused: bool,
    /// Refined from the current mesh rather than from the root.
    pub from_current: bool,
    /// Seconds spent refining (the split set and its leaves carrying the surface).
    pub refine_seconds: f64,
    /// Seconds spent extracting the surface from the split set.
    pub extract_seconds: f64,
    /// Split diamonds of the resulting mesh.
    pub split_diamonds: usize,
}

/// The state kept between isosurface queries on one hierarchy: the current mesh and its query, and
/// the [`IsoCache`].
///
/// Keep one per hierarchy; call [`IsoState::clear`] (or make a new one) when the hierarchy or its
/// samples change.
#[derive(Debug, Default)]
pub struct IsoState {
    /// Where isovalue changes start refining.
    pub start: IsoStart,
    current: Option<Current>,
    last: Option<IsoStats>,
    /// Made by the first query.
    cache: Option<IsoCache>,
}

/// The current mesh and the query it was refined for.
#[derive(Clone, Debug)]
struct Current {
    query: IsoQuery,
    split: SplitSet,
    /// Its leaves that carry the surface.
    carriers: Vec<Tet>,
}

impl IsoState {
    /// An empty state with the measured default start.
    pub fn new() -> Self {
        Self::default()
    }

    /// An empty state that starts isovalue changes as `start` says.
    pub fn with_start(start: IsoStart) -> Self {
        Self {
            start,
            ..Self::default()
        }
    }

    /// Forgets the current mesh and the cache: the next query starts from the root and measures
    /// again (for another hierarchy or other samples).
    pub fn clear(&mut self) {
        self.forget_mesh();
        self.cache = None;
    }

    /// Forgets the current mesh but keeps the cache (same hierarchy and samples): the next query
    /// starts from the root.
    pub fn forget_mesh(&mut self) {
        self.current = None;
        self.last = None;
    }

    /// What the last query did.
    pub fn last(&self) -> Option<IsoStats> {
        self.last
    }

    /// Bytes held between queries: the cache (brick ranges, gradients, the errors of the last
    /// isovalues) and the kept adaptive mesh (its split set and the leaves carrying the surface).
    pub fn memory_bytes(&self) -> usize {
        self.cache.as_ref().map_or(0, |c| c.bytes())
            + self.current.as_ref().map_or(0, |c| {
                c.split.bytes() + c.carriers.capacity() * std::mem::size_of::<Tet>()
            })
    }

    /// The split set of the last surface [`IsoState::extract`] refined, while it is kept.
    pub(crate) fn current_split(&self) -> Option<&SplitSet> {
        self.current.as_ref().map(|c| &c.split)
    }
}

/// Does the refinement of `b` equal that of `a` except for the isovalues?
fn same_refinement(a: &IsoQuery, b: &IsoQuery) -> bool {
    a.tolerance.to_bits() == b.tolerance.to_bits()
        && a.max_triangles == 0
        && b.max_triangles == 0
        && a.region_of_interest.map(|r| r.map(f64::to_bits))
            == b.region_of_interest.map(|r| r.map(f64::to_bits))
}

impl IsoState {
    /// Extracts the isosurface(s) of `query` as [`super::extract`] does, keeping the adaptive mesh
    /// and the cache between queries (Gregorski §6.1); `scalars` must be the samples `hierarchy` was
    /// built from. The surface is always the one [`super::extract`] returns for `query` (same triangles,
    /// same points, same order). When nothing that drives refinement changed since the previous query
    /// (same isovalues, tolerance and region; only normals or carrier output), the mesh is
    /// reused without refining. When only the isovalues changed, [`IsoStart::Current`] starts from the
    /// previous mesh (merge pass, then split pass: `Refiner::rerun`); [`IsoStart::Root`] (the default)
    /// starts from the root. Budget queries (`max_triangles > 0`) and tolerance or
    /// region changes start from the root; a budget query keeps no mesh.
    ///
    /// Measured: see "Isovalue change" in `docs/benchmarks.md`.
    pub fn extract(
        &mut self,
        hierarchy: &Hierarchy,
        scalars: ScalarSlice<'_>,
        query: &IsoQuery,
    ) -> Result<IsoSurface> {
        check(hierarchy, scalars, query)?;
        with_volume!(*hierarchy.grid(), scalars, |v| self
            .extract_volume(hierarchy, &v, query, None))
    }

    /// The part of [`IsoState::extract`]'s surface that the piece of `partition` owns, for a
    /// piece of a distributed image that holds the whole image (`hierarchy` and `scalars` are the
    /// whole grid's): the triangles of the carrier leaves it owns ([`crate::hierarchy::piece::CellOwner`]: centroid in its
    /// half-open cell box), their points numbered by the whole surface in
    /// [`IsoSurface::point_ids`] (the same point, bit for bit, on every piece), and the carrier
    /// tetrahedra it owns. Over all pieces, each triangle of the whole surface once. The error
    /// bound and warnings are the whole surface's. The two-sided bound's check is shared
    /// ([`Partition`]): each piece checks the surface of the carriers and the cells of the
    /// full-resolution surface it owns, and every round's violations reach every piece through the
    /// partition's exchange, so each refines as one whole check does. Every piece must call it
    /// with the same query and the same state (the same queries before, none failed on one piece
    /// alone: [`IsoState::clear`] after a failure elsewhere), so that all exchange alike.
    pub fn extract_shared(
        &mut self,
        hierarchy: &Hierarchy,
        scalars: ScalarSlice<'_>,
        query: &IsoQuery,
        partition: &Partition<'_>,
    ) -> Result<IsoSurface> {
        check(hierarchy, scalars, query)?;
        with_volume!(*hierarchy.grid(), scalars, |v| self.extract_volume(
            hierarchy,
            &v,
            query,
            Some(partition)
        ))
    }

    fn extract_volume<T: Sample>(
        &mut self,
        hierarchy: &Hierarchy,
        volume: &Volume<'_, T>,
        query: &IsoQuery,
        partition: Option<&Partition<'_>>,
    ) -> Result<IsoSurface> {
        let owner = partition.map(|p| &p.owner);
        self.last = None;
        if self.cache.as_ref().is_some_and(|c| !c.fits(&volume.grid)) {
            self.cache = None;
        }
        let cache = self.cache.get_or_insert_with(|| IsoCache::new(volume));
        let x = Extraction {
            hierarchy,
            volume,
            cache,
            partition,
        };
        if query.max_triangles > 0 {
            self.current = None;
            return x.isosurface_of(query, owner);
        }
        let t = Instant::now();
        let mut stats = IsoStats::default();
        let previous = self.current.take().filter(|c| {
            c.split.lattice() == hierarchy.lattice() && same_refinement(&c.query, query)
        });
        let refine = refine_query(query, query.tolerance);
        let (grid, base) = (hierarchy.grid(), hierarchy.base());
        let (split, carriers) = match previous {
            Some(c) if c.query.isovalues == query.isovalues => {
                stats.reused = true;
                let carriers = c.carriers;
                (c.split, carriers)
            }
            Some(c) if self.start == IsoStart::Current => {
                stats.from_current = true;
                x.refine_iso(query, query.tolerance, &mut |criterion| {
                    Refiner::rerun(grid, base, &refine, criterion, &c.split)
                })?
            }
            _ => x.refine_iso(query, query.tolerance, &mut |criterion| {
                Refiner::run(grid, base, &refine, criterion)
            })?,
        };
        stats.refine_seconds = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let surface = x.surface_of(query, query.tolerance, &carriers, owner)?;
        stats.extract_seconds = t.elapsed().as_secs_f64();
        stats.split_diamonds = split.len();
        self.current = Some(Current {
            query: query.clone(),
            split,
            carriers,
        });
        self.last = Some(stats);
        Ok(surface)
    }
}

impl IsoState {
    /// What `keep` makes of the leaves of the mesh that [`IsoState::extract`] refines `query` to
    /// (no budget: `query.max_triangles` is ignored; the two-sided bound checked for every
    /// isovalue), skipping subtrees whose samples all lie outside `range`, and the isosurface
    /// error bound of the carriers, as [`IsoSurface::error_bound`], and the split set of the mesh.
    /// For extractions that read
    /// more of the mesh than the surface: interval volumes ([`crate::interval`]) keep the leaves
    /// that meet their isorange. Uses the cache but keeps no mesh.
    ///
    /// The isosurface-only hierarchy has no base mesh: a diamond straddling a far face of the
    /// domain is split only where the surface may pass, and its tetrahedra have corners without
    /// samples. Here every straddling diamond whose samples may meet `range` is split too, so that
    /// the leaves meeting `range` are inside the grid (their closure may refine the surfaces near
    /// the far faces beyond what [`IsoState::extract`] draws there; grids of `2^k + 1` points per
    /// axis have no far faces inside the lattice). The surfaces bound the leaves kept: the bound's
    /// check is for the boundary of `{α ≤ f ≤ β}` (`range`), a face drawn from both sides being no
    /// part of it ([`Extraction::certify_solid`]). With a `partition`, the pieces share the error
    /// measurement and the bound's check as in [`IsoState::extract_shared`] (the same leaves on
    /// every piece).
    pub(crate) fn refined_leaves<T: Sample, X: Send>(
        &mut self,
        hierarchy: &Hierarchy,
        volume: &Volume<'_, T>,
        query: &IsoQuery,
        range: [f64; 2],
        keep: impl Fn(&Tet) -> Option<X> + Sync,
        partition: Option<&Partition<'_>>,
    ) -> Result<(Vec<X>, f64, SplitSet)> {
        self.forget_mesh();
        if self.cache.as_ref().is_some_and(|c| !c.fits(&volume.grid)) {
            self.cache = None;
        }
        let cache = self.cache.get_or_insert_with(|| IsoCache::new(volume));
        let x = Extraction {
            hierarchy,
            volume,
            cache,
            partition,
        };
        let refine = refine_query(query, query.tolerance);
        let (grid, base) = (hierarchy.grid(), hierarchy.base());
        let lattice = *hierarchy.lattice();
        // A superset of the samples' range in the box `[lo, hi]` (clipped to the grid) misses
        // `range`.
        let misses = |lo: IVec3, hi: IVec3| {
            let (a, b) = x.box_range(lo.max(IVec3::ZERO), hi.min(lattice.hi));
            b < range[0] || a > range[1]
        };
        let iso = x.iso_criterion(&query.isovalues, query.tolerance)?;
        let criterion = |d: Diamond| {
            let (lo, hi) = d.bounds();
            if !hi.cmple(lattice.hi).all()
                && d.placement(&lattice) == Placement::Straddling
                && !misses(lo, hi)
            {
                f64::INFINITY
            } else {
                iso(d)
            }
        };
        let (split, carriers) = x.refine_with(
            query,
            query.tolerance,
            &mut |criterion| Refiner::run(grid, base, &refine, criterion),
            &criterion,
            Some(range),
        )?;
        let error_bound = (carriers.iter())
            .map(x.carrier_error(&query.isovalues, query.tolerance)?)
            .fold(0.0, f64::max);
        // Prunes every unsplit straddling tetrahedron: its diamond's box, which holds its own,
        // misses `range`.
        let outside = |t: &Tet| {
            misses(
                t[0].min(t[1]).min(t[2].min(t[3])),
                t[0].max(t[1]).max(t[2].max(t[3])),
            )
        };
        let leaves = mesh::leaves_where(&lattice, &split, outside, keep)?;
        Ok((leaves, error_bound, split))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fields::{marschner_lobb, sample, sphere_distance, torus_distance, unit_grid};
    use crate::isosurface::extract;
    use crate::volume::Grid;

    fn build(grid: Grid, values: &[f32]) -> Hierarchy {
        Hierarchy::build(grid, ScalarSlice::F32(values), &mut |_| true).unwrap()
    }

    fn diagonal(h: &Hierarchy) -> f64 {
        h.grid().diagonal()
    }

    fn area(s: &IsoSurface) -> f64 {
        s.triangles
            .iter()
            .map(|t| {
                let p = t.map(|i| glam::DVec3::from(s.points[i as usize]));
                0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length()
            })
            .sum()
    }

    fn point_set(s: &IsoSurface) -> Vec<[u64; 3]> {
        let mut p: Vec<[u64; 3]> = s.points.iter().map(|p| p.map(f64::to_bits)).collect();
        p.sort_unstable();
        p
    }

    /// `f` of an extraction from `h` and its samples `values`, with a fresh cache.
    fn with_extraction<R>(
        h: &Hierarchy,
        values: &[f32],
        f: impl FnOnce(&Extraction<'_, '_, f32>) -> R,
    ) -> R {
        let volume = Volume::new(*h.grid(), values).unwrap();
        let cache = IsoCache::new(&volume);
        f(&Extraction {
            hierarchy: h,
            volume: &volume,
            cache: &cache,
            partition: None,
        })
    }

    /// The from-root split set of `query` (hidden pieces far from the surface included).
    fn from_root_split(h: &Hierarchy, values: &[f32], query: &IsoQuery) -> SplitSet {
        let refine = refine_query(query, query.tolerance);
        with_extraction(h, values, |x| {
            x.refine_iso(query, query.tolerance, &mut |criterion| {
                Refiner::run(h.grid(), h.base(), &refine, criterion)
            })
            .unwrap()
            .0
        })
    }

    /// The from-root split set of the diamond error alone (no pass for hidden pieces).
    fn criterion_split(h: &Hierarchy, values: &[f32], query: &IsoQuery) -> SplitSet {
        with_extraction(h, values, |x| {
            let criterion = x.iso_criterion(&query.isovalues, query.tolerance).unwrap();
            let refine = refine_query(query, query.tolerance);
            Refiner::run(h.grid(), h.base(), &refine, &criterion).unwrap()
        })
    }

    /// Runs `sequence` through one state starting from the current mesh and checks every surface and
    /// split set against a fresh from-root query. Returns how many queries refined from the current mesh.
    fn check_sequence(h: &Hierarchy, values: &[f32], queries: &[IsoQuery]) -> usize {
        let mut state = IsoState::with_start(IsoStart::Current);
        let mut from_current = 0;
        for (k, q) in queries.iter().enumerate() {
            let s = state.extract(h, ScalarSlice::F32(values), q).unwrap();
            let stats = state.last().unwrap();
            from_current += stats.from_current as usize;
            let root = extract(h, ScalarSlice::F32(values), q).unwrap();
            let what = format!("query {k} {:?} tol {}", q.isovalues, q.tolerance);
            assert_eq!(s.triangles.len(), root.triangles.len(), "{what}");
            assert_eq!(point_set(&s), point_set(&root), "{what}");
            let (a, b) = (area(&s), area(&root));
            assert!(
                (a - b).abs() <= 1e-12 * b.max(1.0),
                "{what}: area {a} vs {b}"
            );
            assert_eq!(s, root, "{what}");
            let split = &state.current.as_ref().unwrap().split;
            assert_eq!(*split, from_root_split(h, values, q), "{what}");
            assert_eq!(stats.split_diamonds, split.len());
        }
        from_current
    }

    fn queries(isovalues: &[&[f64]], tolerance: f64) -> Vec<IsoQuery> {
        isovalues
            .iter()
            .map(|v| IsoQuery {
                isovalues: v.to_vec(),
                ..IsoQuery::new(0.0, tolerance)
            })
            .collect()
    }

    /// Up, down, small steps, jumps, back to the first, several isovalues at once.
    const ML_SEQUENCE: &[&[f64]] = &[
        &[0.5],
        &[0.51],
        &[0.53],
        &[0.47],
        &[0.2],
        &[0.8],
        &[0.5],
        &[0.3, 0.6],
        &[0.32, 0.61, 0.9],
        &[0.5],
        &[0.05],
    ];

    #[test]
    fn marschner_lobb_from_current_equals_from_root() {
        for dims in [[33, 29, 41], [33, 33, 33], [17, 17, 17]] {
            let grid = unit_grid(dims);
            let v = sample(&grid, |x, y, z| marschner_lobb(x, y, z) as f32);
            let h = build(grid, &v);
            let d = diagonal(&h);
            for tol in [0.02 * d, 0.005 * d, 0.0] {
                let n = check_sequence(&h, &v, &queries(ML_SEQUENCE, tol));
                assert_eq!(n, ML_SEQUENCE.len() - 1, "{dims:?} tol {tol}");
            }
        }
    }

    #[test]
    fn distance_fields_from_current_equal_from_root() {
        let sequence: &[&[f64]] = &[
            &[0.0],
            &[0.01],
            &[0.05],
            &[-0.1],
            &[0.3],
            &[-0.25, 0.2],
            &[0.0],
            &[-0.02],
        ];
        for dims in [[33, 29, 41], [41, 23, 37], [65, 65, 65]] {
            let grid = unit_grid(dims);
            for (name, v) in [
                (
                    "sphere",
                    sample(&grid, |x, y, z| sphere_distance(0.6)(x, y, z) as f32),
                ),
                (
                    "torus",
                    sample(&grid, |x, y, z| torus_distance(0.55, 0.25)(x, y, z) as f32),
                ),
            ] {
                let h = build(grid, &v);
                let d = diagonal(&h);
                for tol in [0.01 * d, 0.002 * d] {
                    let n = check_sequence(&h, &v, &queries(sequence, tol));
                    assert_eq!(n, sequence.len() - 1, "{name} {dims:?} tol {tol}");
                }
            }
        }
    }

    #[test]
    fn region_of_interest_is_kept_across_isovalues() {
        let grid = unit_grid([33, 29, 41]);
        let v = sample(&grid, |x, y, z| marschner_lobb(x, y, z) as f32);
        let h = build(grid, &v);
        let mut qs = queries(ML_SEQUENCE, 0.01 * diagonal(&h));
        for q in &mut qs {
            q.region_of_interest = Some([-0.5, 0.4, -1.0, 0.2, -0.3, 1.0]);
        }
        assert_eq!(check_sequence(&h, &v, &qs), qs.len() - 1);
    }

    #[test]
    fn other_changes_start_from_the_root_or_reuse() {
        let grid = unit_grid([33, 29, 41]);
        let v = sample(&grid, |x, y, z| marschner_lobb(x, y, z) as f32);
        let h = build(grid, &v);
        let d = diagonal(&h);
        let base = IsoQuery::new(0.5, 0.01 * d);
        let mut qs = vec![base.clone()];
        // Only normals and carriers: reused.
        qs.push(IsoQuery {
            compute_normals: false,
            carrier_tetrahedra: true,
            ..base.clone()
        });
        // Tolerance change, region change, budget, then an isovalue change after the budget.
        qs.push(IsoQuery::new(0.5, 0.004 * d));
        qs.push(IsoQuery {
            region_of_interest: Some([-1.0, 0.0, -1.0, 1.0, -1.0, 1.0]),
            ..IsoQuery::new(0.5, 0.004 * d)
        });
        qs.push(IsoQuery {
            max_triangles: 2000,
            ..IsoQuery::new(0.5, 0.001 * d)
        });
        qs.push(IsoQuery::new(0.45, 0.001 * d));
        qs.push(IsoQuery::new(0.4, 0.001 * d));
        let mut state = IsoState::with_start(IsoStart::Current);
        let mut log = Vec::new();
        for q in &qs {
            let s = state.extract(&h, ScalarSlice::F32(&v), q).unwrap();
            assert_eq!(s, extract(&h, ScalarSlice::F32(&v), q).unwrap());
            let st = state.last();
            log.push(st.map(|s| (s.reused, s.from_current)));
        }
        let expected = [
            Some((false, false)),
            Some((true, false)),
            Some((false, false)),
            Some((false, false)),
            None,
            Some((false, false)),
            Some((false, true)),
        ];
        assert_eq!(log, expected);
        // The default start is the root and gives the same surfaces.
        let mut state = IsoState::new();
        assert_eq!(state.start, IsoStart::Root);
        for q in &qs {
            let s = state.extract(&h, ScalarSlice::F32(&v), q).unwrap();
            assert_eq!(s, extract(&h, ScalarSlice::F32(&v), q).unwrap());
        }
    }

    #[test]
    fn errors_leave_a_usable_state() {
        let grid = unit_grid([17, 17, 17]);
        let v = sample(&grid, |x, y, z| marschner_lobb(x, y, z) as f32);
        let h = build(grid, &v);
        let mut state = IsoState::with_start(IsoStart::Current);
        let q = IsoQuery::new(0.5, 0.02);
        state.extract(&h, ScalarSlice::F32(&v), &q).unwrap();
        assert!(state.extract(&h, ScalarSlice::F32(&v[1..]), &q).is_err());
        assert!(state
            .extract(&h, ScalarSlice::F32(&v), &IsoQuery::new(f64::NAN, 0.02))
            .is_err());
        assert!(state
            .extract(&h, ScalarSlice::F32(&v), &IsoQuery::new(0.4, -1.0))
            .is_err());
        let q = IsoQuery::new(0.45, 0.02);
        let s = state.extract(&h, ScalarSlice::F32(&v), &q).unwrap();
        assert_eq!(s, extract(&h, ScalarSlice::F32(&v), &q).unwrap());
    }

    /// Gregorski's bottom-up merge queue alone, then the split pass: merge a split diamond (not of the
    /// base mesh) with no split child while its criterion meets the tolerance.
    fn bottom_up_rerun(
        h: &Hierarchy,
        values: &[f32],
        query: &IsoQuery,
        old: &SplitSet,
    ) -> SplitSet {
        with_extraction(h, values, |x| {
            let criterion = x.iso_criterion(&query.isovalues, query.tolerance).unwrap();
            let lattice = *h.lattice();
            let mut split = old.clone();
            let mut merge: Vec<_> = crate::diamond::all_diamonds(&lattice)
                .into_iter()
                .filter(|&d| split.contains(d))
                .collect();
            while let Some(d) = merge.pop() {
                let leaf = d.children(&lattice).iter().all(|&c| !split.contains(c));
                if !split.contains(d) || h.base().split.contains(d) || !leaf {
                    continue;
                }
                if criterion(d) <= query.tolerance {
                    split.remove(d);
                    merge.extend(d.parents(&lattice));
                }
            }
            let candidates = Refiner::candidates(&lattice, &split);
            Refiner::new(lattice, split, 0, &criterion)
                .refine_with(query.tolerance, &candidates)
                .0
        })
    }

    /// A smooth field plus uniform noise on `dims` (deterministic in `seed`), and six isovalues: the
    /// noise makes isolated non-empty diamonds whose parents are split only for their closure.
    fn noisy(seed: u64, dims: [usize; 3]) -> (Grid, Vec<f32>, Vec<f64>) {
        let grid = unit_grid(dims);
        let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let mut rnd = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x % 10000) as f64 / 10000.0
        };
        let smooth = rnd() * 6.0;
        let (a, b, c) = (rnd() * 8.0, rnd() * 8.0, rnd() * 8.0);
        let noise: Vec<f64> = (0..grid.len()).map(|_| rnd()).collect();
        let v = sample(&grid, |x, y, z| {
            (a * x).sin() * (b * y).cos() + (c * z).sin() * smooth
        })
        .iter()
        .zip(&noise)
        .map(|(f, n)| (f + 0.5 * n) as f32)
        .collect();
        let isovalues = (0..6).map(|_| rnd() * 2.0 - 1.0).collect();
        (grid, v, isovalues)
    }

    const NOISY: [(u64, [usize; 3]); 4] = [
        (1, [17, 17, 17]),
        (3, [17, 9, 13]),
        (5, [17, 17, 17]),
        (7, [17, 9, 13]),
    ];

    /// The bottom-up merge queue alone keeps diamonds from-root does not reach (a split diamond above
    /// the tolerance whose parents are split only for its closure): the merge pass must compute what
    /// remains needed from the base mesh, as `Refiner::rerun` does.
    #[test]
    fn bottom_up_merge_alone_keeps_unreachable_diamonds() {
        let (mut extra, mut changes) = (0, 0);
        for (seed, dims) in NOISY {
            let (grid, v, isovalues) = noisy(seed, dims);
            let h = build(grid, &v);
            let d = diagonal(&h);
            for tol in [0.05 * d, 0.02 * d] {
                for w in isovalues.windows(2) {
                    let (q0, q1) = (IsoQuery::new(w[0], tol), IsoQuery::new(w[1], tol));
                    let old = criterion_split(&h, &v, &q0);
                    let new = criterion_split(&h, &v, &q1);
                    let bottom_up = bottom_up_rerun(&h, &v, &q1, &old);
                    let all = crate::diamond::all_diamonds(h.lattice());
                    // Never fewer than from-root (it only merges what the new criterion allows) …
                    assert!(all
                        .iter()
                        .all(|&d| !new.contains(d) || bottom_up.contains(d)));
                    // … but sometimes more.
                    extra += all
                        .iter()
                        .filter(|&&d| bottom_up.contains(d) && !new.contains(d))
                        .count();
                    changes += 1;
                }
            }
        }
        assert!(extra > 0, "{changes} isovalue changes, no extra diamond");
    }

    #[test]
    fn noisy_fields_from_current_equal_from_root() {
        for (seed, dims) in NOISY {
            let (grid, v, isovalues) = noisy(seed, dims);
            let h = build(grid, &v);
            let d = diagonal(&h);
            let mut sequence: Vec<&[f64]> = isovalues.chunks(1).collect();
            sequence.push(&isovalues[..3]);
            sequence.push(&isovalues[..1]);
            for tol in [0.05 * d, 0.02 * d, 0.01 * d] {
                let n = check_sequence(&h, &v, &queries(&sequence, tol));
                assert_eq!(n, sequence.len() - 1, "seed {seed} tol {tol}");
            }
        }
    }
}
