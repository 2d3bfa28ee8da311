//! Integer point enumeration inside a tetrahedron and its exact interpolation error (Marchesin §4.1).
//!
//! Marchesin et al. enumerate the lattice points of an LEB tetrahedron slice by slice. We scan rows
//! along x instead: for each `(y, z)` the row's x-interval is cut by the four face half-spaces, using
//! the *barycentric numerators* `B_i(p) = n_i · p + b_i` (integer coefficients; `B_i(p) = det · λ_i(p)`).
//! A point is inside (closed) iff every `B_i(p) ≥ 0` — exact integer tests, no epsilon.
//!
//! The linear interpolant satisfies `det · L(p) = Σ B_i(p) f_i`, so the error at a sample is
//! `|det · f(p) − Σ B_i(p) f_i| / det`. For samples of up to 16-bit integers every term is an integer
//! below 2^53 and the `f64` arithmetic is exact (coefficients are first divided by `s²`, `s` the
//! tetrahedron's scale): an error of zero is reported as exactly zero. For 32-bit and floating-point
//! samples the result carries the usual `f64` rounding (relative 1e-16).

use crate::diamond::{Class, Diamond};
use crate::lattice::Lattice;
use crate::lattice::Tet;
use crate::volume::{Grid, Sample, Volume};
use glam::{I64Vec3, IVec3};
use rustc_hash::FxHashMap;

/// What a scan of a tetrahedron finds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TetStats {
    /// Largest `|f(p) − L(p)|` over the samples `p` in the closed tetrahedron.
    pub error: f64,
    /// Smallest sample in the closed tetrahedron.
    pub min: f64,
    /// Largest sample in the closed tetrahedron.
    pub max: f64,
}

impl TetStats {
    /// Neutral element of [`TetStats::merge`].
    pub const EMPTY: Self = Self {
        error: 0.0,
        min: f64::INFINITY,
        max: f64::NEG_INFINITY,
    };

