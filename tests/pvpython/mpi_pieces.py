"""Adaptive Tetrahedra on a distributed image equals the serial result, partitioned. Run with

  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds \
    mpiexec --allow-run-as-root -n 2 pvbatch tests/pvpython/mpi_pieces.py
  (and -n 3 with DIAMONDS_EXPECTED_RANKS=3), or in client-server mode, as the GUI connects:
  PV_PLUGIN_PATH=... pvpython tests/pvpython/mpi_pieces.py --client-server
  (starts `mpiexec -n 2 pvserver` on a free port and Connects to it).

For images of odd sizes (generated, and every shared volume when ../shared is there) and several
queries, the script (rank 0) fetches every rank's piece and checks, independently of the filter:
- the tetrahedra of all ranks together are those of the serial mesh (the CLI's, on the same image),
  as sets of whole-grid point triples, with the same BisectionDepth and ApproximationError;
- no tetrahedron is output by two ranks, and every rank with cells owns some;
- the union is conforming: every face is shared by two tetrahedra or lies on the image's boundary
  (no hanging faces along the seams);
- GlobalPointIds are the whole-grid indices of the points, and point data equals the image's (also
  a two-component array of non-contiguous layout after a string array, which ranks leave out);
- field data: TetrahedraPerRank (one value per rank, summing to NumberOfTetrahedra), SecondsPerRank,
  BytesSentPerRank; changing the tolerance re-queries without rebuilding.
"""

import builtins
import os
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import diamonds_checks as dc  # noqa: E402
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402
from vtkmodules.vtkIOXML import vtkXMLImageDataWriter, vtkXMLUnstructuredGridReader  # noqa: E402

simple = dc.require_plugin()
RANKS = dc.Ranks(simple)
ranks = RANKS.count
workdir = tempfile.mkdtemp(prefix="diamonds-mpi-")


def tets_by_grid_index(ug, image):
    """(sorted whole-grid point indices per tetrahedron, depths, errors) from coordinates."""
    points, tets, types = dc.mesh_arrays(ug)
    origin, spacing = np.array(image.GetOrigin()), np.array(image.GetSpacing())
    ext = np.array(image.GetExtent())
    dims = ext[1::2] - ext[0::2] + 1
    ijk = np.rint((points - origin) / spacing).astype(np.int64) - ext[0::2]
    index = ijk[:, 0] + dims[0] * (ijk[:, 1] + dims[1] * ijk[:, 2])
    keys = np.sort(index[tets], axis=1) if len(tets) else np.zeros((0, 4), np.int64)
    cd = ug.GetCellData()
    depth = vtk_to_numpy(cd.GetArray("BisectionDepth")).astype(np.int64)
    error = vtk_to_numpy(cd.GetArray("ApproximationError")).astype(np.float64)
    return keys, depth, error, index


def as_rows(keys, depth, error):
    rows = np.column_stack([keys, depth, (error * 1e6).round().astype(np.int64)])
    return rows[np.lexsort(rows.T[::-1])]


def serial_reference(image, tolerance, roi, label):
    """The serial mesh of `image`, written by the CLI."""
    vti = os.path.join(workdir, f"{label}.vti")
    vtu = os.path.join(workdir, f"{label}.vtu")
    w = vtkXMLImageDataWriter()
    w.SetFileName(vti)
    w.SetInputData(image)
    w.Write()
    cmd = [dc.diamonds_binary(), "tetra", vti, vtu, "--tolerance", str(tolerance)]
    if roi is not None:
        cmd += ["--roi"] + [str(v) for v in roi]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    r = vtkXMLUnstructuredGridReader()
    r.SetFileName(vtu)
    r.Update()
    return r.GetOutput()


