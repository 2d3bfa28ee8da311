//! The distributed-image half of the bridge: the Rust side of Adaptive Tetrahedra on a piece of an
//! image split across MPI ranks ([`diamonds::hierarchy::piece`] explains the scheme).
//!
//! What crosses, and nothing else: the whole grid ([`GridSpec`]), extents as six integers per piece
//! in VTK's order `[x0, x1, y0, y1, z0, z1]`, relative to the whole extent's first point; the
//! boxes of samples a piece asks of the others (seven integers each); the piece's samples and the
//! samples received from other pieces as raw bytes with a type tag; the
//! coarse errors (one `f64` per coarse point) and the split diamonds (three `i32` each) the
//! filter exchanges; out an opaque [`PieceHierarchy`], an opaque [`PieceRefinement`] and the
//! piece's [`Mesh`] with whole-grid point ids. The filter does all communication; every function
//! runs inside [`guard`].

use std::pin::Pin;
use std::sync::Mutex;

use diamonds::hierarchy::piece::{self, PieceLayout, PointBox, StridedBox};
use diamonds::isosurface::Exchange;
use diamonds::lattice::Lattice;
use glam::IVec3;

use crate::ffi::{
    self, GridSpec, IsoSpec, PieceExchange, QuerySpec, SampleRequests, ScalarType, SplitMessages,
};
use crate::{core_grid, core_query, guard, typed_slice, MeshPlan};

/// Opaque handle on a [`piece::PieceHierarchy`] for C++, with its identity (the mesh plans it
/// makes carry it: see [`crate::Hierarchy`]).
pub struct PieceHierarchy(piece::PieceHierarchy, u64);

/// Opaque handle on a [`piece::PieceRefinement`] for C++: one query's split set on one piece.
pub struct PieceRefinement(piece::PieceRefinement);

/// The point boxes of `extents` (six values per piece, VTK order).
pub(crate) fn boxes(extents: &[i64]) -> Result<Vec<PointBox>, String> {
    if !extents.len().is_multiple_of(6) {
        return Err(format!(
            "{} extent values: not six per piece",
            extents.len()
        ));
    }
    extents
        .chunks_exact(6)
        .map(|e| {
            let v: Vec<i32> = e
                .iter()
                .map(|&x| i32::try_from(x).map_err(|_| format!("extent value {x} out of range")))
                .collect::<Result<_, _>>()?;
            Ok(PointBox {
                lo: IVec3::new(v[0], v[2], v[4]),
                hi: IVec3::new(v[1], v[3], v[5]),
            })
        })
        .collect()
}

/// The layout of the piece at `rank` of `pieces` (every piece's extent), and the pieces' boxes.
fn piece_layout(
    whole: &GridSpec,
    pieces: &[i64],
    rank: usize,
) -> Result<(PieceLayout, Vec<PointBox>), String> {
    let pieces = boxes(pieces)?;
    let owned = *pieces
        .get(rank)
        .ok_or_else(|| format!("piece {rank} of {} pieces", pieces.len()))?;
    let layout = PieceLayout::new(core_grid(whole), owned).map_err(|e| e.to_string())?;
    Ok((layout, pieces))
}

fn layout(whole: &GridSpec, owned: &[i64]) -> Result<PieceLayout, String> {
    let owned = match boxes(owned)?.as_slice() {
        [b] => *b,
        other => return Err(format!("{} extents given for one piece", other.len())),
    };
    PieceLayout::new(core_grid(whole), owned).map_err(|e| e.to_string())
}

/// The boxes of samples the piece at `rank` of `pieces` (every piece's extent) asks of each piece
/// ([`PieceLayout::requests`]).
pub fn piece_requests(
    whole: &GridSpec,
    pieces: &[i64],
    rank: usize,
) -> Result<SampleRequests, String> {
    guard("listing the samples a piece needs", || {
        let (layout, pieces) = piece_layout(whole, pieces, rank)?;
        let requests = layout.requests(&pieces).map_err(|e| e.to_string())?;
        let mut out = SampleRequests {
            counts: vec![0; pieces.len()],
            points: vec![0; pieces.len()],
            boxes: Vec::with_capacity(7 * requests.len()),
        };
        for r in &requests {
            out.counts[r.rank] += 1;
            out.points[r.rank] += r.points.len();
            let (lo, hi) = (r.points.lo.to_array(), r.points.hi.to_array());
            out.boxes.extend(
                lo.iter()
                    .chain(&hi)
                    .chain(&[r.points.stride])
                    .map(|&v| v as u64),
            );
        }
        Ok(out)
    })
}

