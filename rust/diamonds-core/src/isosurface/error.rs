//! The isosurface error of a diamond for given isovalues (Gregorski §6.2), measured at the samples that
//! decide the full-resolution surface.
//!
//! Gregorski's isosurface error of a tetrahedron `T` is `ae / ‖∇T‖`: the approximation error `ae` over
//! the magnitude of `T`'s linear gradient, i.e. how far the linear isosurface can move when the values
//! move by `ae`. Samples far from every isovalue do not move the surface, so here `ae` is taken only at
//! the *surface samples* of the query: the corners of the grid cells the isovalue crosses, which are
//! what the full-resolution surface (Flying Edges, marching cubes or marching tetrahedra of the grid) is
//! interpolated from. This needs no precomputation over the whole volume: the surface samples descend
//! the hierarchy together from the root (one bisection test and a barycentric update per sample and
//! level, [`crate::diamond::bisect`]'s vertex order), and the diamond of each tetrahedron they pass
//! keeps the largest `|f(s) − L_T(s)|` of its surface samples. The descent stops at tetrahedra no
//! larger than the tolerance: smaller diamonds' errors are bounded by their size anyway.
//!
//! This is an estimate, not a bound (see [`super::bound`], which checks the result and refines where
//! it does not hold).

use super::blocks::{bits, set_bit};
use super::paged::PagedCodes;
use super::{value, Extraction};
use crate::diamond::{arrange, child_layout, child_of, Diamond};
use crate::hierarchy::record::{decode_error, encode_error};
use crate::lattice::{Lattice, Placement, Tet};
use crate::volume::{Sample, Volume};
use crate::{Error, Result};
use glam::{DVec3, IVec3};
use rayon::prelude::*;
use std::sync::atomic::Ordering;

/// Per-diamond approximation error at the surface samples of a set of isovalues.
pub(super) struct IsoErrors {
    isovalues: Vec<f64>,
    /// Tetrahedra no larger than this (world units) end the descent: diamonds below them are not
    /// measured (their isosurface error is bounded by their size instead).
    cutoff: f64,
    /// The hierarchy's lattice (its domain the grid of the samples).
    lattice: Lattice,
    /// By central vertex: 0 if no surface sample reached the diamond, else the bfloat16 code of `ae`
    /// (at least [`VISITED`]; bit 15 clear), or, once computed, of the isosurface error (bit 15 set;
    /// codes of non-negative numbers never use it); stored where surface samples reached
    /// ([`PagedCodes`]).
    codes: PagedCodes,
    /// The central vertices (indices) of the diamonds some surface sample reached, each once.
    reached: Vec<u32>,
    /// Surface samples located (for reports and tests).
    surface_samples: usize,
}

impl std::fmt::Debug for IsoErrors {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "IsoErrors({:?}, cutoff {}, {} surface samples)",
            self.isovalues, self.cutoff, self.surface_samples
        )
    }
}

/// Marks a code that holds the isosurface error rather than `ae`.
const FINAL: u16 = 0x8000;

/// The code of a diamond some surface sample reached with `ae` = 0 (the smallest positive bfloat16).
const VISITED: u16 = 1;

impl IsoErrors {
    /// The reached diamonds (central vertex index) with their codes of `ae`, before
    /// [`IsoErrors::finalize`].
    pub(super) fn reached_codes(&self) -> impl Iterator<Item = (u32, u16)> + '_ {
        (self.reached.iter()).map(|&i| (i, self.codes.load(self.lattice.point(i as usize))))
    }

    /// Takes other pieces' [`IsoErrors::reached_codes`]: each diamond's code becomes the largest
    /// (codes of non-negative numbers order as the numbers), so pieces that located the surface
    /// samples of their own cells together hold the codes of all samples. An error, with nothing
    /// taken, when a diamond lies outside this grid (the pieces' grids differ).
    pub(super) fn raise(&mut self, others: Vec<(u32, u16)>) -> Result<()> {
        let lattice = self.lattice;
        // The domain's points are the grid's, indexed alike.
        let points = lattice.index(lattice.hi) + 1;
        if let Some(&(i, _)) = others.iter().find(|&&(i, _)| i as usize >= points) {
            return Err(Error::Parameter(format!(
                "a piece sent the error of diamond {i}, outside this grid of {points} points"
            )));
        }
        for (i, code) in others {
            let slot = self.codes.slot(lattice.point(i as usize));
            let old = slot.load(Ordering::Relaxed);
            if old == 0 {
                self.reached.push(i);
            }
            slot.store(old.max(code), Ordering::Relaxed);
        }
        Ok(())
    }

    /// Bytes held: the codes and the reached diamonds.
    pub(super) fn bytes(&self) -> usize {
        self.codes.bytes() + self.reached.capacity() * std::mem::size_of::<u32>()
    }
}

