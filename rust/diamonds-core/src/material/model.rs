//! The prepared material model and its selective refinement (Gregorski et al. 2002, §5.2–5.4).

use super::distance::InterfaceIndex;
use super::reconstruct::{classify, reconstruct};
use super::{mixed_from_materials, InterfaceMesh, MaterialInput, MaterialMesh, MaterialQuery};
use crate::diamond::{signed_volume6, Diamond};
use crate::hierarchy::base_mesh;
use crate::lattice::{Lattice, Placement, Tet};
use crate::refine::{BaseMesh, Refiner, SplitSet};
use crate::{Error, Grid, Progress, Result};
use arrayvec::ArrayVec;
use glam::{DMat3, DMat4, DVec3, DVec4, IVec3};
use rayon::prelude::*;
use rustc_hash::{FxBuildHasher, FxHashMap};
use std::hash::{BuildHasher, Hash};
use std::sync::{Arc, Mutex, PoisonError};

/// Largest number of materials (the per-tetrahedron material set is a 32-bit mask).
pub const MAX_MATERIALS: usize = 32;

/// Slack when deciding whether a point lies in a closed tetrahedron (barycentric units).
const INSIDE_EPS: f64 = 1e-9;

/// Rounding, not data: a sample's field error at most this fraction of the field's largest
/// magnitude (over its mixed and per-material values) counts as 0. Barycentric coordinates of a
/// sample at a vertex come out a few ulps off, and a vertex's own or ghost value at a sample
/// position is a renormalised average (1e-16 where the sample holds 0); until session 32 that made
/// Field Tolerance 0 refine every interface down to the finest lattice allowed, warning about
/// errors of 1e-14 (the impact case: 1,876,564 tetrahedra in 4.3 s instead of 118,762). 4096 ulps
/// of the field's scale: well above such rounding, far below the f32 data's own precision.
const ROUNDOFF: f64 = 4096.0 * f64::EPSILON;

/// The prepared input, kept between queries: sample materials, interface meshes and their spatial index.
pub struct MaterialModel {
    grid: Grid,
    materials: usize,
    /// Material of each sample (largest fraction).
    labels: Vec<u8>,
    /// Copies of the fields (the model outlives the caller's arrays).
    fields: Vec<Vec<f32>>,
    /// `own[f * materials + m]`: copy of the per-material values of field `f` in material `m`, when
    /// given (read at the samples of `m` only).
    own: Vec<Option<Vec<f32>>>,
    interfaces: Vec<InterfaceMesh>,
    index: InterfaceIndex,
    /// Per material: the interface meshes bounding it.
    boundary: Vec<Vec<usize>>,
    /// Interface-mesh vertices bucketed by data cell (compressed rows): `(mesh, point)`.
    bucket_start: Vec<u32>,
    bucket_items: Vec<(u32, u32)>,
    /// Per lattice of a query ([`MaterialModel::levels`]): where refinement starts, the diamonds
    /// straddling the domain's far faces with their closure (computed once per lattice).
    bases: Mutex<FxHashMap<Shift, Arc<BaseMesh>>>,
    /// The signed distance given to a material without interfaces (twice the diagonal).
    far: f64,
    /// Per field: deviations up to this are rounding (see [`ROUNDOFF`]).
    rounding: Vec<f64>,
}

/// What a vertex of the adaptive mesh knows about the materials (computed when first needed).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct VertexInfo {
    /// The material the vertex lies in: smallest `phi`.
    pub label: u8,
    /// Signed distance to each material's boundary (negative inside).
    pub phi: Vec<f32>,
    /// Signed distance to each interface mesh (positive on `pair.1`'s side).
    pub dist: Vec<f32>,
    /// `values[f * materials + m]`: field `f` of material `m`, own or ghost value.
    pub values: Vec<f32>,
    /// Trilinearly resampled mixed fields.
    pub mixed: Vec<f32>,
}

/// The errors of one tetrahedron.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct TetEval {
    pub interface: f64,
    pub field: f64,
    pub materials: u32,
}

/// The errors of one diamond as refinement measured them: the largest over its inside tetrahedra
/// (interface, field), and when no tetrahedron exceeded the limits (the diamond is not split) each
/// one's exact [`TetEval`], in the order of [`Diamond::tets`], for extraction to reuse.
#[derive(Clone)]
struct DiamondEval {
    error: (f64, f64),
    exact: Option<Arc<ArrayVec<TetEval, 8>>>,
}

/// A tetrahedron in world space with its barycentric map.
pub(super) struct WorldTet {
    x: [DVec3; 4],
    inv: DMat3,
}

impl WorldTet {
    pub(super) fn new(x: [DVec3; 4]) -> Self {
        let m = DMat3::from_cols(x[1] - x[0], x[2] - x[0], x[3] - x[0]);
        Self {
            x,
            inv: m.inverse(),
        }
    }

    /// Barycentric coordinates of `p`.
    fn bary(&self, p: DVec3) -> [f64; 4] {
        let l = self.inv * (p - self.x[0]);
        [1.0 - l.x - l.y - l.z, l.x, l.y, l.z]
    }

    /// Gradient of the linear function with vertex values `v`.
    pub(super) fn gradient(&self, v: [f64; 4]) -> DVec3 {
        // λ_k (k = 1..3) = row k of inv · (p − x0); λ_0 = 1 − Σ.
        let rows = self.inv.transpose();
        (v[1] - v[0]) * rows.x_axis + (v[2] - v[0]) * rows.y_axis + (v[3] - v[0]) * rows.z_axis
    }

    fn bounds(&self) -> (DVec3, DVec3) {
        let lo = self.x.iter().fold(DVec3::INFINITY, |a, &b| a.min(b));
        let hi = self.x.iter().fold(DVec3::NEG_INFINITY, |a, &b| a.max(b));
        (lo, hi)
    }
}

fn inside(l: &[f64; 4]) -> bool {
    l.iter().all(|&v| v >= -INSIDE_EPS)
}

fn dot4(l: &[f64; 4], v: [f64; 4]) -> f64 {
    l[0] * v[0] + l[1] * v[1] + l[2] * v[2] + l[3] * v[3]
}

/// `error / tolerance`, with 0 tolerance meaning "any error is too much".
fn ratio(error: f64, tolerance: f64) -> f64 {
    if error <= tolerance {
        if tolerance > 0.0 {
            error / tolerance
        } else {
            0.0
        }
    } else if tolerance > 0.0 {
        error / tolerance
    } else {
        f64::INFINITY
    }
}

