//! View-dependent meshes for `vtkViewDependentTetrahedra` and their exact visibility order for
//! `vtkDiamondsVisibilitySort` (Gregorski §4, §6.2, §8; Marchesin §6), see `diamonds::view`.
//!
//! A [`ViewMesh`] is what the filter keeps between executions next to its hierarchy: the nested
//! view-error bounds and the split and merge queues' state, so that a new camera starts from the
//! previous frame's mesh. Its meshes are [`MeshPlan`]s, written by the same code as Adaptive
//! Tetrahedra's. A mesh carries the bisection path of each tetrahedron as a cell array; a
//! [`PathOrder`] rebuilds the BSP tree from those paths wherever the cells went, and orders them
//! for any eye.

use crate::ffi::{GridSpec, ViewFrame, ViewSpec};
use crate::{core_grid, guard, Hierarchy, MeshPlan};
use diamonds::view::{BspTree, Camera, Direction, Metric, ViewErrors, ViewQuery, ViewState};

/// Opaque handle on the view-dependent state of one hierarchy (identified as in [`MeshPlan`]).
pub struct ViewMesh {
    errors: ViewErrors,
    state: ViewState,
    hierarchy: u64,
}

/// Opaque handle on the BSP tree of a set of cells rebuilt from their bisection paths.
pub struct PathOrder(BspTree);

/// The eye position from a slice of three coordinates.
fn eye_of(eye: &[f64]) -> Result<[f64; 3], String> {
    <[f64; 3]>::try_from(eye)
        .map_err(|_| format!("an eye position has 3 coordinates (got {})", eye.len()))
}

/// The state of `hierarchy`'s base mesh and its view-error bounds (2 bytes per point).
pub fn new_view_mesh(hierarchy: &Hierarchy) -> Result<Box<ViewMesh>, String> {
    guard("preparing the view-dependent refinement", || {
        let errors = ViewErrors::new(&hierarchy.hierarchy).map_err(|e| e.to_string())?;
        Ok(Box::new(ViewMesh {
            errors,
            state: ViewState::new(&hierarchy.hierarchy),
            hierarchy: hierarchy.id,
        }))
    })
}

impl ViewMesh {
    /// Whether this state belongs to `hierarchy` (a rebuilt hierarchy needs a new state).
    pub fn belongs_to(&self, hierarchy: &Hierarchy) -> bool {
        self.hierarchy == hierarchy.id
    }

    /// Splits and merges from the current mesh to the mesh of `spec`'s view
    /// ([`ViewState::update`]); the state is left as it was when the update fails.
    pub fn update_view(
        &mut self,
        hierarchy: &Hierarchy,
        spec: &ViewSpec,
    ) -> Result<ViewFrame, String> {
        guard("refining for the view", || {
            if !self.belongs_to(hierarchy) {
                return Err("the view state belongs to another hierarchy".into());
            }
            let query = ViewQuery {
                camera: Camera {
                    position: spec.position,
                    focal_point: spec.focal_point,
                    view_up: spec.view_up,
                    view_angle: spec.view_angle,
                    viewport: spec.viewport,
                },
                metric: Metric::ScreenSpace,
                tolerance: spec.pixel_tolerance,
                max_tetrahedra: spec.max_tetrahedra,
            };
            let mut next = self.state.clone();
            let stats = next
                .update(&hierarchy.hierarchy, &self.errors, &query)
                .map_err(|e| e.to_string())?;
            self.state = next;
            Ok(ViewFrame {
                splits: stats.splits,
                merges: stats.merges,
                tets: stats.tets,
                tolerance: stats.tolerance,
                evaluated: stats.evaluated,
                seconds: stats.seconds,
            })
        })
    }

    /// The current mesh, counted, to be written like a query's ([`MeshPlan`]).
    pub fn view_plan(&self, hierarchy: &Hierarchy) -> Result<Box<MeshPlan>, String> {
        guard("counting the view-dependent mesh", || {
            if !self.belongs_to(hierarchy) {
                return Err("the view state belongs to another hierarchy".into());
            }
            let plan = self.state.plan().map_err(|e| e.to_string())?;
            Ok(Box::new(MeshPlan {
                plan,
                hierarchy: hierarchy.id,
            }))
        })
    }
}

impl Hierarchy {
    /// The grid the hierarchy was built for (what a [`PathOrder`] needs with the paths).
    pub fn grid_spec(&self) -> GridSpec {
        let g = self.hierarchy.grid();
        GridSpec {
            dims: g.dims,
            origin: g.origin,
            spacing: g.spacing,
        }
    }

    /// Has `plan` write its tetrahedra in exact visibility order from `eye` (`sort` 1: back to
    /// front, 2: front to back; 0: in ascending bisection-path order, as planned)
    /// ([`diamonds::mesh::MeshPlan::set_visibility_order`]).
    pub fn order_plan(&self, plan: &mut MeshPlan, sort: u8, eye: &[f64]) -> Result<(), String> {
        guard("ordering the tetrahedra", || {
            if plan.hierarchy != self.id {
                return Err("the mesh plan belongs to another hierarchy".into());
            }
            let direction = match sort {
                0 => return Ok(()),
                1 => Direction::BackToFront,
                2 => Direction::FrontToBack,
                _ => return Err(format!("SortCells must be 0, 1 or 2 (got {sort})")),
            };
            plan.plan
                .set_visibility_order(self.hierarchy.grid(), eye_of(eye)?, direction)
                .map_err(|e| e.to_string())
        })
    }
}

impl MeshPlan {
    /// Writes the bisection path of each tetrahedron, in the order the tetrahedra are written.
    pub fn write_paths(&self, paths: &mut [u64]) -> Result<(), String> {
        guard("writing the bisection paths", || {
            self.plan.write_paths(paths).map_err(|e| e.to_string())
        })
    }
}

/// The BSP tree of the cells whose bisection paths are `paths` (cell `i` has `paths[i]`), on the
/// grid of the hierarchy they were refined on ([`BspTree::from_paths`]).
pub fn new_path_order(grid: &GridSpec, paths: &[u64]) -> Result<Box<PathOrder>, String> {
    guard("rebuilding the visibility order", || {
        BspTree::from_paths(&core_grid(grid), paths)
            .map(|tree| Box::new(PathOrder(tree)))
            .map_err(|e| e.to_string())
    })
}

impl PathOrder {
    /// Number of cells ordered.
    pub fn number_of_cells(&self) -> usize {
        self.0.tets()
    }

    /// Writes the cell ids in visibility order for an eye at `eye` into `cells` (one slot per
    /// cell).
    pub fn order_cells(
        &self,
        eye: &[f64],
        front_to_back: bool,
        cells: &mut [i64],
    ) -> Result<(), String> {
        guard("ordering the cells", || {
            let direction = if front_to_back {
                Direction::FrontToBack
            } else {
                Direction::BackToFront
            };
            let order = self
                .0
                .order(eye_of(eye)?, direction)
                .map_err(|e| e.to_string())?;
            if cells.len() != order.len() {
                return Err(format!(
                    "room for {} cells, the order has {}",
                    cells.len(),
                    order.len()
                ));
            }
            for (c, &i) in cells.iter_mut().zip(&order) {
                *c = i64::from(i);
            }
            Ok(())
        })
    }
}
