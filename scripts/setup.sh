#!/usr/bin/env bash
# Sets up Diamonds from a clean checkout on Debian 12 (idempotent; safe to run again):
#   1. installs the system packages that are missing (apt-get; sudo only when not root),
#   2. checks that cargo (Rust) is there,
#   3. configures, builds (cmake + ninja, -j2) and installs into build/install.
#
#   bash scripts/setup.sh
#
# Results:
#   build/lib/paraview-5.11/plugins/Diamonds/Diamonds.so          the ParaView plugin (build tree)
#   build/install/lib/paraview-5.11/plugins/Diamonds/Diamonds.so  the same, installed
#   build/install/lib/cmake/Diamonds/DiamondsConfig.cmake         find_package(Diamonds) for C++
# Use the plugin with: PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds pvpython ...
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

JOBS="${JOBS:-2}"
PACKAGES=(paraview-dev python3-paraview python3-numpy cmake ninja-build libopenmpi-dev openmpi-bin g++ xvfb xauth
  libglew-dev) # libglew-dev: ParaView::RemotingViews (the Adaptive Volume representation) links VTK::glew

if ! command -v apt-get >/dev/null 2>&1; then
  echo "error: apt-get not found. This script targets Debian 12; install the equivalents of" >&2
  echo "       ${PACKAGES[*]} and run the cmake commands below by hand." >&2
  exit 1
fi
missing=()
for pkg in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$pkg")
  fi
done
if ((${#missing[@]})); then
  SUDO=()
  if [ "$(id -u)" -ne 0 ]; then
    SUDO=(sudo)
  fi
  echo "==> installing system packages: ${missing[*]}"
  "${SUDO[@]}" apt-get update
  "${SUDO[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "${missing[@]}"
else
  echo "==> system packages already installed"
fi

if ! command -v cargo >/dev/null 2>&1; then
  if [ -x "${CARGO_HOME:-$HOME/.cargo}/bin/cargo" ]; then
    export PATH="${CARGO_HOME:-$HOME/.cargo}/bin:$PATH"
  else
    cat >&2 <<'MSG'
error: cargo (Rust) was not found. Install Rust with rustup, then run this script again:
  curl --proto '=https' --tlsv1.2 -sSf https://sh.rustup.rs | sh -s -- -y
  source "$HOME/.cargo/env"
(Debian's own `apt-get install cargo` is too old for this workspace: it needs Rust >= 1.80.)
MSG
    exit 1
  fi
fi
echo "==> $(cargo --version)"

export CARGO_BUILD_JOBS="$JOBS"
echo "==> configure"
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
echo "==> build (-j$JOBS)"
cmake --build build -j "$JOBS"
echo "==> install into build/install"
cmake --install build --prefix "$PWD/build/install" >/dev/null

plugin="$PWD/build/lib/paraview-5.11/plugins/Diamonds"
test -f "$plugin/Diamonds.so"
cat <<MSG
==> done
ParaView plugin:  $plugin/Diamonds.so
  load it with:   export PV_PLUGIN_PATH=$plugin
  (or in ParaView: Tools > Manage Plugins > Load New, then the Filters > Diamonds menu)
Installed tree:   $PWD/build/install  (C++: find_package(Diamonds) with CMAKE_PREFIX_PATH=$PWD/build/install)
MSG
