#!/usr/bin/env bash
# Benchmark Adaptive Tetrahedra against ParaView's Tetrahedralize on ../shared/data/volumes and write
# docs/benchmarks.md. Needs the build (bash scripts/setup.sh). Not a test: it measures, it does not assert.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
bash scripts/setup.sh >/dev/null
exec pvpython scripts/bench.py "$@"
