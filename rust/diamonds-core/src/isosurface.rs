//! Multiresolution isosurfaces from the diamond hierarchy (Gregorski §6, §6.1–6.2; Weiss & De Floriani
//! §2.1, §5.1).
//!
//! A query refines the hierarchy with the *isosurface error* of Gregorski §6.2 as the diamond error:
//! for each tetrahedron `T` of a diamond, `ie_T = ae / ‖∇T‖` (the diamond's approximation error over the
//! magnitude of the tetrahedron's linear gradient, in world units) clamped to the tetrahedron's size,
//! because a surface drawn through `T` never leaves it. `ae` is measured per query at the samples that
//! decide the surface ([`crate::iso_error`]), so no per-diamond precomputation over the volume is
//! needed ([`Hierarchy::build_for_isosurfaces`]). Diamonds whose sample range misses every isovalue are
//! *empty* (Gregorski §6.1) and never split; diamonds straddling a far face of the domain are split
//! where the surface may pass. Tolerance 0 splits every non-empty diamond, so the surface is exactly
//! the full-resolution one.
//!
//! Beyond the paper: the surface of a coarse tetrahedron whose vertices all lie on one side of the
//! isovalue is lost, and a small closed piece (a speck of noise, a thin branch) lost that way can lie
//! far from every drawn triangle — the local error cannot see it. After refining, the pieces hidden in
//! leaves farther than the tolerance (plus a voxel) from the drawn surface are found and the diamonds
//! down to one sample of each are split; so every part of the full-resolution surface ends up within
//! about the tolerance of the result, which bounds the Hausdorff distance from that side.
//!
//! The surface is extracted from the leaves of the adaptive, conforming mesh by marching tetrahedra; a
//! point is shared by every triangle through its mesh edge, so the surface is crack-free wherever the
//! full-resolution one is.

use crate::diamond::{signed_volume6, Diamond};
use crate::hierarchy::record::{decode_error, encode_down};
use crate::iso_error::{
    far_hidden_samples, paths_to, smallest_gradient, tet_gradient, world, IsoErrors,
};
use crate::lattice::{Lattice, Placement, Tet};
use crate::refine::{Query, Refiner, SplitSet};
use crate::volume::{Sample, Volume};
use crate::{with_volume, Error, Hierarchy, Result, ScalarSlice, TetMesh};
use glam::{DVec3, I64Vec3, IVec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU16, Ordering};
use std::sync::{Arc, Mutex};

/// An isosurface query.
#[derive(Clone, Debug, PartialEq)]
pub struct IsoQuery {
    /// One or more isovalues, in data units.
    pub isovalues: Vec<f64>,
    /// Isosurface error bound in world units (Gregorski §6.2: approximation error over gradient
    /// magnitude, clamped to the tetrahedron's size); 0 = full resolution wherever the surface passes.
    pub tolerance: f64,
    /// Maximum number of triangles, 0 = no limit.
    pub max_triangles: usize,
    /// World-space box `[xmin, xmax, ymin, ymax, zmin, zmax]`: the tolerance applies inside, coarse outside.
    pub region_of_interest: Option<[f64; 6]>,
    /// Compute point normals from the gradient at the lattice points.
    pub compute_normals: bool,
    /// Also return the tetrahedra that carry the surface.
    pub carrier_tetrahedra: bool,
}

impl IsoQuery {
    /// One isovalue at `tolerance`, with normals.
    pub fn new(isovalue: f64, tolerance: f64) -> Self {
        Self {
            isovalues: vec![isovalue],
            tolerance,
            max_triangles: 0,
            region_of_interest: None,
            compute_normals: true,
            carrier_tetrahedra: false,
        }
    }
}

/// An extracted isosurface.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IsoSurface {
    /// World coordinates of each point.
    pub points: Vec<[f64; 3]>,
    /// Unit normals toward increasing values (empty unless asked for).
    pub normals: Vec<[f32; 3]>,
    /// Triangles, oriented so that their normal points toward increasing values.
    pub triangles: Vec<[u32; 3]>,
    /// The isovalue of each point.
    pub values: Vec<f64>,
    /// Largest isosurface error (world units) of the diamonds carrying the surface.
    pub error_bound: f64,
    /// The tetrahedra carrying the surface, when asked for.
    pub carrier: Option<TetMesh>,
}

impl Hierarchy {
    /// Extracts the isosurface(s) of `query` from the adaptive mesh; `scalars` must be the samples the
    /// hierarchy was built from. Each call refines from the root; [`Hierarchy::isosurface_from`] keeps
    /// the mesh between isovalues.
    pub fn isosurface(&self, scalars: ScalarSlice<'_>, query: &IsoQuery) -> Result<IsoSurface> {
        self.check_iso(scalars, query)?;
        with_volume!(*self.grid(), scalars, |v| self.isosurface_of(&v, query))
    }

