//! Final gathering (docs/final-gathering.md): `pm-fg`, `rpm-fg`, `rs-fg` on `scenes/cornell-box.usda`.
//!
//! - Equivalence (the reverse photon mapping paper's central claim): with a fixed gather radius, the
//!   same photons and the same gather rays, `rpm-fg` and `pm-fg` give the same image, every pixel
//!   within 1e-5 relative (only the summation order differs).
//! - Memory tasks: a budget far below the unconstrained `A_r` splits the render into tasks and the
//!   image stays the same (within 1e-5 relative per pixel); the largest task fits the budget.
//! - External memory (§6.5): with `--spill-dir`, `A_r` goes to disk and comes back in chunks; the
//!   image equals the in-memory one and the spill directory is removed.
//! - Density control (§6.2): the controlled map has fewer photons, pm-fg and rpm-fg still agree per
//!   pixel on it at a fixed radius, with fewer pairs and the same mean indirect light (energy kept).
//! - Accuracy against the path tracer on the indirect layer (the direct light is the same explicit
//!   light sampling in all methods). Small images: the file takes a few seconds in release.

mod common;
use common::max_rel_diff;
use common::repo::load;

use raysplat::integrators::{render, Method, RenderOutput, RenderRequest, RenderSettings, SilentProgress};
use raysplat::scene::SceneDesc;


fn run(scene: &SceneDesc, s: &RenderSettings) -> RenderOutput {
    let out = render(scene.clone(), s, &SilentProgress).expect("render");
    assert_eq!(out.film.nan_count(), 0, "{} rendered NaN/Inf values", s.method.method());
    out
}

fn fg_request(method: Method, res: u32, rays: u32, radius: Option<f32>, memory: Option<u64>) -> RenderRequest {
    RenderRequest {
        method: Some(method),
        spp: Some(2),
        seed: 5,
        resolution: Some([res, res]),
        photons: Some(40_000),
        fg_rays: Some(rays),
        gather_radius: radius,
        memory,
        ..Default::default()
    }
}

fn settings(r: RenderRequest) -> RenderSettings {
    r.settings().unwrap_or_else(|e| panic!("{e}"))
}

fn fg(method: Method, res: u32, rays: u32, radius: Option<f32>, memory: Option<u64>) -> RenderSettings {
    settings(fg_request(method, res, rays, radius, memory))
}

fn counter(o: &RenderOutput, name: &str) -> u64 {
    o.stats.counters.iter().find(|(n, _)| n == name).map(|c| c.1).unwrap_or_else(|| panic!("no counter {name}"))
}

#[test]
fn rpm_fg_and_pm_fg_agree_per_pixel_with_a_fixed_radius() {
    let scene = load("cornell-box.usda");
    let pm = run(&scene, &fg(Method::PmFg, 32, 16, Some(0.04), None));
    let rpm = run(&scene, &fg(Method::RpmFg, 32, 16, Some(0.04), None));
    assert_eq!(counter(&pm, "photons_found"), counter(&rpm, "photons_found"), "the same pairs must be found");
    assert!(counter(&pm, "photons_found") > 1_000_000);
    for layer in ["indirect", ""] {
        let (a, b) = (pm.film.rgb(layer).unwrap(), rpm.film.rgb(layer).unwrap());
        assert!(a.iter().any(|&v| v > 0.0));
        let d = max_rel_diff(&a, &b);
        assert!(d <= 1e-5, "{layer}: largest per-pixel relative difference {d:e}");
    }
}

