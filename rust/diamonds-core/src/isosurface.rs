//! Multiresolution isosurfaces from the diamond hierarchy (Gregorski §6, §6.1–6.2; Weiss & De Floriani
//! §2.1, §5.1).
//!
//! A query refines the hierarchy with the *isosurface error* of Gregorski §6.2 as the diamond error:
//! for each tetrahedron `T` of a diamond, `ie_T = ae / ‖∇T‖` (the diamond's approximation error over the
//! magnitude of the tetrahedron's linear gradient, in world units) clamped to the tetrahedron's size,
//! because a surface drawn through `T` never leaves it. Diamonds whose sample range misses every
//! isovalue are *empty* (Gregorski §6.1) and never split. Tolerance 0 splits every non-empty diamond,
//! so the surface is exactly the full-resolution one. The surface is then extracted from the leaves of
//! the adaptive, conforming mesh by marching tetrahedra; a point is shared by every triangle through
//! its mesh edge, so the surface is crack-free wherever the full-resolution one is.

use crate::diamond::{signed_volume6, Diamond};
use crate::hierarchy::{decode_error, encode_error};
use crate::lattice::{Lattice, Placement, Tet};
use crate::refine::{Query, Refiner, SplitSet};
use crate::volume::{Grid, Sample, Volume};
use crate::{with_volume, Error, Hierarchy, Result, ScalarSlice, TetMesh};
use glam::{DMat3, DVec3, I64Vec3, IVec3};
use rustc_hash::FxHashMap;
use std::sync::atomic::{AtomicU16, Ordering};

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
        }
        Ok(self.surface_of(volume, query, &carriers))
    }

    /// Marching tetrahedra on `carriers`, with the error bound and, when asked for, the carrier mesh.
    pub(crate) fn surface_of<T: Sample>(
        &self,
        volume: &Volume<'_, T>,
        query: &IsoQuery,
        carriers: &[Tet],
    ) -> IsoSurface {
        let mut surface =
            marching_tetrahedra(volume, carriers, &query.isovalues, query.compute_normals);
        surface.error_bound = carriers
            .iter()
            .filter_map(Diamond::of_tet)
            .map(|d| self.cached_isosurface_error(volume, d))
            .fold(0.0, f64::max);
        if query.carrier_tetrahedra {
            surface.carrier = Some(carrier_mesh(self, carriers));
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
        let criterion = self.iso_criterion(volume, &query.isovalues, tolerance);
        let split = Refiner::run(self, &refine_query(query, tolerance), &criterion)?;
        Ok(self.carriers_of(volume, &query.isovalues, &split))
    }

    /// The diamond error of isosurface queries for `isovalues` at `tolerance`.
    pub(crate) fn iso_criterion<'a, T: Sample>(
        &'a self,
        volume: &'a Volume<'_, T>,
        isovalues: &'a [f64],
        tolerance: f64,
    ) -> impl Fn(Diamond) -> f64 + 'a {
        let lattice = *self.lattice();
        move |d: Diamond| {
            if !lattice.in_domain(d.center) {
                return 0.0; // split in the base mesh, or outside the domain
            }
            let (lo, hi) = self.range(d);
            if !isovalues.iter().any(|&v| lo <= v && v <= hi) {
                0.0 // empty (Gregorski §6.1)
            } else if tolerance == 0.0 {
                f64::INFINITY
            } else {
                self.cached_isosurface_error(volume, d)
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
        // Walk only below tetrahedra whose sample range holds an isovalue.
        let empty = |t: &Tet| {
            let (lo, hi) = self.tet_range(volume, t);
            !isovalues.iter().any(|&v| lo <= v && v <= hi)
        };
        crate::mesh::leaves_where(self.lattice(), split, empty, |t| {
            let f = t.map(|p| volume.at(p.x as usize, p.y as usize, p.z as usize));
            isovalues.iter().any(|&v| crosses(&f, v))
        })
    }
}

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

/// What isosurface queries keep between isovalues: the isovalue-independent isosurface error of each
/// diamond (computed the first time a query needs it, stored rounded up like the approximation error)
/// and the sample range of 8³ bricks, which bounds the range of any box (used to skip subtrees of the
/// base mesh, whose diamonds carry no range of their own).
pub(crate) struct IsoCache {
    errors: Vec<AtomicU16>,
    bricks: Bricks,
}

