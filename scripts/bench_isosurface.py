"""Benchmark: Adaptive Isosurface vs Flying Edges (+ DecimatePro, + QuadricDecimation), one run.

    bash scripts/bench.sh            # runs both benchmarks (after scripts/setup.sh)

For each dataset (bonsai 256^3 iso 40, neghip 64^3, hydrogen orbital 64^3 from ../shared/data/volumes),
every case in a fresh pvpython process so that peak memory is its own:
  * vtkFlyingEdges3D at full resolution: the reference surface;
  * Adaptive Isosurface at tolerances of 0.25, 0.5, 1 and 2 % of the data diagonal: first extraction
    (hierarchy build included), then an isovalue change (to iso + 5 % of the range) at the same tolerance;
  * Flying Edges + vtkDecimatePro and + vtkQuadricDecimation reduced to the triangle count we reached;
  * the goals of issue 3 on bonsai: Flying Edges + DecimatePro at TargetReduction 0.9 against our
    surface with the most triangles not above its count (time ratio, Hausdorff), and the isovalue
    change at 1 % of the diagonal against Flying Edges (the single run above, then GOAL_REPEATS
    alternating pairs of fresh processes: medians and ranges).
Each surface's symmetric Hausdorff distance to the full-resolution Flying Edges surface (max and RMS of the
point-to-surface distances both ways, vtkHausdorffDistancePointSetFilter) is measured afterwards, outside
the timings. Appends to docs/benchmarks.md and writes docs/images/isosurface-hausdorff.png.
"""

import json
import os
import subprocess
import sys
import tempfile
import time

from bench import reset_peak, rss_kib  # scripts/bench.py, beside this file

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(os.path.dirname(ROOT), "shared", "data", "volumes")
PLUGIN = os.path.join(ROOT, "build", "lib", "paraview-5.11", "plugins", "Diamonds")
# Isovalues of the u8 volumes are shifted by half a grey level off the samples: at a sample value Flying
# Edges emits triangles collapsed onto a sample, which VTK's point-to-cell distance cannot see (bonsai's
# iso-40 surface measured 28.2 away from itself), and every method makes zero-area triangles there.
DATASETS = [
    ("bonsai 256³ u8, iso 40.5", "bonsai_256x256x256_uint8_lossy.vti", 40.5),
    ("neghip 64³ u8, iso 100.5", "neghip_64x64x64_uint8.vti", 100.5),
    ("hydrogen orbital 64³ f32, iso 0.05", "hydrogen_orbital_64x64x64_float32.vti", 0.05),
]
RELATIVE_TOLERANCES = [0.0025, 0.005, 0.01, 0.02, 0.04, 0.06]
# Issue 3's goals, on the first dataset: DecimatePro as a user runs it (TargetReduction 0.9, no
# topology preservation) against our surface with at most as many triangles.
GOAL_REDUCTION = 0.9
# Single timings on a shared 2-core machine vary by ±30 %: the isovalue-change goal is also measured
# this many times, alternating with Flying Edges, each in a fresh process.
GOAL_REPEATS = 7


