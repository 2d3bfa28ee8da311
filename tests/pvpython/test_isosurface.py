"""Adaptive Isosurface, checked independently with numpy (VTK only hands over the arrays, and
ParaView's own Contour is the reference surface):

- (isosurface_checks.py) only triangles; watertight and consistently oriented: every edge in exactly
  two triangles, once in each direction, except edges on the image boundary (in one), checked by
  `diamonds verify-surface` on the saved surface (and shown to fail on a hole and a flipped triangle);
  a closed sphere is one genus-0 component (V - E + F = 2); triangles face increasing values (trilinear
  interpolation of the samples on both sides), normals unit length and on the same side;
- ErrorBound <= Tolerance; triangle count non-increasing as Tolerance grows; every vertex within
  Tolerance + one voxel diagonal of ParaView's Contour of the same isovalue (and of the exact sphere);
- two isovalues give two surfaces; ComputeScalars; every other point array interpolated as Contour
  does (with every Hierarchy); the region of interest; the triangle budget; the carrier tetrahedra of
  port 1;
- an isovalue or tolerance change does not rebuild the hierarchy and equals a fresh filter; the
  hierarchy is the isosurface-only one (HierarchyMemorySize: the samples it reads and its caches, where
  Adaptive Tetrahedra's is 2 bytes per point of records);
- toggling ComputeNormals, ComputeScalars or the carriers reuses the adaptive mesh (NumberOfReusedMeshes)
  and gives the same triangles; an isovalue change or a new input (rebuilt hierarchy) does not reuse it
  and equals a fresh filter;
- bad inputs: a clear error, empty outputs, no crash;
- defaults that pay: on every shared volume of at least 64³ samples the default Tolerance gives at
  most half of Contour's triangles.

  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds pvpython tests/pvpython/test_isosurface.py
"""

import builtins
import math
import os
import sys

import numpy as np
from vtkmodules.util.numpy_support import numpy_to_vtkIdTypeArray, vtk_to_numpy
from vtkmodules.vtkCommonCore import VTK_DOUBLE, VTK_FLOAT, VTK_INT
from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import diamonds_checks as dc  # noqa: E402
from isosurface_checks import check_surface, components, same_surface, surface_arrays, verify_surface  # noqa: E402
from paraview import servermanager  # noqa: E402

simple = dc.require_plugin()
dc.check(hasattr(simple, "AdaptiveIsosurface"), "AdaptiveIsosurface exists in paraview.simple")

VTK_TETRA = 10
# A ProgrammableSource runs its script in __main__ after `from ...numpy_interface.algorithms import *`,
# which replaces abs, all, max, sum... here: the builtins are used by these names below.
babs, ball = builtins.abs, builtins.all


def contour(source, value, array):
    c = simple.Contour(Input=source, ContourBy=["POINTS", array], Isosurfaces=[value])
    c.ComputeScalars = 0
    return dc.fetch(c)


# ---- Wavelet 33^3 (extent -16..16): defaults, tolerances, the hierarchy cache.
wavelet = simple.Wavelet()
wavelet.WholeExtent = [-16, 16, -16, 16, -16, 16]
image = dc.fetch(wavelet)
lo, hi = image.GetPointData().GetArray("RTData").GetRange()
filt = simple.AdaptiveIsosurface(Input=wavelet)
contour_default = simple.Contour(Input=wavelet)
dc.check(list(filt.Isosurfaces) == list(contour_default.Isosurfaces), f"default Isosurfaces {list(filt.Isosurfaces)} == Contour's {list(contour_default.Isosurfaces)}")
dc.check(len(filt.Isosurfaces) == 1 and babs(filt.Isosurfaces[0] - 0.5 * (lo + hi)) < 1e-6 * hi, "default: one isovalue at the middle of the range")
dc.check(list(filt.ContourBy) == ["POINTS", "RTData"], f"default ContourBy {list(filt.ContourBy)}")
dc.check(filt.ComputeNormals == 1 and filt.ComputeScalars == 1, "default ComputeNormals on, ComputeScalars on")
dc.check(filt.ComputeScalars == contour_default.ComputeScalars and filt.ComputeNormals == contour_default.ComputeNormals, "ComputeScalars and ComputeNormals default as Contour's")
voxel_length = math.sqrt(3 * 32.0**2) / 32.0
dc.check(babs(filt.Tolerance - 2.5 * voxel_length) < 1e-9, f"default Tolerance is two and a half voxel diagonals (2.5 diagonal / cbrt(cells)): {filt.Tolerance}")
dc.check(filt.MaximumNumberOfTriangles == 0 and filt.UseRegionOfInterest == 0 and filt.GenerateCarrierTetrahedra == 0, "defaults: no budget, no region, no carrier")
explicit_zero = simple.AdaptiveIsosurface(Input=wavelet, Tolerance=0.0)
dc.check(explicit_zero.Tolerance == 0.0, "AdaptiveIsosurface(..., Tolerance=0) keeps 0 (not replaced by the default)")
default_surface = dc.fetch(filt)
filt.UpdatePropertyInformation()
relative = filt.GetProperty("RelativeTolerance").GetElement(0)
dc.check(babs(relative - filt.Tolerance / math.sqrt(3 * 32.0**2)) < 1e-12, f"information property RelativeTolerance {relative:.5g} == Tolerance / diagonal")
dc.check(default_surface.GetNumberOfCells() > 0, f"default settings: {default_surface.GetNumberOfCells()} triangles")