impl MaterialModel {
    /// Validates the input, classifies the samples, reconstructs (or adopts) the interface meshes and
    /// indexes them.
    pub fn new(input: &MaterialInput<'_>) -> Result<Self> {
        let grid = input.grid;
        grid.validate()?;
        let n = grid.len();
        let k = input.fractions.len();
        if k < 2 {
            return Err(Error::Parameter(format!(
                "{k} volume-fraction array{} given, one per material; at least 2 materials are needed (material interfaces take between 2 and {MAX_MATERIALS} materials)",
                if k == 1 { " was" } else { "s were" }
            )));
        }
        if k > MAX_MATERIALS {
            return Err(Error::Parameter(format!(
                "{k} volume-fraction arrays given; material interfaces need between 2 and {MAX_MATERIALS} materials"
            )));
        }
        for (m, f) in input.fractions.iter().enumerate() {
            check_length("volume-fraction", m, f.len(), n, &grid)?;
        }
        for (i, f) in input.fields.iter().enumerate() {
            if let Some(f) = f {
                check_length("field", i, f.len(), n, &grid)?;
            }
        }
        check_material_field_ranges(input, &grid)?;
        let fields = mixed_fields(input)?;
        for (i, f) in fields.iter().enumerate() {
            if let Some(p) = f.iter().position(|v| !v.is_finite()) {
                let name = input
                    .field_names
                    .get(i)
                    .map_or_else(|| format!("field {i}"), |n| format!("field \"{n}\""));
                return Err(Error::Parameter(format!(
                    "the {name} holds a non-finite value ({}) at point {p} (i, j, k = {:?}); replace NaN/Inf first",
                    f[p],
                    grid.ijk(p)
                )));
            }
        }
        check_fractions(&input.fractions, &grid)?;
        let labels = classify(&input.fractions);
        let own = check_material_fields(input, &labels, &grid)?;
        let interfaces = match &input.interfaces {
            Some(given) => check_interfaces(given, k)?,
            None => reconstruct(&grid, &labels, &input.fractions),
        };
        let index = InterfaceIndex::new(&interfaces);
        let mut boundary = vec![Vec::new(); k];
        for (i, mesh) in interfaces.iter().enumerate() {
            boundary[mesh.pair.0 as usize].push(i);
            boundary[mesh.pair.1 as usize].push(i);
        }
        // Refuses grids whose lattice would be too large.
        Shift::first(&grid, 0.0).lattice(&grid)?;
        let far = 2.0 * crate::volume::bounds_diagonal(&grid.bounds());
        let largest = |v: &[f32]| v.iter().fold(0.0f64, |a, &x| a.max((x as f64).abs()));
        let rounding = (0..fields.len())
            .map(|f| {
                let own = own[f * k..(f + 1) * k].iter().flatten();
                ROUNDOFF * own.fold(largest(&fields[f]), |a, v| a.max(largest(v)))
            })
            .collect();
        let mut model = Self {
            grid,
            materials: k,
            labels,
            fields,
            own,
            interfaces,
            index,
            boundary,
            bucket_start: Vec::new(),
            bucket_items: Vec::new(),
            bases: Mutex::default(),
            far,
            rounding,
        };
        model.bucket_interface_vertices();
        Ok(model)
    }

    /// The interface meshes (reconstructed or given).
    pub fn interfaces(&self) -> &[InterfaceMesh] {
        &self.interfaces
    }

    /// Material of each input sample.
    pub fn labels(&self) -> &[u8] {
        &self.labels
    }

    /// The grid of the input samples.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Tetrahedra of the base mesh on the lattice of [`Shift::first`]: the refinement forced by the
    /// domain's far faces alone (0 extra where the lattice's domain is a cube of `2^k + 1` points per
    /// axis; see [`crate::lattice`]). Every query starts from it, scaled, when its lattice is whole
    /// levels finer on every axis alike, as on grids of equal spacings; on others a query's lattice
    /// can be finer along some axes only, with a base mesh of its own.
    pub fn base_tetrahedra(&self) -> usize {
        self.base(Shift::first(&self.grid, 0.0))
            .map_or(0, |(_, b)| b.tets)
    }

    /// The lattice `shift` levels finer than the data and its base mesh (computed when first asked).
    fn base(&self, shift: Shift) -> Result<(Lattice, Arc<BaseMesh>)> {
        let lattice = shift.lattice(&self.grid)?;
        let mut bases = self.bases.lock().unwrap_or_else(PoisonError::into_inner);
        let base = bases
            .entry(shift)
            .or_insert_with(|| Arc::new(base_mesh(lattice)));
        Ok((lattice, base.clone()))
    }

    /// How many levels finer than the data the lattice of `query` is ([`Shift::for_tolerance`]).
    fn levels(&self, query: &MaterialQuery) -> Shift {
        let tolerance = if query.ghost_values {
            query.interface_tolerance
        } else {
            f64::INFINITY
        };
        Shift::for_tolerance(&self.grid, tolerance)
    }

    fn bucket_interface_vertices(&mut self) {
        let cells = self.cell_count();
        let mut count = vec![0u32; cells + 1];
        let mut items = Vec::new();
        for (i, mesh) in self.interfaces.iter().enumerate() {
            for (p, x) in mesh.points.iter().enumerate() {
                let c = self.cell_index(self.cell_corner(DVec3::from_array(*x)));
                count[c + 1] += 1;
                items.push((c, i as u32, p as u32));
            }
        }
        for c in 0..cells {
            count[c + 1] += count[c];
        }
        let mut fill = count.clone();
        let mut out = vec![(0, 0); items.len()];
        for (c, i, p) in items {
            out[fill[c] as usize] = (i, p);
            fill[c] += 1;
        }
        self.bucket_start = count;
        self.bucket_items = out;
    }

    fn cell_count(&self) -> usize {
        self.grid.dims.iter().map(|d| d - 1).product()
    }

    /// Continuous sample coordinates of a world point.
    fn to_grid(&self, x: DVec3) -> DVec3 {
        let o = DVec3::from_array(self.grid.origin);
        let s = DVec3::from_array(self.grid.spacing);
        (x - o) / s
    }

    /// The data cell (lower corner, clamped) holding `x`.
    fn cell_corner(&self, x: DVec3) -> [usize; 3] {
        let u = self.to_grid(x);
        std::array::from_fn(|a| (u[a].floor().max(0.0) as usize).min(self.grid.dims[a] - 2))
    }

    /// Linear index of the data cell whose lower corner is sample `[i, j, k]`.
    fn cell_index(&self, [i, j, k]: [usize; 3]) -> usize {
        let d = self.grid.dims;
        i + (d[0] - 1) * (j + (d[1] - 1) * k)
    }

    /// The 8 corner samples of `x`'s cell with their trilinear weights.
    fn corners(&self, x: DVec3) -> [(usize, f64); 8] {
        let c = self.cell_corner(x);
        let u = self.to_grid(x);
        let t: [f64; 3] = std::array::from_fn(|a| (u[a] - c[a] as f64).clamp(0.0, 1.0));
        std::array::from_fn(|n| {
            let o = [n & 1, (n >> 1) & 1, (n >> 2) & 1];
            let w = (0..3)
                .map(|a| if o[a] == 1 { t[a] } else { 1.0 - t[a] })
                .product();
            (self.grid.index(c[0] + o[0], c[1] + o[1], c[2] + o[2]), w)
        })
    }

