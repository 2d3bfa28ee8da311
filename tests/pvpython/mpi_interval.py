"""Adaptive Interval Volume on a distributed image equals the serial volume, partitioned. Run with

  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds \
    mpiexec --allow-run-as-root -n 2 pvbatch tests/pvpython/mpi_interval.py
  (and -n 3 with DIAMONDS_EXPECTED_RANKS=3), or in client-server mode, as the GUI connects:
  PV_PLUGIN_PATH=... pvpython tests/pvpython/mpi_interval.py --client-server

Before, each rank extracted the interval volume of its own piece: Wavelet 41x37x31, range
[100, 200], Tolerance 1, two ranks: 19,660 tetrahedra against 19,866 serially, not conforming
across the seam. For images of odd sizes (ParaView's Wavelet, an image smaller than the number of
ranks, and the shared volumes of up to 2 M points when ../shared is there) and several queries, the
script (rank 0) fetches every rank's share and checks, independently of the filter:
- the tetrahedra of all ranks together are those of the serial volume (the CLI's `diamonds interval`
  on the same image), as sets of coordinates, each on exactly one rank; the processed array at every
  point is the serial one; another point array (the coordinates) is interpolated onto every rank's
  points;
- GlobalPointIds name points consistently: the same id has the same coordinates on every rank, and
  distinct positions have distinct ids;
- merged by coordinates, the union conforms across the seams: every face is in two tetrahedra but
  as many faces in one as serially (on the box or on a bounding surface);
- field data: TetrahedraPerRank (summing to NumberOfTetrahedra), the per-rank figures, ErrorBound and
  NumberOfPoints the whole volume's on every rank; changing the tolerance keeps the hierarchies.
"""

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
workdir = tempfile.mkdtemp(prefix="diamonds-mpi-interval-")


def tet_arrays(ug, scalars):
    """Points (N,3), tetrahedra (M,4) and the processed array (N) of an unstructured grid."""
    if ug.GetNumberOfCells() == 0:
        return np.zeros((0, 3)), np.zeros((0, 4), np.int64), np.zeros(0)
    points = vtk_to_numpy(ug.GetPoints().GetData()).astype(np.float64)
    cells = ug.GetCells()
    offsets = vtk_to_numpy(cells.GetOffsetsArray()).astype(np.int64)
    dc.check((np.diff(offsets) == 4).all() and (vtk_to_numpy(ug.GetCellTypesArray()) == 10).all(), "tetrahedra only")
    values = vtk_to_numpy(ug.GetPointData().GetArray(scalars)).astype(np.float64)
    return points, vtk_to_numpy(cells.GetConnectivityArray()).astype(np.int64).reshape(-1, 4), values


def serial_reference(image, scalars, value_range, tolerance, label):
    """The serial interval volume of `image`, written by the CLI."""
    vti = os.path.join(workdir, f"{label}.vti")
    vtu = os.path.join(workdir, f"{label}.vtu")
    w = vtkXMLImageDataWriter()
    w.SetFileName(vti)
    w.SetInputData(image)
    w.Write()
    subprocess.run([dc.diamonds_binary(), "interval", vti, vtu, "--array", scalars, "--range",
                    repr(float(value_range[0])), repr(float(value_range[1])), "--tolerance", str(tolerance)],
                   check=True, stdout=subprocess.DEVNULL)
    r = vtkXMLUnstructuredGridReader()
    r.SetFileName(vtu)
    r.Update()
    return r.GetOutput()


def face_counts(tets):
    """How many tetrahedra hold each face (faces as sorted point ids)."""
    faces = np.concatenate([tets[:, [1, 2, 3]], tets[:, [0, 2, 3]], tets[:, [0, 1, 3]], tets[:, [0, 1, 2]]])
    _, counts = np.unique(np.sort(faces, axis=1), axis=0, return_counts=True)
    return counts