impl std::fmt::Debug for IsoCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "IsoCache({} diamonds, {} bricks)",
            self.errors.len(),
            self.bricks.min.len()
        )
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
        let n = dims[0] * dims[1] * dims[2];
        let (mut min, mut max) = (vec![f64::INFINITY; n], vec![f64::NEG_INFINITY; n]);
        for (i, s) in volume.samples.iter().enumerate() {
            let v = s.to_f64();
            let p = g.ijk(i);
            // Bricks holding this sample: b with 8b ≤ p ≤ 8b + 8 on every axis.
            let span = p.map(|c| (c.saturating_sub(1) / BRICK, c / BRICK));
            for bz in span[2].0..=span[2].1.min(dims[2] - 1) {
                for by in span[1].0..=span[1].1.min(dims[1] - 1) {
                    for bx in span[0].0..=span[0].1.min(dims[0] - 1) {
                        let b = bx + dims[0] * (by + dims[1] * bz);
                        min[b] = min[b].min(v);
                        max[b] = max[b].max(v);
                    }
                }
            }
        }
        Self { dims, min, max }
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
            errors: (0..self.grid().len())
                .map(|_| AtomicU16::new(UNKNOWN))
                .collect(),
            bricks: Bricks::new(volume),
        })
    }

    /// The isosurface error of `d` (central vertex in the domain), from the cache or computed now.
    fn cached_isosurface_error<T: Sample>(&self, volume: &Volume<'_, T>, d: Diamond) -> f64 {
        let slot = &self.iso_cache(volume).errors[self.lattice().index(d.center)];
        let code = slot.load(Ordering::Relaxed);
        if code != UNKNOWN {
            return decode_error(code);
        }
        let code = encode_error(isosurface_error(self, volume, d));
        slot.store(code, Ordering::Relaxed);
        decode_error(code)
    }

    /// A superset of the sample range of the tetrahedron `t` (inside or straddling the domain).
    fn tet_range<T: Sample>(&self, volume: &Volume<'_, T>, t: &Tet) -> (f64, f64) {
        let lattice = self.lattice();
        if let Some(d) = Diamond::of_tet(t) {
            let (lo, hi) = d.bounds();
            if lattice.in_domain(lo) && lattice.in_domain(hi) {
                return self.range(d); // the diamond, hence its range, lies inside the domain
            }
        }
        let lo = t[0].min(t[1]).min(t[2].min(t[3]));
        let hi = t[0].max(t[1]).max(t[2].max(t[3])).min(lattice.hi);
        self.iso_cache(volume).bricks.range(lo, hi)
    }
}

/// Marks a diamond whose isosurface error no query has computed yet.
const UNKNOWN: u16 = u16::MAX;

/// Does the tetrahedron with vertex values `f` carry the isosurface of `v`? (Vertices at `v` count as above.)
#[inline]
fn crosses(f: &[f64; 4], v: f64) -> bool {
    let min = f[0].min(f[1]).min(f[2].min(f[3]));
    let max = f[0].max(f[1]).max(f[2].max(f[3]));
    min < v && v <= max
}

/// World position of a lattice point.
#[inline]
fn world(grid: &Grid, p: IVec3) -> DVec3 {
    DVec3::from(grid.point([p.x as usize, p.y as usize, p.z as usize]))
}

/// Gradient (world units) of the linear interpolant on `t`.
fn tet_gradient<T: Sample>(volume: &Volume<'_, T>, t: &Tet) -> DVec3 {
    let p = t.map(|q| world(&volume.grid, q));
    let f = t.map(|q| volume.at(q.x as usize, q.y as usize, q.z as usize));
    let m = DMat3::from_cols(p[1] - p[0], p[2] - p[0], p[3] - p[0]);
    m.transpose().inverse() * DVec3::new(f[1] - f[0], f[2] - f[0], f[3] - f[0])
}

