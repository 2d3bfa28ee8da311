//! The diamond hierarchy of a volume: per-diamond precomputation (Gregorski §6, §8; Weiss & De Floriani §4;
//! Marchesin §4.1).
//!
//! Every lattice point of the domain is the central vertex of exactly one diamond, so the per-diamond data
//! is a 3-D array parallel to the samples ("a hierarchy of diamonds built on a regular volume data set can be
//! efficiently encoded as a three-dimensional array", Weiss & De Floriani §4). Each [`Record`] holds, in
//! 2 bytes ([`record`]), the diamond's **exact** maximum interpolation error over every sample inside its
//! tetrahedra (Marchesin's enumeration, [`crate::scan`]), rounded *up* to a bfloat16 — an upper bound
//! within 0.8 % that is 0 exactly when the error is 0, so tolerance 0 stays lossless.
//!
//! Diamonds with a tetrahedron straddling a far face of the domain are split unconditionally (see
//! [`crate::lattice`]); their closure is the *base mesh*, computed once here.

pub mod piece;
pub mod record;

use crate::diamond::Diamond;
use crate::lattice::{Lattice, Placement};
use crate::memory;
use crate::mesh::{self, Index, MeshPlan, TetMesh};
use crate::refine::{BaseMesh, Query, Refiner, SplitSet};
use crate::scan::{scan_tet, Stencils};
use crate::volume::{Grid, Sample, ScalarSlice, Volume};
use crate::{with_volume, Error, Result};
use rayon::prelude::*;
use record::{decode_error, Record};

/// Progress callback: called on the calling thread with a fraction in `[0, 1]`; return `false` to abort.
pub type Progress<'a> = &'a mut dyn FnMut(f64) -> bool;

/// Bytes the hierarchy needs for a grid of `points` points (records, split set, queue headroom).
pub fn bytes_needed(points: usize) -> u64 {
    points as u64 * (std::mem::size_of::<Record>() as u64) + points as u64 / 8 * 2
}

/// Bytes an isosurface-only hierarchy ([`Hierarchy::build_for_isosurfaces`]) needs for a grid of
/// `points` points before any surface is measured: no records, a bit per point for each of the
/// whole-grid split sets alive at once (the hierarchy's root set, a query's, the copy that grows
/// in parallel, the last mesh's kept for the next isovalue change). What a surface adds (error
/// codes and gradients by bricks written, the check's blocks, triangles) grows with the surface
/// or is capped, not the grid, and is allocated fallibly.
pub fn isosurface_bytes_needed(points: usize) -> u64 {
    points as u64 / 8 * 4
}

/// Bytes of memory the system can still give (`MemAvailable`), when known.
pub fn available_memory() -> Option<u64> {
    let mut sys = sysinfo::System::new();
    sys.refresh_memory();
    let available = sys.available_memory();
    (available > 0).then_some(available)
}

/// The diamond hierarchy of one volume. Owns its metadata; the samples are only read during [`Hierarchy::build`].
#[derive(Debug)]
pub struct Hierarchy {
    grid: Grid,
    lattice: Lattice,
    records: Vec<Record>,
    value_range: (f64, f64),
    /// Where every query starts.
    base: BaseMesh,
}

impl Hierarchy {
    /// Builds the hierarchy for `scalars` on `grid`, refusing grids whose hierarchy would not fit in the
    /// available memory before allocating anything.
    pub fn build(grid: Grid, scalars: ScalarSlice<'_>, progress: Progress<'_>) -> Result<Self> {
        Self::build_with_memory_limit(grid, scalars, available_memory(), progress)
    }

    /// [`Hierarchy::build`] with an explicit memory limit (`None`: no check).
    pub fn build_with_memory_limit(
        grid: Grid,
        scalars: ScalarSlice<'_>,
        available: Option<u64>,
        progress: Progress<'_>,
    ) -> Result<Self> {
        Self::check_size(&grid, bytes_needed(grid.len()), available)?;
        with_volume!(grid, scalars, |v| Self::build_volume(&v, progress))
    }

