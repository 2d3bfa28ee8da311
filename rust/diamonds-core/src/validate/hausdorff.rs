//! Both one-sided Hausdorff distances between a triangle surface `S` and the full-resolution surface
//! `F` of a volume ([`crate::isosurface::full_resolution_triangles`]: marching tetrahedra on the
//! finest tetrahedra, what a query at tolerance 0 draws), with exact point–triangle distances
//! ([`crate::geometry::closest_point_on_triangle`]) found through [`rstar`] R-trees of the triangles.
//!
//! - `F → S`: the largest distance to `S` from the vertices of `F` and from samples of its triangles
//!   spaced at most `h` ([`crate::geometry::triangle_samples`]): half the tolerance checked
//!   against, held between the smallest and the largest grid spacing
//!   ([`crate::Grid::sampling_step`]; the smallest spacing when no tolerance is given);
//! - `S → F`: the largest distance to `F` from the corners of the triangles of `S` and from samples
//!   of them spaced at most `h`. Here `F` includes the parts of the level set that marching
//!   tetrahedra draws with zero area ([`crate::isosurface::LevelSets::degenerate`]):
//!   points of `S` on them lie on `{f = v}`, and a surface at tolerance 0 keeps some of them.
//!
//! Every point of either surface lies within `h / √3` of a sample, so every point is within the
//! measured distance plus `h / √3` of the other surface (the *slack*). The isosurface bound
//! ([`crate::isosurface`]) is that every point of either surface is within the tolerance of the
//! other, so both measured distances are at most the tolerance.

use crate::geometry::{triangle_key, triangle_samples, triangle_tree, TriangleKey, TriangleTree};
use crate::isosurface::{full_resolution_level_sets, in_region, LevelSets};
use crate::volume::{Sample, Volume};
use glam::DVec3;
use rayon::prelude::*;
use rstar::PointDistance;
use rustc_hash::FxHashSet;

/// The largest distance found in one direction and the point it was found at.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Farthest {
    /// Exact distance (infinite when the other surface is empty and this one is not).
    pub distance: f64,
    /// The point of the surface measured from.
    pub point: [f64; 3],
}

/// What [`surface_distances`] measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceDistances {
    /// The largest distance from a vertex or sample of `F` to `S`.
    pub fine_to_surface: Farthest,
    /// The largest distance from a vertex or sample of `S` to `F`.
    pub surface_to_fine: Farthest,
    /// Vertices and samples of `F` measured, and triangles of `F`.
    pub fine_vertices: usize,
    pub fine_triangles: usize,
    /// Triangles of `F` that are triangles of `S` (the same three points, bit for bit): every point
    /// of them is at distance 0 from the other surface, so neither side samples them.
    pub shared_triangles: usize,
    /// Vertices and samples of `S` measured.
    pub surface_samples: usize,
    /// Every point of either surface lies within this distance of a measured sample (`h / √3`).
    pub slack: f64,
    /// Rounding allowed by [`SurfaceDistances::check`]: a billionth of the volume's diagonal.
    pub rounding: f64,
}

impl SurfaceDistances {
    /// Both distances within `tolerance` (plus [`SurfaceDistances::rounding`]), or a message naming
    /// the one that is not and where.
    pub fn check(&self, tolerance: f64) -> Result<(), String> {
        let side = |name: &str, f: &Farthest| {
            if f.distance <= tolerance + self.rounding {
                Ok(())
            } else {
                Err(format!(
                    "{name} {} > tolerance {tolerance} at {:?}",
                    f.distance, f.point
                ))
            }
        };
        side(
            "a point of the full-resolution surface lies",
            &self.fine_to_surface,
        )
        .and(side(
            "a point of the surface lies (from the full-resolution surface)",
            &self.surface_to_fine,
        ))
    }
}

/// The largest distance from `points` to the triangles of `tree` (infinite if it is empty while
/// `points` is not), and how many points there were. The points are measured as they come, never
/// held together: a surface sampled finely has hundreds of millions.
pub fn farthest(
    points: impl ParallelIterator<Item = DVec3>,
    tree: &TriangleTree,
) -> (Farthest, usize) {
    points
        .map(|p| {
            let p = p.to_array();
            let distance = tree
                .nearest_neighbor(&p)
                .map_or(f64::INFINITY, |t| t.distance_2(&p).sqrt());
            (Farthest { distance, point: p }, 1)
        })
        .reduce(
            || {
                let none = Farthest {
                    distance: 0.0,
                    point: [0.0; 3],
                };
                (none, 0)
            },
            |(a, m), (b, n)| (if b.distance > a.distance { b } else { a }, m + n),
        )
}

