//! Marching tetrahedra on the leaves of the adaptive mesh that carry the surface (Gregorski §6.1,
//! isosurface extraction from the current mesh; Weiss & De Floriani §2.1: on a conforming mesh the
//! surface has no cracks). Each polygon names its points by (mesh edge, isovalue), so every
//! triangle through an edge shares its point; normals are the data's gradient at the point.

use super::fine::edge_point;
use super::{tet_gradient, world, IsoSurface};
use crate::lattice::Tet;
use crate::memory;
use crate::volume::{Sample, Volume};
use crate::Result;
use glam::{DVec3, I64Vec3, IVec3};
use rayon::prelude::*;
use rustc_hash::FxHashSet;

/// Does the tetrahedron with vertex values `f` carry the isosurface of `v`? (Vertices at `v` count as above.)
#[inline]
pub(crate) fn crosses(f: &[f64; 4], v: f64) -> bool {
    let min = f[0].min(f[1]).min(f[2].min(f[3]));
    let max = f[0].max(f[1]).max(f[2].max(f[3]));
    min < v && v <= max
}

/// Does the tetrahedron `t` carry the surface of some isovalue?
pub(super) fn carries<T: Sample>(volume: &Volume<'_, T>, isovalues: &[f64], t: &Tet) -> bool {
    let f = t.map(|p| volume.at(p.x as usize, p.y as usize, p.z as usize));
    isovalues.iter().any(|&v| crosses(&f, v))
}

