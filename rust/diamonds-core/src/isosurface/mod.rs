//! Multiresolution isosurfaces from the diamond hierarchy (Gregorski §6, §6.1–6.2; Weiss & De Floriani
//! §2.1, §5.1).
//!
//! A query refines the hierarchy with the *isosurface error* of Gregorski §6.2 as the diamond error:
//! for each tetrahedron `T` of a diamond, `ie_T = ae / ‖∇T‖` (the diamond's approximation error over the
//! magnitude of the tetrahedron's linear gradient, in world units) clamped to the tetrahedron's size,
//! because a surface drawn through `T` never leaves it. `ae` is measured per query at the samples that
//! decide the surface ([`error`]), so no per-diamond precomputation over the volume is
//! needed ([`Hierarchy::build_for_isosurfaces`]). Diamonds whose sample range misses every isovalue are
//! *empty* (Gregorski §6.1) and never split; diamonds straddling a far face of the domain are split
//! where the surface may pass. Tolerance 0 splits every non-empty diamond, so the surface is exactly
//! the full-resolution one.
//!
//! **The bound.** Relative to the full-resolution surface `F` (marching tetrahedra on the finest
//! tetrahedra of the grid, [`fine`]: what tolerance 0 draws), for every isovalue, a query's surface `S`
//! satisfies: every point of `F` is within the tolerance of `S`, and every point of `S` within the
//! tolerance of `F` (exact point–triangle distances; checked against the tolerance less a millionth
//! of the diagonal for rounding; inside the region of interest only). Gregorski's error estimates
//! but does not guarantee this, so [`bound`] checks the refined surface and splits where it fails
//! until it holds. `F` is not the trilinear surface of marching cubes or Flying Edges: both
//! interpolate the same samples linearly along the cell edges, but inside a cell they differ by less
//! than one voxel diagonal. A query's result depends only on the query, never on the queries before
//! it.
//!
//! The surface is extracted from the leaves of the adaptive, conforming mesh by marching tetrahedra; a
//! point is shared by every triangle through its mesh edge, so the surface is crack-free wherever the
//! full-resolution one is.
//!
//! **Across MPI pieces** ([`IsoState::extract_shared`]): a rank that holds the whole image (fetched
//! from the others) refines as one process does and extracts the whole surface, the same bit for
//! bit on every rank, and keeps the triangles of the carrier leaves it owns
//! ([`crate::hierarchy::piece::CellOwner`]), numbering their points by the whole surface (global
//! ids). The error measurement and the two-sided bound's check, most of the work, are shared
//! ([`Partition`]): each rank measures at the samples and checks the surface it owns, and the ranks
//! exchange the codes and each round's violations. Exact; memory per rank is still the serial
//! one's.
//!
//! The stages, one file each, in the order a query runs them:
//! - this file: the query and result types, the entry point [`extract`], the triangle budget and the
//!   carrier tetrahedra;
//! - [`state`]: [`IsoState`], what a caller keeps between queries — the current mesh (reused, or
//!   refined "from the current mesh", §6.1) and the [`IsoCache`];
//! - [`cache`]: the [`IsoCache`] — brick ranges, gradient magnitudes (the `‖∇T‖` of §6.2) and the
//!   errors of the last isovalues, their codes by central vertex stored near the surface only
//!   ([`paged`]);
//! - [`bricks`]: sample ranges of 8³ bricks, which bound any box's range and list the crossed cells;
//! - [`criterion`]: the diamond error refinement compares with the tolerance (§6.1 culling, §6.2);
//! - [`error`]: `ae` measured per query at the surface samples, which descend the hierarchy together;
//! - [`bound`]: the two-sided bound, checked and refined until it holds, with [`cover`] settling
//!   every point of a triangle from its corners and [`blocks`] as its cheap distance certificate;
//! - [`fine`]: the full-resolution surface the bound is relative to;
//! - [`marching`]: marching tetrahedra on the carrier leaves, points shared by edge.

mod blocks;
mod bound;
mod bricks;
mod cache;
mod cover;
mod criterion;
mod error;
mod fine;
mod marching;
mod paged;
mod state;
#[cfg(test)]
pub(crate) mod threads;