/// Both one-sided distances between the surface made of `triangles` (corners indexing `points`) and
/// the full-resolution surface of `isovalues` in `volume`, measured from the points of either
/// inside `region` (a box, x, y and z ranges) when there is one: a query with a region of interest
/// meets its tolerance there.
pub fn surface_distances<T: Sample>(
    volume: &Volume<'_, T>,
    isovalues: &[f64],
    points: &[[f64; 3]],
    triangles: &[[u32; 3]],
    region: Option<[f64; 6]>,
    tolerance: Option<f64>,
) -> SurfaceDistances {
    let LevelSets {
        triangles: fine,
        degenerate,
    } = full_resolution_level_sets(volume, isovalues);
    let vertices = corners(&fine);
    let mut level_set = fine.clone();
    level_set.extend(degenerate);
    distances(
        FineSides {
            from: &fine,
            vertices,
            to: &level_set,
        },
        (&volume.grid, tolerance),
        (points, region),
        (triangles, triangles),
    )
}

/// Both one-sided distances between the bounding surfaces of an interval volume of `[α, β]`
/// (`tets`, corners indexing `points`, `values` the field at each point) and the full-resolution
/// boundary of `{α ≤ f ≤ β}` in `volume`:
/// - the bounding surfaces are the volume's faces in one tetrahedron whose three values are all α,
///   or all β;
/// - the full-resolution boundary is the surface of α and the surface of β with samples at β
///   counted as *below* (the full-resolution surface of `−f` at `−β`; marching tetrahedra count
///   vertices at the isovalue as above, which draws a plateau of samples at exactly β on its low
///   side, where `{f ≤ β}` goes on, instead of its high side, where it ends).
///
/// Each side is measured *from* its proper part only, to the whole of the other: parts that need
/// no counterpart are measured against but not from. They are the faces lying on the image's
/// bounds (where the volume ends at the box, or a plateau at a level lies on it), and, of the
/// full-resolution boundary, sheets: triangles drawn twice, from both sides of samples at a level
/// with the other side of it all around (a part of the set without thickness, which no
/// tetrahedron holds).
///
/// With a `region` (a box), only points of either side inside it are measured from, as in
/// [`surface_distances`].
pub fn interval_distances<T: Sample>(
    volume: &Volume<'_, T>,
    [alpha, beta]: [f64; 2],
    points: &[[f64; 3]],
    values: &[f64],
    tets: &[[u32; 4]],
    region: Option<[f64; 6]>,
    tolerance: Option<f64>,
) -> SurfaceDistances {
    let LevelSets {
        triangles: mut fine,
        degenerate: mut level_sets,
    } = full_resolution_level_sets(volume, &[alpha]);
    let upper = full_resolution_level_sets(&volume.negated(), &[-beta]);
    fine.extend(upper.triangles);
    level_sets.extend(upper.degenerate);
    level_sets.extend_from_slice(&fine);
    let bounds = volume.grid.bounds();
    let eps = super::bounds_eps(&bounds);
    let mut keys: Vec<TriangleKey> = fine.par_iter().map(triangle_key).collect();
    keys.par_sort_unstable();
    let twice: FxHashSet<TriangleKey> = (keys.windows(2))
        .filter(|w| w[0] == w[1])
        .map(|w| w[0])
        .collect();
    let proper: Vec<[[f64; 3]; 3]> = (fine.par_iter())
        .filter(|t| !on_the_box(t, &bounds, eps) && !twice.contains(&triangle_key(t)))
        .copied()
        .collect();
    let vertices = corners(&proper);
    let faces = super::bounding_faces(tets, values, &[alpha, beta]);
    let off_the_box: Vec<[u32; 3]> = (faces.iter())
        .filter(|f| !on_the_box(&f.map(|v| points[v as usize]), &bounds, eps))
        .copied()
        .collect();
    distances(
        FineSides {
            from: &proper,
            vertices,
            to: &level_sets,
        },
        (&volume.grid, tolerance),
        (points, region),
        (&off_the_box, &faces),
    )
}

/// The corners of `triangles`, each once: the vertices of `F` are those of its triangles of
/// positive area. (Points on crossed edges that only triangles of zero area use are not: a sample
/// one ulp above the isovalue with lower values all around makes a speck of `10⁻¹³` whose points
/// differ in one coordinate's last bit, a segment; measured from, it failed a surface that rightly
/// left it out.)
fn corners(triangles: &[[[f64; 3]; 3]]) -> Vec<[f64; 3]> {
    let mut corners: Vec<[f64; 3]> = triangles.iter().flatten().copied().collect();
    corners.par_sort_unstable_by_key(|p| p.map(f64::to_bits));
    corners.dedup();
    corners
}

