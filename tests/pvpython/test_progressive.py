"""Progressive Tetrahedral Mesh (issue 15): on Adaptive Tetrahedra's output of a Wavelet, the level
for TargetReduction is a manifold tetrahedralisation with positive volumes, every point array passes
through, FieldError and the field data agree; changing TargetReduction or MaximumFieldError only
replays the kept sequence (NumberOfSimplifications stays 1) or, to a coarser level than the first
execution's, continues it into the same mesh a first run there gives; changing a weight computes it again;
other cells are tetrahedralised with a warning; the progressive isosurface on output port 1 is
watertight inside the mesh at every level asked, holds the isovalue and follows level changes without
a new simplification; the shared disk_out_ref when present.

  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds pvpython tests/pvpython/test_progressive.py
"""

import os
import sys

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import diamonds_checks as dc  # noqa: E402

simple = dc.require_plugin()


def simplifications(proxy):
    proxy.UpdatePropertyInformation()
    return int(proxy.GetProperty("NumberOfSimplifications").GetElement(0))


def check_level(source, ug, scalars, label):
    """Manifold, positive volumes, point data passed through, FieldError within MaximumFieldError."""
    points, tets, types = dc.mesh_arrays(ug)
    dc.check(tets is not None and (types == dc.VTK_TETRA).all(), f"{label}: tetrahedra only")
    x = points[tets]
    volumes = np.einsum("ij,ij->i", x[:, 1] - x[:, 0], np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 0]))
    dc.check((volumes > 0).all(), f"{label}: positive volumes (min {volumes.min():.3g})")
    faces = np.sort(np.concatenate([tets[:, [1, 2, 3]], tets[:, [0, 2, 3]], tets[:, [0, 1, 3]], tets[:, [0, 1, 2]]]), axis=1)
    _, counts = np.unique(faces, axis=0, return_counts=True)
    dc.check(counts.max() <= 2, f"{label}: every face shared by at most two tetrahedra")
    src_points = vtk_to_numpy(source.GetPoints().GetData()).astype(np.float64)
    index = {tuple(p): k for k, p in enumerate(src_points)}
    ids = np.array([index.get(tuple(p), -1) for p in points])
    dc.check((ids >= 0).all(), f"{label}: every point is an input point")
    same = True
    for name, a in dc.point_arrays(source).items():
        b = ug.GetPointData().GetArray(name)
        same &= b is not None and np.array_equal(vtk_to_numpy(a)[ids], vtk_to_numpy(b))
    dc.check(same, f"{label}: every point array passed through")
    errors = ug.GetCellData().GetArray("FieldError")
    reported = dc.field_value(ug, "MaximumFieldError")
    dc.check(errors is not None and vtk_to_numpy(errors).max() <= reported * (1 + 1e-9) + 1e-12,
             f"{label}: FieldError within MaximumFieldError {reported:.4g}")
    dc.check(dc.field_value(ug, "NumberOfTetrahedra") == len(tets), f"{label}: NumberOfTetrahedra")
    return len(tets), reported


wavelet = simple.Wavelet()
wavelet.WholeExtent = [-8, 8, -8, 8, -8, 8]
adaptive = simple.AdaptiveTetrahedra(Input=wavelet)
adaptive.Tolerance = 2.0
source = dc.fetch(adaptive)
n = source.GetNumberOfCells()

prog = simple.ProgressiveTetrahedralMesh(Input=adaptive)
prog.Scalars = ["POINTS", "RTData"]
prog.TargetReduction = 0.9
first90 = dc.fetch(prog)
level90, error90 = check_level(source, first90, "RTData", "90 %")
dc.check(level90 <= 0.1 * n + 1, f"90 %: {level90} tetrahedra of {n}")
dc.check(simplifications(prog) == 1, "the sequence computed once")

prog.TargetReduction = 0.5
level50, error50 = check_level(source, dc.fetch(prog), "RTData", "50 %")
dc.check(level90 < level50 <= 0.5 * n + 1, f"50 %: {level50} tetrahedra")
dc.check(error50 <= error90, f"50 %: error {error50:.4g} <= 90 %'s {error90:.4g}")
prog.TargetReduction = 0.9
again, _ = check_level(source, dc.fetch(prog), "RTData", "90 % again")
dc.check(again == level90, "back to 90 %: the same level")
prog.MaximumFieldError = error90 / 2
limited, error = check_level(source, dc.fetch(prog), "RTData", "MaximumFieldError")
dc.check(error <= error90 / 2 and limited > level90, f"MaximumFieldError {error90 / 2:.4g}: error {error:.4g}, {limited} tetrahedra")
dc.check(simplifications(prog) == 1, "TargetReduction and MaximumFieldError changes only replayed")

# The first execution simplifies only as far as asked; a larger TargetReduction continues the same
# sequence: first run at 50 %, then at 90 %, a filter outputs what one first run at 90 % did.
stepwise = simple.ProgressiveTetrahedralMesh(Input=adaptive)
stepwise.Scalars = ["POINTS", "RTData"]
stepwise.TargetReduction = 0.5
dc.check(check_level(source, dc.fetch(stepwise), "RTData", "first at 50 %")[0] == level50, "first at 50 %: the 50 % level")
stepwise.TargetReduction = 0.9
continued = dc.fetch(stepwise)
check_level(source, continued, "RTData", "continued to 90 %")
same = all(np.array_equal(x, y) for x, y in zip(dc.mesh_arrays(continued), dc.mesh_arrays(first90)))
dc.check(same and dc.field_value(continued, "MaximumFieldError") == error90,
         "continued to 90 %: the mesh and error of a first run at 90 %")
