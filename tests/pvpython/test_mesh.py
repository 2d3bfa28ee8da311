"""The mesh of Adaptive Tetrahedra, checked independently with numpy (see diamonds_checks.py):
on ParaView's Wavelet at several tolerances, on an odd-sized float64 field (33 x 20 x 17, origin and
spacing not trivial) and on a uint8 volume (40 x 31 x 26).

  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds pvpython tests/pvpython/test_mesh.py
"""

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import diamonds_checks as dc  # noqa: E402

simple = dc.require_plugin()

# ---- Wavelet 33^3 (extent -16..16: the extent does not start at 0).
wavelet = simple.Wavelet()
wavelet.WholeExtent = [-16, 16, -16, 16, -16, 16]
image = dc.fetch(wavelet)
rt_range = image.GetPointData().GetArray("RTData").GetRange()
print(f"Wavelet 33^3, RTData range {rt_range}")
filt = simple.AdaptiveTetrahedra(Input=wavelet)
dc.check(filt.Tolerance == 1.0, f"default Tolerance is 1.0 (got {filt.Tolerance})")
dc.check(filt.MaximumNumberOfTetrahedra == 0, "default MaximumNumberOfTetrahedra is 0")
dc.check(filt.UseRegionOfInterest == 0, "default UseRegionOfInterest is off")
counts = []
for tol in (0.0, 1.0, 4.0, 16.0):
    filt.Tolerance = tol
    mesh = dc.fetch(filt)
    counts.append(dc.check_mesh(image, mesh, "RTData", tol, f"Wavelet tol {tol:g}"))
print("Wavelet tetrahedra at tolerance 0, 1, 4, 16:", counts, "(Tetrahedralize: 163840)")
dc.check(counts[0] == 6 * 32**3, f"tolerance 0 on a 2^k+1 grid with no linear region keeps all {6 * 32**3} tetrahedra")
dc.check(all(a >= b for a, b in zip(counts, counts[1:])), "tetrahedron count non-increasing as the tolerance grows")
dc.check(counts[-1] < counts[0] / 4, "tolerance 16 is visibly adaptive (< 1/4 of the lossless count)")

# ---- An odd-sized float64 field with a sharp front: 33 x 20 x 17 points.
odd = dc.programmable_image(
    simple,
    (33, 20, 17),
    "add('front', np.tanh(4.0 * (x + 0.5 * y - 0.3 * z - 3.0)) + 0.05 * np.sin(x) * np.cos(z), scalars=True)\n"
    "add('ramp', 2.0 * x - y + 0.5 * z)\n"
    "add('velocity', np.stack([x, 2.0 * y, z - 1.0], axis=1))\n"
    "labels = vtk.vtkStringArray()\n"
    "labels.SetName('label')\n"
    "labels.SetNumberOfValues(x.size)\n"
    "for i in range(x.size):\n"
    "    labels.SetValue(i, str(i % 97))\n"
    "out.GetPointData().AddArray(labels)\n",
    origin=(-3.0, 1.5, 10.0),
    spacing=(0.25, 0.5, 0.75),
)
odd_image = dc.fetch(odd)
odd_filter = simple.AdaptiveTetrahedra(Input=odd)
for tol in (0.0, 0.01, 0.1):
    odd_filter.Tolerance = tol
    dc.check_mesh(odd_image, dc.fetch(odd_filter), "front", tol, f"33x20x17 float64 tol {tol:g}")
# A string array (no contiguous values: passed through by point id) keeps each point's value.
odd_mesh = dc.fetch(odd_filter)
odd_points, _, _ = dc.mesh_arrays(odd_mesh)
ijk = np.rint((odd_points - np.array([-3.0, 1.5, 10.0])) / np.array([0.25, 0.5, 0.75])).astype(np.int64)
lin = ijk[:, 0] + 33 * (ijk[:, 1] + 20 * ijk[:, 2])
labels = odd_mesh.GetPointData().GetAbstractArray("label")
dc.check(
    labels is not None
    and labels.GetNumberOfValues() == len(lin)
    and [labels.GetValue(k) for k in range(len(lin))] == [str(i % 97) for i in lin],
    "string point array 'label' passed through unchanged",
)
# The linear 'ramp' is reproduced exactly by the coarsest mesh.
odd_filter.Scalars = ["POINTS", "ramp"]
odd_filter.Tolerance = 0.0
ramp_mesh = dc.fetch(odd_filter)
dc.check_mesh(odd_image, ramp_mesh, "ramp", 1e-9, "33x20x17 linear ramp tol 0")
front_count = dc.fetch(simple.AdaptiveTetrahedra(Input=odd, Tolerance=0.0)).GetNumberOfCells()
print(f"linear ramp at tolerance 0: {ramp_mesh.GetNumberOfCells()} tetrahedra (front: {front_count})")
dc.check(ramp_mesh.GetNumberOfCells() < front_count / 4, "a linear field needs only the base mesh")

# ---- A uint8 volume: a blurred ball plus a plateau, 40 x 31 x 26 points.
u8 = dc.programmable_image(
    simple,
    (40, 31, 26),
    "r = np.sqrt((x - 18.0) ** 2 + (y - 14.0) ** 2 + (z - 12.0) ** 2)\n"
    "v = 200.0 / (1.0 + np.exp(r - 9.0)) + np.where(x > 30, 40.0, 0.0)\n"
    "add('density', np.clip(np.rint(v), 0, 255).astype(np.uint8), scalars=True)\n",
)
u8_image = dc.fetch(u8)
dc.check(u8_image.GetPointData().GetScalars().GetDataTypeAsString() == "unsigned char", "the volume is uint8")
u8_filter = simple.AdaptiveTetrahedra(Input=u8)
for tol in (0.0, 1.0, 8.0):
    u8_filter.Tolerance = tol
    dc.check_mesh(u8_image, dc.fetch(u8_filter), "density", tol, f"40x31x26 uint8 tol {tol:g}")

dc.finish("test_mesh")
