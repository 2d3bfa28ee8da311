"""Benchmark: Adaptive Interval Volume against ParaView's Iso Volume (issue 16) on the shared volumes.

    bash scripts/bench.sh                         # every benchmark (after scripts/setup.sh)
    pvpython scripts/bench_interval.py [NAME...]  # this one alone (NAME: e.g. bonsai_256x256x256_uint8_lossy)

Replaces its own section of docs/benchmarks.md ("## Interval volumes (issue 16)") and prints it (only
when run on every volume).

One rule picks the range of every volume, never per volume: α is Otsu's threshold of the 256-bin
histogram (the value separating material from background best), β the middle between α and the
largest sample; both moved to the middle between two integers for integer data (ties with samples
are legal but not what a user measures). Per volume and tolerance (0, 0.5 % and 1 % of the image
diagonal), each run is its own fresh pvpython process reading the .vti: Iso Volume (IsoVolume in
paraview.simple, the filter a user picks for this) and Adaptive Interval Volume (first execution,
hierarchy build included: what a user waits for), alternating, REPEATS times; the time is the
median of the proxies' UpdatePipeline after the reader has been updated (untimed). Memory: growth of
the process's peak RSS during the update, and the output's GetActualMemorySize. Volumes are
measured outside the timings with numpy (Iso Volume's cells through Tetrahedralize). The volume
difference is relative to Iso Volume's (which cuts trilinear cells, ours the linear interpolant of
the finest tetrahedra: at tolerance 0 they differ by less than a voxel layer along the surfaces).
The goal at 1 %: at least 10× fewer cells and 3× faster than Iso Volume.

Where the cells go (measured outside the timings): Iso Volume's cells as tetrahedra (Tetrahedralize:
a hexahedron is 5 or 6 of them, a wedge 3, a pyramid 2), the triangles of our two bounding surfaces
(Adaptive Isosurface of α and β together at the same Tolerance: the surfaces that bound ours), and
the share of our tetrahedra with a point on one of them (a point that is not a grid point). Every
bounding triangle is a face of one of our tetrahedra, so Iso Volume's cells divided by the bounding
triangles is about the most any mesh carrying both surfaces at that Tolerance can reach.
"""

import json
import os
import statistics
import subprocess
import sys

from benchlib import replace_section  # scripts/benchlib.py, beside this file

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(os.path.dirname(ROOT), "shared", "data", "volumes")
PLUGIN = os.path.join(ROOT, "build", "lib", "paraview-5.11", "plugins", "Diamonds")
SECTION = "## Interval volumes (issue 16)"
RELATIVE_TOLERANCES = [0.0, 0.005, 0.01]
REPEATS = int(os.environ.get("DIAMONDS_BENCH_REPEATS", "3"))


def load(path):
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader

    reader = vtkXMLImageDataReader()
    reader.SetFileName(path)
    reader.Update()
    image = reader.GetOutput()
    image.GetPointData().SetActiveScalars(image.GetPointData().GetArrayName(0))
    return image


def value_range(image):
    """[α, β] by the rule of the docstring."""
    import numpy as np
    from vtkmodules.util.numpy_support import vtk_to_numpy

    scalars = image.GetPointData().GetScalars()
    values = vtk_to_numpy(scalars).astype(np.float64).ravel()
    counts, edges = np.histogram(values, bins=256)
    centres = 0.5 * (edges[:-1] + edges[1:])
    w0 = np.cumsum(counts)
    w1 = w0[-1] - w0
    s0 = np.cumsum(counts * centres)
    m0 = s0 / np.maximum(w0, 1)
    m1 = (s0[-1] - s0) / np.maximum(w1, 1)
    alpha = float(centres[int(np.argmax(w0 * w1 * (m0 - m1) ** 2))])
    beta = 0.5 * (alpha + float(values.max()))
    if scalars.GetDataType() not in (10, 11):  # not float or double
        alpha, beta = np.floor(alpha) + 0.5, np.floor(beta) + 0.5
    return float(alpha), float(beta)


