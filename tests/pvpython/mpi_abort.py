"""A user's abort (AbortExecute, as a click on ParaView's Abort) ends the filters on every MPI rank
together, and the next Apply after a property change recomputes: no hang, no stale abort. Run with

  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds pvpython tests/pvpython/mpi_abort.py

Serial part (this process), for every filter the plugin runs on an image: an observer sets
AbortExecute once, at the first progress report inside the execution (after the hierarchy build
started) or at the very first report (the executive's, before the filter runs); then
- every output port is empty and no error is reported (an abort is not an error);
- the test does not touch the flag again: the property is set back and UpdatePipeline recomputes
  exactly the result of the run before the abort (cells and points of every port), and the flag is
  clear afterwards.
Before, VTK 9.2 (ParaView 5.11) left the flag set: every later update aborted at once.

Distributed part: for Adaptive Tetrahedra, Adaptive Isosurface, Adaptive Interval Volume and
Material Interface Approximation, a child `mpiexec -n 2 pvbatch --symmetric` (under `timeout`: a hang is a failure)
runs, in one session, aborts on rank 1 and on rank 0, during the first execution (in the hierarchy
build) and at the start of later ones, each followed by a property change and UpdatePipeline (every
output port, as Apply). Every rank exits 0; after each abort every port of every rank is empty and
no rank reports an error; after each recomputation the ranks' outputs equal the first complete
run's, rank by rank, their cell total equals the serial result, and no rank's flag is left set.
Before, an abort on one rank of Adaptive Isosurface or Material Interface Approximation hung both:
the aborting rank alone had its outputs marked ABORTED, so the request for the second port
executed the filter there again, alone, and it waited in a collective no other rank entered.
(Progressive Tetrahedral Mesh and View Dependent Tetrahedra do not run distributed: they are in
the serial part.)
"""

import json
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import diamonds_checks as dc  # noqa: E402
from mpi_memory_limit import counts, run_symmetric  # noqa: E402
from test_memory_limit import make  # noqa: E402

DISTRIBUTED = ["AdaptiveTetrahedra", "AdaptiveIsosurface", "AdaptiveIntervalVolume", "MaterialInterfaceApproximation"]
SERIAL = DISTRIBUTED + ["ProgressiveTetrahedralMesh"]
# The input's extent (Wavelet 0..EXTENT; the impact case for Material at its coarse tolerances).
EXTENT = 24
# Seconds a child may take before it counts as hung (it takes about 20 s).
TIMEOUT = 240
# The aborts of a child: (rank that aborts, when); "inside": at its first progress report inside
# the filter (the first execution builds the hierarchy), "start": at the executive's first report.
ABORTS = [(1, "inside"), (0, "start"), (1, "start"), (0, "inside")]
WHEN = {"inside": "inside the execution", "start": "at its start"}


def changed_property(name):
    """The property a user changes before applying again, and its two values (first, aborted)."""
    return {
        "AdaptiveTetrahedra": ("Tolerance", 2.0, 4.0),
        "AdaptiveIsosurface": ("Tolerance", 0.0, 0.5),
        "AdaptiveIntervalVolume": ("Tolerance", 0.0, 0.5),
        "MaterialInterfaceApproximation": ("InterfaceTolerance", 0.5, 0.4),
        "ProgressiveTetrahedralMesh": ("TargetReduction", 0.9, 0.8),
    }[name]


def setup(simple, name, impact):
    source, filt = make(simple, name, 0 if name == "MaterialInterfaceApproximation" else EXTENT, impact)
    if name == "AdaptiveIsosurface":
        filt.GenerateCarrierTetrahedra = 1  # both output ports carry cells
    prop, first, _ = changed_property(name)
    setattr(filt, prop, first)
    return filt


def aborted_update(filt, when, aborting=True):
    """UpdatePipeline (every output port) with an observer that sets AbortExecute once, `when`
    ("inside" or "start"); returns (counts, errors, whether the abort was requested)."""
    from vtkmodules.vtkCommonCore import vtkCommand

    algorithm = filt.GetClientSideObject()
    clicked = []

    def abort_once(obj, _event):  # as a user's click on Abort: once
        progress = obj.GetProgress()
        if aborting and not clicked and (when == "start" or 0.0 < progress < 1.0):
            clicked.append(progress)
            obj.SetAbortExecute(1)

    tag = algorithm.AddObserver(vtkCommand.ProgressEvent, abort_once)
    with dc.ErrorCapture(filt) as errors:
        filt.UpdatePipeline()
    algorithm.RemoveObserver(tag)
    return counts(algorithm), errors.text(), bool(clicked)


