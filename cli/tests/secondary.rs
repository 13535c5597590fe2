//! Strong secondary lights as the command line reports them: `raysplat info` says whether a scene
//! has them, and bad he-fg options are clean errors.

use std::path::Path;

fn cli(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_raysplat"))
        .env("RAYSPLAT_CACHE_DIR", Path::new(env!("CARGO_TARGET_TMPDIR")).join("convert-cache"))
        .args(args)
        .output()
        .expect("run raysplat")
}

/// `raysplat info` says whether a scene has strong secondary lights; bad he-fg options are clean errors.
#[test]
fn info_reports_strong_secondary_lights() {
    let scene = |n: &str| Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes").join(n).display().to_string();
    let o = cli(&["info", &scene("secondary-light.usda")]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success() && out.contains("strong secondary lights: yes ("), "{out}");
    let o = cli(&["info", &scene("furnace.usda")]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success() && out.contains("strong secondary lights: no (0 high-energy voxels"), "{out}");
    for bad in [["--explicit-allocation", "most"], ["--cache-error", "0"], ["--emax", "0"]] {
        let o = cli(&["render", &scene("furnace.usda"), "-o", "/tmp/never.exr", "--method", "he-fg", bad[0], bad[1]]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(!err.contains("panicked") && err.contains(&bad[0][2..]), "{err}");
    }
}