impl IsoErrors {
    /// Locates every surface sample of `isovalues` in the hierarchy, down to the tetrahedra no larger
    /// than `cutoff` (world units); `cells_crossed` lists, per isovalue, the lower corners of the grid
    /// cells it crosses.
    pub(super) fn new<T: Sample>(
        lattice: &Lattice,
        volume: &Volume<'_, T>,
        isovalues: &[f64],
        cutoff: f64,
        cells_crossed: impl Fn(f64) -> Vec<u32> + Sync,
    ) -> Self {
        let grid = &volume.grid;
        let codes = PagedCodes::new(grid.dims, 0);
        let roots = RootTets::new(lattice);
        let mut surface_samples = 0;
        let mut reached = Vec::new();
        for &v in isovalues {
            let cells = cells_crossed(v);
            let samples = corners_of(grid.dims, &cells);
            surface_samples += samples.len();
            let walk = Walk {
                lattice,
                volume,
                cutoff2: cutoff * cutoff,
                codes: &codes,
            };
            // Each sample with its coordinates in the root tetrahedron holding it, bucketed by root.
            let roots_n = roots.tets.len();
            let chunks: Vec<Vec<Vec<Located>>> = samples
                .par_chunks(1 << 16)
                .map(|chunk| {
                    let mut buckets = vec![Vec::new(); roots_n];
                    for &i in chunk {
                        let [x, y, z] = grid.ijk(i as usize);
                        let (k, l) = roots.containing(DVec3::new(x as f64, y as f64, z as f64));
                        let f = volume.samples[i as usize].to_f64();
                        buckets[k].push(Located {
                            l: l.map(|c| c as f32),
                            f,
                        });
                    }
                    buckets
                })
                .collect();
            let mut located: Vec<Vec<Located>> = (0..roots_n)
                .map(|k| chunks.iter().flat_map(|c| c[k].iter().copied()).collect())
                .collect();
            drop(chunks);
            reached.extend(
                located
                    .par_iter_mut()
                    .zip(&roots.tets)
                    .flat_map_iter(|(points, (t, _))| {
                        let mut reached = Vec::new();
                        walk.descend(*t, None, points, &mut reached);
                        reached
                    })
                    .collect::<Vec<u32>>(),
            );
        }
        Self {
            isovalues: isovalues.to_vec(),
            cutoff,
            lattice: *lattice,
            codes,
            reached,
            surface_samples,
        }
    }

    /// Whether these errors serve queries for `isovalues` at `tolerance`: measured for both, so that
    /// a query's result never depends on the queries before it (errors measured down to a smaller
    /// cutoff would split more).
    pub(super) fn serve(&self, isovalues: &[f64], tolerance: f64) -> bool {
        self.isovalues == isovalues && self.cutoff.to_bits() == tolerance.to_bits()
    }

    /// The isosurface error of `d` (central vertex in the domain), world units: the largest
    /// `min(ae / ‖∇T‖, size(T))` over its inside tetrahedra (Gregorski §6.2, Eq. 5), 0 when no surface
    /// sample lies in it.
    pub(super) fn error<T: Sample>(&self, x: &Extraction<'_, '_, T>, d: Diamond) -> f64 {
        let code = self.codes.load(d.center);
        match code {
            // Not reached: no surface sample in it, or below the cutoff (bounded by the size).
            0 => {
                let size = d.tet_size(x.volume.grid.spacing);
                if size <= self.cutoff {
                    size
                } else {
                    0.0
                }
            }
            _ if code & FINAL != 0 => decode_error(code & !FINAL),
            _ => decode_error(encode_error(isosurface_error(x, d, decode_error(code)))),
        }
    }
}