iso = 157.0
filt.Isosurfaces = [iso]
reference = contour(wavelet, iso, "RTData")
print(f"Wavelet 33^3, RTData range ({lo:.2f}, {hi:.2f}), isovalue {iso}: Contour gives {reference.GetNumberOfCells()} triangles")
counts = []
for tol in (0.0, 0.1, 0.3, 1.0, 3.0):
    filt.Tolerance = tol
    counts.append(check_surface(image, dc.fetch(filt), "RTData", tol, f"Wavelet tol {tol:g}", reference=reference))
print("Wavelet triangles at tolerance 0, 0.1, 0.3, 1, 3:", counts)
dc.check(ball(a >= b for a, b in zip(counts, counts[1:])), "triangle count non-increasing as the tolerance grows")
dc.check(counts[-1] < counts[0] / 4, "tolerance 3 (5 % of the diagonal) is visibly adaptive (< 1/4 of the full-resolution count)")
dc.check(dc.hierarchy_builds(filt) == 1, f"five tolerances and an isovalue change, one hierarchy build (got {dc.hierarchy_builds(filt)})")
# The isosurface-only hierarchy keeps no per-diamond records (Adaptive Tetrahedra's full one: 4 bytes
# per point on the same image).
filt.UpdatePropertyInformation()
tetra_filter = simple.AdaptiveTetrahedra(Input=wavelet, Tolerance=4.0)
tetra_filter.UpdatePipeline()
tetra_filter.UpdatePropertyInformation()
iso_bytes = int(filt.GetProperty("HierarchyMemorySize").GetElement(0))
tetra_bytes = int(tetra_filter.GetProperty("HierarchyMemorySize").GetElement(0))
surface_bytes = dc.field_value(dc.fetch(filt), "HierarchyMemorySize")
dc.check(iso_bytes >= 4 * image.GetNumberOfPoints() and iso_bytes == surface_bytes and tetra_bytes == 2 * image.GetNumberOfPoints(), f"HierarchyMemorySize: {iso_bytes} (= field data {surface_bytes}) for the isosurface-only hierarchy: its float samples (4 per point) and its extraction's caches; {tetra_bytes} (2 per point) for Adaptive Tetrahedra's records")
simple.Delete(tetra_filter)

# An isovalue change re-extracts without a rebuild and equals a fresh filter.
filt.Tolerance = 0.5
filt.Isosurfaces = [120.0]
changed = dc.fetch(filt)
fresh = dc.fetch(simple.AdaptiveIsosurface(Input=wavelet, Isosurfaces=[120.0], Tolerance=0.5))
dc.check(dc.hierarchy_builds(filt) == 1, "isovalue change: no rebuild")
dc.check(same_surface(changed, fresh), f"isovalue change gives the same surface as a fresh filter ({changed.GetNumberOfCells()} triangles)")
check_surface(image, changed, "RTData", 0.5, "Wavelet isovalue 120 tol 0.5", reference=contour(wavelet, 120.0, "RTData"))
filt.Isosurfaces = [iso]
filt.Tolerance = 0.3
dc.check(same_surface(dc.fetch(filt), dc.fetch(simple.AdaptiveIsosurface(Input=wavelet, Isosurfaces=[iso], Tolerance=0.3))), "and back: same as a fresh filter")
wavelet.Maximum = 300.0
dc.fetch(filt)
dc.check(dc.hierarchy_builds(filt) == 2, "changing the input data rebuilds the hierarchy")
wavelet.Maximum = 255.0
dc.fetch(filt)