#[test]
fn a_memory_budget_splits_into_tasks_with_the_same_image() {
    let scene = load("cornell-box.usda");
    // 48² pixels × 2 eye samples × 32 gather rays ≈ 147 000 gather rays, ≈ 6 MB of A_r + A_w + keys.
    let budget = 1u64 << 20;
    for method in [Method::RpmFg, Method::PmFg] {
        let free = run(&scene, &fg(method, 48, 32, None, None));
        // tasks, not the automatic spill
        let s = settings(RenderRequest { no_spill: true, ..fg_request(method, 48, 32, None, Some(budget)) });
        let tight = run(&scene, &s);
        assert_eq!(counter(&free, "fg_tasks"), 1);
        assert_eq!(counter(&tight, "fg_spilled"), 0);
        assert!(counter(&tight, "fg_tasks") >= 4, "{} tasks", counter(&tight, "fg_tasks"));
        let peak = |o: &RenderOutput| o.stats.enabled.iter().find(|(w, _)| w.starts_with("A_r + A_w")).unwrap().1;
        assert!(peak(&free) > 3 * budget, "unconstrained A_r + A_w {} B", peak(&free));
        assert!(peak(&tight) <= budget, "largest task {} B over the budget", peak(&tight));
        let d = max_rel_diff(&free.film.rgb("indirect").unwrap(), &tight.film.rgb("indirect").unwrap());
        assert!(d <= 1e-5, "{method}: largest per-pixel relative difference {d:e}");
    }
}

/// Indirect light of pm-fg, rpm-fg and rs-fg against a 2 × 1024-spp path-traced reference on `name`
/// (32², 100 000 photons, 64 gather rays): (method, relMSE with the reference noise subtracted,
/// bias of the mean) and the printed table.
fn accuracy(name: &str) -> (Vec<(Method, f64, f64)>, String) {
    let scene = load(name);
    let res = 32;
    let pt = |seed| run(&scene, &RenderSettings { spp: 1024, seed, resolution: Some([res, res]), ..Default::default() }).film.rgb("indirect").unwrap();
    let (a, b) = (pt(11), pt(12));
    let reference: Vec<f32> = a.iter().zip(&b).map(|(x, y)| 0.5 * (x + y)).collect();
    let noise = raysplat::image::compare(&a, &b).rel_mse / 4.0;
    let sum = |v: &[f32]| v.iter().map(|&x| x as f64).sum::<f64>();
    let mut table = format!("{name}: reference noise relMSE {noise:.5}\n");
    let mut results = Vec::new();
    for method in [Method::PmFg, Method::RpmFg, Method::RsFg] {
        let s = settings(RenderRequest { photons: Some(100_000), ..fg_request(method, res, 64, None, None) });
        let img = run(&scene, &s).film.rgb("indirect").unwrap();
        let err = raysplat::image::compare(&img, &reference).rel_mse - noise;
        let bias = sum(&img) / sum(&reference) - 1.0;
        table += &format!("{method:7} relMSE {err:.5} bias {:+.2} %\n", bias * 100.0);
        results.push((method, err, bias));
    }
    eprintln!("{table}");
    (results, table)
}

#[test]
fn final_gathering_matches_the_path_tracer_on_the_cornell_box() {
    let (results, table) = accuracy("cornell-box.usda");
    for (method, err, bias) in results {
        assert!(bias.abs() < 0.06, "{method}: indirect bias {:.2} %\n{table}", bias * 100.0);
        assert!(err < 0.01, "{method}: relMSE {err}\n{table}");
    }
}

#[test]
fn final_gathering_matches_the_path_tracer_in_concave_corners() {
    // Measured: all three underestimate here (−3 … −5 %), not overestimate. A likely cause (not
    // verified): the disc of an estimate near an inner corner reaches onto the other face, whose
    // photons the normal filter rejects, yet the estimate divides by the full disc area.
    let (results, table) = accuracy("concave-corners.usda");
    for (method, err, bias) in results {
        assert!(bias.abs() < 0.08, "{method}: indirect bias {:.2} %\n{table}", bias * 100.0);
        assert!(err < 0.01, "{method}: relMSE {err}\n{table}");
    }
}