    /// World position of a point of the lattice `shift` levels finer than the data (`2^-shift`
    /// sample spacings per lattice unit along each axis; a sample's own position, exactly, at
    /// multiples of `2^shift`).
    pub(super) fn world(&self, p: IVec3, shift: Shift) -> DVec3 {
        DVec3::from_array(self.grid.origin)
            + DVec3::from_array(self.grid.spacing) * (p.as_dvec3() / shift.scale())
    }

    /// The material common to all corners of `x`'s cell, if there is one.
    fn uniform_label(&self, x: DVec3) -> Option<u8> {
        let c = self.corners(x);
        let l = self.labels[c[0].0];
        c.iter().all(|&(i, _)| self.labels[i] == l).then_some(l)
    }

    /// The values of field `f` inside material `m`, valid at the samples of `m`: the per-material
    /// values when given, else the mixed field.
    fn own_field(&self, f: usize, m: u8) -> &[f32] {
        self.own[f * self.materials + m as usize]
            .as_deref()
            .unwrap_or(&self.fields[f])
    }

    /// Field `f` of material `m` at `x` from the corners of its cell that lie in `m` (trilinear weights
    /// renormalised over them, own values), or `None` when no corner does.
    fn material_value(&self, x: DVec3, m: u8, f: usize) -> Option<f64> {
        let own = self.own_field(f, m);
        let (mut sum, mut weight, mut plain, mut count) = (0.0, 0.0, 0.0, 0);
        for (i, w) in self.corners(x) {
            if self.labels[i] == m {
                let v = own[i] as f64;
                sum += w * v;
                weight += w;
                plain += v;
                count += 1;
            }
        }
        match count {
            0 => None,
            _ if weight > 1e-12 => Some(sum / weight),
            _ => Some(plain / count as f64),
        }
    }