pub use bound::{Exchange, Partition};
pub(crate) use cover::in_region;
#[cfg(test)]
pub(crate) use fine::cell_tets;
pub use fine::{full_resolution_level_sets, full_resolution_triangles, LevelSets};
pub use marching::marching_tetrahedra;
pub use state::{IsoStart, IsoState, IsoStats};

use crate::diamond::{signed_volume6, Diamond};
use crate::hierarchy::piece::CellOwner;
use crate::hierarchy::Hierarchy;
use crate::lattice::{Lattice, Tet};
use crate::mesh::TetMesh;
use crate::refine::{Query, Refiner, SplitSet};
use crate::volume::{Sample, ScalarSlice, Volume};
use crate::{Error, Result};
use cache::IsoCache;
use glam::{DMat3, DVec3, IVec3};
use marching::{count_triangles, OnVolume};
pub(crate) use marching::{
    crosses, marching_on_listed_edges, marching_with_sources, source_weight, EdgeKey, EdgePoint,
    Marching,
};

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
    /// The input samples each point lies between (grid point indices, x fastest), `[i, i]` for
    /// sample `i` itself.
    pub sources: Vec<[u32; 2]>,
    /// The weight of the second source (`0` for a sample): any point array interpolates onto the
    /// surface as `(1 − w) a[i] + w a[j]`, as the point itself (up to rounding) and the isovalue.
    pub weights: Vec<f64>,
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
    /// What the user should know: isovalues outside the data range, a triangle budget that the
    /// coarsest surface exceeds.
    pub warnings: Vec<String>,
    /// Global point ids, for a piece's part ([`IsoState::extract_shared`]): each point's position
    /// in the whole surface, the same on every piece holding it. Empty for a whole surface.
    pub point_ids: Vec<u64>,
}

/// Extracts the isosurface(s) of `query` from the adaptive mesh of `hierarchy`; `scalars` must be the
/// samples the hierarchy was built from. Each call refines from the root and measures its errors
/// again; [`IsoState::extract`] keeps the mesh and the [`IsoCache`] between queries (same surface).
pub fn extract(
    hierarchy: &Hierarchy,
    scalars: ScalarSlice<'_>,
    query: &IsoQuery,
) -> Result<IsoSurface> {
    IsoState::new().extract(hierarchy, scalars, query)
}

/// Refuses empty or non-finite isovalues and samples that do not match the grid.
fn check(hierarchy: &Hierarchy, scalars: ScalarSlice<'_>, query: &IsoQuery) -> Result<()> {
    if query.isovalues.is_empty() || query.isovalues.iter().any(|v| !v.is_finite()) {
        return Err(Error::Parameter(format!(
            "isovalues must be one or more finite numbers (got {:?})",
            query.isovalues
        )));
    }
    if scalars.len() != hierarchy.grid().len() {
        return Err(Error::Length {
            len: scalars.len(),
            expected: hierarchy.grid().len(),
            dims: hierarchy.grid().dims,
        });
    }
    Ok(())
}

/// What the stages of an extraction read: the hierarchy, the samples it was built from and what
/// queries keep between calls. The stages are its methods, one file each.
struct Extraction<'a, 'v, T> {
    hierarchy: &'a Hierarchy,
    volume: &'a Volume<'v, T>,
    cache: &'a IsoCache,
    /// The piece's share of the bound's check, when pieces share it ([`Partition`]).
    partition: Option<&'a Partition<'a>>,
}

/// A refinement (from the root or from a current mesh) with a given diamond error.
type RefineWith<'a> = dyn FnMut(&dyn Fn(Diamond) -> f64) -> Result<SplitSet> + 'a;

/// The refinement query of an isosurface query at `tolerance`.
fn refine_query(query: &IsoQuery, tolerance: f64) -> Query {
    Query {
        tolerance,
        max_tetrahedra: 0,
        region_of_interest: query.region_of_interest,
    }
}

impl<T: Sample> Extraction<'_, '_, T> {
    /// The lattice of the hierarchy.
    fn lattice(&self) -> &Lattice {
        self.hierarchy.lattice()
    }

