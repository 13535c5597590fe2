//! USD input: conversion of `.usd/.usda/.usdc/.usdz` stages into the scene format with Pixar's
//! `usd-core` Python package, cached by content hash.
//!
//! The converter (`python/raysplat_usd.py` and its parts `raysplat_usd_common.py`,
//! `raysplat_usd_mtlx_nodes.py`, `raysplat_usd_mtlx.py`, `raysplat_usd_materials.py`,
//! `raysplat_usd_meshes.py`, `raysplat_usd_lights.py`, after `raysplat_crate.py` and
//! `raysplat_curves.py`) is embedded in the binary, one text, and piped to a Python that can
//! `import pxr` (see [`find_python`]): the one the caller names ([`StageOptions::python`], the C++
//! `StageView::python`), else `$RAYSPLAT_PYTHON`, else the `.venv` of the source tree a program
//! under its `target/` was built in, else `python3` on `PATH`. Being embedded, the converter needs
//! no files beside the library, wherever it is installed or moved.

mod process;

use crate::error::{Error, Result};
use crate::io::{cache, temporaries};
use crate::scene::subdiv::SubdivisionMode;
use crate::scene::{format, SceneDesc, Warning};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::collections::HashMap;
use std::sync::Mutex;

/// The converter source, embedded so the CLI works from any directory.
pub const CONVERTER: &str = concat!(
    include_str!("../../python/raysplat_crate.py"),
    include_str!("../../python/raysplat_curves.py"),
    include_str!("../../python/raysplat_usd_common.py"),
    include_str!("../../python/raysplat_usd_mtlx_nodes.py"),
    include_str!("../../python/raysplat_usd_mtlx.py"),
    include_str!("../../python/raysplat_usd_materials.py"),
    include_str!("../../python/raysplat_usd_meshes.py"),
    include_str!("../../python/raysplat_usd_lights.py"),
    include_str!("../../python/raysplat_usd.py")
);

/// File extensions handled by the USD converter.
pub fn is_usd(path: &Path) -> bool {
    matches!(
        path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).as_deref(),
        Some("usd" | "usda" | "usdc" | "usdz")
    )
}

/// Which view of a stage the converter reads (the camera and the time code), and what the
/// renderer makes of its subdivision surfaces.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StageOptions {
    /// Prim path of the camera to render (default: the render settings' camera, else the first).
    pub camera: Option<String>,
    /// USD time code to read animated values at (default: the stage's start time code).
    pub frame: Option<f64>,
    /// What the renderer makes of subdivision surfaces (default `auto`). The conversion keeps
    /// them as cages whatever it is, so it applies to `.rss` files too.
    pub subdivision: Option<SubdivisionMode>,
    /// The Python to convert with (default: `RAYSPLAT_PYTHON`, else the build tree's `.venv`, else
    /// `python3`); an error when it cannot import `pxr`. Not part of the view: it does not change
    /// the cache key.
    pub python: Option<PathBuf>,
}

impl StageOptions {
    /// The converter's command-line arguments for these options.
    fn args(&self) -> Vec<String> {
        let mut a = Vec::new();
        if let Some(c) = &self.camera {
            a.extend(["--camera".to_string(), c.clone()]);
        }
        if let Some(f) = self.frame {
            // `{:?}` prints an f64 that parses back to the same value
            a.extend(["--frame".to_string(), format!("{f:?}")]);
        }
        a
    }

    /// A clear error for options a converted scene cannot honour, and for a non-finite frame.
    fn check(&self, path: &Path) -> Result<()> {
        if let Some(f) = self.frame {
            if !f.is_finite() {
                return Err(Error::param("frame", format!("{f} is not a finite time code")));
            }
        }
        if (self.camera.is_some() || self.frame.is_some()) && !is_usd(path) {
            return Err(Error::Usd {
                file: path.display().to_string(),
                message: "--camera and --frame choose what is read from a USD stage (.usd, .usda, .usdc, .usdz), \
                          and this file is not one (a converted scene keeps the camera and time code it was \
                          converted with)"
                    .into(),
            });
        }
        Ok(())
    }
}

/// Load a scene from a USD stage (converted and cached) or a `.rss` file, then validate it.
pub fn load_scene(path: &Path) -> Result<SceneDesc> {
    load_scene_with(path, &StageOptions::default())
}