    /// Per field, the trilinear interpolation of `field(f)` at the four vertices of `t`.
    fn vertex_values<'a>(
        &'a self,
        t: &WorldTet,
        field: impl Fn(usize) -> &'a [f32],
    ) -> Vec<[f64; 4]> {
        (0..self.fields.len())
            .map(|f| std::array::from_fn(|v| self.trilinear(field(f), t.x[v])))
            .collect()
    }

    /// Trilinear interpolation of `values` (one per sample) at `x`.
    fn trilinear(&self, values: &[f32], x: DVec3) -> f64 {
        self.corners(x)
            .iter()
            .map(|&(i, w)| w * values[i] as f64)
            .sum()
    }

    /// A ghost value of field `f` of material `m` at `x` (Gregorski §5.2.3's "linear … extrapolation"):
    /// the least-squares linear fit `a + g · (y − x)` to `m`'s own values at its samples `y` among the
    /// 4 × 4 × 4 around `x`'s cell, evaluated at `x`; `None` when fewer than 4 of them, or all on one
    /// plane, are of `m`. A field that is continuous across the interface is thus continued, a jump is
    /// kept.
    fn extrapolated_value(&self, x: DVec3, m: u8, f: usize) -> Option<f64> {
        let own = self.own_field(f, m);
        let u = self.to_grid(x);
        let d = self.grid.dims;
        let (mut ata, mut atv, mut count) = (DMat4::ZERO, DVec4::ZERO, 0);
        let range = |a: usize| {
            let c = u[a].floor() as i64;
            (c - 1).max(0) as usize..=((c + 2).min(d[a] as i64 - 1)).max(0) as usize
        };
        for k in range(2) {
            for j in range(1) {
                for i in range(0) {
                    let s = self.grid.index(i, j, k);
                    if self.labels[s] != m {
                        continue;
                    }
                    // Cell units keep the system well conditioned.
                    let r = DVec4::new(1.0, i as f64 - u.x, j as f64 - u.y, k as f64 - u.z);
                    ata += DMat4::from_cols(r * r.x, r * r.y, r * r.z, r * r.w);
                    atv += r * own[s] as f64;
                    count += 1;
                }
            }
        }
        if count < 4 || ata.determinant().abs() < 1e-6 * (count as f64).powi(4) {
            return None;
        }
        let c = ata.inverse() * atv;
        c.x.is_finite().then_some(c.x)
    }

    /// The value of field `f` of material `m` at the sample of `m` nearest to `x` within a few cells.
    fn nearest_sample_value(&self, x: DVec3, m: u8, f: usize) -> Option<f64> {
        let u = self.to_grid(x);
        let d = self.grid.dims;
        for r in 1..=4i64 {
            let mut best: Option<(f64, usize)> = None;
            let lo: [i64; 3] = std::array::from_fn(|a| (u[a].floor() as i64 - r + 1).max(0));
            let hi: [i64; 3] =
                std::array::from_fn(|a| (u[a].floor() as i64 + r).min(d[a] as i64 - 1));
            for k in lo[2]..=hi[2] {
                for j in lo[1]..=hi[1] {
                    for i in lo[0]..=hi[0] {
                        let s = self.grid.index(i as usize, j as usize, k as usize);
                        if self.labels[s] != m {
                            continue;
                        }
                        let q = DVec3::new(i as f64, j as f64, k as f64);
                        let dist = ((q - u) * DVec3::from_array(self.grid.spacing)).length();
                        if best.is_none_or(|(b, _)| dist < b) {
                            best = Some((dist, s));
                        }
                    }
                }
            }
            if let Some((_, s)) = best {
                return Some(self.own_field(f, m)[s] as f64);
            }
        }
        None
    }

    /// Everything a vertex at point `p` of the lattice `shift` levels finer than the data needs
    /// (§5.2.1 signed distances, §5.2.3 ghost values).
    pub(super) fn vertex_info(&self, p: IVec3, shift: Shift) -> VertexInfo {
        let x = self.world(p, shift);
        let uniform = self.uniform_label(x);
        let k = self.materials;
        let closest: Vec<_> = (0..self.interfaces.len())
            .map(|i| self.index.closest(i, x.to_array()))
            .collect();
        // Interface distances: sign from the sample materials where the cell is uniform, else from the
        // side of the closest point (the mesh normal).
        let dist = closest
            .iter()
            .zip(&self.interfaces)
            .map(|(c, mesh)| match c {
                None => 0.0,
                Some(c) => {
                    let side = match uniform {
                        Some(l) if l == mesh.pair.0 => -1.0,
                        Some(l) if l == mesh.pair.1 => 1.0,
                        _ => c.side,
                    };
                    // + 0.0: a point on the interface has distance +0, never −0 (see `phi`).
                    (side * c.distance) as f32 + 0.0
                }
            })
            .collect();
        // Material distances: the nearest of the material's interfaces.
        let mut phi = vec![0f32; k];
        let mut foot = vec![None; k];
        for m in 0..k {
            let nearest = self.boundary[m]
                .iter()
                .filter_map(|&i| closest[i].map(|c| (i, c)))
                .min_by(|a, b| a.1.distance.total_cmp(&b.1.distance));
            phi[m] = match nearest {
                None => {
                    (match uniform {
                        Some(l) if l as usize == m => -self.far,
                        _ => self.far,
                    }) as f32
                }
                Some((i, c)) => {
                    foot[m] = Some(DVec3::from_array(c.point));
                    let outside = match uniform {
                        Some(l) => {
                            if l as usize == m {
                                -1.0
                            } else {
                                1.0
                            }
                        }
                        // The normal points from pair.0 into pair.1: pair.1's side is outside pair.0.
                        None if self.interfaces[i].pair.0 as usize == m => c.side,
                        None => -c.side,
                    };
                    // + 0.0 turns −0 into +0: the materials' order at a point on their interface
                    // is a tie (the lowest index wins, as `g ≤ 0` puts such points on the first
                    // material's side); with −0 below +0 (`total_cmp`) the interface polygons
                    // skipped the tetrahedra whose face lies on the interface (a crack: until
                    // session 32, 8 open edges on the 28×38×3 impact grid).
                    (outside * c.distance) as f32 + 0.0
                }
            };
        }
        let label = uniform.unwrap_or_else(|| {
            (0..k)
                .min_by(|&a, &b| phi[a].total_cmp(&phi[b]).then(a.cmp(&b)))
                .unwrap_or(0) as u8
        });
        let nf = self.fields.len();
        let mixed: Vec<f32> = (0..nf)
            .map(|f| self.trilinear(&self.fields[f], x) as f32)
            .collect();
        // The sample at p, if any: its own value is exact there, whatever φ says.
        let sample_label = shift.sample(p).map(|sample| {
            self.labels[self
                .grid
                .index(sample.x as usize, sample.y as usize, sample.z as usize)]
        });
        let mut values = vec![0f32; nf * k];
        for f in 0..nf {
            for m in 0..k {
                let own = if m == label as usize || sample_label == Some(m as u8) {
                    self.material_value(x, m as u8, f)
                } else {
                    self.extrapolated_value(x, m as u8, f)
                        .or_else(|| self.material_value(x, m as u8, f))
                };
                let v = own
                    .or_else(|| {
                        let y = foot[m]?;
                        self.material_value(y, m as u8, f)
                            .or_else(|| self.nearest_sample_value(y, m as u8, f))
                    })
                    .unwrap_or(mixed[f] as f64);
                values[f * k + m] = v as f32;
            }
        }
        VertexInfo {
            label,
            phi,
            dist,
            values,
            mixed,
        }
    }

    /// Visits the data samples in the closed tetrahedron `t` with their barycentric coordinates, row
    /// by row (the span of each row solved from the barycentric coordinates, which are affine along
    /// it), until `visit` returns `false`; returns `false` then.
    fn scan_samples(&self, t: &WorldTet, visit: &mut dyn FnMut(usize, &[f64; 4]) -> bool) -> bool {
        let (lo, hi) = t.bounds();
        let (ulo, uhi) = (self.to_grid(lo), self.to_grid(hi));
        let d = self.grid.dims;
        let range = |a: usize| {
            let a0 = (ulo[a] - 1e-9).ceil().max(0.0) as usize;
            let a1 = ((uhi[a] + 1e-9).floor().max(0.0) as usize).min(d[a] - 1);
            (a0, a1)
        };
        let ((i0, i1), (j0, j1), (k0, k1)) = (range(0), range(1), range(2));
        // Barycentric change per step along x.
        let step = t.inv.x_axis * self.grid.spacing[0];
        let dl = [-(step.x + step.y + step.z), step.x, step.y, step.z];
        for k in k0..=k1 {
            for j in j0..=j1 {
                let l0 = t.bary(DVec3::from_array(self.grid.point([0, j, k])));
                let (mut a, mut b) = (i0 as f64, i1 as f64);
                for m in 0..4 {
                    // l0[m] + i dl[m] ≥ −ε
                    let bound = (-INSIDE_EPS - l0[m]) / dl[m];
                    if dl[m] > 0.0 {
                        a = a.max(bound);
                    } else if dl[m] < 0.0 {
                        b = b.min(bound);
                    } else if l0[m] < -INSIDE_EPS {
                        b = -1.0;
                    }
                }
                if a > b {
                    continue;
                }
                // The coordinates stepped from the row's first sample in the range, not from the
                // grid's: no cancellation of large terms far from x = 0 (see ROUNDOFF).
                let first = a.ceil() as usize;
                let ls = t.bary(DVec3::from_array(self.grid.point([first, j, k])));
                for i in first..=(b.floor() as usize) {
                    let x = (i - first) as f64;
                    let l = std::array::from_fn(|m| ls[m] + x * dl[m]);
                    if inside(&l) && !visit(self.grid.index(i, j, k), &l) {
                        return false;
                    }
                }
            }
        }
        true
    }

    /// Interface and field errors of tetrahedron `t` (§5.4), exact at the data samples inside it.
    /// `info` gives the vertex records, asked for only where the materials are not uniform around
    /// the tetrahedron. With `limits` (interface, field tolerances) the errors are exact only up to
    /// them: the scan stops at the first interface error above its limit (the field error is then
    /// not measured) or the first field error above its limit, and the materials are not reported;
    /// enough to decide a split.
    fn evaluate(
        &self,
        (t, shift): (&Tet, Shift),
        ghost_values: bool,
        info: &mut dyn FnMut(IVec3) -> Arc<VertexInfo>,
        limits: Option<(f64, f64)>,
    ) -> TetEval {
        let (interface_limit, field_limit) = limits.unwrap_or((f64::INFINITY, f64::INFINITY));
        let wt = WorldTet::new(t.map(|p| self.world(p, shift)));
        let nf = self.fields.len();
        // The largest deviation at the samples of t of their value (own value of their material with
        // ghost values, else mixed) from the linear function `values(f, material)`, or `None` when
        // `uniform` is given and a sample is of another material; with the materials of the samples.
        let field_error = |values: &dyn Fn(usize, u8) -> [f64; 4], uniform: Option<u8>| {
            let (mut e, mut mask) = (0.0f64, 0u32);
            let complete = self.scan_samples(&wt, &mut |s, l| {
                let m = self.labels[s];
                if uniform.is_some_and(|u| u != m) {
                    return false;
                }
                mask |= 1 << m;
                for f in 0..nf {
                    let at = if ghost_values {
                        self.own_field(f, m)[s]
                    } else {
                        self.fields[f][s]
                    } as f64;
                    let deviation = (at - dot4(l, values(f, m))).abs();
                    if deviation > self.rounding[f] {
                        e = e.max(deviation);
                    }
                }
                e <= field_limit
            });
            (complete || uniform.is_none() || e > field_limit).then_some((e, mask))
        };
        let (lo, hi) = wt.bounds();
        let (c0, c1) = (self.cell_corner(lo), self.cell_corner(hi));
        let interface_vertices = (c0[2]..=c1[2]).flat_map(|k| {
            (c0[1]..=c1[1]).flat_map(move |j| {
                (c0[0]..=c1[0]).flat_map(move |i| {
                    let c = self.cell_index([i, j, k]);
                    &self.bucket_items
                        [self.bucket_start[c] as usize..self.bucket_start[c + 1] as usize]
                })
            })
        });
        let mut v: Option<[Arc<VertexInfo>; 4]> = None;
        let mut interface = 0.0f64;
        for &(mesh, p) in interface_vertices {
            let l = wt.bary(DVec3::from_array(
                self.interfaces[mesh as usize].points[p as usize],
            ));
            if !inside(&l) {
                continue;
            }
            let v = v.get_or_insert_with(|| std::array::from_fn(|i| info(t[i])));
            let (a, b) = self.interfaces[mesh as usize].pair;
            let g: [f64; 4] =
                std::array::from_fn(|i| v[i].phi[a as usize] as f64 - v[i].phi[b as usize] as f64);
            let grad = wt.gradient(g).length();
            let value = dot4(&l, g).abs();
            let e = if grad > 1e-12 {
                value / grad
            } else if value < 1e-12 {
                0.0
            } else {
                f64::INFINITY
            };
            interface = interface.max(e);
            if interface > interface_limit {
                return TetEval {
                    interface,
                    ..TetEval::default()
                };
            }
        }
        // Plain interpolation of the mixed fields: the interfaces are measured (the mesh carries
        // them all the same), not refined for.
        if !ghost_values {
            let vals = self.vertex_values(&wt, |f| &self.fields[f]);
            let (field, materials) = field_error(&|f, _| vals[f], None).unwrap_or_default();
            return TetEval {
                interface,
                field,
                materials,
            };
        }
        // The cheap case: one material around every vertex and at every sample, no interface inside.
        if v.is_none() {
            let uniform: Vec<Option<u8>> = wt.x.iter().map(|&x| self.uniform_label(x)).collect();
            if let Some(l) = uniform[0].filter(|&l| uniform.iter().all(|&u| u == Some(l))) {
                // Every corner sample of the vertices' cells is of l: l's own values are the
                // trilinear interpolation of its samples (what `vertex_info` gives too).
                let vals = self.vertex_values(&wt, |f| self.own_field(f, l));
                if let Some((field, materials)) = field_error(&|f, _| vals[f], Some(l)) {
                    return TetEval {
                        interface: 0.0,
                        field,
                        materials,
                    };
                }
            }
        }
        let v = v.unwrap_or_else(|| std::array::from_fn(|i| info(t[i])));
        let k = self.materials;
        let (field, mut materials) = field_error(
            &|f, m| std::array::from_fn(|i| v[i].values[f * k + m as usize] as f64),
            None,
        )
        .unwrap_or_default();
        for vi in &v {
            materials |= 1 << vi.label;
        }
        TetEval {
            interface,
            field,
            materials,
        }
    }

    /// Refines to `query` (§5.3): interfaces first, then fields. `progress` gets fractions in `[0, 1]`
    /// and returns `false` to abort.
    pub fn refine(&self, query: &MaterialQuery, progress: Progress<'_>) -> Result<MaterialMesh> {
        for (name, t) in [
            ("interface tolerance", query.interface_tolerance),
            ("field tolerance", query.field_tolerance),
        ] {
            if !t.is_finite() || t < 0.0 {
                return Err(Error::Parameter(format!(
                    "the {name} must be a finite number ≥ 0 (got {t})"
                )));
            }
        }
        // The interface error of a tetrahedron is a distance, but near a junction of materials the
        // signed distances can vary slowly enough inside it to exceed its width: where the finest
        // tetrahedra of the lattice still miss the interface tolerance, a lattice one level finer
        // is tried, as far as memory allows (the field error reaches 0 on any lattice).
        let mut shift = self.levels(query);
        loop {
            let mesh = self.refine_on(query, shift, progress)?;
            if !query.ghost_values
                || mesh.max_interface_error <= query.interface_tolerance
                || shift.finer().points(&self.grid) > MAX_LATTICE_POINTS
            {
                return Ok(mesh);
            }
            shift = shift.finer();
        }
    }

    /// [`Self::refine`] on the lattice `shift` levels finer than the data.
    fn refine_on(
        &self,
        query: &MaterialQuery,
        shift: Shift,
        progress: Progress<'_>,
    ) -> Result<MaterialMesh> {
        let (lattice, base) = self.base(shift)?;
        let infos: Memo<usize, Arc<VertexInfo>> = Memo::default();
        let evals: Memo<Diamond, DiamondEval> = Memo::default();
        // A diamond is split when its interface error exceeds the interface tolerance (both passes)
        // or, in the second, its field error the field tolerance: errors are measured up to these.
        let limits = (
            if query.ghost_values {
                query.interface_tolerance
            } else {
                f64::INFINITY
            },
            query.field_tolerance,
        );
        let diamond_error = |d: Diamond| -> (f64, f64) {
            evals
                .get_or_insert_with(d, || {
                    let mut info = |p: IVec3| {
                        infos.get_or_insert_with(lattice.index(p), || {
                            Arc::new(self.vertex_info(p, shift))
                        })
                    };
                    let mut e = (0.0f64, 0.0f64);
                    let mut exact = ArrayVec::new();
                    for t in d.tets(&lattice) {
                        if lattice.place(&t) == Placement::Inside {
                            let r = self.evaluate(
                                (&t, shift),
                                query.ghost_values,
                                &mut info,
                                Some(limits),
                            );
                            e = (e.0.max(r.interface), e.1.max(r.field));
                            if e.0 > limits.0 {
                                break;
                            }
                            exact.push(r);
                        }
                    }
                    let within = e.0 <= limits.0 && e.1 <= limits.1;
                    DiamondEval {
                        error: e,
                        exact: within.then(|| Arc::new(exact)),
                    }
                })
                .error
        };
        let mut round =
            |evaluated: usize| progress(0.8 * (1.0 - 1.0 / (1.0 + evaluated as f64 / 20_000.0)));
        // Pass 1 (§5.3 step 2): the interfaces.
        let interface_only = |d: Diamond| diamond_error(d).0;
        let (split, interface_tets) = if query.ghost_values {
            Refiner::refine_parallel(
                lattice,
                base.split.clone(),
                base.tets,
                (query.interface_tolerance, &base.candidates),
                &interface_only,
                &mut round,
            )
            .ok_or(Error::Aborted)?
        } else {
            (base.split.clone(), base.tets)
        };
        // Pass 2 (step 3): the fields, keeping the interfaces within their tolerance.
        let both = |d: Diamond| {
            let (ie, fe) = diamond_error(d);
            let i = if query.ghost_values {
                ratio(ie, query.interface_tolerance)
            } else {
                0.0
            };
            i.max(ratio(fe, query.field_tolerance))
        };
        let candidates = Refiner::candidates(&lattice, &split);
        let (split, _) = Refiner::refine_parallel(
            lattice,
            split,
            interface_tets,
            (1.0, &candidates),
            &both,
            &mut round,
        )
        .ok_or(Error::Aborted)?;
        let mut mesh = self.extract((&split, shift), query.ghost_values, &infos, &evals)?;
        mesh.interface_tetrahedra = interface_tets;
        if !progress(1.0) {
            return Err(Error::Aborted);
        }
        Ok(mesh)
    }

    /// The leaves of `split` with their vertex records (from `infos`, completed) and errors (from
    /// `evals` where refinement measured them exactly, else measured here).
    fn extract(
        &self,
        (split, shift): (&SplitSet, Shift),
        ghost_values: bool,
        infos: &Memo<usize, Arc<VertexInfo>>,
        evals: &Memo<Diamond, DiamondEval>,
    ) -> Result<MaterialMesh> {
        let lattice = split.lattice();
        // Each leaf with its errors when refinement measured them exactly.
        let measured = |t: &Tet| -> Option<TetEval> {
            let d = Diamond::of_tet(t)?;
            let exact = evals.get(&d)?.exact?;
            let same = |u: &Tet| {
                let pair = |a: IVec3, b: IVec3| (a.min(b).to_array(), a.max(b).to_array());
                pair(u[0], u[1]) == pair(t[0], t[1]) && pair(u[2], u[3]) == pair(t[2], t[3])
            };
            d.tets(lattice)
                .iter()
                .filter(|u| lattice.place(u) == Placement::Inside)
                .position(same)
                .and_then(|i| exact.get(i).copied())
        };
        let mut leaves =
            crate::mesh::leaves_where(lattice, split, |_| false, |t| Some((*t, measured(t))))?;
        for (t, _) in &mut leaves {
            if signed_volume6(t) < 0 {
                t.swap(2, 3);
            }
        }
        let mut ids: Vec<usize> = leaves
            .iter()
            .flat_map(|(t, _)| t.map(|p| lattice.index(p)))
            .collect();
        ids.par_sort_unstable();
        ids.dedup();
        let lattice_point = |i: usize| lattice.point(i);
        let infos: Vec<Arc<VertexInfo>> = ids
            .par_iter()
            .map(|&i| {
                infos.get_or_insert_with(i, || Arc::new(self.vertex_info(lattice_point(i), shift)))
            })
            .collect();
        let id = |p: IVec3| ids.binary_search(&lattice.index(p)).expect("leaf vertex") as u32;
        let evals: Vec<TetEval> = leaves
            .par_iter()
            .map(|(t, measured)| {
                measured.unwrap_or_else(|| {
                    self.evaluate(
                        (t, shift),
                        ghost_values,
                        &mut |p| infos[id(p) as usize].clone(),
                        None,
                    )
                })
            })
            .collect();
        let k = self.materials;
        let nf = self.fields.len();
        let column = |f: &dyn Fn(&VertexInfo) -> f32| infos.iter().map(|v| f(v)).collect();
        Ok(MaterialMesh {
            materials: k,
            fields: nf,
            points: ids
                .iter()
                .map(|&i| self.world(lattice_point(i), shift).to_array())
                .collect(),
            tets: leaves.iter().map(|(t, _)| t.map(id)).collect(),
            depths: leaves
                .iter()
                .map(|(t, _)| {
                    Diamond::of_tet(t).map_or(3 * lattice.levels, |d| d.depth(lattice)) as u8
                })
                .collect(),
            point_material: infos.iter().map(|v| v.label).collect(),
            pairs: self.interfaces.iter().map(|m| m.pair).collect(),
            interface_distance: (0..self.interfaces.len())
                .map(|i| column(&|v| v.dist[i]))
                .collect(),
            material_distance: (0..k).map(|m| column(&|v| v.phi[m])).collect(),
            mixed: (0..nf).map(|f| column(&|v| v.mixed[f])).collect(),
            material_field: if ghost_values {
                (0..nf * k).map(|c| column(&|v| v.values[c])).collect()
            } else {
                Vec::new()
            },
            interface_error: evals.iter().map(|e| e.interface as f32).collect(),
            field_error: evals.iter().map(|e| e.field as f32).collect(),
            tet_materials: evals.iter().map(|e| e.materials).collect(),
            max_interface_error: evals.iter().fold(0.0, |a, e| a.max(e.interface)),
            max_field_error: evals.iter().fold(0.0, |a, e| a.max(e.field)),
            interface_tetrahedra: 0,
            ghost_values,
        })
    }
}

