"""Material Interface Approximation (Gregorski 2002, section 5), checked independently with numpy:

- on the generated impact case (written by `diamonds generate --field impact`, read by ParaView's
  XML reader): the three outputs non-empty; field data; InterfaceError <= InterfaceTolerance and
  FieldError <= FieldTolerance on every tetrahedron; positively oriented, conforming tetrahedra
  (every interior face shared by exactly two, unmatched faces on the box); interface polygons
  crack-free (every edge in >= 2 polygons unless it lies in a face of the box); slice polygons on
  the plane with per-material values; IsGhost consistent with Material, and a material's own value
  equal to the resampled field where all the samples around a vertex are of that material; the base
  mesh (the tetrahedra along the far faces every query on these 32x32x52 samples starts from, every
  sample being a lattice vertex: the filter at tolerances it never reaches) no finer than Adaptive
  Tetrahedra's on the same grid; no more tetrahedra than Adaptive Tetrahedra on Density at the same
  tolerance plus the interface pass; beyond the base mesh no more than the paper's 11,990, and at
  least 3x fewer than plain interpolation at the same field tolerance;
- per-material densities (MaterialFieldArrays "Density for Void", ...): FieldError <= FieldTolerance,
  void's own density 0 at every vertex, no more tetrahedra than with the mixed density; a field
  given only per material (its mixed values: the fraction-weighted sum); MaterialFieldArrays alone
  define their field ("Density for ..." gives "Density", same tetrahedra as naming it in FieldArrays
  without the input array); an unmatched name -> error;
- defaults, the automatic choice of fraction arrays, cell-data input, uniform rectilinear input,
  user interface meshes on input 1;
- the kept model: tolerance, ghost-value and slice changes do not rebuild it; a slice change does
  not refine again;
- bad inputs: an error message, empty outputs, no crash; AbortExecute;
- tissue maps from ../shared's headsq (on its own points and resampled) and bonsai (resampled) when
  present: both tolerances at every sample (T1 probed independently), interface polygons with one
  point per position and no open edge inside the box, no more tetrahedra than Adaptive Tetrahedra on
  T1 at the same tolerance plus the interface pass;
- the CTH armor impact data of ../shared when present, with FieldArrays "Mass" given only per
  material ("Mass for Armor Plate", "Mass for Body, Nose"), and with FieldArrays empty (the
  MaterialFieldArrays define "Mass": the same tetrahedra); skipped with a message otherwise.

  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds pvpython tests/pvpython/test_material.py
"""

import builtins
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import diamonds_checks as dc  # noqa: E402
from paraview import servermanager  # noqa: E402

simple = dc.require_plugin()
dc.check(hasattr(simple, "MaterialInterfaceApproximation"), "MaterialInterfaceApproximation exists in paraview.simple")

# A ProgrammableSource runs its script in __main__ after `from ...numpy_interface.algorithms import *`,
# which replaces abs, all, max, sum... here: the builtins are used by these names below.
babs, ball, bany, bmax = builtins.abs, builtins.all, builtins.any, builtins.max

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
FRACTIONS = ["Volume Fraction for Void", "Volume Fraction for Block", "Volume Fraction for Projectile"]
NAMES = ["Void", "Block", "Projectile"]
BOX = [0.0, 12.0, 0.0, 12.0, -16.0, 4.8]
VTK_TETRA = 10
CTH_MASS_TOLERANCE = 0.001  # "Mass for ..." of the CTH data reach about 0.0094


def fetch_all(f):
    f.UpdatePipeline()
    return [servermanager.Fetch(f, idx=i) for i in range(3)]


def get_array(data, name, cell_data=False):
    a = (data.GetCellData() if cell_data else data.GetPointData()).GetArray(name)
    return None if a is None else vtk_to_numpy(a).astype(np.float64)


def strings(data, name):
    a = data.GetFieldData().GetAbstractArray(name)
    return [] if a is None else [a.GetValue(i) for i in range(a.GetNumberOfValues())]


def model_builds(f):
    f.UpdatePropertyInformation()
    return int(f.GetProperty("NumberOfModelBuilds").GetElement(0))


def refinements(f):
    f.UpdatePropertyInformation()
    return int(f.GetProperty("NumberOfRefinements").GetElement(0))


def polygons(poly):
    """Points (N,3) and the polygons as lists of point ids."""
    points = vtk_to_numpy(poly.GetPoints().GetData()).astype(np.float64) if poly.GetPoints() else np.zeros((0, 3))
    polys = poly.GetPolys()
    offsets = vtk_to_numpy(polys.GetOffsetsArray()).astype(np.int64)
    conn = vtk_to_numpy(polys.GetConnectivityArray()).astype(np.int64)
    return points, [conn[offsets[i] : offsets[i + 1]] for i in range(len(offsets) - 1)]


def on_box(points, bounds, eps=1e-6):
    b = np.asarray(bounds)
    return np.stack([np.abs(points[..., a] - b[2 * a + s]) <= eps for a in range(3) for s in (0, 1)], axis=-1)


def same_tets(a, b):
    """Whether two tetrahedral meshes have the same points and the same cells."""
    if a.GetNumberOfCells() != b.GetNumberOfCells() or a.GetNumberOfPoints() != b.GetNumberOfPoints():
        return False
    pa, pb = (vtk_to_numpy(m.GetPoints().GetData()) for m in (a, b))
    ca, cb = (vtk_to_numpy(m.GetCells().GetConnectivityArray()) for m in (a, b))
    return bool(np.array_equal(pa, pb) and np.array_equal(ca, cb))


def check_tets(ug, bounds, label):
    """Only tetrahedra, positively oriented, conforming; returns (points, tets)."""
    points, tets, types = dc.mesh_arrays(ug)
    dc.check(tets is not None and (types == VTK_TETRA).all(), f"{label}: only VTK_TETRA cells ({ug.GetNumberOfCells()})")
    if tets is None:
        return points, np.zeros((0, 4), np.int64)
    V = points[tets]
    det = np.linalg.det(V[:, 1:] - V[:, :1])
    dc.check((det > 0).all(), f"{label}: every tetrahedron positively oriented")
    box = np.prod([bounds[2 * a + 1] - bounds[2 * a] for a in range(3)])
    dc.check(babs(det.sum() / 6.0 - box) <= 1e-9 * box, f"{label}: tetrahedra fill the box ({det.sum() / 6.0:.6g} vs {box:.6g})")
    faces = np.sort(np.concatenate([tets[:, [0, 1, 2]], tets[:, [0, 1, 3]], tets[:, [0, 2, 3]], tets[:, [1, 2, 3]]]), axis=1)
    uniq, counts = np.unique(faces, axis=0, return_counts=True)
    dc.check(counts.max() <= 2, f"{label}: no face in 3+ tetrahedra")
    single = uniq[counts == 1]
    boxed = on_box(points[single], bounds).all(axis=1).any(axis=1)
    dc.check(boxed.all(), f"{label}: conforming ({(~boxed).sum()} unmatched interior faces of {len(uniq)})")
    return points, tets


