"""View Dependent Tetrahedra (issue 14): the mesh of an image refined for a camera, in exact order.

Independent checks (numpy, tests/pvpython/diamonds_checks.py), on a 33^3 Wavelet and on an
anisotropic image with a non-zero origin:
- the output is a conforming tetrahedral mesh of the image (check_mesh: orientation, volume,
  faces, every sample within the reported MaximumError) with cell data Level = BisectionDepth / 3;
- SortCells 1 / 2: the cell order is back to front / front to back from CameraPosition face by face
  (order_violations, which knows nothing of the bisection tree), for an eye outside, inside the
  volume and on a face plane; the unsorted output fails that check (the check can fail);
- a camera move reuses the kept state: no hierarchy rebuild, few splits and merges compared with
  the mesh, and the same mesh as a fresh filter for that camera;
- the budget binds (at most MaximumNumberOfTetrahedra cells, PixelToleranceReached above the asked
  tolerance);
- bad input is a clear error with an empty output, no crash.

Run: PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds pvpython tests/pvpython/test_view.py
"""

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy

from diamonds_checks import (
    ErrorCapture,
    check,
    check_mesh,
    fetch,
    field_value,
    finish,
    hierarchy_builds,
    mesh_arrays,
    order_violations,
    programmable_image,
    require_plugin,
)

simple = require_plugin()
check(hasattr(simple, "ViewDependentTetrahedra"), "ViewDependentTetrahedra exists")

wavelet = simple.Wavelet(WholeExtent=[0, 32, 0, 32, 0, 32])
image = fetch(wavelet)
center = np.array(image.GetCenter())
center_list = [float(c) for c in center]


def camera(degrees, distance, height=0.3, target=center):
    a = np.radians(degrees)
    return [float(c) for c in target + distance * np.array([np.cos(a), np.sin(a), height])]


def tets_of(ug):
    points, tets, _ = mesh_arrays(ug)
    return points, tets


def leaf_keys(ug):
    """The tetrahedra as sorted tuples of rounded point coordinates (independent of ids and order)."""
    points, tets = tets_of(ug)
    keys = np.round(points[tets] * 1e6).astype(np.int64)  # M,4,3
    return {tuple(sorted(map(tuple, k))) for k in keys}


f = simple.ViewDependentTetrahedra(Input=wavelet)
f.Scalars = ["POINTS", "RTData"]
f.CameraPosition = camera(30.0, 60.0)
f.CameraFocalPoint = center_list
f.CameraViewUp = [0.0, 0.0, 1.0]
f.ViewAngle = 30.0
f.ViewportSize = [800, 600]
f.PixelTolerance = 2.0
f.MaximumNumberOfTetrahedra = 0
f.SortCells = 1
ug = fetch(f)
n = check_mesh(image, ug, "RTData", field_value(ug, "MaximumError"), "view mesh")
cd = ug.GetCellData()
for name in ("BisectionDepth", "Level", "ApproximationError", "BisectionPath"):
    check(cd.GetArray(name) is not None, f"cell data {name}")
