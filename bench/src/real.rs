//! `raysplat-bench real`: the real-scene table (docs/accuracy.md). Per scene (the workplace's
//! shared scenes, each missing one named in the output, and the repository's): a path-traced
//! reference in two halves (cached on disk, see `reference`), then `auto` and each single method at
//! equal wall-clock times, their errors against the reference (`metrics`: relative MSE, relative
//! MSE with an ε relative to the reference's mean, and MSE over the reference's squared mean, each
//! less the reference's own noise) of the image and of its direct and indirect layers, and per
//! time the verdict of the two goals: `auto` at most 1.25 × the error of the best single method that
//! rendered in about its time, and at most the path tracer's. `auto`'s survey counts against its
//! time (its seconds include it).
//!
//! The output is Markdown (stdout): a section per scene and a summary of the verdicts; what it
//! is doing goes to stderr. A scene that fails to load or render is reported in its section and in
//! the summary, and the run goes on.

mod metrics;
mod reference;

use metrics::Measure;
use raysplat::integrators::{self, Method, RenderRequest, RenderSettings, SilentProgress};
use raysplat::usd;
use std::io::Write;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(clap::Args)]
pub struct RealTableArgs {
    /// Scenes (comma separated; default: the shared scenes and the repository's).
    #[arg(long, value_delimiter = ',')]
    pub real_scenes: Vec<PathBuf>,
    /// Wall-clock budgets in seconds (comma separated).
    #[arg(long, value_delimiter = ',', default_value = "1,4,16")]
    pub real_times: Vec<f64>,
    /// The longer image side in pixels (the scene's aspect ratio kept).
    #[arg(long, default_value_t = 200)]
    pub real_size: u32,
    /// Samples per pixel of the path-traced reference (two halves).
    #[arg(long, default_value_t = 1024)]
    pub real_reference_spp: u32,
    /// The single methods auto is compared with (comma separated).
    #[arg(long, value_delimiter = ',', default_value = "pt,rs,pm,rs-rc")]
    pub real_methods: Vec<String>,
    /// The shared scenes' directory.
    #[arg(long, default_value = "../shared/scenes")]
    pub shared_scenes: PathBuf,
    /// Where the references are kept between runs (default: `real-references` in raysplat's cache
    /// folder, `RAYSPLAT_CACHE_DIR` or `~/.cache/raysplat`).
    #[arg(long)]
    pub real_cache: Option<PathBuf>,
}

/// The shared scenes of the table, relative to the shared directory: Crytek Sponza, the shader
/// ball, the car kit and McGuire's Cornell boxes.
const SHARED: [&str; 6] = [
    "classic/crytek_sponza/sponza.usdc",
    "usd/usd-wg-assets/full_assets/StandardShaderBall/standard_shader_ball_scene.usda",
    "usd/MiniCarKit_scene.usda",
    "classic/cornell_box/CornellBox-Original.usda",
    "classic/cornell_box/CornellBox-Sphere.usda",
    "classic/cornell_box/CornellBox-Water.usda",
];
/// The repository's scenes of the table: all but the analytic test scenes (`furnace`,
/// `plane-distant`, `plane-rect`), a constant or a single lit plane on which every method's error
/// is at the reference's noise and a ratio of two such errors says nothing.
const REPOSITORY: [&str; 5] =
    ["scenes/cornell-box.usda", "scenes/bumpy-box.usda", "scenes/cornell-glossy.usda", "scenes/secondary-light.usda", "scenes/concave-corners.usda"];
/// Layers measured: the image, then its direct and indirect light.
const LAYERS: [&str; 3] = ["", "direct", "indirect"];
/// A render taking more than this × its time budget is marked as overrunning it.
const OVERRUN: f64 = 1.2;
/// The goals: auto's error at most this × the best single method's, and at most the path tracer's.
const BEST_RATIO: f64 = 1.25;

