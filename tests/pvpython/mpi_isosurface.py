"""Adaptive Isosurface on a distributed image: run with

  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds \
    mpiexec --allow-run-as-root -n 2 pvbatch tests/pvpython/mpi_isosurface.py

Each rank contours its own piece of the Wavelet. The script (on rank 0) fetches every rank's piece of
the input and of the surface and checks each surface independently (isosurface_checks.py) against its
piece: triangles only, watertight except along the piece's boundary, consistently oriented, facing
increasing values, ErrorBound <= Tolerance, RelativeTolerance relative to the whole image, and every
vertex within Tolerance + a voxel diagonal of the full-resolution Contour of the whole image computed
here. Surfaces of different pieces are not required to match along the plane they share (documented).
"""

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import diamonds_checks as dc  # noqa: E402
from isosurface_checks import check_surface  # noqa: E402
from paraview import servermanager  # noqa: E402
from vtkmodules.vtkFiltersCore import vtkFlyingEdges3D  # noqa: E402
from vtkmodules.vtkImagingCore import vtkRTAnalyticSource  # noqa: E402

simple = dc.require_plugin()
ranks = servermanager.vtkProcessModule.GetProcessModule().GetNumberOfLocalPartitions()
expected = int(os.environ.get("DIAMONDS_EXPECTED_RANKS", "2"))
dc.check(ranks == expected, f"running on {ranks} MPI ranks (expected {expected})")

whole = [-16, 16, -16, 16, -16, 16]
iso = 157.0
wavelet = simple.Wavelet()
wavelet.WholeExtent = whole
filt = simple.AdaptiveIsosurface(Input=wavelet, Isosurfaces=[iso], Tolerance=0.3)
filt.UpdatePipeline()

# The reference: the whole image and its full-resolution surface, computed here without the pipeline.
reference_image = vtkRTAnalyticSource()
reference_image.SetWholeExtent(*whole)
reference = vtkFlyingEdges3D()
reference.SetInputConnection(reference_image.GetOutputPort())
reference.SetValue(0, iso)
reference.Update()
whole_bounds = reference_image.GetOutput().GetBounds()


def check_pieces(label, tolerance, error_limit=None):
    counts = []
    extents = []
    for r in range(ranks):
        piece = servermanager.Fetch(wavelet, r)
        surface = servermanager.Fetch(filt, r)
        extent = list(piece.GetExtent())
        print(f"{label}: rank {r} piece extent {extent}: {surface.GetNumberOfCells()} triangles")
        counts.append(
            check_surface(
                piece,
                surface,
                "RTData",
                tolerance,
                f"{label}, rank {r}",
                reference=reference.GetOutput(),
                whole_bounds=whole_bounds,
                error_limit=error_limit,
            )
        )
        extents.append(extent)
    lo = np.min(np.array(extents)[:, 0::2], axis=0)
    hi = np.max(np.array(extents)[:, 1::2], axis=0)
    dc.check(list(lo) == whole[0::2] and list(hi) == whole[1::2], f"{label}: the pieces cover the whole extent")
    if ranks > 1:
        dc.check(len({tuple(e) for e in extents}) == ranks, f"{label}: every rank has its own piece")
    return counts


counts = check_pieces("tol 0.3", 0.3)
print(f"triangles per rank: {counts}, total {sum(counts)} (full-resolution Flying Edges: {reference.GetOutput().GetNumberOfCells()})")

# An isovalue and a tolerance change: every piece re-extracted.
filt.Isosurfaces = [130.0]
filt.Tolerance = 1.0
filt.UpdatePipeline()
reference.SetValue(0, 130.0)
reference.Update()
check_pieces("isovalue 130 tol 1", 1.0)

# A region of interest inside rank 0's piece only: the other pieces get their coarsest surface.
first = servermanager.Fetch(wavelet, 0).GetBounds()
roi = [first[0], first[0] + 6.0, first[2], first[2] + 6.0, first[4], first[4] + 6.0]
filt.Tolerance = 0.0
filt.UseRegionOfInterest = 1
filt.RegionOfInterest = roi
filt.UpdatePipeline()
roi_counts = check_pieces("ROI", 0.0, error_limit=float("inf"))
filt.UseRegionOfInterest = 0
full_counts = check_pieces("tol 0", 0.0)
print(f"tolerance 0 with a region of interest in rank 0's corner: triangles per rank {roi_counts}; without: {full_counts}")
if ranks > 1:
    dc.check(max(roi_counts[1:]) < min(full_counts[1:]), "pieces outside the region of interest are coarser")

dc.finish(f"mpi_isosurface ({ranks} ranks)", mpi=True)
