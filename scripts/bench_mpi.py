"""Benchmark of Adaptive Tetrahedra, Adaptive Isosurface and Adaptive Interval Volume on a distributed
image (issue 12): bonsai 256³ at Tolerance 8 (tetrahedra), at isovalue 40.5 (isosurface) or range
[78.5, 166.5] (interval volume) and 1 % of the diagonal, on 1 and 2 MPI ranks (`mpiexec -n R
pvbatch`), alternating, each run its own process group.

    python3 scripts/bench_mpi.py             # tetrahedra: runs the cases, replaces its section of docs/benchmarks.md
    python3 scripts/bench_mpi.py --iso       # the same for the isosurface (its own section)
    python3 scripts/bench_mpi.py --interval  # the same for the interval volume (its own section)
    python3 scripts/bench_mpi.py --iso --coordinates  # with a 3-component double point array too
                                                      # (the points' coordinates; its own section)

Per case: wall time of the first execution (hierarchy build + query; for the isosurface the fetch of
the image too; the interval volume's likewise) and of a second query on the kept hierarchies (Tolerance changed), cells, and per rank
the figures the filter reports in its field data: cells, seconds, bytes sent, seconds spent
exchanging, refinement rounds (tetrahedra) and peak resident memory. One rank runs the serial filter
(no field data per rank; its peak memory is the process's). Needs the build (bash scripts/setup.sh)
and ../shared. Not a test: it measures.
"""

import json
import os
import resource
import subprocess
import sys

from benchlib import replace_section  # scripts/benchlib.py, beside this file

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BONSAI = os.path.join(ROOT, "..", "shared", "data", "volumes", "bonsai_256x256x256_uint8_lossy.vti")
ISO = "--iso" in sys.argv
INTERVAL = "--interval" in sys.argv
MODE = "--iso" if ISO else "--interval" if INTERVAL else None
# Another point array the output interpolates: the coordinates, 3 doubles per point (403 MB whole).
COORDINATES = "--coordinates" in sys.argv and MODE is not None
ISOVALUE = 40.5
RANGE = [78.5, 166.5]  # Otsu's threshold and half-way to the maximum, as scripts/bench_interval.py
# Per filter: heading, tolerance, what its cells are, its count and per-rank field data.
CASE = {
    None: ("## Distributed Adaptive Tetrahedra (issue 12)", 8.0, "tetrahedra", "NumberOfTetrahedra", "TetrahedraPerRank"),
    "--iso": ("## Distributed Adaptive Isosurface (issue 12)", 0.01 * 255 * 3 ** 0.5, "triangles", "NumberOfTriangles",
              "TrianglesPerRank"),
    "--interval": ("## Distributed Adaptive Interval Volume (issue 12)", 0.01 * 255 * 3 ** 0.5, "tetrahedra",
                   "NumberOfTetrahedra", "TetrahedraPerRank"),
}[MODE]
HEADING, TOLERANCE, CELLS, COUNT, PER_RANK = CASE
if COORDINATES:
    HEADING = HEADING.replace(" (issue 12)", ", with a 3-component point array (issue 12)")
REPEATS = 2
ISO_NOTE = ("Every rank with a piece gathers the whole image of the contoured array (one all-gather of each "
            "rank's piece, `Pieces::GatherWhole`; the other point arrays are fetched only at the input points its "
            "share interpolates from, `Pieces::SourceTable`) and refines as the serial filter does, but shares the error measurement and the "
            "two-sided bound's check: each rank locates the surface samples of the cells it owns and checks the surface "
            "of the carriers and the cells of the full-resolution surface it owns, and the ranks all-gather the "
            "diamonds' error codes and each round's violations (`Partition`, `Ranks::Share`), then each writes its share: "
            "exact, the whole image on every rank (see *Across MPI pieces* in docs/ARCHITECTURE.md); a second query "
            "with the same input gathers nothing.")

INTERVAL_NOTE = ("The same scheme as the isosurface's above: every rank with a piece gathers the whole image of "
                 "the processed array (the other point arrays fetched at its share's sources only), refines as the serial filter does for the two bounding surfaces, sharing "
                 "the error measurement and the two-sided bound's check (`interval::extract_shared`), then clips "
                 "the whole volume and outputs the tetrahedra whose centroid its piece holds: exact, the whole "
                 "image on every rank.")

