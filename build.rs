//! Build script: Embree (bindgen bindings of Debian's Embree 3, or Embree 4 from the embreex wheel
//! with the feature `embree4`), the run-time search path of the OpenEXR libraries, the optional
//! Open Image Denoise library, and the C++ side of the `cxx` bridge.

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let embree = if std::env::var_os("CARGO_FEATURE_EMBREE4").is_some() {
        Embree::Four(embree4_link())
    } else {
        embree_bindings();
        Embree::Three
    };
    let mut rpath = openexr_rpath();
    let oidn = oidn_link();
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("windows") {
        if let Embree::Four(e) = &embree {
            rpath.push(e.lib_dir.clone());
        }
        rpath.extend(oidn.clone());
    }
    emit_rpath(&rpath);
    cxx_bridge(oidn.as_deref(), &embree);
}

/// Which Embree the crate links.
enum Embree {
    /// Debian's `libembree3`, a system library.
    Three,
    /// `libembree4` from the embreex wheel (or `EMBREE4_LIB_DIR`).
    Four(Embree4),
}

/// Where `libembree4` was found ([`embree4_link`]).
struct Embree4 {
    /// The directory holding the library (and the TBB it loads from beside itself): the run-path.
    lib_dir: String,
    /// A directory with `libembree4.so` (a symbolic link to the library, whose file name in the
    /// wheel carries a hash), for `-lembree4`.
    link_dir: String,
}

/// Generate Rust bindings for Debian's `embree3/rtcore.h` and link `libembree3`.
///
/// The header is looked up in `$EMBREE_INCLUDE_DIR` (if set), then `/usr/include` and
/// `/usr/local/include`. The bindings go to `$OUT_DIR/embree_sys.rs` (included by `src/embree/sys.rs`).
fn embree_bindings() {
    use std::path::PathBuf;

    println!("cargo:rerun-if-env-changed=EMBREE_INCLUDE_DIR");
    println!("cargo:rerun-if-env-changed=EMBREE_LIB_DIR");
    let mut include_dirs: Vec<PathBuf> = Vec::new();
    if let Some(dir) = std::env::var_os("EMBREE_INCLUDE_DIR") {
        include_dirs.push(dir.into());
    }
    include_dirs.extend(["/usr/include", "/usr/local/include"].map(PathBuf::from));
    let Some(include_dir) = include_dirs.iter().find(|d| d.join("embree3/rtcore.h").is_file()) else {
        panic!(
            "embree3/rtcore.h not found (searched {include_dirs:?}). Install the Embree 3 development \
             package: `apt-get install libembree-dev` (or set EMBREE_INCLUDE_DIR)"
        );
    };
    let header = include_dir.join("embree3/rtcore.h");

    let bindings = bindgen::Builder::default()
        .header(header.to_string_lossy())
        .clang_arg(format!("-I{}", include_dir.display()))
        .allowlist_function("rtc.*")
        .allowlist_type("RTC.*")
        .allowlist_var("RTC.*")
        // Plain integer constants named like the C enumerators (`RTC_ERROR_NONE`): an out-of-range
        // value coming back from C can never be undefined behaviour.
        .prepend_enum_name(false)
        .derive_default(true)
        .parse_callbacks(Box::new(bindgen::CargoCallbacks::new()))
        .generate()
        .unwrap_or_else(|e| panic!("bindgen failed on {}: {e}", header.display()));
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("OUT_DIR not set")).join("embree_sys.rs");
    bindings
        .write_to_file(&out)
        .unwrap_or_else(|e| panic!("cannot write {}: {e}", out.display()));

    if let Some(dir) = std::env::var_os("EMBREE_LIB_DIR") {
        println!("cargo:rustc-link-search=native={}", PathBuf::from(dir).display());
    }
    println!("cargo:rustc-link-lib=embree3");
}