    /// Refuses empty or non-finite isovalues and samples that do not match the grid.
    pub(crate) fn check_iso(&self, scalars: ScalarSlice<'_>, query: &IsoQuery) -> Result<()> {
        if query.isovalues.is_empty() || query.isovalues.iter().any(|v| !v.is_finite()) {
            return Err(Error::Parameter(format!(
                "isovalues must be one or more finite numbers (got {:?})",
                query.isovalues
            )));
        }
        if scalars.len() != self.grid().len() {
            return Err(Error::Length {
                len: scalars.len(),
                expected: self.grid().len(),
                dims: self.grid().dims,
            });
        }
        Ok(())
    }

    pub(crate) fn isosurface_of<T: Sample>(
        &self,
        volume: &Volume<'_, T>,
        query: &IsoQuery,
    ) -> Result<IsoSurface> {
        let mut carriers = self.carriers_at(volume, query, query.tolerance)?;
        let mut used = query.tolerance;
        if query.max_triangles > 0
            && count_triangles(volume, &carriers, &query.isovalues) > query.max_triangles
        {
            // Budget: the smallest tolerance whose surface fits, by bisection on the tolerance (the
            // triangle count does not grow with it; it is counted without building the surface). At
            // the data diagonal nothing non-empty is split.
            let b = self.grid().bounds();
            let diagonal = DVec3::new(b[1] - b[0], b[3] - b[2], b[5] - b[4]).length();
            let (mut lo, mut hi) = (query.tolerance, diagonal.max(query.tolerance));
            carriers = self.carriers_at(volume, query, hi)?;
            for _ in 0..24 {
                let mid = 0.5 * (lo + hi);
                let c = self.carriers_at(volume, query, mid)?;
                if count_triangles(volume, &c, &query.isovalues) <= query.max_triangles {
                    (hi, carriers) = (mid, c);
                } else {
                    lo = mid;
                }
                if hi - lo <= 1e-3 * hi {
                    break;
                }
            }
            used = hi;
        }
        Ok(self.surface_of(volume, query, used, &carriers))
    }

    /// Marching tetrahedra on `carriers` (refined at `tolerance`), with the error bound and, when asked
    /// for, the carrier mesh.
    pub(crate) fn surface_of<T: Sample>(
        &self,
        volume: &Volume<'_, T>,
        query: &IsoQuery,
        tolerance: f64,
        carriers: &[Tet],
    ) -> IsoSurface {
        let mut surface =
            marching_tetrahedra(volume, carriers, &query.isovalues, query.compute_normals);
        // At tolerance 0 the surface is the full-resolution one: error 0.
        let errors =
            (tolerance > 0.0).then(|| self.iso_errors(volume, &query.isovalues, tolerance));
        let error = |t: &Tet| match (&errors, Diamond::of_tet(t)) {
            (Some(errors), Some(d)) if self.lattice().in_domain(d.center) => {
                errors.error(self, volume, d)
            }
            _ => 0.0,
        };
        surface.error_bound = carriers.iter().map(error).fold(0.0, f64::max);
        if query.carrier_tetrahedra {
            surface.carrier = Some(carrier_mesh(self, carriers, error));
        }
        surface
    }

    /// The leaves of the mesh refined for `query` at `tolerance` that carry the surface.
    fn carriers_at<T: Sample>(
        &self,
        volume: &Volume<'_, T>,
        query: &IsoQuery,
        tolerance: f64,
    ) -> Result<Vec<Tet>> {
        let refine = refine_query(query, tolerance);
        let (_, carriers) = self.refine_iso(volume, query, tolerance, &mut |criterion| {
            Refiner::run(self.grid(), self.base(), &refine, criterion)
        })?;
        Ok(carriers)
    }

