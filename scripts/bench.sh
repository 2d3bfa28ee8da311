#!/usr/bin/env bash
# Benchmarks against the VTK filters a user would use instead, on ../shared/data/volumes: Adaptive
# Tetrahedra vs Tetrahedralize, then Adaptive Isosurface vs Flying Edges (+ decimation). Writes
# docs/benchmarks.md and docs/images/isosurface-hausdorff.png. Needs the build (bash scripts/setup.sh).
# Not a test: it measures, it does not assert.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
bash scripts/setup.sh >/dev/null
pvpython scripts/bench.py "$@"
pvpython scripts/bench_isosurface.py