def diagonal(image):
    b = image.GetBounds()
    return sum((b[2 * i + 1] - b[2 * i]) ** 2 for i in range(3)) ** 0.5


def peak_rss():
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def tet_volume(ug):
    """Sum of |volume| of the tetrahedra of an unstructured grid of tetrahedra."""
    import numpy as np
    from vtkmodules.util.numpy_support import vtk_to_numpy

    if ug.GetNumberOfCells() == 0:
        return 0.0
    p = vtk_to_numpy(ug.GetPoints().GetData()).astype(np.float64)
    t = vtk_to_numpy(ug.GetCells().GetConnectivityArray()).astype(np.int64).reshape(-1, 4)
    a = p[t]
    return float(np.abs(np.einsum("ij,ij->i", a[:, 1] - a[:, 0], np.cross(a[:, 2] - a[:, 0], a[:, 3] - a[:, 0]))).sum() / 6.0)


def worker(spec):
    """One timed case in this fresh process; prints RESULT {json}."""
    import time

    from paraview import servermanager, simple

    reader = simple.XMLImageDataReader(FileName=[spec["path"]])
    reader.UpdatePipeline()
    array = reader.PointData.keys()[0]
    if spec["method"] == "ours":
        f = simple.AdaptiveIntervalVolume(Input=reader, Scalars=["POINTS", array], ThresholdRange=spec["range"], Tolerance=spec["tolerance"])
    else:
        f = simple.IsoVolume(Input=reader, InputScalars=["POINTS", array], ThresholdRange=spec["range"])
    before = peak_rss()
    t = time.perf_counter()
    f.UpdatePipeline()
    seconds = time.perf_counter() - t
    rss = peak_rss() - before
    out = servermanager.Fetch(f)
    result = {"seconds": seconds, "rss": rss, "cells": out.GetNumberOfCells(), "memory": out.GetActualMemorySize() * 1024}
    if spec.get("measure"):
        tets = out if spec["method"] == "ours" else servermanager.Fetch(simple.Tetrahedralize(Input=f))
        result["volume"] = tet_volume(tets)
        result["tets"] = tets.GetNumberOfCells()
        if spec["method"] == "ours":
            result.update(where(reader, array, spec, out))
    print("RESULT " + json.dumps(result))


def where(reader, array, spec, out):
    """Where our tetrahedra are: the triangles of the two bounding surfaces (Adaptive Isosurface of
    α and β together at the same Tolerance: the very surfaces that bound ours), and the share of our
    tetrahedra with a point on one (a new point: not a grid point)."""
    import numpy as np
    from paraview import servermanager, simple
    from vtkmodules.util.numpy_support import vtk_to_numpy

    surfaces = simple.AdaptiveIsosurface(Input=reader, ContourBy=["POINTS", array], Isosurfaces=spec["range"], Tolerance=spec["tolerance"])
    triangles = servermanager.Fetch(surfaces).GetNumberOfCells()
    if out.GetNumberOfCells() == 0:
        return {"triangles": triangles, "touching": 0.0}
    image = servermanager.Fetch(reader)
    p = vtk_to_numpy(out.GetPoints().GetData()).astype(np.float64)
    g = (p - np.array(image.GetOrigin())) / np.array(image.GetSpacing())
    new = np.abs(g - np.round(g)).max(axis=1) > 1e-6
    t = vtk_to_numpy(out.GetCells().GetConnectivityArray()).astype(np.int64).reshape(-1, 4)
    return {"triangles": triangles, "touching": float(new[t].any(axis=1).mean())}


def run(spec):
    env = dict(os.environ, PV_PLUGIN_PATH=PLUGIN)
    cmd = ["pvpython", os.path.abspath(__file__), "--worker", json.dumps(spec)]
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    for line in out.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[len("RESULT "):])
    sys.exit(f"benchmark case failed: {' '.join(cmd)}\n{out.stdout}\n{out.stderr}")