impl IsoErrors {
    /// Computes, in parallel, the isosurface error of every diamond a surface sample reached.
    pub(super) fn finalize<T: Sample>(&self, x: &Extraction<'_, '_, T>) {
        self.reached
            .par_iter()
            .with_min_len(1 << 10)
            .for_each(|&i| {
                let c = self.lattice.point(i as usize);
                let slot = self.codes.slot(c);
                let code = slot.load(Ordering::Relaxed);
                if code & FINAL == 0 {
                    let e = isosurface_error(x, Diamond::new(c), decode_error(code));
                    slot.store(encode_error(e) | FINAL, Ordering::Relaxed);
                }
            });
    }

    /// The error refinement compares with a tolerance at least the cutoff: [`IsoErrors::error`] where a
    /// surface sample reached the diamond, else 0 (its error is at most the cutoff).
    pub(super) fn refinement_error<T: Sample>(&self, x: &Extraction<'_, '_, T>, d: Diamond) -> f64 {
        match self.codes.load(d.center) {
            0 => 0.0,
            _ => self.error(x, d),
        }
    }
}

/// Gregorski §6.2, Eq. (5): the largest `min(ae / ‖∇T‖, size(T))` over the diamond's inside
/// tetrahedra, i.e. `min(ae / G, size)` with `G` the smallest gradient magnitude among them (the
/// tetrahedra of a diamond are congruent) — `G` comes from the [`IsoCache`](super::cache::IsoCache),
/// the same for every isovalue.
fn isosurface_error<T: Sample>(x: &Extraction<'_, '_, T>, d: Diamond, ae: f64) -> f64 {
    let size = d.tet_size(x.volume.grid.spacing);
    let g = x.smallest_gradient(d);
    if g > 0.0 {
        (ae / g).min(size)
    } else {
        size
    }
}