/// Gregorski §6.2, Eq. (5): the largest `min(ae / ‖∇T‖, size(T))` over the diamond's inside tetrahedra.
fn isosurface_error<T: Sample>(h: &Hierarchy, volume: &Volume<'_, T>, d: Diamond) -> f64 {
    let ae = h.error(d);
    if ae == 0.0 {
        return 0.0;
    }
    let lattice = h.lattice();
    d.tets(lattice)
        .iter()
        .filter(|t| lattice.place(t) == Placement::Inside)
        .map(|t| {
            let p = t.map(|q| world(&volume.grid, q));
            let size = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
                .iter()
                .map(|&(a, b)| p[a].distance(p[b]))
                .fold(0.0, f64::max);
            let g = tet_gradient(volume, t).length();
            if g > 0.0 {
                (ae / g).min(size)
            } else {
                size
            }
        })
        .fold(0.0, f64::max)
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
/// toward increasing values.
pub fn marching_tetrahedra<T: Sample>(
    volume: &Volume<'_, T>,
    tets: &[Tet],
    isovalues: &[f64],
    compute_normals: bool,
) -> IsoSurface {
    let grid = &volume.grid;
    let lattice_index = |p: IVec3| grid.index(p.x as usize, p.y as usize, p.z as usize);
    let mut surface = IsoSurface::default();
    let mut ids: FxHashMap<(usize, usize, usize), u32> = FxHashMap::default();
    for t in tets {
        let f = t.map(|p| volume.at(p.x as usize, p.y as usize, p.z as usize));
        let gradient = tet_gradient(volume, t);
        for (k, &v) in isovalues.iter().enumerate() {
            if !crosses(&f, v) {
                continue;
            }
            let mut point = |a: usize, b: usize| -> u32 {
                let (ia, ib) = (lattice_index(t[a]), lattice_index(t[b]));
                let key = (ia.min(ib), ia.max(ib), k);
                *ids.entry(key).or_insert_with(|| {
                    // Interpolate from the lower id so that both tets sharing the edge agree bit for bit.
                    let (a, b) = if ia < ib { (a, b) } else { (b, a) };
                    let s = (v - f[a]) / (f[b] - f[a]);
                    let (pa, pb) = (world(grid, t[a]), world(grid, t[b]));
                    surface.points.push((pa + s * (pb - pa)).to_array());
                    surface.values.push(v);
                    if compute_normals {
                        let (ga, gb) = (point_gradient(volume, t[a]), point_gradient(volume, t[b]));
                        let n = (ga + s * (gb - ga)).normalize_or(gradient.normalize_or_zero());
                        surface.normals.push(n.as_vec3().to_array());
                    }
                    (surface.points.len() - 1) as u32
                })
            };
            let above: Vec<usize> = (0..4).filter(|&i| f[i] >= v).collect();
            let below: Vec<usize> = (0..4).filter(|&i| f[i] < v).collect();
            // The crossed edges in cyclic order around the polygon.
            let mut edges: Vec<(usize, usize)> = match (above.len(), below.len()) {
                (1, 3) => below.iter().map(|&b| (above[0], b)).collect(),
                (3, 1) => above.iter().map(|&a| (a, below[0])).collect(),
                _ => {
                    let ([a, b], [c, d]) = ([above[0], above[1]], [below[0], below[1]]);
                    vec![(a, c), (a, d), (b, d), (b, c)]
                }
            };
            // Orientation from the lattice alone, so that it holds even when points coincide with
            // samples (zero-area triangles): the polygon through the edges' midpoints, in doubled
            // integer coordinates, must face from the vertices below to those above. (A positive
            // diagonal scaling to world coordinates keeps the sign.)
            let mid2 = |(a, b): (usize, usize)| (t[a] + t[b]).as_i64vec3();
            let q: Vec<I64Vec3> = edges.iter().map(|&e| mid2(e)).collect();
            let sum = |vs: &[usize]| vs.iter().map(|&i| t[i].as_i64vec3()).sum::<I64Vec3>();
            let up = sum(&above) * below.len() as i64 - sum(&below) * above.len() as i64;
            if (q[1] - q[0]).cross(q[2] - q[0]).dot(up) < 0 {
                edges.reverse();
            }
            let polygon: Vec<u32> = edges.into_iter().map(|(a, b)| point(a, b)).collect();
            for tri in [[0, 1, 2], [0, 2, 3]].iter().take(polygon.len() - 2) {
                surface.triangles.push(tri.map(|i| polygon[i]));
            }
        }
    }
    surface
}

/// The carrier tetrahedra as a mesh of their own (points deduplicated by input point).
fn carrier_mesh(h: &Hierarchy, tets: &[Tet]) -> TetMesh {
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
        let (depth, error) = match Diamond::of_tet(&t) {
            Some(d) => (d.depth(lattice), h.error(d) as f32),
            None => (3 * lattice.levels, 0.0),
        };
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