    /// Union of two scans.
    #[inline]
    pub fn merge(self, other: Self) -> Self {
        Self {
            error: self.error.max(other.error),
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }
}

/// Barycentric numerator planes of a tetrahedron: `B_i(p) = normals[i] · p + offsets[i]`.
///
/// After division by `s²` every normal component of an LEB tetrahedron is 0, ±1, ±2 or ±4 (checked by a
/// test over every tetrahedron of a 32-cube), so row bounds need shifts only.
struct Planes {
    normals: [I64Vec3; 4],
    offsets: [i64; 4],
    det: i64,
}

impl Planes {
    fn new(t: &Tet) -> Self {
        let v = t.map(|p| p.as_i64vec3());
        // Every edge vector of an LEB tetrahedron is a multiple of its scale s (a power of two);
        // dividing the normals by s² keeps all products small and exact.
        let or = (1..4).fold(0i64, |acc, i| {
            let e = (v[i] - v[0]).abs();
            acc | e.x | e.y | e.z
        });
        let s2 = 1i64 << (2 * or.trailing_zeros());
        let mut normals = [I64Vec3::ZERO; 4];
        let mut offsets = [0i64; 4];
        let mut det = 0;
        for i in 0..4 {
            let [a, b, c] = [(i + 1) % 4, (i + 2) % 4, (i + 3) % 4].map(|j| v[j]);
            let mut n = (b - a).cross(c - a) / s2;
            let at_vertex = n.dot(v[i] - a);
            if at_vertex < 0 {
                n = -n;
            }
            det = at_vertex.abs();
            normals[i] = n;
            offsets[i] = -n.dot(a);
        }
        Self {
            normals,
            offsets,
            det,
        }
    }
}

/// Scans the samples of `volume` inside the closed tetrahedron `t` (all vertices must be samples).
pub fn scan_tet<T: Sample>(volume: &Volume<'_, T>, t: &Tet) -> TetStats {
    let spread = (1..4).fold(0, |acc, i| {
        let e = (t[i] - t[0]).abs();
        acc | e.x | e.y | e.z
    });
    if spread < 4 {
        return scan_finest(volume, t);
    }
    let values = t.map(|p| volume.at(p.x as usize, p.y as usize, p.z as usize));
    let lo = t[0].min(t[1]).min(t[2].min(t[3]));
    let hi = t[0].max(t[1]).max(t[2].max(t[3]));
    scan_rows(volume, IVec3::ZERO, t, values, (lo, hi))
}

/// The part of a tetrahedron's scan that one piece of a distributed volume sees: the samples of
/// the closed tetrahedron `t` (lattice coordinates of the whole grid) inside the closed box `clip`,
/// read from `volume`, whose first sample is the lattice point `origin` (`clip` must lie inside
/// it); `values` are the samples at `t`'s vertices, which may lie outside `volume`. The merge of
/// the parts of boxes covering `t` is [`scan_tet`]'s result, bit for bit: every row is scanned
/// with the same floating-point operations as by [`scan_tet`] on the whole grid (for tetrahedra
/// wider than a unit cube, which is what it is used for).
pub fn scan_tet_part<T: Sample>(
    volume: &Volume<'_, T>,
    origin: IVec3,
    t: &Tet,
    values: [f64; 4],
    clip: (IVec3, IVec3),
) -> TetStats {
    let lo = t[0].min(t[1]).min(t[2].min(t[3])).max(clip.0);
    let hi = t[0].max(t[1]).max(t[2].max(t[3])).min(clip.1);
    if lo.cmpgt(hi).any() {
        return TetStats::EMPTY;
    }
    scan_rows(volume, origin, t, values, (lo, hi))
}

/// The row scan of Marchesin §4.1 over the rows of `t` in the box `(lo, hi)` (whole-grid lattice
/// coordinates; `volume` starts at `origin`). Each row's interpolant runs from the row's first
/// point inside `t`, also when the box cuts the row later, so that a row's arithmetic does not
/// depend on the box.
#[inline]
fn scan_rows<T: Sample>(
    volume: &Volume<'_, T>,
    origin: IVec3,
    t: &Tet,
    values: [f64; 4],
    (lo, hi): (IVec3, IVec3),
) -> TetStats {
    let planes = Planes::new(t);
    let det = planes.det as f64;
    let slope: f64 = (0..4).map(|i| planes.normals[i].x as f64 * values[i]).sum();
    let dims = volume.grid.dims;
    let shifts = planes.normals.map(|n| n.x.unsigned_abs().trailing_zeros());
    let t_lo_x = t[0].x.min(t[1].x).min(t[2].x.min(t[3].x)) as i64;
    let t_hi_x = t[0].x.max(t[1].x).max(t[2].x.max(t[3].x)) as i64;
    let (mut worst, mut min, mut max) = (0.0f64, f64::INFINITY, f64::NEG_INFINITY);
    for z in lo.z as i64..=hi.z as i64 {
        for y in lo.y as i64..=hi.y as i64 {
            let (mut x0, mut x1) = (t_lo_x, t_hi_x);
            let mut base = 0.0;
            for i in 0..4 {
                let n = planes.normals[i];
                let r = n.y * y + n.z * z + planes.offsets[i];
                if n.x > 0 {
                    x0 = x0.max(-(r >> shifts[i]));
                } else if n.x < 0 {
                    x1 = x1.min(r >> shifts[i]);
                } else if r < 0 {
                    x1 = -1;
                }
                base += r as f64 * values[i];
            }
            let mut numerator = base + slope * x0 as f64;
            // Clipped rows advance the interpolant the way the whole row does.
            for _ in x0..lo.x as i64 {
                numerator += slope;
            }
            let (x0, x1) = (x0.max(lo.x as i64), x1.min(hi.x as i64));
            if x0 > x1 {
                continue;
            }
            let (ry, rz) = (
                (y - origin.y as i64) as usize,
                (z - origin.z as i64) as usize,
            );
            let row = dims[0] * (ry + dims[1] * rz);
            let (a, b) = (
                (x0 - origin.x as i64) as usize,
                (x1 - origin.x as i64) as usize,
            );
            let samples = &volume.samples[row + a..=row + b];
            for s in samples {
                let f = s.to_f64();
                let e = (det * f - numerator).abs();
                if e > worst {
                    worst = e;
                }
                if f < min {
                    min = f;
                }
                if f > max {
                    max = f;
                }
                numerator += slope;
            }
        }
    }
    TetStats {
        error: worst / det,
        min,
        max,
    }
}

fn scan_finest<T: Sample>(volume: &Volume<'_, T>, t: &Tet) -> TetStats {
    let at = |p: IVec3| volume.at(p.x as usize, p.y as usize, p.z as usize);
    let f = t.map(at);
    let mut stats = TetStats {
        error: 0.0,
        min: f[0].min(f[1]).min(f[2].min(f[3])),
        max: f[0].max(f[1]).max(f[2].max(f[3])),
    };
    for (a, b) in [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)] {
        let twice = t[a] + t[b];
        if twice & IVec3::ONE == IVec3::ZERO {
            let v = at(twice / 2);
            stats.error = stats.error.max((2.0 * v - f[a] - f[b]).abs());
            stats.min = stats.min.min(v);
            stats.max = stats.max.max(v);
        }
    }
    stats.error *= 0.5;
    stats
}