def check_crack_free(poly, bounds, label):
    points = vtk_to_numpy(poly.GetPoints().GetData()).astype(np.float64) if poly.GetPoints() else np.zeros((0, 3))
    offsets = vtk_to_numpy(poly.GetPolys().GetOffsetsArray()).astype(np.int64)
    conn = vtk_to_numpy(poly.GetPolys().GetConnectivityArray()).astype(np.int64)
    sizes = np.diff(offsets)
    dc.check(len(sizes) > 0 and (sizes >= 3).all(), f"{label}: {len(sizes)} polygons of 3+ points")
    # Edge k of a polygon joins its point k to the next one, the last to the first.
    following = np.arange(1, len(conn) + 1)
    following[offsets[1:] - 1] = offsets[:-1]
    edges = np.sort(np.stack([conn, conn[following]], axis=1), axis=1)
    uniq, counts = np.unique(edges, axis=0, return_counts=True)
    open_edges = uniq[counts < 2]
    ok = on_box(points[open_edges], bounds).all(axis=1).any(axis=1) if len(open_edges) else np.zeros(0, bool)
    dc.check(ok.all(), f"{label}: crack-free ({(~ok).sum()} open edges inside the box, {len(uniq)} edges)")


def labels_of(image):
    """Material of each input sample: the largest fraction, the lowest index on ties."""
    f = np.stack([vtk_to_numpy(image.GetPointData().GetArray(n)).astype(np.float64) for n in FRACTIONS])
    return np.argmax(f, axis=0)


def check_ghosts(image, ug, field, label):
    """IsGhost (m) == (Material != m); m's own value == the mixed resampled value where every sample
    of non-zero trilinear weight around the vertex is of material m."""
    material = get_array(ug, "Material").astype(int)
    mixed = get_array(ug, field)
    points = vtk_to_numpy(ug.GetPoints().GetData()).astype(np.float64)
    dims = np.array(image.GetDimensions())
    origin = np.array(image.GetOrigin())
    spacing = np.array(image.GetSpacing())
    labels = labels_of(image)
    u = (points - origin) / spacing
    base = np.clip(np.floor(u).astype(int), 0, dims - 2)
    t = u - base
    uniform = np.ones(len(points), bool)
    for c in range(8):
        o = np.array([c & 1, (c >> 1) & 1, c >> 2])
        w = np.prod(np.where(o == 1, t, 1.0 - t), axis=1)
        idx = base + o
        lin = idx[:, 0] + dims[0] * (idx[:, 1] + dims[1] * idx[:, 2])
        uniform &= (w <= 1e-9) | (labels[lin] == material)
    checked = 0
    for m, name in enumerate(NAMES):
        own = get_array(ug, f"{field} ({name})")
        ghost = get_array(ug, f"IsGhost ({name})")
        dc.check(own is not None and ghost is not None, f"{label}: point arrays '{field} ({name})' and 'IsGhost ({name})'")
        if own is None or ghost is None:
            continue
        dc.check(((ghost == 0) == (material == m)).all(), f"{label}: IsGhost ({name}) is 1 exactly where Material != {m}")
        sel = (material == m) & uniform
        checked += int(sel.sum())
        err = np.abs(own[sel] - mixed[sel]).max() if sel.any() else 0.0
        dc.check(err <= 1e-4 * bmax(1.0, np.abs(mixed).max()), f"{label}: {field} ({name}) == {field} at {sel.sum()} vertices of {name} in uniform cells (max diff {err:.3g})")
    dc.check(checked > 100, f"{label}: {checked} vertices checked in uniform cells")


# ---- The impact case, written by the CLI and read by ParaView.
tmp = tempfile.mkdtemp(prefix="diamonds-material-")
impact_path = os.path.join(tmp, "impact.vti")
subprocess.run([dc.diamonds_binary(), "generate", impact_path, "--field", "impact"], check=True)
reader = simple.XMLImageDataReader(FileName=[impact_path])
reader.UpdatePipeline()
image = servermanager.Fetch(reader)
dc.check(image.GetDimensions() == (32, 32, 52), f"impact case 32x32x52 ({image.GetDimensions()})")
dc.check(np.allclose(image.GetBounds(), BOX), f"impact case bounds {image.GetBounds()}")

# Defaults.
default = simple.MaterialInterfaceApproximation(Input=reader)
dc.check(list(default.VolumeFractionArrays) == [] and list(default.FieldArrays) == [], "default: no arrays selected (the fraction arrays are found by name)")
cell_diagonal = np.sqrt(12.0**2 + 12.0**2 + 20.8**2) / np.cbrt(31 * 31 * 51)
dc.check(babs(default.InterfaceTolerance - cell_diagonal) < 1e-6, f"default InterfaceTolerance: about a cell diagonal ({default.InterfaceTolerance:.4g} vs {cell_diagonal:.4g})")
dc.check(default.FieldTolerance == 3.0 and default.UseGhostValues == 1, "default FieldTolerance 3, UseGhostValues on")
dc.check(np.allclose(list(default.SliceOrigin), [6.0, 6.0, -5.6]) and list(default.SliceNormal) == [1.0, 0.0, 0.0], f"default slice through the centre, normal x ({list(default.SliceOrigin)})")
explicit_zero = simple.MaterialInterfaceApproximation(Input=reader, InterfaceTolerance=0.0)
dc.check(explicit_zero.InterfaceTolerance == 0.0, "MaterialInterfaceApproximation(..., InterfaceTolerance=0) keeps 0")
with dc.ErrorCapture(default) as errors:
    d0, d1, d2 = fetch_all(default)
dc.check(not errors.messages, f"defaults: no error ({errors.text()[:200]})")
dc.check(d0.GetNumberOfCells() > 0 and d1.GetNumberOfCells() > 0 and d2.GetNumberOfCells() > 0, "defaults: three non-empty outputs")
dc.check(strings(d0, "MaterialNames") == NAMES, f"fraction arrays found by name, materials {strings(d0, 'MaterialNames')}")

