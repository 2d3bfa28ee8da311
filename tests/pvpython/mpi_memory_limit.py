"""Running out of memory on one MPI rank ends the distributed filters on every rank together: no
hang, no crash, no partial result (a user's abort on one rank: mpi_abort.py). Run with

  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds pvpython tests/pvpython/mpi_memory_limit.py

For each distributed filter (Adaptive Tetrahedra, Adaptive Isosurface, Adaptive Interval Volume,
Material Interface Approximation, Progressive Tetrahedral Mesh), the parent runs children `mpiexec -n 2 pvbatch --symmetric` under `timeout` (a hang
is a failure). In a child every rank runs the filter once on a tiny input (libraries, thread pools
and the core's emergency reserve set up as in a session that has done some work), then rank 1 alone
limits its address space (RLIMIT_AS) to what it uses plus a headroom, and both ranks run the filter
on a large input. Independently of the filter, the parent checks for every headroom of a sweep (from
far too little to enough):
- every rank exits normally and reports (the child's exit code is 0, not timeout's 124);
- either every rank's output equals the unlimited run's (cells and points per rank), or every rank's
  output is empty, rank 1's error says memory ran out and rank 0's that another rank (rank 1) failed;
  Progressive Tetrahedral Mesh reduces each piece on its own after the collective steps, so there
  rank 0 may instead output its own piece in full when rank 1 ran out of memory in its reduction;
- the sweep reaches the out-of-memory path for every filter (the test tests something), and after
  the limit is lifted the same session recomputes the unlimited result on every rank.
Before the fix, the ranks hung (rank 1 left a step early and missed a collective the other entered)
or rank 1 aborted the process ("memory allocation of N bytes failed"), leaving rank 0 waiting.
"""

import json
import os
import resource
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import diamonds_checks as dc  # noqa: E402
from test_memory_limit import MiB, make, vm_size  # noqa: E402

HEADROOMS = ["4", "32", "96"]
FILTERS = ["AdaptiveTetrahedra", "AdaptiveIsosurface", "AdaptiveIntervalVolume", "MaterialInterfaceApproximation",
           "ProgressiveTetrahedralMesh"]
# Seconds a child may take before it counts as hung (a run takes well under a minute).
TIMEOUT = 240


# The input of each filter on a large extent (1: the impact case for Material), 0 for the tiny one.
EXTENT = {"AdaptiveTetrahedra": 127, "AdaptiveIsosurface": 127, "AdaptiveIntervalVolume": 127,
          "MaterialInterfaceApproximation": 1, "ProgressiveTetrahedralMesh": 48}


def counts(algorithm):
    """Cells and points of every output port of this rank."""
    out = []
    for port in range(algorithm.GetNumberOfOutputPorts()):
        data = algorithm.GetOutputDataObject(port)
        out += [data.GetNumberOfCells(), data.GetNumberOfPoints()]
    return out


def child(name, mode, impact, prefix):
    simple = dc.require_plugin()
    from vtkmodules.vtkParallelCore import vtkMultiProcessController

    rank = vtkMultiProcessController.GetGlobalController().GetLocalProcessId()
    _, warm = make(simple, name, 0, impact)  # libraries, thread pools, the core's reserve
    warm.UpdatePipeline()
    source, filt = make(simple, name, EXTENT[name], impact)
    source.UpdatePipeline()
    algorithm = filt.GetClientSideObject()
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    if rank == 1 and mode != "none":
        resource.setrlimit(resource.RLIMIT_AS, (vm_size() + int(mode) * MiB, hard))
    with dc.ErrorCapture(filt) as errors:
        filt.UpdatePipeline()
    resource.setrlimit(resource.RLIMIT_AS, (soft, hard))
    result = {"rank": rank, "counts": counts(algorithm), "errors": errors.text()}
    # The same session, the limit lifted: the filter works again on every rank.
    algorithm.Modified()
    with dc.ErrorCapture(filt) as again:
        algorithm.UpdatePiece(rank, 2, 0)  # this rank's piece, as the proxy requested it
    result["again"] = counts(algorithm)
    result["again_errors"] = again.text()
    with open(f"{prefix}{rank}.json", "w") as f:  # one file per rank: their prints interleave
        json.dump(result, f)