/// Largest number of points of a query's lattice domain beyond one level finer than the data (its
/// split sets take 2 bits per point).
const MAX_LATTICE_POINTS: u64 = 1 << 30;

impl MaterialMesh {
    /// What to tell the user when this mesh, refined to `query`, misses a tolerance somewhere
    /// (`None` when it meets both). Every sample is a vertex, so the field error reaches 0 on the
    /// finest tetrahedra, and [`MaterialModel::refine`] goes to finer lattices while the interface
    /// error is above its tolerance: a miss means the next finer lattice would exceed
    /// `MAX_LATTICE_POINTS` (2³⁰ points).
    pub fn tolerance_warning(&self, query: &MaterialQuery) -> Option<String> {
        // Plain interpolation does not refine for the interfaces (their error is only reported).
        let interface_missed =
            query.ghost_values && self.max_interface_error > query.interface_tolerance;
        (interface_missed || self.max_field_error > query.field_tolerance)
            .then(|| {
                format!(
                    "the finest tetrahedra cannot meet the tolerances everywhere: interface error {} \
                     (tolerance {}), field error {} (tolerance {}). Every sample is a vertex of the \
                     finest tetrahedra and the mesh refines on lattices finer than the data where interfaces need it, but \
                     the next finer lattice would exceed {MAX_LATTICE_POINTS} points; a larger \
                     interface tolerance can be met",
                    self.max_interface_error,
                    query.interface_tolerance,
                    self.max_field_error,
                    query.field_tolerance
                )
            })
    }
}