# The paper's tolerances.
filt = simple.MaterialInterfaceApproximation(Input=reader, VolumeFractionArrays=FRACTIONS, FieldArrays=["Density"], InterfaceTolerance=0.15, FieldTolerance=3.0)
filt.SliceOrigin = [6.0, 0.8, -4.0]
filt.SliceNormal = [0.0, 1.0, 0.0]
tets_out, iface_out, slice_out = fetch_all(filt)
n_tets = tets_out.GetNumberOfCells()
print(f"impact case: {n_tets} tetrahedra, {iface_out.GetNumberOfCells()} interface polygons, {slice_out.GetNumberOfCells()} slice polygons")
dc.check(n_tets > 0 and iface_out.GetNumberOfCells() > 0 and slice_out.GetNumberOfCells() > 0, "three non-empty outputs")
# The base mesh every query starts from (tolerances never reached: no split beyond it) is no finer than
# Adaptive Tetrahedra's on the same grid: the material lattice, one level finer, costs nothing more at
# the far faces.
def tetrahedra_of(f):
    f.UpdatePipeline()
    return servermanager.Fetch(f).GetNumberOfCells()


BASE_TETS = tetrahedra_of(simple.MaterialInterfaceApproximation(Input=reader, VolumeFractionArrays=FRACTIONS, FieldArrays=["Density"], InterfaceTolerance=1e9, FieldTolerance=1e9))
at_base = tetrahedra_of(simple.AdaptiveTetrahedra(Input=reader, Scalars=["POINTS", "Density"], Tolerance=1e9))
dc.check(0 < BASE_TETS <= at_base, f"base mesh: {BASE_TETS} tetrahedra <= Adaptive Tetrahedra's {at_base} on the same grid")
at_tets = tetrahedra_of(simple.AdaptiveTetrahedra(Input=reader, Scalars=["POINTS", "Density"], Tolerance=3.0))
interface_tets = int(dc.field_value(tets_out, "InterfaceTetrahedra"))
dc.check(n_tets <= at_tets + interface_tets, f"{n_tets} tetrahedra <= Adaptive Tetrahedra's {at_tets} on Density at tolerance 3 + the interface pass's {interface_tets}")
dc.check(n_tets - BASE_TETS <= 11990, f"{n_tets} - {BASE_TETS} base tetrahedra <= the paper's 11,990 at interface error 0.15, density error 3")
dc.check(dc.field_value(tets_out, "NumberOfTetrahedra") == n_tets, "field data NumberOfTetrahedra")
dc.check(0 < dc.field_value(tets_out, "InterfaceTetrahedra") <= n_tets, f"field data InterfaceTetrahedra {dc.field_value(tets_out, 'InterfaceTetrahedra')}")
dc.check(dc.field_value(tets_out, "InterfaceTolerance") == 0.15 and dc.field_value(tets_out, "FieldTolerance") == 3.0, "field data tolerances")
dc.check(dc.field_value(tets_out, "MaximumInterfaceError") <= 0.15 and dc.field_value(tets_out, "MaximumFieldError") <= 3.0, "field data maximum errors within the tolerances")
dc.check(strings(tets_out, "MaterialNames") == NAMES and strings(tets_out, "FieldNames") == ["Density"], f"names {strings(tets_out, 'MaterialNames')}")
interface_names = strings(tets_out, "InterfaceNames")
dc.check(set(interface_names) <= {"Void|Block", "Void|Projectile", "Block|Projectile"} and len(interface_names) == 3, f"interfaces {interface_names}")
ie, fe = get_array(tets_out, "InterfaceError", True), get_array(tets_out, "FieldError", True)
dc.check(ie.max() <= 0.15 * (1 + 1e-6), f"InterfaceError <= 0.15 on every tetrahedron (max {ie.max():.4g})")
dc.check(fe.max() <= 3.0 * (1 + 1e-6), f"FieldError <= 3 on every tetrahedron (max {fe.max():.4g})")
mask = get_array(tets_out, "Materials", True).astype(np.int64)
count = get_array(tets_out, "NumberOfMaterials", True)
dc.check((np.array([bin(int(v)).count("1") for v in mask]) == count).all() and (mask > 0).all() and (mask < 8).all(), "Materials bit masks and NumberOfMaterials agree")
dc.check(get_array(tets_out, "BisectionDepth", True) is not None, "cell data BisectionDepth")
for name in ["Material", "SignedDistance Void|Block", "SignedDistance Projectile", "Density", "Density (Block)", "IsGhost (Projectile)"]:
    dc.check(tets_out.GetPointData().GetArray(name) is not None, f"point array '{name}'")
check_tets(tets_out, BOX, "impact tetrahedra")
check_ghosts(image, tets_out, "Density", "impact")
phi = np.stack([get_array(tets_out, f"SignedDistance {n}") for n in NAMES], axis=1)
material = get_array(tets_out, "Material").astype(int)
dc.check((phi[np.arange(len(material)), material] <= 0).all(), "SignedDistance <M> <= 0 at the vertices of M")
dc.check((np.argmin(phi, axis=1) == material).all(), "Material is the material of smallest signed distance at every vertex")
pair = get_array(tets_out, "SignedDistance Void|Block")
vb = (material == 0) | (material == 1)
dc.check((np.sign(pair[vb & (np.abs(pair) > 1e-6)]) == np.where(material == 1, 1, -1)[vb & (np.abs(pair) > 1e-6)]).mean() > 0.95, "SignedDistance Void|Block mostly negative at Void vertices, positive at Block vertices")

# Interfaces.
check_crack_free(iface_out, BOX, "interface polygons")
a, b, idx = get_array(iface_out, "MaterialA", True), get_array(iface_out, "MaterialB", True), get_array(iface_out, "Interface", True)
dc.check((a < b).all() and (b <= 2).all() and (idx >= 0).all(), "interface polygons: MaterialA < MaterialB, a valid Interface index")
named = [interface_names[int(i)] for i in idx[:50]]
dc.check(ball(n == f"{NAMES[int(x)]}|{NAMES[int(y)]}" for n, x, y in zip(named, a[:50], b[:50])), "Interface indexes InterfaceNames consistently with MaterialA/B")