    /// The surface of `query` refined from the root, within its triangle budget when it has one
    /// (the part `owner` owns, when given).
    fn isosurface_of(&self, query: &IsoQuery, owner: Option<&CellOwner>) -> Result<IsoSurface> {
        let volume = self.volume;
        let mut carriers = self.carriers_at(query, query.tolerance)?;
        let mut used = query.tolerance;
        if query.max_triangles > 0
            && count_triangles(volume, &carriers, &query.isovalues) > query.max_triangles
        {
            // Budget: the smallest tolerance whose surface fits, by bisection on the tolerance (the
            // triangle count does not grow with it; it is counted without building the surface). At
            // the data diagonal nothing non-empty is split.
            let diagonal = self.hierarchy.grid().diagonal();
            let (mut lo, mut hi) = (query.tolerance, diagonal.max(query.tolerance));
            carriers = self.carriers_at(query, hi)?;
            for _ in 0..24 {
                let mid = 0.5 * (lo + hi);
                let c = self.carriers_at(query, mid)?;
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
        let mut surface = self.surface_of(query, used, &carriers, owner)?;
        let n = surface.triangles.len();
        if query.max_triangles > 0 && n > query.max_triangles {
            surface.warnings.push(format!(
                "the budget of {} triangles cannot be met: the coarsest surface has {n} triangles, {} more (the adaptive mesh is never coarser than the six tetrahedra of its root cube)",
                query.max_triangles,
                n - query.max_triangles
            ));
        }
        Ok(surface)
    }

    /// Marching tetrahedra on `carriers` (refined at `tolerance`), with the error bound and, when asked
    /// for, the carrier mesh. With an `owner`, the part of the whole surface it owns (the triangles of
    /// the carriers it owns, points numbered by the whole surface's ids in
    /// [`IsoSurface::point_ids`]) and of the carrier mesh; the error bound stays the whole one's.
    fn surface_of(
        &self,
        query: &IsoQuery,
        tolerance: f64,
        carriers: &[Tet],
        owner: Option<&CellOwner>,
    ) -> Result<IsoSurface> {
        let volume = self.volume;
        let field = OnVolume {
            volume,
            isovalues: &query.isovalues,
        };
        let (mut surface, made_by) =
            marching_with_sources(&field, carriers, query.compute_normals)?;
        let error = self.carrier_error(&query.isovalues, tolerance)?;
        surface.error_bound = carriers.iter().map(&error).fold(0.0, f64::max);
        let owned: Vec<Tet>;
        let carriers = match owner {
            Some(owner) => {
                surface = owned_part(surface, &made_by, |k| owner.owns(&carriers[k as usize]));
                owned = carriers.iter().filter(|t| owner.owns(t)).copied().collect();
                &owned[..]
            }
            None => carriers,
        };
        let (lo, hi) = self.hierarchy.value_range();
        surface.warnings.extend(
            (query.isovalues.iter())
                .filter(|&&v| !(lo < v && v <= hi))
                .map(|v| {
                    format!(
                        "isovalue {v} is outside ({lo}, {hi}], the data range: no surface for it"
                    )
                }),
        );
        if query.carrier_tetrahedra {
            surface.carrier = Some(carrier_mesh(self.hierarchy, carriers, error));
        }
        Ok(surface)
    }

    /// The isosurface error of a carrier leaf's diamond for `isovalues` at `tolerance` (0 at
    /// tolerance 0, where the surface is the full-resolution one).
    fn carrier_error<'s>(
        &'s self,
        isovalues: &[f64],
        tolerance: f64,
    ) -> Result<impl Fn(&Tet) -> f64 + 's> {
        let errors = (tolerance > 0.0)
            .then(|| self.iso_errors(isovalues, tolerance))
            .transpose()?;
        Ok(move |t: &Tet| match (&errors, Diamond::of_tet(t)) {
            (Some(errors), Some(d)) if self.lattice().in_domain(d.center) => errors.error(self, d),
            _ => 0.0,
        })
    }

    /// The leaves of the mesh refined for `query` at `tolerance` that carry the surface.
    fn carriers_at(&self, query: &IsoQuery, tolerance: f64) -> Result<Vec<Tet>> {
        let refine = refine_query(query, tolerance);
        let h = self.hierarchy;
        let (_, carriers) = self.refine_iso(query, tolerance, &mut |criterion| {
            Refiner::run(h.grid(), h.base(), &refine, criterion)
        })?;
        Ok(carriers)
    }