/// How many levels finer than the data a query's lattice is, per axis: sample `[i, j, k]` is
/// lattice point `[i << s_x, j << s_y, k << s_z]`, the grid at the lattice's corner as in
/// [`crate::lattice`]. Every sample is a lattice vertex, so the field error can reach 0 at the
/// finest tetrahedra on any grid. Coarse axes get at least the halvings that make the lattice steps
/// about equal in world units, down to a quarter of the interface tolerance
/// ([`Shift::for_tolerance`]; axes whose spacing is finer than that get none): longest-edge
/// bisection halves the longest
/// edge in lattice units, so with equal shifts on a grid 52 times coarser along z than along x (the
/// impact case on 31×38×2 points) the finest tetrahedra the memory allowed were still 52 times
/// longer along z, and an interface tolerance of an eighth of the x spacing was missed 2.3 times
/// over (until session 33). Made equal to the finest spacing whatever the tolerance, thin slices
/// (spacings 1, 1 and 0.01) at a tolerance of about a cell got lattices 2⁷ times finer along the
/// wide axes than the tolerance needed: 9.7 M tetrahedra for 53,248 samples (until session 41).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) struct Shift([u32; 3]);

impl Shift {
    /// One level finer than the data, and along each axis as many more as bring its step nearest
    /// to the finest spacing or to `step`, whichever is larger (axes of one point do not count).
    /// With a `step` of 0, the lattice's steps are about equal in world units.
    fn first(grid: &Grid, step: f64) -> Self {
        let spread = (0..3)
            .filter(|&a| grid.dims[a] > 1)
            .map(|a| grid.spacing[a]);
        let target = spread.fold(f64::INFINITY, f64::min).max(step);
        let mut shift = Self(std::array::from_fn(|a| {
            let halvings = (grid.spacing[a] / target).log2().round();
            // Only finite and at most 30: a degenerate spacing (an axis of one point) adds none.
            1 + if grid.dims[a] > 1 && halvings.is_finite() {
                halvings.clamp(0.0, 30.0) as u32
            } else {
                0
            }
        }));
        // Extreme ratios: the coarsest axes' extra halvings go first until the lattice fits.
        while shift.points(grid) > MAX_LATTICE_POINTS && shift.0.iter().any(|&s| s > 1) {
            let widest = (0..3).max_by_key(|&a| shift.0[a]).unwrap_or(0);
            shift.0[widest] -= 1;
        }
        shift
    }