/// Tetrahedron shapes of small scales with their lattice points precomputed: for each shape (edge vectors
/// from the first vertex) the linear offsets of its non-vertex samples and their barycentric numerators.
/// Scanning a tetrahedron then needs neither plane setup nor row bounds — the dominant cost of
/// [`scan_tet`] for small tetrahedra, which are the most numerous.
pub struct Stencils {
    shapes: FxHashMap<[IVec3; 3], usize>,
    stencils: Vec<Stencil>,
    /// Per scale 2 and 4 (`σ` = 1, 2) and residue of the central vertex `(c >> σ) mod 8`, which fixes
    /// the shapes of a diamond's tetrahedra: each tetrahedron as its vertices' linear offsets from the
    /// central vertex and its stencil (see [`Stencils::diamond_error`]).
    diamonds: Vec<Vec<([isize; 4], usize)>>,
    finest: FinestMidpoints,
}

/// The residue `(c >> σ) mod 8` of a central vertex, `x + 8 y + 64 z`.
#[inline]
fn residue(c: IVec3, sigma: u32) -> usize {
    let r = (c >> IVec3::splat(sigma as i32)) & IVec3::splat(7);
    (r.x | r.y << 3 | r.z << 6) as usize
}

struct Stencil {
    det: f64,
    points: Vec<(isize, [f64; 4])>,
}

impl Stencils {
    /// Shapes of every diamond tetrahedron of scale 2 and 4, with offsets for `grid`'s layout.
    pub fn new(grid: &Grid) -> Self {
        let mut shapes = FxHashMap::default();
        let mut stencils = Vec::new();
        let lattice = Lattice::new([65; 3]).expect("valid");
        let stride = IVec3::new(1, grid.dims[0] as i32, (grid.dims[0] * grid.dims[1]) as i32);
        let linear = |o: IVec3| {
            o.x as isize * stride.x as isize
                + o.y as isize * stride.y as isize
                + o.z as isize * stride.z as isize
        };
        let mut diamonds = Vec::with_capacity(2 * 512);
        for sigma in 1..=2u32 {
            for r in 0..512i32 {
                let residue = IVec3::new(r & 7, r >> 3 & 7, r >> 6);
                let mut tets = Vec::new();
                // A representative centre of scale 2^σ with this residue, inside the 64-cube.
                if (residue & IVec3::ONE) != IVec3::ZERO {
                    let c = (residue + IVec3::splat(8)) << IVec3::splat(sigma as i32);
                    let d = Diamond::new(c);
                    for t in d.tets(&lattice) {
                        let key = [t[1] - t[0], t[2] - t[0], t[3] - t[0]];
                        let id = *shapes.entry(key).or_insert_with(|| {
                            stencils.push(Stencil::new(&t, linear));
                            stencils.len() - 1
                        });
                        tets.push((t.map(|p| linear(p - c)), id));
                    }
                }
                diamonds.push(tets);
            }
        }
        Self {
            shapes,
            stencils,
            diamonds,
            finest: FinestMidpoints::new(linear),
        }
    }

    /// Error of a finest diamond (scale 1) whose bounds lie inside the domain, from the sample of its
    /// central vertex at `center` ([`finest_diamond_error`]; like [`Stencils::diamond_error`], `volume`
    /// may start anywhere in the lattice).
    #[inline]
    pub fn finest_diamond_error<T: Sample>(
        &self,
        volume: &Volume<'_, T>,
        d: Diamond,
        center: usize,
    ) -> f64 {
        finest_diamond_error(volume, &self.finest, d, center)
    }