def worker(spec):
    """Runs one case described by `spec` (JSON) and prints its result."""
    from paraview import servermanager, simple
    from vtkmodules.vtkFiltersCore import vtkDecimatePro, vtkFlyingEdges3D, vtkQuadricDecimation
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader, vtkXMLPolyDataWriter

    method = spec["method"]
    if method == "adaptive":
        reader = simple.XMLImageDataReader(FileName=[spec["path"]])
        reader.UpdatePipeline()
        array = reader.PointData.keys()[0]
    else:
        reader = vtkXMLImageDataReader()
        reader.SetFileName(spec["path"])
        reader.Update()
        image = reader.GetOutput()
        image.GetPointData().SetActiveScalars(image.GetPointData().GetArrayName(0))
    reset_peak()
    base = rss_kib("VmRSS")
    result = {}
    if method == "adaptive":
        f = simple.AdaptiveIsosurface(Input=reader)
        f.ContourBy = ["POINTS", array]
        f.Isosurfaces = [spec["iso"]]
        f.Tolerance = spec["tolerance"]
        f.ComputeNormals = 1
        t = time.perf_counter()
        f.UpdatePipeline()
        result["first"] = time.perf_counter() - t
        surface = servermanager.Fetch(f)
        result["triangles"] = surface.GetNumberOfCells()
        result["peak_mib"] = (rss_kib("VmHWM") - base) / 1024.0
        f.Isosurfaces = [spec["iso"] + spec["iso_step"]]
        t = time.perf_counter()
        f.UpdatePipeline()
        result["change"] = time.perf_counter() - t
    else:
        fe = vtkFlyingEdges3D()
        fe.SetInputData(image)
        fe.SetValue(0, spec["iso"])
        fe.ComputeNormalsOn()
        t = time.perf_counter()
        fe.Update()
        result["contour"] = time.perf_counter() - t
        surface = fe.GetOutput()
        if method != "flyingedges":
            full = surface.GetNumberOfCells()
            dec = vtkDecimatePro() if method == "decimatepro" else vtkQuadricDecimation()
            dec.SetInputData(surface)
            dec.SetTargetReduction(max(0.0, min(0.999, 1.0 - spec["target"] / full)))
            if method == "decimatepro":
                dec.PreserveTopologyOff()
            t = time.perf_counter()
            dec.Update()
            result["decimate"] = time.perf_counter() - t
            surface = dec.GetOutput()
        result["triangles"] = surface.GetNumberOfCells()
        result["peak_mib"] = (rss_kib("VmHWM") - base) / 1024.0
    writer = vtkXMLPolyDataWriter()
    writer.SetInputData(surface)
    writer.SetFileName(spec["out"])
    writer.Write()
    print("RESULT " + json.dumps(result))


def hausdorff(spec):
    """Symmetric Hausdorff distance (max, RMS) between two .vtp files."""
    import math

    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkFiltersModeling import vtkHausdorffDistancePointSetFilter
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader

    surfaces = []
    for path in (spec["a"], spec["b"]):
        r = vtkXMLPolyDataReader()
        r.SetFileName(path)
        r.Update()
        surfaces.append(r.GetOutput())
    h = vtkHausdorffDistancePointSetFilter()
    h.SetInputData(0, surfaces[0])
    h.SetInputData(1, surfaces[1])
    h.SetTargetDistanceMethodToPointToCell()
    h.Update()
    d = []
    for port in (0, 1):
        d.extend(vtk_to_numpy(h.GetOutput(port).GetPointData().GetArray("Distance")).tolist())
    rms = math.sqrt(sum(x * x for x in d) / max(len(d), 1))
    print("RESULT " + json.dumps({"max": max(d) if d else 0.0, "rms": rms}))


def run(kind, spec, threads=2):
    env = dict(os.environ, PV_PLUGIN_PATH=PLUGIN, RAYON_NUM_THREADS=str(threads))
    cmd = ["pvpython", os.path.abspath(__file__), kind, json.dumps(spec)]
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    for line in out.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[len("RESULT "):])
    sys.exit(f"benchmark case failed: {' '.join(cmd)}\n{out.stdout}\n{out.stderr}")