    /// The lattice of a query with this interface tolerance: at least one level finer than the data
    /// (interfaces crossing a cell and junctions of three materials approximated to a fraction of a
    /// cell), and more on every axis while the widest lattice step exceeds the tolerance
    /// (refinement goes that deep only where the interface needs it), as far as
    /// [`MAX_LATTICE_POINTS`] allows, from one shift on every axis and from [`Shift::first`]'s
    /// toward a quarter of the tolerance (toward the finest spacing when it is infinite, without
    /// ghost values; toward the tolerance itself, headsq's tissue maps at their default tolerance,
    /// 4.43 on cells of 3.2×3.2×1.5, took 38 % more tetrahedra, and at a quarter they are as
    /// before on every case measured): the
    /// larger of the two on each axis where that fits (never coarser than one shift for all, which
    /// also serves junctions, where the signed distances vary slowly: on headsq's own 3.2×3.2×1.5
    /// cells at tolerance 1, `[2, 2, 1]` missed it and needed `[3, 3, 2]`, 5 times the time of
    /// `[2, 2, 2]`), else the latter (the one shift for all ran out of memory first).
    fn for_tolerance(grid: &Grid, tolerance: f64) -> Self {
        let grow = |mut shift: Self| {
            while shift.widest_step(grid) > tolerance
                && shift.finer().points(grid) <= MAX_LATTICE_POINTS
            {
                shift = shift.finer();
            }
            shift
        };
        let toward = if tolerance.is_finite() {
            0.25 * tolerance
        } else {
            0.0
        };
        let per_axis = grow(Self::first(grid, toward));
        let one = grow(Self([1; 3]));
        let both = Self(std::array::from_fn(|a| per_axis.0[a].max(one.0[a])));
        if both.points(grid) <= MAX_LATTICE_POINTS {
            both
        } else {
            per_axis
        }
    }

    /// One level finer along every axis.
    fn finer(self) -> Self {
        Self(self.0.map(|s| s + 1))
    }

    /// Lattice points per axis of the domain.
    fn dims(self, grid: &Grid) -> [usize; 3] {
        std::array::from_fn(|a| ((grid.dims[a] - 1) << self.0[a]) + 1)
    }

    /// Points of the lattice's domain (saturating).
    fn points(self, grid: &Grid) -> u64 {
        self.dims(grid)
            .iter()
            .fold(1u64, |n, &d| n.saturating_mul(d as u64))
    }

    /// The lattice of the domain.
    fn lattice(self, grid: &Grid) -> Result<Lattice> {
        Lattice::new(self.dims(grid))
    }

    /// Lattice units per sample spacing, per axis.
    fn scale(self) -> DVec3 {
        DVec3::from_array(self.0.map(|s| f64::from(s).exp2()))
    }

    /// The widest lattice step in world units (axes of one point do not count).
    fn widest_step(self, grid: &Grid) -> f64 {
        (0..3)
            .filter(|&a| grid.dims[a] > 1)
            .map(|a| grid.spacing[a] / f64::from(self.0[a]).exp2())
            .fold(0.0, f64::max)
    }

    /// The sample at lattice point `p`, if there is one.
    fn sample(self, p: IVec3) -> Option<IVec3> {
        let s = IVec3::from_array(self.0.map(|s| s as i32));
        let sample = p >> s;
        (sample << s == p).then_some(sample)
    }
}

fn check_length(what: &str, i: usize, len: usize, n: usize, grid: &Grid) -> Result<()> {
    if len == n {
        return Ok(());
    }
    Err(Error::Parameter(format!(
        "{what} array {i} has {len} values but the grid has {n} points ({:?})",
        grid.dims
    )))
}

/// Per-material fields: field and material in range, one value per point.
fn check_material_field_ranges(input: &MaterialInput<'_>, grid: &Grid) -> Result<()> {
    let (k, nf) = (input.fractions.len(), input.fields.len());
    for (i, mf) in input.material_fields.iter().enumerate() {
        if mf.field >= nf || mf.material as usize >= k {
            return Err(Error::Parameter(format!(
                "per-material field {i} is field {} of material {}, but there are {nf} fields and {k} materials",
                mf.field, mf.material
            )));
        }
        check_length("per-material field", i, mf.values.len(), grid.len(), grid)?;
    }
    Ok(())
}

/// Copies of the mixed fields: the given ones, and for a field given only per material (`None`) `Σ
/// fraction × per-material value` over the materials with an array (the others count 0). Lengths and
/// ranges are checked.
fn mixed_fields(input: &MaterialInput<'_>) -> Result<Vec<Vec<f32>>> {
    input
        .fields
        .iter()
        .enumerate()
        .map(|(f, values)| match values {
            Some(values) => Ok(values.to_vec()),
            None => {
                let own: Vec<(usize, &[f32])> = input
                    .material_fields
                    .iter()
                    .filter(|mf| mf.field == f)
                    .map(|mf| (mf.material as usize, mf.values))
                    .collect();
                if own.is_empty() {
                    return Err(Error::Parameter(format!(
                        "field {f} is to be computed from per-material arrays, but none was given for it"
                    )));
                }
                Ok(mixed_from_materials(&input.fractions, &own))
            }
        })
        .collect()
}

/// Per-material fields (in range and of the right length: [`check_material_field_ranges`]): finite
/// at the samples of their material, one per (field, material). Returns their copies indexed by
/// `field * materials + material`.
fn check_material_fields(
    input: &MaterialInput<'_>,
    labels: &[u8],
    grid: &Grid,
) -> Result<Vec<Option<Vec<f32>>>> {
    let (k, nf) = (input.fractions.len(), input.fields.len());
    let mut own: Vec<Option<Vec<f32>>> = vec![None; nf * k];
    for (i, mf) in input.material_fields.iter().enumerate() {
        if let Some(p) =
            (0..grid.len()).find(|&p| labels[p] == mf.material && !mf.values[p].is_finite())
        {
            return Err(Error::NonFinite {
                index: p,
                ijk: grid.ijk(p),
                value: mf.values[p] as f64,
            });
        }
        let slot = &mut own[mf.field * k + mf.material as usize];
        if slot.is_some() {
            return Err(Error::Parameter(format!(
                "per-material field {i} gives field {} of material {} a second time",
                mf.field, mf.material
            )));
        }
        *slot = Some(mf.values.to_vec());
    }
    Ok(own)
}

