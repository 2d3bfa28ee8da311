//! Multiresolution interval volumes from the diamond hierarchy (Weiss & De Floriani §2.1, §5: the
//! material between two isovalues, `{α ≤ f ≤ β}`, as a conforming tetrahedral mesh at any
//! resolution).
//!
//! A query refines the hierarchy exactly as an isosurface query for the two isovalues `{α, β}`
//! ([`crate::isosurface`]): the isosurface error of Gregorski §6.2 per diamond, empty-diamond culling
//! (a diamond whose samples all lie on one side of both levels is never split, so the inside of the
//! interval volume stays as coarse as the base mesh allows), and the checked two-sided bound: both
//! bounding surfaces are within the tolerance of the full-resolution ones, as Adaptive Isosurface's
//! are for the same isovalues and tolerance (they *are* its surfaces, triangulated, but for faces
//! drawn from both sides, which bound nothing here: [`crate::validate::interval_distances`]
//! measures the bound; where samples equal β, the upper surface checked is that of `−f` at `−β`,
//! the boundary of `{f ≤ β}`, rather than marching tetrahedra's surface of β, which bounds
//! `{f ≥ β}`: [`crate::isosurface`]'s `Extraction::certify_solid`). Then every leaf
//! of the adaptive mesh that meets `[α, β]` is clipped to it, the field being linear on the leaf, and
//! its patch tetrahedralised by a rule that depends only on global point names ([`clip`]), so that
//! patches of face-adjacent leaves conform; the adaptive mesh itself conforms (no hanging faces), so
//! the interval volume is crack-free at every resolution. New points lie on mesh edges and are shared
//! by every patch through that edge (named by the edge and the level, placed by interpolation from
//! the edge's lower-index end as marching tetrahedra places them, but kept a 2⁻³¹ of the edge from
//! its ends and from each other, so that a sample a few rounding errors from a level leaves no
//! tetrahedron too flat for a positive volume: [`clip::edge_parameter`]); the other points are input
//! samples. Tolerance 0 refines every diamond that may hold `α` or `β` to the finest tetrahedra, so
//! the volume is exactly that of `{α ≤ f ≤ β}` for the piecewise-linear field on the finest
//! tetrahedra.
//!
//! **Across MPI pieces** ([`extract_shared`], [`IntervalVolume::piece`]): as Adaptive
//! Isosurface's, a rank that holds the whole image extracts the whole volume, the same bit for bit
//! on every rank, sharing the error measurement and the two-sided bound's check with the others
//! ([`Partition`]: each measures and checks what it owns, and they exchange the codes and each
//! round's violations), and keeps the tetrahedra whose centroid its piece owns
//! ([`PositionOwner`]), numbering their points by the whole volume (global ids). Exact; memory per
//! rank is still the serial one's.

mod clip;
#[cfg(test)]
mod tests;

pub use clip::{PointKey, ALPHA, BETA, SAMPLE};

use crate::diamond::Diamond;
use crate::geometry::orient3d;
use crate::hierarchy::piece::{pick, used_points, PositionOwner};
use crate::hierarchy::Hierarchy;
use crate::isosurface::{IsoState, Partition};
use crate::lattice::{Lattice, Tet};
use crate::memory;
use crate::volume::{Sample, ScalarSlice, Volume};
use crate::{with_volume, Error, IsoQuery, Result};
use clip::EDGES;
pub(crate) use clip::{clip, edge_parameter};
use glam::DVec3;
use rayon::prelude::*;

/// An interval-volume query.
#[derive(Clone, Debug, PartialEq)]
pub struct IntervalQuery {
    /// `[α, β]`, data units, `α < β`: the volume holds the points where `α ≤ f ≤ β`.
    pub range: [f64; 2],
    /// Isosurface error bound of both bounding surfaces, world units (as [`IsoQuery::tolerance`]);
    /// 0 = full resolution wherever a bounding surface may pass.
    pub tolerance: f64,
    /// Maximum number of output tetrahedra, 0 = no limit (the tolerance is raised until it fits).
    pub max_tetrahedra: usize,
    /// World-space box `[xmin, xmax, ymin, ymax, zmin, zmax]`: the tolerance applies inside, coarse
    /// outside.
    pub region_of_interest: Option<[f64; 6]>,
}

