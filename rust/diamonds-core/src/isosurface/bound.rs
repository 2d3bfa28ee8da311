//! The two-sided bound, by a check that refines until it holds (beyond Gregorski §6.2, whose
//! `ae / ‖∇T‖` only estimates the distance: the linear surface of a tetrahedron and the data's surface
//! can be farther apart than it says near the tetrahedron's faces, and a tetrahedron whose vertices
//! all lie on one side of the isovalue hides whatever its samples draw — a speck, a thin branch).
//!
//! Relative to the full-resolution surface `F` ([`super::fine`]) and for every isovalue, after the
//! refinement by the isosurface error, the surface `S` drawn from the carrier leaves is checked at
//! every point of both ([`Cover`]):
//! - every point of every triangle of `F` lies within the tolerance of `S`;
//! - every point of every triangle of `S` (the output's, [`super::fine::output_triangles`]) lies
//!   within the tolerance of `F`.
//!
//! A triangle of `S` is covered by the parts of its subdivision at [`triangle_samples`] spaced at
//! most half the tolerance, held between the smallest and the largest grid spacing
//! ([`Grid::sampling_step`]), a triangle of `F` (inside one grid cell) as it is; the
//! parts near the tolerance are cut further. Distances are certified cheaply where possible
//! ([`super::blocks`]): a sample of `S` within a block of a vertex of `F` is within the blocks'
//! reach of `F`, and a grid cell whose centre is within a block of a sample of `S` holds no point
//! of `F` beyond the tolerance (the reaches leave room for the parts' size, [`Reach`]). The rest
//! are measured exactly: points of `F` against the triangles of `S` near them, from an [`rstar`]
//! R-tree of them; points of `S` against the triangles of `F` in the grid cells around them that
//! `F` crosses ([`super::fine::cell_pieces`]; each rayon job keeps the last cells' in a
//! [`Recent`]). Every point that fails is a *violation*: the leaf holding it (found as the mesh's
//! walk finds it, through the tetrahedra straddling a far face of the domain, whose diamonds the
//! split set does not hold; a point on a far face is taken just inside it; the point is first
//! moved just inside the triangle it lies on, [`Violation::probes`]) is split — the
//! diamonds on the path from the leaf down to the tetrahedra around the point no larger than the
//! tolerance, or, when the leaf already is, down to the finest tetrahedra — with closure,
//! refinement continues from that mesh, and the check runs again. On the finest tetrahedra `S`
//! is `F`, so this ends; every round splits at least one more diamond (the check fails with
//! [`crate::Error::Uncertified`] if it has not ended after [`MAX_ROUNDS`]). A round after the first
//! checks only what the splits may have changed: the surface of the new carriers and of the
//! carriers that held a violation, and the cells of F within the tolerance of a carrier that was
//! split (the surface that certified them may be gone) or that held violations; everything else
//! was certified by surface that is still there, against the same `F`. (For a solid's surfaces,
//! whose sheets depend on the carriers across them, also what a change of sheets changed:
//! [`Extraction::sheets_changed`].)
//!
//! Both directions are checked against the tolerance less a millionth of the volume's diagonal (at
//! most half the tolerance), for rounding (points written in single precision). Points outside the
//! region of interest are not checked (the tolerance applies inside it).

use super::blocks::{bits, set_bit, Blocks};
use super::cover::{in_region, Cover, Known, Surface};
use super::error::{child_coordinates, tet_size2, IsoErrors, RootTets};
use super::fine::{cell_pieces, cell_triangles, output_triangles, vertices_from};
use super::marching::carries;
use super::{value, world};
use super::{Extraction, IsoQuery};
use crate::diamond::{child_of, Diamond};
use crate::geometry::{
    has_area, point_triangle_distance, sample_triangles, triangle_samples, triangle_tree, Triangle,
    TriangleTree,
};
use crate::hierarchy::piece::CellOwner;
use crate::lattice::{Placement, Tet};
use crate::mesh;
use crate::refine::{Refiner, SplitSet};
use crate::volume::{Grid, Sample, Volume};
use crate::{Error, Result};
use arrayvec::ArrayVec;
use glam::{DVec3, IVec3};
use rayon::prelude::*;
use rustc_hash::FxHashSet;
use std::cell::RefCell;
use std::sync::atomic::AtomicU64;

/// The full-resolution surface F of one isovalue as the check reads it.
struct Fine {
    /// The blocks around its vertices (inside the region of interest), of reach [`Reach::samples`].
    blocks: Option<Blocks>,
    /// The grid cells it crosses, a bit per lower corner (point index), and listed.
    crossed: Cells,
    cells: Vec<u32>,
}

/// The distances the check compares with.
#[derive(Clone, Copy)]
struct Reach {
    /// The tolerance less the rounding allowance.
    full: f64,
    /// How far apart the samples of `S`'s triangles are ([`Grid::sampling_step`] of `full`).
    /// Sampled at the smallest spacing whatever the tolerance, a grid of spacings 1, 1 and 0.01
    /// made every triangle 10⁴ times as many samples as at spacing 1, for the same surface.
    step: f64,
    /// The reach of the blocks of F's vertices, which certify the samples of `S`, leaving room for
    /// the parts between samples (at most `step` long, so within `step / √3` of a sample); none when
    /// there is no such room or the blocks would be finer than a dense bitset allows
    /// ([`Blocks::dense_reach`]; tolerances below about a voxel: every sample is measured).
    samples: Option<f64>,
    /// The reach of the blocks of `S`'s samples, which certify whole grid cells of F by their
    /// centres, leaving room for half a cell's diagonal `D` (every point of a cell lies within
    /// `D / 2` of its centre), and the corners of F's triangles (at most `D` long, so within
    /// `D / √3` of a corner: [`Known::within`]); none as above.
    cells: Option<f64>,
}

impl Reach {
    fn new(grid: &Grid, tolerance: f64) -> Self {
        let full = tolerance - (1e-6 * grid.diagonal()).min(0.5 * tolerance);
        let step = grid.sampling_step(full);
        let diagonal = DVec3::from(grid.spacing).length();
        let (lo, hi) = bounding_box(grid);
        let dense = Blocks::dense_reach(lo, hi);
        let room = |margin: f64| Some(full - margin).filter(|&r| r > 0.0 && r >= dense);
        Self {
            full,
            step,
            samples: room(step / 3f64.sqrt()),
            cells: room(diagonal / 2.0),
        }
    }
}

/// The grid's bounds, lower and upper corners.
fn bounding_box(grid: &Grid) -> (DVec3, DVec3) {
    let b = grid.bounds();
    (DVec3::new(b[0], b[2], b[4]), DVec3::new(b[1], b[3], b[5]))
}

/// Parts of triangles are cut down to `h / FLOOR` (`h` the smallest grid spacing) before a part
/// near the tolerance counts as a violation.
const FLOOR: f64 = 16.0;

/// How far (lattice units) a violation on a far face of the domain is moved inside to find its leaf.
const INSIDE: f64 = 1e-6;

/// How far (a fraction of the way) a violation is moved towards the centroid of its triangle to find
/// its leaf ([`Violation::probes`]).
const INTO_TRIANGLE: f64 = 1e-3;

/// A point that breaks the bound and the triangle it lies on: of F (in one finest tetrahedron) or
/// of the drawn surface (in one carrier leaf).
#[derive(Clone, Copy, Debug)]
struct Violation {
    point: DVec3,
    triangle: [DVec3; 3],
}

impl Violation {
    /// Where to look for the leaf to split, in order: the point moved [`INTO_TRIANGLE`] of the way
    /// to its triangle's centroid, then that point just off either side of the triangle's plane
    /// ([`INSIDE`] lattice units of the smallest spacing), then the point itself (whose first leaf
    /// found may be the only one not yet finest). The point itself may be a vertex, edge or
    /// face of several leaves — a point of F at a sample equal to the isovalue is a vertex of the
    /// finest tetrahedra — and the first leaf found holding it may hide nothing (a finest leaf
    /// beside the coarse one that hides the samples below the isovalue); inside its triangle it is
    /// inside the tetrahedron that draws the triangle, unless the triangle lies in a face of two
    /// tetrahedra (a plateau of samples at the isovalue), which the sides tell apart.
    fn probes(&self, h: f64) -> [DVec3; 4] {
        let [a, b, c] = self.triangle;
        let inside = self.point + INTO_TRIANGLE * ((a + b + c) / 3.0 - self.point);
        let off = (b - a).cross(c - a).normalize_or_zero() * (INSIDE * h);
        [inside, inside + off, inside - off, self.point]
    }
}