    /// The split set of `query`'s isovalues at `tolerance` and its leaves that carry the surface.
    /// `refine` splits with the diamond error it is given (from the root or from a current mesh).
    /// When parts of the surface hidden in leaves ([`crate::iso_error`]) lie farther than the
    /// tolerance (plus a voxel diagonal) from the surface drawn, the diamonds down to one sample of
    /// each such part are split as well and `refine` runs again, so every part of the full-resolution
    /// surface is drawn within the tolerance.
    pub(crate) fn refine_iso<T: Sample>(
        &self,
        volume: &Volume<'_, T>,
        query: &IsoQuery,
        tolerance: f64,
        refine: &mut RefineWith<'_>,
    ) -> Result<(SplitSet, Vec<Tet>)> {
        let isovalues = &query.isovalues;
        let criterion = self.iso_criterion(volume, isovalues, tolerance);
        let split = refine(&criterion)?;
        if tolerance == 0.0 {
            // Full resolution wherever the surface may pass: nothing is hidden.
            let carriers = self.carriers_of(volume, isovalues, &split);
            return Ok((split, carriers));
        }
        let errors = self.iso_errors(volume, isovalues, tolerance);
        let lattice = *self.lattice();
        // The leaves that carry the surface and those that hide part of it.
        let empty = |t: &Tet| self.misses(volume, isovalues, t);
        let (carriers, hiders): (Vec<_>, Vec<_>) =
            crate::mesh::leaves_where(&lattice, &split, empty, |t| {
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
            return Ok((split, carriers));
        }
        let drawn = polygon_centres(volume, &carriers, isovalues);
        let voxel = DVec3::from(self.grid().spacing).length();
        let mut far = far_hidden_samples(volume, isovalues, &hiders, &drawn, tolerance + voxel);
        if let Some(roi) = query.region_of_interest {
            // The tolerance applies inside the region only.
            far.retain(|&s| {
                let p = world(volume, s);
                (0..3).all(|a| roi[2 * a] <= p[a] && p[a] <= roi[2 * a + 1])
            });
        }
        if far.is_empty() {
            return Ok((split, carriers));
        }
        // Continue from this mesh: split the diamonds down to each far sample (with closure) and
        // whatever their new children need. Every diamond above the tolerance in the result is
        // reachable from the diamonds split here, so this equals refining from the root with the
        // paths' diamonds infinitely wrong.
        let paths = paths_to(&lattice, &far);
        let forced: rustc_hash::FxHashSet<Diamond> = paths.iter().copied().collect();
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
        let newly_split: rustc_hash::FxHashSet<Diamond> = newly.iter().copied().collect();
        let was_leaf = |d: &Diamond, t: &Tet| {
            !d.parents(&lattice)
                .iter()
                .any(|p| (p.center == t[2] || p.center == t[3]) && newly_split.contains(p))
        };
        let mut carriers: Vec<Tet> = carriers
            .into_iter()
            .filter(|t| !Diamond::of_tet(t).is_some_and(|d| newly_split.contains(&d)))
            .collect();
        let empty = |t: &Tet| self.misses(volume, isovalues, t);
        let keep = |t: &Tet| carries(volume, isovalues, t).then_some(*t);
        for d in &newly {
            for t in d.tets(&lattice).into_iter().filter(|t| was_leaf(d, t)) {
                carriers.extend(crate::mesh::leaves_below(
                    &lattice, &split, t, &empty, &keep,
                ));
            }
        }
        Ok((split, carriers))
    }

    /// The diamond error of isosurface queries for `isovalues` at `tolerance`: the isosurface error
    /// measured at the surface samples ([`crate::iso_error`]); at tolerance 0, infinite for every
    /// diamond whose sample range may hold an isovalue, so the surface is the full-resolution one.
    pub(crate) fn iso_criterion<'a, T: Sample>(
        &'a self,
        volume: &'a Volume<'_, T>,
        isovalues: &'a [f64],
        tolerance: f64,
    ) -> impl Fn(Diamond) -> f64 + 'a {
        let lattice = *self.lattice();
        let errors = (tolerance > 0.0).then(|| self.iso_errors(volume, isovalues, tolerance));
        // Infinite where the diamond's sample range may hold an isovalue, else 0 (empty, §6.1).
        let non_empty = move |d: Diamond| {
            let (lo, hi) = d.bounds();
            if self.may_hold(volume, isovalues, lo, hi) {
                f64::INFINITY
            } else {
                0.0
            }
        };
        move |d: Diamond| {
            if !d.bounds().1.cmple(lattice.hi).all() {
                // Near a far face: a diamond straddling it must be split wherever the surface may
                // pass (its tetrahedra have vertices without samples); one outside is never split.
                match d.placement(&lattice) {
                    Placement::Straddling => return non_empty(d),
                    Placement::Outside => return 0.0,
                    Placement::Inside => {}
                }
            }
            match &errors {
                _ if !lattice.in_domain(d.center) => 0.0, // outside the domain
                Some(errors) => errors.refinement_error(self, volume, d),
                None => non_empty(d), // tolerance 0
            }
        }
    }

    /// The leaves of the mesh of `split` that carry the surface of `isovalues`.
    pub(crate) fn carriers_of<T: Sample>(
        &self,
        volume: &Volume<'_, T>,
        isovalues: &[f64],
        split: &SplitSet,
    ) -> Vec<Tet> {
        let empty = |t: &Tet| self.misses(volume, isovalues, t);
        crate::mesh::leaves_where(self.lattice(), split, empty, |t| {
            carries(volume, isovalues, t).then_some(*t)
        })
    }

    /// Does the sample range of `t` miss every isovalue? Then so do those of all its descendants.
    /// From the bricks, and for a tetrahedron straddling a far face as [`Hierarchy::may_hold`] (so
    /// that the walk prunes every unsplit one).
    fn misses<T: Sample>(&self, volume: &Volume<'_, T>, isovalues: &[f64], t: &Tet) -> bool {
        let lo = t[0].min(t[1]).min(t[2].min(t[3]));
        let hi = t[0].max(t[1]).max(t[2].max(t[3]));
        if self.lattice().place_box(lo, hi) == Placement::Inside {
            let (a, b) = self.box_range(volume, lo, hi);
            !isovalues.iter().any(|&v| a <= v && v <= b)
        } else {
            !self.may_hold(volume, isovalues, lo, hi)
        }
    }

    /// May the samples in the box `[lo, hi]` (clipped to the grid) hold an isovalue? From the
    /// bricks' range, a superset; for a small box (the fine diamonds along a far face) from the
    /// samples, which spares splits there.
    fn may_hold<T: Sample>(
        &self,
        volume: &Volume<'_, T>,
        isovalues: &[f64],
        lo: IVec3,
        hi: IVec3,
    ) -> bool {
        let (lo, hi) = (lo.max(IVec3::ZERO), hi.min(self.lattice().hi));
        let holds = |(a, b): (f64, f64)| isovalues.iter().any(|&v| a <= v && v <= b);
        holds(self.box_range(volume, lo, hi))
            && ((hi - lo + IVec3::ONE).element_product() > SMALL_BOX
                || holds(volume.box_range(lo, hi)))
    }
}