/// The indices among the points of the piece `owned` (x fastest) of the points of `boxes` (seven
/// values each, as [`piece_requests`] lists them), box after box: what that piece answers.
pub fn piece_box_local_ids(
    whole: &GridSpec,
    owned: &[i64],
    boxes: &[u64],
) -> Result<Vec<i64>, String> {
    guard("finding the points asked of a piece", || {
        if !boxes.len().is_multiple_of(7) {
            return Err(format!("{} box values: not seven per box", boxes.len()));
        }
        let boxes = boxes
            .chunks_exact(7)
            .map(|b| {
                let v: Vec<i32> = b
                    .iter()
                    .map(|&x| i32::try_from(x).map_err(|_| format!("box value {x} out of range")))
                    .collect::<Result<_, _>>()?;
                StridedBox::checked(
                    IVec3::new(v[0], v[1], v[2]),
                    IVec3::new(v[3], v[4], v[5]),
                    v[6],
                )
                .map_err(|e| e.to_string())
            })
            .collect::<Result<Vec<_>, String>>()?;
        layout(whole, owned)?
            .box_indices(&boxes)
            .map_err(|e| e.to_string())
    })
}

/// Checks that the pieces of `pieces` (every rank's extent) cover every point and every cell of the
/// whole grid, so that the whole image can be put together from them.
pub fn piece_check_cover(whole: &GridSpec, pieces: &[i64]) -> Result<(), String> {
    guard("checking that the pieces cover the image", || {
        let points = boxes(pieces)?;
        if let Some(p) = piece::first_uncovered(whole.dims, &points) {
            return Err(format!(
                "point {p} of the whole extent lies in no rank's piece"
            ));
        }
        let cells: Vec<PointBox> = points
            .iter()
            .map(|b| PointBox {
                lo: b.lo,
                hi: b.hi - IVec3::ONE,
            })
            .collect();
        let cell_dims = whole.dims.map(|d| d.saturating_sub(1));
        if let Some(c) = piece::first_uncovered(cell_dims, &cells) {
            return Err(format!(
                "cell {c} of the whole extent lies in no rank's piece"
            ));
        }
        Ok(())
    })
}

impl crate::Hierarchy {
    /// The part of the isosurface the piece at `rank` of `pieces` owns, on a rank holding the
    /// whole image, the ranks sharing the error measurement and the bound's check through
    /// `exchange`
    /// ([`diamonds::IsoState::extract_shared`]).
    #[allow(clippy::too_many_arguments)]
    pub fn isosurface_piece(
        &self,
        state: &mut crate::IsoState,
        scalar_type: ScalarType,
        samples: &[u8],
        isovalues: &[f64],
        spec: &IsoSpec,
        pieces: &[i64],
        rank: usize,
        exchange: Pin<&mut PieceExchange>,
    ) -> Result<Box<crate::Surface>, String> {
        let pieces = guard("reading the pieces' extents", || boxes(pieces))?;
        let exchange = CxxExchange::new(exchange);
        self.isosurface_of(
            state,
            scalar_type,
            samples,
            isovalues,
            spec,
            Some((&pieces, rank, &exchange)),
        )
    }
}

/// The core's [`Exchange`] through the filter's [`PieceExchange`], called on the thread that
/// called the bridge only (the filter's MPI calls are made there).
pub(crate) struct CxxExchange<'a> {
    exchange: Mutex<Pin<&'a mut PieceExchange>>,
    thread: std::thread::ThreadId,
}

impl<'a> CxxExchange<'a> {
    /// `exchange`, to be called on this thread only.
    pub(crate) fn new(exchange: Pin<&'a mut PieceExchange>) -> Self {
        Self {
            exchange: Mutex::new(exchange),
            thread: std::thread::current().id(),
        }
    }
}