/// A violation with where the check found it, `[kind, position, sequence, item]`: a crossed cell
/// of F ([`CELL`], its position among the cells pending, the violation's place among the cell's,
/// the cell) or a triangle of S ([`TRIANGLE`], its position among the triangles checked, the
/// violation's place among the triangle's, its carrier's position among those checked). Every
/// piece of a partitioned check ([`Partition`]) lists the cells and triangles alike and checks
/// those it owns, so the keys of all pieces' violations order them as one check finds them.
type Keyed = ([u32; 4], Violation);

/// [`Keyed`] kinds, in the order the check lists them.
const CELL: u32 = 0;
const TRIANGLE: u32 = 1;

/// `found` at position `n` with its `item`, keyed ([`Keyed`]).
fn keyed(kind: u32, n: usize, item: u32, found: impl IntoIterator<Item = Violation>) -> Vec<Keyed> {
    (found.into_iter().enumerate())
        .map(|(seq, v)| ([kind, n as u32, seq as u32, item], v))
        .collect()
}

/// The carriers whose surface a round checks.
fn checked_carriers<'c>(carriers: &'c [Tet], pending: &'c Pending) -> &'c [Tet] {
    match pending {
        Pending::All => carriers,
        Pending::Some { carriers, .. } => carriers,
    }
}

/// The crossed cells of F that a round checks.
fn pending_cells<'f>(fine: &'f Fine, pending: &'f Pending) -> &'f [u32] {
    match pending {
        Pending::All => &fine.cells,
        Pending::Some { cells, .. } => cells,
    }
}

/// A check shared by the pieces of a distributed image, each holding the whole image: every piece
/// refines and lists as one check does, checks the triangles of the carriers it owns and the cells
/// it owns ([`CellOwner`]), and `exchange` gives it every piece's violations of the round, so all
/// pieces split the same diamonds as one check does.
pub struct Partition<'a> {
    pub(super) owner: CellOwner,
    exchange: &'a dyn Exchange,
}

/// How the pieces of a [`Partition`] share what each found: an all-gather of bytes. Every piece
/// calls it the same number of times, in the same order.
pub trait Exchange: Sync {
    /// Sends this piece's `bytes` and returns every piece's (its own included), in piece order.
    fn all_gather(&self, bytes: Vec<u8>) -> Result<Vec<Vec<u8>>>;
}

impl<'a> Partition<'a> {
    /// The partition of piece `owner`, with every piece's `exchange`.
    pub fn new(owner: CellOwner, exchange: &'a dyn Exchange) -> Self {
        Self { owner, exchange }
    }

    /// Every piece's `bytes` of the step `tag`: the exchange, with a check that every piece was at
    /// the same step (pieces whose states differ would otherwise read each other's bytes as
    /// something else).
    fn exchange(&self, tag: u8, bytes: Vec<u8>) -> Result<Vec<Vec<u8>>> {
        let mut tagged = Vec::with_capacity(bytes.len() + 1);
        tagged.push(tag);
        tagged.extend(bytes);
        (self.exchange.all_gather(tagged)?.into_iter())
            .map(|mut piece| match piece.first() {
                Some(&t) if t == tag => {
                    piece.remove(0);
                    Ok(piece)
                }
                _ => Err(Error::Parameter(
                    "the pieces exchanged different steps of the isosurface extraction".into(),
                )),
            })
            .collect()
    }

    /// Every piece's codes of `errors` ([`IsoErrors::raise`]), each piece having located the
    /// surface samples of the cells it owns.
    pub(super) fn share_errors(&self, errors: &mut IsoErrors) -> Result<()> {
        let mut bytes = Vec::new();
        for (i, code) in errors.reached_codes() {
            bytes.extend(i.to_le_bytes());
            bytes.extend(code.to_le_bytes());
        }
        let mut others = Vec::new();
        let pieces = self.exchange(ERRORS, bytes)?;
        // This piece's own codes are already there.
        for (_, piece) in (pieces.iter().enumerate()).filter(|&(k, _)| k != self.owner.me()) {
            if piece.len() % 6 != 0 {
                return Err(Error::Parameter(
                    "a piece sent a truncated list of errors".into(),
                ));
            }
            others.extend(piece.chunks_exact(6).map(|c| {
                let i = u32::from_le_bytes(c[..4].try_into().expect("4 bytes"));
                (i, u16::from_le_bytes(c[4..].try_into().expect("2 bytes")))
            }));
        }
        errors.raise(others)
    }

    /// Every piece's violations of a round (per isovalue), from this piece's `found`.
    fn all(&self, found: Vec<Vec<Keyed>>) -> Result<Vec<Vec<Keyed>>> {
        let mut bytes = Vec::new();
        for list in &found {
            bytes.extend((list.len() as u64).to_le_bytes());
            for (key, v) in list {
                key.iter().for_each(|k| bytes.extend(k.to_le_bytes()));
                let coordinates = v.point.to_array().into_iter();
                let coordinates = coordinates.chain(v.triangle.iter().flat_map(|p| p.to_array()));
                coordinates.for_each(|c| bytes.extend(c.to_le_bytes()));
            }
        }
        let pieces = self.exchange(VIOLATIONS, bytes)?;
        let mut all: Vec<Vec<Keyed>> = found.iter().map(|_| Vec::new()).collect();
        for piece in pieces {
            let mut at = piece.as_slice();
            let mut take = |n: usize| -> Result<&[u8]> {
                if at.len() < n {
                    return Err(Error::Parameter(
                        "a piece sent a truncated list of violations".into(),
                    ));
                }
                let (head, rest) = at.split_at(n);
                at = rest;
                Ok(head)
            };
            for list in &mut all {
                let n = u64::from_le_bytes(take(8)?.try_into().expect("8 bytes"));
                for _ in 0..n {
                    let mut key = [0u32; 4];
                    for k in &mut key {
                        *k = u32::from_le_bytes(take(4)?.try_into().expect("4 bytes"));
                    }
                    let mut c = [0f64; 12];
                    for x in &mut c {
                        *x = f64::from_le_bytes(take(8)?.try_into().expect("8 bytes"));
                    }
                    let p = |i: usize| DVec3::new(c[i], c[i + 1], c[i + 2]);
                    list.push((
                        key,
                        Violation {
                            point: p(0),
                            triangle: [p(3), p(6), p(9)],
                        },
                    ));
                }
            }
        }
        Ok(all)
    }
}

/// What a [`Partition`]'s exchange carries: the errors' codes, a round's violations.
const ERRORS: u8 = 0;
pub(super) const VIOLATIONS: u8 = 1;

/// Rounds of checking and splitting at most (each splits at least one diamond; in practice a few).
const MAX_ROUNDS: usize = 64;

