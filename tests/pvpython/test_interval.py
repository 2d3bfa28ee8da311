"""Adaptive Interval Volume, checked independently with numpy (VTK only hands over the arrays, and
ParaView's own Iso Volume is the reference):

- only VTK_TETRA cells, positive volumes; conformity from the faces alone: no face in three or more
  tetrahedra, and a face in one only on the image box or on a bounding surface (its three values of
  the processed array at the lower or the upper bound);
- every output point is a sample in the range (its arrays passed through unchanged) or lies on a
  segment between two samples with the processed array at a bound; cell data Level;
- at Tolerance 0 the volume equals Iso Volume's within one voxel layer over the bounding surfaces
  (both are exact for their interpolants: linear on the finest tetrahedra here, trilinear cuts
  there), and within (Tolerance + h/sqrt(3)) times that area at larger tolerances, with fewer
  tetrahedra as Tolerance grows and ErrorBound <= Tolerance;
- the budget, the region of interest; changing the range or Tolerance does not rebuild the hierarchy;
- defaults (ThresholdRange = the array's range, Tolerance two and a half voxel diagonals);
- bad inputs: a clear error, an empty output, no crash; a range missing the data: a warning.

  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds pvpython tests/pvpython/test_interval.py
"""

import math
import os
import sys

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import diamonds_checks as dc  # noqa: E402

simple = dc.require_plugin()
dc.check(hasattr(simple, "AdaptiveIntervalVolume"), "AdaptiveIntervalVolume exists in paraview.simple")

VTK_TETRA = 10


def volumes(points, tets):
    p = points[tets]
    return np.einsum("ij,ij->i", p[:, 1] - p[:, 0], np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 0])) / 6.0


def iso_volume(source, array, lo, hi):
    """Volume of ParaView's Iso Volume, its cells tetrahedralised (Tetrahedralize) and summed."""
    iv = simple.IsoVolume(Input=source, InputScalars=["POINTS", array], ThresholdRange=[lo, hi])
    tets = dc.fetch(simple.Tetrahedralize(Input=iv))
    points, t, _ = dc.mesh_arrays(tets)
    cells = dc.fetch(iv).GetNumberOfCells()
    return float(np.abs(volumes(points, t)).sum()), cells


def check_interval(image, ug, array, lo, hi, label):
    """The independent checks of one output; returns (volume, tetrahedra, bounding-surface area)."""
    points, tets, types = dc.mesh_arrays(ug)
    n = 0 if tets is None else len(tets)
    dc.check(n > 0 and (types == VTK_TETRA).all(), f"{label}: {n} tetrahedra, only VTK_TETRA")
    if not n:
        return 0.0, 0, 0.0
    v = volumes(points, tets)
    dc.check((v > 0).all(), f"{label}: every tetrahedron has a positive volume (smallest {v.min():.3g})")
    f = vtk_to_numpy(ug.GetPointData().GetArray(array)).astype(np.float64)
    span = hi - lo
    at_lo, at_hi = np.abs(f - lo) <= 1e-9 * span, np.abs(f - hi) <= 1e-9 * span
    dc.check(((f >= lo - 1e-9 * span) & (f <= hi + 1e-9 * span)).all(), f"{label}: every point value in [{lo}, {hi}]")
    # Points: samples (on the lattice, arrays unchanged) or at a bound on a segment between samples.
    origin, spacing = np.array(image.GetOrigin()), np.array(image.GetSpacing())
    extent, dims = np.array(image.GetExtent()), np.array(image.GetDimensions())
    fijk = (points - origin) / spacing - extent[0::2]
    on_lattice = (np.abs(fijk - np.rint(fijk)) < 1e-9).all(axis=1)
    ijk = np.rint(fijk[on_lattice]).astype(np.int64)
    lin = ijk[:, 0] + dims[0] * (ijk[:, 1] + dims[1] * ijk[:, 2])
    samples = vtk_to_numpy(image.GetPointData().GetArray(array)).astype(np.float64)
    dc.check(np.array_equal(samples[lin], f[on_lattice]), f"{label}: {on_lattice.sum()} sample points keep their values")
    dc.check((at_lo | at_hi)[~on_lattice].all(), f"{label}: {(~on_lattice).sum()} new points lie on a bound")
    levels = ug.GetCellData().GetArray("Level")
    dc.check(levels is not None and levels.GetNumberOfTuples() == n and levels.GetDataTypeAsString() == "unsigned char", f"{label}: cell data Level")
    # Conformity from the faces alone.
    faces = np.sort(np.concatenate([tets[:, [1, 2, 3]], tets[:, [0, 2, 3]], tets[:, [0, 1, 3]], tets[:, [0, 1, 2]]]), axis=1)
    keys, counts = np.unique(faces, axis=0, return_counts=True)
    dc.check(counts.max() <= 2, f"{label}: no face in more than two tetrahedra")
    single = keys[counts == 1]
    b = np.array(image.GetBounds())
    eps = 1e-9 * np.abs(b).max()
    on_box = np.zeros(len(single), bool)
    for axis in range(3):
        c = points[single][:, :, axis]
        on_box |= (np.abs(c - b[2 * axis]) <= eps).all(axis=1) | (np.abs(c - b[2 * axis + 1]) <= eps).all(axis=1)
    on_lo, on_hi = at_lo[single].all(axis=1), at_hi[single].all(axis=1)
    bad = ~(on_box | on_lo | on_hi)
    dc.check(not bad.any(), f"{label}: the {len(single)} faces in one tetrahedron lie on the box or a bounding surface ({bad.sum()} do not)")
    surface = single[(on_lo | on_hi) & ~on_box]
    p = points[surface]
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum()
    return float(v.sum()), n, float(area)


