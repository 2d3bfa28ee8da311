"""Adaptive Isosurface on a distributed image equals the serial surface, partitioned. Run with

  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds \
    mpiexec --allow-run-as-root -n 2 pvbatch tests/pvpython/mpi_isosurface.py
  (and -n 3 with DIAMONDS_EXPECTED_RANKS=3), or in client-server mode, as the GUI connects:
  PV_PLUGIN_PATH=... pvpython tests/pvpython/mpi_isosurface.py --client-server
  (starts `mpiexec -n 2 pvserver` on a free port and Connects to it).

For images of odd sizes (ParaView's Wavelet, an image smaller than the number of ranks, and every
shared volume when ../shared is there) and several queries, the script (rank 0) fetches every rank's
surface and checks, independently of the filter:
- the triangles of all ranks together are those of the serial surface (the CLI's `diamonds iso` on the
  same image), as a set of oriented coordinate triangles, each on exactly one rank; every rank with a
  piece takes its share when the surface is large;
- GlobalPointIds name points consistently: the same id has the same coordinates on every rank, and
  the ids of distinct positions differ;
- the union is watertight across the seams: merged by coordinates (and by global ids), every edge is
  in exactly two triangles, traversed in opposite directions, except edges on the image's boundary
  (where the serial surface is open too), exactly as many as the serial surface has;
- field data: TrianglesPerRank (one value per rank, summing to NumberOfTriangles), SecondsPerRank,
  BytesSentPerRank, ExchangeSecondsPerRank, PeakMemoryPerRank; ErrorBound the same on every rank;
  changing the tolerance re-extracts without rebuilding the hierarchy;
- the contoured array (ComputeScalars, on by default) and every other point array of the input are
  on each rank's points, the latter interpolated as serially; the carrier tetrahedra carry every
  point array of the input at their points.
"""

import os
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import diamonds_checks as dc  # noqa: E402
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy  # noqa: E402
from vtkmodules.vtkCommonDataModel import vtkImageData  # noqa: E402
from vtkmodules.vtkIOXML import vtkXMLImageDataWriter, vtkXMLPolyDataReader  # noqa: E402

simple = dc.require_plugin()
RANKS = dc.Ranks(simple)
ranks = RANKS.count
workdir = tempfile.mkdtemp(prefix="diamonds-mpi-iso-")


def surface_arrays(pd):
    """Points (N,3) and triangles (M,3) of a polydata."""
    if pd.GetNumberOfCells() == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    points = vtk_to_numpy(pd.GetPoints().GetData()).astype(np.float64)
    polys = pd.GetPolys()
    offsets = vtk_to_numpy(polys.GetOffsetsArray()).astype(np.int64)
    dc.check(pd.GetNumberOfCells() == polys.GetNumberOfCells() and (np.diff(offsets) == 3).all(), "triangles only")
    return points, vtk_to_numpy(polys.GetConnectivityArray()).astype(np.int64).reshape(-1, 3)


def position_ids(points, scale):
    """An id per distinct position (coordinates rounded to a billionth of the image diagonal: the
    CLI's image geometry and the pipeline's may differ in the last bit), and the positions' keys."""
    keys = np.rint(points / scale).astype(np.int64)
    uniq, inverse = np.unique(keys, axis=0, return_inverse=True)
    return inverse.reshape(-1), uniq


def oriented_rows(t):
    """Triangles `t` (M,3,3 integer coordinates) as rows of 9, rotated to start at their smallest
    corner (orientation kept), sorted."""
    def less(a, c):
        return (a[:, 0] < c[:, 0]) | ((a[:, 0] == c[:, 0]) & ((a[:, 1] < c[:, 1]) | ((a[:, 1] == c[:, 1]) & (a[:, 2] < c[:, 2]))))

    rows = np.arange(len(t))
    first = np.zeros(len(t), np.int64)
    for k in (1, 2):
        first[less(t[:, k], t[rows, first])] = k
    out = np.stack([t[rows, (first + k) % 3] for k in range(3)], axis=1).reshape(len(t), 9)
    return out[np.lexsort(out.T[::-1])] if len(out) else out