#[test]
fn final_gathering_images_do_not_depend_on_the_thread_count() {
    let scene = load("cornell-box.usda");
    for method in [Method::PmFg, Method::RpmFg] {
        let one = run(&scene, &RenderSettings { threads: 1, ..fg(method, 24, 8, None, None) });
        let two = run(&scene, &RenderSettings { threads: 3, ..fg(method, 24, 8, None, None) });
        assert_eq!(one.film.rgb("").unwrap(), two.film.rgb("").unwrap(), "{method}");
    }
}

#[test]
fn a_spilled_render_equals_the_in_memory_one() {
    let scene = load("cornell-box.usda");
    let parent = tempfile::tempdir().unwrap();
    for method in [Method::RpmFg, Method::PmFg, Method::RsFg] {
        let mem = run(&scene, &fg(method, 40, 16, None, None));
        let s = settings(RenderRequest { spill_dir: Some(parent.path().to_path_buf()), ..fg_request(method, 40, 16, None, Some(1 << 20)) });
        let spilled = run(&scene, &s);
        assert!(counter(&spilled, "spill_chunks") >= 2, "{method}: {} chunks", counter(&spilled, "spill_chunks"));
        let on_disk = spilled.stats.enabled.iter().find(|(w, _)| w.starts_with("A_r spilled")).expect("spill reported").1;
        assert_eq!(on_disk, counter(&spilled, "gather_hits") * 32, "{method}: every reverse photon on disk once");
        assert_eq!(counter(&mem, "photons_found"), counter(&spilled, "photons_found"), "{method}");
        for layer in ["indirect", ""] {
            let d = max_rel_diff(&mem.film.rgb(layer).unwrap(), &spilled.film.rgb(layer).unwrap());
            assert!(d <= 1e-5, "{method} {layer}: largest per-pixel relative difference {d:e}");
        }
        assert_eq!(std::fs::read_dir(parent.path()).unwrap().count(), 0, "spill directory left behind");
    }
    let s = settings(RenderRequest { spill_dir: Some(parent.path().join("missing")), ..fg_request(Method::RpmFg, 8, 2, None, None) });
    let e = render(scene.clone(), &s, &SilentProgress).err().expect("a missing spill directory is an error");
    assert!(e.to_string().contains("missing"), "{e}");
}

/// Under a memory budget (tasks in memory, or a spill), every final-gathering image is still
/// bit-identical for one and two threads: the blocks of the reverse photon map and the spilled
/// chunks are cut the same way whatever the thread count.
#[test]
fn budgeted_final_gathering_does_not_depend_on_the_thread_count() {
    let scene = load("cornell-box.usda");
    let parent = tempfile::tempdir().unwrap();
    for method in [Method::RpmFg, Method::PmFg] {
        for (memory, no_spill) in [(1u64 << 20, false), (1 << 20, true), (4 << 20, false), (4 << 20, true)] {
            let render_with = |threads: usize| {
                let spill_dir = (!no_spill).then(|| parent.path().to_path_buf());
                let request = RenderRequest { spp: Some(1), no_spill, spill_dir, ..fg_request(method, 64, 16, None, Some(memory)) };
                run(&scene, &RenderSettings { threads, ..settings(request) })
            };
            let (one, two) = (render_with(1), render_with(2));
            let what = format!("{method} --memory {}M{}", memory >> 20, if no_spill { " --no-spill" } else { "" });
            assert!(counter(&one, "fg_tasks") > 1, "{what}: one task");
            let (a, b) = (one.film.rgb("").unwrap(), two.film.rgb("").unwrap());
            let differ = a.chunks(3).zip(b.chunks(3)).filter(|(x, y)| x != y).count();
            assert_eq!(differ, 0, "{what}: {differ} of {} pixels differ between 1 and 2 threads (largest relative difference {:e})", a.len() / 3, max_rel_diff(&a, &b));
        }
    }
}

