//! Exact visibility order of a mesh's tetrahedra from the bisection tree (Marchesin §6).
//!
//! Every bisection splits a tetrahedron by the plane through its spine's midpoint and its two other
//! vertices, so the bisection tree of a mesh *is* a binary space partition of it ("hierarchically
//! splitting tetrahedra into two using a plane … implicitly corresponds to building a binary space
//! partition", Marchesin §6, Algorithm 2). Above it, the six root tetrahedra (Kuhn's split of the
//! root cube around its diagonal `x = y = z`) are the cells of the three planes `x = y`, `x = z`,
//! `y = z`, a BSP of three levels. Visiting, at every node, first the child on the far side of its
//! plane from the eye gives a back-to-front order; its reverse is front to back. It is exact for any
//! eye position — perspective, inside the volume, on a plane (then neither side can hide the other)
//! — because two tetrahedra that share a face are separated at their lowest common ancestor by the
//! plane of that face. One visit per node: linear in the number of tetrahedra.
//!
//! [`BspTree`] keeps, for one mesh, the tree's shape with the mesh index of each leaf (4 bytes per
//! node, about 8 bytes per tetrahedron), so that every new eye position costs one traversal.

use crate::diamond::{bisect, Diamond};
use crate::lattice::{Placement, Tet};
use crate::mesh::{pieces, MeshPlan};
use crate::volume::Grid;
use crate::{Error, Result, TetMesh};
use glam::{DVec3, I64Vec3, IVec3};
use rayon::prelude::*;
use rustc_hash::FxHashMap;

/// Which end of the order comes first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// Farthest first (compositing with "over" in drawing order, Marchesin's Algorithm 2).
    BackToFront,
    /// Nearest first.
    FrontToBack,
}

/// A node with no tetrahedra in the domain.
const EMPTY: u32 = u32::MAX;
/// Marks a leaf; the low bits are its index in the mesh.
const LEAF: u32 = 1 << 31;

/// The binary space partition of a mesh's tetrahedra by their bisection planes (Marchesin §6).
#[derive(Clone, Debug)]
pub struct BspTree {
    grid: Grid,
    /// Depth-first, the second child of a bisection right after its parent: a leaf is `LEAF | mesh
    /// index`, a node outside the domain `EMPTY`, an inner node the position of its first child.
    nodes: Vec<u32>,
    /// The six root tetrahedra and the position of their nodes.
    roots: Vec<(Tet, u32)>,
    /// The nodes of the mesh plan's subtrees (its parallel work units) and their numbers of
    /// tetrahedra: an order visits them in turn, then fills each one's slice in parallel.
    subtrees: FxHashMap<u32, usize>,
    tets: usize,
}