impl<T: Sample> Extraction<'_, '_, T> {
    /// `split` (refined for `query` at `tolerance` > 0 with `criterion`) refined further until its
    /// surface meets the two-sided bound, and its leaves that carry the surface. With `solid` the
    /// surfaces are those of a solid (an interval volume's bounding surfaces): faces that bound no
    /// volume ([`sheets`]) are no part of them. `certified`: the carriers of a split
    /// set that `split` refines, where the surface met the bound; then only what the splits since
    /// may have changed is checked, as in a round after the first (see [`Pending`]).
    pub(super) fn certify(
        &self,
        query: &IsoQuery,
        tolerance: f64,
        mut split: SplitSet,
        criterion: impl Fn(Diamond) -> f64,
        solid: bool,
        certified: Option<&[Tet]>,
    ) -> Result<(SplitSet, Vec<Tet>)> {
        let isovalues = &query.isovalues;
        let mut carriers = self.carriers_of(isovalues, &split)?;
        let grid = &self.volume.grid;
        let reach = Reach::new(grid, tolerance);
        let inside = |p: DVec3| in_region(query.region_of_interest, p);
        // F, per isovalue, once.
        let (lo, hi) = bounding_box(grid);
        let fine = isovalues
            .iter()
            .map(|&v| {
                let cells = self.cache.bricks.cells_crossed(self.volume, v);
                let points = super::error::corners_of(grid.dims, &cells);
                let mut vertices = vertices_from(self.volume, v, &points);
                vertices.retain(|&p| inside(p));
                let blocks = (reach.samples)
                    .map(|r| Blocks::around(lo, hi, r, vertices.par_iter().copied()))
                    .transpose()?;
                let crossed = bits(grid.len());
                cells.par_iter().for_each(|&c| {
                    set_bit(&crossed, c as usize);
                });
                let crossed = Cells::from(crossed);
                Ok(Fine {
                    blocks,
                    crossed,
                    cells,
                })
            })
            .collect::<Result<Vec<Fine>>>()?;
        // What each round checks, per isovalue: the first everything, or what the splits since
        // `certified` may have changed; then what the splits of the round before may have changed
        // (see `Pending`).
        let mut pending: Vec<Pending> = match certified {
            None => fine.iter().map(|_| Pending::All).collect(),
            Some(before) => {
                let (before, now): (FxHashSet<Tet>, FxHashSet<Tet>) = rayon::join(
                    || before.iter().copied().collect(),
                    || carriers.iter().copied().collect(),
                );
                let removed: Vec<Tet> = (before.iter())
                    .filter(|t| !now.contains(*t))
                    .copied()
                    .collect();
                let near_removed = NearBoxes::new(grid, &removed, reach.full);
                let new: Vec<Tet> = (carriers.iter())
                    .filter(|t| !before.contains(*t))
                    .copied()
                    .collect();
                (fine.iter())
                    .map(|fine| Pending::Some {
                        carriers: new.clone(),
                        cells: (fine.cells.par_iter().copied())
                            .filter(|&c| {
                                near_removed
                                    .has(IVec3::from(grid.ijk(c as usize).map(|c| c as i32)))
                            })
                            .collect(),
                    })
                    .collect()
            }
        };
        // Solid surfaces: the sheets of the surface the pending checks start from, per isovalue.
        let mut last_sheets: Vec<Option<Sheets>> = match certified {
            Some(before) if solid => (isovalues.iter())
                .map(|&v| Some(sheets(self.volume, before, v)))
                .collect(),
            _ => isovalues.iter().map(|_| None).collect(),
        };
        for _ in 0..MAX_ROUNDS {
            let mut found_by_value = Vec::with_capacity(isovalues.len());
            for (((&v, fine), pending), last) in (isovalues.iter().zip(&fine))
                .zip(&mut pending)
                .zip(&mut last_sheets)
            {
                let sheets = if solid {
                    let now = sheets(self.volume, &carriers, v);
                    if let Some(before) = last.replace(now.clone()) {
                        let crossed = &fine.cells;
                        self.sheets_changed(v, (&before, &now), &carriers, crossed, pending, reach);
                    }
                    now
                } else {
                    Sheets::default()
                };
                let found = self.violations(
                    v,
                    (&carriers, &sheets),
                    fine,
                    pending,
                    reach,
                    query.region_of_interest,
                )?;
                found_by_value.push(found);
            }
            if let Some(partition) = self.partition {
                found_by_value = partition.all(found_by_value)?;
            }
            let far: Vec<Far> = (found_by_value.into_iter().zip(&pending))
                .map(|(found, pending)| Self::far(found, checked_carriers(&carriers, pending)))
                .collect();
            if far.iter().all(|f| f.points.is_empty()) {
                return Ok((split, carriers));
            }
            // Cubes of side `reach / (2√3)`: the splits a violation causes cover its neighbours in
            // its cube.
            let side = reach.full / (2.0 * 3f64.sqrt());
            let cube = |p: DVec3| ((p - lo) / side).floor().as_i64vec3().to_array();
            let violations = far.iter().map(|f| &f.points[..]);
            let forced = self.forced(&split, violations, tolerance, cube);
            if forced.is_empty() {
                // Every violation lies in a leaf of the finest tetrahedra, where the surface is F's
                // but for pieces of zero area (an isovalue equal to a sample's: points and edges of
                // {f = v}, which the surface draws only where it keeps coinciding points).
                return Ok((split, carriers));
            }
            let (removed, kept);
            (split, carriers, removed, kept) =
                self.force(isovalues, split, carriers, &forced, &criterion, tolerance);
            let near_removed = NearBoxes::new(grid, &removed, reach.full);
            let gone: FxHashSet<Tet> = removed.into_iter().collect();
            pending = (far.into_iter().zip(&fine))
                .map(|(far, fine)| {
                    let mut again = carriers[kept..].to_vec();
                    again.extend(far.carriers.into_iter().filter(|t| !gone.contains(t)));
                    let mut cells: Vec<u32> = (fine.cells.par_iter().copied())
                        .filter(|&c| {
                            near_removed.has(IVec3::from(grid.ijk(c as usize).map(|c| c as i32)))
                        })
                        .collect();
                    cells.extend(far.cells);
                    cells.sort_unstable();
                    cells.dedup();
                    Pending::Some {
                        carriers: again,
                        cells,
                    }
                })
                .collect();
        }
        Err(Error::Uncertified(format!(
            "still failing after {MAX_ROUNDS} rounds of splits"
        )))
    }
}

impl<T: Sample> Extraction<'_, '_, T> {
    /// [`Extraction::certify`] for the bounding surfaces of the solid `{α ≤ f ≤ β}` (`range`, the
    /// isovalues of `query`). The surface of α bounds `{f ≥ α}` as marching tetrahedra draw it,
    /// but the surface of β must bound `{f ≤ β}`: the surface of `−f` at `−β`
    /// ([`Volume::negated`]). The two differ where samples equal β, since marching tetrahedra count
    /// samples at the isovalue as above: at a plateau of samples at β next to samples above it,
    /// the surface of β runs along the plateau's low side, inside the solid, while the solid ends
    /// at its high side (a level just above β instead would draw specks around single samples at
    /// β that the solid does not hold). Without samples at β both surfaces are checked together;
    /// with them each is checked on its own in turn, until a check splits nothing: every check
    /// ends on a split set where its surface meets the bound, so then both do.
    pub(super) fn certify_solid(
        &self,
        query: &IsoQuery,
        [alpha, beta]: [f64; 2],
        tolerance: f64,
        mut split: SplitSet,
        criterion: &dyn Fn(Diamond) -> f64,
    ) -> Result<(SplitSet, Vec<Tet>)> {
        let ties = (self.volume.samples.par_iter()).any(|s| s.to_f64() == beta);
        if !ties {
            return self.certify(query, tolerance, split, criterion, true, None);
        }
        let negated = self.volume.negated();
        let cache = self.cache.negated();
        let below = Extraction {
            hierarchy: self.hierarchy,
            volume: &negated,
            cache: &cache,
            partition: self.partition,
        };
        let level = |v: f64| IsoQuery {
            isovalues: vec![v],
            ..query.clone()
        };
        let (upper, lower) = (level(alpha), level(-beta));
        // The carriers of each surface where it last met the bound.
        let mut certified: [Option<Vec<Tet>>; 2] = [None, None];
        for round in 0..MAX_ROUNDS {
            let before = split.len();
            let last = certified[round % 2].as_deref();
            let carriers;
            (split, carriers) = if round % 2 == 0 {
                self.certify(&upper, tolerance, split, criterion, true, last)?
            } else {
                below.certify(&lower, tolerance, split, criterion, true, last)?
            };
            certified[round % 2] = Some(carriers);
            if round > 0 && split.len() == before {
                let mut carriers = self.carriers_of(&upper.isovalues, &split)?;
                carriers.extend(below.carriers_of(&lower.isovalues, &split)?);
                carriers.par_sort_unstable_by_key(|t| t.map(|p| p.to_array()));
                carriers.dedup();
                return Ok((split, carriers));
            }
        }
        Err(Error::Uncertified(format!(
            "the two bounding surfaces still failing in turn after {MAX_ROUNDS} checks"
        )))
    }
}