/// [`load_scene`] with a camera and time code chosen for a USD stage.
pub fn load_scene_with(path: &Path, opts: &StageOptions) -> Result<SceneDesc> {
    Ok(load_scene_info(path, opts)?.0)
}

/// [`load_scene_with`], also returning what the converter recorded (the stage's cameras, the time).
/// Problems with the cache (a damaged entry converted again, a cache directory that cannot be
/// written) come back as warnings of the scene.
pub fn load_scene_info(path: &Path, opts: &StageOptions) -> Result<(SceneDesc, format::FileInfo)> {
    crate::io::input::check_input(path)?;
    opts.check(path)?;
    let mut notes = Vec::new();
    let rss = if is_usd(path) { convert_cached_noting(path, opts, &mut notes)? } else { path.to_path_buf() };
    let (mut scene, info) = format::load(&rss).map_err(|e| rename_source(e, &rss, path))?;
    if is_usd(path) {
        scene.source = path.display().to_string();
    }
    scene.warnings.splice(0..0, notes);
    scene.subdivision = opts.subdivision.unwrap_or_default();
    scene.validate()?;
    Ok((scene, info))
}

/// Errors from loading a cached or staged conversion name the USD file the user gave, not the
/// `.rss` file.
fn rename_source(e: Error, rss: &Path, usd: &Path) -> Error {
    match e {
        Error::Scene { file, prim, message } if file == rss.display().to_string() => {
            Error::Scene { file: usd.display().to_string(), prim, message }
        }
        other => other,
    }
}

/// The converter's requirement, `usd-core==<version>` (`python/requirements.txt`, which
/// `make setup` installs into `.venv`).
pub fn usd_core_requirement() -> &'static str {
    include_str!("../../python/requirements.txt")
        .lines()
        .map(str::trim)
        .find(|l| l.starts_with("usd-core"))
        .expect("python/requirements.txt names usd-core")
}

/// Where the converter's Python was named.
#[derive(Clone, Copy, Debug, PartialEq)]
enum PythonSource {
    /// [`StageOptions::python`] (C++: `StageView::python`).
    Caller,
    /// `RAYSPLAT_PYTHON`.
    Environment,
    /// The `.venv` of the source tree the running program was built in (`make setup` makes it).
    BuildTree,
    /// `python3` on `PATH`.
    Path,
}

/// `<tree>/.venv/bin/python3` when the running program lies under `<tree>/target/` (the CLI, the
/// tests and in-tree C++ programs after `make setup`), found from the program's own path, so
/// nothing installed refers to the source tree.
fn build_tree_python() -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    let target = exe.ancestors().find(|a| a.file_name().is_some_and(|n| n == "target"))?;
    let python = target.parent()?.join(".venv/bin/python3");
    python.is_file().then_some(python)
}

/// The Python interpreter the converter runs with: `explicit` (the caller's
/// [`StageOptions::python`]), else `RAYSPLAT_PYTHON`, else `python3` on `PATH`. One that cannot be
/// run or cannot `import pxr` is an error saying how to install usd-core into it; a Python that was
/// named is never replaced by another. Checks are memoised per interpreter.
pub fn find_python(explicit: Option<&Path>) -> Result<PathBuf> {
    let (python, source) = match (explicit, std::env::var_os("RAYSPLAT_PYTHON")) {
        (Some(p), _) => (p.to_path_buf(), PythonSource::Caller),
        (None, Some(p)) if !p.is_empty() => (PathBuf::from(p), PythonSource::Environment),
        (None, _) => match build_tree_python() {
            Some(p) => (p, PythonSource::BuildTree),
            None => (PathBuf::from("python3"), PythonSource::Path),
        },
    };
    static CHECKED: Mutex<Option<HashMap<PathBuf, std::result::Result<(), String>>>> = Mutex::new(None);
    let known = CHECKED.lock().unwrap_or_else(|e| e.into_inner()).get_or_insert_with(HashMap::new).get(&python).cloned();
    let outcome = match known {
        Some(o) => o,
        None => {
            let o = check_python(&python);
            CHECKED.lock().unwrap_or_else(|e| e.into_inner()).get_or_insert_with(HashMap::new).insert(python.clone(), o.clone());
            o
        }
    };
    match outcome {
        Ok(()) => Ok(python),
        Err(why) => Err(Error::Usd { file: "-".into(), message: python_error(&python, source, &why) }),
    }
}