# The adaptive mesh is kept with the hierarchy: reused as is when only the outputs change, never
# after an isovalue change (refined from the root) or a rebuild (the mesh belongs to the old hierarchy).
def reused_meshes(proxy):
    proxy.UpdatePropertyInformation()
    return int(proxy.GetProperty("NumberOfReusedMeshes").GetElement(0))


keep = simple.AdaptiveIsosurface(Input=wavelet, Isosurfaces=[iso], Tolerance=0.5, ComputeScalars=0)
first = dc.fetch(keep)
first_normals = vtk_to_numpy(first.GetPointData().GetNormals()).copy()
dc.check(reused_meshes(keep) == 0 and first.GetNumberOfCells() > 0, f"first execution: nothing to reuse ({first.GetNumberOfCells()} triangles)")
keep.ComputeNormals = 0
toggled = dc.fetch(keep)
dc.check(reused_meshes(keep) == 1, f"ComputeNormals off: the mesh is reused (NumberOfReusedMeshes {reused_meshes(keep)})")
dc.check(same_surface(first, toggled) and toggled.GetPointData().GetNormals() is None, "ComputeNormals off: same triangles, no normals")
keep.ComputeScalars = 1
toggled = dc.fetch(keep)
dc.check(reused_meshes(keep) == 2, "ComputeScalars on: the mesh is reused")
dc.check(same_surface(first, toggled) and toggled.GetPointData().GetArray("RTData") is not None, "ComputeScalars on: same triangles, with the scalars")
keep.ComputeNormals = 1
keep.ComputeScalars = 0
keep.GenerateCarrierTetrahedra = 1
toggled = dc.fetch(keep)
toggled_normals = vtk_to_numpy(toggled.GetPointData().GetNormals())
dc.check(reused_meshes(keep) == 3, "normals back on and carriers on: the mesh is reused")
dc.check(same_surface(first, toggled) and np.array_equal(first_normals, toggled_normals), "normals back on: same triangles and normals")
dc.check(servermanager.Fetch(keep, idx=1).GetNumberOfCells() > 0, "carriers from the reused mesh")
keep.GenerateCarrierTetrahedra = 0
keep.Isosurfaces = [120.0]
changed = dc.fetch(keep)
dc.check(reused_meshes(keep) == 3, "isovalue change: the mesh is not reused")
dc.check(same_surface(changed, fresh), f"isovalue change: same surface as a fresh filter ({changed.GetNumberOfCells()} triangles)")
wavelet.Maximum = 300.0
rebuilt = dc.fetch(keep)
fresh_rebuilt = dc.fetch(simple.AdaptiveIsosurface(Input=wavelet, Isosurfaces=[120.0], Tolerance=0.5))
dc.check(dc.hierarchy_builds(keep) == 2 and reused_meshes(keep) == 3, f"new input data: rebuilt, the old mesh not reused (builds {dc.hierarchy_builds(keep)}, reused {reused_meshes(keep)})")
dc.check(not same_surface(rebuilt, changed) and same_surface(rebuilt, fresh_rebuilt), "new input data: a new surface, the same as a fresh filter's")
wavelet.Maximum = 255.0
restored = dc.fetch(keep)
dc.check(reused_meshes(keep) == 3 and same_surface(restored, fresh), "input restored: rebuilt again, not reused, same as a fresh filter")
keep.ComputeNormals = 0
dc.check(same_surface(dc.fetch(keep), fresh) and reused_meshes(keep) == 4, "and the rebuilt hierarchy's mesh is reused in turn")

# Normals and scalars off: no point data at all (the Wavelet has no other point array).
filt.ComputeNormals = 0
filt.ComputeScalars = 0
bare = dc.fetch(filt)
dc.check(bare.GetPointData().GetNumberOfArrays() == 0, "ComputeNormals and ComputeScalars off: no point array")
filt.ComputeNormals = 1
filt.ComputeScalars = 1