/// Find Embree 4 for the feature `embree4` and let the linker find it as `-lembree4` (which
/// `embree4-sys`, the bindings the crate then uses, asks for).
///
/// Where it is looked for, first match wins:
/// - `EMBREE4_LIB_DIR`: a directory holding `libembree4.so` or `libembree4*.so.4` (a build error
///   if it does not);
/// - the embreex wheel that `make setup` installs:
///   `.venv/lib/python3*/site-packages/embreex.libs/libembree4-<hash>.so.4` (auditwheel renames
///   the library and the TBB it needs, and gives it the run-path `$ORIGIN`).
///
/// No library is a build error that says how to get one. The wheel's library has no `libembree4.so`
/// development link, so one is made in `$OUT_DIR/embree4/`, next to links named as every file of the
/// library's directory (so a C++ program linking through that directory finds the library's
/// `SONAME` and TBB there too). Every binary gets the library's real directory as a run-path
/// ([`emit_rpath`] in `main`).
fn embree4_link() -> Embree4 {
    use std::path::{Path, PathBuf};

    println!("cargo:rerun-if-env-changed=EMBREE4_LIB_DIR");
    let manifest = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR not set"));
    // The library file in `dir`: the development link, else the versioned file.
    let library_in = |dir: &Path| -> Option<PathBuf> {
        let mut names: Vec<PathBuf> = std::fs::read_dir(dir)
            .into_iter()
            .flatten()
            .flatten()
            .map(|e| e.path())
            .filter(|p| {
                let n = p.file_name().unwrap_or_default().to_string_lossy().into_owned();
                n == "libembree4.so" || (n.starts_with("libembree4") && n.ends_with(".so.4"))
            })
            .collect();
        names.sort();
        names.into_iter().next()
    };
    let found = match std::env::var_os("EMBREE4_LIB_DIR").filter(|v| !v.is_empty()) {
        Some(dir) => {
            let d = PathBuf::from(&dir);
            match library_in(&d) {
                Some(lib) => lib,
                None => panic!(
                    "EMBREE4_LIB_DIR={}: no libembree4.so or libembree4*.so.4 in that directory",
                    d.display()
                ),
            }
        }
        None => {
            let venv_lib = manifest.join(".venv/lib");
            match venv_site_packages(&manifest).iter().find_map(|sp| library_in(&sp.join("embreex.libs"))) {
                Some(lib) => lib,
                None => panic!(
                    "the feature `embree4` needs libembree4, which was not found (looked in \
                     {}/python3*/site-packages/embreex.libs/ and EMBREE4_LIB_DIR is not set). \
                     Run `make setup` (it installs the embreex wheel from PyPI into .venv), or set \
                     EMBREE4_LIB_DIR to a directory holding libembree4.so; or build without \
                     `--features embree4` (Debian's Embree 3)",
                    venv_lib.display()
                ),
            }
        }
    };
    let lib = found.canonicalize().unwrap_or(found);
    let lib_dir = lib.parent().expect("a library file has a directory").to_path_buf();

    let out_dir = PathBuf::from(std::env::var_os("OUT_DIR").expect("OUT_DIR not set"));
    let link_dir = out_dir.join("embree4");
    let _ = std::fs::remove_dir_all(&link_dir);
    std::fs::create_dir_all(&link_dir).unwrap_or_else(|e| panic!("cannot create {}: {e}", link_dir.display()));
    let mut links: Vec<(PathBuf, PathBuf)> = vec![(lib.clone(), link_dir.join("libembree4.so"))];
    for entry in std::fs::read_dir(&lib_dir).into_iter().flatten().flatten() {
        let name = entry.file_name();
        if name != "libembree4.so" {
            links.push((entry.path(), link_dir.join(name)));
        }
    }
    for (target, link) in links {
        link_file(&target, &link).unwrap_or_else(|e| panic!("cannot link {} to {}: {e}", link.display(), target.display()));
    }
    println!("cargo:rustc-link-search=native={}", link_dir.display());
    Embree4 { lib_dir: lib_dir.display().to_string(), link_dir: link_dir.display().to_string() }
}

/// The `site-packages` directories of the workspace's `.venv` (`.venv/lib/python3*/site-packages`,
/// sorted), each watched so that a `make setup` installing a wheel there relinks.
fn venv_site_packages(manifest: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut site_packages: Vec<std::path::PathBuf> = std::fs::read_dir(manifest.join(".venv/lib"))
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path().join("site-packages"))
        .filter(|p| p.is_dir())
        .collect();
    site_packages.sort();
    for sp in &site_packages {
        println!("cargo:rerun-if-changed={}", sp.display());
    }
    site_packages
}

/// Make `link` name the file `target`: a symbolic link (a copy where there are none).
fn link_file(target: &std::path::Path, link: &std::path::Path) -> std::io::Result<()> {
    #[cfg(unix)]
    return std::os::unix::fs::symlink(target, link);
    #[cfg(not(unix))]
    return std::fs::copy(target, link).map(|_| ());
}

