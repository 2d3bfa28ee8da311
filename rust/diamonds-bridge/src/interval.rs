//! The interval-volume half of the bridge (Weiss & De Floriani §2.1, §5): the Rust side of
//! `vtkAdaptiveIntervalVolume`. In: the [`IntervalSpec`] and the samples the hierarchy was built
//! from; out: an opaque [`IntervalVolume`], checked before C++ indexes with it, whose arrays C++
//! reads as slices (points, the two input points and weight each point interpolates from,
//! tetrahedra, levels).

use std::pin::Pin;

use diamonds::hierarchy::piece::{CellOwner, PositionOwner};
use diamonds::interval;
use diamonds::isosurface::{Exchange, Partition};
use diamonds::validate::check_interval_arrays;

use crate::ffi::{GridSpec, IntervalSpec, PieceExchange, ScalarType};
use crate::piece::{boxes, CxxExchange, PointSources};
use crate::{check_core, guard, Hierarchy, IsoState};

/// Opaque handle on a [`diamonds::interval::IntervalVolume`] for C++, its sources flattened.
pub struct IntervalVolume {
    pub(crate) volume: interval::IntervalVolume,
    /// For a piece's share ([`Hierarchy::interval_piece`]): each point's index in the whole
    /// volume; empty for a whole volume.
    pub(crate) global_ids: Vec<u64>,
}

impl Hierarchy {
    /// Extracts the interval volume of `spec` (see `ffi::Hierarchy::interval_volume`).
    pub fn interval_volume(
        &self,
        state: &mut IsoState,
        scalar_type: ScalarType,
        samples: &[u8],
        spec: &IntervalSpec,
    ) -> Result<Box<IntervalVolume>, String> {
        self.interval_of(state, scalar_type, samples, spec, None)
    }

    /// The share of the rank at `rank` of `pieces` (every rank's extent) of the interval volume
    /// of `spec`, on a rank that holds the whole image (see `ffi::Hierarchy::interval_piece`).
    #[allow(clippy::too_many_arguments)]
    pub fn interval_piece(
        &self,
        state: &mut IsoState,
        scalar_type: ScalarType,
        samples: &[u8],
        spec: &IntervalSpec,
        pieces: &[i64],
        rank: usize,
        exchange: Pin<&mut PieceExchange>,
    ) -> Result<Box<IntervalVolume>, String> {
        let exchange = CxxExchange::new(exchange);
        self.interval_share(state, scalar_type, samples, spec, pieces, rank, &exchange)
    }

    /// [`Hierarchy::interval_piece`] through any exchange.
    #[allow(clippy::too_many_arguments)]
    fn interval_share(
        &self,
        state: &mut IsoState,
        scalar_type: ScalarType,
        samples: &[u8],
        spec: &IntervalSpec,
        pieces: &[i64],
        rank: usize,
        exchange: &dyn Exchange,
    ) -> Result<Box<IntervalVolume>, String> {
        let (owner, cells) = guard("reading the pieces' extents", || {
            let pieces = boxes(pieces)?;
            let owner = PositionOwner::new(self.hierarchy.grid(), &pieces, rank)
                .map_err(|e| e.to_string())?;
            let cells = CellOwner::new(&pieces, rank).map_err(|e| e.to_string())?;
            Ok((owner, cells))
        })?;
        let partition = Partition::new(cells, exchange);
        self.interval_of(
            state,
            scalar_type,
            samples,
            spec,
            Some((&owner, &partition)),
        )
    }

    /// The interval volume of `spec`, whole, or with `piece` the share of its owner, the ranks
    /// sharing the extraction through its partition.
    fn interval_of(
        &self,
        state: &mut IsoState,
        scalar_type: ScalarType,
        samples: &[u8],
        spec: &IntervalSpec,
        piece: Option<(&PositionOwner, &Partition<'_>)>,
    ) -> Result<Box<IntervalVolume>, String> {
        let what = "extracting the interval volume";
        self.with_iso_state(
            state,
            what,
            scalar_type,
            samples,
            |state, scalars, expected| {
                let query = spec.query();
                let h = &self.hierarchy;
                let volume = match piece {
                    None => interval::extract_with(state, h, scalars, &query),
                    Some((_, partition)) => {
                        interval::extract_shared(state, h, scalars, &query, partition)
                    }
                }
                .map_err(|e| e.to_string())?;
                check_core(check_interval_arrays(&volume, expected))?;
                let (volume, global_ids) = match piece {
                    None => (volume, Vec::new()),
                    Some((owner, _)) => volume.piece(owner),
                };
                Ok(Box::new(IntervalVolume { volume, global_ids }))
            },
        )
    }
}

impl IntervalVolume {
    pub fn points(&self) -> &[f64] {
        self.volume.points.as_flattened()
    }

