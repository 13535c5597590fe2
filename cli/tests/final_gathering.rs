//! Final gathering in a `raysplat render` child process, where the process's own figures count:
//! run with and without a budget far below the unconstrained `A_r + A_w`, it reports its peak RSS
//! (`VmHWM`); the budgeted run's gather stage stays within the budget, its peak drops by about the
//! bytes the budget removes, and the EXR is the same; a spill goes to `TMPDIR`, and an unwritable
//! `TMPDIR` falls back to tasks with a warning.

#[path = "../../tests/common/mod.rs"]
mod common;

use common::max_rel_diff;

/// One `raysplat render --json` child process: (stats JSON, beauty, indirect).
fn render_child(dir: &std::path::Path, name: &str, extra: &[&str]) -> (serde_json::Value, Vec<f32>, Vec<f32>) {
    render_child_in(dir, name, extra, &std::env::temp_dir())
}

/// As [`render_child`], with `TMPDIR` set to `tmp`.
fn render_child_in(dir: &std::path::Path, name: &str, extra: &[&str], tmp: &std::path::Path) -> (serde_json::Value, Vec<f32>, Vec<f32>) {
    let exr = dir.join(format!("{name}.exr"));
    let scene = format!("{}/../scenes/cornell-box.usda", env!("CARGO_MANIFEST_DIR"));
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_raysplat"))
        .env("TMPDIR", tmp)
        .args(["render", &scene, "-o", exr.to_str().unwrap(), "--json", "--method", "rpm-fg", "--threads", "2"])
        .args(["--resolution", "96x96", "--spp", "1", "--fg-rays", "128", "--photons", "20000", "--gather-radius", "0.03", "--seed", "3"])
        .args(extra)
        .output()
        .expect("run raysplat");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("stats JSON");
    let film = raysplat::image::read_exr(&exr).expect("read EXR");
    (json, film.rgb("").unwrap(), film.rgb("indirect").unwrap())
}

fn json_counter(j: &serde_json::Value, name: &str) -> u64 {
    j["counters"].as_array().unwrap().iter().find(|c| c[0] == name).unwrap_or_else(|| panic!("no counter {name}"))[1].as_u64().unwrap()
}

#[test]
fn a_memory_budget_bounds_the_measured_peak_rss_with_the_same_image() {
    let dir = tempfile::tempdir().unwrap();
    // 96² × 1 eye sample × 128 gather rays: ≈ 0.8 M gather hits, ≈ 33 MiB of A_r + A_w in one task.
    let budget: u64 = 8 << 20;
    let (free, free_rgb, free_ind) = render_child(dir.path(), "free", &[]);
    let (tight, tight_rgb, tight_ind) = render_child(dir.path(), "tight", &["--memory", "8M", "--no-spill"]);
    // Without --no-spill, 12 tasks are more than the break-even: A_r spills into TMPDIR.
    let tmp = tempfile::tempdir().unwrap();
    let (auto, auto_rgb, auto_ind) = render_child_in(dir.path(), "auto", &["--memory", "8M"], tmp.path());
    let arrays = |j: &serde_json::Value| {
        j["enabled"].as_array().unwrap().iter().find(|e| e[0].as_str().unwrap().starts_with("A_r + A_w")).unwrap()[1].as_u64().unwrap()
    };
    let peak = |j: &serde_json::Value| j["peak_rss_bytes"].as_u64().unwrap();
    let stage = |j: &serde_json::Value| peak(j).saturating_sub(json_counter(j, "rss_before_gather_bytes"));
    let mib = |b: u64| b as f64 / (1u64 << 20) as f64;
    let report = format!(
        "unconstrained: A_r + A_w {:.1} MiB, peak RSS {:.1} MiB, gather stage {:.1} MiB; --memory 8M: {} tasks, peak RSS {:.1} MiB, gather stage {:.1} MiB",
        mib(arrays(&free)),
        mib(peak(&free)),
        mib(stage(&free)),
        json_counter(&tight, "fg_tasks"),
        mib(peak(&tight)),
        mib(stage(&tight))
    ) + &format!("; automatic spill: peak RSS {:.1} MiB, gather stage {:.1} MiB", mib(peak(&auto)), mib(stage(&auto)));
    eprintln!("{report}");
    assert!(peak(&free) > 0, "no peak RSS reported (not Linux?)");
    assert!(arrays(&free) > 4 * budget, "{report}");
    assert!(json_counter(&tight, "fg_tasks") >= 4, "{report}");
    assert_eq!((json_counter(&tight, "fg_spilled"), json_counter(&auto, "fg_spilled")), (0, 1), "{report}");
    let notes = |j: &serde_json::Value| j["notes"].as_array().unwrap().iter().map(|n| n.as_str().unwrap().to_string()).collect::<Vec<_>>().join("\n");
    assert!(notes(&tight).contains("tasks in memory (--no-spill)"), "{}", notes(&tight));
    let said = notes(&auto);
    assert!(said.contains(&format!("spilled to {}", tmp.path().display())) && said.contains("tasks would cost more search"), "{said}");
    assert!(json_counter(&auto, "spill_chunks") >= 2, "{report}");
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 0, "automatic spill directory left behind");
    assert!(stage(&auto) <= budget, "{report}");
    // The unconstrained gather stage really holds its arrays; the budgeted one stays within budget.
    assert!(stage(&free) >= arrays(&free), "{report}");
    assert!(stage(&tight) <= budget, "{report}");
    // The peak drops by about the bytes the budget removes (at least 80 % of them).
    let removed = arrays(&free) - budget;
    assert!(peak(&free) >= peak(&tight) + removed * 4 / 5, "{report}");
    for (name, a, b) in [("beauty", &free_rgb, &tight_rgb), ("indirect", &free_ind, &tight_ind), ("spilled beauty", &free_rgb, &auto_rgb), ("spilled indirect", &free_ind, &auto_ind)] {
        assert!(a.iter().any(|&v| v > 0.0));
        let d = max_rel_diff(a, b);
        assert!(d <= 1e-5, "{name}: largest per-pixel relative difference {d:e}");
    }
}

/// When the temporary directory cannot hold a spill, the budget is met by tasks, with a warning.
#[test]
fn an_unwritable_temporary_directory_falls_back_to_tasks_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no-such-tmp");
    let (j, rgb, _) = render_child_in(dir.path(), "fallback", &["--memory", "8M"], &missing);
    let notes: Vec<&str> = j["notes"].as_array().unwrap().iter().map(|n| n.as_str().unwrap()).collect();
    assert_eq!(json_counter(&j, "fg_spilled"), 0);
    assert!(json_counter(&j, "fg_tasks") > raysplat::gather::schedule::AUTO_SPILL_TASKS as u64, "{notes:?}");
    assert!(notes.iter().any(|n| n.starts_with("warning: could not spill") && n.contains("no-such-tmp") && n.contains("tasks in memory instead")), "{notes:?}");
    assert!(rgb.iter().any(|&v| v > 0.0));
    assert!(!missing.exists());
}