/// Do the corners of a triangle all lie on one face of `bounds` (within `eps`)?
fn on_the_box(corners: &[[f64; 3]; 3], bounds: &[f64; 6], eps: f64) -> bool {
    corners
        .iter()
        .fold(0x3f, |m, p| m & super::faces_of_point(p, bounds, eps))
        != 0
}

/// The full-resolution side of [`distances`]: measured from the triangles `from` and the
/// `vertices` (each once), against the triangles `to`.
struct FineSides<'a> {
    from: &'a [[[f64; 3]; 3]],
    vertices: Vec<[f64; 3]>,
    to: &'a [[[f64; 3]; 3]],
}

/// Both one-sided distances on `grid`: from `fine.from` and `fine.vertices` to the triangles
/// `surface.1` (corners indexing `points`), and from the triangles `surface.0` to `fine.to`; from
/// points inside `region` only, when there is one. Triangles are sampled at the grid's
/// [`crate::Grid::sampling_step`] of `tolerance` (at the smallest spacing without one), except
/// those the other side also has (the same points, bit for bit: every point of them at distance
/// 0), which a surface has wherever it was refined to the finest tetrahedra — at tolerance 0 all
/// of them, where sampling every triangle at the smallest spacing took hours on thin slices.
fn distances(
    fine: FineSides<'_>,
    (grid, tolerance): (&crate::Grid, Option<f64>),
    (points, region): (&[[f64; 3]], Option<[f64; 6]>),
    surface: (&[[u32; 3]], &[[u32; 3]]),
) -> SurfaceDistances {
    let FineSides {
        from: fine_from,
        vertices: fine_vertices,
        to: fine_to,
    } = fine;
    let (from, to) = surface;
    let h = grid.sampling_step(tolerance.unwrap_or(0.0));
    let at = |t: &[u32; 3]| t.map(|i| points[i as usize]);
    let corners = |t: &[u32; 3]| at(t).map(DVec3::from);
    let drawn: FxHashSet<TriangleKey> = to.par_iter().map(|t| triangle_key(&at(t))).collect();
    let unshared: Vec<&[[f64; 3]; 3]> = (fine_from.par_iter())
        .filter(|t| !drawn.contains(&triangle_key(t)))
        .collect();
    let shared_triangles = fine_from.len() - unshared.len();
    // The vertices and the samples of the triangles other than their corners.
    let fine = (fine_vertices.into_par_iter().map(DVec3::from))
        .chain(unshared.into_par_iter().flat_map_iter(|t| {
            let t = t.map(DVec3::from);
            triangle_samples(t, h).filter(move |p| !t.contains(p))
        }))
        .filter(|&p| in_region(region, p));
    let surface = triangle_tree(to.iter().map(corners));
    let (fine_to_surface, fine_vertices) = farthest(fine, &surface);
    drop((surface, drawn));
    let level_set: FxHashSet<TriangleKey> = fine_to.par_iter().map(triangle_key).collect();
    let fine_tree = triangle_tree(fine_to.iter().map(|t| t.map(DVec3::from)));
    // The corners of the triangles among them (a point no triangle uses is no part of the surface).
    let samples = (from.par_iter())
        .filter(|t| !level_set.contains(&triangle_key(&at(t))))
        .flat_map_iter(|t| triangle_samples(corners(t), h))
        .filter(|&p| in_region(region, p));
    let (surface_to_fine, surface_samples) = farthest(samples, &fine_tree);
    SurfaceDistances {
        fine_to_surface,
        surface_to_fine,
        fine_vertices,
        fine_triangles: fine_from.len(),
        shared_triangles,
        surface_samples,
        slack: h / 3f64.sqrt(),
        rounding: 1e-9 * grid.diagonal(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fields::{sample, sphere_distance, unit_grid};
    use crate::isosurface::full_resolution_triangles;

    #[test]
    fn distances_of_f_itself_are_zero_and_of_a_shifted_copy_the_shift() {
        let grid = unit_grid([21, 19, 17]);
        let v = sample(&grid, |x, y, z| sphere_distance(0.6)(x, y, z) as f32);
        let volume = Volume::new(grid, &v[..]).unwrap();
        let soup = full_resolution_triangles(&volume, &[0.0]);
        let points: Vec<[f64; 3]> = soup.iter().flatten().copied().collect();
        let triangles: Vec<[u32; 3]> = (0..soup.len() as u32)
            .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
            .collect();
        let d = surface_distances(&volume, &[0.0], &points, &triangles, None, None);
        assert_eq!(d.fine_to_surface.distance, 0.0, "{d:?}");
        assert_eq!(d.surface_to_fine.distance, 0.0, "{d:?}");
        assert_eq!(d.check(0.0), Ok(()));
        assert_eq!(d.fine_triangles, soup.len());
        // Every triangle is shared, so none is sampled on either side (F's vertices are measured).
        assert_eq!(d.shared_triangles, soup.len());
        assert_eq!(d.surface_samples, 0);
        // Shifted along x by 0.3 of the domain: the distances are at most the shift, and close to
        // it (the sphere's poles along x move straight away).
        let shift = 0.3;
        let moved: Vec<[f64; 3]> = points.iter().map(|p| [p[0] + shift, p[1], p[2]]).collect();
        let d = surface_distances(&volume, &[0.0], &moved, &triangles, None, None);
        for f in [d.fine_to_surface, d.surface_to_fine] {
            assert!(
                f.distance <= shift + 1e-12 && f.distance > 0.8 * shift,
                "{d:?}"
            );
        }
        assert!(d.check(0.2).unwrap_err().contains("> tolerance 0.2"));
        assert_eq!(d.shared_triangles, 0);
        // Only the part beyond x = 0.3 moved: measured from points in x <= 0 only, both
        // distances are 0 again, and fewer points are measured.
        let partly: Vec<[f64; 3]> = (points.iter())
            .map(|p| [p[0] + if p[0] > 0.3 { shift } else { 0.0 }, p[1], p[2]])
            .collect();
        let whole = surface_distances(&volume, &[0.0], &partly, &triangles, None, None);
        assert!(whole.fine_to_surface.distance > 0.1, "{whole:?}");
        let region = Some([-2.0, 0.0, -2.0, 2.0, -2.0, 2.0]);
        let d = surface_distances(&volume, &[0.0], &partly, &triangles, region, None);
        assert!(d.fine_to_surface.distance < 1e-12, "{d:?}");
        assert!(d.surface_to_fine.distance < 1e-12, "{d:?}");
        assert!(0 < whole.shared_triangles && whole.shared_triangles < soup.len());
        assert!(
            d.fine_vertices < whole.fine_vertices && d.surface_samples <= whole.surface_samples
        );
        assert!(d.fine_vertices > 0, "{d:?}");
        // An empty surface is infinitely far from a non-empty F.
        let d = surface_distances(&volume, &[0.0], &[], &[], None, None);
        assert_eq!(d.fine_to_surface.distance, f64::INFINITY);
        assert_eq!(d.surface_to_fine.distance, 0.0);
    }

    /// A block of a fuzzed volume (classes of samples: −1 below the isovalue, 0 at it, 1 above)
    /// where two samples at the isovalue, joined by an edge of the finest tetrahedra, meet sheets of
    /// the surface on both sides: marching tetrahedra draw that edge with triangles of zero area, and
    /// the surface at tolerance 0 keeps coinciding points there to stay watertight. Those points lie
    /// on `{f = v}`: at distance 0 from the full-resolution level set, not from its triangles of
    /// positive area (1.49, a grid step, in the fuzzed volume).
    #[test]
    fn a_surface_at_tolerance_0_is_at_distance_0_where_it_draws_an_edge_of_samples_at_the_isovalue()
    {
        use crate::geometry::has_area;
        use crate::hierarchy::Hierarchy;
        use crate::isosurface::{extract, IsoQuery};
        use crate::volume::ScalarSlice;
        #[rustfmt::skip]
        let block: [i8; 125] = [
            -1, -1, -1, -1, -1,
            -1, -1, -1, -1, 1,
            1, 1, -1, -1, -1,
            -1, -1, -1, 1, 0,
            -1, 1, -1, -1, 1,
            -1, -1, -1, 1, -1,
            1, -1, 0, -1, -1,
            -1, -1, -1, -1, -1,
            1, -1, -1, -1, -1,
            -1, 0, 1, -1, -1,
            -1, -1, -1, -1, -1,
            -1, -1, -1, -1, -1,
            -1, -1, -1, 0, -1,
            -1, 1, -1, 0, -1,
            -1, -1, -1, 1, -1,
            -1, -1, -1, 1, -1,
            -1, -1, 0, -1, -1,
            -1, -1, -1, -1, -1,
            -1, -1, -1, -1, -1,
            -1, 1, -1, -1, 0,
            -1, -1, -1, -1, -1,
            -1, -1, 0, 0, -1,
            0, 1, -1, 1, -1,
            -1, 0, -1, 0, -1,
            -1, 1, -1, -1, -1,
        ];
        let grid = unit_grid([9, 9, 9]);
        let mut v = vec![80f32; 9 * 9 * 9];
        // At an offset of the same parity as in the fuzzed volume (the finest tetrahedra depend on it).
        for (k, c) in block.iter().enumerate() {
            let (x, y, z) = (1 + k % 5, 2 + k / 5 % 5, 2 + k / 25);
            v[x + 9 * (y + 9 * z)] = 90.0 + 10.0 * f32::from(*c);
        }
        let volume = Volume::new(grid, &v[..]).unwrap();
        let h = Hierarchy::build_for_isosurfaces(grid, ScalarSlice::F32(&v)).unwrap();
        let s = extract(
            &h,
            ScalarSlice::F32(&v),
            &IsoQuery {
                isovalues: vec![90.0],
                ..IsoQuery::new(0.0, 0.0)
            },
        )
        .unwrap();
        let corners = |t: &[u32; 3]| t.map(|i| DVec3::from(s.points[i as usize]));
        assert!(
            s.triangles.iter().any(|t| !has_area(&corners(t))),
            "the case: triangles of zero area"
        );
        let d = surface_distances(&volume, &[90.0], &s.points, &s.triangles, None, None);
        assert_eq!(d.check(0.0), Ok(()), "{d:?}");
    }

    /// A sample one ulp above the isovalue with lower values all around (an isovalue typed one ulp
    /// off a maximum of single-precision data) puts the points of its edges within rounding of it:
    /// on this grid they differ in the last bit of x only, triangles of zero area. They are no part
    /// of `F`, so a surface that leaves them out meets the bound. (Values of a bonsai crop, grey
    /// levels / 1000, where the extraction at a tolerance of a few cells draws nothing; measured
    /// from those points, it failed at an infinite distance, 26.7 > 12.9 in the whole crop.)
    #[test]
    fn points_of_a_speck_of_zero_area_are_not_measured_from() {
        use crate::hierarchy::Hierarchy;
        use crate::isosurface::{extract, IsoQuery};
        use crate::volume::{Grid, ScalarSlice};
        let grid = Grid {
            dims: [6, 8, 10],
            origin: [0.0, 156.5, 0.649],
            spacing: [148.0, 40.0, 0.013],
        };
        let mut v = vec![0f32; grid.len()];
        for ([x, y, z], thousandths) in [
            ([1, 3, 4], 1),
            ([2, 3, 4], 6),
            ([3, 3, 4], 16),
            ([2, 4, 4], 21),
            ([3, 4, 4], 11),
            ([2, 5, 4], 14),
            ([2, 3, 5], 2),
            ([3, 3, 5], 13),
            ([1, 4, 5], 1),
            ([2, 4, 5], 24),
            ([3, 4, 5], 9),
            ([1, 5, 5], 2),
            ([2, 5, 5], 14),
            ([3, 3, 6], 4),
            ([2, 4, 6], 20),
            ([3, 4, 6], 1),
            ([1, 5, 6], 1),
            ([2, 5, 6], 5),
        ] {
            v[grid.index(x, y, z)] = thousandths as f32 / 1000.0;
        }
        let isovalue = f64::from_bits(f64::from(0.024f32).to_bits() - 1);
        let volume = Volume::new(grid, &v[..]).unwrap();
        let sets = full_resolution_level_sets(&volume, &[isovalue]);
        assert!(
            sets.triangles.is_empty() && !sets.degenerate.is_empty(),
            "the case: a speck of zero area"
        );
        let h = Hierarchy::build_for_isosurfaces(grid, ScalarSlice::F32(&v)).unwrap();
        for tolerance in [0.0, 12.86] {
            let s = extract(
                &h,
                ScalarSlice::F32(&v),
                &IsoQuery::new(isovalue, tolerance),
            )
            .unwrap();
            let d = surface_distances(
                &volume,
                &[isovalue],
                &s.points,
                &s.triangles,
                None,
                Some(tolerance),
            );
            assert_eq!(d.check(tolerance), Ok(()), "{tolerance}: {d:?}");
        }
    }
}