/// The squared longest edge of `t` in world units for a grid `spacing`.
#[inline]
pub(super) fn tet_size2(spacing: &[f64; 3], t: &Tet) -> f64 {
    let s = DVec3::from(*spacing);
    [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
        .iter()
        .map(|&(a, b)| ((t[a] - t[b]).as_dvec3() * s).length_squared())
        .fold(0.0, f64::max)
}

/// The distinct corners of the cells whose lower corners are `cells`, as point indices, sorted (which
/// thread claims a shared corner first varies; the order must not): marked in a bitset over the
/// points, then read from it in order.
pub(super) fn corners_of(dims: [usize; 3], cells: &[u32]) -> Vec<u32> {
    let seen = bits(dims[0] * dims[1] * dims[2]);
    let (sx, sy) = (1, dims[0]);
    let sz = dims[0] * dims[1];
    cells.par_iter().for_each(|&c| {
        for k in 0..8 {
            let i = c as usize
                + if k & 1 != 0 { sx } else { 0 }
                + if k & 2 != 0 { sy } else { 0 }
                + if k & 4 != 0 { sz } else { 0 };
            set_bit(&seen, i);
        }
    });
    seen.par_iter()
        .enumerate()
        .flat_map_iter(|(w, word)| {
            let mut word = word.load(Ordering::Relaxed);
            std::iter::from_fn(move || {
                (word != 0).then(|| {
                    let b = word.trailing_zeros();
                    word &= word - 1;
                    (64 * w) as u32 + b
                })
            })
        })
        .collect()
}

/// The six tetrahedra of the root diamond, `[0, (N, N, N), N e_i, N (e_i + e_j)]` (see
/// [`Diamond::tets`]), with their axes `(i, j, k)`: each holds the points with `s_i ≥ s_j ≥ s_k`.
pub(super) struct RootTets {
    pub(super) tets: Vec<(Tet, [usize; 3])>,
    n: f64,
}

impl RootTets {
    pub(super) fn new(lattice: &Lattice) -> Self {
        let axis = |v: IVec3| (0..3).find(|&a| v[a] != 0).expect("an axis step");
        let tets = Diamond::root(lattice)
            .tets(lattice)
            .into_iter()
            .map(|t| {
                debug_assert_eq!(t[0], IVec3::ZERO);
                let (i, j) = (axis(t[2] - t[0]), axis(t[3] - t[2]));
                (t, [i, j, 3 - i - j])
            })
            .collect();
        Self {
            tets,
            n: lattice.size() as f64,
        }
    }

    /// The first root tetrahedron holding `s` (its position in `tets`) and the barycentric
    /// coordinates of `s` in it.
    pub(super) fn containing(&self, s: DVec3) -> (usize, [f64; 4]) {
        self.tets
            .iter()
            .enumerate()
            .find_map(|(k, (_, [i, j, kk]))| {
                (s[*i] >= s[*j] && s[*j] >= s[*kk]).then(|| {
                    let c = |a: usize| s[a] / self.n;
                    (k, [1.0 - c(*i), c(*kk), c(*i) - c(*j), c(*j) - c(*kk)])
                })
            })
            .expect("the root tetrahedra cover the root cube")
    }
}

/// A surface sample on its way down: barycentric coordinates in the current tetrahedron and value.
#[derive(Clone, Copy, Debug)]
struct Located {
    /// Exact: the coordinates of a lattice point are multiples of `1 / N`, `N ≤ 2^24`.
    l: [f32; 4],
    f: f64,
}

/// The descent of the surface samples of isovalue `v` through the hierarchy.
struct Walk<'a, 'v, T> {
    lattice: &'a Lattice,
    volume: &'a Volume<'v, T>,
    /// Squared [`IsoErrors::cutoff`].
    cutoff2: f64,
    codes: &'a PagedCodes,
}

/// Below this many samples a subtree is walked on the current thread.
const SEQUENTIAL: usize = 2048;

impl<T: Sample> Walk<'_, '_, T> {
    /// Visits the tetrahedron `t` (vertex values `f` once it lies inside the domain) holding the
    /// surface samples `points`: records in its diamond the largest `|f(s) − L_T(s)|`; then bisects it and sends every sample to the child holding it (the first on a tie).
    /// Samples that became vertices (interpolated exactly below), unit-cube tetrahedra (no sample but
    /// their vertices) and tetrahedra no larger than the cutoff end the descent.
    /// The central vertices of the diamonds reached for the first time are added to `reached`.
    fn descend(&self, t: Tet, f: Option<[f64; 4]>, points: &mut [Located], reached: &mut Vec<u32>) {
        let twice = t[0] + t[1];
        if points.is_empty() || twice & IVec3::ONE != IVec3::ZERO {
            return;
        }
        let m = twice / 2;
        let f = f.or_else(|| {
            (self.lattice.place(&t) == Placement::Inside).then(|| t.map(|p| value(self.volume, p)))
        });
        // A tetrahedron no larger than the cutoff ends the descent: its diamond's children are not
        // measured. (One straddling a far face records nothing, so the descent goes on to its
        // inside descendants, which can be leaves.)
        let last = f.is_some() && tet_size2(&self.volume.grid.spacing, &t) <= self.cutoff2;
        let mut e = 0.0f64;
        let mut measure = |p: &Located| {
            if let Some(f) = f {
                let l = p.l.map(f64::from);
                let interpolated = l[0] * f[0] + l[1] * f[1] + l[2] * f[2] + l[3] * f[3];
                e = e.max((p.f - interpolated).abs());
            }
        };
        // Bisect: child 0 keeps the samples with l0 ≥ l1, in front; samples now at a vertex leave.
        // (Measured in the same pass.)
        let layouts = [child_layout(&t, true), child_layout(&t, false)];
        let (mut front, mut back) = (0, points.len());
        if last {
            points.iter().for_each(&mut measure);
        } else {
            let mut k = 0;
            while k < back {
                let p = points[k];
                measure(&p);
                let l = p.l;
                let first = l[0] >= l[1];
                let (kept, other) = if first { (0, 1) } else { (1, 0) };
                // Exact in f32: differences and doubles of multiples of 1 / N.
                let (lk, lm) = (l[kept] - l[other], 2.0 * l[other]);
                if lm == 1.0 {
                    back -= 1; // at the midpoint: a vertex from here down (other weights stay < 1)
                    points[k] = points[back];
                    points[back] = p;
                    continue;
                }
                let moved = Located {
                    l: arrange(layouts[kept], l, lk, lm),
                    f: p.f,
                };
                if first {
                    points[k] = points[front];
                    points[front] = moved;
                    front += 1;
                } else {
                    points[k] = moved;
                }
                k += 1;
            }
        }
        if f.is_some() {
            let code = encode_error(e).max(VISITED);
            if code > self.codes.load(m)
                && self.codes.slot(m).fetch_max(code, Ordering::Relaxed) == 0
            {
                reached.push(self.lattice.index(m) as u32);
            }
        }
        if last {
            return;
        }
        let fm = f.map(|_| value(self.volume, m));
        let child = |kept: usize| {
            (
                arrange(layouts[kept], t, t[kept], m),
                f.zip(fm)
                    .map(|(f, fm)| arrange(layouts[kept], f, f[kept], fm)),
            )
        };
        let ((c0, f0), (c1, f1)) = (child(0), child(1));
        let (p0, rest) = points[..back].split_at_mut(front);
        if back > SEQUENTIAL {
            let mut other = Vec::new();
            rayon::join(
                || self.descend(c0, f0, p0, reached),
                || self.descend(c1, f1, rest, &mut other),
            );
            reached.append(&mut other);
        } else {
            self.descend(c0, f0, p0, reached);
            self.descend(c1, f1, rest, reached);
        }
    }
}

/// The child of `t` holding the point with barycentric coordinates `l` (the first on a tie) and the
/// point's coordinates in it: `l_k t_k + l_o t_o` with `t_o = 2m − t_k` gives `t_k` the weight
/// `l_k − l_o` and `m` the weight `2 l_o`.
#[inline]
pub(super) fn child_coordinates(t: &Tet, l: [f64; 4]) -> (bool, [f64; 4]) {
    let first = l[0] >= l[1];
    let (k, o) = if first { (0, 1) } else { (1, 0) };
    (first, child_of(t, first, l, l[k] - l[o], 2.0 * l[o]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diamond::bisect;

    #[test]
    fn other_pieces_codes_raise_and_a_diamond_outside_the_grid_is_refused() {
        let mut errors = IsoErrors {
            isovalues: vec![1.0],
            cutoff: 0.0,
            lattice: Lattice::new([2, 2, 2]).unwrap(),
            codes: PagedCodes::new([2, 2, 2], 0),
            reached: Vec::new(),
            surface_samples: 0,
        };
        errors.raise(vec![(3, 5), (3, 9), (4, 2), (3, 7)]).unwrap();
        let codes: Vec<(u32, u16)> = errors.reached_codes().collect();
        assert_eq!(
            codes,
            vec![(3, 9), (4, 2)],
            "the largest code per diamond, each once"
        );
        assert!(errors.raise(vec![(1, 7), (8, 1)]).is_err());
        assert_eq!(
            errors.reached_codes().count(),
            2,
            "nothing taken from a refused list"
        );
    }

    #[test]
    fn descent_follows_bisection_and_keeps_the_sample() {
        // Every step of the descent is one of `bisect`'s children, holds s, and its barycentric
        // coordinates and vertex values (here those of a linear field) reproduce s and f(s).
        let lattice = Lattice::new([17, 17, 17]).unwrap();
        let roots = RootTets::new(&lattice);
        let field = |p: IVec3| 3.0 * p.x as f64 - 2.0 * p.y as f64 + 0.5 * p.z as f64;
        for s in [
            IVec3::new(3, 5, 7),
            IVec3::new(16, 0, 9),
            IVec3::new(8, 8, 8),
            IVec3::new(1, 1, 2),
            IVec3::new(15, 13, 1),
        ] {
            let (k, mut l) = roots.containing(s.as_dvec3());
            let mut t = roots.tets[k].0;
            let mut f = t.map(field);
            let mut steps = 0;
            while l.iter().all(|&c| c < 1.0) && ((t[0] + t[1]) & IVec3::ONE) == IVec3::ZERO {
                let p: DVec3 = (0..4).map(|i| t[i].as_dvec3() * l[i]).sum();
                assert!(p.distance(s.as_dvec3()) < 1e-9, "{s:?} in {t:?} at {l:?}");
                assert!(l.iter().all(|&c| c >= 0.0));
                let fs: f64 = (0..4).map(|i| f[i] * l[i]).sum();
                assert!((fs - field(s)).abs() < 1e-9);
                let m = (t[0] + t[1]) / 2;
                let (first, nl) = child_coordinates(&t, l);
                let k = usize::from(!first);
                let child = child_of(&t, first, t, t[k], m);
                assert_eq!(child, bisect(&t)[k], "{t:?}");
                f = child_of(&t, first, f, f[k], field(m));
                assert_eq!(f, child.map(field));
                (t, l) = (child, nl);
                steps += 1;
            }
            assert!(steps > 0 && l.contains(&1.0), "{s:?} never became a vertex");
        }
    }
}