/// What a round of the check looks at for one isovalue. A point certified in a round stays
/// certified while the surface that certified it is there: splits remove the surface of the
/// carriers they split only, and F does not change.
enum Pending {
    /// Every triangle of the surface and every crossed cell of F (the first round).
    All,
    /// After splits: the triangles of the surface of `carriers` (the new carriers, and the old ones
    /// that held a violation and were not split) and the crossed cells `cells` (those within the
    /// reach of a carrier that was split, whose surface may have certified them, and those that
    /// held violations).
    Some { carriers: Vec<Tet>, cells: Vec<u32> },
}

/// The violations of one round for one isovalue.
struct Far {
    /// Every violating point (world).
    points: Vec<Violation>,
    /// The carriers whose surface holds a violating point.
    carriers: Vec<Tet>,
    /// The crossed cells whose part of F holds a violating point.
    cells: Vec<u32>,
}

/// F as the surface the points of `S` are measured against: its pieces are the polygons of the
/// finest tetrahedra, a grid cell's (lower corner's point index) `k`-th ([`super::fine::cell_tets`]).
struct FineSurface<'v, 'a, T: Sample> {
    volume: &'v Volume<'a, T>,
    v: f64,
    crossed: &'v Cells,
    /// The pieces of the cells visited last (one surface per rayon job: see [`Recent`]).
    recent: RefCell<Recent>,
}

/// The pieces of F in one grid cell ([`cell_pieces`]).
type Pieces = ArrayVec<(u8, [DVec3; 3]), 12>;

/// The pieces of the grid cells visited last, by cell (direct-mapped, `RECENT` slots): the samples
/// of a triangle of `S` and of its neighbours look at the same cells of F, which would otherwise be
/// cut by marching tetrahedra again at every look.
#[derive(Default)]
struct Recent {
    /// (cell, its pieces), `u32::MAX` for none; allocated at the first look.
    slots: Vec<(u32, Pieces)>,
}

/// Slots of [`Recent`] (a power of two).
const RECENT: usize = 64;

impl<T: Sample> FineSurface<'_, '_, T> {
    /// `read` applied to the pieces of F in the crossed grid cell `i` (lower corner's point index;
    /// coordinates `c`); `read` must not look at the surface again.
    fn with_pieces<R>(&self, i: u32, c: IVec3, read: impl FnOnce(&Pieces) -> R) -> R {
        let mut recent = self.recent.borrow_mut();
        if recent.slots.is_empty() {
            recent.slots = vec![(u32::MAX, Pieces::new()); RECENT];
        }
        // Fibonacci hashing: cells one row or one slice apart get different slots.
        let slot = (i.wrapping_mul(0x9E37_79B9) >> (32 - RECENT.trailing_zeros())) as usize;
        let entry = &mut recent.slots[slot];
        if entry.0 != i {
            *entry = (i, cell_pieces(self.volume, c, self.v));
        }
        read(&entry.1)
    }

    /// Calls `visit` with each crossed grid cell (lower corner's point index and coordinates) of
    /// the box of cells `lo..=up` (clamped to the grid) within `reach` of `p`, and the distance
    /// from `p` to the cell, while it returns true.
    fn cells(
        &self,
        p: DVec3,
        (lo, up): (IVec3, IVec3),
        reach: f64,
        mut visit: impl FnMut(u32, IVec3, f64) -> bool,
    ) -> bool {
        let grid = &self.volume.grid;
        let (origin, spacing) = (DVec3::from(grid.origin), DVec3::from(grid.spacing));
        let hi = IVec3::from(grid.dims.map(|d| d as i32 - 2));
        let (lo, up) = (lo.max(IVec3::ZERO), up.min(hi));
        for z in lo.z..=up.z {
            for y in lo.y..=up.y {
                for x in lo.x..=up.x {
                    let c = IVec3::new(x, y, z);
                    let i = grid.index(x as usize, y as usize, z as usize);
                    if !self.crossed.has(i) {
                        continue;
                    }
                    let low = origin + c.as_dvec3() * spacing;
                    let gap = (low - p).max(p - low - spacing).max(DVec3::ZERO).length();
                    if gap <= reach && !visit(i as u32, c, gap) {
                        return false;
                    }
                }
            }
        }
        true
    }

    /// The box of the grid cells around the one holding `p`, `r` (world) in every direction.
    fn around(&self, p: DVec3, r: f64) -> (IVec3, IVec3) {
        let grid = &self.volume.grid;
        let (origin, spacing) = (DVec3::from(grid.origin), DVec3::from(grid.spacing));
        let cell = |p: DVec3| ((p - origin) / spacing).floor().as_ivec3();
        (cell(p - r), cell(p + r))
    }
}

impl<T: Sample> Surface for FineSurface<'_, '_, T> {
    type Piece = (u32, u8);

    fn nearest(&self, p: DVec3, enough: f64, reach: f64) -> (f64, Option<(u32, u8)>) {
        // The crossed cells next to p's first, then those within the best distance so far,
        // skipping cells farther than it; done at a piece within `enough`.
        let best = std::cell::Cell::new((f64::INFINITY, None));
        let visit = |i: u32, c: IVec3, gap: f64| {
            if gap < best.get().0 {
                self.with_pieces(i, c, |pieces| {
                    for &(k, t) in pieces {
                        let d = point_triangle_distance(p, t);
                        if d < best.get().0 {
                            best.set((d, Some((i, k))));
                        }
                    }
                });
            }
            best.get().0 > enough
        };
        let next = self.around(p, 0.0);
        if self.cells(p, (next.0 - IVec3::ONE, next.1 + IVec3::ONE), reach, visit) {
            let r = best.get().0.min(reach);
            self.cells(p, self.around(p, r), r, visit);
        }
        let (d, piece) = best.get();
        (d, piece.filter(|_| d <= reach))
    }

    fn distance_to(&self, (cell, k): (u32, u8), p: DVec3) -> f64 {
        let c = IVec3::from(self.volume.grid.ijk(cell as usize).map(|c| c as i32));
        self.with_pieces(cell, c, |pieces| {
            (pieces.iter())
                .filter(|&&(piece, _)| piece == k)
                .map(|&(_, t)| point_triangle_distance(p, t))
                .fold(f64::INFINITY, f64::min)
        })
    }

    fn any_piece(&self, p: DVec3, reach: f64, test: &mut dyn FnMut((u32, u8)) -> bool) -> bool {
        !self.cells(p, self.around(p, reach), reach, |i, c, _| {
            // (A copy: `test` measures pieces again.)
            let pieces = self.with_pieces(i, c, Pieces::clone);
            let mut pieces = pieces.into_iter().peekable();
            while let Some((k, t)) = pieces.next() {
                // A piece's triangles are consecutive: the piece is near when one of them is.
                let mut near = point_triangle_distance(p, t) <= reach;
                while let Some(&(_, t)) = pieces.peek().filter(|(next, _)| *next == k) {
                    near |= point_triangle_distance(p, t) <= reach;
                    pieces.next();
                }
                if near && test((i, k)) {
                    return false;
                }
            }
            true
        })
    }
}

/// The drawn surface `S` as the surface the points of F are measured against: its triangles with
/// their carriers' numbers (each carrier's together), in an R-tree; its pieces are the carriers'
/// polygons, named by one of their triangles.
struct Drawn {
    triangles: Vec<([DVec3; 3], u32)>,
    tree: TriangleTree,
}

impl Surface for Drawn {
    type Piece = u32;

    fn nearest(&self, p: DVec3, enough: f64, reach: f64) -> (f64, Option<u32>) {
        let within = |r: f64| self.tree.locate_within_distance(p.to_array(), r * r);
        let measure = |t: &Triangle| (point_triangle_distance(p, t.corners), t.id);
        let found = (Some(enough).filter(|&e| e >= 0.0))
            .and_then(|e| within(e).next().map(measure))
            .or_else(|| {
                within(reach)
                    .map(measure)
                    .min_by(|a, b| a.0.total_cmp(&b.0))
            });
        found.map_or((f64::INFINITY, None), |(d, id)| (d, Some(id)))
    }

