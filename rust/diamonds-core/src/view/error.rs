//! The view-dependent error of a diamond and frustum culling (Gregorski §4, §6.2; Marchesin §4).
//!
//! Gregorski projects a diamond's world-space error onto the screen at the diamond's distance from
//! the eye, in pixels (§6.2); Marchesin divides the approximation error by the distance to the
//! observer, and gives 0 to a tetrahedron outside the view frustum (§4.1, Eq. 1). Both are
//! `e · k / d`; [`Metric`] chooses the constant:
//! - [`Metric::ScreenSpace`]: pixels. The world error of a diamond is its approximation error read
//!   as a height over the domain, the value range spanning the domain's diagonal (Marchesin §1's
//!   analogy of the 3-D scalar function with ROAM's height field), projected at distance `d` by a
//!   camera whose viewport is `h` pixels high under a vertical view angle `θ`:
//!   `pixels = e · (diagonal / range) · (h / 2) / tan(θ / 2) / d`.
//! - [`Metric::DistanceRatio`]: Marchesin's `e / d` (data units per world unit).
//!
//! **Nested bounds** (Marchesin §4.2's hierarchical error bound, ROAM's nested wedgies). For the
//! split and merge queues to reach a unique mesh — the fresh refinement of each view, whatever the
//! mesh they start from ([`super::queues`]) — a diamond's view error must never be below a
//! child's. So `e` is the largest approximation error in the diamond's subtree of the hierarchy
//! ([`ViewErrors`], computed once, 2 bytes per point), and `d` and the frustum test use a box around
//! the central vertex `c` that holds every descendant's tetrahedra ([`subtree_box`]): `c ± 3s` for a
//! 0-diamond of scale `s`, `c ± 2s` for a 2-diamond, `c ± 3s` across a 1-diamond's face and `± 2s`
//! along its normal. A child is offset from a parent by `s` along a parent's axis (0 → 1: the
//! child's normal; 1 → 2: an axis in the face) or by `s/2` on every axis (2 → 0 of scale `s/2`),
//! so every child's box lies in every parent's box (with equality on some faces: these are the
//! smallest such boxes). The price is refinement a little ahead of the view: the distance is that
//! of the nearest possible descendant, and a coarse diamond is culled only when all its
//! descendants are. `d` is at least the smallest spacing (an eye inside a box sees its error as
//! one voxel away).

use crate::diamond::{Class, Diamond};
use crate::hierarchy::record::{decode_error, encode_error};
use crate::lattice::Lattice;
use crate::memory;
use crate::volume::Grid;
use crate::{Error, Hierarchy, Result};
use glam::{DQuat, DVec3, IVec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU16, Ordering};

/// A perspective camera, as VTK's `vtkCamera` describes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position (world).
    pub position: [f64; 3],
    /// The point looked at (world).
    pub focal_point: [f64; 3],
    /// Up direction (not parallel to the view direction).
    pub view_up: [f64; 3],
    /// Vertical view angle in degrees, in (0, 180).
    pub view_angle: f64,
    /// Viewport width and height in pixels, both ≥ 1.
    pub viewport: [u32; 2],
}

impl Camera {
    /// The camera turned by `degrees` about its view-up axis through its focal point (one step of
    /// an orbit).
    pub fn orbited(&self, degrees: f64) -> Result<Self> {
        let axis = DVec3::from(self.view_up).normalize_or_zero();
        if axis == DVec3::ZERO || !degrees.is_finite() {
            return Err(Error::Parameter(format!(
                "an orbit needs a non-zero view up and a finite angle (got {:?}, {degrees})",
                self.view_up
            )));
        }
        let turn = DQuat::from_axis_angle(axis, degrees.to_radians());
        let focal = DVec3::from(self.focal_point);
        let position = focal + turn * (DVec3::from(self.position) - focal);
        Ok(Self {
            position: position.to_array(),
            ..*self
        })
    }
}

/// The unit of the view-dependent error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Metric {
    /// Gregorski's screen-space error, in pixels.
    ScreenSpace,
    /// Marchesin's approximation error over distance (data units per world unit).
    DistanceRatio,
}

