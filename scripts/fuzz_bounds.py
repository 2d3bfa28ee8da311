#!/usr/bin/env python3
"""Fuzzes the product's error bounds through the CLI, as users' unseen data would (run by hand, not by
the tests: it is a search, not a check with a known answer).

    python3 scripts/fuzz_bounds.py [--cases N] [--seed S] [--keep DIR]

Each case generates a volume (.vti, written here with the standard library) of random dimensions
(other than 2^k + 1 as often as not), spacing per axis and origin, sample type u8, i16 or f32, from a
random mix of what real data holds: smooth blobs, noise, thin tubes, single-sample specks, plateaus
(rows repeated along an axis, values clamped) and integer quantisation (so that levels equal sample
values). It then runs, each with the independent checker of its output:

- `diamonds tetra --tolerance T` then `diamonds verify` (every sample within T, conforming);
- `diamonds iso --isovalue V --tolerance T` then `diamonds verify-surface --isovalue V --tolerance T`
  (both one-sided Hausdorff distances to the full-resolution surface), and the same for a second
  isovalue together with the first (its level drawn from a generator of its own, so that adding this
  step left every other case of a seed as it was);
- `diamonds interval --range A B --tolerance T` then `diamonds verify-interval --tolerance T`
  (conforming, values in the range, both distances to the full-resolution boundary);
- in half the cases, the surface and the interval volume again with a region of interest (a random
  box meeting the image, `--roi`), measured inside it (`verify-surface`/`verify-interval --roi`);

T a fraction of the diagonal (0.5 to 8 %).

Levels are drawn from the samples themselves (ties), halfway between two sample values, or at random
in the range. Prints one line per failure with the commands to reproduce it (the volume is kept in
--keep DIR, default a temporary directory that is removed when nothing failed) and a summary; exits 1
when anything failed. `cargo build --release -p diamonds-cli` first.
"""

import argparse
import base64
import math
import os
import random
import shutil
import struct
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXE = os.path.join(ROOT, "target", "release", "diamonds")
TYPES = {"u8": ("UInt8", "B", 0, 255), "i16": ("Int16", "h", -32768, 32767), "f32": ("Float32", "f", None, None)}


def write_vti(path, dims, origin, spacing, values, type_name):
    """A VTK XML ImageData file with one point array 'f', inline binary (base64, UInt32 header)."""
    vtk_type, code, _, _ = TYPES[type_name]
    raw = struct.pack(f"<{len(values)}{code}", *values)
    data = base64.b64encode(struct.pack("<I", len(raw)) + raw).decode()
    extent = " ".join(f"0 {d - 1}" for d in dims)
    with open(path, "w") as f:
        f.write('<?xml version="1.0"?>\n<VTKFile type="ImageData" version="0.1" byte_order="LittleEndian" '
                'header_type="UInt32">\n')
        f.write(f'<ImageData WholeExtent="{extent}" Origin="{" ".join(map(repr, origin))}" '
                f'Spacing="{" ".join(map(repr, spacing))}">\n<Piece Extent="{extent}">\n')
        f.write(f'<PointData Scalars="f"><DataArray type="{vtk_type}" Name="f" format="binary">{data}'
                '</DataArray></PointData>\n<CellData/>\n</Piece>\n</ImageData>\n</VTKFile>\n')


