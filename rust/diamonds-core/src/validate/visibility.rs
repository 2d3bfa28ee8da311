//! Visibility orders of tetrahedra, checked face by face without the bisection tree: for every
//! interior face shared by tetrahedra A and B, the one on the far side of the face's plane from the
//! eye must come first in a back-to-front order. (For a conforming mesh this is the whole of the
//! requirement between neighbours; a face whose plane holds the eye orders nothing: neither
//! tetrahedron can hide the other.)

use glam::DVec3;
use rustc_hash::FxHashMap;

/// What [`check_back_to_front`] compared.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VisibilityReport {
    /// Interior faces whose two tetrahedra were found in the right order.
    pub checked: usize,
    /// Interior faces whose plane holds the eye (either order is right).
    pub on_plane: usize,
}

/// Checks that `order` (indices into `tets`, corners indexing `points`) is a permutation of the
/// tetrahedra and a back-to-front order for an eye at `eye` (same coordinates as `points`): for every
/// face shared by two tetrahedra, the one whose fourth vertex lies on the other side of the face's
/// plane than the eye comes first. Reverse a front-to-back order before checking it.
pub fn check_back_to_front(
    points: &[[f64; 3]],
    tets: &[[u32; 4]],
    order: &[u32],
    eye: [f64; 3],
) -> Result<VisibilityReport, String> {
    if order.len() != tets.len() {
        return Err(format!(
            "the order has {} entries for {} tetrahedra",
            order.len(),
            tets.len()
        ));
    }
    let mut position = vec![u32::MAX; tets.len()];
    for (k, &t) in order.iter().enumerate() {
        match position.get_mut(t as usize) {
            Some(p) if *p == u32::MAX => *p = k as u32,
            Some(_) => return Err(format!("tetrahedron {t} comes twice in the order")),
            None => return Err(format!("the order names tetrahedron {t} of {}", tets.len())),
        }
    }
    let p = |i: u32| DVec3::from(points[i as usize]);
    let eye = DVec3::from(eye);
    // Sign of the side of `x` from the plane of `f`, 0 within rounding of the plane.
    let side = |f: [u32; 3], x: DVec3| -> i32 {
        let (a, b, c) = (p(f[0]), p(f[1]), p(f[2]));
        let (u, v, w) = (b - a, c - a, x - a);
        let det = u.cross(v).dot(w);
        let bound = 1e-12 * u.length() * v.length() * w.length();
        if det.abs() <= bound {
            0
        } else {
            det.signum() as i32
        }
    };
    let mut faces: FxHashMap<[u32; 3], (u32, u32)> = FxHashMap::default();
    let mut report = VisibilityReport {
        checked: 0,
        on_plane: 0,
    };
    for (t, corners) in tets.iter().enumerate() {
        for skip in 0..4 {
            let mut f = [0u32; 3];
            let mut k = 0;
            for (i, &v) in corners.iter().enumerate() {
                if i != skip {
                    f[k] = v;
                    k += 1;
                }
            }
            f.sort_unstable();
            let Some((other, other_apex)) = faces.remove(&f) else {
                faces.insert(f, (t as u32, corners[skip]));
                continue;
            };
            let eye_side = side(f, eye);
            if eye_side == 0 {
                report.on_plane += 1;
                continue;
            }
            // The tetrahedron whose apex is on the other side than the eye is the far one.
            let (far, near) = if side(f, p(corners[skip])) == eye_side {
                (other, t as u32)
            } else if side(f, p(other_apex)) == eye_side {
                (t as u32, other)
            } else {
                return Err(format!(
                    "tetrahedra {other} and {t} share face {f:?} but lie on one side of it"
                ));
            };
            if position[far as usize] > position[near as usize] {
                return Err(format!(
                    "tetrahedron {far} (behind face {f:?} seen from {eye}) comes after {near} \
                     (positions {} and {})",
                    position[far as usize], position[near as usize]
                ));
            }
            report.checked += 1;
        }
    }
    Ok(report)
}