fn scenes(a: &RealTableArgs) -> (Vec<PathBuf>, Vec<String>) {
    if !a.real_scenes.is_empty() {
        return (a.real_scenes.clone(), Vec::new());
    }
    let mut missing = Vec::new();
    let mut out = Vec::new();
    for s in SHARED {
        let p = a.shared_scenes.join(s);
        if p.exists() {
            out.push(p);
        } else {
            missing.push(format!("{} is missing (the workplace's shared scenes; `--shared-scenes DIR`)", p.display()));
        }
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    out.extend(REPOSITORY.iter().map(|s| root.join(s)));
    (out, missing)
}

/// A scene's name in the table: the file's stem.
fn label(path: &Path) -> String {
    path.file_stem().map_or_else(|| path.display().to_string(), |s| s.to_string_lossy().into_owned())
}

/// The path as the repository's checkout sees it: `scenes/…` or `../shared/scenes/…`.
fn shown(path: &Path, shared: &Path) -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    if let Ok(rest) = path.strip_prefix(&root) {
        return rest.display().to_string();
    }
    match path.strip_prefix(shared) {
        Ok(rest) => Path::new("../shared/scenes").join(rest).display().to_string(),
        Err(_) => path.display().to_string(),
    }
}

/// Text for a Markdown table cell or line: one line, no `|`.
fn cell(s: &str) -> String {
    s.replace('|', "/").replace('\n', " ")
}

/// `f`, a panic turned into an error naming it (one scene's or method's failure must not end the
/// table).
fn guarded<T>(f: impl FnOnce() -> anyhow::Result<T>) -> anyhow::Result<T> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(p) => {
            let msg = p.downcast_ref::<String>().cloned().or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string())).unwrap_or_default();
            Err(anyhow::anyhow!("panicked: {msg}"))
        }
    }
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg").map_or_else(|_| "unknown".into(), |s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
}

/// A scene ready to render: its description, image size and reference's settings and key.
struct Prepared {
    desc: raysplat::scene::SceneDesc,
    res: [u32; 2],
    halves: [RenderSettings; 2],
    key: String,
}

fn prepare(path: &Path, a: &RealTableArgs) -> anyhow::Result<Prepared> {
    let rss = if usd::is_usd(path) { usd::convert_cached(path, &Default::default())? } else { path.to_path_buf() };
    let desc = usd::load_scene(path)?;
    let [w0, h0] = desc.resolution.unwrap_or([512, 512]);
    let scale = a.real_size as f64 / w0.max(h0) as f64;
    let res = [((w0 as f64 * scale).round() as u32).max(1), ((h0 as f64 * scale).round() as u32).max(1)];
    let base = RenderSettings { resolution: Some(res), seed: 1, ..Default::default() };
    let halves = reference::half_settings(&base, a.real_reference_spp, [1000, 1001]);
    let key = reference::key(&rss, &halves)?;
    Ok(Prepared { desc, res, halves, key })
}

/// Seconds an uncached reference will take: a 4-spp path-traced probe, its preparation counted
/// once per half and its tracing scaled to the reference's samples.
fn reference_estimate(p: &Prepared, spp: u32) -> anyhow::Result<f64> {
    let probe = RenderSettings { spp: 4, ..p.halves[0].clone() };
    let out = integrators::render(p.desc.clone(), &probe, &SilentProgress)?;
    let prepare = out.stats.phase_seconds("prepare").unwrap_or(0.0);
    Ok(2.0 * prepare + (out.stats.total_seconds - prepare).max(0.0) * spp as f64 / 4.0)
}

/// One render's figures.
struct Row {
    name: String,
    seconds: f64,
    /// What the render did in its time (samples, passes).
    did: String,
    /// `errors[measure][layer]` (NaN: the layer is missing).
    errors: [[f64; 3]; 3],
}

/// What a photon method or the path tracer did within its time: "45 spp", "3 × 200k ph. + 12 spp".
fn did(s: &RenderSettings, stats: &integrators::Stats) -> String {
    match s.method.photon_pass() {
        None => stats.counter("spp").map_or_else(|| format!("{} spp", s.spp), |n| format!("{n} spp")),
        Some(pass) => {
            let passes = stats.counter("passes").unwrap_or(1);
            let extra = stats.counter("direct_only_camera_samples").unwrap_or(0);
            let mut d = format!("{passes} × {}k ph.", pass.photons / 1000);
            if extra > 0 {
                d += &format!(" + {extra} spp");
            }
            if let Some(n) = stats.counter("path_tracer_spp") {
                d += &format!(" + pt {n} spp");
            }
            d
        }
    }
}