def volume(rng):
    """Random dimensions, geometry, type and samples; returns (dims, origin, spacing, type, values,
    description)."""
    def size():
        return rng.choice([rng.randint(9, 48), 2 ** rng.randint(3, 5) + 1])

    dims = [size(), size(), size()]
    spacing = [rng.choice([1.0, round(rng.uniform(0.3, 3.0), 3)]) for _ in range(3)]
    origin = [round(rng.uniform(-50, 50), 2) for _ in range(3)]
    type_name = rng.choice(["u8", "u8", "i16", "f32"])
    blobs = [([rng.uniform(0, d - 1) for d in dims], rng.uniform(1.5, 0.4 * max(dims)), rng.uniform(-1, 1))
             for _ in range(rng.randint(1, 8))]
    # Thin tubes along an axis: at (u, v) of the other two axes' extents, radius in voxels.
    tubes = [(rng.randrange(3), rng.random(), rng.random(), rng.uniform(0.3, 1.5)) for _ in range(rng.randint(0, 2))]
    noise = rng.choice([0.0, 0.0, 0.02, 0.1])
    repeat = rng.choice([None, None, rng.randrange(3)])  # rows repeated in pairs along an axis
    clamp = rng.choice([None, None, rng.uniform(0.3, 0.8)])  # values clamped: plateaus
    values = []
    for z in range(dims[2]):
        for y in range(dims[1]):
            for x in range(dims[0]):
                p = [x, y, z]
                if repeat is not None:
                    p[repeat] -= p[repeat] % 2
                f = 0.0
                for c, r, a in blobs:
                    d2 = sum((p[k] - c[k]) ** 2 for k in range(3))
                    f += a * math.exp(-d2 / (r * r))
                for axis, u, v, r in tubes:
                    (i, j) = [k for k in range(3) if k != axis]
                    d = math.hypot(p[i] - u * (dims[i] - 1), p[j] - v * (dims[j] - 1))
                    f = max(f, 1.0 - (d - r))
                f += noise * rng.uniform(-1, 1)
                if clamp is not None:
                    f = min(f, clamp)
                values.append(f)
    specks = rng.randint(0, 6)
    for _ in range(specks):
        values[rng.randrange(len(values))] = rng.choice([1.2, -1.2])
    lo, hi = min(values), max(values)
    if type_name == "f32":
        values = [struct.unpack("<f", struct.pack("<f", v))[0] for v in values]
    else:
        top = 255 if type_name == "u8" else rng.choice([255, 4095])
        scale = (top - 0.0) / (hi - lo) if hi > lo else 1.0
        values = [int(round((v - lo) * scale)) for v in values]
    what = (f"{dims[0]}x{dims[1]}x{dims[2]} {type_name} spacing {spacing} blobs {len(blobs)} tubes {len(tubes)} "
            f"noise {noise} specks {specks} repeat {repeat} clamp {clamp}")
    return dims, origin, spacing, type_name, values, what


def level(rng, values):
    """A level: a sample value (a tie), halfway between two distinct ones, or anywhere in the range."""
    distinct = sorted(set(values))
    if len(distinct) < 2:
        return distinct[0]
    kind = rng.choice(["sample", "half", "any"])
    k = rng.randrange(1, len(distinct) - 1) if len(distinct) > 2 else 1
    if kind == "sample":
        return distinct[k]
    if kind == "half":
        return 0.5 * (distinct[k - 1] + distinct[k])
    return rng.uniform(distinct[0], distinct[-1])


def num(v):
    """`v` for the command line."""
    return str(v) if isinstance(v, int) else repr(float(v))


def run(args):
    out = subprocess.run([EXE] + [str(a) for a in args], capture_output=True, text=True)
    return out.returncode, out.stdout + out.stderr


