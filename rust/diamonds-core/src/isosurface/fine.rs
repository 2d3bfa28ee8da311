//! The full-resolution surface `F` that the isosurface bound is relative to: the level set of the
//! piecewise-linear interpolant on the finest tetrahedra of the hierarchy, i.e. the surface a query
//! at tolerance 0 draws, computed here straight from the grid, without the hierarchy.
//!
//! The finest tetrahedra are the children of the finest diamonds (Gregorski §3, Fig. 1: the 2 → 0
//! bisection of an edge diamond): every unit cell is split into the six Kuhn (Freudenthal)
//! tetrahedra around the diagonal from its corner with all coordinates even to the opposite corner,
//! all odd. Their edges are the cell edges, the face diagonals joining the two corners whose varying
//! coordinates have equal parity, and those cell diagonals. `F` is the union of the triangles of
//! positive area that marching tetrahedra makes of them: a point on every such edge whose ends lie on
//! either side of the isovalue (a value equal to the isovalue counts as above, as in
//! [`super::marching`]); where samples hold the isovalue, triangles collapse and only those of
//! positive area count (an isolated sample at the isovalue is no part of `F`, as the extraction draws
//! none there).
//!
//! This is not the trilinear surface of marching cubes or Flying Edges: both interpolate the same
//! samples linearly along the cell edges, but inside a cell the two differ, by less than the cell
//! (one voxel diagonal).

use super::marching::{crosses, polygon_edges};
use crate::geometry::has_area;
use crate::lattice::Tet;
use crate::volume::{Sample, Volume};
use arrayvec::ArrayVec;
use glam::{DVec3, IVec3};
use rayon::iter::Either;
use rayon::prelude::*;

/// The six finest tetrahedra of the grid cell with lower corner `c`.
pub(crate) fn cell_tets(c: IVec3) -> [Tet; 6] {
    let odd = c & IVec3::ONE;
    let even = c + odd;
    let d = IVec3::ONE - 2 * odd;
    let axis = |a: usize| {
        let mut v = IVec3::ZERO;
        v[a] = d[a];
        v
    };
    [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)].map(|(i, j)| {
        let p = even + axis(i);
        [even, p, p + axis(j), even + d]
    })
}

/// Is the segment from lattice point `p` to `p + o` (`o` in {−1, 0, 1}³, not zero) an edge of the
/// finest tetrahedra?
#[inline]
fn is_fine_edge(p: IVec3, o: IVec3) -> bool {
    let parity = p & IVec3::ONE;
    match o.abs().element_sum() {
        1 => true,
        2 => {
            let [i, j] = [0, 1, 2]
                .into_iter()
                .filter(|&a| o[a] != 0)
                .collect::<ArrayVec<usize, 2>>()
                .into_inner()
                .expect("two axes");
            parity[i] == parity[j]
        }
        _ => parity.x == parity.y && parity.y == parity.z,
    }
}

/// The 13 offsets to the lattice neighbours that come "after" a point (first non-zero component
/// positive): every segment between neighbours is listed once, from one of its ends.
const FORWARD: [IVec3; 13] = [
    IVec3::new(1, 0, 0),
    IVec3::new(0, 1, 0),
    IVec3::new(0, 0, 1),
    IVec3::new(1, 1, 0),
    IVec3::new(1, -1, 0),
    IVec3::new(1, 0, 1),
    IVec3::new(1, 0, -1),
    IVec3::new(0, 1, 1),
    IVec3::new(0, 1, -1),
    IVec3::new(1, 1, 1),
    IVec3::new(1, 1, -1),
    IVec3::new(1, -1, 1),
    IVec3::new(1, -1, -1),
];