def check_distributed(source, image, scalars, value_range, tolerance, label, filt=None):
    """Adaptive Interval Volume on `source` (a pipeline proxy producing `image`) on every rank."""
    if filt is None:
        filt = simple.AdaptiveIntervalVolume(Input=source, ThresholdRange=list(value_range), Tolerance=tolerance)
        filt.Scalars = ["POINTS", scalars]
    else:
        filt.ThresholdRange = list(value_range)
        filt.Tolerance = tolerance
    filt.UpdatePipeline()
    reference = serial_reference(image, scalars, value_range, tolerance, label)
    b = np.array(image.GetBounds())
    scale = 1e-9 * max(np.linalg.norm(b[1::2] - b[0::2]), 1.0)
    ref_points, ref_tets, ref_values = tet_arrays(reference, scalars)
    parts, per_rank, figures = [], [], set()
    by_gid = {}
    for r in range(ranks):
        piece = servermanager.Fetch(filt, r)
        points, tets, values = tet_arrays(piece, scalars)
        per_rank.append(len(tets))
        figures.add((dc.field_value(piece, "ErrorBound"), dc.field_value(piece, "NumberOfPoints")))
        if dc.check_rank_share(piece, points, r, ranks, "TetrahedraPerRank", len(ref_tets), by_gid, label) is not None:
            parts.append((points, tets, values))
    print(f"{label}: {len(ref_tets)} serial tetrahedra; per rank {per_rank}")
    dc.check(dc.same_values(f[0] for f in figures) and {f[1] for f in figures} == {len(ref_points)},
             f"{label}: ErrorBound and NumberOfPoints (the whole volume's) the same on every rank ({figures}; {len(ref_points)} points)")
    dc.check(sum(per_rank) == len(ref_tets), f"{label}: as many tetrahedra as serial ({sum(per_rank)} vs {len(ref_tets)})")
    if ranks > 1 and len(ref_tets) > 1000:
        dc.check(sum(1 for n in per_rank if n > 0) > 1, f"{label}: the work is shared ({per_rank})")
    if not parts:
        dc.check(len(ref_tets) == 0, f"{label}: no tetrahedra, as serial")
        return filt
    # The union as coordinate tetrahedra, against the serial volume.
    all_points = np.concatenate([p[0] for p in parts] + [ref_points])
    keys = np.rint(all_points / scale).astype(np.int64)
    _, ids = np.unique(keys, axis=0, return_inverse=True)
    ids = ids.reshape(-1)
    offsets = np.cumsum([0] + [len(p[0]) for p in parts])
    union = np.concatenate([ids[o:][t] for o, (_, t, _) in zip(offsets, parts)])
    ref = ids[offsets[-1]:][ref_tets]
    rows = lambda t: np.unique(np.sort(t, axis=1), axis=0)  # noqa: E731
    dc.check(np.array_equal(rows(union), rows(ref)), f"{label}: the ranks' tetrahedra are the serial ones (coordinates)")
    dc.check(len(rows(union)) == len(union), f"{label}: no tetrahedron on two ranks")
    value_at = np.full(ids.max() + 1, np.nan)
    value_at[ids[offsets[-1]:]] = ref_values
    mine = np.concatenate([ids[o:o + len(v)] for o, (_, _, v) in zip(offsets, parts)])
    got = np.concatenate([v for _, _, v in parts])
    dc.check(np.allclose(got, value_at[mine], rtol=1e-6, atol=1e-9), f"{label}: '{scalars}' at every point as serial")
    positions = {}
    for g, p in by_gid.items():
        positions.setdefault(tuple(np.rint(np.array(p) / scale).astype(np.int64)), set()).add(g)
    dc.check(all(len(s) == 1 for s in positions.values()), f"{label}: one global id per position")
    counts, ref_counts = face_counts(union), face_counts(ref)
    dc.check(counts.max() <= 2 and (counts == 1).sum() == (ref_counts == 1).sum(),
             f"{label}: merged by coordinates, conforming across the seams ({(counts == 1).sum()} faces in one tetrahedron, serial {(ref_counts == 1).sum()})")
    return filt


# A generated image of odd sizes: ParaView's Wavelet over 41 x 37 x 31 points.
wavelet, image = dc.wavelet(simple, [0, 40, 0, 36, 0, 30])
filt = check_distributed(wavelet, image, "RTData", [100.0, 200.0], 1.0, "wavelet [100, 200] tol 1")
builds = dc.hierarchy_builds(filt)
check_distributed(wavelet, image, "RTData", [100.0, 200.0], 0.4, "wavelet [100, 200] tol 0.4", filt=filt)
dc.check(dc.hierarchy_builds(filt) == builds, "changing the tolerance keeps every rank's hierarchy")
check_distributed(wavelet, image, "RTData", [150.0, 170.0], 0.0, "wavelet [150, 170] tol 0", filt=filt)
simple.Delete(filt)

# Every other point array is interpolated onto every rank's points, whichever rank holds their
# sources: the ranks gather only the processed array and fetch the others at their points' sources.
# Interpolated along the mesh edges, the point coordinates are the points themselves.
with_coords = simple.Calculator(Input=wavelet, ResultArrayName="coordinates", Function="coords")
filt = simple.AdaptiveIntervalVolume(Input=with_coords, ThresholdRange=[100.0, 200.0], Tolerance=1.0)
filt.Scalars = ["POINTS", "RTData"]
filt.UpdatePipeline()
points_seen, off = 0, 0.0
for r in range(ranks):
    piece = servermanager.Fetch(filt, r)
    if piece.GetNumberOfPoints() == 0:
        continue
    points_seen += piece.GetNumberOfPoints()
    coordinates = piece.GetPointData().GetArray("coordinates")
    xyz = vtk_to_numpy(piece.GetPoints().GetData()).astype(np.float64)
    off = max(off, np.inf if coordinates is None else float(np.abs(vtk_to_numpy(coordinates) - xyz).max()))
dc.check(points_seen > 0 and off <= 1e-9 * np.linalg.norm([40.0, 36.0, 30.0]),
         f"wavelet with coordinates: every rank's points carry the interpolated array (max difference {off:.3g})")
simple.Delete(filt)
simple.Delete(with_coords)

# An image smaller than the number of ranks: some ranks have empty pieces.
tiny, tiny_image = dc.wavelet(simple, [0, 2, 0, 1, 0, 1])
lo, hi = tiny_image.GetPointData().GetScalars().GetRange()
simple.Delete(check_distributed(tiny, tiny_image, "RTData", [lo, 0.5 * (lo + hi)], 0.0, "tiny"))

# The shared volumes of up to 2 M points, read in pieces: an integer range in the middle of the
# data's (levels equal to samples) at 2 % of the diagonal.
for entry, path, ct in dc.shared_images():
    if ct.GetNumberOfPoints() > 2_000_000:
        continue
    name = ct.GetPointData().GetScalars().GetName()
    lo, hi = ct.GetPointData().GetScalars().GetRange()
    b = np.array(ct.GetBounds())
    diagonal = float(np.linalg.norm(b[1::2] - b[0::2]))
    a, c = lo + 0.3 * (hi - lo), lo + 0.6 * (hi - lo)
    if hi - lo > 20:
        a, c = float(np.round(a)), float(np.round(c))
    reader = simple.XMLImageDataReader(FileName=[path])
    simple.Delete(check_distributed(reader, ct, name, [a, c], 0.02 * diagonal, entry.split("_")[0]))
    simple.Delete(reader)

RANKS.finish("mpi_interval")