impl IntervalQuery {
    /// The interval volume of `range` at `tolerance`, no budget, no region of interest.
    pub fn new(range: [f64; 2], tolerance: f64) -> Self {
        Self {
            range,
            tolerance,
            max_tetrahedra: 0,
            region_of_interest: None,
        }
    }

    /// The isosurface query of its two bounding surfaces at `tolerance`.
    fn iso_query(&self, tolerance: f64) -> IsoQuery {
        IsoQuery {
            isovalues: self.range.to_vec(),
            tolerance,
            max_triangles: 0,
            region_of_interest: self.region_of_interest,
            compute_normals: false,
            carrier_tetrahedra: false,
        }
    }
}

/// An extracted interval volume: tetrahedra whose points are input samples or points on mesh edges.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IntervalVolume {
    /// World coordinates of each point.
    pub points: Vec<[f64; 3]>,
    /// The input samples each point is interpolated between, `[i, i]` for sample `i` itself.
    pub sources: Vec<[u32; 2]>,
    /// The weight of the second source (`0` for a sample): any point array interpolates as
    /// `(1 − w) a[i] + w a[j]`.
    pub weights: Vec<f64>,
    /// The field at each point (`α` or `β` exactly on a new point).
    pub values: Vec<f64>,
    /// Tetrahedra as indices into `points`, positively oriented (VTK_TETRA order).
    pub tets: Vec<[u32; 4]>,
    /// Bisection depth of the leaf of the adaptive mesh each tetrahedron was cut from (0 = the six
    /// base tetrahedra).
    pub levels: Vec<u8>,
    /// Leaves of the adaptive mesh that meet the range (each gives one or more tetrahedra).
    pub leaves: usize,
    /// The tolerance refined for (above the query's when the budget raised it).
    pub tolerance: f64,
    /// Largest isosurface error (world units) of the diamonds carrying a bounding surface.
    pub error_bound: f64,
    /// What the user should know: a range that misses the data, a budget that cannot be met.
    pub warnings: Vec<String>,
}

impl IntervalVolume {
    /// The tetrahedra the piece of `owner` owns (centroid in its half-open cell box) with their
    /// points, sources, weights, values and levels, and each point's index in this volume (its
    /// global id). Counts, tolerance, error bound and warnings are the whole volume's, of which
    /// this is a share.
    pub fn piece(&self, owner: &PositionOwner) -> (IntervalVolume, Vec<u64>) {
        let kept: Vec<u64> = (0..self.tets.len() as u64)
            .filter(|&t| {
                owner.owns(
                    self.tets[t as usize]
                        .iter()
                        .map(|&v| self.points[v as usize]),
                )
            })
            .collect();
        let (ids, local) = used_points(
            self.points.len(),
            kept.iter().map(|&t| self.tets[t as usize].as_slice()),
        );
        let volume = IntervalVolume {
            points: pick(&self.points, &ids),
            sources: pick(&self.sources, &ids),
            weights: pick(&self.weights, &ids),
            values: pick(&self.values, &ids),
            tets: (kept.iter())
                .map(|&t| self.tets[t as usize].map(|v| local[v as usize]))
                .collect(),
            levels: pick(&self.levels, &kept),
            leaves: self.leaves,
            tolerance: self.tolerance,
            error_bound: self.error_bound,
            warnings: self.warnings.clone(),
        };
        (volume, ids)
    }
}