    fn distance_to(&self, piece: u32, p: DVec3) -> f64 {
        let i = piece as usize;
        let owner = self.triangles[i].1;
        (i.saturating_sub(1)..(i + 2).min(self.triangles.len()))
            .filter(|&j| self.triangles[j].1 == owner)
            .map(|j| point_triangle_distance(p, self.triangles[j].0))
            .fold(f64::INFINITY, f64::min)
    }

    fn any_piece(&self, p: DVec3, reach: f64, test: &mut dyn FnMut(u32) -> bool) -> bool {
        (self
            .tree
            .locate_within_distance(p.to_array(), reach * reach))
        .any(|t| test(t.id))
    }
}

/// Grid cells marked in a bitset (a bit per lower corner's point index).
struct Cells {
    bits: Vec<u64>,
}

impl From<Vec<AtomicU64>> for Cells {
    fn from(marked: Vec<AtomicU64>) -> Self {
        Self {
            bits: marked.into_iter().map(AtomicU64::into_inner).collect(),
        }
    }
}

impl Cells {
    /// Is the cell with lower corner `i` (point index) marked?
    fn has(&self, i: usize) -> bool {
        self.bits[i / 64] & (1 << (i % 64)) != 0
    }
}

/// Blocks of grid cells, each longer than `reach` along every axis, marked around a set of
/// cells: a block is marked when it holds one of the cells or neighbours a block that does, so
/// every point within `reach` of one of the cells lies in a marked block (a superset, whatever the
/// reach, at 27 blocks per cell).
struct Around {
    /// Grid cells per block along each axis.
    per: IVec3,
    /// Blocks along each axis.
    dims: IVec3,
    blocks: Cells,
}

impl Around {
    fn new(grid: &Grid, cells: &[u32], reach: f64) -> Self {
        // Longer than the reach, so that a point at exactly the reach is in a marked block too.
        let per = (reach / DVec3::from(grid.spacing)).floor().as_ivec3() + IVec3::ONE;
        let dims = (IVec3::from(grid.dims.map(|d| d as i32 - 1)) + per - IVec3::ONE) / per;
        let marked = bits(dims.element_product() as usize);
        cells.par_iter().for_each(|&c| {
            let b = IVec3::from(grid.ijk(c as usize).map(|c| c as i32)) / per;
            let lo = (b - IVec3::ONE).max(IVec3::ZERO);
            let up = (b + IVec3::ONE).min(dims - IVec3::ONE);
            for z in lo.z..=up.z {
                for y in lo.y..=up.y {
                    for x in lo.x..=up.x {
                        set_bit(&marked, ((z * dims.y + y) * dims.x + x) as usize);
                    }
                }
            }
        });
        Self {
            per,
            dims,
            blocks: Cells::from(marked),
        }
    }

    /// Does the box `[lo, up]` (grid units) meet a marked block?
    fn meets(&self, grid: &Grid, lo: DVec3, up: DVec3) -> bool {
        let (lo, up) = cell_range(grid, lo, up);
        let (lo, up) = (lo / self.per, up / self.per);
        (lo.z..=up.z).any(|z| {
            (lo.y..=up.y).any(|y| {
                (lo.x..=up.x)
                    .any(|x| (self.blocks).has(((z * self.dims.y + y) * self.dims.x + x) as usize))
            })
        })
    }
}

/// The grid cells within a distance of the bounding box of one of a set of tetrahedra: each box,
/// grown by the distance, as its range of cells, listed in the blocks of cells (longer than the
/// distance, as [`Around`]'s, and at least 8 cells) that the range meets. A cell is tested against the ranges of its
/// block only, so building and asking cost the blocks a range meets and the ranges per block, not
/// the cells of every range (a reach³ per tetrahedron at tolerances of tens of cells).
struct NearBoxes {
    /// Grid cells per block along each axis.
    per: IVec3,
    /// Blocks along each axis.
    dims: IVec3,
    /// The ranges (lowest and highest cell) meeting block `b`: `ranges[starts[b]..starts[b + 1]]`.
    starts: Vec<u32>,
    ranges: Vec<(IVec3, IVec3)>,
}

impl NearBoxes {
    fn new(grid: &Grid, tets: &[Tet], reach: f64) -> Self {
        // At least 8 cells per axis: below a voxel of reach, blocks of single cells would make
        // `starts` 4 bytes per cell of the grid.
        let per = ((reach / DVec3::from(grid.spacing)).floor().as_ivec3() + IVec3::ONE)
            .max(IVec3::splat(8));
        let dims = (IVec3::from(grid.dims.map(|d| d as i32 - 1)) + per - IVec3::ONE) / per;
        let margin = reach / DVec3::from(grid.spacing);
        let boxes: Vec<(IVec3, IVec3)> = (tets.iter())
            .map(|t| {
                let lo = t[0].min(t[1]).min(t[2].min(t[3])).as_dvec3() - margin;
                let up = t[0].max(t[1]).max(t[2].max(t[3])).as_dvec3() + margin;
                cell_range(grid, lo, up)
            })
            .collect();
        let blocks_of = |&(lo, up): &(IVec3, IVec3)| {
            let (lo, up) = (lo / per, up / per);
            (lo.z..=up.z).flat_map(move |z| {
                (lo.y..=up.y)
                    .flat_map(move |y| (lo.x..=up.x).map(move |x| (z * dims.y + y) * dims.x + x))
            })
        };
        // Counting sort of (block, range) by block.
        let mut starts = vec![0u32; dims.element_product() as usize + 1];
        for b in boxes.iter().flat_map(blocks_of) {
            starts[b as usize + 1] += 1;
        }
        for b in 1..starts.len() {
            starts[b] += starts[b - 1];
        }
        let mut next = starts.clone();
        let mut ranges = vec![(IVec3::ZERO, IVec3::ZERO); starts[starts.len() - 1] as usize];
        for range in &boxes {
            for b in blocks_of(range) {
                ranges[next[b as usize] as usize] = *range;
                next[b as usize] += 1;
            }
        }
        Self {
            per,
            dims,
            starts,
            ranges,
        }
    }

    /// Is the grid cell `c` (lower corner) in one of the grown boxes?
    fn has(&self, c: IVec3) -> bool {
        let b = c / self.per;
        let b = ((b.z * self.dims.y + b.y) * self.dims.x + b.x) as usize;
        let (from, to) = (self.starts[b] as usize, self.starts[b + 1] as usize);
        (self.ranges[from..to])
            .iter()
            .any(|&(lo, up)| c.cmpge(lo).all() && c.cmple(up).all())
    }
}

/// The grid cells (lower corners) holding points of the box `[lo, up]` (grid units), clamped to
/// the grid: the lowest and the highest.
fn cell_range(grid: &Grid, lo: DVec3, up: DVec3) -> (IVec3, IVec3) {
    let hi = IVec3::from(grid.dims.map(|d| d as i32 - 2));
    (
        lo.floor().as_ivec3().max(IVec3::ZERO),
        up.floor().as_ivec3().min(hi),
    )
}

/// The surface of the carriers `tets` for isovalue `v` as the output draws it (the fan of each
/// polygon from its first corner), each triangle with its carrier's position in `tets`, each
/// carrier's together. Any triangulation of a polygon covers the same points; the samples of the
/// check's first cheap pass are those of the output's triangles.
fn drawn_triangles<'t, T: Sample>(
    volume: &'t Volume<'_, T>,
    v: f64,
    tets: &'t [Tet],
    sheets: &'t Sheets,
) -> impl ParallelIterator<Item = ([DVec3; 3], u32)> + 't {
    (tets.par_iter().enumerate()).flat_map_iter(move |(k, t)| {
        let sheet =
            !sheets.is_empty() && face_at(volume, t, v).is_some_and(|f| sheets.contains(&f));
        let drawn = if sheet {
            ArrayVec::new()
        } else {
            let corners = t.map(|q| world(volume, q));
            output_triangles(t, corners, t.map(|q| value(volume, q)), v)
        };
        drawn
            .into_iter()
            .filter(has_area)
            .map(move |t| (t, k as u32))
    })
}

/// A face of the lattice: its corners, sorted.
type Face = [[i32; 3]; 3];

/// The faces of carriers that bound no volume (*sheets*, [`sheets`]), for a surface that bounds a
/// solid.
type Sheets = FxHashSet<Face>;

