#!/usr/bin/env bash
# Benchmarks against the VTK filters a user would use instead, on ../shared/data: Adaptive Tetrahedra vs
# Tetrahedralize, Adaptive Isosurface vs Flying Edges (+ decimation, + fast-simplification), Material
# Interface Approximation with ghost values vs plain interpolation and vs Youngs' interfaces. Writes docs/benchmarks.md,
# docs/images/isosurface-hausdorff.png and docs/images/material-interfaces.png. Needs the build
# (bash scripts/setup.sh).
# Not a test: it measures, it does not assert.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
bash scripts/setup.sh >/dev/null
cargo build --release --locked -p diamonds-cli   # the material benchmark generates its data with it
# bench.py writes the file's header and the Adaptive Tetrahedra tables; the others append or replace
# their own sections: start from an empty file.
: >docs/benchmarks.md
pvpython scripts/bench.py "$@"
pvpython scripts/bench_isosurface.py
pvpython scripts/bench_isovalue_change.py
pvpython scripts/bench_interval.py
# Issue 11's goals compare with fast-simplification (PyPI), a benchmark dependency only: it lives in a
# virtual environment of Debian's python3 (python3-venv), created once.
if ! dpkg-query -W -f='${Status}' python3-venv 2>/dev/null | grep -q "install ok installed"; then
  SUDO=(); [ "$(id -u)" -ne 0 ] && SUDO=(sudo)
  "${SUDO[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends python3-venv
fi
[ -x build/bench-venv/bin/python ] || /usr/bin/python3 -m venv build/bench-venv
build/bench-venv/bin/python -c "import fast_simplification" 2>/dev/null ||
  build/bench-venv/bin/pip install --quiet fast-simplification==0.2.0
pvpython scripts/bench_isosurface_goals.py
xvfb-run -a pvbatch scripts/bench_material.py
