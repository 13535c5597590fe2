//! Build script: Embree bindings (bindgen) and the run-time search path of the OpenEXR libraries.

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    embree_bindings();
    openexr_rpath();
}

/// Generate Rust bindings for Debian's `embree3/rtcore.h` and link `libembree3`.
fn embree_bindings() {
    // owned by the embree module work
}

/// Make binaries find the shared OpenEXR/Imath libraries that `openexr-sys` builds.
fn openexr_rpath() {
    // owned by the image module work
}
