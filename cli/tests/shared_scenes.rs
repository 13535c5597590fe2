//! Real scenes written by others (the workspace's shared scenes, see their README): each entry file
//! converts and renders with `--method pt --spp 4`, unsupported features listed as warnings.
//!
//! The folder is `RAYSPLAT_SHARED_SCENES`, else `../shared/scenes` beside the repository. When it is
//! absent the tests skip and say so on the terminal (not in the captured test output); when
//! `RAYSPLAT_SHARED_SCENES` names a folder that does not exist, they fail.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

const ENTRIES: &[&str] = &[
    "classic/cornell_box/CornellBox-Original.usda",
    "classic/cornell_box/CornellBox-Sphere.usda",
    "classic/cornell_box/CornellBox-Water.usda",
    "classic/crytek_sponza/sponza.usdc",
    "usd/MiniCarKit_scene.usda",
    "usd/RoughnessTest_scene.usda",
    "usd/usd-wg-assets/full_assets/StandardShaderBall/standard_shader_ball_scene.usda",
];

/// The shared scenes' folder, or `None` after a visible skip message.
fn shared(test: &str) -> Option<PathBuf> {
    if let Some(dir) = std::env::var_os("RAYSPLAT_SHARED_SCENES") {
        let dir = PathBuf::from(dir);
        assert!(dir.is_dir(), "RAYSPLAT_SHARED_SCENES={} is not a folder", dir.display());
        return Some(dir);
    }
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes");
    if dir.is_dir() {
        return Some(dir);
    }
    // Written to the terminal directly: the test harness captures `eprintln!` of passing tests.
    let _ = writeln!(std::io::stderr(), "SKIPPED {test}: no shared scenes at {} (set RAYSPLAT_SHARED_SCENES)", dir.display());
    None
}

#[test]
fn every_shared_scene_converts_and_renders() {
    let Some(root) = shared("every_shared_scene_converts_and_renders") else { return };
    let dir = tempfile::tempdir().unwrap();
    for entry in ENTRIES {
        let scene = root.join(entry);
        let out = dir.path().join("out.exr");
        let t0 = Instant::now();
        let o = Command::new(env!("CARGO_BIN_EXE_raysplat"))
            .env("RAYSPLAT_CACHE_DIR", dir.path().join("cache"))
            .args(["render", scene.to_str().unwrap(), "--method", "pt", "--spp", "4", "--resolution", "96x64", "-o", out.to_str().unwrap()])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{entry} failed:\n{err}");
        let warnings = err.lines().filter(|l| l.starts_with("warning:")).count();
        eprintln!("{entry}: rendered in {:.1}s with {warnings} warnings", t0.elapsed().as_secs_f64());
        let film = raysplat::image::read_exr(&out).unwrap();
        assert_eq!(film.nan_count(), 0, "{entry} has NaN/Inf pixels");
        let rgb = film.rgb("").unwrap();
        assert!(rgb.iter().any(|&v| v > 0.0), "{entry} rendered black");
    }
}

/// Crytek Sponza converts and loads whole (its conversion and loading times are a benchmark:
/// `raysplat-bench load`).
#[test]
fn sponza_converts_and_loads() {
    let Some(root) = shared("sponza_converts_and_loads") else { return };
    let dir = tempfile::tempdir().unwrap();
    let rss = dir.path().join("sponza.rss");
    let t0 = Instant::now();
    raysplat::usd::convert(&root.join("classic/crytek_sponza/sponza.usdc"), &rss, &Default::default()).unwrap();
    let convert_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let scene = raysplat::usd::load_scene(&rss).unwrap();
    let load_s = t1.elapsed().as_secs_f64();
    let tris: usize = scene.instances.iter().map(|i| scene.meshes[i.mesh as usize].indices.len()).sum();
    eprintln!("sponza: convert {convert_s:.1}s, load {load_s:.2}s, {tris} triangles");
    assert!(tris > 250_000, "{tris} triangles");
    assert_eq!(scene.meshes.len(), 381);
}