# Slice.
sp, spolys = polygons(slice_out)
dc.check(np.abs(sp[:, 1] - 0.8).max() < 1e-9, "slice polygons lie on the plane y = 0.8")
sm = get_array(slice_out, "Material", True)
dc.check(set(np.unique(sm).astype(int).tolist()) == {0, 1, 2}, f"slice polygons of every material ({np.unique(sm)})")
sd_density = get_array(slice_out, "Density")
dc.check(sd_density is not None and len(sd_density) == len(sp), "slice point data Density")
if sd_density is not None:
    void_points = np.unique(np.concatenate([p for p, m in zip(spolys, sm) if m == 0]))
    block_points = np.unique(np.concatenate([p for p, m in zip(spolys, sm) if m == 1]))
    dc.check(np.median(sd_density[void_points]) < 1.0, f"slice: void polygons carry the void's density (median {np.median(sd_density[void_points]):.3g})")
    dc.check(np.median(sd_density[block_points]) > 5.0, f"slice: block polygons carry the block's density (median {np.median(sd_density[block_points]):.3g})")

# Plain interpolation needs more tetrahedra at the same field tolerance.
plain = simple.MaterialInterfaceApproximation(Input=reader, VolumeFractionArrays=FRACTIONS, FieldArrays=["Density"], InterfaceTolerance=0.15, FieldTolerance=3.0, UseGhostValues=0)
p0, p1, p2 = fetch_all(plain)
print(f"ghost values: {n_tets} tetrahedra; plain interpolation: {p0.GetNumberOfCells()}")
dc.check(p0.GetNumberOfCells() - BASE_TETS >= 3 * (n_tets - BASE_TETS), f"UseGhostValues off: {p0.GetNumberOfCells()} >= 3 x {n_tets} tetrahedra beyond the {BASE_TETS} of the base mesh")
dc.check(get_array(p0, "FieldError", True).max() <= 3.0 * (1 + 1e-6), "UseGhostValues off: FieldError <= 3")
dc.check(p0.GetPointData().GetArray("Density (Block)") is None and p0.GetPointData().GetArray("Density") is not None, "UseGhostValues off: mixed field only")
check_tets(p0, BOX, "plain interpolation")

# ---- Per-material densities: each material's own density instead of the mixed one.
MATERIAL_DENSITIES = [f"Density for {n}" for n in NAMES]
dc.check(ball(image.GetPointData().GetArray(n) is not None for n in MATERIAL_DENSITIES), f"the generator writes {MATERIAL_DENSITIES}")
own = simple.MaterialInterfaceApproximation(Input=reader, VolumeFractionArrays=FRACTIONS, FieldArrays=["Density"], MaterialFieldArrays=MATERIAL_DENSITIES, InterfaceTolerance=0.15, FieldTolerance=3.0)
with dc.ErrorCapture(own) as errors:
    o0, o1, o2 = fetch_all(own)
print(f"impact case at interface 0.15, density 3: {n_tets} tetrahedra with the mixed density, {o0.GetNumberOfCells()} with per-material densities")
dc.check(not errors.messages and o0.GetNumberOfCells() > 0 and o1.GetNumberOfCells() > 0 and o2.GetNumberOfCells() > 0, f"per-material densities: three non-empty outputs {errors.text()[:200]}")
dc.check(get_array(o0, "FieldError", True).max() <= 3.0 * (1 + 1e-6), f"per-material densities: FieldError <= 3 (max {get_array(o0, 'FieldError', True).max():.4g})")
dc.check(o0.GetNumberOfCells() <= n_tets, f"per-material densities: {o0.GetNumberOfCells()} <= {n_tets} tetrahedra (mixed density)")
own_material = get_array(o0, "Material").astype(int)
void_density = get_array(o0, "Density (Void)")
dc.check(void_density is not None and (void_density[own_material == 0] == 0).all() and (own_material == 0).sum() > 100, f"per-material densities: 'Density (Void)' is 0 at the {(own_material == 0).sum()} void vertices")
mixed_void = get_array(tets_out, "Density (Void)")
dc.check(mixed_void[material == 0].max() > 1.0, f"mixed density only: void's own value is the mixed density of its samples (max {mixed_void[material == 0].max():.3g})")
block_density = get_array(o0, "Density (Block)")
dc.check(np.median(block_density[own_material == 1]) > 7.0, "per-material densities: the block's own density at its vertices")
# A field given only per material: no input array "Density", its mixed values the fraction-weighted sum
# of the per-material arrays (void has none and counts 0).
only_own = simple.PassArrays(Input=reader, PointDataArrays=FRACTIONS + MATERIAL_DENSITIES[1:], CellDataArrays=[], FieldDataArrays=[])
derived = simple.MaterialInterfaceApproximation(Input=only_own, VolumeFractionArrays=FRACTIONS, FieldArrays=["Density"], MaterialFieldArrays=MATERIAL_DENSITIES[1:], InterfaceTolerance=0.15, FieldTolerance=3.0)
with dc.ErrorCapture(derived) as errors:
    e0 = fetch_all(derived)[0]
dc.check(not errors.messages and e0.GetNumberOfCells() > 0, f"Density only per material: {e0.GetNumberOfCells()} tetrahedra {errors.text()[:200]}")
if e0.GetNumberOfCells():
    points = vtk_to_numpy(e0.GetPoints().GetData()).astype(np.float64)
    dims, origin, spacing = np.array(image.GetDimensions()), np.array(image.GetOrigin()), np.array(image.GetSpacing())
    u = (points - origin) / spacing
    base = np.clip(np.floor(u).astype(int), 0, dims - 2)
    t = u - base
    density = vtk_to_numpy(image.GetPointData().GetArray("Density")).astype(np.float64)
    want = np.zeros(len(points))
    for c in range(8):
        o = np.array([c & 1, (c >> 1) & 1, c >> 2])
        idx = base + o
        want += np.prod(np.where(o == 1, t, 1.0 - t), axis=1) * density[idx[:, 0] + dims[0] * (idx[:, 1] + dims[1] * idx[:, 2])]
    err = np.abs(get_array(e0, "Density") - want).max()
    dc.check(err < 1e-3, f"Density only per material: the mixed field is the sum of fraction x per-material density (max diff {err:.3g} from the generated Density)")
    dc.check(get_array(e0, "FieldError", True).max() <= 3.0 * (1 + 1e-6), "Density only per material: FieldError <= 3")