/// Extracts the interval volume of `query` from the adaptive mesh of `hierarchy`; `scalars` must be
/// the samples the hierarchy was built from.
pub fn extract(
    hierarchy: &Hierarchy,
    scalars: ScalarSlice<'_>,
    query: &IntervalQuery,
) -> Result<IntervalVolume> {
    extract_with(&mut IsoState::new(), hierarchy, scalars, query)
}

/// [`extract`] keeping `state`'s isosurface cache between queries (brick ranges, gradient
/// magnitudes, the errors of the last levels; see [`IsoState`]): the state an isosurface filter
/// keeps for the same hierarchy serves. Its mesh is forgotten.
pub fn extract_with(
    state: &mut IsoState,
    hierarchy: &Hierarchy,
    scalars: ScalarSlice<'_>,
    query: &IntervalQuery,
) -> Result<IntervalVolume> {
    check(hierarchy, scalars, query)?;
    with_volume!(*hierarchy.grid(), scalars, |v| extract_volume(
        state, hierarchy, &v, query, None
    ))
}

/// [`extract_with`] on a piece of a distributed image that holds the whole image (`hierarchy` and
/// `scalars` are the whole grid's): the whole volume, the same bit for bit on every piece, the
/// pieces sharing the error measurement and the two-sided bound's check through `partition` as
/// Adaptive Isosurface's do ([`IsoState::extract_shared`]); [`IntervalVolume::piece`] then keeps a
/// piece's share. Every piece must call it with the same query and the same state (the same
/// queries before; after a failure on any piece, every piece's [`IsoState::clear`]).
pub fn extract_shared(
    state: &mut IsoState,
    hierarchy: &Hierarchy,
    scalars: ScalarSlice<'_>,
    query: &IntervalQuery,
    partition: &Partition<'_>,
) -> Result<IntervalVolume> {
    check(hierarchy, scalars, query)?;
    with_volume!(*hierarchy.grid(), scalars, |v| extract_volume(
        state,
        hierarchy,
        &v,
        query,
        Some(partition)
    ))
}

