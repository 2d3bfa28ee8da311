#!/usr/bin/env bash
# Sets everything up on a fresh Debian 12 machine (system packages, build, install) and runs the main job
# on the embedded default volume: ParaView's Wavelet at 65^3 → Adaptive Tetrahedra →
#   out/demo.vtu  (the adaptive tetrahedral mesh)   out/demo.png  (a screenshot rendered by pvbatch)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
bash scripts/setup.sh
mkdir -p out
xvfb-run -a pvbatch scripts/demo.py --output out "$@"
echo "==> wrote $(pwd)/out/demo.vtu and $(pwd)/out/demo.png"