# MaterialFieldArrays alone define their field: "Density for ..." gives a field "Density" given only per
# material (the input's "Density" array unused), as naming "Density" in FieldArrays without that array.
implicit = simple.MaterialInterfaceApproximation(Input=reader, VolumeFractionArrays=FRACTIONS, FieldArrays=[], MaterialFieldArrays=MATERIAL_DENSITIES, InterfaceTolerance=0.15, FieldTolerance=3.0)
no_density = simple.PassArrays(Input=reader, PointDataArrays=FRACTIONS + MATERIAL_DENSITIES, CellDataArrays=[], FieldDataArrays=[])
explicit = simple.MaterialInterfaceApproximation(Input=no_density, VolumeFractionArrays=FRACTIONS, FieldArrays=["Density"], MaterialFieldArrays=MATERIAL_DENSITIES, InterfaceTolerance=0.15, FieldTolerance=3.0)
with dc.ErrorCapture(implicit) as errors:
    i0 = fetch_all(implicit)[0]
with dc.ErrorCapture(explicit) as explicit_errors:
    x0 = fetch_all(explicit)[0]
print(f"Density from MaterialFieldArrays only: {i0.GetNumberOfCells()} tetrahedra, {x0.GetNumberOfCells()} naming it in FieldArrays")
dc.check(not errors.messages and not explicit_errors.messages and i0.GetNumberOfCells() > 0, f"Density from MaterialFieldArrays only: non-empty output {errors.text()[:200]} {explicit_errors.text()[:200]}")
dc.check(strings(i0, "FieldNames") == ["Density"] and i0.GetPointData().GetArray("Density") is not None and i0.GetPointData().GetArray("Density (Block)") is not None, f"Density from MaterialFieldArrays only: output field Density with its per-material values ({strings(i0, 'FieldNames')})")
dc.check(same_tets(i0, x0), "Density from MaterialFieldArrays only: the same tetrahedra as FieldArrays ['Density'] without the input array")
if i0.GetNumberOfCells() and x0.GetNumberOfCells() == i0.GetNumberOfCells():
    dc.check(np.array_equal(get_array(i0, "Density"), get_array(x0, "Density")), "Density from MaterialFieldArrays only: the same mixed Density as naming it")

# ---- The kept model.
builds, refs = model_builds(filt), refinements(filt)
dc.check(builds == 1 and refs == 1, f"one model build, one refinement so far ({builds}, {refs})")
filt.FieldTolerance = 1.5
finer = fetch_all(filt)[0]
dc.check(model_builds(filt) == 1 and refinements(filt) == 2, "FieldTolerance change: no model rebuild, one refinement")
dc.check(finer.GetNumberOfCells() > n_tets and get_array(finer, "FieldError", True).max() <= 1.5 * (1 + 1e-6), f"FieldTolerance 1.5: {finer.GetNumberOfCells()} tetrahedra, FieldError <= 1.5")
filt.InterfaceTolerance = 0.3
filt.UseGhostValues = 0
fetch_all(filt)
filt.UseGhostValues = 1
filt.SliceOrigin = [6.0, 1.2, -4.0]
moved = fetch_all(filt)[2]
dc.check(model_builds(filt) == 1 and refinements(filt) == 4, f"tolerance, ghost-value and slice changes: one model build, slice change without refinement ({model_builds(filt)}, {refinements(filt)})")
dc.check(moved.GetNumberOfCells() > 0 and np.abs(polygons(moved)[0][:, 1] - 1.2).max() < 1e-9, "moved slice on y = 1.2")
filt.FieldArrays = []
fetch_all(filt)
dc.check(model_builds(filt) == 2, "a change of the arrays rebuilds the model")

# ---- Cell-data input (converted the standard way) and a uniform rectilinear grid.
cell_input = simple.PointDatatoCellData(Input=reader)
cell_input.PassPointData = 0
on_cells = simple.MaterialInterfaceApproximation(Input=cell_input, VolumeFractionArrays=FRACTIONS, FieldArrays=["Density"], InterfaceTolerance=0.15, FieldTolerance=3.0)
with dc.ErrorCapture(on_cells) as errors:
    c0, c1, c2 = fetch_all(on_cells)
dc.check(not errors.messages and c0.GetNumberOfCells() > 0 and c1.GetNumberOfCells() > 0, f"cell-data fractions: {c0.GetNumberOfCells()} tetrahedra {errors.text()[:200]}")
dc.check(get_array(c0, "FieldError", True).max() <= 3.0 * (1 + 1e-6), "cell-data input: FieldError <= 3")

rect_grid = simple.ProgrammableSource(OutputDataSetType="vtkRectilinearGrid")
rect_grid.ScriptRequestInformation = "self.GetExecutive().GetOutputInformation(0).Set(self.GetExecutive().WHOLE_EXTENT(), 0, 15, 0, 13, 0, 11)\n"
rect_grid.Script = """
import numpy as np
from vtkmodules.util.numpy_support import numpy_to_vtk
out = self.GetOutput()
out.SetExtent(0, 15, 0, 13, 0, 11)
xs, ys, zs = np.linspace(-3, 3, 16), np.linspace(-2.6, 2.6, 14), np.linspace(-2.2, 2.2, 12)
out.SetXCoordinates(numpy_to_vtk(xs, deep=1)); out.SetYCoordinates(numpy_to_vtk(ys, deep=1)); out.SetZCoordinates(numpy_to_vtk(zs, deep=1))
z, y, x = np.meshgrid(zs, ys, xs, indexing='ij')
ball = np.clip(1.8 - np.sqrt(x * x + y * y + z * z), 0, 1).ravel()
for name, v in (('Volume Fraction for Ball', ball), ('Void Volume Fraction', 1 - ball), ('Pressure', 2 * x.ravel() + 5 * ball)):
    a = numpy_to_vtk(np.ascontiguousarray(v, dtype=np.float32), deep=1); a.SetName(name); out.GetPointData().AddArray(a)
"""
rect_grid.UpdatePipeline()
on_rect = simple.MaterialInterfaceApproximation(Input=rect_grid, FieldArrays=["Pressure"], InterfaceTolerance=0.05, FieldTolerance=0.2)
with dc.ErrorCapture(on_rect) as errors:
    r0, r1, r2 = fetch_all(on_rect)
