//! The command line as a user meets it: rendering the repository's scenes, independent EXR
//! readers, and bad input (clear message, non-zero exit, no panic, no partial output).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_raysplat"));
    c.env("RAYSPLAT_CACHE_DIR", cache_dir());
    c
}

fn cache_dir() -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join("convert-cache")
}

fn repo(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(p)
}

fn run(args: &[&str]) -> Output {
    bin().args(args).output().expect("run raysplat")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn assert_clean_failure(o: &Output, needles: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "exit status {:?}, stderr:\n{err}", o.status);
    assert!(!err.contains("panicked"), "panic:\n{err}");
    assert!(!err.contains("Traceback"), "python traceback:\n{err}");
    for n in needles {
        assert!(err.contains(n), "stderr lacks {n:?}:\n{err}");
    }
}

#[test]
fn cornell_box_renders_to_a_valid_exr_and_png() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("x.exr");
    let png = dir.path().join("x.png");
    let scene = repo("scenes/cornell-box.usda");
    let o = run(&["render", scene.to_str().unwrap(), "--method", "pt", "--spp", "64", "--resolution", "64x64", "-o", exr.to_str().unwrap(), "--preview", png.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let film = raysplat::image::read_exr(&exr).unwrap();
    assert_eq!((film.width, film.height), (64, 64));
    assert_eq!(film.nan_count(), 0);
    for layer in ["albedo", "normal", "depth", "direct", "indirect"] {
        assert!(film.layer(layer).is_some(), "missing AOV {layer}");
    }
    let mean: f32 = film.rgb("").unwrap().iter().sum::<f32>() / (64.0 * 64.0 * 3.0);
    assert!(mean > 0.01 && mean.is_finite(), "mean {mean}");
    assert!(png.exists());
    // An independent reader: Debian's OpenEXR tools.
    match Command::new("exrheader").arg(&exr).output() {
        Ok(h) => {
            let text = String::from_utf8_lossy(&h.stdout);
            assert!(h.status.success(), "exrheader failed: {}", String::from_utf8_lossy(&h.stderr));
            for ch in ["R, 32-bit floating-point", "albedo.R", "depth.Z", "raysplat:method"] {
                assert!(text.contains(ch), "exrheader output lacks {ch}:\n{text}");
            }
        }
        Err(_) => eprintln!("skipped the exrheader check: Debian's openexr tools are not installed"),
    }
}

/// `convert` writes a scene file others can read (the usual `0666 & !umask`, not a temporary
/// file's 0600), and names a missing output directory.
#[test]
fn converted_scene_has_the_usual_permissions() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("box.rss");
    let scene = repo("scenes/cornell-box.usda");
    let o = run(&["convert", scene.to_str().unwrap(), out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::fs::PermissionsExt;
        let status = std::fs::read_to_string("/proc/self/status").unwrap();
        let umask = status.lines().find_map(|l| l.strip_prefix("Umask:")).map(|v| u32::from_str_radix(v.trim(), 8).unwrap()).unwrap();
        let mode = std::fs::metadata(&out).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o666 & !umask, "mode {mode:o} with umask {umask:o}");
    }
    let missing = dir.path().join("no-such-dir").join("box.rss");
    assert_clean_failure(&run(&["convert", scene.to_str().unwrap(), missing.to_str().unwrap()]), &["no-such-dir", "does not exist"]);
}

/// A negative exposure is given as users write it, after a space (`--exposure -2`), and darkens
/// the preview.
#[test]
fn negative_exposure_after_a_space_darkens_the_preview() {
    let dir = tempfile::tempdir().unwrap();
    let scene = repo("scenes/cornell-box.usda");
    let exr = dir.path().join("x.exr");
    let png = |stops: &str| {
        let png = dir.path().join(format!("x{stops}.png"));
        let o = run(&["render", scene.to_str().unwrap(), "--method", "pt", "--spp", "2", "--resolution", "16x16", "-o", exr.to_str().unwrap(), "--preview", png.to_str().unwrap(), "--exposure", stops]);
        assert!(o.status.success(), "--exposure {stops}: {}", stderr(&o));
        std::fs::read(&png).unwrap()
    };
    let (normal, dark) = (png("0"), png("-2"));
    assert_ne!(normal, dark, "--exposure -2 left the preview unchanged");
}

