//! The field error of each tetrahedron of a level (the `FieldError` cell data): the largest error of
//! the removed original vertices it holds, found by point location in an R-tree of the level's
//! tetrahedra (a vertex outside the mesh, where the boundary moved, counts for the nearest one, at
//! the nearest place of it).

use super::cost::{barycentric, interpolate};
use super::record::{ProgressiveMesh, Replay};
use glam::DVec3;
use rayon::prelude::*;
use rstar::primitives::{GeomWithData, Rectangle};
use rstar::RTree;

impl Replay {
    /// For each tetrahedron of the current level (in [`Replay::live_tets`] order), the largest
    /// `|f(v) - L(v)|` over the removed original vertices `v` inside it (0 if none).
    pub fn field_errors(&self, pm: &ProgressiveMesh) -> Vec<f64> {
        let live: Vec<[u32; 4]> = self.live_tets().map(|(_, t)| t).collect();
        let corners = |t: &[u32; 4]| t.map(|v| DVec3::from_array(pm.points[v as usize]));
        let boxes: Vec<GeomWithData<Rectangle<[f64; 3]>, u32>> = live
            .iter()
            .enumerate()
            .map(|(k, t)| {
                let x = corners(t);
                let lo = x.iter().fold(DVec3::INFINITY, |a, &p| a.min(p));
                let hi = x.iter().fold(DVec3::NEG_INFINITY, |a, &p| a.max(p));
                GeomWithData::new(
                    Rectangle::from_corners(lo.to_array(), hi.to_array()),
                    k as u32,
                )
            })
            .collect();
        let tree = RTree::bulk_load(boxes);
        let mut present = vec![false; pm.points.len()];
        for t in &live {
            for &v in t {
                present[v as usize] = true;
            }
        }
        let value = |k: u32, p: DVec3| -> (f64, f64) {
            let t = &live[k as usize];
            let b = barycentric(&corners(t), p);
            let inside = b.iter().copied().fold(f64::INFINITY, f64::min);
            (inside, interpolate(b, t.map(|v| pm.scalars[v as usize])))
        };
        let placed: Vec<(u32, f64)> = pm
            .removable()
            .par_iter()
            .filter(|&&v| !present[v as usize])
            .filter_map(|&v| {
                let p = DVec3::from_array(pm.points[v as usize]);
                let best = tree
                    .locate_all_at_point(&p.to_array())
                    .map(|g| (g.data, value(g.data, p)))
                    .max_by(|a, b| a.1 .0.total_cmp(&b.1 .0))
                    .filter(|(_, (inside, _))| *inside >= -1e-9)
                    .or_else(|| {
                        let g = tree.nearest_neighbor(&p.to_array())?;
                        Some((g.data, value(g.data, p)))
                    })?;
                Some((best.0, (pm.scalars[v as usize] - best.1 .1).abs()))
            })
            .collect();
        let mut errors = vec![0.0; live.len()];
        for (k, e) in placed {
            errors[k as usize] = f64::max(errors[k as usize], e);
        }
        errors
    }
}
