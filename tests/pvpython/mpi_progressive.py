"""Progressive Tetrahedral Mesh on a distributed unstructured grid: the ranks' meshes fit together.
Run with

  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds \
    mpiexec --allow-run-as-root -n 2 pvbatch tests/pvpython/mpi_progressive.py
  (and -n 3 with DIAMONDS_EXPECTED_RANKS=3), or in client-server mode, as the GUI connects:
  PV_PLUGIN_PATH=... pvpython tests/pvpython/mpi_progressive.py --client-server

Each rank reduces its own piece, keeping the points it shares with other pieces (the core's seam
points). Before, the blunt fin redistributed over 2 ranks and reduced by 90 % had 21 faces in three
tetrahedra and open faces inside the mesh along the seam; and a rank whose piece was empty (a
single-piece .vtu read on 2 ranks) failed with "the input has no cells". For a tetrahedralised
Wavelet (each rank's image piece, sharing a plane of points with its neighbour) and, with
../shared, the blunt fin read as one piece and redistributed, the script (rank 0) fetches every
rank's input and output pieces and checks, independently of the filter:
- merged by coordinates, no face of the ranks' meshes together is in more than two tetrahedra, and
  every face in one lies on the boundary of the input (its three points are boundary points of the
  whole input): no crack, no overlap along a seam;
- every point two ranks' inputs share is in both ranks' outputs; every tetrahedron is positive;
- every rank with cells reduced its piece, the ranks together by about TargetReduction; a rank with
  an empty piece outputs nothing, and the others' union is the mesh;
- changing TargetReduction replays each rank's sequence (NumberOfLevels kept, no new simplification).
A redistribution that gives a rank parts meeting only along an edge (the blunt fin on 3 ranks) is
reduced like any piece, the end of each such edge where the parts fall apart kept in the rank's
output (until session 30 such a rank reported "not manifold" and output nothing).
Under pvbatch, a piece whose build fails on rank 0 (a NaN in its scalars) is reported there and the
other ranks output their reduced pieces; a TargetReduction change reports the same error again on
rank 0 (captured there) while the others replay.
`scripts/test-integration.sh` also fails the run if any rank printed an error of the filter.
"""

import builtins
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import diamonds_checks as dc  # noqa: E402
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402

simple = dc.require_plugin()
RANKS = dc.Ranks(simple)
ranks = RANKS.count


def pieces(proxy):
    """(points (N,3), tetrahedra (M,4)) of every rank's piece of `proxy`'s output."""
    out = []
    for r in range(ranks):
        ug = servermanager.Fetch(proxy, r)
        if ug.GetNumberOfCells() == 0:
            out.append((np.zeros((0, 3)), np.zeros((0, 4), np.int64)))
            continue
        dc.check((vtk_to_numpy(ug.GetCellTypesArray()) == 10).all(), "tetrahedra only")
        points = vtk_to_numpy(ug.GetPoints().GetData()).astype(np.float64)
        tets = vtk_to_numpy(ug.GetCells().GetConnectivityArray()).astype(np.int64).reshape(-1, 4)
        out.append((points, tets))
    return out