# ---- A sphere distance field on an odd grid (40 x 36 x 33, origin and spacing not trivial):
# closed surfaces, exact reference, two isovalues, ComputeScalars, region, budget, carriers.
center = (1.3, -0.4, 4.1)
sphere = dc.programmable_image(
    simple,
    (40, 36, 33),
    f"add('distance', np.sqrt((x - {center[0]}) ** 2 + (y - {center[1]}) ** 2 + (z - {center[2]}) ** 2), scalars=True)\n",
    origin=(-4.0, -5.0, 0.0),
    spacing=(0.25, 0.3, 0.27),
)
sphere_image = dc.fetch(sphere)
r = 2.7137
sphere_filter = simple.AdaptiveIsosurface(Input=sphere, Isosurfaces=[r])
voxel = float(np.linalg.norm(sphere_image.GetSpacing()))
sphere_counts = []
sphere_reference = contour(sphere, r, "distance")
for tol in (0.0, 0.02, 0.1, 0.3):
    sphere_filter.Tolerance = tol
    s = dc.fetch(sphere_filter)
    sphere_counts.append(check_surface(sphere_image, s, "distance", tol, f"sphere r {r} tol {tol:g}", closed=True, reference=sphere_reference))
    pts, _ = surface_arrays(s)
    radial = np.linalg.norm(pts - center, axis=1)
    dc.check(np.abs(radial - r).max() <= tol + voxel, f"sphere tol {tol:g}: every vertex within Tolerance + a voxel diagonal of the exact sphere (max |r - {r}| = {np.abs(radial - r).max():.4g})")
    nv = vtk_to_numpy(s.GetPointData().GetNormals()).astype(np.float64)
    outward = ((pts - center) / radial[:, None] * nv).sum(1)
    dc.check(outward.min() > 0.9, f"sphere tol {tol:g}: normals point outward, toward larger distances (min cos {outward.min():.3f})")
print("sphere triangles at tolerance 0, 0.02, 0.1, 0.3:", sphere_counts)
dc.check(ball(a >= b for a, b in zip(sphere_counts, sphere_counts[1:])), "sphere: triangle count non-increasing as the tolerance grows")
dc.check(sphere_counts[-1] < sphere_counts[0] / 4, "sphere: tolerance 0.3 is visibly adaptive")

# The watertightness check (the CLI on a saved copy) fails on a hole and on a flipped triangle.
def with_triangles(poly, tris):
    copy = vtkPolyData()
    copy.SetPoints(poly.GetPoints())
    cells = vtkCellArray()
    offsets = np.arange(0, 3 * len(tris) + 1, 3, dtype=np.int64)
    cells.SetData(numpy_to_vtkIdTypeArray(offsets, deep=1), numpy_to_vtkIdTypeArray(np.ascontiguousarray(tris.ravel(), dtype=np.int64), deep=1))
    copy.SetPolys(cells)
    return copy


_, sphere_tris = surface_arrays(s)
dc.check(verify_surface(sphere_image, with_triangles(s, sphere_tris), closed=True)[0], "verify-surface passes the sphere copied as is")
for broken, what in [(sphere_tris[1:], "watertight"), (np.concatenate([sphere_tris[:7], sphere_tris[7:8, ::-1], sphere_tris[8:]]), "orientation")]:
    for closed in (True, False):
        passed, report = verify_surface(sphere_image, with_triangles(s, broken), closed=closed)
        dc.check(not passed and f"{what}: FAILED" in report, f"verify-surface{' (closed)' if closed else ''} fails on the sphere with {'a hole' if what == 'watertight' else 'a flipped triangle'}")

# A sphere cut by the image boundary: open along the boundary only.
cut = simple.AdaptiveIsosurface(Input=sphere, Isosurfaces=[5.2], Tolerance=0.05)
check_surface(sphere_image, dc.fetch(cut), "distance", 0.05, "sphere cut by the image boundary", reference=contour(sphere, 5.2, "distance"))

# Two isovalues, ComputeScalars.
two = simple.AdaptiveIsosurface(Input=sphere, Isosurfaces=[1.5, 3.1], Tolerance=0.05, ComputeScalars=1)
both = dc.fetch(two)
pts, tris = surface_arrays(both)
dc.check(components(len(pts), tris) == 2, "two isovalues: two separate surfaces")
scalars = both.GetPointData().GetArray("distance")
dc.check(scalars is not None and scalars.GetDataType() == sphere_image.GetPointData().GetArray("distance").GetDataType(), "ComputeScalars: array named and typed like the input array")
if scalars is not None:
    values = vtk_to_numpy(scalars)
    dc.check(set(np.unique(values).tolist()) == {1.5, 3.1}, f"ComputeScalars: the isovalue of each point ({np.unique(values)})")
    radial = np.linalg.norm(pts - center, axis=1)
    dc.check(np.abs(radial - values).max() <= 0.05 + voxel, "each point lies on the sphere of its own isovalue")