/// The run-path that makes binaries find the shared OpenEXR/Imath libraries `openexr-sys` builds.
///
/// `openexr-sys` has no `links` key, so it exports no `DEP_*` metadata. Its build script
/// (`cppmm-build`) installs the bundled OpenEXR, Imath and zlib with CMake into `<dir>/lib`, where
/// `<dir>` is the third ancestor of its `OUT_DIR`: `target/<profile>` (`target/<triple>/<profile>`
/// when cross-compiling). Our `OUT_DIR` lies under the same `<dir>`, so [`openexr_lib_dirs`]
/// derives the directory with the same rule. (If `CMAKE_PREFIX_PATH` is set and
/// `CPPMM_OPENEXR_BUILD_LIBRARIES` is not `1`, `openexr-sys` links installed libraries instead,
/// and the `lib`/`lib64` directories of those prefixes are used.)
///
/// Every executable, test and cdylib of this crate gets a run-path with `$ORIGIN/lib` (binaries in
/// `target/<profile>/`), `$ORIGIN/../lib` (tests and examples in `target/<profile>/deps/`; an
/// installed `bin/`) and the absolute directory; the workspace's other packages (`cli/`, `bench/`)
/// get the same list from their build scripts. The libraries themselves carry
/// `$ORIGIN/../lib:<dir>/lib` run-paths, so their dependencies on each other resolve as well.
///
/// The directory is exported to the crate as `RAYSPLAT_OPENEXR_LIB_DIR`
/// (`raysplat::image::OPENEXR_LIB_DIR`): a C++ program linking the static library must link
/// against and set its run-path to the same directory.
fn openexr_rpath() -> Vec<String> {
    println!("cargo:rerun-if-env-changed=CMAKE_PREFIX_PATH");
    println!("cargo:rerun-if-env-changed=CPPMM_OPENEXR_BUILD_LIBRARIES");
    let dirs = openexr_lib_dirs();
    let first = dirs.first().map(|d| d.display().to_string()).unwrap_or_default();
    println!("cargo:rustc-env=RAYSPLAT_OPENEXR_LIB_DIR={first}");

    let origin = match std::env::var("CARGO_CFG_TARGET_OS").as_deref() {
        Ok("windows") => return Vec::new(), // DLLs are found next to the executable or on PATH
        Ok("macos") | Ok("ios") => "@loader_path",
        _ => "$ORIGIN",
    };
    let mut rpath = vec![format!("{origin}/lib"), format!("{origin}/../lib")];
    rpath.extend(dirs.iter().map(|d| d.display().to_string()));
    rpath
}

/// Give every executable, test and cdylib of this crate the run-path `dirs`, and hand the list to
/// the workspace's other packages.
fn emit_rpath(dirs: &[String]) {
    for arg in rpath_args(dirs) {
        println!("cargo:rustc-link-arg={arg}");
    }
    // Link arguments reach this package's own targets only: the command line's and the
    // benchmarks' build scripts read the run-path as `DEP_RAYSPLAT_RPATH` (`links` metadata) and
    // give their binaries and tests the same.
    println!("cargo:rpath={}", dirs.join(";"));
}

/// Linker arguments that add each of `dirs` to the run-path.
fn rpath_args(dirs: &[String]) -> Vec<String> {
    let mut args = Vec::new();
    for dir in dirs {
        if dir.contains(',') {
            // `-Wl,` splits at commas; `-Xlinker` passes the argument through unchanged.
            args.push("-Xlinker".to_string());
            args.push(format!("-rpath={dir}"));
        } else {
            args.push(format!("-Wl,-rpath,{dir}"));
        }
    }
    args
}