# ---- Wavelet 33^3: Iso Volume at tolerance 0, tolerances, the hierarchy cache.
wavelet = simple.Wavelet()
wavelet.WholeExtent = [-16, 16, -16, 16, -16, 16]
image = dc.fetch(wavelet)
rlo, rhi = image.GetPointData().GetArray("RTData").GetRange()
filt = simple.AdaptiveIntervalVolume(Input=wavelet)
dc.check(list(filt.Scalars) == ["POINTS", "RTData"], f"default Scalars {list(filt.Scalars)}")
dc.check(np.allclose(list(filt.ThresholdRange), [rlo, rhi]), f"default ThresholdRange {list(filt.ThresholdRange)} is the array's range")
voxel_length = math.sqrt(3 * 32.0**2) / 32.0
dc.check(abs(filt.Tolerance - 2.5 * voxel_length) < 1e-9, f"default Tolerance is two and a half voxel diagonals: {filt.Tolerance}")
zero = simple.AdaptiveIntervalVolume(Input=wavelet, Tolerance=0.0)
dc.check(zero.Tolerance == 0.0, "AdaptiveIntervalVolume(..., Tolerance=0) keeps 0")

lo, hi = 130.5, 190.25
filt.ThresholdRange = [lo, hi]
filt.Tolerance = 0.0
out = dc.fetch(filt)
volume0, tets0, area0 = check_interval(image, out, "RTData", lo, hi, "tolerance 0")
reference, iso_cells = iso_volume(wavelet, "RTData", lo, hi)
h = 1.0
dc.check(
    abs(volume0 - reference) <= h * area0,
    f"tolerance 0: volume {volume0:.2f} vs Iso Volume's {reference:.2f} ({iso_cells} cells): off by {abs(volume0 - reference):.2f} <= one voxel times the surface area {area0:.1f}",
)
dc.check(dc.field_value(out, "ErrorBound") == 0.0 and dc.field_value(out, "NumberOfTetrahedra") == tets0, "tolerance 0: field data ErrorBound 0, NumberOfTetrahedra")
dc.check(dc.field_value(out, "NumberOfLeaves") > 0 and dc.field_value(out, "NumberOfPoints") == out.GetNumberOfPoints(), "field data NumberOfLeaves, NumberOfPoints")
builds = dc.hierarchy_builds(filt)

counts = [tets0]
for tolerance in (0.5, 1.0, 2.0, 4.0):
    filt.Tolerance = tolerance
    out = dc.fetch(filt)
    volume, n, area = check_interval(image, out, "RTData", lo, hi, f"tolerance {tolerance}")
    bound = (tolerance + h / math.sqrt(3)) * area0
    dc.check(abs(volume - volume0) <= bound, f"tolerance {tolerance}: volume off the exact one by {abs(volume - volume0):.2f} <= {bound:.2f}")
    dc.check(dc.field_value(out, "ErrorBound") <= tolerance, f"tolerance {tolerance}: ErrorBound {dc.field_value(out, 'ErrorBound'):.3g} <= Tolerance")
    counts.append(n)