dc.check(both.GetPointData().GetScalars() is not None and both.GetPointData().GetScalars().GetName() == "distance", "ComputeScalars: set as the active scalars")
check_surface(sphere_image, both, "distance", 0.05, "two isovalues")
inner = simple.AdaptiveIsosurface(Input=sphere, Isosurfaces=[1.5], Tolerance=0.05)
outer = simple.AdaptiveIsosurface(Input=sphere, Isosurfaces=[3.1], Tolerance=0.05)
n_inner, n_outer = dc.fetch(inner).GetNumberOfCells(), dc.fetch(outer).GetNumberOfCells()
if scalars is not None:
    # Refined together, each surface is at least as fine as alone (a diamond either query splits is split).
    per_value = [int((values[tris[:, 0]] == v).sum()) for v in (1.5, 3.1)]
    dc.check(per_value[0] >= n_inner and per_value[1] >= n_outer and sum(per_value) == both.GetNumberOfCells(), f"two isovalues: {per_value} triangles, each at least as many as alone ({n_inner}, {n_outer})")

# Every other point array interpolated onto the surface, as Contour does: a linear one (the
# coordinates, 3 components) equals the points; an integer one keeps its type; the contoured array
# only with ComputeScalars (the isovalue). The same with the isodiamond hierarchies, whose points
# lie on the same edges.
arrays = dc.programmable_image(
    simple,
    (40, 36, 33),
    f"add('distance', np.sqrt((x - {center[0]}) ** 2 + (y - {center[1]}) ** 2 + (z - {center[2]}) ** 2), scalars=True)\n"
    "add('position', np.stack([x, y, z], axis=1))\n"
    "add('side', (x > 1.0).astype(np.int32))\n",
    origin=(-4.0, -5.0, 0.0),
    spacing=(0.25, 0.3, 0.27),
)
reference_pd = dc.fetch(simple.Contour(Input=arrays, ContourBy=["POINTS", "distance"], Isosurfaces=[r], ComputeScalars=0)).GetPointData()
interpolating = simple.AdaptiveIsosurface(Input=arrays, ContourBy=["POINTS", "distance"], Isosurfaces=[r], Tolerance=0.1)
for hierarchy in ("Full", "Relevant", "Minimal"):
    interpolating.Hierarchy = hierarchy
    for scalars_on in (0, 1):
        interpolating.ComputeScalars = scalars_on
        got = dc.fetch(interpolating)
        pd = got.GetPointData()
        names = sorted(pd.GetArrayName(i) for i in range(pd.GetNumberOfArrays()))
        want = sorted(reference_pd.GetArrayName(i) for i in range(reference_pd.GetNumberOfArrays()))
        if scalars_on:
            want = sorted(want + ["distance"])
        what = f"point arrays ({hierarchy}, ComputeScalars {scalars_on})"
        dc.check(names == want, f"{what}: {names}, as Contour's {want}")
        if pd.GetArray("position") is None or pd.GetArray("side") is None:
            continue
        pts, _ = surface_arrays(got)
        position = vtk_to_numpy(pd.GetArray("position"))
        dc.check(np.abs(position - pts).max() <= 1e-12 * np.abs(pts).max(), f"{what}: a linear array interpolates to the points themselves (max {np.abs(position - pts).max():.3g})")
        dc.check(pd.GetArray("side").GetDataType() == VTK_INT, f"{what}: an int array stays int ({pd.GetArray('side').GetDataTypeAsString()})")
        side = vtk_to_numpy(pd.GetArray("side"))
        dc.check(set(np.unique(side).tolist()) <= {0, 1} and (side == (pts[:, 0] > 1.0)).mean() > 0.95, f"{what}: the int array is its nearer end's ({np.unique(side)})")
        if scalars_on and hierarchy == "Full":
            dc.check(np.all(vtk_to_numpy(pd.GetArray("distance")) == r), f"{what}: the contoured array is the isovalue")
            dc.check(pd.GetScalars() is not None and pd.GetScalars().GetName() == "distance", f"{what}: the contoured array is the active scalars")
# An input whose active scalars are another array (a Calculator's result, what a user colors by):
# kept beside the contoured array and the normals, not replaced by them.
height = simple.Calculator(Input=arrays, ResultArrayName="height", Function="coordsZ")
with_height = dc.fetch(simple.AdaptiveIsosurface(Input=height, ContourBy=["POINTS", "distance"], Isosurfaces=[r], Tolerance=0.1))
hpd = with_height.GetPointData()
names = sorted(hpd.GetArrayName(i) for i in range(hpd.GetNumberOfArrays()))
dc.check(names == ["Normals", "distance", "height", "position", "side"], f"a Calculator's result (the input's active scalars) kept beside the scalars and normals: {names}")
if hpd.GetArray("height") is not None:
    pts, _ = surface_arrays(with_height)
    dc.check(np.abs(vtk_to_numpy(hpd.GetArray("height")) - pts[:, 2]).max() <= 1e-9, "and interpolated: height = z at every point")