/// Refuses ranges that are not two finite numbers with `α < β`, and samples that do not match the
/// grid.
fn check(hierarchy: &Hierarchy, scalars: ScalarSlice<'_>, query: &IntervalQuery) -> Result<()> {
    let [alpha, beta] = query.range;
    if !alpha.is_finite() || !beta.is_finite() {
        return Err(Error::Parameter(format!(
            "the range must be two finite numbers (got [{alpha}, {beta}])"
        )));
    }
    if alpha >= beta {
        return Err(Error::Parameter(format!(
            "the range [{alpha}, {beta}] is empty: its lower value must be below its upper value{}",
            if alpha == beta {
                " (for a single value, extract an isosurface)"
            } else {
                ""
            }
        )));
    }
    if !query.tolerance.is_finite() || query.tolerance < 0.0 {
        return Err(Error::Parameter(format!(
            "the tolerance must be a finite number ≥ 0 (got {})",
            query.tolerance
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

/// The split set [`extract`] refines `query` to (no budget), for the isodiamond hierarchies
/// ([`crate::isodiamond`]) that store it.
pub(crate) fn split_set<T: Sample>(
    hierarchy: &Hierarchy,
    volume: &Volume<'_, T>,
    query: &IntervalQuery,
) -> Result<crate::refine::SplitSet> {
    let iso = query.iso_query(query.tolerance);
    let keep = |_: &Tet| None::<()>;
    let (_, _, split) =
        IsoState::new().refined_leaves(hierarchy, volume, &iso, query.range, keep, None)?;
    Ok(split)
}

/// The patch of one leaf: its tetrahedra as point names, and the leaf's bisection depth.
pub(crate) type Patch = (Vec<[PointKey; 4]>, u8);

/// [`extract_with`] on the typed samples (checked).
fn extract_volume<T: Sample>(
    state: &mut IsoState,
    hierarchy: &Hierarchy,
    volume: &Volume<'_, T>,
    query: &IntervalQuery,
    partition: Option<&Partition<'_>>,
) -> Result<IntervalVolume> {
    let range = query.range;
    let lattice = *hierarchy.lattice();
    let ids_values = |t: &Tet| {
        let ids = t.map(|p| volume.grid.index(p.x as usize, p.y as usize, p.z as usize));
        (ids.map(|i| i as u32), ids.map(|i| volume.at_index(i)))
    };
    let patch = |t: &Tet| {
        if crate::memory::exhausted() {
            return None; // the extraction fails with an out-of-memory error: stop allocating
        }
        let (ids, f) = ids_values(t);
        let mut out = Vec::new();
        clip(ids, f, range, &mut out);
        (!out.is_empty()).then(|| (out, depth(&lattice, t)))
    };
    // The patches of the leaves refined at `tolerance`, with the error bound.
    let patches_at = |state: &mut IsoState, tolerance: f64| {
        let iso = query.iso_query(tolerance);
        let (patches, error_bound, _) =
            state.refined_leaves(hierarchy, volume, &iso, range, patch, partition)?;
        Ok::<_, Error>((patches, error_bound))
    };
    let mut tolerance = query.tolerance;
    let (mut patches, mut error_bound) = patches_at(state, tolerance)?;
    let count = |patches: &[Patch]| patches.iter().map(|p| p.0.len()).sum::<usize>();
    let mut warnings = Vec::new();
    if query.max_tetrahedra > 0 && count(&patches) > query.max_tetrahedra {
        // Budget: the smallest tolerance whose volume fits, by bisection on the tolerance (the
        // count does not grow with it; counted without keeping the patches). At the data
        // diagonal nothing non-empty is split.
        let counted = |state: &mut IsoState, tolerance: f64| {
            let (counts, ..) = state.refined_leaves(
                hierarchy,
                volume,
                &query.iso_query(tolerance),
                range,
                |t| Some(patch(t).map_or(0, |p| p.0.len())),
                partition,
            )?;
            Ok::<usize, Error>(counts.iter().sum())
        };
        let diagonal = hierarchy.grid().diagonal();
        let (mut lo, mut hi) = (tolerance, diagonal.max(tolerance));
        for _ in 0..24 {
            let mid = 0.5 * (lo + hi);
            if counted(state, mid)? <= query.max_tetrahedra {
                hi = mid;
            } else {
                lo = mid;
            }
            if hi - lo <= 1e-3 * hi {
                break;
            }
        }
        tolerance = hi;
        (patches, error_bound) = patches_at(state, tolerance)?;
        let n = count(&patches);
        if n > query.max_tetrahedra {
            warnings.push(format!(
                    "the budget of {} tetrahedra cannot be met: the coarsest interval volume has {n} tetrahedra",
                    query.max_tetrahedra
                ));
        }
    }
    let (lo, hi) = hierarchy.value_range();
    if range[1] < lo || range[0] > hi {
        warnings.push(format!(
            "the range [{}, {}] misses the data range [{lo}, {hi}]: the interval volume is empty",
            range[0], range[1]
        ));
    }
    let world = |i: u32| DVec3::from(volume.grid.point(volume.grid.ijk(i as usize)));
    // Position, weight of the second source, value; from the lower-index end, as marching
    // tetrahedra places its points, so that bounding surfaces match Adaptive Isosurface's bit for bit
    // (but for points kept off a sample a few rounding errors from a level: [`edge_parameter`]).
    let place = |(i, j, level): PointKey| {
        if level == SAMPLE {
            return (world(i), 0.0, volume.at_index(i as usize));
        }
        let (fa, fb) = (volume.at_index(i as usize), volume.at_index(j as usize));
        let (pa, pb) = (world(i), world(j));
        let w = edge_parameter(fa, fb, range, level);
        (pa + w * (pb - pa), w, range[(level - ALPHA) as usize])
    };
    let mut result = assemble(&patches, place)?;
    result.tolerance = tolerance;
    result.error_bound = error_bound;
    result.warnings = warnings;
    Ok(result)
}

/// Bisection depth of a leaf (unit-cube tetrahedra are one below the finest diamonds).
pub(crate) fn depth(lattice: &Lattice, t: &Tet) -> u8 {
    Diamond::of_tet(t).map_or(3 * lattice.levels, |d| d.depth(lattice)) as u8
}

/// The mesh of the patches: distinct point names become the points (in name order), placed by
/// `place` (position, weight of the second source, value), tetrahedra positively oriented (exactly:
/// a thin one's volume from the usual formula may have the wrong sign).
pub(crate) fn assemble(
    patches: &[Patch],
    place: impl Fn(PointKey) -> (DVec3, f64, f64) + Sync,
) -> Result<IntervalVolume> {
    let n: usize = patches.iter().map(|p| p.0.len()).sum();
    let mut keys: Vec<PointKey> = memory::with_capacity(4 * n, "the interval volume points")?;
    keys.par_extend(
        patches
            .par_iter()
            .flat_map_iter(|p| p.0.iter().flatten().copied()),
    );
    keys.par_sort_unstable();
    keys.dedup();
    let id = |k: &PointKey| keys.binary_search(k).expect("listed") as u32;
    let mut tets = memory::with_capacity(n, "the interval volume tetrahedra")?;
    tets.par_extend(
        patches
            .par_iter()
            .flat_map_iter(|p| p.0.iter().map(|t| t.map(|k| id(&k)))),
    );
    let mut levels = memory::with_capacity(n, "the interval volume levels")?;
    levels.par_extend(
        patches
            .par_iter()
            .flat_map_iter(|p| p.0.iter().map(|_| p.1)),
    );
    assemble_numbered(&keys, tets, levels, patches.len(), place)
}

/// [`assemble`] where the distinct point names `keys` (in name order), the tetrahedra as indices
/// into them (orientation not fixed), their `levels` and the number of `leaves` are known.
pub(crate) fn assemble_numbered(
    keys: &[PointKey],
    mut tets: Vec<[u32; 4]>,
    levels: Vec<u8>,
    leaves: usize,
    place: impl Fn(PointKey) -> (DVec3, f64, f64) + Sync,
) -> Result<IntervalVolume> {
    let placed: Vec<(DVec3, f64, f64)> = keys.par_iter().map(|&k| place(k)).collect();
    tets.par_iter_mut().for_each(|t| {
        let x = t.map(|i| placed[i as usize].0);
        if orient3d(x[1], x[2], x[3], x[0]) < 0.0 {
            t.swap(2, 3);
        }
        // First an end of the shortest edge, by an even permutation (orientation kept): VTK's
        // volume of a tetrahedron (`vtkTetra::ComputeVolume`, verdict's) takes the edges from the
        // first corner, and from a far corner to three points `GAP` of an edge apart the edges are
        // nearly parallel and their determinant loses the volume (769 of 337,041 tetrahedra of
        // neghip at [40 + 1 ulp, 100 − 1 ulp] came out ≤ 0); from one of the three it holds.
        let x = t.map(|i| placed[i as usize].0);
        let shortest = EDGES
            .into_iter()
            .min_by(|a, b| {
                x[a.0]
                    .distance_squared(x[a.1])
                    .total_cmp(&x[b.0].distance_squared(x[b.1]))
            })
            .expect("six edges");
        let k = shortest.0;
        *t = [t[k], t[k ^ 1], t[k ^ 2], t[k ^ 3]];
    });
    let mut result = IntervalVolume {
        tets,
        levels,
        leaves,
        ..IntervalVolume::default()
    };
    result.points = placed.par_iter().map(|p| p.0.to_array()).collect();
    result.weights = placed.par_iter().map(|p| p.1).collect();
    result.values = placed.par_iter().map(|p| p.2).collect();
    result.sources = keys.par_iter().map(|&(i, j, _)| [i, j]).collect();
    Ok(result)
}