/// Find and link Intel Open Image Denoise (`src/denoise`), which is optional; returns its library
/// directory when linked.
///
/// Where it is looked for, first match wins:
/// - `RAYSPLAT_OIDN`: `off` builds without it (to test that configuration); any other value is the
///   directory holding `libOpenImageDenoise.so` (a build error if it does not);
/// - `OIDN_DIR`: an OIDN install prefix (`$OIDN_DIR/lib`), the variable the `oidn` crate reads;
/// - the `pyoidn` wheel that `make setup` installs: `.venv/lib/python3*/site-packages/pyoidn/oidn/lib`.
///
/// When found: the crate is compiled with `cfg(raysplat_oidn)`, links `libOpenImageDenoise.so` (the
/// `#[link]` in `src/denoise/oidn.rs`) from that directory, and every binary gets it as a run-path
/// ([`emit_rpath`] in `main`)
/// (the library finds its CPU module, TBB and weights beside itself). `RAYSPLAT_OIDN_LIB_DIR` (empty
/// without it) tells the crate and the C++ link description. `RAYSPLAT_OIDN_BUILD` says which case.
///
/// A later `make setup` that installs the wheel changes `site-packages`, which is watched, so the
/// next build links it. (Without a `.venv` at all, nothing is watched: `touch build.rs` after
/// creating one.)
fn oidn_link() -> Option<String> {
    use std::path::{Path, PathBuf};

    println!("cargo:rustc-check-cfg=cfg(raysplat_oidn)");
    println!("cargo:rerun-if-env-changed=RAYSPLAT_OIDN");
    println!("cargo:rerun-if-env-changed=OIDN_DIR");
    let manifest = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR not set"));
    let has_lib = |d: &Path| d.join("libOpenImageDenoise.so").is_file();
    let setting = std::env::var("RAYSPLAT_OIDN").ok().filter(|v| !v.is_empty());
    let found: Option<PathBuf> = match setting.as_deref() {
        Some("off") => None,
        Some(dir) => {
            let d = PathBuf::from(dir);
            if !has_lib(&d) {
                panic!("RAYSPLAT_OIDN={dir}: no libOpenImageDenoise.so in that directory (RAYSPLAT_OIDN=off builds without the denoiser)");
            }
            Some(d)
        }
        None => {
            let site_packages = venv_site_packages(&manifest);
            let from_env = std::env::var_os("OIDN_DIR").map(|p| PathBuf::from(p).join("lib"));
            from_env.into_iter().chain(site_packages.iter().map(|sp| sp.join("pyoidn/oidn/lib"))).find(|d| has_lib(d))
        }
    };
    let dir = found.map(|d| d.canonicalize().unwrap_or(d).display().to_string());
    println!("cargo:rustc-env=RAYSPLAT_OIDN_LIB_DIR={}", dir.as_deref().unwrap_or(""));
    let build = match (&dir, setting.as_deref()) {
        (Some(d), _) => d.as_str(),
        (None, Some("off")) => "off",
        (None, _) => "absent",
    };
    println!("cargo:rustc-env=RAYSPLAT_OIDN_BUILD={build}");
    if let Some(d) = &dir {
        println!("cargo:rustc-cfg=raysplat_oidn");
        println!("cargo:rustc-link-search=native={d}");
    }
    dir
}

/// The directories holding the OpenEXR shared libraries `openexr-sys` links (see
/// [`openexr_rpath`]). They may not exist yet: without a `links` key `openexr-sys`'s build script
/// is not ordered before ours.
fn openexr_lib_dirs() -> Vec<std::path::PathBuf> {
    use std::path::{Path, PathBuf};

    let bundled = std::env::var_os("CMAKE_PREFIX_PATH").is_none()
        || std::env::var("CPPMM_OPENEXR_BUILD_LIBRARIES").as_deref() == Ok("1");
    if bundled {
        let out_dir = PathBuf::from(std::env::var_os("OUT_DIR").expect("OUT_DIR not set"));
        // OUT_DIR = <dir>/build/<package>-<hash>/out
        let dir = out_dir.ancestors().nth(3).expect("OUT_DIR has the form <dir>/build/<pkg>/out");
        vec![dir.join("lib")]
    } else {
        let prefixes = std::env::var_os("CMAKE_PREFIX_PATH").unwrap_or_default();
        std::env::split_paths(&prefixes)
            .flat_map(|p: PathBuf| [p.join("lib"), p.join("lib64")])
            .filter(|d: &PathBuf| Path::is_dir(d))
            .collect()
    }
}

/// Generate the C++ side of the `cxx` bridge (`src/ffi/`) and describe how C++ links the library.
///
/// - `cxx_build` generates `raysplat/src/ffi/bridge.rs.h` and the C++ shims from
///   `src/ffi/bridge.rs` and compiles the shims into this crate, so the static library
///   (`crate-type = "staticlib"`: `target/<profile>/libraysplat.a`) contains them.
/// - The generated header and `rust/cxx.h` are copied from `OUT_DIR` (the source of truth) to
///   `<dir>/raysplat-cxx/include/`, where `<dir>` is `target/<profile>` (the third ancestor of
///   `OUT_DIR`, as in [`openexr_lib_dirs`]), so that header and library always match.
/// - `<dir>/raysplat-link.txt` lists the static library, the include directories and the native
///   libraries a C++ program must link; `cpp/cmake/raysplatConfig.cmake` (CMake package) and the
///   generated `raysplat.pc` (pkg-config) read it.
///
/// Both files are rewritten only when their content changes, by rename, so concurrent builds of
/// two profiles never leave a half-written file.
fn cxx_bridge(oidn_dir: Option<&str>, embree: &Embree) {
    use std::path::PathBuf;

    let manifest = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR not set"));
    println!("cargo:rerun-if-changed=src/ffi/bridge.rs");
    println!("cargo:rerun-if-changed=cpp/include/raysplat/progress.hpp");
    cxx_build::CFG.doxygen = true; // the bridge's doc comments become comments in the header
    cxx_build::bridge("src/ffi/bridge.rs")
        .include(manifest.join("cpp/include"))
        .std("c++17")
        .compile("raysplat-cxxbridge");
    if let Err(e) = cxx_export(&manifest, oidn_dir, embree) {
        println!("cargo:warning=C++ API: could not write the header copy and link description: {e}");
    }
}