# 16x14x12 points, not 2^k + 1: a warning when (and only when) a tolerance is not reached, telling the
# error reached.
reached = r0.GetFieldData().GetArray("MaximumFieldError").GetValue(0)
unmet = [m for m in errors.messages if "cannot meet the tolerances" in m]
dc.check(len(unmet) == (1 if reached > 0.2 else 0) and len(errors.messages) == len(unmet), f"uniform vtkRectilinearGrid: a warning exactly when the tolerance is not reached ({reached:.3g}): {errors.text()[:300]}")
dc.check(r0.GetNumberOfCells() > 0 and r1.GetNumberOfCells() > 0, f"uniform vtkRectilinearGrid: {r0.GetNumberOfCells()} tetrahedra")
dc.check(strings(r0, "MaterialNames") == ["Ball", "Void"], f"names from 'Volume Fraction for Ball' and 'Void Volume Fraction': {strings(r0, 'MaterialNames')}")
check_tets(r0, [-3, 3, -2.6, 2.6, -2.2, 2.2], "rectilinear grid")
check_crack_free(r1, [-3, 3, -2.6, 2.6, -2.2, 2.2], "rectilinear grid interfaces")

# ---- User interface meshes on input 1: the approximated interfaces of a first run, triangulated,
# with their material pair as the 2-component array InterfaceMaterials (oriented from A into B).
triangulated_interfaces = simple.Triangulate(Input=simple.OutputPort(filt, 1))
filt.FieldArrays = ["Density"]
filt.InterfaceTolerance = 0.15
labelled = simple.ProgrammableFilter(Input=triangulated_interfaces)
labelled.Script = """
import numpy as np
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy
inp = self.GetPolyDataInput(); out = self.GetPolyDataOutput()
out.ShallowCopy(inp)
a = vtk_to_numpy(inp.GetCellData().GetArray('MaterialA')); b = vtk_to_numpy(inp.GetCellData().GetArray('MaterialB'))
pairs = numpy_to_vtk(np.ascontiguousarray(np.stack([a, b], 1).astype(np.int32)), deep=1)
pairs.SetName('InterfaceMaterials')
out.GetCellData().AddArray(pairs)
"""
given = simple.MaterialInterfaceApproximation(Input=reader, InterfaceMeshes=labelled, VolumeFractionArrays=FRACTIONS, FieldArrays=["Density"], InterfaceTolerance=0.15, FieldTolerance=3.0)
with dc.ErrorCapture(given) as errors:
    g0, g1, g2 = fetch_all(given)
dc.check(not errors.messages and g0.GetNumberOfCells() > 0 and g1.GetNumberOfCells() > 0, f"user interface meshes: {g0.GetNumberOfCells()} tetrahedra {errors.text()[:200]}")
dc.check(get_array(g0, "InterfaceError", True).max() <= 0.15 * (1 + 1e-6), "user interface meshes: InterfaceError <= 0.15")
no_pairs = simple.MaterialInterfaceApproximation(Input=reader, InterfaceMeshes=triangulated_interfaces, VolumeFractionArrays=FRACTIONS)


# ---- Bad inputs: an error that says what is wrong, empty outputs, no crash.
def expect_error(f, phrase, label):
    phrases = phrase if isinstance(phrase, tuple) else (phrase,)
    with dc.ErrorCapture(f) as errors:
        outs = fetch_all(f)
    text = errors.text()
    print(f"   [{label}] {text.strip().splitlines()[-1] if text.strip() else '(no message)'}")
    dc.check(bany(p.lower() in text.lower() for p in phrases), f"{label}: error mentions {' or '.join(map(repr, phrases))}")
    dc.check(ball(o.GetNumberOfCells() == 0 and o.GetNumberOfPoints() == 0 for o in outs), f"{label}: empty outputs")


M = simple.MaterialInterfaceApproximation
expect_error(M(Input=reader, VolumeFractionArrays=[FRACTIONS[0], "No Such Array"]), "no numeric point or cell array named", "missing fraction array")
expect_error(M(Input=reader, VolumeFractionArrays=FRACTIONS, FieldArrays=["Nope"]), "Nope", "missing field array")
expect_error(M(Input=reader, VolumeFractionArrays=[FRACTIONS[0]]), "at least 2", "one fraction array only")
expect_error(M(Input=reader, VolumeFractionArrays=FRACTIONS[:2]), "sum to 1", "fractions not summing to 1 (a material left out)")
expect_error(M(Input=reader, VolumeFractionArrays=FRACTIONS, FieldArrays=[FRACTIONS[0]]), "twice", "an array selected twice")
steel = simple.Calculator(Input=reader, ResultArrayName="Density for Steel", Function="Density")
expect_error(M(Input=steel, VolumeFractionArrays=FRACTIONS, FieldArrays=["Density"], MaterialFieldArrays=["Density for Steel"]), ("matches no field", "Density (Projectile)"), "a per-material array matching no field and material")
# A per-material array of a field not selected now defines that field ("Density"); "Mass" is still no
# array of the input and has no per-material array.
expect_error(M(Input=reader, VolumeFractionArrays=FRACTIONS, FieldArrays=["Mass"], MaterialFieldArrays=["Density for Block"]), "no numeric point or cell array named \"Mass\"", "a per-material array of a field not selected defines it; Mass still missing")
# A typo cannot create a field: the array lookup fails first.
expect_error(M(Input=reader, VolumeFractionArrays=FRACTIONS, MaterialFieldArrays=["Densty for Block"]), "no numeric point or cell array named \"Densty for Block\"", "a per-material array not in the input, no FieldArrays")
expect_error(M(Input=reader, VolumeFractionArrays=FRACTIONS, FieldArrays=["Mass"]), "Mass", "a field neither in the input nor per material")
expect_error(M(Input=reader, VolumeFractionArrays=FRACTIONS, InterfaceTolerance=-0.1), "InterfaceTolerance must be", "negative InterfaceTolerance")
expect_error(M(Input=reader, VolumeFractionArrays=FRACTIONS, FieldArrays=["Density"], FieldTolerance=-1.0), "FieldTolerance must be", "negative FieldTolerance")
zero_normal = M(Input=reader, VolumeFractionArrays=FRACTIONS)
zero_normal.SliceNormal = [0.0, 0.0, 0.0]
expect_error(zero_normal, "normal", "zero slice normal")
vector_input = simple.Calculator(Input=reader, ResultArrayName="Vec", Function="Density*iHat")
expect_error(M(Input=vector_input, VolumeFractionArrays=FRACTIONS, FieldArrays=["Vec"]), "components", "3-component field")
nan_image = dc.programmable_image(simple, (9, 8, 7), "f = np.clip(x / 8.0, 0, 1)\nf[100] = np.nan\nadd('Volume Fraction for A', f)\nadd('Volume Fraction for B', 1 - f)\n")
expect_error(M(Input=nan_image), ("nan", "non-finite"), "NaN fraction")
nan_field = dc.programmable_image(simple, (9, 8, 7), "f = np.clip(x / 8.0, 0, 1)\nadd('Volume Fraction for A', f)\nadd('Volume Fraction for B', 1 - f)\np = x.copy()\np[100] = np.inf\nadd('Pressure', p)\n")
expect_error(M(Input=nan_field, FieldArrays=["Pressure"]), '"pressure" holds a non-finite value', "non-finite field: the message names the array")
flat_image = dc.programmable_image(simple, (9, 8, 1), "f = np.clip(x / 8.0, 0, 1)\nadd('Volume Fraction for A', f)\nadd('Volume Fraction for B', 1 - f)\n")
expect_error(M(Input=flat_image), "at least 2 points", "2-D image")
uneven_grid = simple.ProgrammableSource(OutputDataSetType="vtkRectilinearGrid")
uneven_grid.ScriptRequestInformation = "self.GetExecutive().GetOutputInformation(0).Set(self.GetExecutive().WHOLE_EXTENT(), 0, 7, 0, 6, 0, 5)\n"
uneven_grid.Script = """
import numpy as np
from vtkmodules.util.numpy_support import numpy_to_vtk
out = self.GetOutput()
out.SetExtent(0, 7, 0, 6, 0, 5)
out.SetXCoordinates(numpy_to_vtk(np.array([0, 1, 2, 3, 4.5, 6, 7.5, 9.0]), deep=1))
out.SetYCoordinates(numpy_to_vtk(np.linspace(0, 6, 7), deep=1)); out.SetZCoordinates(numpy_to_vtk(np.linspace(0, 5, 6), deep=1))
f = np.tile(np.clip(np.array([0, 1, 2, 3, 4.5, 6, 7.5, 9.0]) / 9.0, 0, 1), 42).astype(np.float32)
for name, v in (('Volume Fraction for A', f), ('Volume Fraction for B', 1 - f)):
    a = numpy_to_vtk(v, deep=1); a.SetName(name); out.GetPointData().AddArray(a)
"""
expect_error(M(Input=uneven_grid), "not uniformly spaced", "non-uniform rectilinear grid")
expect_error(no_pairs, "InterfaceMaterials", "interface meshes without their material array")
after = fetch_all(M(Input=reader, VolumeFractionArrays=FRACTIONS, FieldArrays=["Density"]))
dc.check(after[0].GetNumberOfCells() > 0, "good input after the bad ones")