/// The face of `t` whose three corners are at `v`, the fourth not: the one triangle marching
/// tetrahedra draw in `t` when the fourth is below `v`.
fn face_at<T: Sample>(volume: &Volume<'_, T>, t: &Tet, v: f64) -> Option<Face> {
    let at = t.map(|q| value(volume, q) == v);
    (at.iter().filter(|&&a| a).count() == 3).then(|| {
        let mut face: Vec<[i32; 3]> = (0..4).filter(|&i| at[i]).map(|i| t[i].to_array()).collect();
        face.sort_unstable();
        [face[0], face[1], face[2]]
    })
}

/// The faces at `v` that bound no volume (*sheets*): those that two of `carriers` draw, one from
/// each side, and those that one draws lying on the image's bounds (the solid `{f ≥ v}` is only
/// that face there, and an interval volume's tetrahedra hold none of it). Where the surfaces bound
/// a solid, they are no part of it: the full-resolution surface near them must be drawn by
/// carriers with volume.
fn sheets<T: Sample>(volume: &Volume<'_, T>, carriers: &[Tet], v: f64) -> Sheets {
    let hi = volume.grid.dims.map(|d| d as i32 - 1);
    let on_the_bounds =
        |f: &Face| (0..3).any(|a| f.iter().all(|p| p[a] == 0) || f.iter().all(|p| p[a] == hi[a]));
    let mut faces: Vec<Face> = (carriers.par_iter())
        .filter_map(|t| face_at(volume, t, v))
        .collect();
    faces.par_sort_unstable();
    faces
        .chunk_by(|a, b| a == b)
        .filter(|g| g.len() == 2 || on_the_bounds(&g[0]))
        .map(|g| g[0])
        .collect()
}

impl<T: Sample> Extraction<'_, '_, T> {
    /// Adds to `pending` what a change of the sheets at `v` from `before` to `now` changed on a
    /// solid's surface, beyond the carriers that splits removed or made: a kept carrier draws a
    /// face again when the tetrahedron across it no longer draws it (a split moved the fourth
    /// vertex's side), and stops drawing it when the one across it starts to. The carriers that
    /// draw a face that is no longer a sheet are checked again (their surface grew), and the cells
    /// among F's `crossed` within the reach of a face that became one (the surface that certified
    /// them may be gone).
    fn sheets_changed(
        &self,
        v: f64,
        (before, now): (&Sheets, &Sheets),
        carriers: &[Tet],
        crossed: &[u32],
        pending: &mut Pending,
        reach: Reach,
    ) {
        let Pending::Some {
            carriers: again,
            cells,
        } = pending
        else {
            return;
        };
        let drawn: Sheets = before.difference(now).copied().collect();
        if !drawn.is_empty() {
            let known: FxHashSet<Tet> = again.iter().copied().collect();
            again.extend((carriers.iter()).filter(|t| {
                !known.contains(*t)
                    && face_at(self.volume, t, v).is_some_and(|f| drawn.contains(&f))
            }));
        }
        let gone: Vec<Tet> = (now.difference(before))
            .map(|f| f.map(IVec3::from))
            .map(|[a, b, c]| [a, b, c, c])
            .collect();
        if !gone.is_empty() {
            let grid = &self.volume.grid;
            let near = NearBoxes::new(grid, &gone, reach.full);
            cells.par_extend(
                (crossed.par_iter().copied())
                    .filter(|&c| near.has(IVec3::from(grid.ijk(c as usize).map(|c| c as i32)))),
            );
            cells.sort_unstable();
            cells.dedup();
        }
    }

    /// The points that break the bound for isovalue `v` on the surface of `carriers`, among those
    /// `pending` names: points of F's triangles in the pending cells of `fine` farther than `reach`
    /// from the surface, points of the pending surface farther than `reach` from F ([`Cover`]);
    /// keyed ([`Keyed`]), in the order of their keys. With a [`Partition`], only in the cells and
    /// the carriers' triangles this piece owns.
    fn violations(
        &self,
        v: f64,
        (carriers, sheets): (&[Tet], &Sheets),
        fine: &Fine,
        pending: &Pending,
        reach: Reach,
        region: Option<[f64; 6]>,
    ) -> Result<Vec<Keyed>> {
        let owner = self.partition.map(|p| &p.owner);
        let volume = self.volume;
        let grid = &volume.grid;
        let (h, step) = (
            grid.spacing.into_iter().fold(f64::INFINITY, f64::min),
            reach.step,
        );
        let checked = checked_carriers(carriers, pending);
        let checked_triangles: Vec<([DVec3; 3], u32)> =
            drawn_triangles(volume, v, checked, sheets).collect();
        // S → F: each triangle's samples spaced at most `step` (the cheap certificate from the blocks
        // of F's vertices), then the parts of the triangles between them covered.
        let fine_surface = || FineSurface {
            volume,
            v,
            crossed: &fine.crossed,
            recent: RefCell::default(),
        };
        let near_fine = |p: DVec3| match &fine.blocks {
            Some(blocks) if blocks.near(p) => Known::within(blocks.reach()),
            _ => Known::UNKNOWN,
        };
        let s_to_f = || -> Vec<Keyed> {
            // Indexed (no filter before `map_init`): each rayon job keeps one surface, whose
            // cache of F's recent cells serves neighbouring triangles (filtered first, the
            // iterator is unindexed and splits into far more jobs: the extraction took 45 %
            // longer on bonsai).
            (checked_triangles.par_iter().enumerate())
                .map_init(fine_surface, |surface, (n, &(t, k))| {
                    if owner.is_some_and(|o| !o.owns(&checked[k as usize])) {
                        return Vec::new(); // another piece's
                    }
                    // Most triangles lie well within the reach: their samples near the blocks settle
                    // every part.
                    if fine.blocks.is_some()
                        && triangle_samples(t, step).all(|p| near_fine(p).d < f64::INFINITY)
                    {
                        return Vec::new();
                    }
                    let samples: Vec<DVec3> = triangle_samples(t, step).collect();
                    let mut known: Vec<_> = samples.iter().map(|&p| near_fine(p)).collect();
                    let to_fine = Cover {
                        surface: &*surface,
                        reach: reach.full,
                        floor: h / FLOOR,
                        region,
                    };
                    let mut far = Vec::new();
                    for [a, b, c] in sample_triangles(samples.len()) {
                        let mut k3 = [known[a], known[b], known[c]];
                        let found =
                            to_fine.violation([samples[a], samples[b], samples[c]], &mut k3);
                        [known[a], known[b], known[c]] = k3;
                        far.extend(found.map(|point| Violation { point, triangle: t }));
                    }
                    keyed(TRIANGLE, n, k, far)
                })
                .flatten_iter()
                .collect()
        };
        // The first round without the cell certificate measures every crossed cell of F against
        // the whole surface: its R-tree is built (sequentially) while S → F runs.
        let whole_tree = matches!(pending, Pending::All) && reach.cells.is_none();
        let (far_samples, tree) = rayon::join(s_to_f, || {
            whole_tree.then(|| triangle_tree(checked_triangles.iter().map(|&(t, _)| t)))
        });
        // F → S: the crossed cells pending whose centre lies near a block of the checked
        // surface's samples are within `reach` of it; each triangle of F in the others is covered
        // against the whole surface (an R-tree of its triangles).
        let with_samples = (reach.cells)
            .map(|r| {
                let (lo, hi) = bounding_box(grid);
                let samples = (checked_triangles.par_iter())
                    .flat_map_iter(|&(t, _)| triangle_samples(t, step));
                Blocks::around(lo, hi, r, samples)
            })
            .transpose()?;
        let near_drawn = |p: DVec3| match &with_samples {
            Some(blocks) if blocks.near(p) => Known::within(blocks.reach()),
            _ => Known::UNKNOWN,
        };
        let (origin, spacing) = (DVec3::from(grid.origin), DVec3::from(grid.spacing));
        // Each with its position among the pending cells. Every piece finds the same open cells
        // (and so the same triangles around them below) and measures those it owns.
        let open: Vec<(usize, u32)> = pending_cells(fine, pending)
            .par_iter()
            .copied()
            .enumerate()
            .filter(|&(_, c)| {
                let centre =
                    origin + (DVec3::from(grid.ijk(c as usize).map(|c| c as f64)) + 0.5) * spacing;
                near_drawn(centre).d == f64::INFINITY
            })
            .collect();
        let far_cells: Vec<Keyed> = if open.is_empty() {
            Vec::new()
        } else {
            let all = match pending {
                Pending::All => checked_triangles,
                // Later rounds: the triangles within the reach of the open cells, the only ones
                // that can settle points of them.
                Pending::Some { .. } => {
                    let cells: Vec<u32> = open.iter().map(|&(_, c)| c).collect();
                    let near_open = Around::new(grid, &cells, reach.full);
                    drawn_triangles(volume, v, carriers, sheets)
                        .filter(|(t, _)| {
                            let [a, b, c] = t.map(|p| (p - origin) / spacing);
                            near_open.meets(grid, a.min(b).min(c), a.max(b).max(c))
                        })
                        .collect()
                }
            };
            let drawn = Drawn {
                tree: tree.unwrap_or_else(|| triangle_tree(all.iter().map(|&(t, _)| t))),
                triangles: all,
            };
            let to_drawn = Cover {
                surface: &drawn,
                reach: reach.full,
                floor: h / FLOOR,
                region,
            };
            open.into_par_iter()
                .filter(|&(_, c)| owner.is_none_or(|o| o.owns_cell(grid.ijk(c as usize))))
                .flat_map_iter(|(n, c)| {
                    let cell = IVec3::from(grid.ijk(c as usize).map(|c| c as i32));
                    let to_drawn = &to_drawn;
                    let near_drawn = &near_drawn;
                    // The cell's points (a point of F is a corner of several of its triangles;
                    // the same point reached along another tetrahedron's edge may differ in its
                    // last bits, far below the rounding allowance), each measured once.
                    let triangles = cell_triangles(volume, cell, v);
                    let mut points = ArrayVec::<(DVec3, Known<u32>), 36>::new();
                    let same = h * 1e-9;
                    let mut found = ArrayVec::<Violation, 12>::new();
                    for t in triangles {
                        let at = t.map(|p| {
                            points
                                .iter()
                                .position(|q| q.0.distance(p) <= same)
                                .unwrap_or_else(|| {
                                    points.push((p, near_drawn(p)));
                                    points.len() - 1
                                })
                        });
                        let mut known = at.map(|i| points[i].1);
                        found.extend(
                            (to_drawn.violation(t, &mut known))
                                .map(|point| Violation { point, triangle: t }),
                        );
                        for (i, k) in at.into_iter().zip(known) {
                            points[i].1 = k;
                        }
                    }
                    keyed(CELL, n, c, found)
                })
                .collect()
        };
        let mut found = far_cells;
        found.extend(far_samples);
        Ok(found)
    }