    /// Writes `error(x, e)` for every finest diamond (scale 1) centred at `(x, y, z)`, `x` in `xs`, whose
    /// bounds lie inside the domain (the caller's promise: `xs`, `y` and `z` at least one point from
    /// every face of `volume`'s grid), `e` its [`Stencils::finest_diamond_error`]. These are 7 of
    /// every 8 diamonds, and along a row the midpoint table only depends on `x mod 8`: it is looked
    /// up once per row, and no [`Diamond`] or bounds are built per diamond.
    #[inline]
    pub fn finest_row_errors<T: Sample>(
        &self,
        volume: &Volume<'_, T>,
        [y, z]: [usize; 2],
        xs: std::ops::Range<usize>,
        mut error: impl FnMut(usize, f64),
    ) {
        let tables: [&[[isize; 3]]; 8] =
            std::array::from_fn(|x| self.finest.of(IVec3::new(x as i32, y as i32, z as i32)));
        let first = volume.grid.index(0, y, z);
        // The diamonds of scale 1 (σ = 0, [`Diamond::sigma`]): with `y` and `z` even, odd `x` only.
        let step = if (y | z) & 1 == 1 { 1 } else { 2 };
        let start = if step == 2 { xs.start | 1 } else { xs.start };
        for x in (start..xs.end).step_by(step) {
            debug_assert_eq!(
                Diamond::new(IVec3::new(x as i32, y as i32, z as i32)).scale(),
                1
            );
            error(x, finest_error(volume, tables[x & 7], first + x));
        }
    }

    /// [`scan_tet`]'s error through the precomputed shape, when `t` has one.
    #[inline]
    pub fn error<T: Sample>(&self, volume: &Volume<'_, T>, t: &Tet) -> Option<f64> {
        let stencil = &self.stencils[*self.shapes.get(&[t[1] - t[0], t[2] - t[0], t[3] - t[0]])?];
        let index = |p: IVec3| volume.grid.index(p.x as usize, p.y as usize, p.z as usize) as isize;
        Some(stencil.error(volume, index(t[0]), t.map(index)))
    }

    /// The largest error of the tetrahedra of diamond `d` of scale 2 or 4 (`None` for other scales)
    /// whose bounds lie inside the domain, from the sample of its central vertex at `center`: what
    /// [`Stencils::error`] gives for each of [`Diamond::tets`], without computing them.
    #[inline]
    pub fn diamond_error<T: Sample>(
        &self,
        volume: &Volume<'_, T>,
        d: Diamond,
        center: usize,
    ) -> Option<f64> {
        let sigma = d.sigma();
        if !(1..=2).contains(&sigma) {
            return None;
        }
        let center = center as isize;
        let tets = &self.diamonds[512 * (sigma as usize - 1) + residue(d.center, sigma)];
        let mut worst = 0.0f64;
        for (vertices, id) in tets {
            let e = self.stencils[*id].error(
                volume,
                center + vertices[0],
                vertices.map(|v| center + v),
            );
            if e > worst {
                worst = e;
            }
        }
        Some(worst)
    }
}

impl Stencil {
    /// The stencil of tetrahedron `t`, its points' offsets from `t[0]` by `linear`.
    fn new(t: &Tet, linear: impl Fn(IVec3) -> isize) -> Self {
        let planes = Planes::new(t);
        let points = brute_force_points(t)
            .into_iter()
            .filter(|p| !t.contains(p))
            .map(|p| {
                let q = p.as_i64vec3();
                let w =
                    std::array::from_fn(|i| (planes.normals[i].dot(q) + planes.offsets[i]) as f64);
                (linear(p - t[0]), w)
            })
            .collect();
        Stencil {
            det: planes.det as f64,
            points,
        }
    }

