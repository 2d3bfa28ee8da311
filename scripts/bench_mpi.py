"""Benchmark of Adaptive Tetrahedra on a distributed image (issue 12): bonsai 256³ at Tolerance 8 on
1 and 2 MPI ranks (`mpiexec -n R pvbatch`), alternating, each run its own process group.

    python3 scripts/bench_mpi.py          # runs the cases, replaces its section of docs/benchmarks.md

Per case: wall time of the first execution (hierarchy build + query) and of a second query on the
kept hierarchies (Tolerance changed), tetrahedra, and per rank the figures the filter reports in its
field data: tetrahedra, seconds, bytes sent, seconds spent exchanging, refinement rounds and peak
resident memory. One rank runs the serial filter (no field data per rank; its peak memory is the
process's). Needs the build (bash scripts/setup.sh) and ../shared. Not a test: it measures.
"""

import json
import os
import resource
import subprocess
import sys

from benchlib import replace_section  # scripts/benchlib.py, beside this file

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BONSAI = os.path.join(ROOT, "..", "shared", "data", "volumes", "bonsai_256x256x256_uint8_lossy.vti")
HEADING = "## Distributed Adaptive Tetrahedra (issue 12)"
TOLERANCE = 8.0
REPEATS = 2


def measure():
    """One case, in pvbatch on rank 0: prints one JSON line."""
    import time

    from paraview import servermanager
    from paraview.simple import AdaptiveTetrahedra, XMLImageDataReader

    reader = XMLImageDataReader(FileName=[BONSAI])
    reader.UpdatePipeline()
    filt = AdaptiveTetrahedra(Input=reader, Tolerance=TOLERANCE)
    t = time.perf_counter()
    filt.UpdatePipeline()
    first = time.perf_counter() - t
    filt.Tolerance = TOLERANCE * (1 + 1e-9)
    t = time.perf_counter()
    filt.UpdatePipeline()
    second = time.perf_counter() - t
    piece = servermanager.Fetch(filt, 0)
    fd = piece.GetFieldData()

    def values(name):
        a = fd.GetArray(name)
        return [a.GetTuple1(i) for i in range(a.GetNumberOfTuples())] if a else None

    print("RESULT " + json.dumps({
        "first": first,
        "second": second,
        "tets": values("NumberOfTetrahedra")[0],
        "tets_per_rank": values("TetrahedraPerRank"),
        "seconds_per_rank": values("SecondsPerRank"),
        "bytes_per_rank": values("BytesSentPerRank"),
        "exchange_per_rank": values("ExchangeSecondsPerRank"),
        "peak_per_rank": values("PeakMemoryPerRank"),
        "rounds": (values("RefinementRounds") or [0])[0],
        "peak_rank0": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
    }), flush=True)


def run(ranks):
    env = dict(os.environ, PV_PLUGIN_PATH=os.path.join(ROOT, "build", "lib", "paraview-5.11", "plugins", "Diamonds"))
    out = subprocess.run(
        ["mpiexec", "--allow-run-as-root", "--oversubscribe", "-n", str(ranks), "pvbatch", __file__, "--measure"],
        env=env, check=True, capture_output=True, text=True).stdout
    line = next(l for l in out.splitlines() if l.startswith("RESULT "))
    return json.loads(line[len("RESULT "):])


def mib(x):
    return f"{x / 2**20:,.0f}"


def report(results):
    lines = [HEADING, "",
             f"Bonsai 256³ (u8), Tolerance {TOLERANCE:g}, `mpiexec -n R pvbatch` on this 2-core machine (R ranks share "
             "the two cores; each rank's core threads too). Wall times are medians of alternating runs; per-rank "
             "figures are the filter's field data of the last execution, the second query (seconds, bytes sent, "
             "seconds spent in exchanges, waiting for the other rank included; the peak is the process's resident "
             "set since it started, ParaView and the fetched result included). One rank runs the serial filter.", "",
             "| ranks | first execution s | second query s | tetrahedra | tetrahedra per rank | bytes sent per rank "
             "| exchange s per rank | rounds | peak RSS per rank MiB |",
             "|---:|---:|---:|---:|---|---|---|---:|---|"]
    for ranks, runs in results:
        med = lambda k: sorted(r[k] for r in runs)[len(runs) // 2]
        r = runs[-1]
        per = lambda k, f: " / ".join(f(v) for v in r[k]) if r[k] else "—"
        peak = per("peak_per_rank", mib) if r["peak_per_rank"] else mib(r["peak_rank0"])
        lines.append(
            f"| {ranks} | {med('first'):.2f} | {med('second'):.2f} | {int(r['tets']):,} | "
            f"{per('tets_per_rank', lambda v: f'{int(v):,}')} | {per('bytes_per_rank', lambda v: f'{v / 1e6:.2f} MB')} | "
            f"{per('exchange_per_rank', lambda v: f'{v:.2f}')} | {int(r['rounds']) if r['rounds'] else '—'} | {peak} |")
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
