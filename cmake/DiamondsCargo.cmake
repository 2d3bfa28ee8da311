# Builds the Rust side of Diamonds with cargo and imports it as the static library target
# `diamonds_bridge_rust`.
#
# - `cargo build --release --locked -p diamonds-bridge` runs on every build (a no-op takes ~0.1 s;
#   cargo decides what is stale), with CARGO_TARGET_DIR inside the CMake build tree.
# - The bridge crate's build.rs runs cxx-build: the C++ half of the bridge and cxx's runtime land
#   inside the staticlib, and the generated headers in ${DIAMONDS_CXXBRIDGE_INCLUDE_DIR}
#   (`rust/cxx.h`, `diamonds-bridge/src/lib.rs.h`).
# - Exactly one Rust staticlib may be linked into a binary; diamonds-bridge is it.
#
# Sets: DIAMONDS_CARGO_TARGET_DIR, DIAMONDS_CXXBRIDGE_INCLUDE_DIR, DIAMONDS_BRIDGE_LIBRARY_NAME.

find_program(DIAMONDS_CARGO_EXECUTABLE cargo
  HINTS "$ENV{CARGO_HOME}/bin" "$ENV{HOME}/.cargo/bin"
  DOC "cargo, the Rust build tool")
if (NOT DIAMONDS_CARGO_EXECUTABLE)
  message(FATAL_ERROR
    "cargo (Rust) was not found. Install Rust with rustup:\n"
    "  curl --proto '=https' --tlsv1.2 -sSf https://sh.rustup.rs | sh -s -- -y\n"
    "then open a new shell (or `source \$HOME/.cargo/env`) and configure again, "
    "or pass -DDIAMONDS_CARGO_EXECUTABLE=/path/to/cargo.")
endif ()

find_package(Threads REQUIRED)

set(DIAMONDS_CARGO_TARGET_DIR "${CMAKE_BINARY_DIR}/cargo")
set(DIAMONDS_CXXBRIDGE_INCLUDE_DIR "${DIAMONDS_CARGO_TARGET_DIR}/cxxbridge")
set(DIAMONDS_BRIDGE_LIBRARY_NAME "libdiamonds_bridge.a")
set(_diamonds_bridge_library "${DIAMONDS_CARGO_TARGET_DIR}/release/${DIAMONDS_BRIDGE_LIBRARY_NAME}")

add_custom_target(diamonds_cargo
  COMMAND "${CMAKE_COMMAND}" -E env "CARGO_TARGET_DIR=${DIAMONDS_CARGO_TARGET_DIR}"
          "${DIAMONDS_CARGO_EXECUTABLE}" build --release --locked -p diamonds-bridge
  BYPRODUCTS
    "${_diamonds_bridge_library}"
    "${DIAMONDS_CXXBRIDGE_INCLUDE_DIR}/rust/cxx.h"
    "${DIAMONDS_CXXBRIDGE_INCLUDE_DIR}/diamonds-bridge/src/lib.rs.h"
  WORKING_DIRECTORY "${PROJECT_SOURCE_DIR}"
  COMMENT "Building the Rust core (cargo build --release -p diamonds-bridge)"
  USES_TERMINAL
  VERBATIM)

add_library(diamonds_bridge_rust STATIC IMPORTED GLOBAL)
set_target_properties(diamonds_bridge_rust PROPERTIES
  IMPORTED_LOCATION "${_diamonds_bridge_library}"
  INTERFACE_LINK_LIBRARIES "Threads::Threads;${CMAKE_DL_LIBS};m;rt;util")
add_dependencies(diamonds_bridge_rust diamonds_cargo)
