"""Benchmark: relevant (RI) and minimal (MI) isodiamond hierarchies (issue 16; Weiss & De Floriani
Table 2 and Figure 15) on the shared volumes.

    python3 scripts/bench_isodiamonds.py [NAME...]   # NAME: e.g. bonsai_256x256x256_uint8_lossy

Replaces its own section of docs/benchmarks.md ("## Isodiamond hierarchies (issue 16)") and prints it
(only when run on every volume). Per volume, the core's isodiamond_probe example
(`cargo run --release -p diamonds-cli --example isodiamond_probe -- IN.vti REPEATS`) builds, for an
isosurface at the middle of the data range and the interval volume from 30 % to 60 % of it (one
rule for every volume, moved to half-integers for integer data), the RI and MI hierarchies on the
default ladder (4 % … 1/16 % of the diagonal, then 0), and measures: their counts and sizes (the
.isd bytes) against the indexed full-resolution mesh (12 B per vertex, 12 B per triangle or 16 B per
tetrahedron, as Table 2), and the extraction time from the full hierarchy (isosurface::extract or
interval::extract, samples and hierarchy in memory), RI and MI at 1 %, 0.25 % and 0 of the diagonal
(Figure 15), alternating, the minimum of REPEATS runs. Goals: MI at most 1/5 of the indexed size for
isosurfaces and 1/10 for interval volumes; MI extraction at least 2x faster than the full hierarchy's.
"""

import json
import os
import subprocess
import sys

from benchlib import replace_section  # scripts/benchlib.py, beside this file

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(os.path.dirname(ROOT), "shared", "data", "volumes")
SECTION = "## Isodiamond hierarchies (issue 16)"
REPEATS = int(os.environ.get("DIAMONDS_BENCH_REPEATS", "3"))
MB = 1024.0 * 1024.0


def probe(path):
    command = ["cargo", "run", "--release", "--locked", "-q", "-p", "diamonds-cli", "--example",
               "isodiamond_probe", "--", path, str(REPEATS)]
    out = subprocess.run(command, cwd=ROOT, check=True, capture_output=True, text=True).stdout
    return [json.loads(line) for line in out.splitlines() if line.startswith("{")]


def report(results):
    method = __doc__.split("\n\n", 2)[2].strip()
    method = "`python3 scripts/bench_isodiamonds.py`: per volume" + method[method.index("Per volume") + len("Per volume"):]
    lines = [SECTION, "", method, ""]
    load = os.getloadavg()[0]
    lines += [f"Load average when the table was written: {load:.1f} (2 cores shared).", ""]
    lines += ["| volume | target | levels | crossings | relevant | creation | active | orphans (MI) | "
              "full-res. vertices | full-res. cells | MI MB | RI MB | indexed MB | RI/MI | indexed/MI | goal |",
              "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for name, rows in results:
        for r in rows:
            ratio = r["indexed_bytes"] / r["mi_bytes"]
            goal = 5 if r["target"] == "isosurface" else 10
            lines.append(
                f"| {name} | {r['target']} | {r['levels']} | {r['crossings']:,} | {r['relevant']:,} | "
                f"{r['creation']:,} | {r['active']:,} | {r['orphans']:,} | {r['vertices']:,} | {r['cells']:,} | "
                f"{r['mi_bytes'] / MB:.2f} | {r['ri_bytes'] / MB:.2f} | {r['indexed_bytes'] / MB:.2f} | "
                f"{r['ri_bytes'] / r['mi_bytes']:.2f} | {ratio:.1f} | {'met' if ratio >= goal else 'NOT met'} (≥ {goal}) |")
    lines += ["", "Extraction (seconds, minimum of the runs; cells: triangles or tetrahedra):", "",
              "| volume | target | tolerance | cells | full | RI | MI | full/MI | goal (≥ 2) |",
              "|---|---|---:|---:|---:|---:|---:|---:|---|"]
    for name, rows in results:
        for r in rows:
            for t in r["times"]:
                speed = t["full"] / t["mi"] if t["mi"] > 0 else float("inf")
                lines.append(
                    f"| {name} | {r['target']} | {100 * t['relative']:g} % | {t['cells']:,} | {t['full']:.4f} | "
                    f"{t['ri']:.4f} | {t['mi']:.4f} | {speed:.1f} | {'met' if speed >= 2 else 'NOT met'} |")
    return lines


def main():
    names = sys.argv[1:]
    files = sorted(f for f in os.listdir(SHARED) if f.endswith(".vti"))
    if names:
        files = [f for f in files if any(n in f for n in names)]
    results = []
    for f in files:
        name = f[:-4]
        print(f"{name} …", file=sys.stderr, flush=True)
        results.append((name, probe(os.path.join(SHARED, f))))
    lines = report(results)
    print("\n".join(lines))
    if not names:
        replace_section(SECTION, lines)


if __name__ == "__main__":
    main()