def check_distributed(source, image, scalars, tolerance, label, roi=None):
    """Adaptive Tetrahedra on `source` (a pipeline proxy producing `image`) on every rank."""
    filt = simple.AdaptiveTetrahedra(Input=source, Tolerance=tolerance)
    filt.Scalars = ["POINTS", scalars]
    if roi is not None:
        filt.UseRegionOfInterest = 1
        filt.RegionOfInterest = roi
    filt.UpdatePipeline()
    reference = serial_reference(image, tolerance, roi, label)
    ref_keys, ref_depth, ref_error, _ = tets_by_grid_index(reference, image)
    values = vtk_to_numpy(image.GetPointData().GetArray(scalars))
    parts, per_rank = [], []
    for r in range(ranks):
        piece = servermanager.Fetch(filt, r)
        n = piece.GetNumberOfCells()
        per_rank.append(n)
        if n == 0:
            continue
        keys, depth, error, index = tets_by_grid_index(piece, image)
        gids = vtk_to_numpy(piece.GetPointData().GetGlobalIds()).astype(np.int64)
        dc.check(np.array_equal(gids, index), f"{label}: rank {r}: GlobalPointIds are the whole-grid indices")
        got = vtk_to_numpy(piece.GetPointData().GetArray(scalars))
        dc.check(np.array_equal(got, values[index]), f"{label}: rank {r}: point data passed through")
        per = vtk_to_numpy(piece.GetFieldData().GetArray("TetrahedraPerRank"))
        dc.check(len(per) == ranks and per[r] == n, f"{label}: rank {r}: TetrahedraPerRank {list(per)}")
        dc.check(dc.field_value(piece, "NumberOfTetrahedra") == len(ref_keys), f"{label}: NumberOfTetrahedra is the total")
        secs = piece.GetFieldData().GetArray("SecondsPerRank")
        sent = piece.GetFieldData().GetArray("BytesSentPerRank")
        dc.check(secs is not None and sent is not None and secs.GetNumberOfTuples() == ranks, f"{label}: rank {r}: SecondsPerRank and BytesSentPerRank")
        parts.append((keys, depth, error))
    keys = np.concatenate([p[0] for p in parts])
    depth = np.concatenate([p[1] for p in parts])
    error = np.concatenate([p[2] for p in parts])
    print(f"{label}: {len(ref_keys)} serial tetrahedra; per rank {per_rank}")
    # builtins.sum: a ProgrammableFilter run by pvbatch's rank 0 puts numpy_interface.algorithms into
    # this script's namespace, whose sum is an MPI all-reduce the other ranks never join.
    total = builtins.sum(per_rank)
    dc.check(total == len(ref_keys), f"{label}: as many tetrahedra as serial ({total} vs {len(ref_keys)})")
    dc.check(len(np.unique(keys, axis=0)) == len(keys), f"{label}: no tetrahedron on two ranks")
    dc.check(
        np.array_equal(as_rows(keys, depth, error), as_rows(ref_keys, ref_depth, ref_error)),
        f"{label}: the ranks' tetrahedra, depths and errors are the serial ones",
    )
    if ranks > 1 and len(ref_keys) > 1000:
        dc.check(builtins.sum(1 for n in per_rank if n > 0) > 1, f"{label}: the work is shared ({per_rank})")
    # Conformity of the union: every face in two tetrahedra, or on the image boundary.
    faces = np.concatenate([keys[:, [0, 1, 2]], keys[:, [0, 1, 3]], keys[:, [0, 2, 3]], keys[:, [1, 2, 3]]])
    uniq, counts = np.unique(faces, axis=0, return_counts=True)
    ext = np.array(image.GetExtent())
    dims = ext[1::2] - ext[0::2] + 1
    ijk = np.stack([uniq % dims[0], uniq // dims[0] % dims[1], uniq // (dims[0] * dims[1])], axis=-1)
    on_boundary = np.zeros(len(uniq), bool)
    for a in range(3):
        for v in (0, dims[a] - 1):
            on_boundary |= (ijk[:, :, a] == v).all(axis=1)
    hanging = int(((counts == 1) & ~on_boundary).sum())
    dc.check(hanging == 0 and counts.max() <= 2, f"{label}: no hanging faces across the seams ({hanging}, max {counts.max()})")
    return filt


# A generated image of odd sizes: ParaView's Wavelet over 65 x 41 x 53 points.
wavelet, image = dc.wavelet(simple, [0, 64, 0, 40, 0, 52])
filt = check_distributed(wavelet, image, "RTData", 8.0, "wavelet tol 8")
builds = dc.hierarchy_builds(filt)
filt.Tolerance = 2.0
filt.UpdatePipeline()
dc.check(dc.hierarchy_builds(filt) == builds, "changing the tolerance keeps every rank's hierarchy")
check_distributed(wavelet, image, "RTData", 2.0, "wavelet tol 2")
check_distributed(wavelet, image, "RTData", 0.0, "wavelet tol 0")
check_distributed(wavelet, image, "RTData", 4.0, "wavelet ROI", roi=[10.0, 30.0, 5.0, 20.0, 0.0, 52.0])

# Point arrays of other kinds on every rank's piece: a string array (not numeric: left out on ranks)
# before a two-component array of non-contiguous layout (vtkSOADataArrayTemplate), which passes through.
extra = simple.ProgrammableFilter(Input=wavelet)
extra.Script = """
from vtkmodules.vtkCommonCore import vtkSOADataArrayTemplate, vtkStringArray
inp, out = self.GetInput(), self.GetOutput()
out.ShallowCopy(inp)
n = inp.GetNumberOfPoints()
rt = inp.GetPointData().GetArray("RTData")
label = vtkStringArray()
label.SetName("Label")
label.SetNumberOfValues(n)
pair = vtkSOADataArrayTemplate["float64"]()
pair.SetName("Pair")
pair.SetNumberOfComponents(2)
pair.SetNumberOfTuples(n)
for i in range(n):
    label.SetValue(i, "p")
    pair.SetTuple2(i, rt.GetValue(i), -2.0 * rt.GetValue(i))
out.GetPointData().AddArray(label)
out.GetPointData().AddArray(pair)
"""
filt = check_distributed(extra, image, "RTData", 8.0, "wavelet with string and SOA arrays")
rt_values = vtk_to_numpy(image.GetPointData().GetArray("RTData"))
for r in range(ranks):
    piece = servermanager.Fetch(filt, r)
    if piece.GetNumberOfCells() == 0:
        continue
    index = vtk_to_numpy(piece.GetPointData().GetGlobalIds()).astype(np.int64)
    pair = piece.GetPointData().GetArray("Pair")
    got = vtk_to_numpy(pair) if pair is not None else None
    expected = np.stack([rt_values[index], -2.0 * rt_values[index]], axis=1)
    dc.check(got is not None and np.array_equal(got, expected), f"rank {r}: a non-contiguous two-component array passes through")
simple.Delete(filt)
simple.Delete(extra)

# An image smaller than the number of ranks: some ranks have empty pieces.
tiny, tiny_image = dc.wavelet(simple, [0, 1, 0, 1, 0, 1])
check_distributed(tiny, tiny_image, "RTData", 0.0, "one cell")

# Every shared volume (real CT/MRI/simulation data, several odd sizes and types) read in pieces, at
# 2 % of its range. Volumes over 2 M points (bonsai 256³) only where DIAMONDS_MPI_LARGE=1 (the 2-rank
# pvbatch run of test-integration.sh), at 10 % of the range (at 2 %: 17.9 M tetrahedra, equal to
# serial, but ten minutes of comparing on a loaded 2-core machine).
large = os.environ.get("DIAMONDS_MPI_LARGE") == "1"
for entry, path, ct in dc.shared_images():
    big = ct.GetNumberOfPoints() > 2_000_000
    if big and not large:
        print(f"{entry}: {ct.GetNumberOfPoints()} points, compared in the 2-rank pvbatch run only")
        continue
    name = ct.GetPointData().GetScalars().GetName()
    lo, hi = ct.GetPointData().GetScalars().GetRange()
    reader = simple.XMLImageDataReader(FileName=[path])
    simple.Delete(check_distributed(reader, ct, name, (0.1 if big else 0.02) * (hi - lo), entry.split("_")[0]))
    simple.Delete(reader)

RANKS.finish("mpi_pieces")