    /// The hierarchy without per-diamond records and without base mesh, for isosurface queries only:
    /// these measure the errors they need at the surface samples of their isovalues
    /// ([`crate::isosurface`]) and split the diamonds straddling a far face only where the surface
    /// passes, so nothing is precomputed over the whole volume; [`Hierarchy::query`] refuses it. Checks the
    /// samples (finite, matching the grid) and the memory like [`Hierarchy::build`].
    pub fn build_for_isosurfaces(grid: Grid, scalars: ScalarSlice<'_>) -> Result<Self> {
        Self::build_for_isosurfaces_with_memory_limit(grid, scalars, available_memory())
    }

    /// [`Hierarchy::build_for_isosurfaces`] with an explicit memory limit (`None`: no check).
    pub fn build_for_isosurfaces_with_memory_limit(
        grid: Grid,
        scalars: ScalarSlice<'_>,
        available: Option<u64>,
    ) -> Result<Self> {
        Self::check_size(&grid, isosurface_bytes_needed(grid.len()), available)?;
        with_volume!(grid, scalars, |v| Self::skeleton(&v))
    }

    /// Refuses grids too large for 32-bit point ids or for the available memory, of which the
    /// hierarchy needs `needed` bytes.
    fn check_size(grid: &Grid, needed: u64, available: Option<u64>) -> Result<()> {
        grid.validate()?;
        if grid.len() > u32::MAX as usize {
            return Err(Error::Parameter(format!(
                "{:?} points: at most 2^32 points are supported (output point ids are 32-bit)",
                grid.dims
            )));
        }
        if let Some(available) = available.filter(|&a| needed > a) {
            return Err(Error::TooLarge {
                dims: grid.dims,
                needed,
                available,
            });
        }
        Ok(())
    }

    /// The hierarchy of `volume` without records, starting from the root: isosurface queries split
    /// the diamonds straddling a far face only where the surface passes (see `crate::isosurface`).
    fn skeleton<T: Sample>(volume: &Volume<'_, T>) -> Result<Self> {
        let lattice = Lattice::new(volume.grid.dims)?;
        let root = Diamond::root(&lattice);
        let base = BaseMesh {
            split: SplitSet::new(&lattice),
            tets: root
                .tets(&lattice)
                .iter()
                .filter(|t| lattice.place(t) == Placement::Inside)
                .count(),
            candidates: vec![root],
        };
        Ok(Self {
            grid: volume.grid,
            lattice,
            records: Vec::new(),
            value_range: volume.range(),
            base,
        })
    }