# Abort during the refinement: empty outputs; the next update works.
abort_filter = M(Input=reader, VolumeFractionArrays=FRACTIONS, FieldArrays=["Density"], FieldTolerance=0.5)
vtk_filter = abort_filter.GetClientSideObject()
seen = []


def abort_on_progress(obj, _event):
    seen.append(obj.GetProgress())
    if obj.GetProgress() > 0.35:
        obj.SetAbortExecute(1)


tag = vtk_filter.AddObserver("ProgressEvent", abort_on_progress)
aborted = fetch_all(abort_filter)
vtk_filter.RemoveObserver(tag)
vtk_filter.SetAbortExecute(0)
dc.check(len(seen) > 0 and ball(o.GetNumberOfCells() == 0 for o in aborted), f"AbortExecute during the refinement: empty outputs ({len(seen)} progress events)")
abort_filter.FieldTolerance = 3.0
dc.check(fetch_all(abort_filter)[0].GetNumberOfCells() > 0, "the next update refines normally")

# ---- The proxy as the GUI sees it.
prototype = servermanager.ProxyManager().GetPrototypeProxy("filters", "MaterialInterfaceApproximation")
hints = prototype.GetHints()
menu = hints.FindNestedElementByName("ShowInMenu") if hints else None
dc.check(menu is not None and menu.GetAttribute("category") == "Diamonds", "listed in the Filters > Diamonds menu")
dc.check(prototype.GetXMLLabel() == "Material Interface Approximation", "label 'Material Interface Approximation'")
doc = prototype.GetDocumentation()
dc.check(len(doc.GetDescription() or "") > 2000 and "section 5" in (doc.GetDescription() or ""), f"a long <Documentation> citing section 5 ({len(doc.GetDescription() or '')} chars)")
dc.check([prototype.GetOutputPortName(i) for i in range(3)] == ["Tetrahedra", "Interfaces", "Slice"], "output ports Tetrahedra, Interfaces, Slice")
undocumented = [n for n in ("VolumeFractionArrays", "FieldArrays", "MaterialFieldArrays", "InterfaceTolerance", "FieldTolerance", "UseGhostValues", "SliceOrigin", "SliceNormal") if not (prototype.GetProperty(n).GetDocumentation() and prototype.GetProperty(n).GetDocumentation().GetDescription())]
dc.check(not undocumented, f"every property documented ({undocumented})")