def update(filt):
    with dc.ErrorCapture(filt) as errors:
        filt.UpdatePipeline()
    algorithm = filt.GetClientSideObject()
    return counts(algorithm), errors.text(), algorithm.GetAbortExecute()


def child(name, impact, prefix):
    """One rank of a distributed run: the aborts of ABORTS, each followed by a recomputation."""
    simple = dc.require_plugin()
    from vtkmodules.vtkParallelCore import vtkMultiProcessController

    rank = vtkMultiProcessController.GetGlobalController().GetLocalProcessId()
    filt = setup(simple, name, impact)
    prop, first, second = changed_property(name)
    runs = []
    for aborter, when in ABORTS:
        setattr(filt, prop, second)
        got, errors, clicked = aborted_update(filt, when, aborting=rank == aborter)
        runs.append({"counts": got, "errors": errors, "clicked": clicked})
        setattr(filt, prop, first)  # the user changes a property and applies again
        got, errors, flag = update(filt)
        runs.append({"counts": got, "errors": errors, "flag": flag})
    with open(f"{prefix}{rank}.json", "w") as f:  # one file per rank: their prints interleave
        json.dump(runs, f)


def serial(simple, name, impact):
    """The serial checks; returns the complete result at the first property value."""
    filt = setup(simple, name, impact)
    prop, first, second = changed_property(name)
    full, errors, _ = update(filt)
    dc.check(full[0] > 0 and not errors, f"{name}, serial: complete result {full} ({errors.strip()[:200]!r})")
    for when in ("inside", "start"):
        setattr(filt, prop, second)
        got, errors, clicked = aborted_update(filt, when)
        dc.check(clicked and not any(got) and not errors,
                 f"{name}, serial, abort {WHEN[when]}: every port empty, no error ({got}, {errors.strip()[:200]!r})")
        setattr(filt, prop, first)
        got, errors, flag = update(filt)
        dc.check(got == full and not errors and not flag,
                 f"{name}, serial: {prop} changed after the abort, the flag untouched: recomputed "
                 f"({got} == {full}, flag {flag})")
    simple.Delete(filt)
    return full


def main():
    simple = dc.require_plugin()
    tmp = tempfile.mkdtemp(prefix="diamonds-mpi-abort-")
    impact = os.path.join(tmp, "impact.vti")
    subprocess.run([dc.diamonds_binary(), "generate", impact, "--field", "impact", "--dims", "64", "64", "104"],
                   check=True, stdout=subprocess.DEVNULL)
    reference = {name: serial(simple, name, impact) for name in SERIAL}
    for name in DISTRIBUTED:
        proc, results = run_symmetric(__file__, [name, impact], os.path.join(tmp, f"{name}-rank"), TIMEOUT)
        if not dc.check(proc.returncode == 0 and sorted(results) == [0, 1],
                        f"{name}, 2 ranks: every rank finishes (exit code {proc.returncode}"
                        f"{', timed out: hung' if proc.returncode == 124 else ''})"):
            tail = [line for line in (proc.stdout + proc.stderr).splitlines() if line.strip()][-8:]
            print("\n".join("     " + line[:200] for line in tail))
            continue
        complete = {r: results[r][1]["counts"] for r in (0, 1)}
        total = complete[0][0] + complete[1][0]
        dc.check(total == reference[name][0] and all(complete[r][0] > 0 for r in (0, 1)),
                 f"{name}, 2 ranks: cells per rank {[complete[r][0] for r in (0, 1)]}, total {total} "
                 f"== serial {reference[name][0]}")
        for k, (aborter, when) in enumerate(ABORTS):
            label = f"{name}, 2 ranks, abort on rank {aborter} {WHEN[when]}"
            aborted = {r: results[r][2 * k] for r in (0, 1)}
            again = {r: results[r][2 * k + 1] for r in (0, 1)}
            dc.check(aborted[aborter]["clicked"], f"{label}: the abort was requested")
            dc.check(all(not any(aborted[r]["counts"]) and not aborted[r]["errors"] for r in (0, 1)),
                     f"{label}: every port of every rank empty, no error "
                     f"({[aborted[r]['counts'] for r in (0, 1)]}, "
                     f"{[aborted[r]['errors'].strip()[:160] for r in (0, 1)]})")
            dc.check(all(again[r]["counts"] == complete[r] and not again[r]["errors"] and not again[r]["flag"]
                         for r in (0, 1)),
                     f"{label}: property changed, the flag untouched: every rank recomputes the "
                     f"complete result ({[again[r]['counts'] for r in (0, 1)]})")
    dc.finish("mpi_abort")


if __name__ == "__main__":
    if "--child" in sys.argv:
        i = sys.argv.index("--child")
        child(*sys.argv[i + 1:i + 4])
    else:
        main()