/// Fractions must be finite, in `[0, 1]` and sum to 1 (to 1 %) at every point.
fn check_fractions(fractions: &[&[f32]], grid: &Grid) -> Result<()> {
    let bad = (0..grid.len()).into_par_iter().find_first(|&p| {
        let mut sum = 0.0f64;
        for f in fractions {
            let v = f[p] as f64;
            if !v.is_finite() || !(-0.01..=1.01).contains(&v) {
                return true;
            }
            sum += v;
        }
        (sum - 1.0).abs() > 0.01
    });
    match bad {
        None => Ok(()),
        Some(p) => {
            let values: Vec<f32> = fractions.iter().map(|f| f[p]).collect();
            Err(Error::Parameter(format!(
                "the volume fractions at point {p} (i, j, k = {:?}) are {values:?}: every fraction must lie in [0, 1] and they must sum to 1 at every point (pick all the materials' fraction arrays)",
                grid.ijk(p)
            )))
        }
    }
}

/// User-given interface meshes: pairs in range and ordered, indices valid, coordinates finite.
fn check_interfaces(given: &[InterfaceMesh], k: usize) -> Result<Vec<InterfaceMesh>> {
    for (i, m) in given.iter().enumerate() {
        let (a, b) = m.pair;
        if b as usize >= k {
            return Err(Error::Parameter(format!(
                "interface mesh {i} names material {b} (pair {:?}) but only {k} volume-fraction arrays were given (materials 0 to {})",
                m.pair,
                k - 1
            )));
        }
        if a >= b {
            return Err(Error::Parameter(format!(
                "interface mesh {i} has the pair ({a}, {b}); a pair names two different materials, the smaller first"
            )));
        }
        let n = m.points.len() as u32;
        if m.triangles.iter().flatten().any(|&v| v >= n) {
            return Err(Error::Parameter(format!(
                "interface mesh {i} has triangles indexing beyond its {n} points"
            )));
        }
        if m.points.iter().flatten().any(|v| !v.is_finite()) {
            return Err(Error::Parameter(format!(
                "interface mesh {i} has a non-finite coordinate"
            )));
        }
    }
    Ok(given
        .iter()
        .filter(|m| !m.triangles.is_empty())
        .cloned()
        .collect())
}

/// A map filled from several threads: each value computed once per key (rarely twice, when two
/// threads race for it; the first stored is kept).
struct Memo<K, V> {
    shards: Vec<Mutex<FxHashMap<K, V>>>,
}

impl<K, V> Default for Memo<K, V> {
    fn default() -> Self {
        Self {
            shards: (0..64).map(|_| Mutex::default()).collect(),
        }
    }
}

impl<K: Hash + Eq + Copy, V: Clone> Memo<K, V> {
    fn shard(&self, key: K) -> std::sync::MutexGuard<'_, FxHashMap<K, V>> {
        self.shards[(FxBuildHasher.hash_one(key) >> 58) as usize]
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
    }

    /// The value stored for `key`, if any.
    fn get(&self, key: &K) -> Option<V> {
        self.shard(*key).get(key).cloned()
    }

    fn get_or_insert_with(&self, key: K, f: impl FnOnce() -> V) -> V {
        if let Some(v) = self.get(&key) {
            return v;
        }
        let v = f();
        self.shard(key).entry(key).or_insert(v).clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(dims: [usize; 3], spacing: [f64; 3]) -> Grid {
        Grid {
            dims,
            origin: [0.0; 3],
            spacing,
        }
    }

    /// The lattice steps are about equal in world units: one level finer than the data along the
    /// finest spacing, as many more along the others as bring them nearest to it; an axis of one
    /// point does not count, and extreme ratios are cut until the lattice fits.
    #[test]
    fn shifts_make_the_lattice_steps_about_equal() {
        let first = |dims, spacing| Shift::first(&grid(dims, spacing), 0.0).0;
        assert_eq!(first([9, 9, 9], [1.0, 1.3, 1.0]), [1, 1, 1]);
        assert_eq!(first([31, 38, 2], [0.4, 0.324, 20.8]), [1, 1, 7]);
        assert_eq!(first([64, 64, 93], [3.2, 3.2, 1.5]), [2, 2, 1]);
        assert_eq!(first([64, 64, 1], [1.0, 1.0, 1e-9]), [1, 1, 1]);
        // Toward a step coarser than the finest spacing: axes finer than it get no extra level.
        let toward = |dims, spacing, step| Shift::first(&grid(dims, spacing), step).0;
        assert_eq!(toward([31, 38, 2], [0.4, 0.324, 20.8], 0.05), [1, 1, 7]);
        assert_eq!(toward([31, 38, 2], [0.4, 0.324, 20.8], 5.0), [1, 1, 3]);
        assert_eq!(toward([32, 32, 52], [1.0, 1.0, 0.01], 1.2), [1, 1, 1]);
        let extreme = grid([100, 100, 100], [1.0, 1.0, 1e9]);
        let shift = Shift::first(&extreme, 0.0);
        assert!(
            shift.points(&extreme) <= MAX_LATTICE_POINTS && shift.0[2] > 1,
            "{shift:?}"
        );
        let s = Shift([1, 2, 3]);
        assert_eq!(s.sample(IVec3::new(6, 12, 16)), Some(IVec3::new(3, 3, 2)));
        assert_eq!(s.sample(IVec3::new(6, 14, 16)), None);
        assert_eq!(s.dims(&grid([3, 3, 3], [1.0; 3])), [5, 9, 17]);
        // For a tolerance: never coarser than one shift for all where that fits, else per axis.
        let for_tolerance = |dims, spacing, t| Shift::for_tolerance(&grid(dims, spacing), t).0;
        assert_eq!(for_tolerance([9, 9, 9], [1.0; 3], 0.3), [2, 2, 2]);
        assert_eq!(for_tolerance([64, 64, 93], [3.2, 3.2, 1.5], 1.0), [2, 2, 2]);
        assert_eq!(for_tolerance([9, 9, 9], [1.0, 1.0, 4.0], 1.0), [2, 2, 3]);
        assert_eq!(
            for_tolerance([31, 38, 2], [0.4, 0.324, 20.8], 0.05),
            [3, 3, 9]
        );
        assert_eq!(
            for_tolerance([31, 38, 2], [0.4, 0.324, 20.8], f64::INFINITY),
            [1, 1, 7]
        );
        assert_eq!(
            for_tolerance([32, 32, 52], [1.0, 1.0, 0.01], 1.2),
            [3, 3, 1]
        );
        assert_eq!(
            for_tolerance([32, 32, 52], [1.0, 1.0, 0.01], 0.3),
            [5, 5, 2]
        );
    }
}