/// Does the tetrahedron `t` carry the surface of some isovalue?
fn carries<T: Sample>(volume: &Volume<'_, T>, isovalues: &[f64], t: &Tet) -> bool {
    let f = t.map(|p| volume.at(p.x as usize, p.y as usize, p.z as usize));
    isovalues.iter().any(|&v| crosses(&f, v))
}

/// A refinement (from the root or from a current mesh) with a given diamond error.
pub(crate) type RefineWith<'a> = dyn FnMut(&dyn Fn(Diamond) -> f64) -> Result<SplitSet> + 'a;

/// The refinement query of an isosurface query at `tolerance`.
pub(crate) fn refine_query(query: &IsoQuery, tolerance: f64) -> Query {
    Query {
        tolerance,
        max_tetrahedra: 0,
        region_of_interest: query.region_of_interest,
    }
}

/// Number of triangles marching tetrahedra makes from `tets`: one per tetrahedron and isovalue that
/// cuts off one vertex, two where it separates two from two.
fn count_triangles<T: Sample>(volume: &Volume<'_, T>, tets: &[Tet], isovalues: &[f64]) -> usize {
    tets.iter()
        .map(|t| {
            let f = t.map(|p| volume.at(p.x as usize, p.y as usize, p.z as usize));
            isovalues
                .iter()
                .filter(|&&v| crosses(&f, v))
                .map(|&v| {
                    if f.iter().filter(|&&x| x >= v).count() == 2 {
                        2
                    } else {
                        1
                    }
                })
                .sum::<usize>()
        })
        .sum()
}

/// What isosurface queries keep: the sample range of 8³ bricks, which bounds the range of any box
/// (computed by the first query), and the errors of the last isovalues ([`crate::iso_error`]), reused
/// while only the tolerance, region, normals or carrier output change.
pub(crate) struct IsoCache {
    bricks: Bricks,
    /// By central vertex: the smallest gradient magnitude of the diamond's tetrahedra, rounded down
    /// (bfloat16; [`UNKNOWN`] until a query needs it).
    gradients: Vec<AtomicU16>,
    errors: Mutex<Option<Arc<IsoErrors>>>,
}

/// Marks a gradient no query has computed yet.
const UNKNOWN: u16 = u16::MAX;

impl std::fmt::Debug for IsoCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "IsoCache({} bricks)", self.bricks.min.len())
    }
}

/// Sample ranges of the bricks `[8b, 8b + 8]` per axis (neighbouring bricks share a layer).
struct Bricks {
    dims: [usize; 3],
    min: Vec<f64>,
    max: Vec<f64>,
}

const BRICK: usize = 8;

impl Bricks {
    fn new<T: Sample>(volume: &Volume<'_, T>) -> Self {
        let g = &volume.grid;
        let dims = g.dims.map(|d| (d - 1).div_ceil(BRICK).max(1));
        let (min, max) = (0..dims[0] * dims[1] * dims[2])
            .into_par_iter()
            .map(|b| {
                let c = [b % dims[0], b / dims[0] % dims[1], b / (dims[0] * dims[1])];
                let lo = c.map(|c| (BRICK * c) as i32);
                let hi = [0, 1, 2].map(|a| (BRICK * (c[a] + 1)).min(g.dims[a] - 1) as i32);
                volume.box_range(IVec3::from(lo), IVec3::from(hi))
            })
            .unzip();
        Self { dims, min, max }
    }