stepwise.TargetReduction = 0.5
dc.check(dc.fetch(stepwise).GetNumberOfCells() == level50 and simplifications(stepwise) == 1,
         "back to 50 %: replayed, the same level")
# A reduction that cannot reach its target (1: no tetrahedron left) stops where no valid collapse
# is left and says so, with where and why; a reachable one says nothing.
stepwise.TargetReduction = 0.6
with dc.ErrorCapture(stepwise) as capture:
    reached = dc.fetch(stepwise).GetNumberOfCells()
dc.check(capture.text() == "" and level90 < reached <= 0.4 * n + 1, f"60 %: {reached} tetrahedra, no warning ({capture.text()[:80]!r})")
stepwise.TargetReduction = 1.0
with dc.ErrorCapture(stepwise) as capture:
    coarsest = dc.fetch(stepwise).GetNumberOfCells()
print(f"   [shortfall] {capture.text().strip()[:300]}")
dc.check(0 < coarsest < level90 and f"the reduction stops at {coarsest} tetrahedra" in capture.text()
         and f"input's {n})" in capture.text() and "short of the 0 asked" in capture.text(),
         f"TargetReduction 1: the coarsest mesh ({coarsest} tetrahedra) and a warning")
prog.MaximumFieldError = 0
prog.FieldWeight = 2.0
dc.fetch(prog)
dc.check(simplifications(prog) == 2, "a weight change computes the sequence again")

def check_isosurface(poly, isovalue, bounds, label):
    """Triangles only, every point on the isovalue, every edge in two triangles traversed in opposite
    directions unless both ends lie on one face of the mesh's box (where the surface is open)."""
    from paraview import servermanager  # noqa: F401

    points = vtk_to_numpy(poly.GetPoints().GetData()).astype(np.float64)
    conn = vtk_to_numpy(poly.GetPolys().GetConnectivityArray()).astype(np.int64)
    offsets = vtk_to_numpy(poly.GetPolys().GetOffsetsArray())
    dc.check(len(conn) > 0 and (np.diff(offsets) == 3).all(), f"{label}: {len(conn) // 3} triangles")
    tris = conn.reshape(-1, 3)
    values = vtk_to_numpy(poly.GetPointData().GetArray("RTData"))
    dc.check(np.allclose(values, isovalue), f"{label}: every point at the isovalue")
    directed = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    undirected = np.sort(directed, axis=1)
    keys, counts = np.unique(undirected, axis=0, return_counts=True)
    eps = 1e-9 * np.linalg.norm(bounds[1::2] - bounds[0::2])
    on_face = np.zeros(len(points), dtype=np.int64)
    for axis in range(3):
        on_face |= (np.abs(points[:, axis] - bounds[2 * axis]) < eps) << (2 * axis)
        on_face |= (np.abs(points[:, axis] - bounds[2 * axis + 1]) < eps) << (2 * axis + 1)
    open_edges = keys[counts == 1]
    dc.check((counts <= 2).all() and ((on_face[open_edges[:, 0]] & on_face[open_edges[:, 1]]) != 0).all(),
             f"{label}: watertight inside the mesh ({len(open_edges)} edges on the boundary)")
    forward = {tuple(e) for e in directed}
    dc.check(len(forward) == len(directed), f"{label}: consistently oriented")
    return len(tris)


def fetch_port(proxy, port):
    from paraview import servermanager

    proxy.UpdatePipeline()
    return servermanager.Fetch(proxy, idx=port)


bounds = np.array(source.GetBounds())
prog.ComputeIsosurface = 1
prog.Isosurfaces = [150.0]
prog.TargetReduction = 0.9
coarse = check_isosurface(fetch_port(prog, 1), 150.0, bounds, "isosurface 90 %")
prog.TargetReduction = 0.2
fine = check_isosurface(fetch_port(prog, 1), 150.0, bounds, "isosurface 20 %")
dc.check(fine > coarse, f"the isosurface refines with the level ({coarse} -> {fine} triangles)")
prog.Isosurfaces = [120.0, 200.0]
two = fetch_port(prog, 1)
dc.check(sorted(set(vtk_to_numpy(two.GetPointData().GetArray("RTData")))) == [120.0, 200.0], "two isovalues")
dc.check(simplifications(prog) == 2, "isosurfaces and level changes only replayed")

# Other cells: voxels from Threshold are tetrahedralised first, with a warning.
voxels = simple.Threshold(Input=wavelet)
voxels.Scalars = ["POINTS", "RTData"]
voxels.LowerThreshold = -1e9
voxels.UpperThreshold = 1e9
mixed = simple.ProgressiveTetrahedralMesh(Input=voxels)
mixed.Scalars = ["POINTS", "RTData"]
with dc.ErrorCapture(mixed) as capture:
    out = dc.fetch(mixed)
dc.check("tetrahedralised" in capture.text(), f"voxel input: a warning ({capture.text()[:80]})")
dc.check(out.GetNumberOfCells() > 0, f"voxel input: {out.GetNumberOfCells()} tetrahedra")

path = dc.shared_path("data/tets/disk_out_ref_tets.vtu")
if path:
    reader = simple.XMLUnstructuredGridReader(FileName=[path])
    disk = simple.ProgressiveTetrahedralMesh(Input=reader)
    disk.Scalars = ["POINTS", "Temp"]
    original = dc.fetch(reader)
    count, error = check_level(original, dc.fetch(disk), "Temp", "disk_out_ref 90 %")
    dc.check(count <= 0.1 * original.GetNumberOfCells() + 1, f"disk_out_ref: {count} tetrahedra, max error {error:.4g}")

dc.finish("test_progressive")