    /// The error of a tetrahedron of this shape whose first vertex is the sample `base` and whose
    /// vertices are the samples `vertices` (linear indices): [`scan_tet`]'s error (no range: the
    /// hierarchy's records hold the error alone).
    #[inline]
    fn error<T: Sample>(&self, volume: &Volume<'_, T>, base: isize, vertices: [isize; 4]) -> f64 {
        let stencil = self;
        let f = vertices.map(|i| volume.samples[i as usize].to_f64());
        let mut worst = 0.0f64;
        for (offset, w) in &stencil.points {
            let v = volume.samples[(base + offset) as usize].to_f64();
            let e =
                (stencil.det * v - (w[0] * f[0] + w[1] * f[1] + w[2] * f[2] + w[3] * f[3])).abs();
            if e > worst {
                worst = e;
            }
        }
        worst / stencil.det
    }
}

/// Error of a finest diamond (scale 1) whose bounds lie inside the domain, without visiting its
/// tetrahedra one by one. Its samples are the lattice points of its `3×3×3` bounding cube that belong
/// to its tetrahedra; each is a vertex or the midpoint of the spine of the diamond itself or of one of
/// its descendants inside it (a 1-diamond's 4 edge children; a 0-diamond's 6 face children and their
/// 12 edge children), where the interpolant is the mean of the spine's endpoints. Only those
/// midpoints and endpoints are read (no range: the record holds the error alone), with plain
/// comparisons: the samples are finite.
///
/// Which midpoints and spines these are depends only on the central vertex modulo 8 (class,
/// orientation and, for a 0-diamond's face children, the parity that picks their diagonal), so they
/// are looked up in [`FinestMidpoints`] instead of being derived per diamond.
#[inline]
fn finest_diamond_error<T: Sample>(
    volume: &Volume<'_, T>,
    midpoints: &FinestMidpoints,
    d: Diamond,
    center: usize,
) -> f64 {
    finest_error(volume, midpoints.of(d.center), center)
}

/// [`finest_diamond_error`] from the diamond's `midpoints` (its entry of [`FinestMidpoints`]).
#[inline]
fn finest_error<T: Sample>(volume: &Volume<'_, T>, midpoints: &[[isize; 3]], center: usize) -> f64 {
    let at = |o: isize| volume.samples[center.wrapping_add_signed(o)].to_f64();
    // Twice the error at each midpoint `m` of a spine `(a, b)`.
    let mut worst = 0.0f64;
    for &[m, a, b] in midpoints {
        let e = (2.0 * at(m) - at(a) - at(b)).abs();
        if e > worst {
            worst = e;
        }
    }
    0.5 * worst
}

/// The spine midpoints of the finest diamonds, per central vertex modulo 8 (see
/// [`finest_diamond_error`]): for each, `[midpoint, end, end]` as linear offsets from the central
/// vertex in the grid's layout.
pub(crate) struct FinestMidpoints {
    triples: Vec<[isize; 3]>,
    /// `triples[starts[r]..starts[r + 1]]` for the residue `r = x + 8 y + 64 z` of the centre.
    starts: Vec<u16>,
}

impl FinestMidpoints {
    /// The table for a grid whose linear offset of `o` is `linear(o)`.
    fn new(linear: impl Fn(IVec3) -> isize) -> Self {
        let mut triples = Vec::new();
        let mut starts = vec![0u16];
        for r in 0..512 {
            let residue = IVec3::new(r & 7, r >> 3 & 7, r >> 6);
            // A representative centre with this residue, away from the origin.
            let d = Diamond::new(residue + IVec3::splat(8));
            if (residue & IVec3::ONE) != IVec3::ZERO {
                let c = d.center;
                let mut push = |o: IVec3, h: IVec3| triples.push([o, o - h, o + h].map(&linear));
                push(IVec3::ZERO, d.spine()[0] - c);
                let axes = [IVec3::X, IVec3::Y, IVec3::Z];
                match d.class() {
                    Class::Edge => {}
                    Class::Face => {
                        // The 4 edges of the face: midpoints c ± u (spine along v) and c ± v (spine along u).
                        let n = axes.iter().position(|a| (c.dot(*a) & 1) == 0).unwrap_or(0);
                        let (u, v) = (axes[(n + 1) % 3], axes[(n + 2) % 3]);
                        for (o, h) in [(u, v), (-u, v), (v, u), (-v, u)] {
                            push(o, h);
                        }
                    }
                    Class::Cube => {
                        for (a, &axis) in axes.iter().enumerate() {
                            for o in [axis, -axis] {
                                // Face centre: a 1-diamond's face diagonal.
                                push(o, Diamond::new(c + o).spine()[0] - c - o);
                                // Cube edges along `axis`: midpoints at the other two axes' ±1.
                                let (p, q) = (axes[(a + 1) % 3], axes[(a + 2) % 3]);
                                let side = if o == axis { 1 } else { -1 };
                                for e in [p + q, p - q] {
                                    push(e * side, axis);
                                }
                            }
                        }
                    }
                }
            }
            starts.push(triples.len() as u16);
        }
        Self { triples, starts }
    }