    /// The violations of one round for one isovalue, every piece's (`found`, each with its key),
    /// in the order of their keys: the order a single check finds them.
    fn far(mut found: Vec<Keyed>, checked: &[Tet]) -> Far {
        found.sort_unstable_by_key(|&(key, _)| key);
        let mut far = Far {
            points: Vec::with_capacity(found.len()),
            carriers: Vec::new(),
            cells: Vec::new(),
        };
        for ([kind, _, _, item], v) in found {
            far.points.push(v);
            match kind {
                CELL => far.cells.push(item),
                _ => far.carriers.push(checked[item as usize]),
            }
        }
        far.cells.dedup();
        far.carriers.dedup();
        far
    }

    /// The diamonds to split for `violations` (of each isovalue): for a violation, the diamonds on
    /// the path from the root to the tetrahedron holding it below its leaf in `split` that is no
    /// larger than `tolerance` — or, when the leaf already is, to the finest tetrahedron holding
    /// it — found at the first of its [`Violation::probes`] whose leaf is not a finest tetrahedron;
    /// for one violation per isovalue and `cube` (the splits it causes cover the others there)
    /// among those that have such a probe (one whose probes all lie in finest leaves forces
    /// nothing, so it stands for no other: a point of F is a corner of several triangles, and its
    /// violation on one whose probes find finest leaves once hid the same point on another whose
    /// probes find the coarse leaf hiding material). In order, each once; none when every probe of
    /// every violation lies in a finest leaf.
    fn forced<'v>(
        &self,
        split: &SplitSet,
        violations: impl Iterator<Item = &'v [Violation]>,
        tolerance: f64,
        cube: impl Fn(DVec3) -> [i64; 3],
    ) -> Vec<Diamond> {
        let lattice = *self.lattice();
        let grid = &self.volume.grid;
        let (origin, spacing) = (DVec3::from(grid.origin), DVec3::from(grid.spacing));
        let h = grid.spacing.into_iter().fold(f64::INFINITY, f64::min);
        let top = lattice.hi.as_dvec3();
        let roots = RootTets::new(&lattice);
        let tolerance2 = tolerance * tolerance;
        let path_at = |p: DVec3| {
            // Just inside a far face of the domain: a tetrahedron holding a point there holds
            // some of the domain around it, so the descent below ends in the mesh's leaf.
            let u = ((p - origin) / spacing).clamp(DVec3::ZERO, top - INSIDE);
            let (k, mut l) = roots.containing(u);
            let mut t = roots.tets[k].0;
            let step = |t: &Tet, l: [f64; 4], m: IVec3| {
                let (first, nl) = child_coordinates(t, l);
                (child_of(t, first, *t, t[usize::from(!first)], m), nl)
            };
            // Down to the leaf, as the mesh's walk goes (`mesh::walk_pruned`): through the split
            // diamonds, and through every tetrahedron straddling a far face, split wherever the
            // surface may pass though its diamond is not in the split set.
            while let Some(d) = Diamond::of_tet(&t)
                .filter(|&d| lattice.place(&t) != Placement::Inside || split.contains(d))
            {
                (t, l) = step(&t, l, d.center);
            }
            // Below it, to no larger than the tolerance; to the finest if it already is.
            let to_finest = tet_size2(&grid.spacing, &t) <= tolerance2;
            let mut path = Vec::new();
            let mut below = false;
            while let Some(d) = Diamond::of_tet(&t) {
                if below && !to_finest && tet_size2(&grid.spacing, &t) <= tolerance2 {
                    break;
                }
                below = true;
                if lattice.in_domain(d.center) {
                    path.push(d);
                }
                (t, l) = step(&t, l, d.center);
            }
            path
        };
        let mut seen = FxHashSet::default();
        let mut forced = Vec::new();
        for violations in violations {
            let paths: Vec<Vec<Diamond>> = violations
                .par_iter()
                .map(|v| {
                    (v.probes(h).into_iter())
                        .map(path_at)
                        .find(|path| !path.is_empty())
                        .unwrap_or_default()
                })
                .collect();
            let mut cubes = FxHashSet::default();
            for (v, path) in violations.iter().zip(paths) {
                if !path.is_empty() && cubes.insert(cube(v.point)) {
                    forced.extend(path.into_iter().filter(|&d| seen.insert(d)));
                }
            }
        }
        forced
    }
}

