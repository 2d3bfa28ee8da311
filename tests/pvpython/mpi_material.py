"""Material Interface Approximation on a distributed input equals the serial result, partitioned. Run with

  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds \
    mpiexec --allow-run-as-root -n 2 pvbatch tests/pvpython/mpi_material.py
  (and -n 3 with DIAMONDS_EXPECTED_RANKS=3), or as a client of `mpiexec -n 2 pvserver`:
  PV_PLUGIN_PATH=... pvpython tests/pvpython/mpi_material.py --client-server

For the generated impact case on odd sizes (point data; the same as cell data, whose conversion to
point data must see the cells of every piece around a seam point; as a uniformly spaced rectilinear
grid), the CTH armor impact run of ../shared resampled to an image, and an image smaller than the
number of ranks (empty pieces), the script fetches every rank's share of the three outputs and checks,
independently of the filter, against the serial result of the CLI (`diamonds material` on the same
file):
- tetrahedra: the union of the ranks' tetrahedra is the serial set (sorted vertex coordinates with
  the cell arrays InterfaceError, FieldError, Materials, BisectionDepth), each on exactly one rank;
  every point's arrays (Material, the fields and per-material fields) are the serial point's; merged
  by coordinates and by GlobalPointIds, no hanging face: every face is in two tetrahedra or on the
  box; the tolerances hold on every tetrahedron (FieldError, InterfaceError) and the reported maxima
  are the serial ones;
- interfaces and slice: the union of the ranks' polygons is the serial set (oriented coordinate
  polygons with their materials, the slice's field values at every point), each on one rank;
  merged by coordinates and by global ids, the interfaces are crack-free across the seams: every
  polygon edge is shared by two or more polygons unless it lies on the box, as serially;
- GlobalPointIds: the same id has the same position on every rank, distinct positions distinct ids;
- field data: NumberOfTetrahedra (the total), TetrahedraPerRank, SecondsPerRank, BytesSentPerRank,
  ExchangeSecondsPerRank, PeakMemoryPerRank; NumberOfPolygons (the total); changing only the slice
  plane neither gathers nor refines again; a non-uniform rectilinear grid is refused on every rank.
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
from vtkmodules.vtkCommonDataModel import vtkRectilinearGrid  # noqa: E402
from vtkmodules.vtkFiltersCore import vtkAppendFilter, vtkPointDataToCellData  # noqa: E402
from vtkmodules.vtkIOXML import (  # noqa: E402
    vtkXMLImageDataReader,
    vtkXMLImageDataWriter,
    vtkXMLPolyDataReader,
    vtkXMLRectilinearGridReader,
    vtkXMLRectilinearGridWriter,
    vtkXMLUnstructuredGridReader,
)

simple = dc.require_plugin()
RANKS = dc.Ranks(simple)
ranks = RANKS.count
CLIENT_SERVER = RANKS.client_server
workdir = tempfile.mkdtemp(prefix="diamonds-mpi-material-")
IMPACT_FRACTIONS = ["Volume Fraction for Void", "Volume Fraction for Block", "Volume Fraction for Projectile"]
CELL_ARRAYS = ["InterfaceError", "FieldError", "Materials", "BisectionDepth"]


def read(reader_class, path):
    r = reader_class()
    r.SetFileName(path)
    r.Update()
    return r.GetOutput()


def polygons(pd):
    """Points (N,3) and the polygons of a polydata as lists of point ids."""
    if pd.GetNumberOfCells() == 0:
        return np.zeros((0, 3)), []
    points = vtk_to_numpy(pd.GetPoints().GetData()).astype(np.float64)
    offsets = vtk_to_numpy(pd.GetPolys().GetOffsetsArray()).astype(np.int64)
    conn = vtk_to_numpy(pd.GetPolys().GetConnectivityArray()).astype(np.int64)
    return points, [conn[a:b] for a, b in zip(offsets[:-1], offsets[1:])]


def array(data, name, cell=False):
    a = (data.GetCellData() if cell else data.GetPointData()).GetArray(name)
    return None if a is None else vtk_to_numpy(a).astype(np.float64)


class Keys:
    """Positions as integer keys (coordinates rounded to a billionth of the box diagonal: the CLI's
    grid geometry and the pipeline's may differ in the last bit)."""

    def __init__(self, bounds):
        self.bounds = np.array(bounds)
        self.scale = 1e-9 * max(np.linalg.norm(self.bounds[1::2] - self.bounds[0::2]), 1.0)

    def of(self, points):
        return [tuple(k) for k in np.rint(points / self.scale).astype(np.int64).tolist()]

    def on_face(self, key_list):
        """Bit mask of the box faces each key lies on."""
        p = np.array(key_list, dtype=np.float64).reshape(-1, 3) * self.scale
        eps = 1e3 * self.scale
        m = np.zeros(len(p), np.int64)
        for a in range(3):
            m |= (np.abs(p[:, a] - self.bounds[2 * a]) <= eps).astype(np.int64) << (2 * a)
            m |= (np.abs(p[:, a] - self.bounds[2 * a + 1]) <= eps).astype(np.int64) << (2 * a + 1)
        return m


def tet_rows(ug, keys):
    """Each tetrahedron as its sorted vertex keys followed by its cell arrays."""
    if ug.GetNumberOfCells() == 0:
        return []
    points, tets, _ = dc.mesh_arrays(ug)
    k = keys.of(points)
    cols = [array(ug, n, True) for n in CELL_ARRAYS]
    return [tuple(sorted(k[v] for v in t)) + tuple(c[i] for c in cols) for i, t in enumerate(tets.tolist())]


def point_rows(data, keys, names):
    """Each point's key with the values of the point arrays `names`."""
    if data.GetNumberOfPoints() == 0:
        return {}
    cols = [array(data, n) for n in names]
    return {k: tuple(x for c in cols for x in np.atleast_1d(c[i]).tolist()) for i, k in enumerate(keys.of(vtk_to_numpy(data.GetPoints().GetData()).astype(np.float64)))}


def polygon_rows(pd, keys, label_arrays, point_arrays=()):
    """Each polygon as its number of vertices, its labels, then its vertex keys (with the values of
    `point_arrays` there) rotated to start at the smallest (orientation kept)."""
    points, polys = polygons(pd)
    k = keys.of(points)
    labels = [array(pd, n, True) for n in label_arrays]
    values = [array(pd, n) for n in point_arrays]
    rows = []
    for i, p in enumerate(polys):
        ring = [(k[v],) + tuple(x for c in values for x in np.atleast_1d(c[v]).tolist()) if values else k[v]
                for v in p.tolist()]
        s = ring.index(min(ring))
        rows.append((len(ring),) + tuple(float(c[i]) for c in labels) + tuple(ring[s:] + ring[:s]))
    return rows


def bad_edges(polygon_lists, keys):
    """Edges (by key) of the polygons in fewer than two polygons and not on one box face."""
    count = {}
    for ring in polygon_lists:
        for a, b in zip(ring, ring[1:] + ring[:1]):
            e = (min(a, b), max(a, b))
            count[e] = count.get(e, 0) + 1
    single = [e for e, c in count.items() if c < 2]
    if not single:
        return 0
    ends = keys.on_face([e[0] for e in single]) & keys.on_face([e[1] for e in single])
    return int((ends == 0).sum())


def hanging_faces(tet_lists, keys):
    """Faces (by key or id) in one tetrahedron off the box, and faces in more than two."""
    count = {}
    for t in tet_lists:
        for f in ((t[0], t[1], t[2]), (t[0], t[1], t[3]), (t[0], t[2], t[3]), (t[1], t[2], t[3])):
            f = tuple(sorted(f))
            count[f] = count.get(f, 0) + 1
    over = sum(1 for c in count.values() if c > 2)
    single = [f for f, c in count.items() if c == 1]
    if not single or keys is None:
        return len(single) if keys is None else 0, over
    mask = keys.on_face([f[0] for f in single]) & keys.on_face([f[1] for f in single]) & keys.on_face([f[2] for f in single])
    return int((mask == 0).sum()), over


def check_case(source, path, label, fractions, fields, material_fields, interface_tolerance, field_tolerance, slice_plane, filt=None):
    """The filter on `source` (a proxy reading `path`) on every rank against `diamonds material` on `path`."""
    if filt is None:
        filt = simple.MaterialInterfaceApproximation(Input=source)
    filt.VolumeFractionArrays = fractions
    filt.FieldArrays = fields
    filt.MaterialFieldArrays = material_fields
    filt.InterfaceTolerance = interface_tolerance
    filt.FieldTolerance = field_tolerance
    filt.SliceOrigin = slice_plane[:3]
    filt.SliceNormal = slice_plane[3:]
    filt.UpdatePipeline()
    base = os.path.join(workdir, label.replace(" ", "_"))
    cmd = [dc.diamonds_binary(), "material", path, "-o", base, "--fractions", ",".join(fractions),
           "--interface-tolerance", repr(interface_tolerance), "--field-tolerance", repr(field_tolerance),
           "--slice=" + ",".join(repr(float(v)) for v in slice_plane)]
    if fields:
        cmd += ["--fields", ",".join(fields)]
    if material_fields:
        cmd += ["--material-fields", ",".join(material_fields)]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    ref = [read(vtkXMLUnstructuredGridReader, base + ".vtu"), read(vtkXMLPolyDataReader, base + "-interfaces.vtp"),
           read(vtkXMLPolyDataReader, base + "-slice.vtp")]
    keys = Keys(ref[0].GetBounds())
    names = [ref[0].GetPointData().GetArrayName(i) for i in range(ref[0].GetPointData().GetNumberOfArrays())]
    slice_names = [ref[2].GetPointData().GetArrayName(i) for i in range(ref[2].GetPointData().GetNumberOfArrays())]
    parts = [[servermanager.Fetch(filt, r, None, port) for port in range(3)] for r in range(ranks)]

    # Tetrahedra: the serial set, each on one rank, with the serial point values.
    per_rank = [p[0].GetNumberOfCells() for p in parts]
    want = sorted(tet_rows(ref[0], keys))
    union = sorted(row for p in parts for row in tet_rows(p[0], keys))
    print(f"{label}: {len(want)} serial tetrahedra; per rank {per_rank}; interface polygons per rank "
          f"{[p[1].GetNumberOfCells() for p in parts]}; slice polygons per rank {[p[2].GetNumberOfCells() for p in parts]}")
    dc.check(union == want, f"{label}: the ranks' tetrahedra are the serial ones, with their cell arrays ({len(union)} vs {len(want)})")
    dc.check(len(set(union)) == len(union), f"{label}: no tetrahedron on two ranks")
    if ranks > 1 and len(want) > 1000:
        dc.check(sum(1 for n in per_rank if n > 0) > 1, f"{label}: the work is shared ({per_rank})")
    ref_points = point_rows(ref[0], keys, names)
    same_points = all(point_rows(p[0], keys, names).items() <= ref_points.items() for p in parts)
    dc.check(same_points, f"{label}: every point's arrays ({', '.join(names)}) are the serial point's")
    # Global ids and hanging faces, merged by coordinates and by ids.
    by_gid, by_key, merged_keys, merged_ids = {}, {}, [], []
    for r, p in enumerate(parts):
        for port, data in enumerate(p):
            if data.GetNumberOfPoints() == 0:
                continue
            g = data.GetPointData().GetGlobalIds()
            dc.check(g is not None and g.GetNumberOfTuples() == data.GetNumberOfPoints(), f"{label}: rank {r} port {port}: GlobalPointIds")
            if g is None:
                continue
            for gid, k in zip(vtk_to_numpy(g).tolist(), keys.of(vtk_to_numpy(data.GetPoints().GetData()).astype(np.float64))):
                by_gid.setdefault((port, gid), set()).add(k)
                by_key.setdefault((port, k), set()).add(gid)
        if p[0].GetNumberOfCells():
            _, tets, _ = dc.mesh_arrays(p[0])
            k = keys.of(vtk_to_numpy(p[0].GetPoints().GetData()).astype(np.float64))
            g = vtk_to_numpy(p[0].GetPointData().GetGlobalIds()).tolist()
            merged_keys += [[k[v] for v in t] for t in tets.tolist()]
            merged_ids += [[g[v] for v in t] for t in tets.tolist()]
    dc.check(all(len(s) == 1 for s in by_gid.values()), f"{label}: one position per global id, on every port")
    # Serially distinct points can share a key (interface junctions computed through different
    # carriers 1e-10 of the diagonal apart): as many ids per key as the serial output has points there.
    serial_points = {}
    for port in (0, 1):
        for k in keys.of(vtk_to_numpy(ref[port].GetPoints().GetData()).astype(np.float64)) if ref[port].GetNumberOfPoints() else []:
            serial_points[(port, k)] = serial_points.get((port, k), 0) + 1
    dc.check(all(len(s) == serial_points.get(key, 0) for key, s in by_key.items() if key[0] < 2),
             f"{label}: one global id per position of the tetrahedra and of the interfaces (per serial point there)")
    hang_k, over_k = hanging_faces(merged_keys, keys)
    dc.check(hang_k == 0 and over_k == 0, f"{label}: merged by coordinates, no hanging face ({hang_k} off the box, {over_k} in 3+)")
    id_keys = {}
    for t_k, t_g in zip(merged_keys, merged_ids):
        for a, b in zip(t_k, t_g):
            id_keys[b] = a
    hang_g, over_g = hanging_faces([[id_keys[v] for v in t] for t in merged_ids], keys)
    dc.check(hang_g == 0 and over_g == 0, f"{label}: merged by global ids, no hanging face ({hang_g}, {over_g})")
    # Tolerances and field data.
    if union:
        fe = max(row[5] for row in union)
        ie = max(row[4] for row in union)
        dc.check(fe <= field_tolerance * (1 + 1e-6) and ie <= interface_tolerance * (1 + 1e-6),
                 f"{label}: FieldError {fe:.4g} <= {field_tolerance}, InterfaceError {ie:.4g} <= {interface_tolerance} on every tetrahedron")
    # The field bound at every input sample, probed independently in the union of the ranks' tetrahedra
    # (an image with point data): each sample's own material's values interpolated where it lies, against
    # the field (or, given per material, its own material's).
    image = read(vtkXMLImageDataReader, path) if path.endswith(".vti") else None
    if image is not None and union and all(image.GetPointData().GetArray(n) is not None for n in fractions + fields):
        append = vtkAppendFilter()
        for p in parts:
            append.AddInputData(p[0])
        append.Update()
        together = append.GetOutput()
        labels = np.argmax(np.stack([vtk_to_numpy(image.GetPointData().GetArray(n)) for n in fractions]), axis=0)
        for field in fields:
            own_names = [n for n in names if n.startswith(field + " (")]
            own = np.stack([vtk_to_numpy(together.GetPointData().GetArray(n)) for n in own_names])
            values = vtk_to_numpy(image.GetPointData().GetArray(field)).astype(np.float64)
            if material_fields:  # the field given per material (in the fractions' order): the sample's own
                per_material = np.stack([vtk_to_numpy(image.GetPointData().GetArray(n)) for n in material_fields])
                values = per_material[labels, np.arange(len(labels))].astype(np.float64)
            covered, worst = dc.material_sample_errors(image, together, labels, own, values)
            dc.check(covered and len(own_names) == len(fractions) and worst <= field_tolerance * (1 + 1e-5) + 1e-3,
                     f"{label}: every sample in a tetrahedron of some rank and {field} within {field_tolerance:g} of it "
                     f"(own material: {', '.join(own_names)}) at every one of {len(labels)} samples (worst {worst:.4g})")
    for r, p in enumerate(parts):
        fd = p[0].GetFieldData()
        per = fd.GetArray("TetrahedraPerRank")
        dc.check(per is not None and per.GetNumberOfTuples() == ranks and per.GetTuple1(r) == per_rank[r]
                 and dc.field_value(p[0], "NumberOfTetrahedra") == len(want),
                 f"{label}: rank {r}: TetrahedraPerRank and NumberOfTetrahedra (the total)")
        dc.check(all(fd.GetArray(n) is not None and fd.GetArray(n).GetNumberOfTuples() == ranks for n in
                     ("SecondsPerRank", "BytesSentPerRank", "ExchangeSecondsPerRank", "PeakMemoryPerRank")),
                 f"{label}: rank {r}: SecondsPerRank, BytesSentPerRank, ExchangeSecondsPerRank, PeakMemoryPerRank")
        if per_rank[r]:
            dc.check(all(dc.field_value(p[0], n) == dc.field_value(ref[0], n) for n in ("MaximumFieldError", "MaximumInterfaceError", "InterfaceTetrahedra")),
                     f"{label}: rank {r}: MaximumFieldError, MaximumInterfaceError, InterfaceTetrahedra are the serial ones")
        dc.check(dc.field_value(p[1], "NumberOfPolygons") == ref[1].GetNumberOfCells(), f"{label}: rank {r}: NumberOfPolygons (the total)")

    # Interfaces and slice: the serial polygons, each on one rank; crack-free across the seams.
    for port, title, labels, values in ((1, "interfaces", ["MaterialA", "MaterialB"], ()),
                                        (2, "slice", ["Material"], slice_names)):
        want = sorted(polygon_rows(ref[port], keys, labels, values))
        union = sorted(row for p in parts for row in polygon_rows(p[port], keys, labels, values))
        dc.check(union == want, f"{label}: the ranks' {title} polygons are the serial ones, oriented, with {labels + list(values)} ({len(union)} vs {len(want)})")
    rings = [list(row[3:]) for p in parts for row in polygon_rows(p[1], keys, ["MaterialA", "MaterialB"])]
    ref_bad = bad_edges([list(row[3:]) for row in polygon_rows(ref[1], keys, ["MaterialA", "MaterialB"])], keys)
    bad = bad_edges(rings, keys)
    id_rings = []
    for p in parts:
        if p[1].GetNumberOfCells():
            g = vtk_to_numpy(p[1].GetPointData().GetGlobalIds()).tolist()
            k = keys.of(vtk_to_numpy(p[1].GetPoints().GetData()).astype(np.float64))
            id_rings += [[(g[v], k[v]) for v in ring.tolist()] for ring in polygons(p[1])[1]]
    bad_ids = bad_edges([[k for _, k in ring] for ring in id_rings], keys) if all(
        len(by_gid[(1, g)]) == 1 for ring in id_rings for g, _ in ring) else -1
    dc.check(bad == 0 and ref_bad == 0 and bad_ids == 0,
             f"{label}: interfaces crack-free across the seams, merged by coordinates ({bad} open edges off the box) and by global ids ({bad_ids}); serial {ref_bad}")
    return filt


# ---- The impact case on odd sizes: point data, cell data, and as a uniformly spaced rectilinear grid.
impact = os.path.join(workdir, "impact.vti")
subprocess.run([dc.diamonds_binary(), "generate", impact, "--field", "impact", "--dims", "29", "31", "45"], check=True,
               stdout=subprocess.DEVNULL)
image = read(vtkXMLImageDataReader, impact)
reader = simple.XMLImageDataReader(FileName=[impact])
plane = [6.0, 6.0, -5.0, 0.0, 0.0, 1.0]
filt = check_case(reader, impact, "impact 29x31x45 points", IMPACT_FRACTIONS, ["Density"], [], 0.15, 3.0, plane)


def counters(f):
    """NumberOfModelBuilds and NumberOfRefinements (information properties, from the first rank)."""
    f.UpdatePropertyInformation()
    return tuple(int(f.GetProperty(n).GetElement(0)) for n in ("NumberOfModelBuilds", "NumberOfRefinements"))


before = counters(filt)
filt = check_case(reader, impact, "impact, slice moved", IMPACT_FRACTIONS, ["Density"], [], 0.15, 3.0,
                  [4.0, 6.0, -5.0, 1.0, 0.0, 0.0], filt=filt)
dc.check(counters(filt) == before, f"moving the slice plane neither gathers and builds nor refines again ({before})")
if not CLIENT_SERVER:
    check_case(reader, impact, "impact, per-material densities", IMPACT_FRACTIONS, ["Density"],
               ["Density for Void", "Density for Block", "Density for Projectile"], 0.3, 2.0, plane, filt=filt)
simple.Delete(filt)
simple.Delete(reader)

if not CLIENT_SERVER:
    # Cell data: converted to point data on the whole input (a seam point averages the cells of both pieces).
    p2c = vtkPointDataToCellData()
    p2c.SetInputData(image)
    p2c.Update()
    cells = os.path.join(workdir, "impact-cells.vti")
    w = vtkXMLImageDataWriter()
    w.SetFileName(cells)
    w.SetInputData(p2c.GetOutput())
    w.Write()
    reader = simple.XMLImageDataReader(FileName=[cells])
    simple.Delete(check_case(reader, cells, "impact as cell data", IMPACT_FRACTIONS, ["Density"], [], 0.15, 3.0, plane))
    simple.Delete(reader)

    # A uniformly spaced rectilinear grid: its coordinates are gathered too.
    grid = vtkRectilinearGrid()
    grid.SetDimensions(image.GetDimensions())
    for axis, setter in enumerate((grid.SetXCoordinates, grid.SetYCoordinates, grid.SetZCoordinates)):
        n = image.GetDimensions()[axis]
        setter(numpy_to_vtk(image.GetOrigin()[axis] + image.GetSpacing()[axis] * np.arange(n), deep=1))
    grid.GetPointData().ShallowCopy(image.GetPointData())
    rectilinear = os.path.join(workdir, "impact.vtr")
    w = vtkXMLRectilinearGridWriter()
    w.SetFileName(rectilinear)
    w.SetInputData(grid)
    w.Write()
    reader = simple.XMLRectilinearGridReader(FileName=[rectilinear])
    simple.Delete(check_case(reader, rectilinear, "impact as a rectilinear grid", IMPACT_FRACTIONS, ["Density"], [], 0.15, 3.0, plane))
    simple.Delete(reader)

    # An image smaller than the number of ranks: empty pieces take part and output nothing.
    tiny = os.path.join(workdir, "tiny.vti")
    subprocess.run([dc.diamonds_binary(), "generate", tiny, "--field", "impact", "--dims", "3", "2", "2"], check=True,
                   stdout=subprocess.DEVNULL)
    reader = simple.XMLImageDataReader(FileName=[tiny])
    simple.Delete(check_case(reader, tiny, "tiny 3x2x2", IMPACT_FRACTIONS, ["Density"], [], 0.5, 100.0, [6.0, 6.0, -5.0, 0.0, 0.0, 1.0]))
    simple.Delete(reader)

# ---- The CTH armor impact run of ../shared: refused as is (non-uniform coordinates) on every rank, and
# resampled to a uniform image (written as .vti, read in pieces).
cth_path = dc.shared_path("data/multimaterial/cth_armor_impact.vtr")
if cth_path and not CLIENT_SERVER:
    cth_fractions = ["Void Volume Fraction", "Volume Fraction for Armor Plate", "Volume Fraction for Body, Nose"]
    cth = simple.XMLRectilinearGridReader(FileName=[cth_path])
    refused = simple.MaterialInterfaceApproximation(Input=cth, VolumeFractionArrays=cth_fractions)
    refused.UpdatePipeline()
    dc.check(all(servermanager.Fetch(refused, r, None, 0).GetNumberOfCells() == 0 for r in range(ranks)),
             "CTH as is (non-uniform rectilinear): empty outputs on every rank (refused, as serially)")
    simple.Delete(refused)
    simple.Delete(cth)
    # Resampled by VTK in a separate serial process (in this MPI process vtkResampleToImage is the
    # parallel one, which the other ranks would have to join).
    resampled = os.path.join(workdir, "cth.vti")
    script = ("import sys; from vtkmodules.vtkIOXML import vtkXMLRectilinearGridReader, vtkXMLImageDataWriter; "
              "from vtkmodules.vtkFiltersCore import vtkResampleToImage; r = vtkXMLRectilinearGridReader(); "
              "r.SetFileName(sys.argv[1]); s = vtkResampleToImage(); s.SetInputConnection(r.GetOutputPort()); "
              "s.SetSamplingDimensions(65, 33, 33); w = vtkXMLImageDataWriter(); w.SetFileName(sys.argv[2]); "
              "w.SetInputConnection(s.GetOutputPort()); w.Write()")
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_", "OPAL_"))}
    with open(os.path.join(workdir, "resample.py"), "w") as f:
        f.write(script.replace("; ", "\n"))
    subprocess.run(["pvpython", f.name, cth_path, resampled], check=True, env=env)
    reader = simple.XMLImageDataReader(FileName=[resampled])
    b = read(vtkXMLImageDataReader, resampled).GetBounds()
    simple.Delete(check_case(reader, resampled, "CTH resampled 65x33x33", cth_fractions, ["Mass"],
                             ["Mass for Armor Plate", "Mass for Body, Nose"], 0.2, 0.002,
                             [0.5 * (b[0] + b[1]), 0.5 * (b[2] + b[3]), 0.5 * (b[4] + b[5]), 0.0, 1.0, 0.0]))
    simple.Delete(reader)

RANKS.finish("mpi_material")