# ---- The CTH armor impact data of ../shared (non-uniform along x and z: resampled first).
cth_path = dc.shared_path("data/multimaterial/cth_armor_impact.vtr")
if cth_path is not None:
    cth = simple.XMLRectilinearGridReader(FileName=[cth_path])
    cth_fractions = ["Void Volume Fraction", "Volume Fraction for Armor Plate", "Volume Fraction for Body, Nose"]
    expect_error(M(Input=cth, VolumeFractionArrays=cth_fractions), "not uniformly spaced", "CTH as is (non-uniform)")
    resampled = simple.ResampleToImage(Input=cth, SamplingDimensions=[129, 65, 65])
    # "Mass" is no array of the data: given only per material (void has none and counts 0).
    cth_filter = M(Input=resampled, VolumeFractionArrays=cth_fractions, FieldArrays=["Mass"], MaterialFieldArrays=["Mass for Armor Plate", "Mass for Body, Nose"], InterfaceTolerance=0.1, FieldTolerance=CTH_MASS_TOLERANCE)
    with dc.ErrorCapture(cth_filter) as errors:
        k0, k1, k2 = fetch_all(cth_filter)
    print(f"CTH resampled 129x65x65: {k0.GetNumberOfCells()} tetrahedra, {k1.GetNumberOfCells()} interface polygons {errors.text()[:300]}")
    dc.check(k0.GetNumberOfCells() > 0 and k1.GetNumberOfCells() > 0 and k2.GetNumberOfCells() > 0, "CTH resampled: three non-empty outputs")
    dc.check(strings(k0, "MaterialNames") == ["Void", "Armor Plate", "Body, Nose"], f"CTH material names {strings(k0, 'MaterialNames')}")
    dc.check(strings(k0, "FieldNames") == ["Mass"] and k0.GetPointData().GetArray("Mass (Armor Plate)") is not None, "CTH: field Mass with its per-material values")
    if k0.GetNumberOfCells():
        dc.check(get_array(k0, "FieldError", True).max() <= CTH_MASS_TOLERANCE * (1 + 1e-6), f"CTH: FieldError <= {CTH_MASS_TOLERANCE}")
        dc.check(get_array(k0, "InterfaceError", True).max() <= 0.1 * (1 + 1e-6), "CTH: InterfaceError <= 0.1")
        check_crack_free(k1, resampled_bounds := servermanager.Fetch(resampled).GetBounds(), "CTH interfaces")
    # FieldArrays empty: the MaterialFieldArrays alone define "Mass", with the same tetrahedra.
    cth_implicit = M(Input=resampled, VolumeFractionArrays=cth_fractions, FieldArrays=[], MaterialFieldArrays=["Mass for Armor Plate", "Mass for Body, Nose"], InterfaceTolerance=0.1, FieldTolerance=CTH_MASS_TOLERANCE)
    with dc.ErrorCapture(cth_implicit) as errors:
        j0 = fetch_all(cth_implicit)[0]
    print(f"CTH with MaterialFieldArrays only: {j0.GetNumberOfCells()} tetrahedra {errors.text()[:300]}")
    dc.check(not errors.messages and strings(j0, "FieldNames") == ["Mass"] and j0.GetPointData().GetArray("Mass (Armor Plate)") is not None, f"CTH, FieldArrays empty: field Mass from MaterialFieldArrays ({strings(j0, 'FieldNames')})")
    dc.check(j0.GetNumberOfCells() > 0 and same_tets(j0, k0), f"CTH, FieldArrays empty: the same tetrahedra as FieldArrays ['Mass'] ({j0.GetNumberOfCells()} vs {k0.GetNumberOfCells()})")

# ---- Tissue maps from the shared volumes (issue 11, item 5): three soft-thresholded tissue fractions
# and the intensity T1, written by `diamonds generate --field tissue`, on grids that are not 2^k + 1
# points (headsq on its own anisotropic points and resampled, bonsai resampled coarser for test time).
TISSUE_FRACTIONS = ["Volume Fraction for Other", "Volume Fraction for Grey", "Volume Fraction for White"]
TISSUE_CASES = [
    ("headsq 64x64x93", "headsq_64x64x93_int16.vti", None),
    ("headsq resampled to 74x87x71", "headsq_64x64x93_int16.vti", [74, 87, 71]),
    ("bonsai resampled to 64x64x64", "bonsai_256x256x256_uint8_lossy.vti", [64, 64, 64]),
]


def check_tissue_map(title, image_path, interface_tolerance=1.0, field_tolerance=10.0):
    """Both tolerances at every sample, crack-free interfaces with one point per position, and no more
    tetrahedra than Adaptive Tetrahedra on T1 at the same tolerance plus the interface pass."""
    source = simple.XMLImageDataReader(FileName=[image_path])
    source.UpdatePipeline()
    image = servermanager.Fetch(source)
    f = M(Input=source, VolumeFractionArrays=TISSUE_FRACTIONS, FieldArrays=["T1"], InterfaceTolerance=interface_tolerance, FieldTolerance=field_tolerance)
    started = time.time()
    with dc.ErrorCapture(f) as errors:
        t0, t1, _ = fetch_all(f)
    print(f"{title}: filter and fetch {time.time() - started:.1f} s")
    n = t0.GetNumberOfCells()
    ie, fe = dc.field_value(t0, "MaximumInterfaceError"), dc.field_value(t0, "MaximumFieldError")
    print(f"{title}: {n} tetrahedra ({dc.field_value(t0, 'InterfaceTetrahedra'):.0f} after the interface pass), interface error {ie}, field error {fe}, {t1.GetNumberOfCells()} interface polygons")
    dc.check(not errors.messages and n > 0 and t1.GetNumberOfCells() > 0, f"{title}: no error or warning, non-empty outputs {errors.text()[:300]}")
    if n == 0:
        return
    dc.check(ie <= interface_tolerance and fe <= field_tolerance, f"{title}: MaximumInterfaceError {ie:.4g} <= {interface_tolerance:g}, MaximumFieldError {fe:.4g} <= {field_tolerance:g}")
    # At every sample, independently: the sample's own material's values linearly interpolated in the
    # tetrahedron holding it against its T1.
    labels = np.argmax(np.stack([get_array(image, n) for n in TISSUE_FRACTIONS]), axis=0)
    own = np.stack([get_array(t0, f"T1 ({name})") for name in ["Other", "Grey", "White"]])
    covered, worst = dc.material_sample_errors(image, t0, labels, own, get_array(image, "T1"))
    dc.check(covered, f"{title}: every sample lies in a tetrahedron")
    dc.check(worst <= field_tolerance * (1 + 1e-5) + 1e-3, f"{title}: T1 within {field_tolerance:g} at every one of {len(labels)} samples (worst {worst:.4g})")
    # Interfaces: one point per position, every edge inside the box in two or more polygons.
    points = vtk_to_numpy(t1.GetPoints().GetData())
    dc.check(len(np.unique(points, axis=0)) == len(points), f"{title}: interface polygons hold one point per position ({len(points)} points)")
    check_crack_free(t1, image.GetBounds(), f"{title} interfaces")
    at = tetrahedra_of(simple.AdaptiveTetrahedra(Input=source, Scalars=["POINTS", "T1"], Tolerance=field_tolerance))
    interface = int(dc.field_value(t0, "InterfaceTetrahedra"))
    dc.check(n <= at + interface, f"{title}: {n} tetrahedra <= Adaptive Tetrahedra's {at} on T1 at {field_tolerance:g} + the interface pass's {interface}")
    for proxy in (f, source):
        simple.Delete(proxy)


for title, name, dims in TISSUE_CASES:
    started = time.time()
    volume = dc.shared_path(f"data/volumes/{name}")
    if volume is None:
        continue
    tissue_path = os.path.join(tmp, "tissue.vti")
    generate = [dc.diamonds_binary(), "generate", tissue_path, "--field", "tissue", "--image", volume]
    subprocess.run(generate + (["--dims", *map(str, dims)] if dims else []), check=True, stdout=subprocess.DEVNULL)
    check_tissue_map(title, tissue_path)
    print(f"{title}: {time.time() - started:.1f} s")

shutil.rmtree(tmp, ignore_errors=True)
dc.finish("test_material")