impl<T: Sample> Extraction<'_, '_, T> {
    /// `split` with the `forced` diamonds split too (with closure) and refinement by `criterion` at
    /// `tolerance` continued from there, and its leaves that carry the surface of `isovalues`
    /// (`carriers`, those of `split`, patched: those still leaves first, their number last), and the
    /// carriers that were split.
    fn force(
        &self,
        isovalues: &[f64],
        split: SplitSet,
        carriers: Vec<Tet>,
        forced: &[Diamond],
        criterion: &dyn Fn(Diamond) -> f64,
        tolerance: f64,
    ) -> (SplitSet, Vec<Tet>, Vec<Tet>, usize) {
        let (volume, lattice) = (self.volume, *self.lattice());
        // Continue from this mesh: split the forced diamonds (with closure) and whatever their new
        // children need. Every diamond above the tolerance in the result is reachable from the
        // diamonds split here, so this equals refining from the root with the forced diamonds
        // infinitely wrong.
        let forced_set: FxHashSet<Diamond> = forced.iter().copied().collect();
        let criterion = |d: Diamond| {
            if forced_set.contains(&d) {
                f64::INFINITY
            } else {
                criterion(d)
            }
        };
        let (split, newly) =
            Refiner::new(lattice, split, 0, &criterion).refine_logged(tolerance, forced);
        // The carriers now: those still leaves, then the carriers below the leaves just split (the
        // tetrahedra of the newly split diamonds made by splitting a diamond split before), in
        // split order. A tetrahedron's parent diamond is centred at its vertex 2 or 3 (the
        // midpoint of the parent's spine, `diamond::bisect`).
        let newly_split: FxHashSet<Diamond> = newly.iter().copied().collect();
        let was_leaf = |d: &Diamond, t: &Tet| {
            !d.parents(&lattice)
                .iter()
                .any(|p| (p.center == t[2] || p.center == t[3]) && newly_split.contains(p))
        };
        let (removed, mut carriers): (Vec<Tet>, Vec<Tet>) = carriers
            .into_iter()
            .partition(|t| Diamond::of_tet(t).is_some_and(|d| newly_split.contains(&d)));
        let kept = carriers.len();
        let empty = |t: &Tet| self.misses(isovalues, t);
        let keep = |t: &Tet| carries(volume, isovalues, t).then_some(*t);
        for d in &newly {
            for t in d.tets(&lattice).into_iter().filter(|t| was_leaf(d, t)) {
                carriers.extend(mesh::leaves_below(&lattice, &split, t, &empty, &keep));
            }
        }
        (split, carriers, removed, kept)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hierarchy::Hierarchy;
    use crate::isosurface::cache::IsoCache;
    use crate::isosurface::refine_query;
    use crate::volume::{Grid, ScalarSlice, Volume};

    #[test]
    fn near_boxes_hold_the_cells_of_the_grown_boxes() {
        // The definition: a cell is near when it lies in the cell range of a tetrahedron's box
        // grown by the reach. Spacing differs per axis; reaches below a cell, of a few cells and
        // beyond the grid; tetrahedra at the grid's faces and inside.
        let mut grid = Grid::new([23, 17, 30]);
        grid.spacing = [0.5, 1.25, 0.8];
        let tets: Vec<Tet> = (0..40)
            .map(|k: i32| {
                let p = IVec3::new((k * 7) % 23, (k * 5) % 17, (k * 11) % 30);
                let q = (p + IVec3::new(k % 3, 1 + k % 2, k % 4)).min(IVec3::new(22, 16, 29));
                [p, q, IVec3::new(p.x, q.y, p.z), IVec3::new(q.x, p.y, q.z)]
            })
            .collect();
        for reach in [0.3, 2.0, 4.1, 40.0] {
            for n in [0, 1, 7, tets.len()] {
                let near = NearBoxes::new(&grid, &tets[..n], reach);
                let margin = reach / DVec3::from(grid.spacing);
                for i in 0..grid.len() {
                    let [x, y, z] = grid.ijk(i);
                    if x + 1 == grid.dims[0] || y + 1 == grid.dims[1] || z + 1 == grid.dims[2] {
                        continue;
                    }
                    let c = IVec3::new(x as i32, y as i32, z as i32);
                    let expected = tets[..n].iter().any(|t| {
                        let lo = t[0].min(t[1]).min(t[2].min(t[3])).as_dvec3() - margin;
                        let up = t[0].max(t[1]).max(t[2].max(t[3])).as_dvec3() + margin;
                        let (lo, up) = cell_range(&grid, lo, up);
                        c.cmpge(lo).all() && c.cmple(up).all()
                    });
                    assert_eq!(
                        near.has(c),
                        expected,
                        "cell {c}, reach {reach}, {n} tetrahedra"
                    );
                }
            }
        }
    }

    #[test]
    fn a_change_of_sheets_checks_again_what_it_changed_on_kept_carriers() {
        // Two tetrahedra draw the face abc at 0 from both sides (a sheet); when one of them stops
        // drawing it, the other, kept, draws it again and is checked again; when the face becomes
        // a sheet, the cells of F within the reach of it are checked again.
        let grid = Grid::new([12, 12, 12]);
        let p = |x, y, z| IVec3::new(x, y, z);
        let (a, b, c) = (p(5, 5, 5), p(6, 5, 5), p(5, 6, 5));
        let mut v = vec![5.0f32; grid.len()];
        for q in [a, b, c] {
            v[grid.index(q.x as usize, q.y as usize, q.z as usize)] = 0.0;
        }
        for q in [p(5, 5, 6), p(5, 5, 4)] {
            v[grid.index(q.x as usize, q.y as usize, q.z as usize)] = -1.0;
        }
        let h = Hierarchy::build_for_isosurfaces(grid, ScalarSlice::F32(&v)).unwrap();
        let volume = Volume::new(grid, &v[..]).unwrap();
        let cache = IsoCache::new(&volume);
        let x = Extraction {
            hierarchy: &h,
            volume: &volume,
            cache: &cache,
            partition: None,
        };
        let (above, below) = ([a, b, c, p(5, 5, 6)], [a, c, b, p(5, 5, 4)]);
        let reach = Reach::new(&grid, 1.0);
        let both = sheets(&volume, &[above, below], 0.0);
        let one = sheets(&volume, &[above], 0.0);
        assert_eq!((both.len(), one.len()), (1, 0));
        let all: Vec<u32> = (0..grid.len() as u32).collect();
        let empty = || Pending::Some {
            carriers: Vec::new(),
            cells: Vec::new(),
        };
        let mut pending = empty();
        x.sheets_changed(0.0, (&both, &one), &[above], &all, &mut pending, reach);
        let Pending::Some { carriers, cells } = pending else {
            unreachable!()
        };
        assert_eq!((carriers, cells.len()), (vec![above], 0));
        let mut pending = empty();
        x.sheets_changed(
            0.0,
            (&one, &both),
            &[above, below],
            &all,
            &mut pending,
            reach,
        );
        let Pending::Some { carriers, cells } = pending else {
            unreachable!()
        };
        let near = NearBoxes::new(&grid, &[[a, b, c, c]], reach.full);
        let expected: Vec<u32> = (all.iter().copied())
            .filter(|&i| near.has(IVec3::from(grid.ijk(i as usize).map(|c| c as i32))))
            .collect();
        assert!(carriers.is_empty() && !expected.is_empty() && expected.len() < all.len() / 4);
        assert_eq!(cells, expected);
        // No change, nothing added; the first round (everything pending) is left as it is.
        let mut pending = empty();
        x.sheets_changed(
            0.0,
            (&both, &both),
            &[above, below],
            &all,
            &mut pending,
            reach,
        );
        assert!(
            matches!(pending, Pending::Some { carriers, cells } if carriers.is_empty() && cells.is_empty())
        );
        let mut pending = Pending::All;
        x.sheets_changed(
            0.0,
            (&one, &both),
            &[above, below],
            &all,
            &mut pending,
            reach,
        );
        assert!(matches!(pending, Pending::All));
    }

    #[test]
    fn carriers_after_forcing_are_the_leaves_that_carry() {
        // Single-sample spikes far from a sphere make the check split more; the carriers patched in
        // below the leaves it split are the carrying leaves of its mesh.
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
        let cache = IsoCache::new(&volume);
        let x = Extraction {
            hierarchy: &h,
            volume: &volume,
            cache: &cache,
            partition: None,
        };
        let sorted = |ts: &[Tet]| {
            let mut k: Vec<_> = ts.iter().map(|t| t.map(|p| p.to_array())).collect();
            k.sort();
            k
        };
        for tol in [3.0, 6.0, 10.0] {
            let query = IsoQuery::new(0.0, tol);
            let refine = refine_query(&query, tol);
            let criterion = x.iso_criterion(&query.isovalues, tol).unwrap();
            let plain = Refiner::run(h.grid(), h.base(), &refine, &criterion).unwrap();
            let (split, carriers) = x
                .refine_iso(&query, tol, &mut |c| {
                    Refiner::run(h.grid(), h.base(), &refine, c)
                })
                .unwrap();
            assert!(split.len() > plain.len(), "nothing forced at {tol}");
            let fresh = x.carriers_of(&query.isovalues, &split).unwrap();
            assert_eq!(sorted(&carriers), sorted(&fresh), "tolerance {tol}");
        }
    }
}