impl BspTree {
    /// The tree of `plan`'s mesh on `grid` (the grid the plan's hierarchy was built for): leaves
    /// carry the index each tetrahedron has in the plan's mesh ([`MeshPlan::to_mesh`],
    /// [`MeshPlan::write_tets`]). Linear in the number of tetrahedra.
    pub fn new(plan: &MeshPlan, grid: &Grid) -> Result<Self> {
        let lattice = plan.lattice();
        if grid.dims != plan.grid_dims() {
            return Err(Error::Parameter(format!(
                "the mesh was planned for a grid of {:?} points, not {:?}",
                plan.grid_dims(),
                grid.dims
            )));
        }
        let split = plan.split();
        // Each subtree of the plan with the index of its first tetrahedron and its count.
        let firsts: Vec<(Tet, usize)> = plan.subtrees().map(|(t, i)| (*t, i)).collect();
        let mut first: FxHashMap<Tet, (usize, usize)> = FxHashMap::default();
        for (k, &(t, i)) in firsts.iter().enumerate() {
            let end = firsts.get(k + 1).map_or(plan.tets(), |next| next.1);
            first.insert(t, (i, end - i));
        }
        // Subtrees are the first levels of the tree: no lookups below the deepest.
        let depth_of =
            |t: &Tet| Diamond::of_tet(t).map_or(3 * lattice.levels, |d| d.depth(lattice));
        let deepest = firsts.iter().map(|(t, _)| depth_of(t)).max().unwrap_or(0);
        let mut nodes = Vec::with_capacity(2 * plan.tets() + 64);
        let mut roots = Vec::with_capacity(6);
        let mut subtrees = FxHashMap::default();
        let mut next = 0usize;
        // (tetrahedron, its depth, the inner node whose first child it is)
        let mut stack: Vec<(Tet, u32, Option<usize>)> = Vec::new();
        for t in Diamond::root(lattice).tets(lattice) {
            roots.push((t, nodes.len() as u32));
            stack.push((t, 0, None));
            while let Some((t, depth, parent)) = stack.pop() {
                let at = nodes.len();
                if at >= LEAF as usize {
                    return Err(Error::Parameter(
                        "the mesh is too large for a visibility order (2^31 tree nodes)".into(),
                    ));
                }
                if let Some(p) = parent {
                    nodes[p] = at as u32;
                }
                if depth <= deepest {
                    if let Some(&(i, count)) = first.get(&t) {
                        next = i; // a subtree of the plan: its tetrahedra are numbered from here
                        subtrees.insert(at as u32, count);
                    }
                }
                match lattice.place(&t) {
                    Placement::Outside => nodes.push(EMPTY),
                    _ if Diamond::of_tet(&t).is_some_and(|d| split.contains(d)) => {
                        let [c0, c1] = bisect(&t);
                        nodes.push(EMPTY); // patched when its first child is placed
                        stack.push((c0, depth + 1, Some(at)));
                        stack.push((c1, depth + 1, None));
                    }
                    Placement::Inside => {
                        nodes.push(LEAF | next as u32);
                        next += 1;
                    }
                    Placement::Straddling => {
                        return Err(Error::Parameter(
                            "internal error: an unsplit tetrahedron straddles the domain".into(),
                        ))
                    }
                }
            }
        }
        Ok(Self {
            grid: *grid,
            nodes,
            roots,
            subtrees,
            tets: plan.tets(),
        })
    }

    /// Number of tetrahedra ordered.
    pub fn tets(&self) -> usize {
        self.tets
    }

    /// Bytes the tree holds.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<u32>()
    }

    /// The mesh indices of the tetrahedra in visibility order for an eye at `eye` (world
    /// coordinates, anywhere: outside, inside or on the boundary of the volume).
    pub fn order(&self, eye: [f64; 3], direction: Direction) -> Result<Vec<u32>> {
        let mut out = vec![0u32; self.tets];
        self.order_into(eye, direction, &mut out)?;
        Ok(out)
    }

    /// [`BspTree::order`] written into `out` (exactly one slot per tetrahedron): the subtrees in
    /// order first, then each subtree's tetrahedra into its slice, in parallel.
    pub fn order_into(&self, eye: [f64; 3], direction: Direction, out: &mut [u32]) -> Result<()> {
        if eye.iter().any(|c| !c.is_finite()) {
            return Err(Error::Parameter(format!(
                "the eye position must be finite (got {eye:?})"
            )));
        }
        if out.len() != self.tets {
            return Err(Error::Parameter(format!(
                "visibility order: room for {} tetrahedra, the mesh has {}",
                out.len(),
                self.tets
            )));
        }
        // The eye in lattice coordinates (a positive scaling per axis keeps every side of every plane).
        let eye =
            (DVec3::from(eye) - DVec3::from(self.grid.origin)) / DVec3::from(self.grid.spacing);
        let mut tops = Vec::with_capacity(self.subtrees.len());
        for (t, node) in self.root_order(eye) {
            self.far_first((node, t), eye, |node, t| match self.subtrees.get(&node) {
                Some(&count) => {
                    tops.push((node, *t, count));
                    false
                }
                None => true,
            });
        }
        let counts: Vec<usize> = tops.iter().map(|top| top.2).collect();
        tops.into_par_iter()
            .zip(pieces(out, &counts, 1))
            .for_each(|((node, t, _), slice)| {
                let mut k = 0;
                self.far_first((node, t), eye, |node, _| {
                    let v = self.nodes[node as usize];
                    if v != EMPTY && v & LEAF != 0 {
                        slice[k] = v & !LEAF;
                        k += 1;
                    }
                    true
                });
            });
        if direction == Direction::FrontToBack {
            out.reverse();
        }
        Ok(())
    }

    /// Marchesin's Algorithm 2 below `start` (a node and its tetrahedron): calls `at` on every
    /// node, the far child of every bisection before the near one, and skips the subtrees of the
    /// nodes for which it returns `false`.
    fn far_first(&self, start: (u32, Tet), eye: DVec3, mut at: impl FnMut(u32, &Tet) -> bool) {
        let mut stack: Vec<(u32, Tet)> = Vec::with_capacity(128);
        stack.push(start);
        while let Some((node, t)) = stack.pop() {
            if !at(node, &t) {
                continue;
            }
            let first_child = self.nodes[node as usize];
            if first_child == EMPTY || first_child & LEAF != 0 {
                continue;
            }
            let [c0, c1] = bisect(&t);
            let (n0, n1) = ((first_child, c0), (node + 1, c1));
            // The first child holds the spine's first end: the side of the eye decides.
            let m = (t[0] + t[1]) / 2;
            let normal = wide(t[2] - m).cross(wide(t[3] - m));
            let first_side = normal.dot(wide(t[0] - m)).signum();
            let eye_side = normal.as_dvec3().dot(eye - m.as_dvec3());
            // Pushed last, visited first: the far child.
            if eye_side * first_side as f64 > 0.0 {
                stack.extend([n0, n1]);
            } else {
                stack.extend([n1, n0]);
            }
        }
    }

    /// The six root tetrahedra back to front: the BSP of the planes `x = y`, `x = z`, `y = z`
    /// (each root tetrahedron is one cell `x_i ≥ x_j ≥ x_k` of it), far side first at each level.
    fn root_order(&self, eye: DVec3) -> Vec<(Tet, u32)> {
        const PLANES: [(usize, usize); 3] = [(0, 1), (0, 2), (1, 2)];
        let mut roots = self.roots.clone();
        roots.sort_by_key(|(t, _)| {
            let centroid = t.iter().fold(IVec3::ZERO, |a, &p| a + p); // 4 × the centroid
            PLANES.map(|(a, b)| (centroid[a] > centroid[b]) == (eye[a] > eye[b]))
        });
        roots
    }
}