/// The lattice box `(lo, hi)` holding the tetrahedra of `d` and of all its descendants (see the
/// module's documentation for why a child's box lies in its parents').
pub fn subtree_box(d: Diamond) -> (IVec3, IVec3) {
    let s = d.scale();
    let half = match d.class() {
        Class::Cube => IVec3::splat(3 * s),
        Class::Face => {
            let mut h = IVec3::splat(3 * s);
            h[d.face_axes().2] = 2 * s;
            h
        }
        Class::Edge => IVec3::splat(2 * s),
    };
    (d.center - half, d.center + half)
}

/// Upper bounds of the approximation error of each diamond's subtree (Marchesin §4.2), one bfloat16
/// per grid point (the diamond centred there), rounded up like the hierarchy's own errors.
#[derive(Debug)]
pub struct ViewErrors {
    lattice: Lattice,
    grid: Grid,
    value_range: (f64, f64),
    nested: Vec<u16>,
}

impl ViewErrors {
    /// The nested bounds of `hierarchy`, finest diamonds first, each level's in parallel.
    pub fn new(hierarchy: &Hierarchy) -> Result<Self> {
        if !hierarchy.has_records() {
            return Err(Error::Parameter(
                "this hierarchy was built for isosurfaces only: it holds no per-diamond errors"
                    .into(),
            ));
        }
        let lattice = *hierarchy.lattice();
        let grid = *hierarchy.grid();
        let mut nested: Vec<AtomicU16> = memory::with_capacity(grid.len(), "the view errors")?;
        nested.extend((0..grid.len()).map(|_| AtomicU16::new(0)));
        let bound = |d: Diamond| {
            if lattice.in_domain(d.center) {
                nested[lattice.index(d.center)].load(Ordering::Relaxed)
            } else {
                0
            }
        };
        // Children of a class-0 diamond are class 1 of its scale, of class 1 class 2 of its scale,
        // of class 2 class 0 of half its scale: finest scale first, classes 2, 1, 0 within it.
        for sigma in 0..lattice.levels {
            let s = 1i32 << sigma;
            for class in [Class::Edge, Class::Face, Class::Cube] {
                let odd = 3 - class as i32; // coordinates of c / s that are odd
                (0..=lattice.hi.z / s).into_par_iter().for_each(|k| {
                    for j in 0..=lattice.hi.y / s {
                        for i in 0..=lattice.hi.x / s {
                            if (i & 1) + (j & 1) + (k & 1) != odd {
                                continue;
                            }
                            let d = Diamond::new(IVec3::new(i, j, k) * s);
                            let children = d.children(&lattice).into_iter().map(bound).max();
                            let own = encode_error(hierarchy.error(d));
                            nested[lattice.index(d.center)]
                                .store(own.max(children.unwrap_or(0)), Ordering::Relaxed);
                        }
                    }
                });
            }
        }
        Ok(Self {
            lattice,
            grid,
            value_range: hierarchy.value_range(),
            nested: nested.into_iter().map(AtomicU16::into_inner).collect(),
        })
    }

    /// The largest approximation error in `d`'s subtree (0 for a diamond centred outside the
    /// domain: split in the base mesh or without tetrahedra).
    #[inline]
    pub fn subtree_error(&self, d: Diamond) -> f64 {
        if self.lattice.in_domain(d.center) {
            decode_error(self.nested[self.lattice.index(d.center)])
        } else {
            0.0
        }
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.nested.len() * std::mem::size_of::<u16>()
    }

    /// The lattice of the hierarchy the bounds belong to.
    pub(crate) fn lattice(&self) -> &Lattice {
        &self.lattice
    }
}

/// One view: the camera's frustum and the constants of the error, in world coordinates.
#[derive(Clone, Debug)]
pub struct View {
    eye: DVec3,
    /// Inward normals of the planes through the eye bounding the frustum (sides and the eye plane).
    planes: [DVec3; 5],
    /// `k` of `e · k / d`.
    scale: f64,
    /// The smallest distance an error is projected at.
    nearest: f64,
    origin: DVec3,
    spacing: DVec3,
}