def edge_report(tris, bounds_mask):
    """(edges not in exactly two opposite triangles, off the image boundary; edges on the boundary in
    one triangle) of triangles `tris` (M,3 ids); `bounds_mask(ids)` tells, per id, which boundary
    faces the point lies on (bit mask)."""
    e = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    forward = e[:, 0] < e[:, 1]
    key = np.sort(e, axis=1)
    uniq, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    fwd = np.bincount(inverse.reshape(-1), weights=forward, minlength=len(uniq))
    on_face = (bounds_mask(uniq[:, 0]) & bounds_mask(uniq[:, 1])) != 0
    good = ((counts == 2) & (fwd == 1)) | ((counts == 1) & on_face)
    return int((~good).sum()), int(((counts == 1) & on_face).sum())


def serial_reference(image, scalars, isovalues, tolerance, label, roi=None):
    """The serial surface of `image`, written by the CLI."""
    vti = os.path.join(workdir, f"{label}.vti")
    vtp = os.path.join(workdir, f"{label}.vtp")
    w = vtkXMLImageDataWriter()
    w.SetFileName(vti)
    w.SetInputData(image)
    w.Write()
    cmd = [dc.diamonds_binary(), "iso", vti, vtp, "--array", scalars, "--tolerance", str(tolerance), "--scalars"]
    for v in isovalues:
        cmd += ["--isovalue", repr(float(v))]
    if roi is not None:
        cmd += ["--roi"] + [str(v) for v in roi]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    r = vtkXMLPolyDataReader()
    r.SetFileName(vtp)
    r.Update()
    return r.GetOutput()