// SAFETY: the C++ object is used only under the mutex and only on the thread that created the
// wrapper (checked at every call).
unsafe impl Send for PieceExchange {}

impl Exchange for CxxExchange<'_> {
    fn all_gather(&self, bytes: Vec<u8>) -> diamonds::Result<Vec<Vec<u8>>> {
        if std::thread::current().id() != self.thread {
            return Err(diamonds::Error::Parameter(
                "the ranks' exchange was called from a worker thread".into(),
            ));
        }
        let (mut all, mut lengths) = (Vec::new(), Vec::new());
        let mut exchange = self
            .exchange
            .lock()
            .map_err(|_| diamonds::Error::Parameter("the ranks' exchange failed before".into()))?;
        if !exchange.as_mut().all_gather(&bytes, &mut all, &mut lengths) {
            return Err(diamonds::Error::Parameter(
                "stopped: the other ranks stopped".into(),
            ));
        }
        let mut pieces = Vec::with_capacity(lengths.len());
        let mut at = 0usize;
        for n in lengths {
            let end = usize::try_from(n)
                .ok()
                .and_then(|n| at.checked_add(n))
                .filter(|&end| end <= all.len())
                .ok_or_else(|| {
                    diamonds::Error::Parameter("the ranks' lengths exceed what they sent".into())
                })?;
            pieces.push(all[at..end].to_vec());
            at = end;
        }
        Ok(pieces)
    }
}

/// For each whole-grid index of `ids`, the first of `pieces` holding it (`pieces.len()` if none).
pub fn piece_point_owners(
    whole: &GridSpec,
    pieces: &[i64],
    ids: &[u64],
) -> Result<Vec<u32>, String> {
    guard("finding the pieces that hold points", || {
        let n = whole.dims.iter().map(|&d| d as u64).product::<u64>();
        if let Some(bad) = ids.iter().find(|&&i| i >= n) {
            return Err(format!("point {bad} lies outside the grid of {n} points"));
        }
        let lattice = Lattice::new(whole.dims).map_err(|e| e.to_string())?;
        Ok(piece::point_owners(&lattice, &boxes(pieces)?, ids))
    })
}

/// For each whole-grid index of `ids`, its index among the points of the piece `owned` (x
/// fastest), or −1 when the piece does not hold it.
pub fn piece_local_ids(whole: &GridSpec, owned: &[i64], ids: &[u64]) -> Result<Vec<i64>, String> {
    guard("finding a piece's own points", || {
        Ok(layout(whole, owned)?.local_ids(ids))
    })
}

/// Opaque handle on a [`piece::PointSources`] for C++.
pub struct PointSources(piece::PointSources);

impl PointSources {
    pub fn local(&self) -> &[u64] {
        &self.0.local
    }

    pub fn remote(&self) -> &[u64] {
        &self.0.remote
    }

    pub fn rows(&self) -> &[u32] {
        &self.0.rows
    }
}

/// The table of the points `ids` (whole-grid indices) for the piece of extent `owned` of the
/// `whole` grid ([`piece::PointSources::new`]).
pub(crate) fn point_sources(
    whole: &GridSpec,
    owned: &[i64],
    ids: impl Iterator<Item = u64>,
) -> Result<Box<PointSources>, String> {
    guard("finding where a piece's point data comes from", || {
        let ids: Vec<u64> = ids.collect();
        let own = layout(whole, owned)?.owned();
        piece::PointSources::new(&core_grid(whole), own, &ids)
            .map(|s| Box::new(PointSources(s)))
            .map_err(|e| e.to_string())
    })
}

/// Builds the part of the hierarchy of the piece at `rank` of `pieces` (every piece's extent)
/// ([`piece::PieceHierarchy::build`]).
pub fn build_piece_hierarchy(
    whole: &GridSpec,
    pieces: &[i64],
    rank: usize,
    scalar_type: ScalarType,
    local: &[u8],
    fetched: &[u8],
    mut progress: Pin<&mut ffi::ProgressObserver>,
) -> Result<Box<PieceHierarchy>, String> {
    guard("building a piece of the diamond hierarchy", || {
        let (layout, pieces) = piece_layout(whole, pieces, rank)?;
        let local = typed_slice(scalar_type, local)?;
        let fetched = typed_slice(scalar_type, fetched)?;
        let mut report = crate::reporter(progress.as_mut());
        piece::PieceHierarchy::build(layout, &pieces, local, fetched, &mut report)
            .map(|h| Box::new(PieceHierarchy(h, crate::next_id())))
            .map_err(|e| e.to_string())
    })
}

