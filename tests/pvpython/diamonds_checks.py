"""Shared helpers of the pvpython tests of the Diamonds plugin.

The checks here are independent of the filter: they recompute everything from the input image and
the output mesh with numpy (VTK is used only to hand over the arrays).

- only VTK_TETRA cells, positively oriented, none degenerate;
- output bounds equal to the input bounds; every output point is an input sample;
- every input point array passed through unchanged (name, type, components, values);
- conformity: every triangular face is shared by exactly two tetrahedra, unless its three vertices
  lie on the same face of the image box (then by exactly one); no face in three or more;
- the sum of the tetrahedron volumes equals the box volume (rel 1e-9);
- the tolerance: every input sample lies in at least one tetrahedron, and in every tetrahedron that
  contains it, the linear interpolation of the vertex values differs from the sample by at most the
  tolerance (+1e-9 relative slack).

Run the tests with the plugin on PV_PLUGIN_PATH, e.g.
  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds pvpython tests/pvpython/test_mesh.py
"""

import functools
import os
import shutil
import subprocess
import sys
import time

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.util.misc import calldata_type
from vtkmodules.vtkCommonCore import VTK_STRING, vtkCommand

VTK_TETRA = 10

FAILURES = []
CHECKS = [0]


def check(ok, what):
    """Records and prints one check."""
    CHECKS[0] += 1
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        FAILURES.append(what)
    return bool(ok)


def finish(name, mpi=False):
    """Prints the summary line and exits non-zero on any failure.

    Under MPI (pvbatch on several ranks) a sys.exit would skip MPI_Finalize and get the other ranks
    killed; there a failure raises instead (pvbatch then exits non-zero) and success returns.
    """
    print(f"{name}: {CHECKS[0] - len(FAILURES)} passed, {len(FAILURES)} failed", flush=True)
    for f in FAILURES:
        print("  failed: " + f)
    if mpi:
        if FAILURES:
            raise RuntimeError(f"{name}: {len(FAILURES)} check(s) failed")
        return
    sys.exit(1 if FAILURES else 0)


def require_plugin():
    """The plugin must have been auto-loaded from PV_PLUGIN_PATH; returns paraview.simple."""
    from paraview import simple

    path = os.environ.get("PV_PLUGIN_PATH", "")
    print(f"PV_PLUGIN_PATH={path}")
    if not hasattr(simple, "AdaptiveTetrahedra"):
        print(
            "FAIL the Diamonds plugin was not auto-loaded: set PV_PLUGIN_PATH to the folder holding "
            "Diamonds.so, e.g. build/lib/paraview-5.11/plugins/Diamonds"
        )
        sys.exit(1)
    check(True, "plugin auto-loaded from PV_PLUGIN_PATH; AdaptiveTetrahedra exists")
    return simple


class ErrorCapture:
    """Collects the error and warning messages of one filter (its VTK object, builtin session)
    while active; an observed message is not printed by VTK."""

    def __init__(self, proxy):
        self.obj = proxy.GetClientSideObject()
        self.messages = []
        self._tags = []

    def __enter__(self):
        self.messages.clear()
        for event in (vtkCommand.ErrorEvent, vtkCommand.WarningEvent):
            self._tags.append(self.obj.AddObserver(event, self._on_message))
        return self

    @calldata_type(VTK_STRING)
    def _on_message(self, _obj, _event, message):
        self.messages.append(str(message))

    def __exit__(self, *exc):
        for tag in self._tags:
            self.obj.RemoveObserver(tag)
        self._tags.clear()
        return False

    def text(self):
        return "\n".join(self.messages)