/// The reference's figures every row is measured with: per layer, A, B and their mean, its noise
/// per measure, and the beauty's mean.
struct Truth {
    layers: Vec<Option<[Vec<f32>; 3]>>,
    noise: [[f64; 3]; 3],
    mean: f64,
}

impl Truth {
    fn new(h: &reference::Halves) -> anyhow::Result<Truth> {
        let layers: Vec<Option<[Vec<f32>; 3]>> = LAYERS.iter().map(|l| h.layer(l)).collect();
        let beauty = layers[0].as_ref().ok_or_else(|| anyhow::anyhow!("the reference has no RGB image"))?;
        let mean = metrics::mean(&beauty[2]);
        let mut noise = [[f64::NAN; 3]; 3];
        for (mi, m) in Measure::ALL.iter().enumerate() {
            for (li, l) in layers.iter().enumerate() {
                if let Some([a, b, r]) = l {
                    noise[mi][li] = m.noise(a, b, r, mean);
                }
            }
        }
        Ok(Truth { layers, noise, mean })
    }

    fn errors(&self, film: &raysplat::image::Film) -> [[f64; 3]; 3] {
        let mut e = [[f64::NAN; 3]; 3];
        for (li, l) in LAYERS.iter().enumerate() {
            let (Some([_, _, r]), Some(t)) = (&self.layers[li], film.rgb(l)) else { continue };
            for (mi, m) in Measure::ALL.iter().enumerate() {
                e[mi][li] = m.error(&t, r, self.mean) - self.noise[mi][li];
            }
        }
        e
    }
}

/// The verdict of one scene at one time.
struct Verdict {
    scene: String,
    time: f64,
    /// auto's method and what it did, or why it failed.
    auto: String,
    /// Per measure: auto against the single methods; `None` when a row is missing.
    ratios: [Option<Ratios>; 3],
}

/// Auto's error over the single methods' in one measure.
struct Ratios {
    /// Over the best single method's among those that took at most [`OVERRUN`] × the longer of T
    /// and auto's own time (all of them when none did), and its name.
    best: f64,
    who: String,
    /// Over the path tracer's.
    pt: f64,
    /// Over a single method's with a lower error that took longer than that, and its name and
    /// seconds: shown, not judged (it did not render in auto's time).
    longer: Option<(f64, String, f64)>,
}

/// Per measure, auto against the best single method and the path tracer, errors floored at the
/// reference's noise (differences below it cannot be resolved). The best is taken at equal time:
/// among the methods that took at most [`OVERRUN`] × the longer of `t` and auto's seconds, since a
/// photon method always finishes its first pass, and a pass that takes three times the budget is
/// not a render of that budget.
fn ratios(auto: &Row, singles: &[Row], noise: &[[f64; 3]; 3], t: f64) -> [Option<Ratios>; 3] {
    std::array::from_fn(|mi| {
        let floor = |e: f64| e.max(noise[mi][0]);
        let limit = OVERRUN * t.max(auto.seconds);
        let any = lowest(singles.iter(), mi)?;
        let best = lowest(singles.iter().filter(|r| r.seconds <= limit), mi).unwrap_or(any);
        let pt = singles.iter().find(|r| r.name == "pt")?;
        let a = floor(auto.errors[mi][0]);
        let longer = (floor(any.errors[mi][0]) < floor(best.errors[mi][0])).then(|| (a / floor(any.errors[mi][0]), any.name.clone(), any.seconds));
        Some(Ratios { best: a / floor(best.errors[mi][0]), who: best.name.clone(), pt: a / floor(pt.errors[mi][0]), longer })
    })
}

/// The row of the lowest finite error in measure `mi`.
fn lowest<'a>(rows: impl Iterator<Item = &'a Row>, mi: usize) -> Option<&'a Row> {
    rows.filter(|r| r.errors[mi][0].is_finite()).min_by(|x, y| x.errors[mi][0].total_cmp(&y.errors[mi][0]))
}

fn fmt_error(e: f64) -> String {
    if e.is_nan() {
        "—".into()
    } else if e.is_infinite() {
        "inf".into()
    } else if e.abs() >= 1e-3 || e == 0.0 {
        format!("{e:.5}")
    } else {
        // three significant digits for the nearly converged rows
        format!("{e:.2e}")
    }
}