    /// Lower corners (point indices) of the grid cells that `v` crosses (min < v ≤ max over the
    /// corners, as [`crosses`]), found in the bricks whose range allows it.
    fn cells_crossed<T: Sample>(&self, volume: &Volume<'_, T>, v: f64) -> Vec<u32> {
        let g = &volume.grid;
        let [nx, ny, nz] = g.dims;
        let (sy, sz) = (nx, nx * ny);
        (0..self.min.len())
            .into_par_iter()
            .filter(|&b| self.min[b] < v && v <= self.max[b])
            .flat_map_iter(|b| {
                let (bx, by, bz) = (
                    b % self.dims[0],
                    b / self.dims[0] % self.dims[1],
                    b / (self.dims[0] * self.dims[1]),
                );
                let mut out = Vec::new();
                for z in BRICK * bz..(BRICK * (bz + 1)).min(nz - 1) {
                    for y in BRICK * by..(BRICK * (by + 1)).min(ny - 1) {
                        for x in BRICK * bx..(BRICK * (bx + 1)).min(nx - 1) {
                            let i = g.index(x, y, z);
                            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
                            for c in [i, i + 1, i + sy, i + sy + 1] {
                                for c in [c, c + sz] {
                                    let f = volume.samples[c].to_f64();
                                    lo = lo.min(f);
                                    hi = hi.max(f);
                                }
                            }
                            if lo < v && v <= hi {
                                out.push(i as u32);
                            }
                        }
                    }
                }
                out
            })
            .collect()
    }

    /// A superset of the sample range in the box `[lo, hi]` (lattice coordinates inside the grid).
    fn range(&self, lo: IVec3, hi: IVec3) -> (f64, f64) {
        // The last brick of an axis also holds the samples at its far end.
        let last = glam::UVec3::from(self.dims.map(|d| d as u32 - 1));
        let b0 = (lo.as_uvec3() / BRICK as u32).min(last);
        let b1 = ((hi - IVec3::ONE).max(lo).as_uvec3() / BRICK as u32).min(last);
        let (mut a, mut b) = (f64::INFINITY, f64::NEG_INFINITY);
        for z in b0.z..=b1.z {
            for y in b0.y..=b1.y {
                for x in b0.x..=b1.x {
                    let i = x as usize + self.dims[0] * (y as usize + self.dims[1] * z as usize);
                    a = a.min(self.min[i]);
                    b = b.max(self.max[i]);
                }
            }
        }
        (a, b)
    }
}

impl Hierarchy {
    fn iso_cache<T: Sample>(&self, volume: &Volume<'_, T>) -> &IsoCache {
        self.iso_cache.get_or_init(|| IsoCache {
            bricks: Bricks::new(volume),
            gradients: (0..self.grid().len())
                .map(|_| AtomicU16::new(UNKNOWN))
                .collect(),
            errors: Mutex::new(None),
        })
    }

    /// The smallest gradient magnitude (world units) of the inside tetrahedra of `d` (central vertex
    /// in the domain), rounded down, from the cache or computed now.
    pub(crate) fn smallest_gradient<T: Sample>(&self, volume: &Volume<'_, T>, d: Diamond) -> f64 {
        let slot = &self.iso_cache(volume).gradients[self.lattice().index(d.center)];
        let mut code = slot.load(Ordering::Relaxed);
        if code == UNKNOWN {
            code = encode_down(smallest_gradient(self.lattice(), volume, d));
            slot.store(code, Ordering::Relaxed);
        }
        decode_error(code)
    }

    /// The isosurface errors of `isovalues` for a query at `tolerance` (> 0): those of the previous
    /// query when they serve, else measured now down to tetrahedra of the tolerance's size (smaller
    /// diamonds' errors are bounded by their size, hence by the tolerance).
    pub(crate) fn iso_errors<T: Sample>(
        &self,
        volume: &Volume<'_, T>,
        isovalues: &[f64],
        tolerance: f64,
    ) -> Arc<IsoErrors> {
        let cache = self.iso_cache(volume);
        let mut kept = cache.errors.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(e) = kept.as_ref().filter(|e| e.serve(isovalues, tolerance)) {
            return e.clone();
        }
        // Reuse the old tables unless a caller still holds them.
        let recycled = kept.take().and_then(|e| Arc::try_unwrap(e).ok());
        let errors = Arc::new(IsoErrors::new(
            self.lattice(),
            volume,
            isovalues,
            tolerance,
            |v| cache.bricks.cells_crossed(volume, v),
            recycled,
        ));
        errors.finalize(self, volume);
        *kept = Some(errors.clone());
        errors
    }