    /// The midpoints of the finest diamond centred at `c`.
    #[inline]
    fn of(&self, c: IVec3) -> &[[isize; 3]] {
        let r = (c.x & 7 | (c.y & 7) << 3 | (c.z & 7) << 6) as usize;
        &self.triples[self.starts[r] as usize..self.starts[r + 1] as usize]
    }
}

/// Lattice points of the closed tetrahedron, by brute force over its bounding box with `f64`
/// barycentric coordinates (slow; used to test [`scan_tet`]).
pub fn brute_force_points(t: &Tet) -> Vec<IVec3> {
    let lo = t[0].min(t[1]).min(t[2].min(t[3]));
    let hi = t[0].max(t[1]).max(t[2].max(t[3]));
    let v = t.map(|p| p.as_dvec3());
    let m = glam::DMat3::from_cols(v[1] - v[0], v[2] - v[0], v[3] - v[0]);
    let inv = m.inverse();
    let mut out = Vec::new();
    for z in lo.z..=hi.z {
        for y in lo.y..=hi.y {
            for x in lo.x..=hi.x {
                let p = IVec3::new(x, y, z);
                let l = inv * (p.as_dvec3() - v[0]);
                if l.min_element() >= -1e-9 && l.element_sum() <= 1.0 + 1e-9 {
                    out.push(p);
                }
            }
        }
    }
    out
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::diamond::all_diamonds;

    /// Deterministic pseudo-random samples in `0..4096` on `grid` (xorshift).
    pub(crate) fn noise(grid: Grid) -> Vec<u16> {
        let n = grid.len();
        let mut x = 0x2545_f491_4f6c_dd1du64;
        (0..n)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                (x % 4096) as u16
            })
            .collect()
    }

    #[test]
    fn matches_brute_force_on_every_tet_of_a_16_cube() {
        let n = 16usize;
        let grid = Grid::new([n + 1; 3]);
        let samples = noise(grid);
        let vol = Volume::new(grid, &samples).unwrap();
        let l = Lattice::new(grid.dims).unwrap();
        let mut tets = 0;
        for d in all_diamonds(&l) {
            for t in d.tets(&l) {
                tets += 1;
                let got = scan_tet(&vol, &t);
                // Independent evaluation: f64 barycentric interpolation at brute-force points.
                let v = t.map(|p| p.as_dvec3());
                let inv = glam::DMat3::from_cols(v[1] - v[0], v[2] - v[0], v[3] - v[0]).inverse();
                let f = t.map(|p| vol.at(p.x as usize, p.y as usize, p.z as usize));
                let mut want = TetStats::EMPTY;
                for p in brute_force_points(&t) {
                    let l = inv * (p.as_dvec3() - v[0]);
                    let interp =
                        f[0] * (1.0 - l.element_sum()) + f[1] * l.x + f[2] * l.y + f[3] * l.z;
                    let s = vol.at(p.x as usize, p.y as usize, p.z as usize);
                    want = want.merge(TetStats {
                        error: (s - interp).abs(),
                        min: s,
                        max: s,
                    });
                }
                assert!(
                    (got.error - want.error).abs() <= 1e-9 * want.error.max(1.0),
                    "{t:?}: {got:?} vs {want:?}"
                );
                assert_eq!((got.min, got.max), (want.min, want.max), "{t:?}");
            }
        }
        assert!(tets > 1000);
    }

    /// Calls `f` with the volume, lattice and stencils of a noise volume of `dims`, for each diamond
    /// centred at a sample (its index) other than the root's corner.
    fn each_diamond(
        dims: [usize; 3],
        mut f: impl FnMut(&Volume<'_, u16>, &Lattice, &Stencils, Diamond, usize),
    ) {
        let grid = Grid {
            dims,
            origin: [0.0; 3],
            spacing: [1.0; 3],
        };
        let samples = noise(grid);
        let vol = Volume::new(grid, &samples).unwrap();
        let l = Lattice::new(grid.dims).unwrap();
        let stencils = Stencils::new(&grid);
        for i in 0..grid.len() {
            let [x, y, z] = grid.ijk(i);
            let d = Diamond::new(IVec3::new(x as i32, y as i32, z as i32));
            if d.center != IVec3::ZERO {
                f(&vol, &l, &stencils, d, i);
            }
        }
    }

    #[test]
    fn stencils_match_the_row_scan() {
        let mut checked = 0;
        each_diamond([33, 29, 31], |vol, l, stencils, d, _| {
            for t in d.tets(l) {
                if l.place(&t) != crate::lattice::Placement::Inside {
                    continue;
                }
                match stencils.error(vol, &t) {
                    Some(fast) => {
                        assert_eq!(fast, scan_tet(vol, &t).error, "{t:?}");
                        checked += 1;
                    }
                    None => assert!(!matches!(d.scale(), 2 | 4), "{d:?} has no stencil"),
                }
            }
        });
        assert!(checked > 10_000, "{checked}");
    }

    #[test]
    fn diamond_stencils_match_the_tets() {
        // Centres up to 64: every residue (c >> σ) mod 8 of scales 2 and 4, several times.
        let mut checked = 0;
        each_diamond([65, 61, 63], |vol, l, stencils, d, i| {
            let (lo, hi) = d.bounds();
            if !l.in_domain(lo) || !l.in_domain(hi) {
                return;
            }
            match stencils.diamond_error(vol, d, i) {
                Some(fast) => {
                    let by_tets = d
                        .tets(l)
                        .iter()
                        .fold(TetStats::EMPTY, |acc, t| acc.merge(scan_tet(vol, t)));
                    assert_eq!(fast, by_tets.error, "{d:?}");
                    checked += 1;
                }
                None => assert!(!matches!(d.scale(), 2 | 4), "{d:?} has no stencils"),
            }
        });
        assert!(checked > 20_000, "{checked}");
    }

    #[test]
    fn finest_diamonds_match_their_tets() {
        let n = 16usize;
        let grid = Grid::new([n + 1; 3]);
        let samples = noise(grid);
        let vol = Volume::new(grid, &samples).unwrap();
        let l = Lattice::new(grid.dims).unwrap();
        let stencils = Stencils::new(&grid);
        let mut checked = 0;
        for i in 0..grid.len() {
            let [x, y, z] = grid.ijk(i);
            let d = Diamond::new(IVec3::new(x as i32, y as i32, z as i32));
            if d.center == IVec3::ZERO || d.scale() != 1 {
                continue;
            }
            let (lo, hi) = d.bounds();
            if !l.in_domain(lo) || !l.in_domain(hi) {
                continue;
            }
            let by_tets = d
                .tets(&l)
                .iter()
                .fold(TetStats::EMPTY, |acc, t| acc.merge(scan_tet(&vol, t)));
            let fast = stencils.finest_diamond_error(&vol, d, i);
            assert_eq!(fast, by_tets.error, "{d:?}");
            checked += 1;
        }
        assert!(checked > 3000);
    }

    #[test]
    fn normal_components_are_powers_of_two() {
        let l = Lattice::new([33; 3]).unwrap();
        for d in all_diamonds(&l) {
            for t in d.tets(&l) {
                let p = Planes::new(&t);
                for n in p.normals {
                    for c in [n.x, n.y, n.z] {
                        assert!([0, 1, 2, 4].contains(&c.abs()), "{t:?}: {n:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn linear_field_has_exactly_zero_error() {
        let n = 32usize;
        let grid = Grid::new([n + 1; 3]);
        let samples: Vec<i16> = (0..grid.len())
            .map(|i| {
                let [x, y, z] = grid.ijk(i);
                (3 * x as i32 - 2 * y as i32 + 5 * z as i32 - 40) as i16
            })
            .collect();
        let vol = Volume::new(grid, &samples).unwrap();
        let l = Lattice::new(grid.dims).unwrap();
        for t in Diamond::root(&l).tets(&l) {
            let st = scan_tet(&vol, &t);
            assert_eq!(st.error, 0.0);
        }
    }
}
