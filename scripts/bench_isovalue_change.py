"""Benchmark: an isovalue change "from the root" vs "from the current mesh" (Gregorski §6.1), core only.

    bash scripts/bench.sh            # runs every benchmark (after scripts/setup.sh)

Dumps bonsai 256³ (../shared/data/volumes) to raw u8, runs the core's probe example
(`cargo run --release -p diamonds-core --example probe -- RAW 256 256 256 isoseq ISOS 1% 2%`), which
times every change of an isovalue sequence with both starts (minimum of 5 runs, isosurface-error cache
warm), and appends its table to docs/benchmarks.md.
"""

import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BONSAI = os.path.join(os.path.dirname(ROOT), "shared", "data", "volumes", "bonsai_256x256x256_uint8_lossy.vti")
SEQUENCE = "40.5,41,40.5,40,40.5,42.5,40.5,38.5,40.5,50.5,40.5,30.5,40.5"
ROW = re.compile(r"^\s+(\S+) -> (\S+)\s+(\d+)\s+(\d+)\s+([\d.]+) \(([\d.]+)\)\s+([\d.]+) \(([\d.]+)\)")
HEADER = re.compile(r"^tol ([\d.]+) \(([\d.]+)% of diagonal\)")
REUSE = re.compile(r"normals toggled at .*: ([\d.]+)s from the root, ([\d.]+)s reusing the mesh")


def main():
    if not os.path.exists(BONSAI):
        print(f"bonsai not found at {BONSAI}: skipped")
        return 0
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader

    reader = vtkXMLImageDataReader()
    reader.SetFileName(BONSAI)
    reader.Update()
    image = reader.GetOutput()
    dims = image.GetDimensions()
    with tempfile.TemporaryDirectory() as tmp:
        raw = os.path.join(tmp, "bonsai.u8")
        vtk_to_numpy(image.GetPointData().GetArray(0)).astype("uint8").tofile(raw)
        command = ["cargo", "run", "--release", "--locked", "-q", "-p", "diamonds-core", "--example", "probe", "--",
                   raw, *map(str, dims), "isoseq", SEQUENCE, "1%", "2%"]
        out = subprocess.run(command, cwd=ROOT, check=True, capture_output=True, text=True).stdout
    lines = [
        "",
        "## Isovalue change: from the root vs from the current mesh (issue 3, item 2)",
        "",
        f"`pvpython scripts/bench_isovalue_change.py` (run by `bash scripts/bench.sh`): the core's probe on "
        f"bonsai {dims[0]}×{dims[1]}×{dims[2]}, isovalue sequence {SEQUENCE.replace(',', ', ')}; each change "
        "timed with both starts, minimum of 5 runs, isosurface-error cache warm. Whole query in ms, "
        "refinement alone in brackets. Both starts give the same split set and surface (tested).",
        "",
        "| tolerance | change | triangles | from the root | from the current mesh |",
        "|---|---|---:|---:|---:|",
    ]
    reuse = []
    tolerance = ""
    for line in out.splitlines():
        if m := REUSE.search(line):
            reuse.append((float(m.group(1)), float(m.group(2))))
        elif m := HEADER.match(line):
            tolerance = f"{float(m.group(2)):g} % of diagonal"
        elif (m := ROW.match(line)) and m.group(1) != "-":
            rt, rr, ct, cr = (1000 * float(m.group(i)) for i in (5, 6, 7, 8))
            lines.append(
                f"| {tolerance} | {m.group(1)} → {m.group(2)} | {int(m.group(3)):,} "
                f"| {rt:.1f} ({rr:.1f}) | {ct:.1f} ({cr:.1f}) |"
            )
    lines.append("")
    for (root, reused), tol in zip(reuse, ["1 %", "2 %"]):
        lines.append(
            f"Same query with only the normals toggled ({tol}): {1000 * root:.0f} ms from the root, "
            f"{1000 * reused:.0f} ms reusing the kept split set."
        )
    lines.append("")
    with open(os.path.join(ROOT, "docs", "benchmarks.md"), "a") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