    /// A superset of the sample range in the box `[lo, hi]` (lattice coordinates inside the grid).
    fn box_range<T: Sample>(&self, volume: &Volume<'_, T>, lo: IVec3, hi: IVec3) -> (f64, f64) {
        self.iso_cache(volume).bricks.range(lo, hi)
    }
}

/// Boxes of at most this many samples get their exact range where it decides a split.
const SMALL_BOX: i32 = 64;

/// Does the tetrahedron with vertex values `f` carry the isosurface of `v`? (Vertices at `v` count as above.)
#[inline]
fn crosses(f: &[f64; 4], v: f64) -> bool {
    let min = f[0].min(f[1]).min(f[2].min(f[3]));
    let max = f[0].max(f[1]).max(f[2].max(f[3]));
    min < v && v <= max
}

/// Gradient (world units) of the data at world position `p`: the central-difference gradients at the
/// corners of the grid cell holding `p`, interpolated trilinearly.
fn gradient_at<T: Sample>(volume: &Volume<'_, T>, p: DVec3) -> DVec3 {
    let grid = &volume.grid;
    let mut cell = IVec3::ZERO;
    let mut w = DVec3::ZERO;
    for a in 0..3 {
        let x = ((p[a] - grid.origin[a]) / grid.spacing[a]).clamp(0.0, (grid.dims[a] - 1) as f64);
        let c = (x.floor() as i32).min(grid.dims[a] as i32 - 2).max(0);
        cell[a] = c;
        w[a] = x - c as f64;
    }
    let mut g = DVec3::ZERO;
    for k in 0..8 {
        let o = IVec3::new(k & 1, (k >> 1) & 1, (k >> 2) & 1);
        let weight: f64 = (0..3)
            .map(|a| if o[a] == 1 { w[a] } else { 1.0 - w[a] })
            .product();
        if weight > 0.0 {
            g += weight
                * point_gradient(
                    volume,
                    (cell + o).min(IVec3::from(grid.dims.map(|d| d as i32 - 1))),
                );
        }
    }
    g
}

/// Gradient at a lattice point by central differences (one-sided on the boundary), world units.
fn point_gradient<T: Sample>(volume: &Volume<'_, T>, p: IVec3) -> DVec3 {
    let grid = &volume.grid;
    let mut g = DVec3::ZERO;
    for a in 0..3 {
        let hi = grid.dims[a] as i32 - 1;
        let (mut lo_p, mut hi_p) = (p, p);
        lo_p[a] = (p[a] - 1).max(0);
        hi_p[a] = (p[a] + 1).min(hi);
        let at = |q: IVec3| volume.at(q.x as usize, q.y as usize, q.z as usize);
        g[a] = (at(hi_p) - at(lo_p)) / ((hi_p[a] - lo_p[a]) as f64 * grid.spacing[a]);
    }
    g
}

/// Marching tetrahedra over `tets` (all inside the grid) for every isovalue. Points are shared by edge
/// and isovalue, so the surface is crack-free across face-adjacent tetrahedra; triangles are oriented
/// toward increasing values. Parallel: each tetrahedron's polygons name their points by edge, the
/// distinct edges (sorted) become the points, each interpolated once from its lower-index end.
pub fn marching_tetrahedra<T: Sample>(
    volume: &Volume<'_, T>,
    tets: &[Tet],
    isovalues: &[f64],
    compute_normals: bool,
) -> IsoSurface {
    let polygons = polygons(volume, tets, isovalues);
    // Every polygon corner with its slot, sorted by edge: equal edges are neighbours.
    let mut corners: Vec<(EdgeKey, u32)> = polygons
        .par_iter()
        .enumerate()
        .flat_map_iter(|(p, poly)| (0..poly.n).map(move |i| (poly.keys[i], (4 * p + i) as u32)))
        .collect();
    corners.par_sort_unstable();
    // The distinct edges, with the polygon of their first corner.
    let mut keys: Vec<(EdgeKey, u32)> = Vec::new();
    let mut slot_ids = vec![0u32; 4 * polygons.len()];
    for &(key, slot) in &corners {
        if keys.last().map(|k| k.0) != Some(key) {
            keys.push((key, slot / 4));
        }
        slot_ids[slot as usize] = (keys.len() - 1) as u32;
    }
    drop(corners);
    let interpolated: Vec<(DVec3, f64, [f32; 3])> = keys
        .par_iter()
        .map(|&(key, p)| {
            let (point, value, normal) = interpolate(volume, isovalues, key, compute_normals);
            // Where the gradients vanish: the gradient of the tetrahedron, toward increasing values.
            let normal = normal.unwrap_or_else(|| {
                if compute_normals {
                    let t = &tets[polygons[p as usize].tet as usize];
                    tet_gradient(volume, t).normalize_or_zero()
                } else {
                    DVec3::ZERO
                }
            });
            (point, value, normal.as_vec3().to_array())
        })
        .collect();
    IsoSurface {
        points: interpolated.par_iter().map(|p| p.0.to_array()).collect(),
        values: interpolated.par_iter().map(|p| p.1).collect(),
        normals: if compute_normals {
            interpolated.par_iter().map(|p| p.2).collect()
        } else {
            Vec::new()
        },
        triangles: polygons
            .par_iter()
            .enumerate()
            .flat_map_iter(|(p, poly)| {
                let slot_ids = &slot_ids;
                let id = move |i: usize| slot_ids[4 * p + i];
                [[0, 1, 2], [0, 2, 3]]
                    .into_iter()
                    .take(poly.n - 2)
                    .map(move |tri| tri.map(id))
            })
            .collect(),
        ..IsoSurface::default()
    }
}