/// Number of triangles marching tetrahedra makes from `tets`: one per tetrahedron and isovalue that
/// cuts off one vertex, two where it separates two from two, less those whose corners merge at
/// samples that hold the isovalue (see [`marching_tetrahedra`]; where sheets touch along an edge
/// and keep a point per crossed edge, a few more).
pub(super) fn count_triangles<T: Sample>(
    volume: &Volume<'_, T>,
    tets: &[Tet],
    isovalues: &[f64],
) -> usize {
    tets.iter()
        .map(|t| {
            let f = t.map(|p| volume.at(p.x as usize, p.y as usize, p.z as usize));
            isovalues
                .iter()
                .filter(|&&v| crosses(&f, v))
                .map(|&v| {
                    // Every vertex above has an edge to each vertex below; those of a vertex that
                    // holds the isovalue make one point.
                    let above = f.iter().filter(|&&x| x >= v).count();
                    let at = f.iter().filter(|&&x| x == v).count();
                    let corners = if above == 2 { 4 } else { 3 };
                    (corners - at * (3 - above)).saturating_sub(2)
                })
                .sum::<usize>()
        })
        .sum()
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
///
/// A sample that holds the isovalue is the point of all its crossed edges in one sheet of the surface
/// (the edges' corners in one polygon, joined across polygons by shared edges): no two points of a
/// sheet coincide, and the corners that merge are dropped, so no triangle has zero area. Two sheets
/// that touch at such a sample keep a point each. Where sheets touch along a mesh edge whose two
/// samples hold the isovalue and are joined into one sheet around it (the edge would be in four
/// triangles), these two samples keep a point per crossed edge instead, as without merging: the
/// surface stays watertight there at the price of coinciding points.
pub fn marching_tetrahedra<T: Sample>(
    volume: &Volume<'_, T>,
    tets: &[Tet],
    isovalues: &[f64],
    compute_normals: bool,
) -> Result<IsoSurface> {
    let field = OnVolume { volume, isovalues };
    Ok(marching_with_sources(&field, tets, compute_normals)?.0)
}

/// What marching tetrahedra reads: the values at the tetrahedra's vertices compared with the
/// levels, the name of each vertex and the point of each crossed edge. A volume's samples
/// ([`OnVolume`]), or an isodiamond hierarchy's vertex classes and quantised crossings
/// ([`crate::isodiamond`]), which give the same polygons.
pub(crate) trait Marching: Sync {
    /// The levels the values are compared with, one surface each.
    fn levels(&self) -> &[f64];
    /// The values at the vertices of `t` (inside the grid).
    fn values(&self, t: &Tet) -> [f64; 4];
    /// The name of a lattice point of the grid: its point index.
    fn index(&self, p: IVec3) -> u32;
    /// The point of edge `key` ([`EdgePoint`]; the normal only when asked and defined).
    fn point(&self, key: EdgeKey, compute_normals: bool) -> EdgePoint;
    /// The normal where [`Marching::point`] has none: the direction of `t`'s gradient.
    fn tet_normal(&self, t: &Tet) -> DVec3;
}

/// Marching tetrahedra on a volume's samples for `isovalues`.
pub(super) struct OnVolume<'a, 'v, T> {
    pub(super) volume: &'a Volume<'v, T>,
    pub(super) isovalues: &'a [f64],
}

impl<T: Sample> Marching for OnVolume<'_, '_, T> {
    fn levels(&self) -> &[f64] {
        self.isovalues
    }

    fn values(&self, t: &Tet) -> [f64; 4] {
        t.map(|p| self.volume.at(p.x as usize, p.y as usize, p.z as usize))
    }

    fn index(&self, p: IVec3) -> u32 {
        self.volume
            .grid
            .index(p.x as usize, p.y as usize, p.z as usize) as u32
    }

    fn point(&self, key: EdgeKey, compute_normals: bool) -> EdgePoint {
        interpolate(self.volume, self.isovalues, key, compute_normals)
    }

    fn tet_normal(&self, t: &Tet) -> DVec3 {
        tet_gradient(self.volume, t).normalize_or_zero()
    }
}

/// [`marching_tetrahedra`] on any [`Marching`] field, and for each triangle the position in `tets`
/// of the tetrahedron that made it.
pub(crate) fn marching_with_sources(
    field: &impl Marching,
    tets: &[Tet],
    compute_normals: bool,
) -> Result<(IsoSurface, Vec<u32>)> {
    let polygons = polygons(field, tets);
    // Every polygon corner with its slot, sorted by edge: equal edges are neighbours.
    let slots: usize = polygons.par_iter().map(|poly| poly.n).sum();
    let mut corners: Vec<(EdgeKey, u32)> = memory::with_capacity(slots, "the isosurface corners")?;
    for (p, poly) in polygons.iter().enumerate() {
        corners.extend((0..poly.n).map(|i| (poly.keys[i], (4 * p + i) as u32)));
    }
    corners.par_sort_unstable();
    // The distinct edges, with the polygon of their first corner.
    let mut keys: Vec<(EdgeKey, u32)> = Vec::new();
    let mut slot_ids = memory::filled(4 * polygons.len(), 0u32, "the isosurface corners")?;
    for &(key, slot) in &corners {
        if keys.last().map(|k| k.0) != Some(key) {
            keys.push((key, slot / 4));
        }
        slot_ids[slot as usize] = (keys.len() - 1) as u32;
    }
    drop(corners);
    let sample_of = |p: usize, i: usize| {
        let poly = &polygons[p];
        (poly.at_sample[i] != NOT_AT_SAMPLE)
            .then(|| field.index(tets[poly.tet as usize][poly.at_sample[i] as usize]) as usize)
    };
    let mut separate = FxHashSet::default();
    let (points, triangles) = loop {
        let points = join_at_samples(&polygons, &slot_ids, keys.len(), &sample_of, &separate)?;
        let triangles = fans(&polygons, &slot_ids, &points.id, slots)?;
        let pinched = pinched_samples(&triangles.0, &points.sample);
        if pinched.is_empty() {
            break (points, triangles);
        }
        separate.extend(pinched);
    };
    let (mut triangles, made_by) = triangles;
    let first_edge = referenced(points.first_edge, &mut triangles)?;
    let mut interpolated: Vec<(EdgeKey, EdgePoint, [f32; 3])> =
        memory::with_capacity(first_edge.len(), "the isosurface points")?;
    interpolated.par_extend(first_edge.par_iter().map(|&e| {
        let (key, p) = keys[e as usize];
        let point = field.point(key, compute_normals);
        // Where the gradients vanish: the gradient of the tetrahedron, toward increasing values.
        let normal = point.normal.unwrap_or_else(|| {
            if compute_normals {
                field.tet_normal(&tets[polygons[p as usize].tet as usize])
            } else {
                DVec3::ZERO
            }
        });
        (key, point, normal.as_vec3().to_array())
    }));
    let n = interpolated.len();
    let mut surface = IsoSurface {
        points: memory::with_capacity(n, "the isosurface points")?,
        sources: memory::with_capacity(n, "the isosurface points' sources")?,
        weights: memory::with_capacity(n, "the isosurface points' weights")?,
        values: memory::with_capacity(n, "the isosurface values")?,
        normals: memory::with_capacity(
            if compute_normals { n } else { 0 },
            "the isosurface normals",
        )?,
        triangles,
        ..IsoSurface::default()
    };
    surface
        .points
        .par_extend(interpolated.par_iter().map(|p| p.1.position.to_array()));
    let source =
        |&((a, b, _), point, _): &(EdgeKey, EdgePoint, _)| source_weight(a, b, point.weight);
    surface
        .sources
        .par_extend(interpolated.par_iter().map(|p| source(p).0));
    surface
        .weights
        .par_extend(interpolated.par_iter().map(|p| source(p).1));
    surface
        .values
        .par_extend(interpolated.par_iter().map(|p| p.1.value));
    if compute_normals {
        surface
            .normals
            .par_extend(interpolated.par_iter().map(|p| p.2));
    }
    Ok((surface, made_by))
}

/// The points (each by its first edge) that `triangles` use, in order, with `triangles`
/// renumbered to them: a polygon whose corners all merged at one sample (at an isovalue equal to
/// the data's largest value, a speck at it) makes no triangle, and its point is on no surface.
fn referenced(first_edge: Vec<u32>, triangles: &mut [[u32; 3]]) -> Result<Vec<u32>> {
    const UNUSED: u32 = u32::MAX;
    let mut id = memory::filled(first_edge.len(), UNUSED, "the isosurface points")?;
    for &p in triangles.iter().flatten() {
        id[p as usize] = 0;
    }
    if !id.contains(&UNUSED) {
        return Ok(first_edge);
    }
    let mut kept = memory::with_capacity(first_edge.len(), "the isosurface points")?;
    for (i, e) in first_edge.into_iter().enumerate() {
        if id[i] != UNUSED {
            id[i] = kept.len() as u32;
            kept.push(e);
        }
    }
    for t in triangles.iter_mut() {
        *t = t.map(|p| id[p as usize]);
    }
    Ok(kept)
}

/// The points of marching tetrahedra: the point id of each distinct edge, and per point its first
/// edge and, when it is a sample that holds the isovalue, that sample's index.
struct Points {
    id: Vec<u32>,
    first_edge: Vec<u32>,
    sample: Vec<Option<usize>>,
}

/// Joins the edges whose point is one sample, per sheet (see [`marching_tetrahedra`]), except at
/// the samples in `separate`. `sample_of(p, i)`: the sample of corner `i` of polygon `p`, if any.
fn join_at_samples(
    polygons: &[Polygon],
    slot_ids: &[u32],
    edges: usize,
    sample_of: &impl Fn(usize, usize) -> Option<usize>,
    separate: &FxHashSet<usize>,
) -> Result<Points> {
    // Union-find over the edges; each set's smallest edge stands for it.
    let mut first = memory::with_capacity(edges, "the isosurface points")?;
    first.extend(0..edges as u32);
    let mut sample = memory::filled(edges, None, "the isosurface points")?;
    fn root(first: &mut [u32], mut e: u32) -> u32 {
        while first[e as usize] != e {
            first[e as usize] = first[first[e as usize] as usize];
            e = first[e as usize];
        }
        e
    }
    for (p, poly) in polygons.iter().enumerate() {
        for i in 0..poly.n {
            let Some(si) = sample_of(p, i).filter(|si| !separate.contains(si)) else {
                continue;
            };
            sample[slot_ids[4 * p + i] as usize] = Some(si);
            for j in i + 1..poly.n {
                if poly.at_sample[j] == poly.at_sample[i] {
                    let a = root(&mut first, slot_ids[4 * p + i]);
                    let b = root(&mut first, slot_ids[4 * p + j]);
                    first[a.max(b) as usize] = a.min(b);
                }
            }
        }
    }
    let mut points = Points {
        id: memory::filled(edges, 0u32, "the isosurface points")?,
        first_edge: Vec::new(),
        sample: Vec::new(),
    };
    for e in 0..edges as u32 {
        let r = root(&mut first, e);
        points.id[e as usize] = if r == e {
            points.first_edge.push(e);
            points.sample.push(sample[e as usize]);
            (points.first_edge.len() - 1) as u32
        } else {
            points.id[r as usize]
        };
    }
    Ok(points)
}

/// The triangles of the polygons: their distinct points (corners at one sample are neighbours) as
/// fans, with the tetrahedron of each. `slots`: the number of corners.
fn fans(
    polygons: &[Polygon],
    slot_ids: &[u32],
    id: &[u32],
    slots: usize,
) -> Result<(Vec<[u32; 3]>, Vec<u32>)> {
    let mut triangles =
        memory::with_capacity(slots - 2 * polygons.len(), "the isosurface triangles")?;
    let mut sources = memory::with_capacity(triangles.capacity(), "the isosurface triangles")?;
    for (p, poly) in polygons.iter().enumerate() {
        let mut ids = [0u32; 4];
        let mut n = 0;
        for i in 0..poly.n {
            let point = id[slot_ids[4 * p + i] as usize];
            if n == 0 || ids[n - 1] != point {
                ids[n] = point;
                n += 1;
            }
        }
        if n > 1 && ids[n - 1] == ids[0] {
            n -= 1;
        }
        for k in 1..n.saturating_sub(1) {
            triangles.push([ids[0], ids[k], ids[k + 1]]);
            sources.push(poly.tet);
        }
    }
    Ok((triangles, sources))
}

/// The samples at both ends of an edge between two sample points that lies in more than two
/// triangles (only such edges can: any other edge of the surface lies in one face of the mesh).
fn pinched_samples(triangles: &[[u32; 3]], sample: &[Option<usize>]) -> Vec<usize> {
    let mut edges: Vec<(u32, u32)> = triangles
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .filter(|&(a, b)| sample[a as usize].is_some() && sample[b as usize].is_some())
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect();
    edges.sort_unstable();
    edges
        .chunk_by(|x, y| x == y)
        .filter(|group| group.len() > 2)
        .flat_map(|group| [group[0].0, group[0].1])
        .filter_map(|point| sample[point as usize])
        .collect()
}

/// A polygon of marching tetrahedra: 3 or 4 corners, oriented toward increasing values, each an
/// edge key; made by tetrahedron `tet`. A corner whose point is the edge's end above the isovalue
/// (that sample holds the isovalue) has that vertex of `tet` in `at_sample`, the others
/// [`NOT_AT_SAMPLE`].
struct Polygon {
    keys: [EdgeKey; 4],
    at_sample: [u8; 4],
    n: usize,
    tet: u32,
}

/// See [`Polygon::at_sample`].
const NOT_AT_SAMPLE: u8 = u8::MAX;

/// The polygons of `tets` for every level of `field`.
fn polygons(field: &impl Marching, tets: &[Tet]) -> Vec<Polygon> {
    polygons_of(
        tets,
        field.levels(),
        |_, t| field.values(t),
        |p| field.index(p),
    )
}

/// The edges of the tetrahedron `t` (pairs of corners, the one above the isovalue `v` first) on
/// which its polygon for `v` has its corners, in the polygon's cyclic order (3 or 4 of them; the
/// rest unused), facing from the vertices below `v` to those above; `v` must cross `f`
/// ([`crosses`]). The order is the output's: its triangles are the fan from the first corner.
pub(crate) fn polygon_edges(t: &Tet, f: &[f64; 4], v: f64) -> ([(usize, usize); 4], usize) {
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
    // Orientation from the lattice alone, so that it holds even when points coincide with samples
    // (zero-area triangles): the polygon through the edges' midpoints, in doubled integer
    // coordinates, must face from the vertices below to those above. (A positive diagonal scaling
    // to world coordinates keeps the sign.)
    let mid2 = |(a, b): (usize, usize)| (t[a] + t[b]).as_i64vec3();
    let (q0, q1, q2) = (mid2(edges[0]), mid2(edges[1]), mid2(edges[2]));
    let sum = |vs: &[usize]| vs.iter().map(|&i| t[i].as_i64vec3()).sum::<I64Vec3>();
    let up = sum(&above[..na]) * nb as i64 - sum(&below[..nb]) * na as i64;
    if (q1 - q0).cross(q2 - q0).dot(up) < 0 {
        edges[..n].reverse();
    }
    (edges, n)
}

/// The polygons of `tets` for every level of `levels`, the values at the vertices of tetrahedron
/// `k` being `values(k, tet)` and the name of a vertex `index(p)`.
fn polygons_of(
    tets: &[Tet],
    levels: &[f64],
    values: impl Fn(usize, &Tet) -> [f64; 4] + Sync,
    index: impl Fn(IVec3) -> u32 + Sync,
) -> Vec<Polygon> {
    let index = &index;
    tets.par_iter()
        .enumerate()
        .flat_map_iter(|(tet, t)| {
            let f = values(tet, t);
            levels.iter().enumerate().filter_map(move |(k, &v)| {
                if !crosses(&f, v) {
                    return None;
                }
                let (edges, n) = polygon_edges(t, &f, v);
                let keys = edges.map(|(a, b)| {
                    let (ia, ib) = (index(t[a]), index(t[b]));
                    (ia.min(ib), ia.max(ib), k as u32)
                });
                // Each edge runs from a vertex above (first) to one below.
                let at_sample = edges.map(|(a, _)| if f[a] == v { a as u8 } else { NOT_AT_SAMPLE });
                Some(Polygon {
                    keys,
                    at_sample,
                    n,
                    tet: tet as u32,
                })
            })
        })
        .collect()
}

/// The listed edges a surface uses, in order, and its triangles.
pub(crate) type ListedMarching = (Vec<u32>, Vec<[u32; 3]>);

/// [`marching_with_sources`] without normals where the crossed edges are listed in advance
/// (`listed`: the position of a crossed edge in the list, sorted by key, of `edges` edges) and no
/// vertex of `tets` holds a level (`values(k, tet)`: the values at the vertices of tetrahedron `k`;
/// `index(p)`: the name of a vertex): no sample joins points, so the points are the crossed edges
/// in key order and no sort is needed. The listed edges used, in order (one point each), and the
/// triangles, the same as [`marching_with_sources`] makes; `None` when a vertex holds a level or a
/// crossed edge is not listed.
pub(crate) fn marching_on_listed_edges(
    tets: &[Tet],
    levels: &[f64],
    values: impl Fn(usize, &Tet) -> [f64; 4] + Sync,
    index: impl Fn(IVec3) -> u32 + Sync,
    edges: usize,
    listed: impl Fn(EdgeKey) -> Option<u32> + Sync,
) -> Result<Option<ListedMarching>> {
    let polygons = polygons_of(tets, levels, values, index);
    if (polygons.par_iter())
        .any(|poly| poly.at_sample[..poly.n].iter().any(|&a| a != NOT_AT_SAMPLE))
    {
        return Ok(None);
    }
    let slots: usize = polygons.par_iter().map(|poly| poly.n).sum();
    let mut slot_ids = memory::filled(4 * polygons.len(), u32::MAX, "the isosurface corners")?;
    let unlisted = (slot_ids.par_chunks_mut(4).zip(&polygons))
        .map(|(ids, poly)| {
            let mut unlisted = false;
            for (id, &key) in ids.iter_mut().zip(&poly.keys[..poly.n]) {
                match listed(key) {
                    Some(e) => *id = e,
                    None => unlisted = true,
                }
            }
            unlisted
        })
        .reduce(|| false, |a, b| a || b);
    if unlisted {
        return Ok(None);
    }
    let mut id = memory::filled(edges, u32::MAX, "the isosurface points")?;
    for &e in &slot_ids {
        if e != u32::MAX {
            id[e as usize] = 0;
        }
    }
    let mut used = Vec::new();
    for (e, id) in id.iter_mut().enumerate() {
        if *id == 0 {
            *id = used.len() as u32;
            used.push(e as u32);
        }
    }
    let (triangles, _) = fans(&polygons, &slot_ids, &id, slots)?;
    Ok(Some((used, triangles)))
}

/// The point of edge `key` on the samples, with the unit normal when asked and defined (the
/// gradient of the data at the point, [`gradient_at`]: a long edge of a coarse tetrahedron may join
/// samples whose gradients point apart). Interpolated from the lower-index end so that every
/// tetrahedron sharing the edge gets the same point bit for bit.
fn interpolate<T: Sample>(
    volume: &Volume<'_, T>,
    isovalues: &[f64],
    (ia, ib, k): EdgeKey,
    compute_normals: bool,
) -> EdgePoint {
    let grid = &volume.grid;
    let at = |i: u32| {
        let [x, y, z] = grid.ijk(i as usize);
        IVec3::new(x as i32, y as i32, z as i32)
    };
    let value = isovalues[k as usize];
    let (a, b) = (at(ia), at(ib));
    let (fa, fb) = (volume.at_index(ia as usize), volume.at_index(ib as usize));
    let (pa, pb) = (world(volume, a), world(volume, b));
    // An end that holds the isovalue is the point, exactly: the same for all its edges.
    let (position, weight) = edge_point(pa, pb, fa, fb, value);
    let normal = if compute_normals {
        gradient_at(volume, position).try_normalize()
    } else {
        None
    };
    EdgePoint {
        position,
        weight,
        value,
        normal,
    }
}

/// The point of a crossed edge `(a, b)` of marching tetrahedra.
#[derive(Clone, Copy, Debug)]
pub(crate) struct EdgePoint {
    /// World position.
    pub(crate) position: DVec3,
    /// The weight of the edge's higher-index end `b`: the point is `(1 − w) a + w b`, and so is any
    /// point array interpolated there ([`IsoSurface::weights`]).
    pub(crate) weight: f64,
    /// The isovalue.
    pub(crate) value: f64,
    /// The unit normal, toward increasing values, where defined (and asked for).
    pub(crate) normal: Option<DVec3>,
}

/// [`IsoSurface::sources`] and [`IsoSurface::weights`] of a point at `weight` along edge `(a, b)`
/// from `a`: a point at a sample is that sample, `[i, i]` with weight 0.
pub(crate) fn source_weight(a: u32, b: u32, weight: f64) -> ([u32; 2], f64) {
    if weight == 0.0 {
        ([a, a], 0.0)
    } else if weight == 1.0 {
        ([b, b], 0.0)
    } else {
        ([a, b], weight)
    }
}

/// A point of marching tetrahedra: the lower and higher point ids of its edge, the isovalue's index.
pub(crate) type EdgeKey = (u32, u32, u32);