impl PieceHierarchy {
    /// This piece's part of the coarse diamonds' errors, to be combined by an element-wise maximum.
    pub fn coarse_errors(&self) -> &[f64] {
        self.0.coarse_errors()
    }

    /// Takes the coarse errors combined over all pieces.
    pub fn combine_coarse_errors(&mut self, combined: &[f64]) -> Result<(), String> {
        guard("combining the coarse errors", || {
            self.0
                .combine_coarse_errors(combined)
                .map_err(|e| e.to_string())
        })
    }

    /// Starts refining for `query` on this piece.
    pub fn start_refinement(&self, query: &QuerySpec) -> Result<Box<PieceRefinement>, String> {
        guard("refining a piece", || {
            self.0
                .start(&core_query(query))
                .map(|r| Box::new(PieceRefinement(r)))
                .map_err(|e| e.to_string())
        })
    }

    /// The diamonds split here since the last call, one list per piece (`pieces`: every piece's
    /// extent) holding those it must know.
    pub fn outgoing(
        &self,
        refinement: &mut PieceRefinement,
        pieces: &[i64],
    ) -> Result<SplitMessages, String> {
        guard("listing the split diamonds to send", || {
            let lists = self.0.outgoing(&mut refinement.0, &boxes(pieces)?);
            Ok(SplitMessages {
                counts: lists.iter().map(Vec::len).collect(),
                centers: lists.concat(),
            })
        })
    }

    /// Inserts the diamonds split elsewhere and refines on; returns how many were new here.
    pub fn receive(
        &self,
        refinement: &mut PieceRefinement,
        centers: &[i32],
    ) -> Result<usize, String> {
        guard("inserting the split diamonds received", || {
            self.0
                .receive(&mut refinement.0, centers)
                .map_err(|e| e.to_string())
        })
    }

    /// Counts the tetrahedra this piece owns (`pieces`: every piece's extent, this one's at
    /// `rank`) and their points ([`piece::PieceHierarchy::plan`]).
    pub fn piece_plan(
        &self,
        refinement: Box<PieceRefinement>,
        pieces: &[i64],
        rank: usize,
    ) -> Result<Box<MeshPlan>, String> {
        guard("counting a piece's mesh", || {
            let plan = self
                .0
                .plan(refinement.0, &boxes(pieces)?, rank)
                .map_err(|e| e.to_string())?;
            Ok(Box::new(MeshPlan {
                plan,
                hierarchy: self.1,
            }))
        })
    }

    /// Writes the tetrahedra of `plan`, a plan of this piece, into the caller's arrays
    /// ([`piece::PieceHierarchy::write_tets`]).
    pub fn write_piece_tets<I: diamonds::mesh::Index>(
        &self,
        plan: &MeshPlan,
        connectivity: &mut [I],
        offsets: &mut [I],
        depths: &mut [u8],
        errors: &mut [f32],
    ) -> Result<f64, String> {
        plan.written_by(self.1, |p| {
            self.0.write_tets(p, connectivity, offsets, depths, errors)
        })
    }

    pub(crate) fn write_piece_tets_i32(
        &self,
        plan: &MeshPlan,
        connectivity: &mut [i32],
        offsets: &mut [i32],
        depths: &mut [u8],
        errors: &mut [f32],
    ) -> Result<f64, String> {
        self.write_piece_tets(plan, connectivity, offsets, depths, errors)
    }