/// A point of each polygon marching tetrahedra makes from `tets` (the mean of its corners).
pub(crate) fn polygon_centres<T: Sample>(
    volume: &Volume<'_, T>,
    tets: &[Tet],
    isovalues: &[f64],
) -> Vec<[f64; 3]> {
    polygons(volume, tets, isovalues)
        .par_iter()
        .map(|poly| {
            let sum: DVec3 = poly.keys[..poly.n]
                .iter()
                .map(|&key| interpolate(volume, isovalues, key, false).0)
                .sum();
            (sum / poly.n as f64).to_array()
        })
        .collect()
}

/// A polygon of marching tetrahedra: 3 or 4 corners, oriented toward increasing values, each an
/// edge key; made by tetrahedron `tet`.
struct Polygon {
    keys: [EdgeKey; 4],
    n: usize,
    tet: u32,
}

/// The polygons of `tets` for every isovalue.
fn polygons<T: Sample>(volume: &Volume<'_, T>, tets: &[Tet], isovalues: &[f64]) -> Vec<Polygon> {
    let grid = &volume.grid;
    let index = |p: IVec3| grid.index(p.x as usize, p.y as usize, p.z as usize) as u32;
    tets.par_iter()
        .enumerate()
        .flat_map_iter(|(tet, t)| {
            let f = t.map(|p| volume.at(p.x as usize, p.y as usize, p.z as usize));
            isovalues.iter().enumerate().filter_map(move |(k, &v)| {
                if !crosses(&f, v) {
                    return None;
                }
                let mut above = [0usize; 4];
                let mut below = [0usize; 4];
                let (mut na, mut nb) = (0, 0);
                for (i, &fi) in f.iter().enumerate() {
                    if fi >= v {
                        above[na] = i;
                        na += 1;
                    } else {
                        below[nb] = i;
                        nb += 1;
                    }
                }
                // The crossed edges in cyclic order around the polygon.
                let (mut edges, n) = match (na, nb) {
                    (1, 3) => {
                        let a = above[0];
                        ([(a, below[0]), (a, below[1]), (a, below[2]), (0, 0)], 3)
                    }
                    (3, 1) => {
                        let b = below[0];
                        ([(above[0], b), (above[1], b), (above[2], b), (0, 0)], 3)
                    }
                    _ => {
                        let ([a, b], [c, d]) = ([above[0], above[1]], [below[0], below[1]]);
                        ([(a, c), (a, d), (b, d), (b, c)], 4)
                    }
                };
                // Orientation from the lattice alone, so that it holds even when points coincide
                // with samples (zero-area triangles): the polygon through the edges' midpoints, in
                // doubled integer coordinates, must face from the vertices below to those above.
                // (A positive diagonal scaling to world coordinates keeps the sign.)
                let mid2 = |(a, b): (usize, usize)| (t[a] + t[b]).as_i64vec3();
                let (q0, q1, q2) = (mid2(edges[0]), mid2(edges[1]), mid2(edges[2]));
                let sum = |vs: &[usize]| vs.iter().map(|&i| t[i].as_i64vec3()).sum::<I64Vec3>();
                let up = sum(&above[..na]) * nb as i64 - sum(&below[..nb]) * na as i64;
                if (q1 - q0).cross(q2 - q0).dot(up) < 0 {
                    edges[..n].reverse();
                }
                let keys = edges.map(|(a, b)| {
                    let (ia, ib) = (index(t[a]), index(t[b]));
                    (ia.min(ib), ia.max(ib), k as u32)
                });
                Some(Polygon {
                    keys,
                    n,
                    tet: tet as u32,
                })
            })
        })
        .collect()
}