/// The point of the isovalue `v` on the edge `a`–`b` (values `fa`, `fb` on either side of it, or
/// one of them equal to it) and its weight `w` of `b`: `b` itself when it holds `v`, otherwise
/// interpolated from `a`, which must be the end with the lower point id ([`precedes`]).
///
/// Every surface of marching tetrahedra computes its points here, this way round: the output
/// ([`super::marching`]), `F`, its vertices and the bound's check, so that they agree to the last
/// bit. Computed from either end, a point within rounding of an end may or may not differ from it
/// in the last bits: one ulp below an isolated maximum, whether the speck around it has any area
/// depended on which of them computed it.
#[inline]
pub(crate) fn edge_point(a: DVec3, b: DVec3, fa: f64, fb: f64, v: f64) -> (DVec3, f64) {
    if fb == v {
        (b, 1.0)
    } else {
        let w = (v - fa) / (fb - fa);
        (a + w * (b - a), w)
    }
}

/// Does lattice point `a` come before `b` in the order of point ids (by z, then y, then x)?
#[inline]
fn precedes(a: IVec3, b: IVec3) -> bool {
    (a.z, a.y, a.x) < (b.z, b.y, b.x)
}

/// [`edge_point`] on the edge between the lattice points `a` and `b` (each with its world position
/// and value), from whichever of them has the lower point id.
#[inline]
fn lattice_edge_point(a: (IVec3, DVec3, f64), b: (IVec3, DVec3, f64), v: f64) -> DVec3 {
    let ((_, pa, fa), (_, pb, fb)) = if precedes(a.0, b.0) { (a, b) } else { (b, a) };
    edge_point(pa, pb, fa, fb, v).0
}

/// The points of marching tetrahedra for isovalue `v` on the edges from the lattice points `points`
/// (indices; each crossing edge is found from one of its ends, so `points` must hold the corners of
/// every grid cell `v` crosses: [`super::bricks::Bricks::cells_crossed`]), in world coordinates:
/// the vertices of `F`, and points of `{f = v}` near a sample that only triangles of zero area use.
pub(crate) fn vertices_from<T: Sample>(
    volume: &Volume<'_, T>,
    v: f64,
    points: &[u32],
) -> Vec<DVec3> {
    let grid = &volume.grid;
    let hi = IVec3::from(grid.dims.map(|d| d as i32 - 1));
    points
        .par_iter()
        .flat_map_iter(|&i| {
            let p = IVec3::from(grid.ijk(i as usize).map(|c| c as i32));
            let fp = volume.at_index(i as usize);
            let wp = super::world(volume, p);
            FORWARD
                .iter()
                .filter_map(move |&o| {
                    let q = p + o;
                    if q.cmplt(IVec3::ZERO).any() || q.cmpgt(hi).any() || !is_fine_edge(p, o) {
                        return None;
                    }
                    let (fq, wq) = (super::value(volume, q), super::world(volume, q));
                    // A point at a sample is added below, once.
                    ((fp >= v) != (fq >= v) && fp != v && fq != v)
                        .then(|| lattice_edge_point((p, wp, fp), (q, wq, fq), v))
                })
                .chain((fp == v && at_sample_in_f(volume, p, v)).then_some(wp))
        })
        .collect()
}

/// Is the sample `p` (which holds `v`) a corner of a triangle of `F` of positive area?
fn at_sample_in_f<T: Sample>(volume: &Volume<'_, T>, p: IVec3, v: f64) -> bool {
    let hi = IVec3::from(volume.grid.dims.map(|d| d as i32 - 2));
    let wp = super::world(volume, p);
    (0..8).any(|k| {
        let c = p - IVec3::new(k & 1, (k >> 1) & 1, (k >> 2) & 1);
        c.cmpge(IVec3::ZERO).all()
            && c.cmple(hi).all()
            && cell_triangles(volume, c, v).iter().any(|t| t.contains(&wp))
    })
}