dc.check(hpd.GetScalars() is not None and hpd.GetScalars().GetName() == "distance" and hpd.GetNormals() is not None and hpd.GetNormals().GetName() == "Normals", "the contoured array and Normals are the active scalars and normals")

# Region of interest: full resolution in the x < center half, coarse elsewhere, still closed.
region_filter = simple.AdaptiveIsosurface(Input=sphere, Isosurfaces=[r], Tolerance=0.0, UseRegionOfInterest=1)
region_filter.RegionOfInterest = [-4.0, center[0], -5.0, 6.0, 0.0, 9.0]
region = dc.fetch(region_filter)
check_surface(sphere_image, region, "distance", 0.0, "region of interest (tol 0 inside)", closed=True, error_limit=float("inf"))
rp, rt = surface_arrays(region)
full_p, full_t = surface_arrays(dc.fetch(simple.AdaptiveIsosurface(Input=sphere, Isosurfaces=[r], Tolerance=0.0)))
left = lambda p, t: (p[t].mean(1)[:, 0] < center[0] - voxel).sum()  # noqa: E731
right = lambda p, t: (p[t].mean(1)[:, 0] > center[0] + voxel).sum()  # noqa: E731
print(f"region of interest: {len(rt)} triangles ({left(rp, rt)} left, {right(rp, rt)} right) vs full resolution {len(full_t)} ({left(full_p, full_t)}, {right(full_p, full_t)})")
dc.check(left(rp, rt) >= 0.9 * left(full_p, full_t), "region of interest: full resolution inside")
dc.check(right(rp, rt) < 0.5 * right(full_p, full_t), "region of interest: coarse outside")
roi_bad = simple.AdaptiveIsosurface(Input=sphere, Isosurfaces=[r], UseRegionOfInterest=1)
roi_bad.RegionOfInterest = [100.0, 110.0, 100.0, 110.0, 100.0, 110.0]

# Budget.
budget_filter = simple.AdaptiveIsosurface(Input=sphere, Isosurfaces=[r], Tolerance=0.0, MaximumNumberOfTriangles=1000)
budget = dc.fetch(budget_filter)
eb = dc.field_value(budget, "ErrorBound")
dc.check(0 < budget.GetNumberOfCells() <= 1000, f"budget 1000: {budget.GetNumberOfCells()} triangles, ErrorBound {eb:.4g}")
check_surface(sphere_image, budget, "distance", 0.0, "budget 1000 (within the reported ErrorBound)", closed=True, reference=sphere_reference, error_limit=eb)

# Carrier tetrahedra on port 1.
dc.check(dc.fetch(sphere_filter).GetNumberOfCells() > 0 and servermanager.Fetch(sphere_filter, idx=1).GetNumberOfCells() == 0, "port 1 empty unless GenerateCarrierTetrahedra")
carrier_filter = simple.AdaptiveIsosurface(Input=sphere, Isosurfaces=[r], Tolerance=0.1, GenerateCarrierTetrahedra=1)
carrier_filter.UpdatePipeline()
surface = servermanager.Fetch(carrier_filter, idx=0)
carrier = servermanager.Fetch(carrier_filter, idx=1)
cp, ctets, ctypes = dc.mesh_arrays(carrier)
dc.check(carrier.GetNumberOfCells() > 0 and ctets is not None and (ctypes == VTK_TETRA).all(), f"port 1: {carrier.GetNumberOfCells()} carrier tetrahedra, VTK_TETRA only")
if ctets is not None and len(ctets):
    cv = vtk_to_numpy(carrier.GetPointData().GetArray("distance"))[ctets]
    straddle = (cv.min(1) < r) & (cv.max(1) >= r)
    dc.check(straddle.all(), "every carrier tetrahedron straddles the isovalue (values passed through from the input)")
    V = cp[ctets]
    vol = np.linalg.det(V[:, 1:] - V[:, :1]) / 6.0
    dc.check((vol > 0).all(), "carrier tetrahedra positively oriented")
    dc.check(carrier.GetCellData().GetArray("BisectionDepth") is not None and carrier.GetCellData().GetArray("IsosurfaceError") is not None, "carrier cell data BisectionDepth and IsosurfaceError")
    dc.check(dc.field_value(carrier, "NumberOfTetrahedra") == carrier.GetNumberOfCells(), "carrier field data NumberOfTetrahedra")
    ie = vtk_to_numpy(carrier.GetCellData().GetArray("IsosurfaceError"))
    dc.check(ie.max() == dc.field_value(surface, "ErrorBound") and ie.max() <= carrier_filter.Tolerance, f"carrier IsosurfaceError: largest {ie.max()} = the surface's ErrorBound, within Tolerance {carrier_filter.Tolerance}")
    dc.check(dc.field_value(carrier, "MaximumError") == ie.max() and carrier.GetCellData().GetArray("ApproximationError") is None, "carrier field data MaximumError = the largest IsosurfaceError; no data-unit ApproximationError")
    # Each surface triangle's centroid lies in the carriers' bounding region (cheap containment proxy).
    sp, st = surface_arrays(surface)
    cb = carrier.GetBounds()
    cent = sp[st].mean(1)
    dc.check(((cent >= np.array(cb[0::2]) - 1e-9) & (cent <= np.array(cb[1::2]) + 1e-9)).all(), "surface inside the carriers' bounds")
    dc.check(same_surface(surface, dc.fetch(simple.AdaptiveIsosurface(Input=sphere, Isosurfaces=[r], Tolerance=0.1))), "the carriers do not change the surface")


