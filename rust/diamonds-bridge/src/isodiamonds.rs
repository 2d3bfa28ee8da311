//! The isodiamond half of the bridge (Weiss & De Floriani §5–§7): the `Hierarchy` choice of
//! `vtkAdaptiveIsosurface` and `vtkAdaptiveIntervalVolume`. In: the samples once, to build a
//! relevant (RI) or minimal (MI) hierarchy of one isosurface or interval volume
//! ([`diamonds::isodiamond`]); then queries that read no sample. Out: the same [`Surface`] and
//! [`IntervalVolume`] as the full hierarchy's queries, checked before C++ indexes with them.

use diamonds::isodiamond::{self, Model, Target, DEFAULT_LADDER};
use diamonds::validate::{check_interval_arrays, check_isosurface_arrays};
use diamonds::IsoSurface;

use crate::ffi::{IntervalSpec, IsoSpec, ProgressObserver, ScalarType};
use crate::interval::IntervalVolume;
use crate::{check_core, guard, reporter, typed_slice, Hierarchy, IsoState, Surface};
use std::pin::Pin;

/// Opaque handle on a [`diamonds::isodiamond::Isodiamonds`] for C++.
pub struct Isodiamonds {
    hierarchy: isodiamond::Isodiamonds,
    /// Points of the grid it was built on (sources of interval-volume points index them).
    grid_points: usize,
}

impl Hierarchy {
    /// Builds an RI or MI hierarchy (see `ffi::Hierarchy::build_isodiamonds`).
    pub fn build_isodiamonds(
        &self,
        scalar_type: ScalarType,
        samples: &[u8],
        levels: &[f64],
        minimal: bool,
        mut progress: Pin<&mut ProgressObserver>,
    ) -> Result<Box<Isodiamonds>, String> {
        guard("building the isodiamond hierarchy", || {
            let mut report = reporter(progress.as_mut());
            let target = match *levels {
                [v] => Target::Isosurface(v),
                [a, b] => Target::IntervalVolume([a, b]),
                _ => {
                    return Err(format!(
                        "an isodiamond hierarchy encodes one isosurface or one interval volume (one or two values, got {})",
                        levels.len()
                    ))
                }
            };
            let scalars = typed_slice(scalar_type, samples)?;
            let grid = *self.hierarchy.grid();
            let ladder: Vec<f64> = DEFAULT_LADDER.iter().map(|r| r * grid.diagonal()).collect();
            let model = if minimal {
                Model::Minimal
            } else {
                Model::Relevant
            };
            let hierarchy = isodiamond::build(
                &self.hierarchy,
                scalars,
                target,
                model,
                &ladder,
                &mut report,
            )
            .map_err(|e| e.to_string())?;
            Ok(Box::new(Isodiamonds {
                hierarchy,
                grid_points: grid.len(),
            }))
        })
    }
}

/// Whether an isodiamond hierarchy's extraction accepts these options (see
/// `ffi::check_isodiamond_query`).
pub fn check_isodiamond_query(
    region_of_interest: bool,
    carrier_tetrahedra: bool,
) -> Result<(), String> {
    guard("checking the isodiamond query", || {
        isodiamond::Isodiamonds::refuse_unsupported(region_of_interest, carrier_tetrahedra)
            .map_err(|e| e.to_string())
    })
}

impl Isodiamonds {
    /// The isosurface of `spec` (see `ffi::Isodiamonds::isosurface`).
    pub fn isosurface(&self, isovalues: &[f64], spec: &IsoSpec) -> Result<Box<Surface>, String> {
        guard(
            "extracting the isosurface from the isodiamond hierarchy",
            || {
                let query = spec.query(isovalues);
                let surface: IsoSurface = self
                    .hierarchy
                    .isosurface_query(&query)
                    .map_err(|e| e.to_string())?;
                check_core(check_isosurface_arrays(&surface, &query, self.grid_points))?;
                Ok(Box::new(Surface {
                    surface,
                    carrier: None,
                }))
            },
        )
    }

    /// The interval volume of `spec` (see `ffi::Isodiamonds::interval_volume`).
    pub fn interval_volume(&self, spec: &IntervalSpec) -> Result<Box<IntervalVolume>, String> {
        guard(
            "extracting the interval volume from the isodiamond hierarchy",
            || {
                let query = spec.query();
                let volume = self
                    .hierarchy
                    .interval_volume_query(&query)
                    .map_err(|e| e.to_string())?;
                check_core(check_interval_arrays(&volume, self.grid_points))?;
                Ok(Box::new(IntervalVolume {
                    volume,
                    global_ids: Vec::new(),
                }))
            },
        )
    }

    pub fn memory_bytes(&self) -> usize {
        self.hierarchy.memory_bytes()
    }

    pub fn ladder(&self) -> &[f64] {
        self.hierarchy.ladder()
    }
}

impl IsoState {
    pub fn memory_bytes(&self) -> usize {
        self.state.memory_bytes()
    }
}
