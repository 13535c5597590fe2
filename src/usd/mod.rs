//! USD input: conversion of `.usd/.usda/.usdc/.usdz` stages into the scene format with Pixar's
//! `usd-core` Python package, cached by content hash.
//!
//! The converter (`python/raysplat_usd.py` and its parts `raysplat_usd_common.py`,
//! `raysplat_usd_mtlx_nodes.py`, `raysplat_usd_mtlx.py`, `raysplat_usd_materials.py`,
//! `raysplat_usd_meshes.py`, `raysplat_usd_lights.py`, after
//! `raysplat_curves.py`) is embedded in the binary, one text, and piped to
//! a Python that can `import pxr`, found in this order:
//! `$RAYSPLAT_PYTHON`; the repository's `.venv` (made by `make setup`); `python3` on `PATH`.


use crate::error::{Error, Result};
use crate::io::cache;
use crate::scene::subdiv::SubdivisionMode;
use crate::scene::{format, SceneDesc};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;

/// The converter source, embedded so the CLI works from any directory.
pub const CONVERTER: &str = concat!(
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
pub fn load_scene_info(path: &Path, opts: &StageOptions) -> Result<(SceneDesc, format::FileInfo)> {
    if !path.exists() {
        return Err(Error::io(path, std::io::Error::new(std::io::ErrorKind::NotFound, "no such file")));
    }
    opts.check(path)?;
    let rss = if is_usd(path) { convert_cached(path, opts)? } else { path.to_path_buf() };
    let (mut scene, info) = format::load(&rss).map_err(|e| rename_source(e, &rss, path))?;
    if is_usd(path) {
        scene.source = path.display().to_string();
    }
    scene.subdivision = opts.subdivision.unwrap_or_default();
    scene.validate()?;
    Ok((scene, info))
}

/// Errors from loading a cached conversion name the USD file the user gave, not the cache file.
fn rename_source(e: Error, rss: &Path, usd: &Path) -> Error {
    match e {
        Error::Scene { file, prim, message } if file == rss.display().to_string() => {
            Error::Scene { file: usd.display().to_string(), prim, message }
        }
        other => other,
    }
}

/// Find a Python interpreter that can import `pxr` (memoised).
pub fn find_python() -> Result<PathBuf> {
    static FOUND: OnceLock<std::result::Result<PathBuf, String>> = OnceLock::new();
    FOUND
        .get_or_init(|| {
            let mut candidates: Vec<PathBuf> = Vec::new();
            if let Some(p) = std::env::var_os("RAYSPLAT_PYTHON") {
                candidates.push(PathBuf::from(p));
            }
            candidates.push(Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv/bin/python3"));
            candidates.push(PathBuf::from("python3"));
            for c in &candidates {
                let ok = Command::new(c)
                    .args(["-c", "import pxr.Usd"])
                    .stdin(Stdio::null())
                    .stdout(Stdio::null())
                    .stderr(Stdio::null())
                    .status()
                    .map(|s| s.success())
                    .unwrap_or(false);
                if ok {
                    return Ok(c.clone());
                }
            }
            Err(format!(
                "no Python with usd-core found (tried {}); run `make setup` or `pip install usd-core`, \
                 or set RAYSPLAT_PYTHON",
                candidates.iter().map(|c| c.display().to_string()).collect::<Vec<_>>().join(", ")
            ))
        })
        .clone()
        .map_err(|message| Error::Usd { file: "-".into(), message })
}

/// The converter's warnings a failed conversion's error message repeats (the first ones).
const MAX_WARNINGS_WITH_ERROR: usize = 10;

/// Convert `input` to `output` (no cache). Returns the converter's warnings output (stderr).
pub fn convert(input: &Path, output: &Path, opts: &StageOptions) -> Result<String> {
    opts.check(input)?;
    let python = find_python()?;
    let file = input.display().to_string();
    let mut child = Command::new(&python)
        .arg("-")
        .arg(input)
        .arg(output)
        .args(opts.args())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| Error::Usd { file: file.clone(), message: format!("cannot run {}: {e}", python.display()) })?;
    // progress lines are shown as they come; the rest (warnings, the error) is kept
    let err_pipe = child.stderr.take().expect("piped stderr");
    let name = input.file_name().map_or_else(|| file.clone(), |n| n.to_string_lossy().into_owned());
    let reader = std::thread::spawn(move || {
        use std::io::BufRead;
        let mut kept = String::new();
        for line in std::io::BufReader::new(err_pipe).lines().map_while(|l| l.ok()) {
            match line.strip_prefix("progress: ") {
                Some(p) => eprintln!("converting {name}: {p}"),
                None => {
                    kept.push_str(&line);
                    kept.push('\n');
                }
            }
        }
        kept
    });
    {
        use std::io::Write;
        let mut stdin = child.stdin.take().expect("piped stdin");
        stdin
            .write_all(CONVERTER.as_bytes())
            .map_err(|e| Error::Usd { file: file.clone(), message: format!("cannot start the converter: {e}") })?;
    }
    let out = child
        .wait_with_output()
        .map_err(|e| Error::Usd { file: file.clone(), message: format!("converter failed: {e}") })?;
    let stderr = reader.join().unwrap_or_default();
    if !out.status.success() {
        // The converter prints one `error: <file>: <prim>: <message>` line for user errors.
        let line = stderr
            .lines()
            .rev()
            .find(|l| l.starts_with("error: "))
            .map(|l| l.trim_start_matches("error: ").to_string());
        // the warnings printed before the error often explain it (every mesh skipped, say)
        let warnings: Vec<&str> = stderr.lines().filter(|l| l.starts_with("warning: ")).collect();
        let mut context = String::new();
        for w in warnings.iter().take(MAX_WARNINGS_WITH_ERROR) {
            context.push_str("\n  ");
            context.push_str(w);
        }
        if warnings.len() > MAX_WARNINGS_WITH_ERROR {
            context.push_str(&format!("\n  ({} more warnings)", warnings.len() - MAX_WARNINGS_WITH_ERROR));
        }
        return Err(match line {
            Some(l) => Error::Usd { file, message: strip_file_prefix(&l, input) + &context },
            None => Error::Usd {
                file,
                message: format!("converter failed ({}): {}", out.status, stderr.trim()),
            },
        });
    }
    Ok(stderr)
}

fn strip_file_prefix(line: &str, input: &Path) -> String {
    let p = format!("{}: ", input.display());
    line.strip_prefix(&p).unwrap_or(line).to_string()
}

/// SHA-256 of a file's content, hex.
pub fn sha256_file(path: &Path) -> Result<String> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    Ok(hex(&Sha256::digest(&bytes)))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Convert through the cache: reuse a previous conversion while the converter, the root layer and
/// every recorded dependency (layers, textures) are unchanged. Each camera and time code of a stage
/// is a conversion of its own. The cache keeps to a size limit ([`cache`]).
pub fn convert_cached(input: &Path, opts: &StageOptions) -> Result<PathBuf> {
    let abs = std::fs::canonicalize(input).map_err(|e| Error::io(input, e))?;
    let root = std::fs::read(&abs).map_err(|e| Error::io(&abs, e))?;
    let mut h = Sha256::new();
    h.update(CONVERTER.as_bytes());
    h.update(abs.to_string_lossy().as_bytes());
    h.update(&root);
    for a in opts.args() {
        h.update([0u8]);
        h.update(a.as_bytes());
    }
    let key = hex(&h.finalize());
    let dir = crate::io::cache::dir();
    let cached = dir.join(format!("{}.rss", &key[..32]));
    let limit = cache::limit()?;
    if cached.exists() && dependencies_unchanged(&cached) {
        cache::touch(&cached);
        return Ok(cached);
    }
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    convert(&abs, &cached, opts)?;
    cache::prune(&dir, &cached, limit);
    Ok(cached)
}

fn dependencies_unchanged(cached: &Path) -> bool {
    let Ok(info) = format::read_info(cached) else { return false };
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