def goals(label, path, iso, reference, tmp, fe, ours_rows, diagonal, iso_step):
    """Issue 3's goals on `label`: markdown lines."""
    out = os.path.join(tmp, "goal-decimatepro.vtp")
    print(f"== {label}: Flying Edges + DecimatePro at TargetReduction {GOAL_REDUCTION}", flush=True)
    dec = run("--worker", {"method": "decimatepro", "path": path, "iso": iso,
                           "target": (1.0 - GOAL_REDUCTION) * fe["triangles"], "out": out})
    h = run("--hausdorff", {"a": out, "b": reference})
    dec_time = dec["contour"] + dec["decimate"]
    fitting = [r for r in ours_rows if r[1]["triangles"] <= dec["triangles"]]
    lines = [
        f"### Goals (issue 3), {label}",
        "",
        f"Flying Edges + DecimatePro at TargetReduction {GOAL_REDUCTION} (what a user runs today) against our surface with the",
        "most triangles not above its count (first extraction, hierarchy build included), and isovalue changes",
        "at 1 % of the diagonal against Flying Edges at full resolution.",
        "",
        "| method | triangles | time s | Hausdorff max | Hausdorff RMS |",
        "|---|---:|---:|---:|---:|",
        f"| Flying Edges + DecimatePro ({GOAL_REDUCTION:g}) | {dec['triangles']:,} | {dec_time:.2f} | {h['max']:.3g} | {h['rms']:.3g} |",
    ]
    if fitting:
        rel, ours, ho = max(fitting, key=lambda r: r[1]["triangles"])
        lines += [
            f"| Adaptive Isosurface, tolerance {rel * 100:g} % | {ours['triangles']:,} | {ours['first']:.2f} | {ho['max']:.3g} | {ho['rms']:.3g} |",
            "",
            f"- Time: **{dec_time / ours['first']:.1f}×** faster end to end (goal ≥ 30×); max Hausdorff "
            f"{ho['max']:.3g} vs {h['max']:.3g} ({'no larger' if ho['max'] <= h['max'] else 'LARGER'}; goal: no larger).",
        ]
    one = [r for r in ours_rows if r[0] == 0.01]
    if one:
        change = one[0][1]["change"]
        lines.append(
            f"- Isovalue change at 1 %: {change:.3f} s vs Flying Edges {fe['contour']:.3f} s "
            f"({'faster' if change < fe['contour'] else 'SLOWER'}; goal: faster)."
        )
    import statistics

    fe_times, change_times = [], []
    for k in range(GOAL_REPEATS):
        print(f"== {label}: isovalue change at 1 % vs Flying Edges, pair {k + 1}/{GOAL_REPEATS}", flush=True)
        fe_times.append(run("--worker", {"method": "flyingedges", "path": path, "iso": iso,
                                         "out": os.path.join(tmp, "goal-fe.vtp")})["contour"])
        change_times.append(run("--worker", {"method": "adaptive", "path": path, "iso": iso,
                                             "tolerance": 0.01 * diagonal, "iso_step": iso_step,
                                             "out": os.path.join(tmp, "goal-ours.vtp")})["change"])
    wins = sum(c < f for c, f in zip(change_times, fe_times))
    median_change, median_fe = statistics.median(change_times), statistics.median(fe_times)
    lines.append(
        f"- Repeated {GOAL_REPEATS}× alternately, fresh processes: isovalue change at 1 % median "
        f"**{median_change:.3f} s** ({min(change_times):.3f}–{max(change_times):.3f}) vs Flying Edges median "
        f"**{median_fe:.3f} s** ({min(fe_times):.3f}–{max(fe_times):.3f}): "
        f"{median_fe / median_change:.2f}× ({'faster' if median_change < median_fe else 'SLOWER'}; "
        f"faster in {wins} of {GOAL_REPEATS} pairs)."
    )
    return lines + [""]