depth = vtk_to_numpy(cd.GetArray("BisectionDepth"))
check((vtk_to_numpy(cd.GetArray("Level")) == depth // 3).all(), "Level == BisectionDepth / 3")
paths = vtk_to_numpy(cd.GetArray("BisectionPath"))
check(((paths & 63) == depth).all(), "BisectionPath carries the depth in its low 6 bits")
grid = ug.GetFieldData().GetArray("BisectionGrid")
check(grid is not None and grid.GetNumberOfValues() == 9, "field data BisectionGrid (9 values)")
check(hierarchy_builds(f) == 1, "one hierarchy build")

eye = np.array(f.CameraPosition)

# The view matters: a close camera refines near the eye more than far away; a camera looking away
# from the volume (all of it outside the frustum) leaves the coarsest mesh.
close = simple.ViewDependentTetrahedra(Input=wavelet, Scalars=["POINTS", "RTData"], CameraPosition=[-30.0, 16.0, 16.0],
                                       CameraFocalPoint=[16.0, 16.0, 16.0], CameraViewUp=[0.0, 0.0, 1.0], ViewAngle=60.0,
                                       PixelTolerance=30.0, MaximumNumberOfTetrahedra=0)
cu = fetch(close)
points, tets = tets_of(cu)
cdepth = vtk_to_numpy(cu.GetCellData().GetArray("BisectionDepth")).astype(float)
centroids = points[tets].mean(axis=1)
axis = (np.abs(centroids[:, 1] - 16.0) < 10.0) & (np.abs(centroids[:, 2] - 16.0) < 10.0)
near, far = cdepth[axis & (centroids[:, 0] < 8.0)].mean(), cdepth[axis & (centroids[:, 0] > 24.0)].mean()
check(near >= far + 1.0, f"finer near the eye (mean bisection depth {near:.2f} for x < 8 vs {far:.2f} for x > 24, eye at x = -30)")
close.CameraFocalPoint = [-60.0, 16.0, 16.0]
away = fetch(close).GetNumberOfCells()
close.CameraFocalPoint = [16.0, 16.0, 16.0]
toward = fetch(close).GetNumberOfCells()
check(0 < away < 0.01 * toward, f"looking away from the volume: {away} tetrahedra vs {toward} looking at it (outside the frustum stays coarse)")
simple.Delete(close)


def check_order(ug, eye, sort, label):
    points, tets = tets_of(ug)
    order_tets = tets if sort == 1 else tets[::-1]
    bad, checked, on_plane = order_violations(points, order_tets, eye)
    check(bad == 0 and checked > 0, f"{label}: {checked} interior faces in order ({bad} violations, {on_plane} with the eye on their plane)")


check_order(ug, eye, 1, "back to front, eye outside")
f.SortCells = 2
check_order(fetch(f), eye, 2, "front to back, eye outside")
f.SortCells = 0
points, tets = tets_of(fetch(f))
bad, checked, _ = order_violations(points, tets, eye)
check(bad > 0, f"the unsorted output fails the order check ({bad} of {checked} faces)")

# Eye inside the volume and eye on a lattice plane (many face planes through it).
for label, position in (("eye inside", list(center + np.array([3.3, -2.1, 1.7]))), ("eye on face planes", [16.0, 16.0, 40.0])):
    f.CameraPosition = position
    f.CameraFocalPoint = list(center + np.array([0.0, 1.0, 0.0]) if label == "eye inside" else center)
    f.CameraViewUp = [0.0, 0.0, 1.0] if label == "eye inside" else [0.0, 1.0, 0.0]
    f.SortCells = 1
    u = fetch(f)
    check_mesh(image, u, "RTData", field_value(u, "MaximumError"), label)
    check_order(u, np.array(position), 1, label)

# Frame coherence: a 2-degree orbit step from a frame reuses the state and gives the fresh mesh.
f.CameraFocalPoint = center_list
f.CameraViewUp = [0.0, 0.0, 1.0]
f.CameraPosition = camera(30.0, 60.0)
f.SortCells = 0
before = fetch(f).GetNumberOfCells()
f.CameraPosition = camera(32.0, 60.0)
moved = fetch(f)
changes = field_value(moved, "FrameSplits") + field_value(moved, "FrameMerges")
check(hierarchy_builds(f) == 1, "a camera move does not rebuild the hierarchy")
check(0 < changes < 0.1 * moved.GetNumberOfCells(), f"a 2-degree move: {changes:.0f} splits + merges for {moved.GetNumberOfCells()} tetrahedra (was {before})")
fresh = simple.ViewDependentTetrahedra(Input=wavelet, Scalars=["POINTS", "RTData"])
for p in ("CameraPosition", "CameraFocalPoint", "CameraViewUp", "ViewAngle", "ViewportSize", "PixelTolerance", "MaximumNumberOfTetrahedra"):
    fresh.SetPropertyWithName(p, f.GetPropertyValue(p))
fresh_ug = fetch(fresh)
check(leaf_keys(fresh_ug) == leaf_keys(moved), "after the move: the same tetrahedra as a fresh refinement for that camera")
fresh_splits = field_value(fresh_ug, "FrameSplits")
check(changes < fresh_splits, f"the move did fewer splits and merges ({changes:.0f}) than the fresh refinement ({fresh_splits:.0f})")

# The budget binds.
f.MaximumNumberOfTetrahedra = 5000
budget = fetch(f)
check(budget.GetNumberOfCells() <= 5000, f"budget 5000: {budget.GetNumberOfCells()} tetrahedra")
check(field_value(budget, "PixelToleranceReached") > 2.0, f"budget: tolerance reached {field_value(budget, 'PixelToleranceReached'):.3g} > 2")
check_mesh(image, budget, "RTData", field_value(budget, "MaximumError"), "budget mesh")
f.MaximumNumberOfTetrahedra = 0

# An anisotropic image with an origin: the order is exact in world coordinates.
aniso = programmable_image(simple, (20, 13, 9), "add('f', np.sin(x) * np.cos(0.5 * y) + 0.1 * z, True)\n", origin=(1.0, -2.0, 3.0), spacing=(0.5, 2.0, 1.5))
aimage = fetch(aniso)
g = simple.ViewDependentTetrahedra(Input=aniso, Scalars=["POINTS", "f"], PixelTolerance=0.5, SortCells=1, MaximumNumberOfTetrahedra=0)
acenter = np.array(aimage.GetCenter())
for label, position in (("anisotropic, outside", list(acenter + np.array([-20.0, 7.0, 30.0]))), ("anisotropic, inside", list(acenter + np.array([0.3, 0.7, -0.2])))):
    g.CameraPosition = position
    g.CameraFocalPoint = list(acenter + np.array([1.0, 0.0, 0.0]))
    g.CameraViewUp = [0.0, 0.0, 1.0]
    u = fetch(g)
    check_mesh(aimage, u, "f", field_value(u, "MaximumError"), label)
    check_order(u, np.array(position), 1, label)

# Bad input: a clear error, an empty output.
bad_cases = [
    ("CameraPosition", center_list, "focal"),
    ("ViewAngle", 0.0, "angle"),
    ("ViewAngle", 180.0, "angle"),
    ("PixelTolerance", -1.0, "PixelTolerance"),
    ("MaximumNumberOfTetrahedra", -5, "MaximumNumberOfTetrahedra"),
    ("SortCells", 3, "SortCells"),
    ("ViewportSize", [0, 600], "ViewportSize"),
    ("CameraViewUp", [1.0, 0.0, 0.0], "up"),
]
for prop, value, word in bad_cases:
    h = simple.ViewDependentTetrahedra(Input=wavelet, Scalars=["POINTS", "RTData"], CameraPosition=[60.0, 16.0, 16.0],
                                       CameraFocalPoint=center_list, CameraViewUp=[0.0, 0.0, 1.0])
    h.SetPropertyWithName(prop, value)
    with ErrorCapture(h) as errors:
        out = fetch(h)
    said = [line for line in errors.text().splitlines() if word.lower() in line.lower()]
    check(out.GetNumberOfCells() == 0 and said, f"bad {prop}={value}: error mentioning '{word}' ({said[-1] if said else errors.text() or 'no message'}, {out.GetNumberOfCells()} cells)")
    simple.Delete(h)
vec = simple.Calculator(Input=wavelet, ResultArrayName="v", Function="RTData*iHat+jHat")
h = simple.ViewDependentTetrahedra(Input=vec, Scalars=["POINTS", "v"], CameraPosition=[60.0, 16.0, 16.0], CameraFocalPoint=center_list)
with ErrorCapture(h) as errors:
    out = fetch(h)
said = [line for line in errors.text().splitlines() if "component" in line]
check(out.GetNumberOfCells() == 0 and said, f"a 3-component array is refused ({said[-1] if said else 'no such message'})")

finish("test_view")