# ---- Bad inputs: an error that says what is wrong, empty outputs, no crash.
def expect_error(f, phrase, label):
    with dc.ErrorCapture(f) as errors:
        f.UpdatePipeline()
        out0 = servermanager.Fetch(f, idx=0)
        out1 = servermanager.Fetch(f, idx=1)
    text = errors.text()
    print(f"   [{label}] {text.strip().splitlines()[-1] if text.strip() else '(no message)'}")
    dc.check(phrase.lower() in text.lower(), f"{label}: error mentions {phrase!r}")
    dc.check(out0.GetNumberOfPoints() == 0 and out0.GetNumberOfCells() == 0 and out1.GetNumberOfCells() == 0, f"{label}: empty outputs")


no_value = simple.AdaptiveIsosurface(Input=wavelet, ContourBy=["POINTS", "RTData"])
no_value.Isosurfaces = []  # (as a constructor argument, the domain default would replace it)
expect_error(no_value, "at least one value", "no isovalue")
expect_error(simple.AdaptiveIsosurface(Input=wavelet, Isosurfaces=[150.0, float("nan")]), "finite", "a NaN isovalue")
expect_error(simple.AdaptiveIsosurface(Input=wavelet, Isosurfaces=[150.0], Tolerance=-0.5), "Tolerance must be", "negative Tolerance")
expect_error(simple.AdaptiveIsosurface(Input=wavelet, Isosurfaces=[150.0], MaximumNumberOfTriangles=-3), "MaximumNumberOfTriangles must be", "negative budget")
flat = simple.Wavelet()
flat.WholeExtent = [-8, 8, -8, 8, 0, 0]
not_updated = simple.AdaptiveIsosurface(Input=flat, Isosurfaces=[150.0])
dc.check(not_updated.Tolerance > 0, f"on an input not updated yet, the default Tolerance is still valid ({not_updated.Tolerance})")
expect_error(not_updated, "at least 2 points", "2-D image")
missing = simple.AdaptiveIsosurface(Input=wavelet, Isosurfaces=[150.0])
missing.ContourBy = ["POINTS", "NoSuchArray"]
expect_error(missing, "no point-data array named", "unknown array")
vector = simple.Calculator(Input=wavelet, ResultArrayName="Vector", Function="RTData*iHat + coordsY*jHat")
vector_filter = simple.AdaptiveIsosurface(Input=vector, Isosurfaces=[150.0])
vector_filter.ContourBy = ["POINTS", "Vector"]
expect_error(vector_filter, "single-component", "3-component array")
cells_only = simple.PointDatatoCellData(Input=wavelet)
cells_only.PassPointData = 0
expect_error(simple.AdaptiveIsosurface(Input=cells_only, Isosurfaces=[150.0]), "Cell Data to Point Data", "cell data only")
nan_image = dc.programmable_image(simple, (9, 8, 7), "v = np.sin(x) + y\nv[100] = np.nan\nadd('f', v, scalars=True)\n")
expect_error(simple.AdaptiveIsosurface(Input=nan_image, Isosurfaces=[1.0]), "non-finite", "a NaN sample")
expect_error(roi_bad, "outside the image bounds", "region of interest outside the image")
after = dc.fetch(simple.AdaptiveIsosurface(Input=wavelet, Isosurfaces=[150.0], Tolerance=0.5))
check_surface(image, after, "RTData", 0.5, "good input after the bad ones")