def check_distributed(source, image, scalars, isovalues, tolerance, label, roi=None, filt=None):
    """Adaptive Isosurface on `source` (a pipeline proxy producing `image`) on every rank."""
    if filt is None:
        filt = simple.AdaptiveIsosurface(Input=source, Isosurfaces=list(isovalues), Tolerance=tolerance)
        filt.ContourBy = ["POINTS", scalars]
    else:
        filt.Isosurfaces = list(isovalues)
        filt.Tolerance = tolerance
    filt.UseRegionOfInterest = 1 if roi is not None else 0
    if roi is not None:
        filt.RegionOfInterest = roi
    filt.UpdatePipeline()
    reference = serial_reference(image, scalars, isovalues, tolerance, label, roi)
    b = np.array(image.GetBounds())
    scale = 1e-9 * max(np.linalg.norm(b[1::2] - b[0::2]), 1.0)
    ref_points, ref_tris = surface_arrays(reference)
    parts, part_data, per_rank, bounds = [], [], [], set()
    by_gid = {}
    for r in range(ranks):
        piece = servermanager.Fetch(filt, r)
        points, tris = surface_arrays(piece)
        per_rank.append(len(tris))
        bounds.add(dc.field_value(piece, "ErrorBound"))
        gids = dc.check_rank_share(piece, points, r, ranks, "TrianglesPerRank", len(ref_tris), by_gid, label)
        if gids is not None:
            parts.append((points, tris, gids))
            part_data.append(piece.GetPointData())
    print(f"{label}: {len(ref_tris)} serial triangles; per rank {per_rank}")
    dc.check(dc.same_values(bounds), f"{label}: ErrorBound the same on every rank ({bounds})")
    dc.check(sum(per_rank) == len(ref_tris), f"{label}: as many triangles as serial ({sum(per_rank)} vs {len(ref_tris)})")
    if ranks > 1 and len(ref_tris) > 1000:
        dc.check(sum(1 for n in per_rank if n > 0) > 1, f"{label}: the work is shared ({per_rank})")
    if not parts:
        dc.check(len(ref_tris) == 0, f"{label}: no triangles, as serial")
        return filt
    # The union as coordinate triangles, against the serial surface.
    all_points = np.concatenate([p[0] for p in parts] + [ref_points])
    ids, keys = position_ids(all_points, scale)
    offsets = np.cumsum([0] + [len(p[0]) for p in parts])
    union = np.concatenate([ids[o:][t] for o, (_, t, _) in zip(offsets, parts)])
    ref = ids[offsets[-1]:][ref_tris]
    dc.check(np.array_equal(oriented_rows(keys[union]), oriented_rows(keys[ref])),
             f"{label}: the ranks' triangles are the serial ones (oriented coordinates)")
    dc.check(len(np.unique(np.sort(union, axis=1), axis=0)) == len(union), f"{label}: no triangle on two ranks")
    gid_positions = {}
    for (_, t, g), o in zip(parts, offsets):
        for gi, pi in zip(g.tolist(), ids[o:o + len(g)].tolist()):
            gid_positions.setdefault(pi, set()).add(gi)
    dc.check(all(len(s) == 1 for s in gid_positions.values()), f"{label}: one global id per position")
    # Every other point array interpolated as serially, point for point.
    ref_pd = reference.GetPointData()
    ref_index = dict(zip(ids[offsets[-1]:].tolist(), range(len(ref_points))))
    names = sorted(ref_pd.GetArrayName(i) for i in range(ref_pd.GetNumberOfArrays()) if ref_pd.GetArrayName(i) != "Normals")
    for (points, _, _), pd, o in zip(parts, part_data, offsets):
        got_names = sorted(pd.GetArrayName(i) for i in range(pd.GetNumberOfArrays()) if pd.GetArrayName(i) not in ("Normals", "GlobalPointIds"))
        dc.check(got_names == names, f"{label}: the serial point arrays {names} ({got_names})")
        at = [ref_index[i] for i in ids[o:o + len(points)].tolist()]
        # The contoured array holds the isovalues, of the input's type here (the CLI's are doubles).
        for name in (set(names) & set(got_names)) - {scalars}:
            ref_values = vtk_to_numpy(ref_pd.GetArray(name)).astype(np.float64)[at]
            values = vtk_to_numpy(pd.GetArray(name)).astype(np.float64)
            off = float(np.abs(values - ref_values).max()) if len(values) else 0.0
            dc.check(off <= 1e-9 * max(1.0, float(np.abs(ref_values).max())), f"{label}: \"{name}\" as serially (max difference {off:.3g})")
    # Watertight across the seams, as the serial surface.
    eps = 1e-9 * max(np.linalg.norm(b[1::2] - b[0::2]), 1.0)

    def mask_of(positions):
        def mask(i):
            m = np.zeros(len(i), np.int64)
            for a in range(3):
                m |= (np.abs(positions[i, a] - b[2 * a]) <= eps) << (2 * a)
                m |= (np.abs(positions[i, a] - b[2 * a + 1]) <= eps) << (2 * a + 1)
            return m
        return mask

    world = keys * scale
    bad, open_edges = edge_report(union, mask_of(world))
    ref_bad, ref_open = edge_report(ref, mask_of(world))
    dc.check(bad == ref_bad and open_edges == ref_open,
             f"{label}: merged by coordinates, watertight across the seams ({bad} bad and {open_edges} boundary edges; serial {ref_bad}, {ref_open})")
    gid_union = np.concatenate([g[t] for _, t, g in parts])
    gid_world = np.zeros((max(by_gid) + 1, 3))
    for g, p in by_gid.items():
        gid_world[g] = p
    bad_g, open_g = edge_report(gid_union, mask_of(gid_world))
    dc.check(bad_g == ref_bad and open_g == ref_open, f"{label}: merged by global ids, the same ({bad_g}, {open_g})")
    return filt


# A generated image of odd sizes: ParaView's Wavelet over 65 x 41 x 53 points.
wavelet, image = dc.wavelet(simple, [0, 64, 0, 40, 0, 52])
filt = check_distributed(wavelet, image, "RTData", [157.0], 1.0, "wavelet 157 tol 1")
builds = dc.hierarchy_builds(filt)
check_distributed(wavelet, image, "RTData", [157.0], 0.3, "wavelet 157 tol 0.3", filt=filt)
dc.check(dc.hierarchy_builds(filt) == builds, "changing the tolerance keeps every rank's hierarchy")
check_distributed(wavelet, image, "RTData", [130.0, 200.0], 2.0, "wavelet 130+200 tol 2", filt=filt)
check_distributed(wavelet, image, "RTData", [157.0], 0.0, "wavelet 157 tol 0", filt=filt)
check_distributed(wavelet, image, "RTData", [157.0], 0.5, "wavelet ROI", roi=[10.0, 30.0, 5.0, 20.0, 0.0, 52.0], filt=filt)
simple.Delete(filt)

