#!/usr/bin/env bash
# Benchmarks against the VTK filters a user would use instead, on ../shared/data: Adaptive Tetrahedra vs
# Tetrahedralize, Adaptive Isosurface vs Flying Edges (+ decimation), Material Interface Approximation
# with ghost values vs plain interpolation and vs Youngs' interfaces. Writes docs/benchmarks.md,
# docs/images/isosurface-hausdorff.png and docs/images/material-interfaces.png. Needs the build
# (bash scripts/setup.sh).
# Not a test: it measures, it does not assert.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
bash scripts/setup.sh >/dev/null
cargo build --release --locked -p diamonds-cli   # the material benchmark generates its data with it
pvpython scripts/bench.py "$@"
pvpython scripts/bench_isosurface.py
pvpython scripts/bench_isovalue_change.py
xvfb-run -a pvbatch scripts/bench_material.py
