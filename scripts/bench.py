"""Benchmark: Adaptive Tetrahedra vs ParaView's Tetrahedralize (vtkDataSetTriangleFilter), one run.

    bash scripts/bench.sh            # = pvpython scripts/bench.py (after scripts/setup.sh)

For each dataset (bonsai 256^3 and neghip 64^3 from ../shared/data/volumes) it runs, each case in a
fresh pvpython process so that peak memory is its own:
  * Tetrahedralize on the full image (single-threaded: VTK's SMP backend here is Sequential);
  * Adaptive Tetrahedra at Tolerance 0, 0.5, 2, 8 grey levels with 1 and 2 threads
    (RAYON_NUM_THREADS): a first execution at Tolerance = 1e30 measures the hierarchy build (it also
    outputs the base mesh), a second at the tolerance measures the query (refinement + VTK output).
Peak memory is the growth of the process's peak RSS (VmHWM, reset after loading the image) while the
filter runs. Writes docs/benchmarks.md (markdown tables) and prints them.
"""

import json
import os
import platform
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(os.path.dirname(ROOT), "shared", "data", "volumes")
PLUGIN = os.path.join(ROOT, "build", "lib", "paraview-5.11", "plugins", "Diamonds")
DATASETS = [
    ("bonsai 256³ u8", "bonsai_256x256x256_uint8_lossy.vti"),
    ("neghip 64³ u8", "neghip_64x64x64_uint8.vti"),
]
TOLERANCES = [0.0, 0.5, 2.0, 8.0]
THREADS = [1, 2]


def rss_kib(field):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field + ":"):
                return int(line.split()[1])
    raise RuntimeError(field)


def reset_peak():
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")  # resets VmHWM to the current RSS (Linux >= 4.0)


def worker(method, path, tolerance):
    from paraview import simple

    reader = simple.XMLImageDataReader(FileName=[path])
    reader.UpdatePipeline()
    array = reader.PointData.keys()[0]
    reset_peak()
    base = rss_kib("VmRSS")
    result = {"method": method}
    if method == "tetrahedralize":
        f = simple.Tetrahedralize(Input=reader)
        t = time.perf_counter()
        f.UpdatePipeline()
        result["total"] = time.perf_counter() - t
    else:
        f = simple.AdaptiveTetrahedra(Input=reader)
        f.Scalars = ["POINTS", array]
        f.Tolerance = 1e30
        t = time.perf_counter()
        f.UpdatePipeline()
        result["build"] = time.perf_counter() - t
        result["base_tets"] = f.GetDataInformation().GetNumberOfCells()
        f.Tolerance = tolerance
        t = time.perf_counter()
        f.UpdatePipeline()
        result["query"] = time.perf_counter() - t
        result["total"] = result["build"] + result["query"]
        f.UpdatePropertyInformation()
        result["builds"] = int(f.GetProperty("NumberOfHierarchyBuilds").GetElement(0))
        result["bytes_per_point"] = int(f.GetProperty("HierarchyMemorySize").GetElement(0)) / (
            reader.GetDataInformation().GetNumberOfPoints()
        )
        fd = f.FieldData
        result["max_error"] = fd["MaximumError"].GetRange()[1] if "MaximumError" in fd.keys() else None
    result["tets"] = f.GetDataInformation().GetNumberOfCells()
    result["peak_mib"] = (rss_kib("VmHWM") - base) / 1024.0
    print("RESULT " + json.dumps(result))


def run(method, path, tolerance=0.0, threads=1):
    env = dict(os.environ, PV_PLUGIN_PATH=PLUGIN, RAYON_NUM_THREADS=str(threads))
    cmd = ["pvpython", os.path.abspath(__file__), "--worker", method, path, repr(tolerance)]
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    for line in out.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[len("RESULT "):])
    sys.exit(f"benchmark case failed: {' '.join(cmd)}\n{out.stdout}\n{out.stderr}")


def fmt(x, digits=2):
    return f"{x:.{digits}f}"


def main():
    if not os.path.isdir(SHARED):
        sys.exit(f"skipped: {SHARED} not found (the benchmark needs ../shared/data/volumes)")
    if not os.path.exists(os.path.join(PLUGIN, "Diamonds.so")):
        sys.exit("Diamonds.so not found: run `bash scripts/setup.sh` first")
    cpu = "unknown CPU"
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    lines = [
        "# Benchmarks",
        "",
        "Written by `bash scripts/bench.sh` (do not edit by hand). Adaptive Tetrahedra vs ParaView's",
        "Tetrahedralize (vtkDataSetTriangleFilter, what a user runs today), in the same run, each case in",
        "its own pvpython process. *Build* is the first execution (hierarchy + base mesh output, at",
        "Tolerance = 1e30); *query* the second, at the tolerance (refinement + VTK output); *total* is what",
        "the first execution at that tolerance costs. *Peak* is the growth of the process's peak RSS while",
        "the filter runs (output included). Ratios are Tetrahedralize ÷ Adaptive Tetrahedra.",
        "",
        f"Machine: {cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}; "
        f"{time.strftime('%Y-%m-%d')}.",
        "",
    ]
    for label, name in DATASETS:
        path = os.path.join(SHARED, name)
        print(f"== {label}: Tetrahedralize", flush=True)
        ref = run("tetrahedralize", path)
        lines += [
            f"## {label}",
            "",
            f"Tetrahedralize: **{ref['tets']:,} tets**, {fmt(ref['total'])} s, peak +{fmt(ref['peak_mib'], 0)} MiB.",
            "",
            "| threads | tolerance | tets | fewer tets | build s | query s | total s | faster | peak MiB | less memory | max error | base tets | hierarchy B/point |",
            "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for threads in THREADS:
            for tol in TOLERANCES:
                print(f"== {label}: Adaptive Tetrahedra, tolerance {tol}, {threads} thread(s)", flush=True)
                r = run("adaptive", path, tol, threads)
                if r["builds"] != 1:
                    sys.exit(f"the hierarchy was built {r['builds']} times; expected once")
                lines.append(
                    f"| {threads} | {tol:g} | {r['tets']:,} | {ref['tets'] / r['tets']:.1f}× | {fmt(r['build'])} | "
                    f"{fmt(r['query'])} | {fmt(r['total'])} | {ref['total'] / r['total']:.1f}× | "
                    f"{fmt(r['peak_mib'], 0)} | {ref['peak_mib'] / max(r['peak_mib'], 1e-9):.1f}× | "
                    f"{r['max_error']:g} | {r['base_tets']:,} | {r['bytes_per_point']:g} |"
                )
        lines.append("")
    text = "\n".join(lines) + "\n"
    with open(os.path.join(ROOT, "docs", "benchmarks.md"), "w") as f:
        f.write(text)
    print(text)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--worker":
        worker(sys.argv[2], sys.argv[3], float(sys.argv[4]))
    else:
        main()