impl View {
    /// The view of `camera` over the grid of `errors` with `metric`; refuses a degenerate camera.
    pub fn new(camera: &Camera, errors: &ViewErrors, metric: Metric) -> Result<Self> {
        let Camera {
            position,
            focal_point,
            view_up,
            view_angle,
            viewport,
        } = *camera;
        let finite = |v: [f64; 3]| v.iter().all(|c| c.is_finite());
        if !(finite(position) && finite(focal_point) && finite(view_up)) {
            return Err(Error::Parameter(format!(
                "camera position {position:?}, focal point {focal_point:?} and view up {view_up:?} must be finite"
            )));
        }
        if !(view_angle > 0.0 && view_angle < 180.0) {
            return Err(Error::Parameter(format!(
                "the view angle must be between 0 and 180 degrees (got {view_angle})"
            )));
        }
        if viewport.contains(&0) {
            return Err(Error::Parameter(format!(
                "the viewport must be at least 1 × 1 pixels (got {} × {})",
                viewport[0], viewport[1]
            )));
        }
        let eye = DVec3::from(position);
        let forward = (DVec3::from(focal_point) - eye).normalize_or_zero();
        if forward == DVec3::ZERO {
            return Err(Error::Parameter(format!(
                "the camera position {position:?} and focal point are the same point: no view direction"
            )));
        }
        let right = forward.cross(DVec3::from(view_up)).normalize_or_zero();
        if right == DVec3::ZERO {
            return Err(Error::Parameter(format!(
                "the view up {view_up:?} is parallel to the view direction (or zero)"
            )));
        }
        let up = right.cross(forward);
        let tan_v = (view_angle.to_radians() / 2.0).tan();
        let tan_h = tan_v * viewport[0] as f64 / viewport[1] as f64;
        let planes = [
            (forward * tan_h - right).normalize(),
            (forward * tan_h + right).normalize(),
            (forward * tan_v - up).normalize(),
            (forward * tan_v + up).normalize(),
            forward,
        ];
        let grid = &errors.grid;
        let (lo, hi) = errors.value_range;
        let scale = match metric {
            Metric::DistanceRatio => 1.0,
            Metric::ScreenSpace if hi > lo => {
                grid.diagonal() / (hi - lo) * (viewport[1] as f64 / 2.0) / tan_v
            }
            Metric::ScreenSpace => 0.0, // a constant volume has no error
        };
        let spacing = DVec3::from(grid.spacing);
        Ok(Self {
            eye,
            planes,
            scale,
            nearest: spacing.min_element(),
            origin: DVec3::from(grid.origin),
            spacing,
        })
    }

    /// The view-dependent error of `d` given its subtree error `e`: 0 when the box of its
    /// subtree lies outside the frustum, else `e · k / d` at the box's nearest distance `d`.
    #[inline]
    pub fn error(&self, d: Diamond, e: f64) -> f64 {
        if e == 0.0 {
            return 0.0;
        }
        let (lo, hi) = subtree_box(d);
        let lo = self.origin + lo.as_dvec3() * self.spacing;
        let hi = self.origin + hi.as_dvec3() * self.spacing;
        // Outside when the box's corner farthest along a plane's inward normal is behind it.
        let outside = self.planes.iter().any(|n| {
            let corner = DVec3::select(n.cmpge(DVec3::ZERO), hi, lo);
            n.dot(corner - self.eye) < 0.0
        });
        if outside {
            return 0.0; // invisible: never split, merged first (Gregorski §6.2)
        }
        let distance = (self.eye.clamp(lo, hi) - self.eye)
            .length()
            .max(self.nearest);
        e * self.scale / distance
    }

