#!/usr/bin/env bash
# Runs every test: formatting and lints, the Rust unit/property/integration tests (core, bridge, CLI;
# the ../shared datasets are used when present and skipped with a message otherwise — a failure instead
# under CI=true or DIAMONDS_REQUIRE_SHARED=1, as .ci/run sets), the external C++
# consumer against the installed package, and the pvpython/pvbatch tests (including MPI).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
bash scripts/setup.sh
export PATH="${CARGO_HOME:-$HOME/.cargo}/bin:$PATH"
echo "==> cargo fmt --check"
cargo fmt --all --check
echo "==> cargo clippy"
cargo clippy --workspace --all-targets --locked --release -- -D warnings
echo "==> cargo test (release)"
cargo test --workspace --locked --release
echo "==> integration tests (C++ consumer, pvpython, MPI)"
bash scripts/test-integration.sh
echo "==> all tests passed"