# Other point arrays (a 3-component and a derived one) interpolated onto every rank's share.
with_arrays = simple.Calculator(Input=wavelet, ResultArrayName="coordinates", Function="coords")
with_arrays = simple.Calculator(Input=with_arrays, ResultArrayName="twice", Function="2*RTData")
with_image = vtkImageData()
with_image.DeepCopy(image)
xyz = np.array([with_image.GetPoint(i) for i in range(with_image.GetNumberOfPoints())])
for name, values in (("coordinates", xyz), ("twice", 2.0 * vtk_to_numpy(image.GetPointData().GetArray("RTData")).astype(np.float64))):
    a = numpy_to_vtk(np.ascontiguousarray(values), deep=1)
    a.SetName(name)
    with_image.GetPointData().AddArray(a)
filt = check_distributed(with_arrays, with_image, "RTData", [157.0], 1.0, "wavelet with arrays")
# The carrier tetrahedra (at lattice points) pass every point array through, whichever rank holds
# the point: the ranks gather only the contoured array and fetch the others at their points.
filt.GenerateCarrierTetrahedra = 1
filt.UpdatePipeline()
dims = np.array(with_image.GetDimensions())
origin, spacing = np.array(with_image.GetOrigin()), np.array(with_image.GetSpacing())
carried, names, off = 0, set(), 0.0
for r in range(ranks):
    carrier = servermanager.Fetch(filt, r, None, 1)
    if carrier.GetNumberOfPoints() == 0:
        continue
    carried += carrier.GetNumberOfCells()
    pd = carrier.GetPointData()
    names.add(tuple(sorted(pd.GetArrayName(i) for i in range(pd.GetNumberOfArrays()))))
    ijk = np.rint((vtk_to_numpy(carrier.GetPoints().GetData()) - origin) / spacing).astype(np.int64)
    at = ijk[:, 0] + dims[0] * (ijk[:, 1] + dims[1] * ijk[:, 2])
    for name in ("RTData", "coordinates", "twice"):
        if pd.GetArray(name) is not None:
            want = vtk_to_numpy(with_image.GetPointData().GetArray(name)).astype(np.float64)[at]
            got = vtk_to_numpy(pd.GetArray(name)).astype(np.float64)
            off = max(off, float(np.abs(got - want).max()))
dc.check(carried > 0 and names == {("RTData", "coordinates", "twice")},
         f"wavelet with arrays: carriers on the ranks ({carried}) carry every point array ({names})")
dc.check(off == 0.0, f"wavelet with arrays: the carriers' point arrays are the input's at their points (max difference {off:.3g})")
simple.Delete(filt)
simple.Delete(with_arrays)

# An image smaller than the number of ranks: some ranks have empty pieces.
tiny, tiny_image = dc.wavelet(simple, [0, 2, 0, 1, 0, 1])
lo, hi = tiny_image.GetPointData().GetScalars().GetRange()
simple.Delete(check_distributed(tiny, tiny_image, "RTData", [0.5 * (lo + hi)], 0.0, "tiny"))

# Every shared volume (real CT/MRI/simulation data, several odd sizes and types) read in pieces, at
# the middle of its range and 1 % of its diagonal. Volumes over 2 M points (bonsai 256³) only where
# DIAMONDS_MPI_LARGE=1 (the 2-rank pvbatch run of test-integration.sh).
large = os.environ.get("DIAMONDS_MPI_LARGE") == "1"
for entry, path, ct in dc.shared_images():
    if ct.GetNumberOfPoints() > 2_000_000 and not large:
        print(f"{entry}: {ct.GetNumberOfPoints()} points, compared in the 2-rank pvbatch run only")
        continue
    name = ct.GetPointData().GetScalars().GetName()
    lo, hi = ct.GetPointData().GetScalars().GetRange()
    b = np.array(ct.GetBounds())
    diagonal = float(np.linalg.norm(b[1::2] - b[0::2]))
    reader = simple.XMLImageDataReader(FileName=[path])
    isovalue = float(np.floor(lo + 0.4 * (hi - lo))) + 0.5 if hi - lo > 4 else 0.5 * (lo + hi)
    simple.Delete(check_distributed(reader, ct, name, [isovalue], 0.01 * diagonal, entry.split("_")[0]))
    simple.Delete(reader)

RANKS.finish("mpi_isosurface")