#[test]
fn density_control_thins_the_map_and_keeps_pm_fg_and_rpm_fg_equal() {
    let scene = load("cornell-box.usda");
    let with = |method, limit| settings(RenderRequest { density_limit: limit, ..fg_request(method, 32, 16, Some(0.04), None) });
    let free = run(&scene, &with(Method::RpmFg, None));
    let pm = run(&scene, &with(Method::PmFg, Some(8000.0)));
    let rpm = run(&scene, &with(Method::RpmFg, Some(8000.0)));
    let (before, after) = (counter(&rpm, "density_control_photons_before"), counter(&rpm, "density_control_photons_after"));
    assert!(after < before / 2, "{before} → {after} photons");
    assert_eq!(counter(&pm, "photons_found"), counter(&rpm, "photons_found"));
    assert!(counter(&rpm, "photons_found") * 2 < counter(&free, "photons_found"), "fewer photons, fewer pairs at a fixed radius");
    let (a, b) = (pm.film.rgb("indirect").unwrap(), rpm.film.rgb("indirect").unwrap());
    let d = max_rel_diff(&a, &b);
    assert!(d <= 1e-5, "largest per-pixel relative difference {d:e}");
    let sum = |v: &[f32]| v.iter().map(|&x| x as f64).sum::<f64>();
    let shift = sum(&b) / sum(&free.film.rgb("indirect").unwrap()) - 1.0;
    eprintln!("density control: {before} → {after} photons, pairs {} → {}, mean indirect {:+.2} %", counter(&free, "photons_found"), counter(&rpm, "photons_found"), shift * 100.0);
    assert!(shift.abs() < 0.03, "mean indirect moved by {:.2} %", shift * 100.0);
}

/// The ray shooting cache (§6.4) only reorders: any window of eye samples traces bit for bit the
/// same reverse photons (the cache's window, 1 eye sample, 7, the whole range), and the order it
/// hands them out in does not depend on the thread count.
#[test]
fn the_ray_shooting_cache_window_changes_only_the_order_and_never_with_the_threads() {
    use raysplat::eye::{eye_pass, EyeSettings};
    use raysplat::gather::{rays, ReversePhoton};
    let scene = raysplat::prepare::PreparedScene::new(load("cornell-box.usda"), 32, 32, 0).expect("prepare");
    let eye = eye_pass(&scene, &EyeSettings { spp: 2, aa_spp: 0, seed: 5, light_samples: 1 }).unwrap();
    let n = eye.samples.len();
    let trace = |window: usize| {
        let mut out: Vec<ReversePhoton> = Vec::new();
        let c = rays::trace_gather_each(&scene, &eye, 3..n, 2..50, 64, 9, window, |w| out.extend_from_slice(w));
        assert_eq!(c.hits, out.len() as u64);
        assert!(c.rays >= c.hits && c.rays <= (n as u64 - 3) * 48);
        out
    };
    let key = |v: &[ReversePhoton]| {
        let mut k: Vec<[u32; 9]> = v
            .iter()
            .map(|r| [r.pixel, r.p[0].to_bits(), r.p[1].to_bits(), r.p[2].to_bits(), r.weight[0].to_bits(), r.weight[1].to_bits(), r.weight[2].to_bits(), r.n as u32, r.wi as u32])
            .collect();
        k.sort_unstable();
        k
    };
    let default = rays::window_samples(48, u64::MAX);
    assert_eq!(default, rays::WINDOW_RAYS.div_ceil(48));
    assert!(n - 3 > 2 * default, "{n} eye samples: fewer than three windows");
    let reference = trace(default);
    assert!(reference.len() > 10_000, "{} reverse photons", reference.len());
    for window in [1, 7, n] {
        let other = trace(window);
        assert_eq!(key(&other), key(&reference), "window of {window} eye samples");
        if window == 7 {
            assert_ne!(other, reference, "windows of 7 eye samples should order the rays differently");
        }
    }
    for threads in [1, 3] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        assert!(pool.install(|| trace(default)) == reference, "{threads} threads changed the order");
    }
}