def case(rng, n, tmp, seed, execute=True):
    """Case `n`: its volume and levels are drawn from `rng` whether or not it is executed."""
    dims, origin, spacing, type_name, values, what = volume(rng)
    vti = os.path.join(tmp, f"case{n}.vti")
    write_vti(vti, dims, origin, spacing, values, type_name)
    failures = []
    lo, hi = min(values), max(values)
    fraction = rng.choice([0.005, 0.01, 0.02, 0.04, 0.08])
    # Adaptive Tetrahedra: a tolerance in data units.
    t = round(rng.choice([0.0, 0.01, 0.05, 0.2]) * (hi - lo), 6)
    vtu = os.path.join(tmp, f"case{n}-tetra.vtu")
    steps = [("tetra", ["tetra", vti, vtu, "--tolerance", num(t)], ["verify", vti, vtu, "--tolerance", num(t)])]
    # Surfaces: a fraction of the diagonal, in world units (the bound checked is the one asked for).
    tolerance = num(fraction * math.sqrt(sum(((d - 1) * s) ** 2 for d, s in zip(dims, spacing))))
    iso = level(rng, values)
    vtp = os.path.join(tmp, f"case{n}-iso.vtp")
    steps.append(("iso", ["iso", vti, vtp, "--isovalue", num(iso), "--tolerance", tolerance],
                  ["verify-surface", vtp, "--image", vti, "--isovalue", num(iso), "--tolerance", tolerance]))
    second = level(random.Random(f"{seed}:{n}"), values)
    if second != iso:
        both = os.path.join(tmp, f"case{n}-iso2.vtp")
        levels = [x for v in (iso, second) for x in ("--isovalue", num(v))]
        steps.append(("iso2", ["iso", vti, both, *levels, "--tolerance", tolerance],
                      ["verify-surface", both, "--image", vti, *levels, "--tolerance", tolerance]))
    a, b = sorted([level(rng, values), level(rng, values)])
    if a < b:
        ivtu = os.path.join(tmp, f"case{n}-interval.vtu")
        steps.append(("interval",
                      ["interval", vti, ivtu, "--range", num(a), num(b), "--tolerance", tolerance],
                      ["verify-interval", vti, ivtu, "--range", num(a), num(b), "--tolerance", tolerance]))
    # Half the cases again with a region of interest (a random box meeting the image), measured
    # inside it; drawn from a generator of its own, so that the other steps stay as they were.
    extra = random.Random(f"{seed}:{n}:roi")
    if extra.random() < 0.5:
        roi = []
        for d, s, o in zip(dims, spacing, origin):
            u, v = sorted([extra.uniform(-0.2, 1.2), extra.uniform(-0.2, 1.2)])
            u, v = min(u, 0.9), max(v, 0.1)
            roi += [num(round(o + u * (d - 1) * s, 3)), num(round(o + v * (d - 1) * s, 3))]
        region = ["--roi", *roi]
        rvtp = os.path.join(tmp, f"case{n}-iso-roi.vtp")
        steps.append(("iso-roi", ["iso", vti, rvtp, "--isovalue", num(iso), "--tolerance", tolerance, *region],
                      ["verify-surface", rvtp, "--image", vti, "--isovalue", num(iso), "--tolerance", tolerance,
                       *region]))
        if a < b:
            rvtu = os.path.join(tmp, f"case{n}-interval-roi.vtu")
            steps.append(("interval-roi",
                          ["interval", vti, rvtu, "--range", num(a), num(b), "--tolerance", tolerance, *region],
                          ["verify-interval", vti, rvtu, "--range", num(a), num(b), "--tolerance", tolerance,
                           *region]))
    for name, make, check in steps if execute else []:
        code, said = run(make)
        if code != 0:
            failures.append(f"{name}: {' '.join(map(str, make))} exited {code}: {said.strip()[-300:]}")
            continue
        code, said = run(check)
        if code != 0:
            bad = [line.strip() for line in said.splitlines() if "FAILED" in line][:1]
            failures.append(f"{name}: {' '.join(map(str, make))} && {' '.join(map(str, check))}: "
                            f"{bad[0][:300] if bad else said.strip()[-300:]}")
    return what, failures


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--cases", type=int, default=50)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--keep", help="directory for the volumes (kept)")
    p.add_argument("--only", type=int, help="run this case alone (the others are drawn, not run)")
    a = p.parse_args()
    if not os.path.exists(EXE):
        sys.exit(f"{EXE} missing: cargo build --release -p diamonds-cli")
    tmp = a.keep or tempfile.mkdtemp(prefix="fuzz-bounds-")
    os.makedirs(tmp, exist_ok=True)
    rng = random.Random(a.seed)
    failed = 0
    for n in range(a.cases):
        what, failures = case(rng, n, tmp, a.seed, a.only is None or a.only == n)
        for f in failures:
            print(f"case {n} ({what}): {f}", flush=True)
        failed += bool(failures)
        if not failures:
            for name in os.listdir(tmp):
                if name.startswith(f"case{n}.") or name.startswith(f"case{n}-"):
                    os.remove(os.path.join(tmp, name))
    print(f"{a.cases} cases, {failed} with failures (seed {a.seed}; volumes of failures in {tmp})")
    if not failed and not a.keep:
        shutil.rmtree(tmp)
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