dc.check(all(a >= b for a, b in zip(counts, counts[1:])) and counts[-1] < counts[0], f"fewer tetrahedra as Tolerance grows: {counts}")

# Budget and region of interest.
filt.Tolerance = 0.0
filt.MaximumNumberOfTetrahedra = tets0 // 3
out = dc.fetch(filt)
check_interval(image, out, "RTData", lo, hi, "budget")
dc.check(0 < out.GetNumberOfCells() <= tets0 // 3 and dc.field_value(out, "ReachedTolerance") > 0, f"budget {tets0 // 3}: {out.GetNumberOfCells()} tetrahedra at tolerance {dc.field_value(out, 'ReachedTolerance'):.3g}")
filt.MaximumNumberOfTetrahedra = 0
filt.UseRegionOfInterest = 1
filt.RegionOfInterest = [-16, 0, -16, 16, -16, 16]
out = dc.fetch(filt)
_, n_roi, _ = check_interval(image, out, "RTData", lo, hi, "region of interest")
dc.check(n_roi < tets0, f"region of interest: {n_roi} < {tets0} tetrahedra")
filt.UseRegionOfInterest = 0
dc.check(dc.hierarchy_builds(filt) == builds == 1, f"range, tolerance, budget and region changes built the hierarchy once ({dc.hierarchy_builds(filt)})")

# Another range: equal to a fresh filter.
filt.ThresholdRange = [100.0, 150.0]
filt.Tolerance = 1.0
again = dc.fetch(filt)
fresh = dc.fetch(simple.AdaptiveIntervalVolume(Input=wavelet, ThresholdRange=[100.0, 150.0], Tolerance=1.0))
same = again.GetNumberOfCells() == fresh.GetNumberOfCells() and np.array_equal(
    vtk_to_numpy(again.GetPoints().GetData()), vtk_to_numpy(fresh.GetPoints().GetData())
)
dc.check(same and dc.hierarchy_builds(filt) == 1, "a new range on the kept hierarchy equals a fresh filter")

# ---- Bad inputs: clear errors, empty outputs, no crash.
for label, props, phrase in [
    ("reversed range", dict(ThresholdRange=[150.0, 100.0]), "is empty"),
    ("equal bounds", dict(ThresholdRange=[150.0, 150.0]), "is empty"),
    ("NaN bound", dict(ThresholdRange=[float("nan"), 100.0]), "finite"),
    ("negative tolerance", dict(ThresholdRange=[100.0, 150.0], Tolerance=-1.0), "Tolerance"),
    ("region outside", dict(ThresholdRange=[100.0, 150.0], UseRegionOfInterest=1, RegionOfInterest=[100, 200, 100, 200, 100, 200]), "region"),
]:
    f = simple.AdaptiveIntervalVolume(Input=wavelet, **dict(dict(Tolerance=1.0), **props))
    with dc.ErrorCapture(f) as errors:
        result = dc.fetch(f)
    text = errors.text()
    print(f"   [{label}] {text.strip().splitlines()[-1] if text.strip() else '(no message)'}")
    dc.check(phrase.lower() in text.lower() and result.GetNumberOfCells() == 0, f"{label}: error mentions {phrase!r}, empty output")
outside = simple.AdaptiveIntervalVolume(Input=wavelet, ThresholdRange=[1000.0, 2000.0], Tolerance=1.0)
with dc.ErrorCapture(outside) as errors:
    empty = dc.fetch(outside)
dc.check(empty.GetNumberOfCells() == 0 and "misses the data range" in errors.text(), f"range outside the data: empty output, a warning ({errors.text()!r})")
cells_only = simple.PointDatatoCellData(Input=wavelet)
cells_only.PassPointData = 0
f = simple.AdaptiveIntervalVolume(Input=cells_only, ThresholdRange=[100.0, 150.0])
with dc.ErrorCapture(f) as errors:
    result = dc.fetch(f)
dc.check(result is not None and "point" in errors.text().lower(), "cell data only: an error asking for point data")

prototype = simple.AdaptiveIntervalVolume(Input=wavelet)
doc = prototype.GetDocumentation()
dc.check(len(doc.GetDescription() or "") > 2000, f"the filter has a long <Documentation> ({len(doc.GetDescription() or '')} chars)")

dc.finish("test_interval")
