"""Properties and attributes of Adaptive Tetrahedra: pass-through of extra point arrays, cell and
field data, the tetrahedron budget, the region of interest, and the cached hierarchy (changing only
the query re-executes the filter without rebuilding the hierarchy).

  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds pvpython tests/pvpython/test_properties.py
"""

import os
import sys

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import diamonds_checks as dc  # noqa: E402

simple = dc.require_plugin()

wavelet = simple.Wavelet()
wavelet.WholeExtent = [-16, 16, -16, 16, -16, 16]
# Extra point arrays of other types and sizes, to be passed through.
calc = simple.Calculator(Input=wavelet)
calc.ResultArrayName = "Shifted"
calc.Function = "RTData * 2 + coordsX"
vec = simple.Calculator(Input=calc)
vec.ResultArrayName = "Vector"
vec.Function = "RTData*iHat + coordsY*jHat + 3*kHat"
image = dc.fetch(vec)
names = sorted(dc.point_arrays(image))
print("input point arrays:", names)

filt = simple.AdaptiveTetrahedra(Input=vec)
filt.Scalars = ["POINTS", "RTData"]
filt.Tolerance = 4.0
mesh = dc.fetch(filt)
n = dc.check_mesh(image, mesh, "RTData", 4.0, "Wavelet + Calculator arrays tol 4")
out_names = sorted(dc.point_arrays(mesh))
dc.check(out_names == names, f"every input point array in the output: {out_names}")
dc.check(
    mesh.GetPointData().GetArray("Vector").GetNumberOfComponents() == 3,
    "3-component array passed through with its components",
)

# ---- Cell and field data.
level = mesh.GetCellData().GetArray("BisectionDepth")
err = mesh.GetCellData().GetArray("ApproximationError")
dc.check(level is not None and level.GetDataTypeAsString() == "unsigned char", "cell data BisectionDepth (unsigned char)")
dc.check(err is not None and err.GetDataTypeAsString() == "float", "cell data ApproximationError (float)")
lv, ev = vtk_to_numpy(level), vtk_to_numpy(err)
dc.check(len(lv) == n and len(ev) == n, "one BisectionDepth and one ApproximationError per tetrahedron")
dc.check(ev.min() >= 0 and ev.max() <= 4.0, f"0 <= ApproximationError <= Tolerance (max {ev.max():g})")
dc.check(lv.max() <= 3 * 5 + 2, f"BisectionDepth within the depth of a 33^3 lattice (max {lv.max()})")
dc.check(dc.field_value(mesh, "Tolerance") == 4.0, "field data Tolerance == 4")
dc.check(dc.field_value(mesh, "NumberOfTetrahedra") == n, "field data NumberOfTetrahedra == number of cells")
max_error = dc.field_value(mesh, "MaximumError")
dc.check(
    max_error is not None and abs(max_error - float(ev.max())) < 1e-6 and max_error <= 4.0,
    f"field data MaximumError ({max_error}) == max ApproximationError <= Tolerance",
)

# ---- The hierarchy is kept when only the query changes.
builds = dc.hierarchy_builds(filt)
dc.check(builds == 1, f"one hierarchy build so far (got {builds})")
filt.Tolerance = 16.0
coarse = dc.fetch(filt)
dc.check(coarse.GetNumberOfCells() < n, f"Tolerance 16 re-executed: {coarse.GetNumberOfCells()} < {n} tetrahedra")
filt.MaximumNumberOfTetrahedra = 1000
dc.fetch(filt)
filt.MaximumNumberOfTetrahedra = 0
dc.check(dc.hierarchy_builds(filt) == 1, "changing Tolerance and the budget did not rebuild the hierarchy")
filt.Scalars = ["POINTS", "Shifted"]
dc.fetch(filt)
dc.check(dc.hierarchy_builds(filt) == 2, "changing Scalars rebuilt the hierarchy")
filt.Scalars = ["POINTS", "RTData"]
wavelet.Maximum = 300.0
dc.fetch(filt)
dc.check(dc.hierarchy_builds(filt) == 3, "changing the input data rebuilt the hierarchy")
wavelet.Maximum = 255.0