def start_pvserver(ranks):
    """Starts `mpiexec -n ranks pvserver` on a free local port (its environment without this
    process's own MPI variables, so it is not part of this process's singleton MPI job) and waits
    until it accepts connections; returns the process and its port. Connect with
    `simple.Connect("localhost", port)`; the server exits when its client disconnects."""
    import socket

    with socket.socket() as s:
        s.bind(("localhost", 0))
        port = s.getsockname()[1]
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_", "OPAL_"))}
    server = subprocess.Popen(["mpiexec", "--allow-run-as-root", "--oversubscribe", "-n", str(ranks), "pvserver",
                               f"--server-port={port}"], stdout=subprocess.PIPE, text=True, env=env,
                              start_new_session=True)  # its own process group, so stop_pvserver can end all ranks
    for line in server.stdout:  # the server says when it listens
        if "Accepting connection" in line:
            break
    return server, port


def stop_pvserver(simple, server):
    """Disconnects from the server of start_pvserver and waits for it to exit. A multi-rank pvserver
    can hang for a minute in MPI's finalisation after its client left, and a rank still holding its X
    display makes the next test's server fail to open one, so after 10 s its whole process group
    (mpiexec and every rank) is terminated, then killed."""
    import signal

    simple.Disconnect()
    for sig in (None, signal.SIGTERM, signal.SIGKILL):
        if sig is not None:
            try:
                os.killpg(server.pid, sig)
            except ProcessLookupError:
                pass
        try:
            server.wait(timeout=10)
            break
        except subprocess.TimeoutExpired:
            continue
    try:  # ranks that outlived mpiexec
        os.killpg(server.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass


class Ranks:
    """The MPI ranks a distributed test runs on: pvbatch's own (`mpiexec -n N pvbatch script.py`) or,
    with `--client-server` on the command line, those of a 2-rank pvserver this pvpython client starts
    and Connects to (as the GUI connects). Checks the count against DIAMONDS_EXPECTED_RANKS (default 2);
    `finish` stops the server and prints the summary."""

    def __init__(self, simple):
        from paraview import servermanager

        self.simple = simple
        self.client_server = "--client-server" in sys.argv
        self.server = None
        if self.client_server:
            self.server, port = start_pvserver(2)
            check(simple.Connect("localhost", port, timeout=60) is not None, f"connected to pvserver on port {port}")
            self.count = servermanager.ActiveConnection.GetNumberOfDataPartitions()
        else:
            self.count = servermanager.vtkProcessModule.GetProcessModule().GetNumberOfLocalPartitions()
        expected = int(os.environ.get("DIAMONDS_EXPECTED_RANKS", "2"))
        check(self.count == expected, f"running on {self.count} MPI ranks (expected {expected})"
              + (" of a pvserver this client connected to" if self.client_server else ""))

    def finish(self, name):
        if self.client_server:
            stop_pvserver(self.simple, self.server)
            finish(f"{name} (client of a {self.count}-rank pvserver)")
        finish(f"{name} ({self.count} ranks)", mpi=True)


def fetch(proxy):
    from paraview import servermanager

    proxy.UpdatePipeline()
    return servermanager.Fetch(proxy)


def hierarchy_builds(proxy):
    """The filter's NumberOfHierarchyBuilds information property."""
    proxy.UpdatePropertyInformation()
    return int(proxy.GetProperty("NumberOfHierarchyBuilds").GetElement(0))


def field_value(data, name):
    a = data.GetFieldData().GetArray(name)
    return None if a is None else a.GetTuple1(0)


def same_values(values):
    """Whether `values` (one figure per rank, as Fetch returns them) are one value. Equal to 11
    significant digits: Fetch of rank 0's output when it is empty returned 0.014526367188 for an
    ErrorBound of 0.0145263671875, which every rank's pipeline holds exactly (found with random
    extents on 3 ranks)."""
    values = list(values)
    if any(v is None for v in values):
        return all(v is None for v in values)
    return max(values) - min(values) <= 1e-10 * max(abs(v) for v in values)


def point_arrays(data):
    """The numeric point arrays of `data` by name (string arrays are checked where they are made)."""
    pd = data.GetPointData()
    return {pd.GetArrayName(i): pd.GetArray(i) for i in range(pd.GetNumberOfArrays()) if pd.GetArray(i)}


def mesh_arrays(ug):
    """Points (N,3), tetrahedra (M,4) and cell types of an unstructured grid."""
    points = vtk_to_numpy(ug.GetPoints().GetData()).astype(np.float64) if ug.GetPoints() else np.zeros((0, 3))
    cells = ug.GetCells()
    conn = vtk_to_numpy(cells.GetConnectivityArray()).astype(np.int64)
    offsets = vtk_to_numpy(cells.GetOffsetsArray()).astype(np.int64)
    types = vtk_to_numpy(ug.GetCellTypesArray()) if ug.GetNumberOfCells() else np.zeros(0, np.uint8)
    sizes = np.diff(offsets)
    if len(sizes) and not (sizes == 4).all():
        return points, None, types
    return points, conn.reshape(-1, 4), types


def _face_keys(faces, n_points):
    faces = np.sort(faces, axis=1)
    if n_points < (1 << 21):
        return (faces[:, 0] << 42) | (faces[:, 1] << 21) | faces[:, 2], faces
    return faces, faces


def check_mesh(image, ug, scalars, tolerance, label, tolerance_region=None):
    """All the independent checks of one output mesh; returns the number of tetrahedra.

    `tolerance_region`: if given (world box), the tolerance is checked only for samples inside it.
    """
    t0 = time.time()
    dims = np.array(image.GetDimensions())
    origin = np.array(image.GetOrigin())
    spacing = np.array(image.GetSpacing())
    extent = np.array(image.GetExtent())
    n_in = int(np.prod(dims))
    points, tets, types = mesh_arrays(ug)
    n = 0 if tets is None else len(tets)
    check(ug.GetNumberOfCells() > 0, f"{label}: {ug.GetNumberOfCells()} tetrahedra, {len(points)} points")
    if ug.GetNumberOfCells() == 0:
        return 0
    check(tets is not None and (types == VTK_TETRA).all(), f"{label}: only VTK_TETRA cells")
    if tets is None:
        return 0
    check(
        np.allclose(np.array(ug.GetBounds()), np.array(image.GetBounds()), rtol=0, atol=1e-12 * max(1.0, np.abs(image.GetBounds()).max())),
        f"{label}: output bounds {ug.GetBounds()} == input bounds {image.GetBounds()}",
    )

    # Every output point is an input sample: its lattice index.
    fijk = (points - origin) / spacing - extent[0::2]
    ijk = np.rint(fijk).astype(np.int64)
    on_lattice = np.abs(fijk - ijk).max() < 1e-6 and (ijk >= 0).all() and (ijk < dims).all()
    check(on_lattice, f"{label}: every output point is an input sample")
    if not on_lattice:
        return n
    lin = ijk[:, 0] + dims[0] * (ijk[:, 1] + dims[1] * ijk[:, 2])
    check(len(np.unique(lin)) == len(lin), f"{label}: no duplicate points")

    # Pass-through of every input point array.
    out_arrays = point_arrays(ug)
    for name, arr in point_arrays(image).items():
        out = out_arrays.get(name)
        same = (
            out is not None
            and out.GetDataType() == arr.GetDataType()
            and out.GetNumberOfComponents() == arr.GetNumberOfComponents()
        )
        if same:
            a_in = vtk_to_numpy(arr).reshape(n_in, -1)[lin]
            a_out = vtk_to_numpy(out).reshape(len(points), -1)
            same = np.array_equal(a_in, a_out, equal_nan=a_in.dtype.kind == "f")
        check(same, f"{label}: point array '{name}' passed through unchanged")

    # Orientation and volume, in lattice units (exact integers).
    V = ijk[tets]  # M,4,3
    E = (V[:, 1:, :] - V[:, :1, :]).astype(np.float64)  # M,3 edges,3
    det = np.linalg.det(E)
    check((det > 0.5).all(), f"{label}: every tetrahedron positively oriented, none degenerate")
    box = float(np.prod(dims - 1))
    vol = np.abs(det).sum() / 6.0
    check(abs(vol - box) <= 1e-9 * box, f"{label}: tetrahedra volume {vol:.9g} == box volume {box:.9g}")

    # Conformity.
    faces = np.concatenate([tets[:, [0, 1, 2]], tets[:, [0, 1, 3]], tets[:, [0, 2, 3]], tets[:, [1, 2, 3]]])
    keys, sorted_faces = _face_keys(faces, len(points))
    if keys.ndim == 1:
        uniq, first, counts = np.unique(keys, return_index=True, return_counts=True)
    else:
        uniq, first, counts = np.unique(keys, axis=0, return_index=True, return_counts=True)
    check(counts.max() <= 2, f"{label}: no face shared by 3+ tetrahedra (max {counts.max()})")
    single = sorted_faces[first[counts == 1]]  # F,3 point indices
    fc = ijk[single]  # F,3 vertices,3 coords
    on_box = np.zeros(len(fc), bool)
    for axis in range(3):
        c = fc[:, :, axis]
        on_box |= (c == 0).all(1) | (c == dims[axis] - 1).all(1)
    check(on_box.all(), f"{label}: conforming ({(~on_box).sum()} unmatched interior faces of {len(uniq)})")

    # Tolerance at every input sample.
    samples = vtk_to_numpy(image.GetPointData().GetArray(scalars)).astype(np.float64).ravel()
    worst, covered, checked = _max_interpolation_error(ijk, tets, lin, samples, dims, tolerance_region, image)
    check(covered, f"{label}: every input sample lies in a tetrahedron")
    slack = 1e-9 * max(1.0, np.abs(samples).max())
    check(
        worst <= tolerance + slack,
        f"{label}: max |interpolated - sample| = {worst:.6g} <= tolerance {tolerance:g} ({checked} samples)",
    )
    print(f"   ({label}: checked in {time.time() - t0:.1f} s)")
    return n


def _max_interpolation_error(ijk, tets, lin, samples, dims, region, image):
    """Largest |linear interpolation - sample| over every (sample, containing tetrahedron) pair."""
    V = ijk[tets]
    vals = samples[lin][tets]  # M,4
    lo = V.min(1)
    shape = V.max(1) - lo
    T = (V[:, 1:, :] - V[:, :1, :]).transpose(0, 2, 1).astype(np.float64)  # columns = edges
    Tinv = np.linalg.inv(T)
    covered = np.zeros(int(np.prod(dims)), bool)
    in_region = np.ones(int(np.prod(dims)), bool)
    if region is not None:
        p = np.arange(int(np.prod(dims)))
        g = np.stack([p % dims[0], (p // dims[0]) % dims[1], p // (dims[0] * dims[1])], -1)
        x = np.array(image.GetOrigin()) + (g + np.array(image.GetExtent())[0::2]) * np.array(image.GetSpacing())
        in_region = np.all((x >= np.array(region[0::2])) & (x <= np.array(region[1::2])), axis=1)
    worst = 0.0
    eps = 1e-9
    keys = shape[:, 0] * 1_000_000 + shape[:, 1] * 1_000 + shape[:, 2]
    for key in np.unique(keys):
        idx = np.nonzero(keys == key)[0]
        s = shape[idx[0]]
        off = np.stack(np.meshgrid(*[np.arange(k + 1) for k in s], indexing="ij"), -1).reshape(-1, 3)
        step = max(1, 2_000_000 // len(off))
        for c0 in range(0, len(idx), step):
            c = idx[c0 : c0 + step]
            P = lo[c][:, None, :] + off[None, :, :]  # c,K,3
            d = (P - V[c][:, None, 0, :]).astype(np.float64)
            lam = np.einsum("cij,ckj->cki", Tinv[c], d)
            l0 = 1.0 - lam.sum(-1)
            inside = (lam >= -eps).all(-1) & (l0 >= -eps)
            interp = l0 * vals[c, None, 0] + (lam * vals[c, None, 1:]).sum(-1)
            plin = P[..., 0] + dims[0] * (P[..., 1] + dims[1] * P[..., 2])
            covered[plin[inside]] = True
            sel = inside & in_region[plin]
            if sel.any():
                worst = max(worst, float(np.abs(interp - samples[plin])[sel].max()))
    return worst, bool(covered.all()), int(in_region.sum())


def material_sample_errors(image, ug, labels, own, values, chunk=50000):
    """Whether every sample of `image` lies in a tetrahedron of `ug`, and the largest deviation of a
    sample's value from the linear interpolation of its own material's vertex values (`own[m]`) over
    every tetrahedron holding it (samples found by bounding box, barycentric coordinates): the field
    bound of Material Interface Approximation at every sample, checked without the core."""
    points, tets, _ = mesh_arrays(ug)
    dims, origin, spacing = (np.array(v, dtype=np.float64) for v in (image.GetDimensions(), image.GetOrigin(), image.GetSpacing()))
    u = (points - origin) / spacing  # sample index coordinates: barycentric coordinates are affine-invariant
    covered = np.zeros(int(np.prod(dims)), bool)
    worst = 0.0
    for start in range(0, len(tets), chunk):
        tt = tets[start : start + chunk]
        V = u[tt]
        lo = np.clip(np.ceil(V.min(axis=1) - 1e-6), 0, dims - 1).astype(np.int64)
        ext = np.maximum(np.clip(np.floor(V.max(axis=1) + 1e-6), 0, dims - 1).astype(np.int64) - lo + 1, 0)
        count = np.prod(ext, axis=1)
        which = np.repeat(np.arange(len(tt)), count)
        local = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
        e = ext[which]
        ijk = lo[which] + np.stack([local % e[:, 0], (local // e[:, 0]) % e[:, 1], local // (e[:, 0] * e[:, 1])], axis=1)
        inv = np.linalg.inv(np.transpose(V[:, 1:] - V[:, :1], (0, 2, 1)))
        l123 = np.einsum("nij,nj->ni", inv[which], ijk - V[which, 0])
        lam = np.concatenate([1.0 - l123.sum(axis=1, keepdims=True), l123], axis=1)
        inside = (lam >= -1e-7).all(axis=1)
        which, ijk, lam = which[inside], ijk[inside], lam[inside]
        s = ijk[:, 0] + int(dims[0]) * (ijk[:, 1] + int(dims[1]) * ijk[:, 2])
        covered[s] = True
        vertex_values = own[labels[s][:, None], tt[which]]
        if len(s):
            worst = max(worst, float(np.abs((lam * vertex_values).sum(axis=1) - values[s]).max()))
    return bool(covered.all()), worst


def programmable_image(simple, dims, script_body, origin=(0.0, 0.0, 0.0), spacing=(1.0, 1.0, 1.0)):
    """A ProgrammableSource producing a vtkImageData of `dims` points; `script_body` fills `out`
    (a vtkImageData already sized) using numpy; `x, y, z` are the point coordinates (x fastest)."""
    src = simple.ProgrammableSource()
    src.OutputDataSetType = "vtkImageData"
    ext = (0, dims[0] - 1, 0, dims[1] - 1, 0, dims[2] - 1)
    src.ScriptRequestInformation = (
        "executive = self.GetExecutive()\n"
        "outInfo = executive.GetOutputInformation(0)\n"
        f"outInfo.Set(executive.WHOLE_EXTENT(), {', '.join(map(str, ext))})\n"
        f"outInfo.Set(vtk.vtkDataObject.ORIGIN(), {origin[0]!r}, {origin[1]!r}, {origin[2]!r})\n"
        f"outInfo.Set(vtk.vtkDataObject.SPACING(), {spacing[0]!r}, {spacing[1]!r}, {spacing[2]!r})\n"
    )
    src.Script = (
        "import numpy as np\n"
        "from vtkmodules.util.numpy_support import numpy_to_vtk\n"
        "out = self.GetOutput()\n"
        f"out.SetExtent({', '.join(map(str, ext))})\n"
        f"out.SetOrigin({origin[0]!r}, {origin[1]!r}, {origin[2]!r})\n"
        f"out.SetSpacing({spacing[0]!r}, {spacing[1]!r}, {spacing[2]!r})\n"
        f"i, j, k = np.meshgrid(np.arange({dims[0]}), np.arange({dims[1]}), np.arange({dims[2]}), indexing='ij')\n"
        "x = (i.transpose(2, 1, 0).ravel() * out.GetSpacing()[0] + out.GetOrigin()[0])\n"
        "y = (j.transpose(2, 1, 0).ravel() * out.GetSpacing()[1] + out.GetOrigin()[1])\n"
        "z = (k.transpose(2, 1, 0).ravel() * out.GetSpacing()[2] + out.GetOrigin()[2])\n"
        "def add(name, values, scalars=False):\n"
        "    a = numpy_to_vtk(np.ascontiguousarray(values), deep=1)\n"
        "    a.SetName(name)\n"
        "    out.GetPointData().AddArray(a)\n"
        "    if scalars:\n"
        "        out.GetPointData().SetActiveScalars(name)\n" + script_body
    )
    return src


def check_rank_share(piece, points, rank, ranks, cells, total, by_gid, label):
    """Checks rank `rank`'s share `piece` (its `points`, N x 3) of a distributed output split over
    `ranks` ranks: field data `cells` (e.g. TetrahedraPerRank) holds its cell count at its rank,
    NumberOf<cells without PerRank> is `total`, and the per-rank figures are there; when it has cells,
    a GlobalPointId per point, each id at one position across the ranks seen so far (`by_gid`, id
    -> position, filled in). Returns the global ids (None without cells)."""
    import numpy as np
    from vtkmodules.util.numpy_support import vtk_to_numpy

    n = piece.GetNumberOfCells()
    per = piece.GetFieldData().GetArray(cells)
    check(per is not None and per.GetNumberOfTuples() == ranks and per.GetTuple1(rank) == n,
          f"{label}: rank {rank}: {cells}")
    name = "NumberOf" + cells[: -len("PerRank")]
    check(field_value(piece, name) == total, f"{label}: rank {rank}: {name} is the total")
    for figure in ("SecondsPerRank", "BytesSentPerRank", "ExchangeSecondsPerRank", "PeakMemoryPerRank"):
        a = piece.GetFieldData().GetArray(figure)
        check(a is not None and a.GetNumberOfTuples() == ranks, f"{label}: rank {rank}: {figure}")
    if n == 0:
        return None
    gids = vtk_to_numpy(piece.GetPointData().GetGlobalIds()).astype(np.int64)
    check(len(gids) == len(points), f"{label}: rank {rank}: a GlobalPointId per point")
    for g, p in zip(gids.tolist(), map(tuple, points.tolist())):
        if by_gid.setdefault(g, p) != p:
            check(False, f"{label}: global id {g} has two positions {by_gid[g]} and {p}")
            break
    return gids


def wavelet(simple, whole):
    """ParaView's Wavelet over the extent `whole` (a pipeline proxy) and the same image made here
    (vtkRTAnalyticSource), for comparing a distributed run with a serial reference."""
    from vtkmodules.vtkImagingCore import vtkRTAnalyticSource

    proxy = simple.Wavelet()
    proxy.WholeExtent = list(whole)
    rt = vtkRTAnalyticSource()
    rt.SetWholeExtent(*whole)
    rt.Update()
    return proxy, rt.GetOutput()


def shared_images():
    """Every shared volume (../shared/data/volumes/*.vti, in name order) as (file name, path, the
    image read here); nothing when ../shared is absent (see shared_path)."""
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader

    folder = shared_path("data/volumes")
    for entry in sorted(os.listdir(folder)) if folder else []:
        if entry.endswith(".vti"):
            path = os.path.join(folder, entry)
            reader = vtkXMLImageDataReader()
            reader.SetFileName(path)
            reader.Update()
            yield entry, path, reader.GetOutput()


def shared_path(relative):
    """`relative` under `../shared` beside the checkout, or None when absent: then the test is skipped
    with a message, or fails when the shared data is required (CI=true, as `.ci/run` sets, or
    DIAMONDS_REQUIRE_SHARED=1)."""
    root = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
    path = os.path.abspath(os.path.join(root, "..", "shared", relative))
    if os.path.exists(path):
        return path
    required = os.environ.get("CI") in ("true", "1") or os.environ.get("DIAMONDS_REQUIRE_SHARED") == "1"
    why = f"../shared/{relative} not found (looked for {path})"
    if required:
        check(False, f"{why}, and the shared data is required here (CI=true or DIAMONDS_REQUIRE_SHARED=1)")
    else:
        print(f"skipped: {why}")
    return None


@functools.lru_cache(maxsize=None)
def diamonds_binary():
    """The CLI (target/release/diamonds), brought up to date with cargo when cargo is there (a no-op
    when it is fresh; once per process)."""
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    binary = os.path.join(root, "target", "release", "diamonds")
    cargo = shutil.which("cargo") or os.path.expanduser("~/.cargo/bin/cargo")
    if os.path.exists(cargo):
        subprocess.run([cargo, "build", "--release", "--locked", "-p", "diamonds-cli"], cwd=root, check=True)
    return binary


def order_violations(points, tets, eye):
    """Checks that the cells of `tets` (M,4 point indices into `points`, N,3) are in back-to-front
    order for an eye at `eye`, face by face and independently of how the order was made: for every
    face shared by two tetrahedra, the one whose fourth vertex lies on the other side of the face's
    plane than the eye (the far one) must come first. Faces whose plane holds the eye (within
    rounding) constrain nothing. Returns (violations, faces checked, faces on the eye's plane);
    reverse a front-to-back order before checking it."""
    tets = np.asarray(tets, dtype=np.int64)
    m = len(tets)
    if m == 0:
        return 0, 0, 0
    skip = [(1, 2, 3, 0), (0, 2, 3, 1), (0, 1, 3, 2), (0, 1, 2, 3)]
    faces = np.concatenate([tets[:, list(s[:3])] for s in skip])
    apex = np.concatenate([tets[:, s[3]] for s in skip])
    owner = np.tile(np.arange(m, dtype=np.int64), 4)
    faces = np.sort(faces, axis=1)
    order = np.lexsort((faces[:, 2], faces[:, 1], faces[:, 0]))
    f = faces[order]
    same = (f[1:] == f[:-1]).all(axis=1)
    first = order[:-1][same]
    second = order[1:][same]
    a, b, c = (points[faces[first, k]] for k in range(3))
    u, v = b - a, c - a
    normal = np.cross(u, v)

    def side(x):
        w = x - a
        det = np.einsum("ij,ij->i", normal, w)
        bound = 1e-12 * np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1) * np.linalg.norm(w, axis=1)
        return np.where(np.abs(det) <= bound, 0, np.sign(det))

    eye_side = side(np.broadcast_to(np.asarray(eye, dtype=np.float64), a.shape))
    apex_first = side(points[apex[first]])
    t_first, t_second = owner[first], owner[second]
    # The far tetrahedron: the one whose apex is across the plane from the eye.
    first_is_far = apex_first == -eye_side
    far = np.where(first_is_far, t_first, t_second)
    near = np.where(first_is_far, t_second, t_first)
    constrained = eye_side != 0
    violations = int((far[constrained] > near[constrained]).sum())
    return violations, int(constrained.sum()), int((~constrained).sum())