def main():
    if not os.path.isdir(SHARED):
        sys.exit(f"skipped: {SHARED} not found (the benchmark needs ../shared/data/volumes)")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vtkmodules.vtkIOXML import vtkXMLImageDataReader

    tmp = tempfile.mkdtemp(prefix="diamonds-bench-")
    lines = [
        "",
        "# Isosurfaces",
        "",
        "Written by `bash scripts/bench.sh`. Adaptive Isosurface vs Flying Edges at full resolution and",
        "Flying Edges + DecimatePro / + QuadricDecimation reduced to our triangle count, 2 threads for us",
        "(VTK's filters are single-threaded here). *First* includes the hierarchy build; *change* is an",
        "isovalue change (+5 % of the range) at the same tolerance on the kept hierarchy. Hausdorff: symmetric,",
        "to the full-resolution Flying Edges surface (max and RMS of point-to-surface distances, world units).",
        "",
    ]
    fig, axes = plt.subplots(1, len(DATASETS), figsize=(6 * len(DATASETS), 4.5))
    for (label, name, iso), ax in zip(DATASETS, axes):
        path = os.path.join(SHARED, name)
        r = vtkXMLImageDataReader()
        r.SetFileName(path)
        r.Update()
        img = r.GetOutput()
        lo, hi = img.GetPointData().GetArray(0).GetRange()
        b = img.GetBounds()
        diagonal = ((b[1] - b[0]) ** 2 + (b[3] - b[2]) ** 2 + (b[5] - b[4]) ** 2) ** 0.5
        reference = os.path.join(tmp, f"{name}-fe.vtp")
        print(f"== {label}: Flying Edges", flush=True)
        fe = run("--worker", {"method": "flyingedges", "path": path, "iso": iso, "out": reference})
        lines += [
            f"## {label}",
            "",
            f"Flying Edges (full resolution): **{fe['triangles']:,} triangles** in {fe['contour']:.2f} s, peak +{fe['peak_mib']:.0f} MiB.",
            "",
            "| tolerance (% diagonal) | method | triangles | time s | isovalue change s | Hausdorff max | Hausdorff RMS | peak MiB |",
            "|---:|---|---:|---:|---:|---:|---:|---:|",
        ]
        curves = {"Adaptive Isosurface": [], "Flying Edges + DecimatePro": [], "Flying Edges + QuadricDecimation": []}
        ours_rows = []
        for rel in RELATIVE_TOLERANCES:
            tol = rel * diagonal
            out = os.path.join(tmp, f"{name}-{rel}-ours.vtp")
            print(f"== {label}: Adaptive Isosurface at {rel * 100:g} % of the diagonal", flush=True)
            ours = run("--worker", {"method": "adaptive", "path": path, "iso": iso, "tolerance": tol,
                                    "iso_step": 0.05 * (hi - lo), "out": out})
            h = run("--hausdorff", {"a": out, "b": reference})
            curves["Adaptive Isosurface"].append((ours["triangles"], h["max"]))
            ours_rows.append((rel, ours, h))
            lines.append(
                f"| {rel * 100:g} | Adaptive Isosurface | {ours['triangles']:,} | {ours['first']:.2f} | {ours['change']:.3f} | "
                f"{h['max']:.3g} | {h['rms']:.3g} | {ours['peak_mib']:.0f} |"
            )
            for method, title in [("decimatepro", "Flying Edges + DecimatePro"),
                                  ("quadric", "Flying Edges + QuadricDecimation")]:
                out = os.path.join(tmp, f"{name}-{rel}-{method}.vtp")
                print(f"== {label}: {title} to {ours['triangles']:,} triangles", flush=True)
                dec = run("--worker", {"method": method, "path": path, "iso": iso,
                                       "target": ours["triangles"], "out": out})
                h = run("--hausdorff", {"a": out, "b": reference})
                curves[title].append((dec["triangles"], h["max"]))
                lines.append(
                    f"| {rel * 100:g} | {title} | {dec['triangles']:,} | {dec['contour'] + dec['decimate']:.2f} | — | "
                    f"{h['max']:.3g} | {h['rms']:.3g} | {dec['peak_mib']:.0f} |"
                )
        lines.append("")
        if name == DATASETS[0][1]:
            lines += goals(label, path, iso, reference, tmp, fe, ours_rows, diagonal, 0.05 * (hi - lo))
        for title, points in curves.items():
            points.sort()
            ax.plot([p[0] for p in points], [p[1] for p in points], marker="o", label=title)
        ax.set_xscale("log")
        ax.set_xlabel("triangles")
        ax.set_ylabel("Hausdorff distance to full resolution (max)")
        ax.set_title(label)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(ROOT, "docs", "images", "isosurface-hausdorff.png"), dpi=100)
    lines.append("![Hausdorff distance against triangle count](images/isosurface-hausdorff.png)")
    text = "\n".join(lines) + "\n"
    with open(os.path.join(ROOT, "docs", "benchmarks.md"), "a") as f:
        f.write(text)
    print(text)


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--worker":
        worker(json.loads(sys.argv[2]))
    elif len(sys.argv) > 2 and sys.argv[1] == "--hausdorff":
        hausdorff(json.loads(sys.argv[2]))
    else:
        main()