/// Copy the generated headers next to the static library and write `raysplat-link.txt`.
fn cxx_export(manifest: &std::path::Path, oidn_dir: Option<&str>, embree: &Embree) -> std::io::Result<()> {
    use std::path::PathBuf;

    let out_dir = PathBuf::from(std::env::var_os("OUT_DIR").expect("OUT_DIR not set"));
    let dir = out_dir.ancestors().nth(3).expect("OUT_DIR has the form <dir>/build/<pkg>/out");
    let generated = out_dir.join("cxxbridge/include");
    let include = dir.join("raysplat-cxx/include");
    for header in ["rust/cxx.h", "raysplat/src/ffi/bridge.rs.h"] {
        // `fs::read` follows the symlinks cxx_build leaves in OUT_DIR.
        write_if_changed(&include.join(header), &std::fs::read(generated.join(header))?)?;
    }

    let mut lib_dirs: Vec<String> = openexr_lib_dirs().iter().map(|d| d.display().to_string()).collect();
    let mut bundled = vec!["OpenEXRUtil-3_0", "OpenEXR-3_0", "IlmThread-3_0", "Iex-3_0", "Imath-3_0", "z"];
    if let Some(d) = oidn_dir {
        lib_dirs.push(d.to_string());
        bundled.push("OpenImageDenoise");
    }
    let mut system = vec!["stdc++", "pthread", "dl", "m", "rt", "util", "gcc_s", "c"];
    match embree {
        Embree::Three => system.insert(0, "embree3"),
        Embree::Four(e) => {
            // `libembree4.so` is found in the link directory; both directories become run-paths.
            lib_dirs.push(e.link_dir.clone());
            lib_dirs.push(e.lib_dir.clone());
            bundled.push("embree4");
        }
    }
    let list = |v: &[&str]| v.join(";");
    let text = format!(
        "# How a C++ program links raysplat (written by build.rs, cxx_bridge; do not edit).\n\
         # Lists are ;-separated. Read by cpp/cmake/raysplatConfig.cmake and cpp/raysplat.pc.in.\n\
         version={version}\n\
         static_lib={static_lib}\n\
         include_dirs={include};{cpp_include}\n\
         # Shared libraries built by openexr-sys (with its bundled zlib), Open Image Denoise when the\n\
         # build found it (src/denoise), and Embree 4 in a build with the feature `embree4`, in\n\
         # lib_dirs: link with -L<dir> and a run-path to <dir>.\n\
         lib_dirs={lib_dirs}\n\
         bundled_libs={bundled}\n\
         # System libraries: Embree 3 (unless Embree 4 is bundled), then what the Rust standard\n\
         # library and libstdc++ need.\n\
         system_libs={system}\n",
        version = std::env::var("CARGO_PKG_VERSION").unwrap_or_default(),
        static_lib = dir.join("libraysplat.a").display(),
        include = include.display(),
        cpp_include = manifest.join("cpp/include").display(),
        lib_dirs = lib_dirs.join(";"),
        // What openexr-sys 0.10 links (its build output: cargo:rustc-link-lib=dylib=...), and OIDN.
        bundled = list(&bundled),
        system = list(&system),
    );
    write_if_changed(&dir.join("raysplat-link.txt"), text.as_bytes())
}

/// Write `path` through a temporary file and a rename, unless it already holds `bytes`.
fn write_if_changed(path: &std::path::Path, bytes: &[u8]) -> std::io::Result<()> {
    if std::fs::read(path).is_ok_and(|old| old == bytes) {
        return Ok(());
    }
    let dir = path.parent().expect("a file path");
    std::fs::create_dir_all(dir)?;
    let name = path.file_name().expect("a file name").to_string_lossy();
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    std::fs::write(&tmp, bytes)?;
    std::fs::rename(&tmp, path)
}