/// The point of edge `key`: position, isovalue and, when asked and defined, the unit normal (the
/// gradient of the data at the point, [`gradient_at`]: a long edge of a coarse tetrahedron may join
/// samples whose gradients point apart). Interpolated from the lower-index end so that every
/// tetrahedron sharing the edge gets the same point bit for bit.
fn interpolate<T: Sample>(
    volume: &Volume<'_, T>,
    isovalues: &[f64],
    (ia, ib, k): EdgeKey,
    compute_normals: bool,
) -> (DVec3, f64, Option<DVec3>) {
    let grid = &volume.grid;
    let at = |i: u32| {
        let [x, y, z] = grid.ijk(i as usize);
        IVec3::new(x as i32, y as i32, z as i32)
    };
    let v = isovalues[k as usize];
    let (a, b) = (at(ia), at(ib));
    let (fa, fb) = (volume.at_index(ia as usize), volume.at_index(ib as usize));
    let s = (v - fa) / (fb - fa);
    let (pa, pb) = (world(volume, a), world(volume, b));
    let point = pa + s * (pb - pa);
    let normal = if compute_normals {
        gradient_at(volume, point).try_normalize()
    } else {
        None
    };
    (point, v, normal)
}

/// A point of marching tetrahedra: the lower and higher point ids of its edge, the isovalue's index.
type EdgeKey = (u32, u32, u32);

/// The carrier tetrahedra as a mesh of their own (points deduplicated by input point), each with the
/// isosurface error of its diamond.
fn carrier_mesh(h: &Hierarchy, tets: &[Tet], error_of: impl Fn(&Tet) -> f64) -> TetMesh {
    let lattice: &Lattice = h.lattice();
    let grid = h.grid();
    let mut point_ids: Vec<usize> = tets.iter().flatten().map(|&p| lattice.index(p)).collect();
    point_ids.sort_unstable();
    point_ids.dedup();
    let id = |p: IVec3| point_ids.binary_search(&lattice.index(p)).expect("listed") as u32;
    let mut mesh = TetMesh::default();
    for t in tets {
        let mut t = *t;
        if signed_volume6(&t) < 0 {
            t.swap(2, 3);
        }
        let depth = Diamond::of_tet(&t).map_or(3 * lattice.levels, |d| d.depth(lattice));
        let error = error_of(&t) as f32;
        mesh.tets.push(t.map(id));
        mesh.levels.push(depth as u8);
        mesh.errors.push(error);
        mesh.max_error = mesh.max_error.max(error as f64);
    }
    mesh.points = point_ids.iter().map(|&i| grid.point(grid.ijk(i))).collect();
    mesh.point_ids = point_ids;
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Grid;

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
        let sorted = |ts: &[Tet]| {
            let mut k: Vec<_> = ts.iter().map(|t| t.map(|p| p.to_array())).collect();
            k.sort();
            k
        };
        for tol in [3.0, 6.0, 10.0] {
            let query = IsoQuery::new(0.0, tol);
            let refine = refine_query(&query, tol);
            let criterion = h.iso_criterion(&volume, &query.isovalues, tol);
            let plain = Refiner::run(h.grid(), h.base(), &refine, &criterion).unwrap();
            let (split, carriers) = h
                .refine_iso(&volume, &query, tol, &mut |c| {
                    Refiner::run(h.grid(), h.base(), &refine, c)
                })
                .unwrap();
            assert!(split.len() > plain.len(), "nothing forced at {tol}");
            let fresh = h.carriers_of(&volume, &query.isovalues, &split);
            assert_eq!(sorted(&carriers), sorted(&fresh), "tolerance {tol}");
        }
    }

    #[test]
    fn brick_ranges_hold_every_box() {
        let grid = Grid::new([19, 9, 26]);
        let samples: Vec<i16> = (0..grid.len())
            .map(|i| ((i * 7919) % 1000) as i16)
            .collect();
        let volume = Volume::new(grid, &samples[..]).unwrap();
        let bricks = Bricks::new(&volume);
        let hi = IVec3::new(18, 8, 25);
        for (k, lo) in [
            IVec3::ZERO,
            IVec3::new(3, 1, 8),
            IVec3::new(8, 8, 16),
            IVec3::new(17, 0, 24),
        ]
        .into_iter()
        .enumerate()
        {
            for size in [0, 1, 5, 8, 9, 30] {
                let top = (lo + IVec3::splat(size + k as i32)).min(hi);
                let (a, b) = bricks.range(lo, top);
                for z in lo.z..=top.z {
                    for y in lo.y..=top.y {
                        for x in lo.x..=top.x {
                            let v = volume.at(x as usize, y as usize, z as usize);
                            assert!(a <= v && v <= b, "{lo:?}..{top:?}: {v} outside [{a}, {b}]");
                        }
                    }
                }
            }
        }
    }
}