/// `mesh` with its tetrahedra (and their depths and errors) in `order`, a permutation of their
/// indices such as [`BspTree::order`] gives.
pub fn sorted(mesh: TetMesh, order: &[u32]) -> Result<TetMesh> {
    let n = mesh.tets.len();
    let mut seen = vec![false; n];
    for &i in order {
        match seen.get_mut(i as usize) {
            Some(s) if !*s => *s = true,
            _ => {
                return Err(Error::Parameter(format!(
                    "the order is no permutation of the mesh's {n} tetrahedra (index {i})"
                )))
            }
        }
    }
    if order.len() != n {
        return Err(Error::Parameter(format!(
            "the order names {} of the mesh's {n} tetrahedra",
            order.len()
        )));
    }
    let pick = |i: &u32| *i as usize;
    Ok(TetMesh {
        tets: order.iter().map(|i| mesh.tets[pick(i)]).collect(),
        depths: order.iter().map(|i| mesh.depths[pick(i)]).collect(),
        errors: order.iter().map(|i| mesh.errors[pick(i)]).collect(),
        ..mesh
    })
}

#[inline]
fn wide(v: IVec3) -> I64Vec3 {
    v.as_i64vec3()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fields::marschner_lobb_u8;
    use crate::validate::check_back_to_front;
    use crate::{Hierarchy, Query, ScalarSlice};

    /// The hierarchy of the Marschner–Lobb bytes on `dims` with the given geometry.
    fn hierarchy(dims: [usize; 3], origin: [f64; 3], spacing: [f64; 3]) -> Hierarchy {
        let (_, v) = marschner_lobb_u8(dims);
        let grid = Grid {
            dims,
            origin,
            spacing,
        };
        Hierarchy::build(grid, ScalarSlice::U8(&v), &mut |_| true).unwrap()
    }

    /// Eyes for `grid`: far outside, on the planes of many faces (a lattice plane, the root's
    /// diagonal planes), inside, at a corner, close to a face.
    fn eyes(grid: &Grid) -> Vec<[f64; 3]> {
        let b = grid.bounds();
        let at = |f: [f64; 3]| -> [f64; 3] {
            std::array::from_fn(|a| b[2 * a] + f[a] * (b[2 * a + 1] - b[2 * a]))
        };
        let lattice = |p: [f64; 3]| -> [f64; 3] {
            std::array::from_fn(|a| grid.origin[a] + grid.spacing[a] * p[a])
        };
        vec![
            at([-3.0, 0.4, 5.5]),
            at([0.5, -7.0, 0.25]),
            at([12.0, 13.0, -11.0]),
            at([0.37, 0.61, 0.29]),
            at([0.9, 0.1, 0.5]),
            lattice([8.0, 3.25, 5.5]),
            lattice([4.0, 4.0, 2.5]),
            lattice([6.0, 6.0, 6.0]),
            lattice([3.0, 5.0, -4.0]),
            at([0.0, 0.0, 0.0]),
            at([1.0, 1.0, 1.0]),
        ]
    }

    /// [`check_back_to_front`] of `order` in `direction`.
    fn check(
        mesh: &TetMesh,
        order: &[u32],
        eye: [f64; 3],
        direction: Direction,
    ) -> std::result::Result<crate::validate::VisibilityReport, String> {
        let mut order = order.to_vec();
        if direction == Direction::FrontToBack {
            order.reverse();
        }
        check_back_to_front(&mesh.points, &mesh.tets, &order, eye)
    }

    #[test]
    fn back_to_front_respects_every_interior_face() {
        let cases = [
            ([17, 17, 17], [0.0; 3], [1.0; 3]),
            ([20, 13, 9], [1.0, -2.0, 3.0], [0.5, 2.0, 1.5]),
            ([33, 9, 26], [0.0; 3], [1.0, 0.25, 3.0]),
        ];
        for (dims, origin, spacing) in cases {
            let h = hierarchy(dims, origin, spacing);
            let g = *h.grid();
            let mut queries = vec![Query::tolerance(0.0), Query::tolerance(6.0)];
            queries.push(Query {
                max_tetrahedra: 3000,
                ..Query::tolerance(0.0)
            });
            let b = g.bounds();
            queries.push(Query {
                region_of_interest: Some([
                    b[0],
                    b[0] + 0.4 * (b[1] - b[0]),
                    b[2],
                    b[3],
                    b[4],
                    b[5],
                ]),
                ..Query::tolerance(1.0)
            });
            for q in queries {
                let plan = h.plan(&q).unwrap();
                let mesh = plan.to_mesh(&g, |d| h.error(d)).unwrap();
                let tree = BspTree::new(&plan, &g).unwrap();
                assert_eq!(tree.tets(), mesh.tets.len());
                for eye in eyes(&g) {
                    let order = tree.order(eye, Direction::BackToFront).unwrap();
                    let faces = check(&mesh, &order, eye, Direction::BackToFront)
                        .unwrap_or_else(|e| panic!("{dims:?} {q:?} eye {eye:?}: {e}"));
                    assert!(faces.checked > 0, "{dims:?} {q:?}");
                    let reverse = tree.order(eye, Direction::FrontToBack).unwrap();
                    check(&mesh, &reverse, eye, Direction::FrontToBack).unwrap();
                    // A wrong order is caught: the reverse is not back to front.
                    assert!(
                        check(&mesh, &reverse, eye, Direction::BackToFront).is_err(),
                        "{dims:?} {q:?} eye {eye:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn bad_eyes_and_buffers_are_refused() {
        let h = hierarchy([9, 9, 9], [0.0; 3], [1.0; 3]);
        let plan = h.plan(&Query::tolerance(2.0)).unwrap();
        let tree = BspTree::new(&plan, h.grid()).unwrap();
        for eye in [[f64::NAN, 0.0, 0.0], [0.0, f64::INFINITY, 1.0]] {
            let err = tree.order(eye, Direction::BackToFront).unwrap_err();
            assert!(err.to_string().contains("finite"), "{err}");
        }
        let mut short = vec![0; tree.tets() - 1];
        assert!(tree
            .order_into([1.0; 3], Direction::BackToFront, &mut short)
            .is_err());
        let other = Grid::new([9, 9, 10]);
        assert!(BspTree::new(&plan, &other).is_err());
        // `sorted` takes permutations only, and reorders every per-tetrahedron array alike.
        let mesh = plan.to_mesh(h.grid(), |d| h.error(d)).unwrap();
        let n = mesh.tets.len() as u32;
        for bad in [vec![0; n as usize], (1..=n).collect(), (0..n - 1).collect()] {
            assert!(sorted(mesh.clone(), &bad).is_err());
        }
        let reverse: Vec<u32> = (0..n).rev().collect();
        let back = sorted(mesh.clone(), &reverse).unwrap();
        assert_eq!(sorted(back, &reverse).unwrap(), mesh);
    }
}