    /// The split set of `query`'s isovalues at `tolerance` and its leaves that carry the surface.
    /// `refine` splits with the diamond error it is given (from the root or from a current mesh).
    /// Then refined further until the two-sided bound holds ([`bound`]).
    fn refine_iso(
        &self,
        query: &IsoQuery,
        tolerance: f64,
        refine: &mut RefineWith<'_>,
    ) -> Result<(SplitSet, Vec<Tet>)> {
        let criterion = self.iso_criterion(&query.isovalues, tolerance)?;
        self.refine_with(query, tolerance, refine, &criterion, None)
    }

    /// [`Extraction::refine_iso`] with the diamond error `criterion` (the isosurface criterion, or
    /// one that splits at least what it splits); with `solid`, `query`'s isovalues are the range
    /// `[α, β]` of the solid `{α ≤ f ≤ β}` that the surfaces bound ([`Extraction::certify_solid`]).
    fn refine_with(
        &self,
        query: &IsoQuery,
        tolerance: f64,
        refine: &mut RefineWith<'_>,
        criterion: &dyn Fn(Diamond) -> f64,
        solid: Option<[f64; 2]>,
    ) -> Result<(SplitSet, Vec<Tet>)> {
        let split = refine(criterion)?;
        if tolerance == 0.0 {
            // Full resolution wherever the surface may pass: nothing is hidden.
            let carriers = self.carriers_of(&query.isovalues, &split)?;
            return Ok((split, carriers));
        }
        match solid {
            Some(range) => self.certify_solid(query, range, tolerance, split, criterion),
            None => self.certify(query, tolerance, split, criterion, false, None),
        }
    }
}

/// The triangles of `surface` whose carrier (`made_by`: its position among the carriers, per
/// triangle) `owned` accepts, with their points renumbered in order and each point's id in `surface`
/// as its [`IsoSurface::point_ids`].
fn owned_part(surface: IsoSurface, made_by: &[u32], owned: impl Fn(u32) -> bool) -> IsoSurface {
    const NONE: u32 = u32::MAX;
    let mut id = vec![NONE; surface.points.len()];
    let mut point_ids = Vec::new();
    let mut triangles = Vec::new();
    for (t, &k) in surface.triangles.iter().zip(made_by) {
        if owned(k) {
            triangles.push(t.map(|p| {
                if id[p as usize] == NONE {
                    id[p as usize] = point_ids.len() as u32;
                    point_ids.push(p as u64);
                }
                id[p as usize]
            }));
        }
    }
    fn pick<T: Copy>(v: &[T], ids: &[u64]) -> Vec<T> {
        ids.iter().map(|&p| v[p as usize]).collect()
    }
    IsoSurface {
        points: pick(&surface.points, &point_ids),
        sources: pick(&surface.sources, &point_ids),
        weights: pick(&surface.weights, &point_ids),
        normals: if surface.normals.is_empty() {
            Vec::new()
        } else {
            pick(&surface.normals, &point_ids)
        },
        values: pick(&surface.values, &point_ids),
        triangles,
        point_ids,
        ..surface
    }
}

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
        mesh.depths.push(depth as u8);
        mesh.errors.push(error);
        mesh.max_error = mesh.max_error.max(error as f64);
    }
    mesh.points = point_ids.iter().map(|&i| grid.point(grid.ijk(i))).collect();
    mesh.point_ids = point_ids;
    mesh
}

/// World position of a lattice point.
#[inline]
fn world<T: Sample>(volume: &Volume<'_, T>, p: IVec3) -> DVec3 {
    DVec3::from(
        volume
            .grid
            .point([p.x as usize, p.y as usize, p.z as usize]),
    )
}

/// The sample at a lattice point.
#[inline]
fn value<T: Sample>(volume: &Volume<'_, T>, p: IVec3) -> f64 {
    volume.at(p.x as usize, p.y as usize, p.z as usize)
}

/// Gradient (world units) of the linear interpolant on `t` (the `∇T` of Gregorski §6.2).
fn tet_gradient<T: Sample>(volume: &Volume<'_, T>, t: &Tet) -> DVec3 {
    let p = t.map(|q| world(volume, q));
    let f = t.map(|q| value(volume, q));
    let m = DMat3::from_cols(p[1] - p[0], p[2] - p[0], p[3] - p[0]);
    m.transpose().inverse() * DVec3::new(f[1] - f[0], f[2] - f[0], f[3] - f[0])
}
