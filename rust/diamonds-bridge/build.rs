//! Generates the C++ half of the bridge and compiles it (with cxx's runtime) into this staticlib.
//! The generated headers land in `$CARGO_TARGET_DIR/cxxbridge/` (`rust/cxx.h`,
//! `diamonds-bridge/src/lib.rs.h`) for the VTK module to include.

fn main() {
    cxx_build::bridge("src/lib.rs")
        .std("c++17")
        .compile("diamonds-bridge-cxx");
    println!("cargo:rerun-if-changed=src/lib.rs");
    println!("cargo:rerun-if-changed=include/progress.h");
    println!("cargo:rerun-if-changed=include/exchange.h");
}