# An isovalue outside the range: an empty surface and a warning (the core's text), not an error.
outside = simple.AdaptiveIsosurface(Input=wavelet, Isosurfaces=[hi + 100.0])
with dc.ErrorCapture(outside) as errors:
    empty = dc.fetch(outside)
dc.check(
    empty.GetNumberOfCells() == 0 and "is outside" in errors.text() and "ERROR" not in errors.text(),
    f"isovalue outside the range: empty surface, a warning ({errors.text()!r})",
)

# Abort at the first progress report: empty output. The isosurface-only hierarchy is built in
# milliseconds without progress, so it is complete and kept; the next update only extracts.
abort_filter = simple.AdaptiveIsosurface(Input=wavelet, Isosurfaces=[150.0])
vtk_filter = abort_filter.GetClientSideObject()
progress_seen = []


def abort_on_progress(obj, _event):
    progress_seen.append(obj.GetProgress())
    if obj.GetProgress() > 0.0:
        obj.SetAbortExecute(1)


tag = vtk_filter.AddObserver("ProgressEvent", abort_on_progress)
aborted = dc.fetch(abort_filter)
vtk_filter.RemoveObserver(tag)
vtk_filter.SetAbortExecute(0)
dc.check(len(progress_seen) > 0 and aborted.GetNumberOfCells() == 0, f"AbortExecute: empty output ({len(progress_seen)} progress events)")
dc.check(dc.hierarchy_builds(abort_filter) == 1, "the complete hierarchy is counted and kept")
abort_filter.Tolerance = 1.0
dc.check(dc.fetch(abort_filter).GetNumberOfCells() > 0 and dc.hierarchy_builds(abort_filter) == 1, "the next update extracts without rebuilding")

# ---- Defaults that pay: on every shared volume of at least 64³ samples, the default Tolerance
# (as a GUI user gets it) gives at most half of Contour's triangles, at a quarter and at half of the
# data range (moved to the middle between two integers for integer data, where Contour's and our
# surfaces would pass through samples).
volumes = dc.shared_path("data/volumes")
for name in sorted(os.listdir(volumes)) if volumes else []:
    reader = simple.XMLImageDataReader(FileName=[os.path.join(volumes, name)])
    reader.UpdatePipeline()
    info = reader.GetDataInformation()
    if info.GetNumberOfPoints() < 64**3:
        continue
    array = reader.PointData.keys()[0]
    lo, hi = reader.PointData[array].GetRange()
    integer = reader.PointData[array].GetDataType() not in (VTK_FLOAT, VTK_DOUBLE)
    for fraction in (0.25, 0.5):
        iso = lo + fraction * (hi - lo)
        iso = math.floor(iso) + 0.5 if integer else iso
        ours = simple.AdaptiveIsosurface(Input=reader, ContourBy=["POINTS", array], Isosurfaces=[iso])
        contour = simple.Contour(Input=reader, ContourBy=["POINTS", array], Isosurfaces=[iso])
        n, m = (dc.fetch(f).GetNumberOfCells() for f in (ours, contour))
        dc.check(0 < n <= 0.5 * m, f"{name} at {iso:g}: the default Tolerance {ours.Tolerance:.3g} gives {n} triangles, at most half of Contour's {m} ({n / m:.2f})")
        simple.Delete(ours)
        simple.Delete(contour)

# ---- The proxy as the GUI sees it.
prototype = servermanager.ProxyManager().GetPrototypeProxy("filters", "AdaptiveIsosurface")
hints = prototype.GetHints()
menu = hints.FindNestedElementByName("ShowInMenu") if hints else None
dc.check(menu is not None and menu.GetAttribute("category") == "Diamonds", "listed in the Filters > Diamonds menu")
dc.check(prototype.GetXMLLabel() == "Adaptive Isosurface", "label 'Adaptive Isosurface'")
doc = prototype.GetDocumentation()
dc.check(len(doc.GetDescription() or "") > 2000, f"the filter has a long <Documentation> ({len(doc.GetDescription() or '')} chars)")
dc.check(prototype.GetProperty("ContourValues").GetXMLLabel() == "Isosurfaces" and prototype.GetProperty("SelectInputScalars").GetXMLLabel() == "Contour By", "Contour's property names (Isosurfaces, Contour By)")

dc.finish("test_isosurface")