def run_symmetric(script, args, prefix, timeout):
    """Runs `script --child *args prefix` on 2 ranks (`mpiexec -n 2 pvbatch --symmetric`) under
    `timeout` seconds (a hang is a failure: exit code 124); returns the process and the results the
    ranks wrote, {rank: the JSON in f"{prefix}{rank}.json"}."""
    cmd = ["timeout", str(timeout), "mpiexec", "--allow-run-as-root", "--oversubscribe", "-n", "2",
           "pvbatch", "--symmetric", os.path.abspath(script), "--child", *args, prefix]
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_", "OPAL_"))}
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    results = {}
    for rank in (0, 1):
        if os.path.exists(f"{prefix}{rank}.json"):
            with open(f"{prefix}{rank}.json") as f:
                results[rank] = json.load(f)
    return proc, results


def run_child(name, mode, impact):
    prefix = os.path.join(os.path.dirname(impact), f"{name}-{mode}-rank")
    return run_symmetric(__file__, [name, mode, impact], prefix, TIMEOUT)


def main():
    dc.require_plugin()  # fails early without the plugin
    tmp = tempfile.mkdtemp(prefix="diamonds-mpi-memory-")
    impact = os.path.join(tmp, "impact.vti")
    subprocess.run([dc.diamonds_binary(), "generate", impact, "--field", "impact", "--dims", "64", "64", "104"],
                   check=True, stdout=subprocess.DEVNULL)
    for name in FILTERS:
        proc, reference = run_child(name, "none", impact)
        if not dc.check(proc.returncode == 0 and sorted(reference) == [0, 1]
                        and not any(r["errors"] for r in reference.values())
                        and all(r["counts"][0] > 0 for r in reference.values()),
                        f"{name}: unlimited run on 2 ranks ({reference})"):
            print(proc.stdout[-2000:], proc.stderr[-2000:])
            continue
        full = {rank: r["counts"] for rank, r in reference.items()}
        ran_out = 0
        for mode in HEADROOMS:
            label = f"{name}, rank 1 with {mode} MiB of headroom"
            proc, results = run_child(name, mode, impact)
            finished = proc.returncode == 0 and sorted(results) == [0, 1]
            if not dc.check(finished, f"{label}: every rank finishes (exit code {proc.returncode}"
                            f"{', timed out: hung' if proc.returncode == 124 else ''})"):
                tail = [line for line in (proc.stdout + proc.stderr).splitlines() if line.strip()][-8:]
                print("\n".join("     " + line[:200] for line in tail))
                continue
            dc.check(all(results[r]["again"] == full[r] and not results[r]["again_errors"] for r in (0, 1)),
                     f"{label}: run again, the same session gets the full result on every rank "
                     f"({[results[r]['again'] for r in (0, 1)]})")
            failed = [r for r in (0, 1) if results[r]["errors"]]
            if not failed:
                dc.check(all(results[r]["counts"] == full[r] for r in (0, 1)),
                         f"{label}: completed with the unlimited result on every rank")
                continue
            for r in (0, 1):
                last = (results[r]["errors"].strip().splitlines() or ["(no error)"])[-1]
                print(f"   [{label}, rank {r}] {last[:240]}")
            if name == "ProgressiveTetrahedralMesh" and not results[0]["errors"]:
                dc.check(results[0]["counts"] == full[0] and not any(results[1]["counts"]),
                         f"{label}: rank 1's output is empty, rank 0's its own piece in full (rank 1 failed in "
                         f"its own reduction)")
            else:
                dc.check(all(not any(results[r]["counts"]) for r in (0, 1)),
                         f"{label}: every rank's output is empty")
                dc.check(any(words in results[0]["errors"] for words in ("another rank", "rank 1 ")),
                         f"{label}: rank 0 says another rank failed")
            ran_out += 1
            dc.check("memory" in results[1]["errors"].lower(), f"{label}: rank 1's error says memory ran out")
        dc.check(ran_out > 0, f"{name}: the sweep ran out of memory at least once ({ran_out} of {len(HEADROOMS)})")
    dc.finish("mpi_memory_limit")


if __name__ == "__main__":
    if "--child" in sys.argv:
        i = sys.argv.index("--child")
        child(*sys.argv[i + 1:i + 5])
    else:
        main()