/// Run `python -c "import pxr.Usd"`: `Err` says why it failed (cannot run, or Python's last line).
fn check_python(python: &Path) -> std::result::Result<(), String> {
    let out = Command::new(python)
        .args(["-c", "import pxr.Usd"])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .output()
        .map_err(|e| format!("cannot run it: {e}"))?;
    if out.status.success() {
        return Ok(());
    }
    let stderr = String::from_utf8_lossy(&out.stderr);
    let last = stderr.lines().rev().map(str::trim).find(|l| !l.is_empty()).unwrap_or("no message");
    Err(format!("it cannot import pxr ({last})"))
}

/// The message for a Python that cannot convert: which one, why, and how to install usd-core.
fn python_error(python: &Path, source: PythonSource, why: &str) -> String {
    let req = usd_core_requirement();
    let p = python.display();
    let named = match source {
        PythonSource::Caller => format!("the Python given to convert USD stages ({p})"),
        PythonSource::Environment => format!("RAYSPLAT_PYTHON={p}"),
        PythonSource::BuildTree => format!("the source tree's Python ({p}, since RAYSPLAT_PYTHON is not set)"),
        PythonSource::Path => "python3 (from PATH, since RAYSPLAT_PYTHON is not set)".to_string(),
    };
    let cannot_run = why.starts_with("cannot run");
    let fix = match (source, cannot_run) {
        (PythonSource::Path, true) => format!(
            "install Python 3 and usd-core (`python3 -m pip install '{req}'`), or set RAYSPLAT_PYTHON to a Python that has usd-core"
        ),
        (PythonSource::Path, false) => format!(
            "install usd-core with `python3 -m pip install '{req}'`, or into a virtual environment with \
             `python3 -m venv DIR && DIR/bin/python3 -m pip install '{req}'` and set RAYSPLAT_PYTHON=DIR/bin/python3"
        ),
        (_, true) => "name an existing Python 3 that has usd-core".to_string(),
        (_, false) => format!("install usd-core into it with `{p} -m pip install '{req}'`"),
    };
    format!("{named}: {why}; {fix}")
}

/// Convert `input` to `output` (no cache), atomically: the converter writes into a staging
/// directory beside `output`, the result is loaded and validated, and only then renamed into
/// place; a failed conversion leaves `output` as it was. `output` must pass the output rule
/// ([`crate::io::check_output`]; never the input itself). Textures extracted from a `.usdz`
/// go to `OUTPUT.textures/`. Returns the converter's warnings output (stderr).
pub fn convert(input: &Path, output: &Path, opts: &StageOptions) -> Result<String> {
    opts.check(input)?;
    crate::io::input::check_input(input)?;
    let target = crate::io::check_outputs(&[(output, crate::io::Format::Rss)], &[input])?.remove(0);
    convert_into(input, &target, opts, &input.display().to_string(), Some(output))
}

/// Convert `input` into `target` through a staging directory beside it (see [`convert`]); errors
/// name the input as `shown`. `checked`: the output path as given, checked again before the rename.
fn convert_into(input: &Path, target: &Path, opts: &StageOptions, shown: &str, checked: Option<&Path>) -> Result<String> {
    let dir = match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let name = target.file_name().ok_or_else(|| Error::io(target, std::io::Error::other("is not a file name to write")))?;
    let staging = temporaries::create_dir(dir, &format!(".{}.raysplat-", name.to_string_lossy()), ".tmp")?;
    let staged = staging.path().join(name);
    let mut textures = target.as_os_str().to_owned();
    textures.push(".textures");
    let textures = PathBuf::from(textures);
    // extracted textures go straight to their place; a failed conversion removes a folder it made
    let made_textures = !textures.exists();
    let registered = if made_textures { Some(temporaries::register(&textures)?) } else { None };
    let result = (|| {
        let warnings = process::run(input, &staged, &textures, opts, shown)?;
        let (mut scene, _) = format::load(&staged).map_err(|e| rename_source(e, &staged, Path::new(shown)))?;
        scene.source = shown.to_string();
        scene.validate()?;
        if let Some(out) = checked {
            if crate::io::check_outputs(&[(out, crate::io::Format::Rss)], &[input])?[0] != target {
                return Err(Error::io(out, std::io::Error::other("changed while the stage was converted")));
            }
        }
        std::fs::rename(&staged, target).map_err(|e| Error::io(target, e))?;
        Ok(warnings)
    })();
    if result.is_err() && made_textures {
        let _ = std::fs::remove_dir_all(&textures);
    }
    drop(registered);
    result
}