# ---- The tetrahedron budget.
filt.Tolerance = 0.0
for budget in (500, 5000, 50000):
    filt.MaximumNumberOfTetrahedra = budget
    m = dc.fetch(filt)
    dc.check(
        0 < m.GetNumberOfCells() <= budget,
        f"budget {budget}: {m.GetNumberOfCells()} tetrahedra, MaximumError {dc.field_value(m, 'MaximumError'):.4g}",
    )
dc.check_mesh(image, m, "RTData", dc.field_value(m, "MaximumError"), "budget 50000 (tolerance = reported MaximumError)")
# A budget below the minimal mesh of a non-2^k+1 grid yields that minimal mesh.
odd = simple.Wavelet()
odd.WholeExtent = [0, 32, 0, 19, 0, 16]
odd_filter = simple.AdaptiveTetrahedra(Input=odd, Tolerance=0.0, MaximumNumberOfTetrahedra=10)
odd_mesh = dc.fetch(odd_filter)
print(f"budget 10 on 33x20x17: {odd_mesh.GetNumberOfCells()} tetrahedra (the minimal mesh of that domain)")
dc.check(odd_mesh.GetNumberOfCells() > 10, "a budget below the minimal mesh yields the minimal mesh")
dc.check_mesh(dc.fetch(odd), odd_mesh, "RTData", dc.field_value(odd_mesh, "MaximumError"), "budget below the base mesh")
filt.MaximumNumberOfTetrahedra = 0

# ---- Region of interest: refined inside, coarse outside.
roi = [-16.0, -4.0, -16.0, -4.0, -16.0, -4.0]
builds_before_roi = dc.hierarchy_builds(filt)
filt.Tolerance = 2.0
full = dc.fetch(filt)
filt.UseRegionOfInterest = 1
filt.RegionOfInterest = roi
part = dc.fetch(filt)
dc.check(part.GetNumberOfCells() < full.GetNumberOfCells() / 2, f"ROI mesh {part.GetNumberOfCells()} < half of the full mesh {full.GetNumberOfCells()}")
dc.check_mesh(image, part, "RTData", 2.0, "ROI (tolerance checked inside the ROI)", tolerance_region=roi)


pts, tets, _ = dc.mesh_arrays(part)
corners = pts[tets]
centers = corners.mean(1)
volumes = np.abs(np.linalg.det(corners[:, 1:] - corners[:, :1])) / 6.0
inside = np.all((centers >= roi[0::2]) & (centers <= roi[1::2]), axis=1)
far = np.all(centers > 4.0, axis=1)  # the octant opposite the region
levels = vtk_to_numpy(part.GetCellData().GetArray("BisectionDepth"))
print(
    f"ROI: {inside.sum()} tetrahedra inside (mean volume {volumes[inside].mean():.3g}), "
    f"{(~inside).sum()} outside (mean volume {volumes[~inside].mean():.3g}); "
    f"far octant: {far.sum()} tetrahedra, levels {sorted(set(levels[far].tolist()))}"
)
dc.check(volumes[~inside].mean() > 8 * volumes[inside].mean(), "ROI: tetrahedra outside are much larger than inside")
dc.check(far.sum() < 100 and levels[far].max() < levels[inside].min(), "ROI: the far octant stays coarse")
dc.check(dc.hierarchy_builds(filt) == builds_before_roi, "the region of interest did not rebuild the hierarchy")
# The default region is the input's bounds (BoundsDomain), once the input has been updated.
fresh = simple.AdaptiveTetrahedra(Input=wavelet)
dc.check(list(fresh.RegionOfInterest) == [-16.0, 16.0] * 3, f"RegionOfInterest defaults to the input bounds: {list(fresh.RegionOfInterest)}")

# ---- The proxy as the GUI sees it: menu category and documentation.
from paraview import servermanager  # noqa: E402

prototype = servermanager.ProxyManager().GetPrototypeProxy("filters", "AdaptiveTetrahedra")
hints = prototype.GetHints()
menu = hints.FindNestedElementByName("ShowInMenu") if hints else None
dc.check(menu is not None and menu.GetAttribute("category") == "Diamonds", "listed in the Filters > Diamonds menu")
doc = prototype.GetDocumentation()
dc.check(len(doc.GetDescription() or "") > 2000, f"the filter has a long <Documentation> ({len(doc.GetDescription() or '')} chars)")
dc.check(prototype.GetXMLLabel() == "Adaptive Tetrahedra", "label 'Adaptive Tetrahedra'")

dc.finish("test_properties")