    pub fn sources(&self) -> &[u32] {
        self.volume.sources.as_flattened()
    }

    pub fn weights(&self) -> &[f64] {
        &self.volume.weights
    }

    /// Where a piece's point data comes from: its points' sources.
    pub fn piece_sources(
        &self,
        whole: &GridSpec,
        owned: &[i64],
    ) -> Result<Box<PointSources>, String> {
        let sources = self.volume.sources.as_flattened().iter();
        crate::piece::point_sources(whole, owned, sources.map(|&i| i as u64))
    }

    pub fn tets(&self) -> &[u32] {
        self.volume.tets.as_flattened()
    }

    pub fn levels(&self) -> &[u8] {
        &self.volume.levels
    }

    pub fn global_point_ids(&self) -> &[u64] {
        &self.global_ids
    }

    pub fn leaves(&self) -> usize {
        self.volume.leaves
    }

    pub fn reached_tolerance(&self) -> f64 {
        self.volume.tolerance
    }

    pub fn error_bound(&self) -> f64 {
        self.volume.error_bound
    }

    pub fn warnings(&self) -> Result<Vec<String>, String> {
        guard("reading the interval volume", || {
            Ok(self.volume.warnings.clone())
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{build_isosurfaces_with, GridSpec};

    fn spec(range: [f64; 2], tolerance: f64) -> IntervalSpec {
        IntervalSpec {
            range,
            tolerance,
            max_tetrahedra: 0,
            use_region_of_interest: false,
            region_of_interest: [0.0; 6],
        }
    }

    #[test]
    fn interval_volume_through_the_bridge() {
        // A distance field on 17³ points: the range [2, 4] is a spherical shell.
        let grid = GridSpec {
            dims: [17, 17, 17],
            origin: [0.0; 3],
            spacing: [0.5; 3],
        };
        let values: Vec<f32> = (0..17 * 17 * 17)
            .map(|i| {
                let p = [i % 17, i / 17 % 17, i / 289].map(|c| c as f32 * 0.5 - 4.0);
                (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
            })
            .collect();
        let bytes: &[u8] = bytemuck::cast_slice(&values);
        let h = build_isosurfaces_with(&grid, ScalarType::F32, bytes).unwrap();
        let mut state = IsoState::default();
        let v = h
            .interval_volume(&mut state, ScalarType::F32, bytes, &spec([2.0, 4.0], 0.0))
            .unwrap();
        let n = v.weights().len();
        assert!(n > 0 && v.points().len() == 3 * n && v.sources().len() == 2 * n);
        assert_eq!(v.tets().len(), 4 * v.levels().len());
        assert!(v.warnings().unwrap().is_empty());
        // Bad ranges are errors with the core's message, and clear the state.
        let e = h
            .interval_volume(&mut state, ScalarType::F32, bytes, &spec([4.0, 2.0], 0.0))
            .err()
            .unwrap();
        assert!(e.contains("is empty"), "{e}");
        assert!(state.hierarchy.is_some() && state.state.last().is_none());
        let e = h
            .interval_volume(
                &mut state,
                ScalarType::F32,
                &bytes[4..],
                &spec([2.0, 4.0], 0.0),
            )
            .err()
            .unwrap();
        assert!(e.contains("built for"), "{e}");
        // One rank holding the whole extent (extents as C++ gives them; an exchange with no
        // other rank): its share is the whole volume, points under their own ids; a bad extent
        // is an error. (Shares of several ranks: the core's `shared_pieces_extract_the_serial_volume`
        // runs them in threads, `tests/pvpython/mpi_interval.py` under MPI.)
        struct Alone;
        impl Exchange for Alone {
            fn all_gather(&self, bytes: Vec<u8>) -> diamonds::Result<Vec<Vec<u8>>> {
                Ok(vec![bytes])
            }
        }
        let whole = h
            .interval_volume(&mut state, ScalarType::F32, bytes, &spec([2.0, 4.0], 0.3))
            .unwrap();
        assert!(whole.global_point_ids().is_empty());
        let pieces = [0, 16, 0, 16, 0, 16];
        let share = h
            .interval_share(
                &mut state,
                ScalarType::F32,
                bytes,
                &spec([2.0, 4.0], 0.3),
                &pieces,
                0,
                &Alone,
            )
            .unwrap();
        let n = whole.weights().len() as u64;
        assert_eq!(share.global_point_ids(), (0..n).collect::<Vec<_>>());
        assert_eq!(share.points(), whole.points());
        assert_eq!(share.tets(), whole.tets());
        assert_eq!(share.levels(), whole.levels());
        let e = h
            .interval_share(
                &mut state,
                ScalarType::F32,
                bytes,
                &spec([2.0, 4.0], 0.3),
                &pieces[..5],
                0,
                &Alone,
            )
            .err()
            .unwrap();
        assert!(!e.is_empty());
    }
}
