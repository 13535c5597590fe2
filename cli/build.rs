// Build script: the run-path of the OpenEXR shared libraries the renderer links, handed over by
// the library's build script (`DEP_RAYSPLAT_RPATH`, its `links` metadata), for the `raysplat`
// binary and this package's tests (`bench/build.rs` includes this file).

fn main() {
    println!("cargo:rerun-if-env-changed=DEP_RAYSPLAT_RPATH");
    let rpath = std::env::var("DEP_RAYSPLAT_RPATH").unwrap_or_default();
    for dir in rpath.split(';').filter(|d| !d.is_empty()) {
        if dir.contains(',') {
            // `-Wl,` splits at commas; `-Xlinker` passes the argument through unchanged.
            println!("cargo:rustc-link-arg=-Xlinker");
            println!("cargo:rustc-link-arg=-rpath={dir}");
        } else {
            println!("cargo:rustc-link-arg=-Wl,-rpath,{dir}");
        }
    }
}