fn row_line(t: f64, r: &Row) -> String {
    let over = if r.seconds > OVERRUN * t { " (over)" } else { "" };
    let e: Vec<String> = [0, 1, 2].iter().flat_map(|&mi| (0..3).map(move |li| (mi, li))).map(|(mi, li)| fmt_error(r.errors[mi][li])).collect();
    format!("| {t} | {} | {:.2}{over} | {} | {} |", r.name, r.seconds, r.did, e.join(" | "))
}

/// Render one row with `settings`.
fn render_row(name: &str, p: &Prepared, truth: &Truth, settings: &RenderSettings) -> anyhow::Result<Row> {
    guarded(|| {
        let out = integrators::render(p.desc.clone(), settings, &SilentProgress)?;
        Ok(Row { name: name.into(), seconds: out.stats.total_seconds, did: did(settings, &out.stats), errors: truth.errors(&out.film) })
    })
}

/// One scene's section; its verdicts are appended to `verdicts`.
fn scene_section(path: &Path, a: &RealTableArgs, methods: &[Method], cache: &Path, verdicts: &mut Vec<Verdict>) {
    let name = label(path);
    let fail = |verdicts: &mut Vec<Verdict>, why: String| {
        for &t in &a.real_times {
            verdicts.push(Verdict { scene: name.clone(), time: t, auto: format!("failed: {why}"), ratios: [None, None, None] });
        }
    };
    let p = match guarded(|| prepare(path, a)) {
        Ok(p) => p,
        Err(e) => {
            let why = cell(&raysplat_cli::message(&e));
            println!("Not measured: the scene failed to load: {why}\n");
            fail(verdicts, why);
            return;
        }
    };
    let start = Instant::now();
    eprintln!("real: {name}: reference ({} spp, {})", a.real_reference_spp, if reference::is_cached(cache, &p.key) { "cached" } else { "rendering" });
    let truth = match guarded(|| reference::load_or_render(cache, &p.key, &p.desc, &p.halves).and_then(|h| Ok((Truth::new(&h)?, h.spp, h.seconds, h.cached)))) {
        Ok(t) => t,
        Err(e) => {
            let why = cell(&raysplat_cli::message(&e));
            println!("Not measured: the reference failed: {why}\n");
            fail(verdicts, why);
            return;
        }
    };
    let (truth, spp, ref_seconds, cached) = truth;
    println!(
        "{}×{} pixels; reference {spp} spp in two halves ({:.0} s{}), its own relative MSE {} (relative ε {}, scaled {}), mean radiance {:.4}; {} converter warnings; load average {} at the start.\n",
        p.res[0],
        p.res[1],
        ref_seconds,
        if cached { ", cached" } else { "" },
        fmt_error(truth.noise[0][0]),
        fmt_error(truth.noise[1][0]),
        fmt_error(truth.noise[2][0]),
        truth.mean,
        p.desc.warnings.len(),
        load_average()
    );
    println!("| T (s) | method | seconds | did | rel. MSE | direct | indirect | rel. ε | direct | indirect | scaled | direct | indirect |");
    println!("|---:|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let request = RenderRequest { resolution: Some(p.res), seed: 1, ..Default::default() };
    let mut reasons = Vec::new();
    for &t in &a.real_times {
        eprintln!("real: {name}: {t} s");
        let timed = RenderRequest { time: Some(t), ..request.clone() };
        let auto_row = guarded(|| {
            // auto chooses on the scene it renders (one preparation); its survey is in its seconds
            let (out, resolved) = integrators::render_request(p.desc.clone(), &timed, &|_, _| Ok(()), &SilentProgress)?;
            let reason = resolved.auto.expect("auto chose");
            reasons.push(format!("- {t} s: {}", cell(&reason.to_string())));
            let row = Row { name: "auto".into(), seconds: out.stats.total_seconds, did: did(&resolved.settings, &out.stats), errors: truth.errors(&out.film) };
            Ok((row, reason.method))
        });
        let mut singles = Vec::new();
        let auto_text = match &auto_row {
            Ok((r, m)) => {
                println!("{}", row_line(t, r));
                format!("{} ({})", m.name(), r.did)
            }
            Err(e) => {
                let why = cell(&raysplat_cli::message(e));
                println!("| {t} | auto | — | failed: {why} | | | | | | | | | |");
                format!("failed: {why}")
            }
        };
        for &m in methods {
            let row = RenderRequest { method: Some(m), ..timed.clone() }.settings().map_err(anyhow::Error::from).and_then(|s| render_row(m.name(), &p, &truth, &s));
            match row {
                Ok(r) => {
                    println!("{}", row_line(t, &r));
                    singles.push(r);
                }
                Err(e) => println!("| {t} | {} | — | failed: {} | | | | | | | | | |", m.name(), cell(&raysplat_cli::message(&e))),
            }
            let _ = std::io::stdout().flush();
        }
        let ratios = match &auto_row {
            Ok((r, _)) => ratios(r, &singles, &truth.noise, t),
            Err(_) => [None, None, None],
        };
        verdicts.push(Verdict { scene: name.clone(), time: t, auto: auto_text, ratios });
    }
    println!("\n`auto` chose:\n\n{}\n", reasons.join("\n"));
    eprintln!("real: {name}: {:.0} s", start.elapsed().as_secs_f64());
}

fn verdict_cell(r: &Option<Ratios>) -> String {
    match r {
        None => "— | — | —".into(),
        Some(r) => {
            let longer = r.longer.as_ref().map_or(String::new(), |(x, who, s)| format!("; {x:.2} ({who}, {s:.1} s)"));
            format!("{:.2} ({}){longer} | {:.2} | {}", r.best, r.who, r.pt, if met(r) { "met" } else { "**missed**" })
        }
    }
}

/// Whether auto met both goals in a measure, judged on the ratios as printed (two decimals): a
/// difference under 0.5 % is below the resolution of an MSE over the table's 40 000 pixels, whose
/// own standard error is at least 0.7 % (√2/√N for Gaussian pixel errors).
fn met(r: &Ratios) -> bool {
    let printed = |x: f64| (x * 100.0).round() / 100.0;
    printed(r.best) <= BEST_RATIO && printed(r.pt) <= 1.0
}

pub fn run(a: &RealTableArgs) -> anyhow::Result<()> {
    let methods: Vec<Method> = a.real_methods.iter().map(|m| m.parse()).collect::<Result<_, _>>()?;
    if !methods.contains(&Method::Pt) {
        anyhow::bail!(raysplat::Error::param("real-methods", "must include pt (the second goal compares auto with it)"));
    }
    if a.real_reference_spp < 2 {
        anyhow::bail!(raysplat::Error::param("real-reference-spp", "must be at least 2 (two halves)"));
    }
    if let Some(t) = a.real_times.iter().find(|t| !(t.is_finite() && **t > 0.0)) {
        anyhow::bail!(raysplat::Error::param("real-times", format!("{t} is not a positive number of seconds")));
    }
    let cache = a.real_cache.clone().unwrap_or_else(|| raysplat::io::cache::dir().join("real-references"));
    let (paths, missing) = scenes(a);
    let start = Instant::now();

    // The expected run time: the timed renders, and the references not yet cached (a probe each).
    let renders: f64 = (methods.len() + 1) as f64 * a.real_times.iter().sum::<f64>() * paths.len() as f64;
    let mut references = 0.0;
    let mut uncached = 0;
    for path in &paths {
        let estimate = guarded(|| {
            let p = prepare(path, a)?;
            if reference::is_cached(&cache, &p.key) {
                return Ok(0.0);
            }
            reference_estimate(&p, a.real_reference_spp)
        });
        if let Some(s) = estimate.ok().filter(|s| *s > 0.0) {
            references += s;
            uncached += 1;
        }
    }
    let expected = format!(
        "about {:.0} min: {:.0} s of timed renders (at least; a photon pass overruns a short budget) and {:.0} s for {uncached} references not yet cached",
        (renders + references) / 60.0,
        renders,
        references
    );
    eprintln!("real: expected run time {expected}");

    println!(
        "`raysplat-bench real`: `auto` and {} at {} s each, the longer image side {} pixels, against a {}-spp path-traced reference; {} threads; expected run time {expected}.\n",
        a.real_methods.iter().map(|m| format!("`{m}`")).collect::<Vec<_>>().join(", "),
        a.real_times.iter().map(|t| t.to_string()).collect::<Vec<_>>().join(", "),
        a.real_size,
        a.real_reference_spp,
        rayon::current_num_threads(),
    );
    for m in &missing {
        println!("Skipped: {m}.\n");
    }
    let mut verdicts = Vec::new();
    for path in &paths {
        println!("### {}\n\nScene `{}`.\n", label(path), shown(path, &a.shared_scenes));
        scene_section(path, a, &methods, &cache, &mut verdicts);
        let _ = std::io::stdout().flush();
    }

    println!("### Summary\n");
    println!(
        "Per scene and time: auto's error over the best single method's at equal time (which one: among those that took at most {OVERRUN} × the longer of T and auto's time; after a semicolon, over a better one that took longer, with its seconds, not judged) and over the path tracer's, for each error of the image (errors below the reference's own noise count as that noise); the goals, judged on the ratios as printed: auto / best ≤ {BEST_RATIO} and auto / pt ≤ 1.\n"
    );
    println!("| scene | T (s) | auto | rel. MSE: auto / best | auto / pt | goals | rel. ε: auto / best | auto / pt | goals | scaled: auto / best | auto / pt | goals |");
    println!("|---|---:|---|---|---:|---|---|---:|---|---|---:|---|");
    for v in &verdicts {
        println!("| {} | {} | {} | {} | {} | {} |", v.scene, v.time, v.auto, verdict_cell(&v.ratios[0]), verdict_cell(&v.ratios[1]), verdict_cell(&v.ratios[2]));
    }
    let missed = |mi: usize| verdicts.iter().filter(|v| v.ratios[mi].as_ref().is_none_or(|r| !met(r))).count();
    println!(
        "\nGoals missed (or not measured) at {} of {} scene-times by relative MSE, {} by relative ε, {} by scaled MSE. The run took {:.0} min; load average {} at its end.",
        missed(0),
        verdicts.len(),
        missed(1),
        missed(2),
        start.elapsed().as_secs_f64() / 60.0,
        load_average()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(name: &str, seconds: f64, error: f64) -> Row {
        Row { name: name.into(), seconds, did: String::new(), errors: [[error; 3]; 3] }
    }

    /// The best single method is taken at equal time: one whose first pass took three times the
    /// budget is shown beside the verdict, not judged; within the overrun allowed it is judged.
    #[test]
    fn auto_is_judged_against_the_methods_that_rendered_in_its_time() {
        let noise = [[1e-6; 3]; 3];
        let auto = row("auto", 1.05, 0.010);
        let singles = [row("pt", 1.0, 0.040), row("rs", 3.0, 0.005), row("rs-rc", 1.1, 0.009)];
        let r = ratios(&auto, &singles, &noise, 1.0)[0].take().unwrap();
        assert_eq!(r.who, "rs-rc");
        assert!((r.best - 0.010 / 0.009).abs() < 1e-12 && (r.pt - 0.25).abs() < 1e-12);
        let (x, who, seconds) = r.longer.clone().unwrap();
        assert!((x - 2.0).abs() < 1e-12 && who == "rs" && seconds == 3.0);
        assert!(met(&r));
        // auto's own overrun widens the window: a method as slow as auto is judged
        let slow = row("auto", 2.6, 0.010);
        let r = ratios(&slow, &singles, &noise, 1.0)[0].take().unwrap();
        assert_eq!((r.who.as_str(), r.longer.is_none()), ("rs", true));
        assert!(!met(&r), "2 × the best at equal time");
        // a ratio is judged as printed: 0.4 % worse than the path tracer is 1.00
        let pt_only = [row("pt", 1.0, 0.040)];
        let tie = ratios(&row("auto", 1.0, 0.04016), &pt_only, &noise, 1.0)[0].take().unwrap();
        assert!(tie.pt > 1.0 && met(&tie));
        let worse = ratios(&row("auto", 1.0, 0.0403), &pt_only, &noise, 1.0)[0].take().unwrap();
        assert!(!met(&worse), "{} is 1.01 as printed", worse.pt);
        // errors below the reference's noise count as that noise
        let quiet = [[0.01; 3]; 3];
        let r = ratios(&auto, &singles, &quiet, 1.0)[0].take().unwrap();
        assert!((r.best - 1.0).abs() < 1e-12 && r.longer.is_none());
    }
}