/// SHA-256 of a file's content, hex.
pub fn sha256_file(path: &Path) -> Result<String> {
    let bytes = crate::io::input::read_input(path)?;
    Ok(hex(&Sha256::digest(&bytes)))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Convert through the cache: reuse a previous conversion while the converter, the root layer and
/// every recorded dependency (layers, textures) are unchanged and its checksum holds. Each camera
/// and time code of a stage is a conversion of its own. The cache keeps to a size limit ([`cache`]).
pub fn convert_cached(input: &Path, opts: &StageOptions) -> Result<PathBuf> {
    convert_cached_noting(input, opts, &mut Vec::new())
}

/// [`convert_cached`], adding to `notes` what the user should hear about the cache: a damaged
/// entry converted again, a cache directory that cannot be written.
fn convert_cached_noting(input: &Path, opts: &StageOptions, notes: &mut Vec<Warning>) -> Result<PathBuf> {
    let abs = std::fs::canonicalize(input).map_err(|e| Error::io(input, e))?;
    let root = crate::io::input::read_input(&abs).map_err(|e| match e {
        Error::Io { source, .. } => Error::io(input, source),
        other => other,
    })?;
    let mut h = Sha256::new();
    h.update(CONVERTER.as_bytes());
    h.update(abs.to_string_lossy().as_bytes());
    h.update(&root);
    for a in opts.args() {
        h.update([0u8]);
        h.update(a.as_bytes());
    }
    let key = hex(&h.finalize());
    let (dir, note) = cache::usable_dir();
    if let Some((configured, message)) = note {
        notes.push(Warning { prim: configured.display().to_string(), message });
    }
    let cached = dir.join(format!("{}.rss", &key[..32]));
    let limit = cache::limit()?;
    if cached.exists() {
        match format::read_info(&cached) {
            Ok(info) if dependencies_unchanged(&info) => {
                cache::touch(&cached);
                return Ok(cached);
            }
            Ok(_) => {}
            Err(e) => notes.push(Warning {
                prim: cached.display().to_string(),
                message: format!("the cached conversion is damaged ({}); converted again", cause(&e, &cached)),
            }),
        }
    }
    convert_into(&abs, &cached, opts, &input.display().to_string(), None)?;
    cache::prune(&dir, &cached, limit);
    Ok(cached)
}

/// The reason of an error about `path`, without the path.
fn cause(e: &Error, path: &Path) -> String {
    let s = e.to_string();
    let p = format!("{}: ", path.display());
    let s = s.strip_prefix(&p).unwrap_or(&s).to_string();
    s.strip_prefix("-: ").map(str::to_string).unwrap_or(s)
}

fn dependencies_unchanged(info: &format::FileInfo) -> bool {
    info.dependencies.iter().all(|d| match &d.sha256 {
        Some(h) => sha256_file(Path::new(&d.path)).map(|s| &s == h).unwrap_or(false),
        None => !Path::new(&d.path).exists(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The converter passes on the conform policies the camera knows, and writes the scene
    /// format version this build reads.
    #[test]
    fn the_conform_policies_and_the_format_version_are_the_converters() {
        assert!(CONVERTER.contains(&format!("\nFORMAT_VERSION = {}\n", format::VERSION)));
        let start = CONVERTER.find("\nASPECT_CONFORM = {").expect("the converter's policies");
        let set = &CONVERTER[start..start + CONVERTER[start..].find('}').expect("a closing brace")];
        for p in crate::scene::ASPECT_CONFORM {
            assert!(set.contains(&format!("\"{p}\"")), "{p} missing from the converter's {set}");
        }
        assert_eq!(set.matches('"').count(), 2 * crate::scene::ASPECT_CONFORM.len(), "{set}");
    }
}