/// The triangles marching tetrahedra makes of the tetrahedron `t` (world corners `p`, values `f`)
/// for the isovalue `v`, as the output draws them: the points of [`edge_point`], the polygon
/// triangulated as the fan from its first corner ([`super::marching::polygon_edges`]), so that `F`
/// is the output at tolerance 0 triangle for triangle, bit for bit, and samples of these are
/// samples of the output's triangles.
pub(crate) fn output_triangles(
    t: &Tet,
    p: [DVec3; 4],
    f: [f64; 4],
    v: f64,
) -> ArrayVec<[DVec3; 3], 2> {
    let mut out = ArrayVec::new();
    if crosses(&f, v) {
        let (edges, n) = polygon_edges(t, &f, v);
        let x =
            |(a, b): (usize, usize)| lattice_edge_point((t[a], p[a], f[a]), (t[b], p[b], f[b]), v);
        for k in 1..n - 1 {
            out.push([x(edges[0]), x(edges[k]), x(edges[k + 1])]);
        }
    }
    out
}

/// The triangles of `F` for isovalue `v` in the grid cell with lower corner `c` (those of positive
/// area).
pub(crate) fn cell_triangles<T: Sample>(
    volume: &Volume<'_, T>,
    c: IVec3,
    v: f64,
) -> ArrayVec<[DVec3; 3], 12> {
    cell_pieces(volume, c, v)
        .into_iter()
        .map(|(_, t)| t)
        .collect()
}

/// The triangles of `F` for isovalue `v` (those of positive area) in the grid cell with lower
/// corner `c`, each with the number of its tetrahedron among the [`cell_tets`]: the triangles of
/// one tetrahedron together make a convex polygon (a plane's section of it), a *piece* of `F`.
pub(crate) fn cell_pieces<T: Sample>(
    volume: &Volume<'_, T>,
    c: IVec3,
    v: f64,
) -> ArrayVec<(u8, [DVec3; 3]), 12> {
    let mut out = ArrayVec::new();
    for (k, t) in cell_tets(c).into_iter().enumerate() {
        out.extend(tet_piece(volume, t, v).map(|t| (k as u8, t)));
    }
    out
}

/// The triangles of positive area of `F` for isovalue `v` in the finest tetrahedron `t`.
fn tet_piece<T: Sample>(
    volume: &Volume<'_, T>,
    t: Tet,
    v: f64,
) -> impl Iterator<Item = [DVec3; 3]> {
    tet_polygon(volume, t, v).filter(has_area)
}

/// The triangles marching tetrahedra makes of the finest tetrahedron `t` for isovalue `v`, those of
/// zero area included.
fn tet_polygon<T: Sample>(
    volume: &Volume<'_, T>,
    t: Tet,
    v: f64,
) -> impl Iterator<Item = [DVec3; 3]> {
    let f = t.map(|q| super::value(volume, q));
    output_triangles(&t, t.map(|q| super::world(volume, q)), f, v).into_iter()
}

/// The full-resolution surface `F` of `isovalues` as a triangle soup (world coordinates, unoriented):
/// the triangles a query at tolerance 0 draws, as sets of points.
pub fn full_resolution_triangles<T: Sample>(
    volume: &Volume<'_, T>,
    isovalues: &[f64],
) -> Vec<[[f64; 3]; 3]> {
    full_resolution_level_sets(volume, isovalues).triangles
}

/// The full-resolution level sets `{f = v}` of some isovalues, as marching tetrahedra on the finest
/// tetrahedra draws them (world coordinates, unoriented).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LevelSets {
    /// `F`: the triangles of positive area ([`full_resolution_triangles`]).
    pub triangles: Vec<[[f64; 3]; 3]>,
    /// The rest: marching tetrahedra's triangles of zero area, points and segments where samples
    /// hold the isovalue and the values around them lie on one side of it (a sample at a local
    /// maximum equal to the isovalue; an edge of two such samples). They are part of `{f = v}`, and
    /// a surface at tolerance 0 draws the segments where it keeps coinciding points to stay
    /// watertight ([`super::marching_tetrahedra`]), so a distance *to* the full-resolution surface
    /// is measured to them too.
    pub degenerate: Vec<[[f64; 3]; 3]>,
}