#[test]
fn compare_reports_zero_error_against_itself_and_json() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("a.exr");
    let scene = repo("scenes/cornell-box.usda");
    let o = run(&["render", scene.to_str().unwrap(), "--spp", "2", "--resolution", "16x16", "-o", exr.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err_png = dir.path().join("err.png");
    let o = run(&["compare", exr.to_str().unwrap(), exr.to_str().unwrap(), "--json", "--error-image", err_png.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["rel_mse"].as_f64(), Some(0.0));
    assert_eq!(v["rmse"].as_f64(), Some(0.0));
    assert!(err_png.exists());
}

#[test]
fn info_lists_requirements() {
    let o = run(&["info", repo("scenes/cornell-box.usda").to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("requires: diffuse yes"), "{out}");
    assert!(out.contains("rect"), "{out}");
    assert!(out.contains("auto: rs for preview quality — no caustics"), "{out}");
    assert!(out.contains("100000 photons, 2 eye spp, 16 camera spp"), "{out}");
    // a room lit through a spot-lit patch: the survey finds strong secondary light, auto takes rs
    let o = run(&["info", repo("scenes/secondary-light.usda").to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("auto: rs for preview quality — strong secondary light"), "{out}");
    assert!(out.contains("400000 photons, 2 eye spp, 32 camera spp"), "{out}");
}

#[test]
fn missing_scene_file_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.exr");
    let o = run(&["render", "/nonexistent/scene.usda", "-o", out.to_str().unwrap()]);
    assert_clean_failure(&o, &["/nonexistent/scene.usda"]);
    assert!(!out.exists());
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

const MESH_HEAD: &str = "#usda 1.0\n(\n    metersPerUnit = 1\n    upAxis = \"Y\"\n)\n";

#[test]
fn malformed_usd_is_a_clear_error_without_output() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.exr");
    let bad = write(dir.path(), "syntax.usda", "#usda 1.0\ndef Mesh \"M\" {\n  point3f[] points = [(0,0,0), (1,0\n}\n");
    let o = run(&["render", bad.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_clean_failure(&o, &["syntax.usda"]);
    assert!(!out.exists());
    let nan = write(
        dir.path(),
        "nan.usda",
        &format!("{MESH_HEAD}def Mesh \"Tri\"\n{{\n    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, nan, 0)]\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n}}\n"),
    );
    let o = run(&["render", nan.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_clean_failure(&o, &["nan.usda", "/Tri"]);
    assert!(!out.exists());
    let range = write(
        dir.path(),
        "range.usda",
        &format!("{MESH_HEAD}def Mesh \"Tri\"\n{{\n    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 7]\n}}\n"),
    );
    let o = run(&["render", range.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_clean_failure(&o, &["range.usda", "/Tri"]);
    assert!(!out.exists());
    // a stage left without geometry says why: the converter's warnings come with the error
    let holes = write(
        dir.path(),
        "holes.usda",
        &format!("{MESH_HEAD}def Mesh \"Holes\"\n{{\n    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n    int[] holeIndices = [0]\n    uniform token subdivisionScheme = \"none\"\n}}\n"),
    );
    let o = run(&["render", holes.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_clean_failure(&o, &["holes.usda", "no renderable geometry", "warning: /Holes: mesh has no triangles"]);
    assert!(!out.exists());
}

#[test]
fn absurd_parameters_are_rejected_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.exr");
    let scene = repo("scenes/cornell-box.usda");
    let s = scene.to_str().unwrap();
    let o = out.to_str().unwrap();
    assert_clean_failure(&run(&["render", s, "-o", o, "--spp", "0"]), &["spp"]);
    assert_clean_failure(&run(&["render", s, "-o", o, "--resolution", "0x10"]), &["resolution"]);
    assert_clean_failure(&run(&["render", s, "-o", o, "--resolution", "banana"]), &["resolution"]);
    assert_clean_failure(&run(&["render", s, "-o", o, "--method", "nope"]), &["method", "nope"]);
    assert_clean_failure(&run(&["render", s, "-o", o, "--time=-1"]), &["time"]);
    // a negative number after a space is the option's value (its range error, not clap's
    // "unexpected argument")
    assert_clean_failure(&run(&["render", s, "-o", o, "--time", "-1"]), &["time", "positive"]);
    assert_clean_failure(&run(&["render", s, "-o", o, "--method", "rs", "--smoothness", "-0.5"]), &["smoothness", "-0.5"]);
    assert_clean_failure(&run(&["render", s, "-o", o, "--exposure=nan"]), &["exposure"]);
    assert_clean_failure(&run(&["render", s, "-o", o, "--exposure=1000"]), &["exposure"]);
    assert_clean_failure(&run(&["render", s, "-o", "/nonexistent-dir/x.exr"]), &["/nonexistent-dir"]);
    // a render that cannot fit in memory (its eye samples alone: 16384² × 4096 × 36 B = 40 TB) is
    // refused, not aborted part way through on a failed allocation
    assert_clean_failure(&run(&["render", s, "-o", o, "--method", "rs", "--resolution", "16384x16384", "--spp", "4096"]), &["resolution", "memory", "available"]);
    assert!(!out.exists());
    // an output that is a directory, or named as another image format: refused before rendering
    // (no `scene:` summary), nothing written
    let o = run(&["render", s, "-o", dir.path().to_str().unwrap()]);
    assert_clean_failure(&o, &["is a directory"]);
    assert!(!stderr(&o).contains("scene:"), "rendered first:\n{}", stderr(&o));
    let png = dir.path().join("x.png");
    assert_clean_failure(&run(&["render", s, "-o", png.to_str().unwrap()]), &["x.png", "OpenEXR", "name it .exr"]);
    assert!(!png.exists());
}

/// An error wrapping another says the inner one once (`error: FILE: reason`, not the reason twice).
#[test]
fn error_causes_are_printed_once() {
    let o = run(&["compare", "/nonexistent/a.exr", "/nonexistent/b.exr"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    let line = err.lines().find(|l| l.starts_with("error: ")).unwrap_or_else(|| panic!("no error line:\n{err}"));
    assert!(line.contains("/nonexistent/a.exr"), "{line}");
    let reason = line.rsplit(": ").next().unwrap();
    assert_eq!(line.matches(reason).count(), 1, "the cause repeats: {line}");
}

/// `--method auto` (the default) says what it chose and why, and records it in the EXR header; a
/// photon method under `--time` renders passes; `--quality` is for auto only.
#[test]
fn auto_method_explains_its_choice_and_photon_methods_take_a_time_budget() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("auto.exr");
    let scene = repo("scenes/cornell-box.usda");
    let s = scene.to_str().unwrap();
    let o = run(&["render", s, "--quality", "draft", "--resolution", "128x128", "-o", exr.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("auto: rs for draft quality — no caustics"), "{}", stderr(&o));
    let o = run(&["render", s, "--quality", "final", "--spp", "2", "--resolution", "8x8", "-o", exr.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("auto: pt for final quality — no caustics"), "{}", stderr(&o));
    let header = String::from_utf8_lossy(&std::fs::read(&exr).unwrap()).into_owned();
    assert!(header.contains("raysplat:auto"), "the EXR header does not record the choice");
    let timed = dir.path().join("timed.exr");
    let o = run(&["render", s, "--method", "pm", "--time", "2", "--photons", "500", "--resolution", "8x8", "--json", "-o", timed.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let stats: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let passes = stats["counters"].as_array().unwrap().iter().find(|c| c[0] == "passes").map(|c| c[1].as_u64().unwrap());
    assert!(passes.is_some_and(|p| p >= 2), "passes: {passes:?}");
    let o = dir.path().join("x.exr");
    let o = o.to_str().unwrap();
    assert_clean_failure(&run(&["render", s, "-o", o, "--method", "pt", "--quality", "final"]), &["quality"]);
    assert_clean_failure(&run(&["render", s, "-o", o, "--quality", "best"]), &["quality", "best"]);
    assert_clean_failure(&run(&["render", s, "-o", o, "--quality", "final", "--time", "3"]), &["quality"]);
}

/// `raysplat study` writes study.json (the documented keys, one row per method and budget),
/// study.csv, study.md and the error-against-time plot.
#[test]
fn study_writes_rows_with_the_documented_keys() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("study");
    let scene = repo("scenes/cornell-box.usda");
    let o = run(&[
        "study", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--methods", "pt,pm,rpm-fg",
        "--budgets", "1,2", "--reference-spp", "16", "--resolution", "12x12",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let rows: Vec<serde_json::Value> = serde_json::from_slice(&std::fs::read(out.join("study.json")).unwrap()).unwrap();
    assert_eq!(rows.len(), 6);
    for r in &rows {
        for k in ["method", "params", "seconds", "phase_seconds", "peak_bytes", "rel_mse", "rmse", "over_5", "over_15", "over_30", "nan"] {
            assert!(r.get(k).is_some(), "row lacks {k}: {r}");
        }
        assert!(r["rel_mse"].as_f64().unwrap().is_finite() && r["nan"] == 0, "{r}");
    }
    assert_eq!(rows.iter().filter(|r| r["method"] == "rpm-fg").count(), 2);
    for f in ["study.csv", "study.md", "error-vs-time.png"] {
        assert!(out.join(f).metadata().unwrap().len() > 0, "{f} missing");
    }
}

/// The study's ladder scales the axes `--ladder` names, and `--smoothness` renders the splatting
/// methods once per value; bad values are clear errors.
#[test]
fn study_ladders_scale_the_named_axes() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("study");
    let scene = repo("scenes/cornell-box.usda");
    let (s, o) = (scene.to_str().unwrap(), out.to_str().unwrap());
    let r = run(&[
        "study", s, "-o", o, "--methods", "pm,rs,rpm-fg", "--budgets", "1,4", "--ladder", "photons,spp,fg-rays",
        "--smoothness", "0.2,0.4", "--reference-spp", "8", "--resolution", "8x8",
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    let rows: Vec<serde_json::Value> = serde_json::from_slice(&std::fs::read(out.join("study.json")).unwrap()).unwrap();
    // pm ×2 budgets, rs ×2 budgets ×2 smoothness values, rpm-fg ×2
    assert_eq!(rows.len(), 8);
    let p = |r: &serde_json::Value, k: &str| r["params"][k].as_f64().unwrap();
    for r in &rows {
        let photons = p(r, "photons");
        let b = photons / 25_000.0;
        assert!(b == 1.0 || b == 4.0, "{r}");
        // several axes: the per-pixel ones scale by the largest power of two ≤ √b
        assert_eq!(p(r, "spp"), 4.0 * b.sqrt(), "{r}");
        if r["method"] == "rpm-fg" {
            assert_eq!(p(r, "fg_rays"), rows.iter().find(|q| q["method"] == "rpm-fg").map(|q| p(q, "fg_rays")).unwrap() * if b == 4.0 { 2.0 } else { 1.0 }, "{r}");
        }
    }
    let mut cs: Vec<f64> = rows.iter().filter(|r| r["method"] == "rs").map(|r| p(r, "smoothness")).collect();
    cs.sort_by(f64::total_cmp);
    assert_eq!(cs, [0.2, 0.2, 0.4, 0.4]);
    assert_clean_failure(&run(&["study", s, "-o", o, "--ladder", "photons,gather"]), &["ladder"]);
    assert_clean_failure(&run(&["study", s, "-o", o, "--smoothness=0.3,-1"]), &["smoothness"]);
}

/// The study's camera samples (`--eye-spp`, `--aa-spp`, scaled by the `spp` axis), its time limit
/// per method (`--max-seconds`: later budgets skipped and listed) and its errors against the
/// converged image (the same reference noise taken off every row).
#[test]
fn study_camera_samples_time_limit_and_converged_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("study");
    let scene = repo("scenes/cornell-box.usda");
    let (s, o) = (scene.to_str().unwrap(), out.to_str().unwrap());
    let r = run(&[
        "study", s, "-o", o, "--methods", "pt,rs", "--budgets", "1,4", "--ladder", "photons,spp", "--eye-spp", "1",
        "--aa-spp", "3", "--reference-spp", "16", "--resolution", "10x10",
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    let rows: Vec<serde_json::Value> = serde_json::from_slice(&std::fs::read(out.join("study.json")).unwrap()).unwrap();
    assert_eq!(rows.len(), 4);
    let p = |r: &serde_json::Value, k: &str| r["params"][k].as_f64().unwrap();
    for r in rows.iter().filter(|r| r["method"] == "rs") {
        let b = p(r, "photons") / 25_000.0;
        assert_eq!((p(r, "spp"), p(r, "aa_spp")), (b.sqrt(), 3.0 * b.sqrt()), "{r}");
    }
    let noise: Vec<f64> = rows.iter().map(|r| r["rel_mse"].as_f64().unwrap() - r["rel_mse_converged"].as_f64().unwrap()).collect();
    assert!(noise[0] > 0.0 && noise.iter().all(|n| (n - noise[0]).abs() < 1e-12), "{noise:?}");
    assert!(std::fs::read_to_string(out.join("study.md")).unwrap().contains("converged"));

    let r = run(&["study", s, "-o", o, "--methods", "pt,pm", "--budgets", "1,2,4", "--max-seconds", "1e-9", "--reference-spp", "4", "--resolution", "6x6"]);
    assert!(r.status.success(), "{}", stderr(&r));
    let rows: Vec<serde_json::Value> = serde_json::from_slice(&std::fs::read(out.join("study.json")).unwrap()).unwrap();
    assert_eq!(rows.len(), 2, "only the first budget of each method");
    let md = std::fs::read_to_string(out.join("study.md")).unwrap();
    for k in ["pt ×2: skipped", "pt ×4: skipped", "pm ×2: skipped", "pm ×4: skipped"] {
        assert!(md.contains(k), "study.md lacks {k:?}:\n{md}");
    }
    assert_clean_failure(&run(&["study", s, "-o", o, "--eye-spp", "4", "--aa-spp", "2"]), &["aa-spp"]);
    assert_clean_failure(&run(&["study", s, "-o", o, "--eye-spp", "0"]), &["eye-spp"]);
    assert_clean_failure(&run(&["study", s, "-o", o, "--max-seconds", "0"]), &["max-seconds"]);
}

/// A reader that closes the pipe early (`raysplat … | head`) ends the command quietly with the
/// shell's SIGPIPE status, not a panic and a backtrace.
#[test]
fn closed_stdout_is_not_a_panic() {
    use std::io::Read;
    use std::process::Stdio;
    let mut child = bin().args(["info", repo("scenes/cornell-box.usda").to_str().unwrap()]).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    drop(child.stdout.take()); // the reader goes away before anything is written
    let mut err = String::new();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    let status = child.wait().unwrap();
    assert!(!err.contains("panicked"), "stderr: {err}");
    assert!(matches!(status.code(), Some(0) | Some(141)), "status {status:?}, stderr: {err}");
}

/// A stage with two cameras (/Front, /High) and a card that moves across the view from time code 1
/// to 10 (`--camera`, `--frame`, `--frames`).
fn views_stage(dir: &Path) -> PathBuf {
    write(
        dir,
        "views.usda",
        "#usda 1.0\n(\n    startTimeCode = 1\n    endTimeCode = 10\n    metersPerUnit = 1\n    upAxis = \"Y\"\n)\n\
         def Mesh \"Floor\" {\n    int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 2, 3]\n\
             point3f[] points = [(-5, 0, 5), (5, 0, 5), (5, 0, -5), (-5, 0, -5)]\n}\n\
         def Mesh \"Card\" {\n    int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 2, 3]\n\
             point3f[] points = [(-1, 0, 0), (1, 0, 0), (1, 2, 0), (-1, 2, 0)]\n\
             double3 xformOp:translate.timeSamples = { 1: (-1.5, 0, 0), 10: (1.5, 0, 0) }\n\
             uniform token[] xformOpOrder = [\"xformOp:translate\"]\n}\n\
         def DistantLight \"Sun\" {\n    float inputs:intensity = 3\n    float3 xformOp:rotateXYZ = (-60, 0, 0)\n\
             uniform token[] xformOpOrder = [\"xformOp:rotateXYZ\"]\n}\n\
         def Camera \"Front\" {\n    double3 xformOp:translate = (0, 1, 8)\n    uniform token[] xformOpOrder = [\"xformOp:translate\"]\n}\n\
         def Camera \"High\" {\n    double3 xformOp:translate = (0, 8, 8)\n    float3 xformOp:rotateXYZ = (-45, 0, 0)\n\
             uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:rotateXYZ\"]\n}\n",
    )
}

/// A stage with two cameras and an animated quad: `--camera` and `--frame` choose what is read,
/// each choice is a conversion of its own in the cache, and the EXR header records both.
#[test]
fn camera_and_frame_choose_the_view_of_a_stage() {
    let dir = tempfile::tempdir().unwrap();
    let stage = views_stage(dir.path());
    let s = stage.to_str().unwrap();
    let o = run(&["info", s]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(text.contains("camera: /Front, at time code 1"), "{text}");
    assert!(text.contains("the stage's cameras (--camera): /Front, /High"), "{text}");
    assert!(text.contains("the stage's time codes: 1 to 10 (--frame, --frames 1:10)"), "{text}");
    let render = |name: &str, extra: &[&str]| {
        let exr = dir.path().join(name);
        let mut args = vec!["render", s, "--method", "pt", "--spp", "2", "--resolution", "24x16", "-o", exr.to_str().unwrap()];
        args.extend_from_slice(extra);
        let o = run(&args);
        assert!(o.status.success(), "{extra:?}: {}", stderr(&o));
        let attr = |a: &str| raysplat::image::read_exr_string_attribute(&exr, a).unwrap();
        (attr("raysplat:camera"), attr("raysplat:frame"), raysplat::image::read_exr(&exr).unwrap().layer("depth").expect("depth layer").data.clone())
    };
    // the default view first: a cache that ignored the options would serve it to the others
    let (cam, frame, front) = render("front.exr", &[]);
    assert_eq!((cam.as_deref(), frame.as_deref()), (Some("/Front"), Some("1")));
    let (cam, _, high) = render("high.exr", &["--camera", "/High"]);
    assert_eq!(cam.as_deref(), Some("/High"));
    assert_ne!(front, high, "--camera /High rendered the default camera's view");
    let (cam, frame, later) = render("later.exr", &["--frame", "10"]);
    assert_eq!((cam.as_deref(), frame.as_deref()), (Some("/Front"), Some("10")));
    assert_ne!(front, later, "--frame 10 rendered the card where it is at frame 1");
    let (_, frame, again) = render("again.exr", &["--frame", "1"]);
    assert_eq!((frame.as_deref(), &again), (Some("1"), &front), "--frame 1 is the default view");
    // bad choices: the file and the prim named, the stage's cameras listed, nothing written
    let out = dir.path().join("bad.exr");
    let o = run(&["render", s, "--camera", "/Floor", "-o", out.to_str().unwrap()]);
    assert_clean_failure(&o, &[s, "/Floor: is a Mesh, not a Camera", "the stage's cameras: /Front, /High"]);
    let o = run(&["render", s, "--camera", "/Nope", "-o", out.to_str().unwrap()]);
    assert_clean_failure(&o, &["/Nope: no such prim"]);
    let study = dir.path().join("study");
    let o = run(&["study", s, "--camera", "/Nope", "-o", study.to_str().unwrap()]);
    assert_clean_failure(&o, &["/Nope: no such prim"]);
    let o = run(&["render", s, "--frame", "nan", "-o", out.to_str().unwrap()]);
    assert_clean_failure(&o, &["frame", "not a finite time code"]);
    let rss = dir.path().join("views.rss");
    let o = run(&["convert", s, rss.to_str().unwrap(), "--camera", "/High"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&["render", rss.to_str().unwrap(), "--camera", "/Front", "-o", out.to_str().unwrap()]);
    assert_clean_failure(&o, &[rss.to_str().unwrap(), "a converted scene keeps the camera"]);
    assert!(!out.exists());
    // the converted scene keeps the camera it was converted with
    let o = run(&["info", rss.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("camera: /High"), "{}", String::from_utf8_lossy(&o.stdout));
}

/// `--subdivision` says what the stage's subdivision surfaces become (the two quads of the views
/// stage have USD's default scheme, catmullClark): `auto` and a level hand them to Embree as
/// cages (a level N tessellates 2^N segments per edge), `cage` and `--subdivision-level 0` render
/// the cages' polygons; one conversion serves every choice, which applies to a converted scene too;
/// a level beyond 6, or both options, are refused.
#[test]
fn subdivision_chooses_what_subdivision_surfaces_become() {
    let dir = tempfile::tempdir().unwrap();
    let stage = views_stage(dir.path());
    let s = stage.to_str().unwrap();
    let geometry = |file: &str, extra: &[&str]| {
        let mut args = vec!["info", file];
        args.extend_from_slice(extra);
        let o = run(&args);
        assert!(o.status.success(), "{extra:?}: {}", stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        let lines: Vec<&str> = text.lines().skip_while(|l| !l.starts_with("geometry:")).take(2).collect();
        lines.join("\n")
    };
    let embree = |quads: u32| format!("geometry: 2 meshes, 2 instances, 0 triangles\n  subdivision surfaces: 2 cage faces, tessellated by Embree into about {quads} quads");
    assert_eq!(geometry(s, &["--subdivision", "2"]), embree(2 * 16));
    assert_eq!(geometry(s, &["--subdivision-level", "1"]), embree(2 * 4));
    let auto = geometry(s, &[]);
    assert!(auto.starts_with("geometry: 2 meshes, 2 instances, 0 triangles\n  subdivision surfaces: 2 cage faces, tessellated by Embree"), "{auto}");
    for cage in [&["--subdivision", "cage"][..], &["--subdivision-level", "0"]] {
        assert!(geometry(s, cage).starts_with("geometry: 2 meshes, 2 instances, 4 triangles\nbounds"), "{cage:?}: {}", geometry(s, cage));
    }
    let out = dir.path().join("bad.exr");
    let o = run(&["render", s, "--subdivision-level", "7", "-o", out.to_str().unwrap()]);
    assert_clean_failure(&o, &["subdivision-level", "7 is more than 6"]);
    let o = run(&["render", s, "--subdivision", "2", "--subdivision-level", "2", "-o", out.to_str().unwrap()]);
    assert_clean_failure(&o, &["--subdivision"]);
    assert!(!out.exists());
    // the converted scene keeps the cages: every choice applies to it
    let rss = dir.path().join("views.rss");
    let o = run(&["convert", s, rss.to_str().unwrap(), "--subdivision-level", "0"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("--subdivision applies when rendering"), "{}", stderr(&o));
    assert_eq!(geometry(rss.to_str().unwrap(), &["--subdivision", "2"]), embree(2 * 16));
    let o = run(&["render", rss.to_str().unwrap(), "--subdivision", "cage", "--method", "pt", "--spp", "1", "--resolution", "8x8", "-o", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A `UsdTransform2d` on a texture's st reaches the loaded scene as the texture's `st_transform`.
#[test]
fn texture_coordinate_transforms_reach_the_scene() {
    const LOOKS: &str = "def Scope \"Looks\" {\n def Material \"T\" {\n  token outputs:surface.connect = </Looks/T/S.outputs:surface>\n\
          def Shader \"S\" {\n   uniform token info:id = \"UsdPreviewSurface\"\n   color3f inputs:diffuseColor.connect = </Looks/T/Tex.outputs:rgb>\n   token outputs:surface\n  }\n\
          def Shader \"Tex\" {\n   uniform token info:id = \"UsdUVTexture\"\n   asset inputs:file = @tiles.png@\n   float2 inputs:st.connect = </Looks/T/Xf.outputs:result>\n   float3 outputs:rgb\n  }\n\
          def Shader \"Xf\" {\n   uniform token info:id = \"UsdTransform2d\"\n   float2 inputs:in.connect = </Looks/T/St.outputs:result>\n   float2 inputs:scale = (2, 3)\n   float2 outputs:result\n  }\n\
          def Shader \"St\" {\n   uniform token info:id = \"UsdPrimvarReader_float2\"\n   string inputs:varname = \"st\"\n   float2 outputs:result\n  }\n }\n}\n";
    const MESH: &str = "def Mesh \"M\" {\n int[] faceVertexCounts = [4]\n int[] faceVertexIndices = [0, 1, 2, 3]\n\
          point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]\n\
          texCoord2f[] primvars:st = [(0, 0), (1, 0), (1, 1), (0, 1)] (interpolation = \"vertex\")\n\
          uniform token subdivisionScheme = \"none\"\n rel material:binding = </Looks/T>\n}\n";
    let dir = tempfile::tempdir().unwrap();
    let stage = write(dir.path(), "tiled.usda", &format!("{MESH_HEAD}{MESH}{LOOKS}"));
    std::env::set_var("RAYSPLAT_CACHE_DIR", cache_dir());
    let scene = raysplat::usd::load_scene(&stage).unwrap();
    assert_eq!(scene.textures.len(), 1, "{:?}", scene.warnings);
    assert_eq!(scene.textures[0].st_transform, [[2.0, 0.0, 0.0], [0.0, 3.0, 0.0]]);
    assert!(!scene.warnings.iter().any(|w| w.message.contains("Transform2d")), "{:?}", scene.warnings);
}

/// `--frames` renders each frame as `--frame` does, to the names its `#` pattern gives.
#[test]
fn frame_sequences_render_each_frame_to_its_name() {
    let dir = tempfile::tempdir().unwrap();
    let stage = views_stage(dir.path());
    let s = stage.to_str().unwrap();
    let common = ["--method", "pt", "--spp", "2", "--resolution", "24x16"];
    let pattern = dir.path().join("seq.##.exr");
    let o = run(&[&["render", s, "--frames", "1:10:9", "-o", pattern.to_str().unwrap()][..], &common[..]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let names: Vec<_> = ["seq.01.exr", "seq.10.exr"].iter().map(|n| dir.path().join(n)).collect();
    let single = dir.path().join("single.exr");
    let o = run(&[&["render", s, "--frame", "10", "-o", single.to_str().unwrap()][..], &common[..]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let image = |p: &Path| raysplat::image::read_exr(p).unwrap().layer("").unwrap().data.clone();
    assert_eq!(image(&names[1]), image(&single), "frame 10 of the sequence is not the --frame 10 render");
    assert_ne!(image(&names[0]), image(&names[1]));
    for (p, f) in names.iter().zip(["1", "10"]) {
        assert_eq!(raysplat::image::read_exr_string_attribute(p, "raysplat:frame").unwrap().as_deref(), Some(f));
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 4, "views.usda, two frames, single.exr");
    // a name without # is refused before anything renders; so is a .rss file
    let plain = dir.path().join("plain.exr");
    let o = run(&["render", s, "--frames", "1:2", "-o", plain.to_str().unwrap()]);
    assert_clean_failure(&o, &["a frame sequence needs a # in the file name"]);
    let o = run(&["render", s, "--frames", "2:1", "-o", pattern.to_str().unwrap()]);
    assert_clean_failure(&o, &["invalid parameter frames", "the last frame comes before the first"]);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 4);
}

/// The conversion cache keeps to `RAYSPLAT_CACHE_LIMIT`: a conversion per frame does not pile up.
#[test]
fn conversion_cache_keeps_to_its_limit() {
    let dir = tempfile::tempdir().unwrap();
    let stage = views_stage(dir.path());
    let cache = dir.path().join("cache");
    let info = |frame: &str, limit: &str| {
        let o = bin().env("RAYSPLAT_CACHE_DIR", &cache).env("RAYSPLAT_CACHE_LIMIT", limit).args(["info", stage.to_str().unwrap(), "--frame", frame]).output().unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    };
    let conversions = || std::fs::read_dir(&cache).unwrap().flatten().filter(|e| e.path().extension().is_some_and(|x| x == "rss")).count();
    for f in ["1", "2", "3"] {
        info(f, "1G");
    }
    assert_eq!(conversions(), 3);
    // the others count as used within the last minute, so they stay (their times are set ahead of
    // the clock: on a loaded machine the conversions themselves may take longer than the minute)
    for e in std::fs::read_dir(&cache).unwrap().flatten().filter(|e| e.path().extension().is_some_and(|x| x == "rss")) {
        let soon = std::time::SystemTime::now() + std::time::Duration::from_secs(600);
        std::fs::File::options().append(true).open(e.path()).unwrap().set_modified(soon).unwrap();
    }
    info("4", "1K");
    assert_eq!(conversions(), 4);
    // an hour later, a conversion (~2 KB each) leaves only itself
    for e in std::fs::read_dir(&cache).unwrap().flatten().filter(|e| e.path().extension().is_some_and(|x| x == "rss")) {
        let hour_ago = std::time::SystemTime::now() - std::time::Duration::from_secs(3600);
        std::fs::File::options().append(true).open(e.path()).unwrap().set_modified(hour_ago).unwrap();
    }
    info("5", "1K");
    assert_eq!(conversions(), 1);
    let o = bin().env("RAYSPLAT_CACHE_DIR", &cache).env("RAYSPLAT_CACHE_LIMIT", "lots").args(["info", stage.to_str().unwrap()]).output().unwrap();
    assert_clean_failure(&o, &["RAYSPLAT_CACHE_LIMIT", "\"lots\" is not a size"]);
}