def measure():
    """One case, in pvbatch on rank 0: prints one JSON line."""
    import time

    from paraview import servermanager
    from paraview.simple import (AdaptiveIntervalVolume, AdaptiveIsosurface, AdaptiveTetrahedra, ProgrammableFilter,
                                 Calculator, XMLImageDataReader)

    reader = XMLImageDataReader(FileName=[BONSAI])
    if COORDINATES:
        reader = Calculator(Input=reader, ResultArrayName="coordinates", Function="coords")
    reader.UpdatePipeline()
    if ISO:
        filt = AdaptiveIsosurface(Input=reader, Isosurfaces=[ISOVALUE], Tolerance=TOLERANCE)
        filt.ContourBy = ["POINTS", "density"]
    elif INTERVAL:
        filt = AdaptiveIntervalVolume(Input=reader, ThresholdRange=RANGE, Tolerance=TOLERANCE)
        filt.Scalars = ["POINTS", "density"]
    else:
        filt = AdaptiveTetrahedra(Input=reader, Tolerance=TOLERANCE)
    # Rank 0's field data alone: fetching the mesh would copy rank 0's output into the measured peak.
    field = ProgrammableFilter(Input=filt, OutputDataSetType="vtkPolyData",
                               Script="self.GetOutput().GetFieldData().ShallowCopy(self.GetInput().GetFieldData())")
    t = time.perf_counter()
    filt.UpdatePipeline()
    first = time.perf_counter() - t
    fd = servermanager.Fetch(field, 0).GetFieldData()

    def values(name):
        a = fd.GetArray(name)
        return [a.GetTuple1(i) for i in range(a.GetNumberOfTuples())] if a else None

    first_bytes, first_exchange = values("BytesSentPerRank"), values("ExchangeSecondsPerRank")
    filt.Tolerance = TOLERANCE * (1 + 1e-9)
    t = time.perf_counter()
    filt.UpdatePipeline()
    second = time.perf_counter() - t
    fd = servermanager.Fetch(field, 0).GetFieldData()
    print("RESULT " + json.dumps({
        "first": first,
        "second": second,
        "tets": values(COUNT)[0],
        "tets_per_rank": values(PER_RANK),
        "seconds_per_rank": values("SecondsPerRank"),
        "bytes_per_rank": values("BytesSentPerRank"),
        "exchange_per_rank": values("ExchangeSecondsPerRank"),
        "first_bytes_per_rank": first_bytes,
        "first_exchange_per_rank": first_exchange,
        "peak_per_rank": values("PeakMemoryPerRank"),
        "rounds": (values("RefinementRounds") or [0])[0],
        "peak_rank0": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
    }), flush=True)


def run(ranks):
    env = dict(os.environ, PV_PLUGIN_PATH=os.path.join(ROOT, "build", "lib", "paraview-5.11", "plugins", "Diamonds"))
    out = subprocess.run(
        # Unbound: Open MPI binds each of up to two ranks to one core, which would leave one rank's
        # threads a single core of the two.
        ["mpiexec", "--allow-run-as-root", "--oversubscribe", "--bind-to", "none", "-n", str(ranks), "pvbatch",
         __file__, "--measure"]
        + ([MODE] if MODE else []) + (["--coordinates"] if COORDINATES else []),
        env=env, check=True, capture_output=True, text=True).stdout
    line = next(l for l in out.splitlines() if l.startswith("RESULT "))
    return json.loads(line[len("RESULT "):])


def megabytes(x):
    return f"{x / 1e6:.2f} MB" if x >= 1e4 else f"{x:.0f} B"


def seconds(x):
    return f"{x:.2f}"


def mib(x):
    return f"{x / 2**20:,.0f}"


def report(results):
    what = (f"isovalue {ISOVALUE:g}, Tolerance {TOLERANCE:.3g} (1 % of the diagonal)" if ISO
            else f"range [{RANGE[0]:g}, {RANGE[1]:g}], Tolerance {TOLERANCE:.3g} (1 % of the diagonal)" if INTERVAL
            else f"Tolerance {TOLERANCE:g}")
    if COORDINATES:
        what += (", with a point array of the points' coordinates (a Calculator's `coords`: 3 doubles per point, "
                 "403 MB for the whole image) which the output interpolates")
    lines = [HEADING, "",
             f"Bonsai 256³ (u8), {what}, `mpiexec --bind-to none -n R pvbatch` on this 2-core machine "
             "(R ranks share the two cores; each rank's core threads too). Wall times are medians of alternating runs; per-rank "
             "figures are the filter's field data of the last run (seconds; bytes sent and seconds spent in exchanges, "
             "waiting for the other ranks included, of the first execution and of the second query; the peak is the "
             "process's resident set since it started, ParaView included; only the field data is fetched, not the mesh). One rank runs the "
             "serial filter.", "",
             f"| ranks | first execution s | second query s | {CELLS} | {CELLS} per rank | bytes sent per rank, first "
             "| exchange s per rank, first | bytes sent per rank, second | exchange s per rank, second | rounds "
             "| peak RSS per rank MiB |",
             "|---:|---:|---:|---:|---|---|---|---|---|---:|---|"]
    for ranks, runs in results:
        med = lambda k: sorted(r[k] for r in runs)[len(runs) // 2]
        r = runs[-1]
        per = lambda k, f: " / ".join(f(v) for v in r[k]) if r[k] else "—"
        peak = per("peak_per_rank", mib) if r["peak_per_rank"] else mib(r["peak_rank0"])
        lines.append(
            f"| {ranks} | {med('first'):.2f} | {med('second'):.2f} | {int(r['tets']):,} | "
            f"{per('tets_per_rank', lambda v: f'{int(v):,}')} | {per('first_bytes_per_rank', megabytes)} | "
            f"{per('first_exchange_per_rank', seconds)} | {per('bytes_per_rank', megabytes)} | "
            f"{per('exchange_per_rank', seconds)} | {int(r['rounds']) if r['rounds'] else '—'} | {peak} |")
    if ISO:
        lines += ["", ISO_NOTE]
    if INTERVAL:
        lines += ["", INTERVAL_NOTE]
    lines.append("")
    return lines


def main():
    if not os.path.exists(BONSAI):
        print(f"{BONSAI} not found: skipped")
        return
    results = {1: [], 2: []}
    for _ in range(REPEATS):
        for ranks in (1, 2):
            results[ranks].append(run(ranks))
            print(ranks, results[ranks][-1], flush=True)
    lines = report(sorted(results.items()))
    print("\n".join(lines))
    replace_section(HEADING, lines)


if __name__ == "__main__":
    if "--measure" in sys.argv:
        measure()
    else:
        main()