/// The full-resolution level sets of `isovalues`, from one walk over the grid cells each crosses.
pub fn full_resolution_level_sets<T: Sample>(
    volume: &Volume<'_, T>,
    isovalues: &[f64],
) -> LevelSets {
    let bricks = super::bricks::Bricks::new(volume);
    let grid = &volume.grid;
    let mut out = LevelSets::default();
    for &v in isovalues {
        let (triangles, degenerate): (Vec<_>, Vec<_>) = bricks
            .cells_crossed(volume, v)
            .par_iter()
            .flat_map_iter(|&i| {
                let c = IVec3::from(grid.ijk(i as usize).map(|c| c as i32));
                cell_tets(c)
                    .into_iter()
                    .flat_map(move |t| tet_polygon(volume, t, v))
            })
            .partition_map(|t| {
                let corners = t.map(|p| p.to_array());
                if has_area(&t) {
                    Either::Left(corners)
                } else {
                    Either::Right(corners)
                }
            });
        out.triangles.extend(triangles);
        out.degenerate.extend(degenerate);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diamond::signed_volume6;
    use crate::fields::{marschner_lobb, sample, unit_grid};
    use crate::geometry::{triangle_key, TriangleKey};
    use crate::hierarchy::Hierarchy;
    use crate::isosurface::{extract, IsoQuery};
    use crate::volume::ScalarSlice;

    #[test]
    fn cell_tets_tile_the_cell() {
        for c in [IVec3::ZERO, IVec3::new(1, 0, 0), IVec3::new(3, 4, 7)] {
            let tets = cell_tets(c);
            let volume: i64 = tets.iter().map(|t| signed_volume6(t).abs()).sum();
            assert_eq!(volume, 6, "{c:?}");
            for t in tets {
                assert!(t
                    .iter()
                    .all(|&p| (p - c).cmpge(IVec3::ZERO).all() && (p - c).cmple(IVec3::ONE).all()));
                for a in 0..4 {
                    for b in a + 1..4 {
                        let (p, q) = if t[a].to_array() < t[b].to_array() {
                            (t[a], t[b])
                        } else {
                            (t[b], t[a])
                        };
                        assert!(is_fine_edge(p, q - p), "{p:?}-{q:?}");
                    }
                }
            }
        }
    }

    /// Triangles as their corners' bits, in a canonical order.
    fn bits(triangles: &[[[f64; 3]; 3]]) -> Vec<TriangleKey> {
        let mut keys: Vec<TriangleKey> = triangles.iter().map(triangle_key).collect();
        keys.sort_unstable();
        keys
    }

    #[test]
    fn f_is_the_surface_at_tolerance_0() {
        // Grids with and without a far-face band, isovalues between samples and equal to samples.
        for dims in [[17, 17, 17], [20, 13, 11], [33, 29, 41]] {
            let grid = unit_grid(dims);
            let v: Vec<f32> = sample(&grid, |x, y, z| marschner_lobb(x, y, z) as f32)
                .into_iter()
                .map(|f| (f * 16.0).round() / 16.0)
                .collect();
            let volume = Volume::new(grid, &v[..]).unwrap();
            let h = Hierarchy::build_for_isosurfaces(grid, ScalarSlice::F32(&v)).unwrap();
            for isovalues in [vec![0.5], vec![0.3, 0.71]] {
                let s = extract(
                    &h,
                    ScalarSlice::F32(&v),
                    &IsoQuery {
                        isovalues: isovalues.clone(),
                        ..IsoQuery::new(0.0, 0.0)
                    },
                )
                .unwrap();
                // The same triangles of positive area (the extraction merges the points of crossed
                // edges at a sample that holds the isovalue and drops the zero-area triangles this
                // leaves), with the same corners, bit for bit.
                let positive: Vec<[[f64; 3]; 3]> = s
                    .triangles
                    .iter()
                    .map(|t| t.map(|i| s.points[i as usize]))
                    .filter(|t| has_area(&t.map(DVec3::from)))
                    .collect();
                let soup = full_resolution_triangles(&volume, &isovalues);
                assert_eq!(bits(&soup), bits(&positive), "{dims:?} {isovalues:?}");
            }
        }
    }
}