    pub(crate) fn write_piece_tets_i64(
        &self,
        plan: &MeshPlan,
        connectivity: &mut [i64],
        offsets: &mut [i64],
        depths: &mut [u8],
        errors: &mut [f32],
    ) -> Result<f64, String> {
        self.write_piece_tets(plan, connectivity, offsets, depths, errors)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build_with;
    use diamonds::ScalarSlice;

    /// A piece holding the whole grid writes, through the bridge, the serial mesh, point array and
    /// point ids; plans are refused by the other kind of hierarchy.
    #[test]
    fn a_whole_piece_writes_the_serial_mesh() {
        let whole = GridSpec {
            dims: [9, 7, 6],
            origin: [0.5, -1.0, 2.0],
            spacing: [1.0, 0.5, 2.0],
        };
        let values: Vec<f64> = (0..9 * 7 * 6)
            .map(|i| ((i * 37) % 23) as f64 * 0.5)
            .collect();
        let bytes: &[u8] = bytemuck::cast_slice(&values);
        let extents = [0, 8, 0, 6, 0, 5];
        let (layout, pieces) = piece_layout(&whole, &extents, 0).unwrap();
        let mut built = piece::PieceHierarchy::build(
            layout,
            &pieces,
            ScalarSlice::F64(&values),
            ScalarSlice::F64(&[]),
            &mut |_| true,
        )
        .unwrap();
        let coarse = built.coarse_errors().to_vec();
        built.combine_coarse_errors(&coarse).unwrap();
        let piece = PieceHierarchy(built, crate::next_id());
        let query = QuerySpec {
            tolerance: 1.5,
            max_tetrahedra: 0,
            use_region_of_interest: false,
            region_of_interest: [0.0; 6],
        };
        let mut refinement = piece.start_refinement(&query).unwrap();
        let sent = piece.outgoing(&mut refinement, &extents).unwrap();
        assert!(sent.centers.is_empty(), "one piece sends nothing");
        let plan = piece.piece_plan(refinement, &extents, 0).unwrap();
        let serial = build_with(&whole, ScalarType::F64, bytes, &mut |_| true).unwrap();
        let serial_plan = serial.plan_mesh(&query).unwrap();
        let (n, np) = (plan.number_of_tetrahedra(), plan.number_of_points());
        assert!(n > 6, "refined beyond the base mesh");
        assert_eq!(
            (n, np),
            (
                serial_plan.number_of_tetrahedra(),
                serial_plan.number_of_points()
            )
        );
        type Writer<'a> = &'a dyn Fn(&mut [i32], &mut [i32], &mut [u8], &mut [f32]) -> f64;
        let write = |with: Writer<'_>| {
            let (mut c, mut o) = (vec![0i32; 4 * n], vec![0i32; n + 1]);
            let (mut d, mut e) = (vec![0u8; n], vec![0f32; n]);
            let max = with(&mut c, &mut o, &mut d, &mut e);
            (c, o, d, e, max.to_bits())
        };
        assert_eq!(
            write(&|c, o, d, e| piece.write_piece_tets_i32(&plan, c, o, d, e).unwrap()),
            write(&|c, o, d, e| serial.write_tets_i32(&serial_plan, c, o, d, e).unwrap())
        );
        let (mut ids, mut serial_ids) = (vec![0i64; np], vec![0i64; np]);
        plan.write_point_ids(&mut ids).unwrap();
        serial_plan.write_point_ids(&mut serial_ids).unwrap();
        assert_eq!(ids, serial_ids);
        // The whole grid is the piece's own: nothing to fetch, every tuple from its own array.
        assert!(plan.piece_remote_point_ids().unwrap().is_empty());
        let (mut passed, mut serial_passed) = (vec![0u8; 8 * np], vec![0u8; 8 * np]);
        plan.gather_piece_point_values(bytes, &[], 8, &mut passed)
            .unwrap();
        serial_plan
            .gather_point_values(bytes, 8, &mut serial_passed)
            .unwrap();
        assert_eq!(passed, serial_passed);
        assert!(plan
            .gather_piece_point_values(bytes, &[0; 8], 8, &mut passed)
            .is_err());
        // A plan is written only by the hierarchy that made it; a serial plan is no piece's.
        let refused = |r: Result<f64, String>| {
            assert!(r.unwrap_err().contains("another hierarchy"));
        };
        refused(piece.write_piece_tets_i64(&serial_plan, &mut [], &mut [], &mut [], &mut []));
        refused(serial.write_tets_i64(&plan, &mut [], &mut [], &mut [], &mut []));
        assert!(serial_plan
            .piece_remote_point_ids()
            .unwrap_err()
            .contains("not a piece's"));
    }
}
