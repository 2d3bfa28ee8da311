"""Fuzzes the distributed image filters' equality with the serial result on random layouts (run by
hand, not by the tests: it is a search, not a check with a known answer).

    PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds DIAMONDS_EXPECTED_RANKS=3 \\
      mpiexec --allow-run-as-root --oversubscribe -n 3 pvbatch scripts/fuzz_mpi_layouts.py \\
      {mpi_pieces|mpi_isosurface|mpi_interval|mpi_material} [--cases N] [--seed S]

Each case is ParaView's Wavelet over a random whole extent, as users' pipelines give them: starts
anywhere in -20..20 (negative, zero or positive; the default Wavelet's is -10), 2 to 41 points per
axis, some axes of 2 to 4 points, so that ParaView splits it into pieces of odd sizes and leaves
some ranks empty. The filter of the named test (Adaptive Tetrahedra, Adaptive Isosurface or
Adaptive Interval Volume) runs on it at a random tolerance (0 included) and isovalue or range, and
that test's own `check_distributed` compares every rank's output with the CLI's serial result
(same cells or triangles, each on one rank, conforming or watertight across the seams, global ids,
per-rank figures). For mpi_material a case is the generated impact image (`diamonds generate
--field impact`) on random dimensions alike, with random tolerances, slice plane and fields
(per-material densities or not), through that test's `check_case` (the serial tetrahedra,
interfaces and slice, each on one rank, crack-free, tolerances met). The test's definitions are
taken from its script, everything before its first case. Prints the test's lines and summary;
exits 1 when a check failed. `cargo build --release -p diamonds-cli` first.
"""

import argparse
import os
import random
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
a = argparse.ArgumentParser()
a.add_argument("test", choices=["mpi_pieces", "mpi_isosurface", "mpi_interval", "mpi_material"])
a.add_argument("--cases", type=int, default=12)
a.add_argument("--seed", type=int, default=1)
args = a.parse_args()

path = os.path.join(os.path.dirname(HERE), "tests", "pvpython", args.test + ".py")
source = open(path).read()
sys.argv = [path]
test = {"__file__": path, "__name__": "fuzz"}
first_case = "# ---- The impact case on odd sizes" if args.test == "mpi_material" else "# A generated image of odd sizes"
exec(compile(source[:source.index(first_case)], path, "exec"), test)
dc, simple = test["dc"], test["simple"]

rng = random.Random(args.seed)


def material_case(n):
    """The impact image on random dimensions through mpi_material's check_case."""
    dims = [rng.choice([2, 3, 4, rng.randint(5, 41)]) for _ in range(3)]
    path = os.path.join(test["workdir"], f"fuzz-{args.seed}-{n}.vti")
    subprocess.run([dc.diamonds_binary(), "generate", path, "--field", "impact", "--dims", *map(str, dims)],
                   check=True, stdout=subprocess.DEVNULL)
    reader = simple.XMLImageDataReader(FileName=[path])
    # The impact domain [0,12]x[0,12]x[-16,4.8]: a slice through it along a random direction.
    origin = [rng.uniform(0, 12), rng.uniform(0, 12), rng.uniform(-16, 4.8)]
    normal = [rng.uniform(-1, 1) for _ in range(3)]
    normal[rng.randrange(3)] += 2.0  # never zero
    fractions = test["IMPACT_FRACTIONS"]
    per_material = rng.random() < 0.5
    interface, field = rng.choice([0.05, 0.15, 0.5]), rng.choice([0.0, 0.5, 3.0, 10.0])
    label = f"seed {args.seed} case {n}: impact {dims[0]}x{dims[1]}x{dims[2]}, tolerances {interface} {field}" + (
        ", per-material densities" if per_material else "")
    filt = test["check_case"](reader, path, label, fractions, ["Density"],
                              [f"Density for {m}" for m in ("Void", "Block", "Projectile")] if per_material else [],
                              interface, field, origin + normal)
    simple.Delete(filt)
    simple.Delete(reader)


for n in range(args.cases):
    if args.test == "mpi_material":
        material_case(n)
        continue
    check = test["check_distributed"]
    whole = []
    for _ in range(3):
        lo = rng.randint(-20, 20)
        whole += [lo, lo + rng.choice([1, 2, 3, rng.randint(4, 40)])]
    wavelet, image = dc.wavelet(simple, whole)
    label = f"seed {args.seed} case {n}: extent {whole}"
    lo, hi = image.GetPointData().GetArray("RTData").GetRange()
    level = lambda: round(lo + (hi - lo) * rng.random(), 3)  # noqa: E731
    if args.test == "mpi_pieces":
        tolerance = rng.choice([0.0, 1.0, 4.0, 12.0])
        filt = check(wavelet, image, "RTData", tolerance, f"{label}, tolerance {tolerance}")
    elif args.test == "mpi_isosurface":
        iso, tolerance = [level()], rng.choice([0.0, 0.3, 1.0, 3.0])
        filt = check(wavelet, image, "RTData", iso, tolerance, f"{label}, isovalue {iso}, tolerance {tolerance}")
    else:
        value_range, tolerance = sorted([level(), level()]), rng.choice([0.0, 0.3, 1.0, 3.0])
        filt = check(wavelet, image, "RTData", value_range, tolerance, f"{label}, range {value_range}, tolerance {tolerance}")
    if filt is not None:
        simple.Delete(filt)
    simple.Delete(wavelet)
test["RANKS"].finish(f"fuzz_mpi_layouts {args.test}")
