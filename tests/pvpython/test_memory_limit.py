"""Running out of memory ends a filter with an error, never the ParaView session. Run with

  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds pvpython tests/pvpython/test_memory_limit.py

For each filter, a child pvpython builds its input and runs the filter once on a tiny input (so that
libraries, thread pools and the core's emergency reserve are set up as in a session that has done some
work), then limits its own address space (RLIMIT_AS) to what it uses plus a headroom and runs the
filter on a large input. Independently of the filter, the parent checks for every headroom of a sweep
(from far too little to enough):
- the child survives (exits normally and reports), whatever the stage at which memory ran out
  (hierarchy build, refinement, extraction, VTK output arrays);
- either the output equals the unlimited run's (same numbers of cells and points), or the filter
  reported an error that says memory ran out and its outputs are empty (no partial result);
- the sweep reaches the out-of-memory path for every filter (the test tests something), and the
  session can run the filter again once the limit is lifted (same output as unlimited).
Before the fix, the core aborted the process ("memory allocation of N bytes failed") and VTK's arrays
called abort() after "Unable to allocate".
"""

import json
import os
import resource
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import diamonds_checks as dc  # noqa: E402

MiB = 1 << 20
HEADROOMS_MIB = [4, 24, 96, 256, 640]


def vm_size():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmSize:"):
                return int(line.split()[1]) * 1024
    raise RuntimeError("no VmSize in /proc/self/status")


def make(simple, name, extent, impact):
    """The source and the filter `name` on an input of `extent` (the impact case for Material)."""
    if name == "MaterialInterfaceApproximation":
        source = simple.XMLImageDataReader(FileName=[impact])
        filt = simple.MaterialInterfaceApproximation(
            Input=source,
            VolumeFractionArrays=["Volume Fraction for Void", "Volume Fraction for Block",
                                  "Volume Fraction for Projectile"],
            FieldArrays=["Density"])
        filt.InterfaceTolerance = 0.05 if extent else 0.5
        filt.FieldTolerance = 0.5 if extent else 5.0
        return source, filt
    source = simple.Wavelet(WholeExtent=[0, extent, 0, extent, 0, extent] if extent else [0, 8, 0, 8, 0, 8])
    if name == "AdaptiveTetrahedra":
        filt = simple.AdaptiveTetrahedra(Input=source, Tolerance=0.0)
    elif name == "AdaptiveIsosurface":
        filt = simple.AdaptiveIsosurface(Input=source, Isosurfaces=[150.0], Tolerance=0.0)
    elif name == "AdaptiveIntervalVolume":
        filt = simple.AdaptiveIntervalVolume(Input=source, ThresholdRange=[100.0, 200.0], Tolerance=0.0)
    elif name == "ProgressiveTetrahedralMesh":
        tets = simple.AdaptiveTetrahedra(Input=source, Tolerance=0.0)
        tets.UpdatePipeline()
        filt = simple.ProgressiveTetrahedralMesh(Input=tets, TargetReduction=0.9)
        filt.Scalars = ["POINTS", "RTData"]  # pvbatch --symmetric sets no default
    else:
        raise ValueError(name)
    return source, filt


def child(name, extent, headroom_mib, impact):
    simple = dc.require_plugin()
    _, warm = make(simple, name, 0, impact)  # libraries, thread pools, the core's reserve
    warm.UpdatePipeline()
    source, filt = make(simple, name, extent, impact)
    source.UpdatePipeline()
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    if headroom_mib is not None:
        resource.setrlimit(resource.RLIMIT_AS, (vm_size() + headroom_mib * MiB, hard))
    with dc.ErrorCapture(filt) as errors:
        filt.UpdatePipeline()
    resource.setrlimit(resource.RLIMIT_AS, (soft, hard))
    info = filt.GetDataInformation()
    result = {"cells": info.GetNumberOfCells(), "points": info.GetNumberOfPoints(), "errors": errors.text()}
    if headroom_mib is not None and result["errors"]:
        # The same session, the limit lifted: the filter works again.
        algorithm = filt.GetClientSideObject()
        algorithm.Modified()
        algorithm.Update()
        again = algorithm.GetOutputDataObject(0)
        result["again"] = [again.GetNumberOfCells(), again.GetNumberOfPoints()]
    print("RESULT " + json.dumps(result), flush=True)


def run_child(name, extent, headroom_mib, impact):
    cmd = [sys.executable if os.path.basename(sys.executable).startswith("pv") else "pvpython",
           os.path.abspath(__file__), "--child", name, str(extent),
           "none" if headroom_mib is None else str(headroom_mib), impact]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    lines = [line for line in proc.stdout.splitlines() if line.startswith("RESULT ")]
    result = json.loads(lines[-1][len("RESULT "):]) if lines else None
    return proc, result


def main():
    simple = dc.require_plugin()  # noqa: F841 (fails early without the plugin)
    tmp = tempfile.mkdtemp(prefix="diamonds-memory-")
    impact = os.path.join(tmp, "impact.vti")
    subprocess.run([dc.diamonds_binary(), "generate", impact, "--field", "impact", "--dims", "64", "64", "104"],
                   check=True, stdout=subprocess.DEVNULL)
    cases = [("AdaptiveTetrahedra", 119), ("AdaptiveIsosurface", 199), ("AdaptiveIntervalVolume", 149),
             ("MaterialInterfaceApproximation", 1), ("ProgressiveTetrahedralMesh", 48)]
    for name, extent in cases:
        proc, reference = run_child(name, extent, None, impact)
        if not dc.check(proc.returncode == 0 and reference and not reference["errors"] and reference["cells"] > 0,
                        f"{name}: unlimited run ({reference})"):
            print(proc.stdout[-2000:], proc.stderr[-2000:])
            continue
        ran_out = 0
        for headroom in HEADROOMS_MIB:
            label = f"{name} with {headroom} MiB of headroom"
            proc, result = run_child(name, extent, headroom, impact)
            survived = proc.returncode == 0 and result is not None
            if not dc.check(survived, f"{label}: the session survives (exit code {proc.returncode})"):
                tail = [line for line in (proc.stdout + proc.stderr).splitlines() if line.strip()][-8:]
                print("\n".join("     " + line[:200] for line in tail))
                continue
            text = result["errors"]
            if text:
                ran_out += 1
                last = text.strip().splitlines()[-1]
                print(f"   [{label}] {last[:240]}")
                ok = [dc.check("memory" in text.lower(), f"{label}: the error says memory ran out"),
                      dc.check(result["cells"] == 0 and result["points"] == 0, f"{label}: empty output"),
                      dc.check(result.get("again") == [reference["cells"], reference["points"]],
                               f"{label}: the limit lifted, the same session gets the full result "
                               f"({result.get('again')})")]
            else:
                ok = [dc.check((result["cells"], result["points"]) == (reference["cells"], reference["points"]),
                               f"{label}: completed with the unlimited result ({result['cells']} cells)")]
            if not all(ok):
                print(f"     the child's errors: {text[-1500:]!r}\n     its stderr: {proc.stderr[-1500:]!r}")
        dc.check(ran_out > 0, f"{name}: the sweep ran out of memory at least once ({ran_out} of {len(HEADROOMS_MIB)})")
    dc.finish("test_memory_limit")


if __name__ == "__main__":
    if "--child" in sys.argv:
        i = sys.argv.index("--child")
        name, extent, headroom, impact = sys.argv[i + 1:i + 5]
        child(name, int(extent), None if headroom == "none" else int(headroom), impact)
    else:
        main()