def merged(parts):
    """The parts' points merged by coordinates: (unique points, tetrahedra in them, per part the
    merged ids of its points)."""
    if not parts:
        return np.zeros((0, 3)), np.zeros((0, 4), np.int64), []
    points = np.concatenate([p for p, _ in parts])
    unique, inverse = np.unique(points, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    ids, tets, start = [], [], 0
    for p, t in parts:
        ids.append(inverse[start:start + len(p)])
        tets.append(inverse[start:start + len(p)][t])
        start += len(p)
    return unique, np.concatenate(tets), ids


def faces(tets):
    """Every face (sorted point ids) and how many tetrahedra hold it."""
    f = np.sort(np.concatenate([tets[:, [1, 2, 3]], tets[:, [0, 2, 3]], tets[:, [0, 1, 3]], tets[:, [0, 1, 2]]]), axis=1)
    return np.unique(f, axis=0, return_counts=True)


def non_manifold_edges(tets):
    """The edges (point ids) of the boundary faces of `tets` that are in more than two of them (where
    two parts of a mesh meet only at an edge)."""
    s = np.sort(tets, axis=1)
    tets = tets[(s[:, 1:] != s[:, :-1]).all(axis=1)]  # without flat ones (a repeated corner)
    if len(tets) == 0:
        return np.zeros((0, 2), np.int64)
    f, counts = faces(tets)
    boundary = f[counts == 1]
    edges = np.sort(np.concatenate([boundary[:, [0, 1]], boundary[:, [0, 2]], boundary[:, [1, 2]]]), axis=1)
    unique, n = np.unique(edges, axis=0, return_counts=True)
    return unique[n > 2]


def check_case(source, scalars, reduction, label):
    inputs = pieces(source)
    filt = simple.ProgressiveTetrahedralMesh(Input=source, TargetReduction=reduction)
    filt.Scalars = ["POINTS", scalars]
    filt.UpdatePipeline()
    outputs = pieces(filt)
    for r, ((p, t), (q, _)) in enumerate(zip(inputs, outputs)):
        torn = non_manifold_edges(t)
        if len(torn):
            # The core cuts the piece at a point of each such edge whose tetrahedra fall apart there
            # and keeps that point (the other end may go when its tetrahedra stay face-connected).
            have = {tuple(x) for x in q}
            dc.check(all(tuple(p[a]) in have or tuple(p[b]) in have for a, b in torn),
                     f"{label}: rank {r}'s piece has {len(torn)} edges where parts meet; one end of each stays")
    cells_in = [len(t) for _, t in inputs]
    cells_out = [len(t) for _, t in outputs]
    print(f"{label}: tetrahedra per rank {cells_in} -> {cells_out}")
    # The input's boundary points and the points two ranks share, by coordinates.
    in_points, in_tets, in_ids = merged([p for p in inputs if len(p[1])])
    in_faces, in_counts = faces(in_tets)
    boundary = np.zeros(len(in_points), bool)
    boundary[in_faces[in_counts == 1].reshape(-1)] = True
    holders = np.zeros(len(in_points), np.int64)
    for ids in in_ids:
        holders[np.unique(ids)] += 1
    shared = holders > 1
    if sum(1 for n in cells_in if n) > 1:
        dc.check(shared.sum() > 0, f"{label}: the pieces share points (seams): {shared.sum()}")
    # The output, merged.
    with_cells = [(p, t) for p, t in outputs if len(t)]
    out_points, out_tets, _ = merged(with_cells)
    out_faces, out_counts = faces(out_tets)
    dc.check(out_counts.max() <= 2, f"{label}: no face in more than two tetrahedra ({(out_counts > 2).sum()} are)")
    # Where each output point is among the input's points.
    lookup = {tuple(p): k for k, p in enumerate(in_points)}
    to_input = np.array([lookup.get(tuple(p), -1) for p in out_points])
    dc.check((to_input >= 0).all(), f"{label}: every output point is an input point")
    open_faces = out_faces[out_counts == 1]
    inside = ~boundary[to_input[open_faces]].all(axis=1)
    dc.check(not inside.any(), f"{label}: every face of one tetrahedron is on the input's boundary "
             f"({inside.sum()} of {len(open_faces)} are not: cracks along a seam)")
    x = out_points[out_tets]
    volumes = np.einsum("ij,ij->i", x[:, 1] - x[:, 0], np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 0]))
    dc.check((volumes > 0).all(), f"{label}: every tetrahedron positive")
    # Every shared point stays in each rank's output that had it.
    kept = True
    for (p, t), ids in zip([o for o, (_, ti) in zip(outputs, inputs) if len(ti)], in_ids):
        have = {tuple(q) for q in p}
        kept &= all(tuple(in_points[v]) in have for v in np.unique(ids) if shared[v])
    dc.check(kept, f"{label}: the points two pieces share stay in both")
    for r in range(ranks):
        if cells_in[r]:
            dc.check(cells_out[r] < cells_in[r], f"{label}: rank {r} reduced its piece ({cells_in[r]} -> {cells_out[r]})")
        else:
            dc.check(cells_out[r] == 0, f"{label}: rank {r}, with an empty piece, outputs nothing")
    total_in, total_out = sum(cells_in), sum(cells_out)
    dc.check(total_out <= (1.0 - reduction) * total_in * 1.5 + 50,
             f"{label}: reduced by about {reduction:.0%} together ({total_in} -> {total_out})")
    # A level change replays: no new sequence, the same number of levels.
    filt.UpdatePropertyInformation()
    simplifications = int(filt.GetProperty("NumberOfSimplifications").GetElement(0))
    filt.TargetReduction = reduction / 2
    filt.UpdatePipeline()
    filt.UpdatePropertyInformation()
    dc.check(int(filt.GetProperty("NumberOfSimplifications").GetElement(0)) == simplifications,
             f"{label}: a smaller TargetReduction replays the kept sequence")
    finer = sum(len(t) for _, t in pieces(filt))
    dc.check(finer > total_out, f"{label}: TargetReduction {reduction / 2} gives more tetrahedra ({finer})")
    simple.Delete(filt)


