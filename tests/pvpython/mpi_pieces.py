"""Adaptive Tetrahedra on a distributed image: run with

  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds \
    mpiexec --allow-run-as-root -n 2 pvbatch tests/pvpython/mpi_pieces.py

Each rank meshes its own piece of the Wavelet. The script (on rank 0) fetches every rank's piece
separately and checks it independently against the same image computed locally: each piece must
be a valid, conforming tetrahedral mesh of its piece meeting the tolerance. Meshes of different
pieces are not required to conform to each other (documented behaviour).
"""

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import diamonds_checks as dc  # noqa: E402
from paraview import servermanager  # noqa: E402
from vtkmodules.vtkImagingCore import vtkExtractVOI, vtkRTAnalyticSource  # noqa: E402

simple = dc.require_plugin()
ranks = servermanager.vtkProcessModule.GetProcessModule().GetNumberOfLocalPartitions()
expected = int(os.environ.get("DIAMONDS_EXPECTED_RANKS", "2"))
dc.check(ranks == expected, f"running on {ranks} MPI ranks (expected {expected})")

whole = [-16, 16, -16, 16, -16, 16]
wavelet = simple.Wavelet()
wavelet.WholeExtent = whole
filt = simple.AdaptiveTetrahedra(Input=wavelet, Tolerance=4.0)
filt.UpdatePipeline()

# The same image, computed here without the pipeline, to cut each piece's samples from.
reference = vtkRTAnalyticSource()
reference.SetWholeExtent(*whole)
reference.Update()


def piece_image(mesh):
    """The reference samples over the extent covered by `mesh`."""
    b = np.array(mesh.GetBounds())
    extent = [int(round(v)) for v in b]  # spacing 1, origin 0: bounds are indices
    voi = vtkExtractVOI()
    voi.SetInputData(reference.GetOutput())
    voi.SetVOI(*extent)
    voi.Update()
    return voi.GetOutput(), extent


def check_pieces(label, tolerance, region=None):
    counts = []
    extents = []
    for r in range(ranks):
        mesh = servermanager.Fetch(filt, r)
        image, extent = piece_image(mesh)
        print(f"{label}: rank {r} piece extent {extent}: {mesh.GetNumberOfCells()} tetrahedra")
        counts.append(dc.check_mesh(image, mesh, "RTData", tolerance, f"{label}, rank {r}", tolerance_region=region))
        extents.append(extent)
    lo = np.min(np.array(extents)[:, 0::2], axis=0)
    hi = np.max(np.array(extents)[:, 1::2], axis=0)
    dc.check(list(lo) == whole[0::2] and list(hi) == whole[1::2], f"{label}: the pieces cover the whole extent")
    if ranks > 1:
        dc.check(len({tuple(e) for e in extents}) == ranks, f"{label}: every rank has its own piece")
    return counts


counts = check_pieces("tol 4", 4.0)
print(f"tetrahedra per rank: {counts}, total {sum(counts)}")

# A region of interest inside rank 0's piece only: the other pieces get their coarsest mesh.
first = servermanager.Fetch(filt, 0).GetBounds()
roi = [first[0], first[0] + 4.0, first[2], first[2] + 4.0, first[4], first[4] + 4.0]
filt.UseRegionOfInterest = 1
filt.RegionOfInterest = roi
filt.UpdatePipeline()
roi_counts = check_pieces("ROI", 4.0, region=roi)
print(f"with a region of interest in rank 0's corner: tetrahedra per rank {roi_counts}")
dc.check(all(c > 0 for c in roi_counts), "every piece is meshed with a region of interest")
if ranks > 1:
    dc.check(max(roi_counts[1:]) < counts[1], "pieces outside the region of interest are coarser")

dc.finish(f"mpi_pieces ({ranks} ranks)", mpi=True)