    /// The eye position.
    pub fn eye(&self) -> [f64; 3] {
        self.eye.to_array()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diamond::all_diamonds;
    use crate::fields::marschner_lobb_u8;
    use crate::ScalarSlice;

    fn camera(position: [f64; 3]) -> Camera {
        Camera {
            position,
            focal_point: [0.0; 3],
            view_up: [0.0, 0.0, 1.0],
            view_angle: 30.0,
            viewport: [400, 300],
        }
    }

    #[test]
    fn view_error_never_grows_from_parent_to_child() {
        // The property the split and merge queues rely on, over every diamond, for eyes outside,
        // inside, and looking away; anisotropic spacing.
        let dims = [17, 13, 17];
        let (mut g, v) = marschner_lobb_u8(dims);
        g.spacing = [0.11, 0.2, 0.07];
        let h = Hierarchy::build(g, ScalarSlice::U8(&v), &mut |_| true).unwrap();
        let errors = ViewErrors::new(&h).unwrap();
        let lattice = *h.lattice();
        let diamonds: Vec<Diamond> = all_diamonds(&lattice)
            .into_iter()
            .filter(|d| lattice.in_domain(d.center))
            .collect();
        for d in &diamonds {
            assert!(errors.subtree_error(*d) >= h.error(*d));
        }
        let mut visible = 0;
        for (position, metric) in [
            ([4.0, -3.0, 2.0], Metric::ScreenSpace),
            ([0.3, 0.2, 0.1], Metric::DistanceRatio),
            ([-0.9, 0.95, -0.5], Metric::ScreenSpace),
        ] {
            let view = View::new(&camera(position), &errors, metric).unwrap();
            let err = |d: Diamond| view.error(d, errors.subtree_error(d));
            for &d in &diamonds {
                for c in d.children(&lattice) {
                    if lattice.in_domain(c.center) {
                        assert!(err(c) <= err(d), "{d:?} → {c:?} at {position:?}");
                    }
                }
                visible += usize::from(err(d) > 0.0);
            }
        }
        assert!(visible > 0);
        // Looking away from the volume: every diamond whose subtree box lies behind the eye is
        // culled, and every tetrahedron of the hierarchy lies in its diamond's box.
        let mut away = camera([3.0, 0.0, 0.0]);
        away.focal_point = [6.0, 0.0, 0.0];
        let view = View::new(&away, &errors, Metric::ScreenSpace).unwrap();
        let mut behind = 0;
        for &d in &diamonds {
            let (lo, hi) = subtree_box(d);
            for t in d.tets(&lattice) {
                assert!(t.iter().all(|p| p.cmpge(lo).all() && p.cmple(hi).all()));
            }
            let world_hi = g.origin[0] + g.spacing[0] * hi.x as f64;
            if world_hi < 3.0 {
                behind += 1;
                assert_eq!(view.error(d, errors.subtree_error(d)), 0.0, "{d:?}");
            }
        }
        assert!(behind > diamonds.len() / 2);
    }

    #[test]
    fn degenerate_cameras_are_refused() {
        let (g, v) = marschner_lobb_u8([9, 9, 9]);
        let h = Hierarchy::build(g, ScalarSlice::U8(&v), &mut |_| true).unwrap();
        let errors = ViewErrors::new(&h).unwrap();
        let good = camera([3.0, 2.0, 1.0]);
        assert!(View::new(&good, &errors, Metric::ScreenSpace).is_ok());
        let bad = [
            Camera {
                position: [f64::NAN, 0.0, 0.0],
                ..good
            },
            Camera {
                focal_point: good.position,
                ..good
            },
            Camera {
                view_up: [3.0, 2.0, 1.0],
                ..good
            },
            Camera {
                view_up: [0.0; 3],
                ..good
            },
            Camera {
                view_angle: 0.0,
                ..good
            },
            Camera {
                view_angle: f64::NAN,
                ..good
            },
            Camera {
                viewport: [0, 300],
                ..good
            },
        ];
        for camera in bad {
            let err = View::new(&camera, &errors, Metric::ScreenSpace).unwrap_err();
            assert!(matches!(err, Error::Parameter(_)), "{camera:?}: {err}");
        }
    }
}