wavelet, _ = dc.wavelet(simple, [0, 20, 0, 18, 0, 16])
tetrahedralized = simple.Tetrahedralize(Input=wavelet)
check_case(tetrahedralized, "RTData", 0.8, "Wavelet 21x19x17 tetrahedralised per rank")

fin = dc.shared_path(os.path.join("data", "tets", "bluntfin_tets.vtu"))
if fin:
    reader = simple.XMLUnstructuredGridReader(FileName=[fin])
    check_case(reader, "Density", 0.9, "blunt fin, one piece")
    check_case(simple.RedistributeDataSet(Input=reader), "Density", 0.9, "blunt fin, redistributed")

if not RANKS.client_server:
    # A piece whose build fails on rank 0 alone (a NaN in its scalars): rank 0 reports it (captured
    # here, the filter's object is local on rank 0), the others output their reduced pieces; the next
    # execution reports it again and the others replay.
    poisoned = simple.ProgrammableFilter(Input=tetrahedralized)
    poisoned.Script = """
from vtkmodules.vtkParallelCore import vtkMultiProcessController
out = self.GetOutput()
out.ShallowCopy(self.GetInput())
if vtkMultiProcessController.GetGlobalController().GetLocalProcessId() == 0:
    values = out.GetPointData().GetArray("RTData").NewInstance()
    values.DeepCopy(out.GetPointData().GetArray("RTData"))
    values.SetValue(0, float("nan"))
    out.GetPointData().AddArray(values)
"""
    filt = simple.ProgressiveTetrahedralMesh(Input=poisoned, TargetReduction=0.8)
    filt.Scalars = ["POINTS", "RTData"]
    sizes = []
    for reduction in (0.8, 0.4):
        filt.TargetReduction = reduction
        with dc.ErrorCapture(filt) as errors:
            filt.UpdatePipeline()
        dc.check("non-finite" in errors.text(),
                 f"TargetReduction {reduction}: rank 0 reports its NaN ({errors.text()[:160]!r})")
        outputs = pieces(filt)
        dc.check(len(outputs[0][1]) == 0, f"TargetReduction {reduction}: rank 0 outputs nothing")
        sizes.append([len(t) for _, t in outputs[1:]])
        # (builtins: running the programmable filter's script here replaced `all`, `min`, `max`…
        # with numpy_interface's, which reduce across ranks.)
        dc.check(builtins.all(n > 0 for n in sizes[-1]),
                 f"TargetReduction {reduction}: the other ranks output {sizes[-1]}")
    dc.check(builtins.all(a < b for a, b in zip(*sizes)), f"the other ranks replayed to the finer level: {sizes}")
    simple.Delete(filt)

RANKS.finish("mpi_progressive")