    fn build_volume<T: Sample>(volume: &Volume<'_, T>, progress: Progress<'_>) -> Result<Self> {
        let grid = volume.grid;
        let lattice = Lattice::new(grid.dims)?;
        let value_range = volume.range();
        let stencils = Stencils::new(&grid);
        let mut records = memory::filled(grid.len(), Record::default(), "the diamond hierarchy")?;
        let nx = grid.dims[0];
        let rows = grid.dims[1] * grid.dims[2];
        // The base mesh depends on the lattice only: a thread of its own computes it (a serial walk)
        // while the records are scanned, instead of after them.
        let base = std::thread::scope(|scope| {
            let base = scope.spawn(|| base_mesh(lattice));
            // Rows of records in parallel, in batches so that progress and abort are seen on this thread.
            let batches = 64.min(rows);
            let per_batch = rows.div_ceil(batches);
            for (b, chunk) in records.chunks_mut(per_batch * nx).enumerate() {
                if !progress(0.9 * b as f64 / batches as f64) {
                    return Err(Error::Aborted);
                }
                let first_row = b * per_batch;
                chunk.par_chunks_mut(nx).enumerate().for_each(|(r, row)| {
                    let (y, z) = (
                        (first_row + r) % grid.dims[1],
                        (first_row + r) / grid.dims[1],
                    );
                    row_records(volume, &lattice, &stencils, [y, z], row);
                });
            }
            // A panic there goes on here, where the callers' guards see it.
            Ok(base.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
        })?;
        if !progress(0.9) {
            return Err(Error::Aborted);
        }
        progress(1.0);
        Ok(Self {
            grid,
            lattice,
            records,
            value_range,
            base,
        })
    }

    /// Extracts the adaptive mesh for `query` (Gregorski §4 selective refinement with closure):
    /// [`Hierarchy::plan`], then the mesh written into new vectors.
    pub fn query(&self, query: &Query) -> Result<TetMesh> {
        self.plan(query)?.to_mesh(&self.grid, |d| self.error(d))
    }

    /// Refines for `query` (Gregorski §4 selective refinement with closure) and counts the mesh:
    /// the caller allocates its arrays from [`MeshPlan::tets`] and [`MeshPlan::points`] and has it
    /// written there ([`Hierarchy::write_tets`], [`MeshPlan::write_points`], [`MeshPlan::gather`]).
    pub fn plan(&self, query: &Query) -> Result<MeshPlan> {
        if !self.has_records() {
            return Err(Error::Parameter(
                "this hierarchy was built for isosurfaces only: it holds no per-diamond errors"
                    .into(),
            ));
        }
        let error = |d| self.error(d);
        let split = if query.max_tetrahedra == 0 {
            Refiner::run_concurrent(&self.grid, &self.base, query, &error)?
        } else {
            Refiner::run(&self.grid, &self.base, query, &error)?
        };
        MeshPlan::new(&self.lattice, split)
    }

    /// Writes the tetrahedra of `plan`, a plan of this hierarchy, with their errors
    /// ([`MeshPlan::write_tets`]); returns the largest error.
    pub fn write_tets<I: Index>(
        &self,
        plan: &MeshPlan,
        connectivity: &mut [I],
        offsets: &mut [I],
        depths: &mut [u8],
        errors: &mut [f32],
    ) -> Result<f64> {
        if *plan.lattice() != self.lattice {
            return Err(Error::Parameter(
                "the mesh plan belongs to another hierarchy".into(),
            ));
        }
        plan.write_tets(|d| self.error(d), connectivity, offsets, depths, errors)
    }

    /// The grid the hierarchy was built for.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The virtual lattice.
    pub fn lattice(&self) -> &Lattice {
        &self.lattice
    }

    /// Smallest and largest sample of the volume.
    pub fn value_range(&self) -> (f64, f64) {
        self.value_range
    }

    /// Whether the hierarchy holds the per-diamond records ([`Hierarchy::build`]) that tetrahedral
    /// queries need.
    pub fn has_records(&self) -> bool {
        !self.records.is_empty()
    }

    /// Bytes of per-diamond metadata (2 per input point; 0 when built for isosurfaces only).
    pub fn metadata_bytes(&self) -> usize {
        self.records.len() * std::mem::size_of::<Record>()
    }

    /// Tetrahedra of the base mesh: the refinement forced by the domain's far faces alone.
    pub fn base_tetrahedra(&self) -> usize {
        self.base.tets
    }

    /// What a user should know of a budget of `max_tetrahedra` (0: none): one below the base mesh
    /// cannot be met, and a query under it yields the base mesh.
    pub fn budget_warning(&self, max_tetrahedra: usize) -> Option<String> {
        let base = self.base.tets;
        if max_tetrahedra == 0 || base <= max_tetrahedra {
            return None;
        }
        let [nx, ny, nz] = self.grid.dims;
        let why = if self.base.split.is_empty() {
            "its root cube's"
        } else {
            "the refinement its far faces force, least when every axis has 2^k + 1 points: 33, 65, 129, 257, ..."
        };
        Some(format!(
            "the budget of {max_tetrahedra} tetrahedra cannot be met: the coarsest mesh of this {nx}×{ny}×{nz} image has {base} tetrahedra ({why}); the output is that mesh"
        ))
    }

    /// Where every query starts: the base mesh and its candidates for splitting.
    pub(crate) fn base(&self) -> &BaseMesh {
        &self.base
    }

    /// Error bound of diamond `d` (data units); diamonds whose central vertex is outside the domain are
    /// either split in the base mesh or entirely outside, and report 0.
    #[inline]
    pub fn error(&self, d: Diamond) -> f64 {
        if self.lattice.in_domain(d.center) {
            decode_error(self.records[self.lattice.index(d.center)].error)
        } else {
            0.0
        }
    }
}

/// The base mesh of `lattice`: every diamond with a tetrahedron straddling a far face of the domain, with
/// its closure (also the start of material refinement, whose lattice is one level finer than its data).
pub(crate) fn base_mesh(lattice: Lattice) -> BaseMesh {
    let split = Refiner::base_mesh(lattice);
    let mut candidates = Refiner::candidates(&lattice, &split);
    // Ordered by depth, as the depth sweep takes them (stable: in walk order within a depth).
    candidates.sort_by_key(|d| d.depth(&lattice));
    BaseMesh {
        tets: mesh::count_tets(&lattice, &split),
        candidates,
        split,
    }
}

/// True when `p` is a corner of the root cube (no diamond is centred there).
fn is_root_corner(lattice: &Lattice, p: glam::IVec3) -> bool {
    (p.cmpeq(glam::IVec3::ZERO) | p.cmpeq(glam::IVec3::splat(lattice.size()))).all()
}

/// The records of the row `(y, z)` of a whole grid's `volume`: those of the finest diamonds inside
/// the domain, 7 of every 8 points away from the faces, in one loop along the row
/// ([`Stencils::finest_row_errors`]: no [`Diamond`], bounds or placement per diamond), then every
/// other point's by [`diamond_record`] (the same records: the finest ones take the same path there).
fn row_records<T: Sample>(
    volume: &Volume<'_, T>,
    lattice: &Lattice,
    stencils: &Stencils,
    [y, z]: [usize; 2],
    row: &mut [Record],
) {
    let hi = lattice.hi;
    let interior = |c: usize, hi: i32| c >= 1 && (c as i32) < hi;
    let mut finest = 0..0;
    if interior(y, hi.y) && interior(z, hi.z) && hi.x >= 2 {
        finest = 1..hi.x as usize;
        stencils.finest_row_errors(volume, [y, z], finest.clone(), |x, e| {
            row[x] = Record::of(e)
        });
    }
    for (x, rec) in row.iter_mut().enumerate() {
        let d = Diamond::new(glam::IVec3::new(x as i32, y as i32, z as i32));
        // (Short-circuits before the root corner, whose scale is undefined.)
        if finest.contains(&x) && d.scale() == 1 {
            continue; // written by the row loop
        }
        *rec = diamond_record(volume, lattice, stencils, (d, glam::IVec3::ZERO));
    }
}

/// Scans the inside tetrahedra of `d` and packs the result. `volume` starts at the lattice point
/// `shift` (zero for a whole grid; a piece's padded box for a piece): the samples are read at
/// shifted positions, while the shapes of the tetrahedra come from `d` itself, so any shift works.
fn diamond_record<T: Sample>(
    volume: &Volume<'_, T>,
    lattice: &Lattice,
    stencils: &Stencils,
    (d, shift): (Diamond, glam::IVec3),
) -> Record {
    if is_root_corner(lattice, d.center) {
        return Record::default(); // a root-cube corner is no diamond
    }
    let (lo, hi) = d.bounds();
    if lattice.in_domain(lo) && lattice.in_domain(hi) {
        let c = d.center - shift;
        let center = volume.grid.index(c.x as usize, c.y as usize, c.z as usize);
        if d.scale() == 1 {
            return Record::of(stencils.finest_diamond_error(volume, d, center));
        }
        // Scales 2 and 4: the tetrahedra's stencils found by the central vertex's residue.
        if let Some(error) = stencils.diamond_error(volume, d, center) {
            return Record::of(error);
        }
    } else if !lattice.in_domain(hi) && d.placement(lattice) == Placement::Straddling {
        // Split unconditionally in the base mesh: no error needed. Told by the boxes of its
        // tetrahedra (the placement of each), without building them: along a far face whose
        // coordinate has low-order one bits (63 for 64 points) most diamonds near it are such.
        // Only a diamond reaching past a far face can straddle one: along the near faces (`lo`
        // below 0) its boxes are inside the domain or outside the root cube.
        return Record::default();
    }
    // The finest diamonds' tetrahedra have no stencil (scales 2 and 4 only): scanned at once.
    let finest = d.scale() == 1;
    let mut error = 0.0f64;
    for t in d.tets(lattice) {
        match lattice.place(&t) {
            Placement::Inside => {
                let t = t.map(|p| p - shift);
                let stencil = if finest {
                    None
                } else {
                    stencils.error(volume, &t)
                };
                let e = stencil.unwrap_or_else(|| scan_tet(volume, &t).error);
                if e > error {
                    error = e;
                }
            }
            Placement::Outside => {}
            // Not met: a diamond with a straddling tetrahedron was told by its placement above.
            Placement::Straddling => return Record::default(),
        }
    }
    Record::of(error)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_before_allocating_when_too_large() {
        let samples = [0u8; 8];
        let grid = Grid {
            dims: [2, 2, 2],
            origin: [0.0; 3],
            spacing: [1.0; 3],
        };
        let err = Hierarchy::build_with_memory_limit(
            grid,
            ScalarSlice::U8(&samples),
            Some(10),
            &mut |_| true,
        )
        .unwrap_err();
        assert!(matches!(err, Error::TooLarge { needed, available: 10, .. } if needed > 10));
        assert!(err.to_string().contains("needs"));
    }

    /// An isosurface-only hierarchy holds no records: it is refused only when its bitsets do not
    /// fit, not by the 2 bytes per point of the records it never builds.
    #[test]
    fn an_isosurface_hierarchy_is_refused_by_its_own_needs() {
        let dims = [64, 64, 64];
        let samples = vec![0u8; 64 * 64 * 64];
        let grid = Grid {
            dims,
            origin: [0.0; 3],
            spacing: [1.0; 3],
        };
        let points = grid.len();
        let (iso, full) = (isosurface_bytes_needed(points), bytes_needed(points));
        assert!(iso > 0 && 4 * iso < full, "{iso} against {full}");
        let between = Some(2 * iso);
        Hierarchy::build_for_isosurfaces_with_memory_limit(
            grid,
            ScalarSlice::U8(&samples),
            between,
        )
        .expect("an isosurface hierarchy within its needs");
        let err = Hierarchy::build_with_memory_limit(
            grid,
            ScalarSlice::U8(&samples),
            between,
            &mut |_| true,
        )
        .unwrap_err();
        assert!(matches!(err, Error::TooLarge { needed, .. } if needed == full));
        let err = Hierarchy::build_for_isosurfaces_with_memory_limit(
            grid,
            ScalarSlice::U8(&samples),
            Some(iso - 1),
        )
        .unwrap_err();
        assert!(matches!(err, Error::TooLarge { needed, .. } if needed == iso));
    }

    /// A budget below the base mesh is reported, with the base mesh's size and why; one that the
    /// base mesh fits, or none, is not.
    #[test]
    fn a_budget_below_the_base_mesh_is_reported() {
        let build = |n: usize| {
            let samples: Vec<u8> = (0..n * n * n).map(|i| (i * 37 % 251) as u8).collect();
            Hierarchy::build(Grid::new([n; 3]), ScalarSlice::U8(&samples), &mut |_| true).unwrap()
        };
        let cube = build(9);
        assert_eq!(cube.base_tetrahedra(), 6);
        assert_eq!(cube.budget_warning(0), None);
        assert_eq!(cube.budget_warning(6), None);
        let w = cube
            .budget_warning(5)
            .expect("a budget below the root cube's six");
        assert!(
            w.contains("budget of 5 tetrahedra")
                && w.contains("has 6 tetrahedra (its root cube's)"),
            "{w}"
        );
        let band = build(8);
        let base = band.base_tetrahedra();
        assert!(base > 6);
        assert_eq!(band.budget_warning(base), None);
        let w = band
            .budget_warning(base - 1)
            .expect("a budget below the band");
        assert!(
            w.contains(&format!(
                "8×8×8 image has {base} tetrahedra (the refinement its far faces force"
            )),
            "{w}"
        );
        // The query under that budget is the base mesh, as the message says.
        let mesh = band
            .query(&Query {
                max_tetrahedra: base - 1,
                ..Query::tolerance(0.0)
            })
            .unwrap();
        assert_eq!(mesh.tets.len(), base);
    }

    #[test]
    fn records_do_not_depend_on_where_the_volume_starts() {
        // A piece scans a box of the grid that starts at `shift` (its padded box); every fine diamond
        // inside that box must get the whole grid's record, whatever the shift modulo 8 (the finest
        // diamonds' midpoint table is keyed by the central vertex modulo 8).
        let grid = Grid::new([33, 29, 31]);
        let samples = crate::scan::tests::noise(grid);
        let whole = Volume::new(grid, &samples).unwrap();
        let lattice = Lattice::new(grid.dims).unwrap();
        let stencils = Stencils::new(&grid);
        let at = |p: glam::IVec3| grid.index(p.x as usize, p.y as usize, p.z as usize);
        for shift in [
            [4, 0, 0],
            [0, 4, 0],
            [0, 0, 4],
            [4, 4, 4],
            [2, 6, 5],
            [16, 8, 0],
        ] {
            let shift = glam::IVec3::from_array(shift);
            let dims = [0, 1, 2].map(|a| grid.dims[a] - shift[a] as usize);
            let sub = Grid::new(dims);
            let mut part = Vec::with_capacity(sub.len());
            for z in 0..dims[2] {
                for y in 0..dims[1] {
                    for x in 0..dims[0] {
                        part.push(
                            samples[at(shift + glam::IVec3::new(x as i32, y as i32, z as i32))],
                        );
                    }
                }
            }
            let volume = Volume::new(sub, &part).unwrap();
            let sub_stencils = Stencils::new(&sub);
            let mut checked = 0;
            for i in 0..grid.len() {
                let [x, y, z] = grid.ijk(i);
                let d = Diamond::new(glam::IVec3::new(x as i32, y as i32, z as i32));
                if d.center == glam::IVec3::ZERO || d.scale() > 4 || d.bounds().0.cmplt(shift).any()
                {
                    continue;
                }
                let expected = diamond_record(&whole, &lattice, &stencils, (d, glam::IVec3::ZERO));
                let got = diamond_record(&volume, &lattice, &sub_stencils, (d, shift));
                assert_eq!(got, expected, "{d:?} shifted by {shift}");
                checked += 1;
            }
            assert!(checked > 5_000, "{checked}");
        }
    }

    #[test]
    fn row_records_are_the_diamond_records() {
        // The finest diamonds' loop along a row gives every point the record diamond_record gives it,
        // on grids whose far faces fall on odd and even coordinates, thin and cubic.
        for dims in [
            [33, 29, 31],
            [20, 17, 12],
            [3, 5, 4],
            [2, 9, 3],
            [16, 16, 16],
        ] {
            let grid = Grid::new(dims);
            let samples = crate::scan::tests::noise(grid);
            let volume = Volume::new(grid, &samples).unwrap();
            let lattice = Lattice::new(dims).unwrap();
            let stencils = Stencils::new(&grid);
            for z in 0..dims[2] {
                for y in 0..dims[1] {
                    // Every record written: none left at this marker.
                    let mut row = vec![Record { error: u16::MAX }; dims[0]];
                    row_records(&volume, &lattice, &stencils, [y, z], &mut row);
                    for (x, got) in row.iter().enumerate() {
                        let d = Diamond::new(glam::IVec3::new(x as i32, y as i32, z as i32));
                        let expected =
                            diamond_record(&volume, &lattice, &stencils, (d, glam::IVec3::ZERO));
                        assert_eq!(*got, expected, "{d:?} in {dims:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn aborts_when_asked() {
        let samples = vec![0u8; 17 * 17 * 17];
        let grid = Grid::new([17; 3]);
        let err = Hierarchy::build(grid, ScalarSlice::U8(&samples), &mut |f| f < 0.5).unwrap_err();
        assert_eq!(err, Error::Aborted);
    }
}