def measure(label, path):
    image = load(path)
    rng, diag = value_range(image), diagonal(image)
    print(f"== {label}: range [{rng[0]:g}, {rng[1]:g}]", flush=True)
    base = {"path": path, "range": list(rng)}
    iso = run(dict(base, method="iso", measure=True))
    iso_t = []
    rows = []
    for rel in RELATIVE_TOLERANCES:
        ours = run(dict(base, method="ours", tolerance=rel * diag, measure=True))
        ours_t, rss = [], []
        for _ in range(REPEATS):
            r = run(dict(base, method="ours", tolerance=rel * diag))
            ours_t.append(r["seconds"])
            rss.append(r["rss"])
            i = run(dict(base, method="iso"))
            iso_t.append(i["seconds"])
        rows.append({"rel": rel, "ours": ours, "seconds": statistics.median(ours_t), "rss": statistics.median(rss)})
        print(f"   {rel * 100:g} %: {ours['cells']:,} tetrahedra, {statistics.median(ours_t):.3f} s", flush=True)
    return {"range": rng, "iso": iso, "iso_seconds": statistics.median(iso_t), "rows": rows}


def report(results):
    mib = lambda b: f"{b / 2**20:.1f}"  # noqa: E731
    lines = [
        SECTION,
        "",
        "`pvpython scripts/bench_interval.py` (run by `bash scripts/bench.sh`; method in its docstring). "
        f"Range [α, β]: α by Otsu's rule, β half-way to the maximum. Times: medians of {REPEATS} alternating "
        "fresh-process runs (Iso Volume's over all of them). Memory: peak-RSS growth during the update / "
        "the output's size, MiB. Volume difference: relative to Iso Volume's.",
        "",
        "| volume | range | tolerance | Iso Volume cells / s / MiB | ours tetrahedra / s / MiB | cells ÷ | speed × | volume diff. | goal at 1 % (≥ 10× fewer, ≥ 3× faster) | Iso Volume tetrahedra, ÷ | bounding triangles α+β | ours on a bounding surface | cells ÷ at one tetrahedron per bounding triangle |",
        "|---|---|---:|---|---|---:|---:|---:|---|---|---:|---:|---:|",
    ]
    for label, r in results:
        iso = r["iso"]
        for row in r["rows"]:
            o = row["ours"]
            fewer = iso["cells"] / max(o["cells"], 1)
            speed = r["iso_seconds"] / row["seconds"]
            diff = (o["volume"] - iso["volume"]) / iso["volume"] if iso["volume"] else 0.0
            goal = ""
            if row["rel"] == 0.01:
                goal = "met" if fewer >= 10 and speed >= 3 else f"**missed** ({'cells' if fewer < 10 else ''}{' and ' if fewer < 10 and speed < 3 else ''}{'speed' if speed < 3 else ''})"
            lines.append(
                f"| {label} | [{r['range'][0]:g}, {r['range'][1]:g}] | {row['rel'] * 100:g} % "
                f"| {iso['cells']:,} / {r['iso_seconds']:.3f} / {mib(iso['rss'])} / {mib(iso['memory'])} "
                f"| {o['cells']:,} / {row['seconds']:.3f} / {mib(row['rss'])} / {mib(o['memory'])} "
                f"| {fewer:.1f}× | {speed:.2f}× | {diff * 100:+.2f} % | {goal} "
                f"| {iso['tets']:,}, {iso['tets'] / max(o['cells'], 1):.1f}× | {o['triangles']:,} | {o['touching'] * 100:.0f} % "
                f"| {iso['cells'] / max(o['triangles'], 1):.1f}× |"
            )
    return lines


def main():
    if not os.path.isdir(SHARED):
        print(f"../shared not found at {SHARED}: skipped")
        return 0
    only = sys.argv[1:]
    results = []
    for name in sorted(os.listdir(SHARED)):
        label = name[: -len(".vti")]
        if name.endswith(".vti") and (not only or label in only):
            results.append((label, measure(label, os.path.join(SHARED, name))))
    lines = report(results)
    if not only:
        replace_section(SECTION, lines)
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--worker":
        worker(json.loads(sys.argv[2]))
    else:
        sys.exit(main())
