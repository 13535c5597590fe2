//! `raysplat study`: the speed–accuracy trade of every method on one scene, measured in one run.
//!
//! Renders (or reads) a path-traced reference, then each method at a ladder of budgets — the budget
//! multipliers scale the path tracer's samples per pixel (base 4) and, for the photon methods, the
//! axes `--ladder` names: photons (base 25 000), eye samples per pixel (base 4), final gather rays
//! (base: the method's default) — optionally for several smoothness values `C` of the splatting
//! methods (`--smoothness`), and records per render: parameters, seconds in total and per phase, peak
//! resident memory, and the error against the reference (`image::compare`: relative MSE, RMSE, share
//! of pixels over 5/15/30 % error, NaN count). With `--denoise both` each render is also measured
//! after Open Image Denoise (method `<method>+oidn`, seconds including the denoise), against the
//! same reference. The renders alternate between the methods budget by budget. Writes
//! `study.json`, `study.csv`, `study.md` and a log-log plot of error against time,
//! `error-vs-time.png`; with denoised rows also `denoise.md`: the lowest error within a few time
//! limits for pt and the photon methods, raw and denoised, and each render's error raw and denoised.

use super::progress::Bars;
use super::reference::Reference;
use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use raysplat::denoise::{self, Mode, Options, Status};
use raysplat::image::{self, Metrics};
use raysplat::integrators::{self, Method, MethodSettings, RenderSettings, SilentProgress};
use raysplat::{usd, Error};
use serde::Serialize;
use raysplat::io::Format;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(clap::Args)]
pub struct StudyArgs {
    scene: PathBuf,
    /// Output directory (created if missing).
    #[arg(short, long)]
    output: PathBuf,
    #[command(flatten)]
    stage: super::StageArgs,
    /// Methods to study, comma separated.
    #[arg(long, default_value = "pt,rs,pm,pm-fg,rpm-fg,rs-fg,he-fg,rs-rc")]
    methods: String,
    /// Budget multipliers (pt: × 4 spp; photon methods: see `--ladder`), comma separated.
    #[arg(long, default_value = "1,2,4,8")]
    budgets: String,
    /// What a budget multiplier b scales for the photon methods, comma separated: `photons`
    /// (25 000 × b), `spp` (eye samples per pixel, 4 × b), `fg-rays` (final gather rays per eye
    /// sample, the default × b). With several axes the photons scale by b and the per-pixel axes by
    /// the largest power of two ≤ √b, so a rung costs about b times the first.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "photons")]
    ladder: Vec<Axis>,
    /// Smoothness values C of the splatting methods (rs, rs-fg, rs-rc), comma separated: each budget
    /// is rendered once per value (default: the renderer's default C only).
    #[arg(long, value_delimiter = ',')]
    smoothness: Vec<f32>,
    /// Eye samples per pixel of the photon methods' density estimate at the first rung (the `spp`
    /// axis of `--ladder` scales it).
    #[arg(long, default_value_t = 4)]
    eye_spp: u32,
    /// Camera samples per pixel of the photon methods for anti-aliasing and direct light
    /// (`render --aa-spp`) at the first rung; 0: as many as eye samples. The `spp` axis scales it
    /// with the eye samples.
    #[arg(long, default_value_t = 0)]
    aa_spp: u32,
    /// Once a render of a method takes longer than this many seconds, its larger budgets are
    /// skipped (and listed as skipped). Default: no limit.
    #[arg(long, allow_negative_numbers = true)]
    max_seconds: Option<f64>,
    /// Use this EXR as the reference instead of rendering one (its own noise is then unknown, and
    /// no error against the converged image is reported).
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Samples per pixel of the path-traced reference.
    #[arg(long, default_value_t = 1024)]
    reference_spp: u32,
    /// Image size WxH (default: the scene's).
    #[arg(long)]
    resolution: Option<String>,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Denoised variants (Open Image Denoise on each render, `raysplat render --denoise`): `off`,
    /// `on` (only the denoised images) or `both` (each render measured raw and denoised, the
    /// denoised one as method `<method>+oidn`, its seconds including the denoise).
    #[arg(long, default_value = "off", value_parser = ["off", "on", "both"])]
    denoise: String,
    /// The denoiser's qualities (fast, balanced, high), comma separated: each render is denoised
    /// at each (method `<method>+oidn`, or `<method>+oidn-<quality>` for several).
    #[arg(long, value_delimiter = ',', default_value = "high", value_parser = ["fast", "balanced", "high"])]
    denoise_quality: Vec<String>,
}

/// What the method name of a denoised row holds after the method's.
pub const DENOISED: &str = "+oidn";

/// The method of a row without the denoiser's suffix, and whether the row is denoised.
pub fn base_method(r: &Row) -> (&str, bool) {
    match r.method.split_once(DENOISED) {
        Some((m, _)) => (m, true),
        None => (&r.method, false),
    }
}

/// One render of the study.
#[derive(Serialize, Clone)]
pub struct Row {
    pub method: String,
    pub params: BTreeMap<String, serde_json::Value>,
    pub seconds: f64,
    pub phase_seconds: BTreeMap<String, f64>,
    pub peak_bytes: u64,
    pub rel_mse: f64,
    /// `rel_mse` less the reference's own relative MSE: the error against the converged image
    /// (`None` with a given `--reference`, whose noise is unknown).
    pub rel_mse_converged: Option<f64>,
    pub rmse: f64,
    pub mean_rel_error: f64,
    pub over_5: f64,
    pub over_15: f64,
    pub over_30: f64,
    pub nan: usize,
}

const PT_BASE_SPP: u32 = 4;
const PHOTON_BASE: usize = 25_000;

/// A parameter the budget ladder scales for the photon methods.
#[derive(clap::ValueEnum, Clone, Copy, PartialEq, Eq, Debug)]
pub enum Axis {
    Photons,
    Spp,
    FgRays,
}

/// The factors of each axis at budget multiplier `b` (photons, eye spp, gather rays).
fn ladder_factors(axes: &[Axis], b: u32) -> (u32, u32, u32) {
    let shared = axes.len() > 1;
    let per_pixel = if shared { 1u32 << ((b as f64).sqrt().log2().floor() as u32) } else { b };
    let f = |a: Axis, full: u32| if axes.contains(&a) { full } else { 1 };
    (f(Axis::Photons, b), f(Axis::Spp, per_pixel), f(Axis::FgRays, per_pixel))
}

/// Does the method splat photon rays with the bandwidth of §6 (so `--smoothness` applies)?
fn splats(m: Method) -> bool {
    matches!(m, Method::Rs | Method::RsFg | Method::RsRc)
}

fn parse_list<T: std::str::FromStr>(s: &str, what: &str) -> Result<Vec<T>, Error> {
    s.split(',')
        .map(|x| x.trim().parse::<T>().map_err(|_| Error::param(what, format!("{x:?} in {s:?} is not valid"))))
        .collect()
}

use raysplat::integrators::{peak_rss, reset_peak_rss};

pub fn run(a: &StudyArgs) -> anyhow::Result<()> {
    let methods: Vec<Method> = parse_list(&a.methods, "methods")?;
    let budgets: Vec<u32> = parse_list(&a.budgets, "budgets")?;
    if budgets.iter().any(|&b| b == 0 || b > 4096) {
        return Err(Error::param("budgets", "multipliers must be in 1..=4096").into());
    }
    if a.ladder.is_empty() {
        return Err(Error::param("ladder", "name at least one of photons, spp, fg-rays").into());
    }
    if a.eye_spp == 0 || a.eye_spp > 4096 {
        return Err(Error::param("eye-spp", format!("{} is out of range 1..=4096", a.eye_spp)).into());
    }
    if a.aa_spp != 0 && (a.aa_spp < a.eye_spp || a.aa_spp > 4096) {
        return Err(Error::param("aa-spp", format!("{} is out of range (--eye-spp {} ..= 4096, or 0)", a.aa_spp, a.eye_spp)).into());
    }
    if let Some(t) = a.max_seconds.filter(|t| !(t.is_finite() && *t > 0.0)) {
        return Err(Error::param("max-seconds", format!("{t} is not a positive number of seconds")).into());
    }
    if let Some(c) = a.smoothness.iter().find(|c| !(c.is_finite() && **c > 0.0 && **c <= 10.0)) {
        return Err(Error::param("smoothness", format!("{c} is out of range (0, 10]")).into());
    }
    let (raw_rows, denoised_rows) = (a.denoise != "on", a.denoise != "off");
    let qualities: Vec<denoise::Quality> = a.denoise_quality.iter().map(|q| q.parse()).collect::<Result<_, _>>()?;
    let denoising: Vec<Options> = qualities.iter().map(|&quality| Options { mode: Mode::On, quality, ..Default::default() }).collect();
    if denoised_rows {
        Options { mode: Mode::On, ..Default::default() }.validate()?;
    }
    let resolution = a.resolution.as_deref().map(raysplat::integrators::parse_size).transpose()?;
    std::fs::create_dir_all(&a.output).map_err(|e| Error::io(&a.output, e))?;
    // the files the study writes, checked before hours of rendering
    let mut names = vec![("reference.exr", Format::Exr), ("study.json", Format::Json), ("study.csv", Format::Csv), ("study.md", Format::Markdown), ("error-vs-time.png", Format::Png)];
    if denoised_rows {
        names.push(("denoise.md", Format::Markdown));
    }
    let paths: Vec<(PathBuf, Format)> = names.iter().filter(|(n, _)| a.reference.is_none() || *n != "reference.exr").map(|(n, f)| (a.output.join(n), *f)).collect();
    let outputs: Vec<(&Path, Format)> = paths.iter().map(|(p, f)| (p.as_path(), *f)).collect();
    let inputs: Vec<&Path> = std::iter::once(a.scene.as_path()).chain(a.reference.as_deref()).collect();
    raysplat::io::check_outputs(&outputs, &inputs)?;
    let scene = usd::load_scene_with(&a.scene, &a.stage.options())?;
    let base = RenderSettings { seed: a.seed, resolution, ..Default::default() };

    // The reference: given, or path traced as two independent halves whose difference measures
    // its own noise (`rel_mse_converged` = error against the reference less that noise).
    let (reference, noise) = match &a.reference {
        Some(p) => (image::read_exr(p)?, None),
        None => {
            eprintln!("study: rendering the path-traced reference ({} spp, two halves)", a.reference_spp);
            let seeds = [a.seed ^ 0x5eed, a.seed ^ 0x5eed ^ 0x100];
            let r = Reference::render_with_progress(&scene, &base, a.reference_spp.max(2), seeds, &[""], &Bars::new())?;
            let s = RenderSettings { spp: r.spp, ..base.clone() };
            image::write_exr(&a.output.join("reference.exr"), &r.film, &s.attributes())?;
            let noise = r.noise("");
            (r.film, Some(noise))
        }
    };
    let ref_rgb = reference.rgb("").context("the reference has no RGB beauty layer")?;
    if denoised_rows {
        // Starts the denoiser's device, so that no render's denoise time includes it.
        for o in &denoising {
            if let (Some(spp), Status::Available(v)) = (denoise::seconds_per_pixel(o.quality, base.threads), denoise::status()) {
                eprintln!("study: Open Image Denoise {v}, {} quality: {:.2} µs per pixel", o.quality, spp * 1e6);
            }
        }
    }

    // (method, smoothness) pairs: the splatting methods once per C given, the others once.
    let variants: Vec<(Method, Option<f32>)> = methods
        .iter()
        .flat_map(|&m| {
            if splats(m) && !a.smoothness.is_empty() {
                a.smoothness.iter().map(|&c| (m, Some(c))).collect::<Vec<_>>()
            } else {
                vec![(m, None)]
            }
        })
        .collect();
    let total = (variants.len() * budgets.len()) as u64;
    let bar = ProgressBar::new(total);
    bar.set_style(ProgressStyle::with_template("{msg:>24} [{bar:40}] {pos}/{len} {elapsed_precise} eta {eta}")?.progress_chars("=> "));
    // Rows with their place in the tables (variant, budget, denoised): the renders alternate
    // between the variants, budget by budget, so that a change in the machine's load falls on all
    // of them alike, and the tables list them variant by variant.
    let mut rows: Vec<((usize, usize, usize), Row)> = Vec::new();
    let mut skipped: Vec<String> = Vec::new();
    let mut too_slow: Vec<Option<(u32, f64)>> = vec![None; variants.len()];
    for (bi, &b) in budgets.iter().enumerate() {
        for (vi, &(m, smoothness)) in variants.iter().enumerate() {
            if let Some((prev, secs)) = too_slow[vi] {
                let c = smoothness.map_or(String::new(), |c| format!(" (C={c})"));
                skipped.push(format!("{m}{c} ×{b}: skipped, ×{prev} took {secs:.1} s (`--max-seconds`)"));
                bar.inc(1);
                continue;
            }
            let mut s = RenderSettings { method: MethodSettings::of(m), ..base.clone() };
            let mut params = BTreeMap::new();
            if m.uses_photons() {
                let (fp, fs, fr) = ladder_factors(&a.ladder, b);
                s.spp = a.eye_spp * fs;
                if let Some(pass) = s.method.photon_pass_mut() {
                    pass.aa_spp = if a.aa_spp == 0 { 0 } else { (a.aa_spp * fs).max(s.spp) };
                    pass.photons = PHOTON_BASE * fp as usize;
                    if let Some(c) = smoothness {
                        pass.bandwidth.smoothness = c;
                    }
                    params.insert("photons".into(), pass.photons.into());
                    params.insert("spp".into(), s.spp.into());
                    if pass.aa_spp > s.spp {
                        params.insert("aa_spp".into(), pass.aa_spp.into());
                    }
                    if splats(m) {
                        params.insert("smoothness".into(), round6(pass.bandwidth.smoothness).into());
                        params.insert("sensitivity".into(), round6(pass.bandwidth.sensitivity).into());
                    }
                }
                // the gather rays the ladder scales, per method
                match &mut s.method {
                    MethodSettings::Pm(pm) => {
                        params.insert("knn".into(), pm.knn.into());
                    }
                    MethodSettings::PmFg(fg) => fg.fg.rays = fg.fg.rays.saturating_mul(fr),
                    MethodSettings::RpmFg(fg) => fg.fg.rays = fg.fg.rays.saturating_mul(fr),
                    MethodSettings::RsFg(fg) => fg.fg.rays = fg.fg.rays.saturating_mul(fr),
                    MethodSettings::HeFg(he) => {
                        he.stratified_rays = he.stratified_rays.saturating_mul(fr);
                        he.explicit_rays = he.explicit_rays.saturating_mul(fr);
                        params.insert("fg_rays".into(), he.stratified_rays.into());
                        params.insert("explicit_rays".into(), he.explicit_rays.into());
                    }
                    _ => {}
                }
                if let MethodSettings::PmFg(raysplat::integrators::PmFgSettings { fg, .. })
                | MethodSettings::RpmFg(raysplat::integrators::RpmFgSettings { fg, .. })
                | MethodSettings::RsFg(raysplat::integrators::RsFgSettings { fg, .. }) = &s.method
                {
                    params.insert("fg_rays".into(), fg.rays.into());
                }
                s.validate()?;
            } else {
                s.spp = PT_BASE_SPP * b;
                params.insert("spp".into(), s.spp.into());
            }
            bar.set_message(format!("{m} ×{b}"));
            reset_peak_rss();
            let t0 = Instant::now();
            let out = integrators::render(scene.clone(), &s, &SilentProgress)?;
            let seconds = t0.elapsed().as_secs_f64();
            if a.max_seconds.is_some_and(|limit| seconds > limit) {
                too_slow[vi] = Some((b, seconds));
            }
            let peak_bytes = peak_rss();
            let rgb = out.film.rgb("").expect("beauty");
            if rgb.len() != ref_rgb.len() {
                return Err(Error::image(
                    a.reference.as_ref().map_or("reference".into(), |p| p.display().to_string()),
                    format!("the reference is {}x{}, the renders {}x{}", reference.width, reference.height, out.film.width, out.film.height),
                )
                .into());
            }
            let row = |method: String, params: BTreeMap<String, serde_json::Value>, seconds: f64, phases: BTreeMap<String, f64>, e: Metrics| Row {
                method,
                params,
                seconds,
                phase_seconds: phases,
                peak_bytes,
                rel_mse: e.rel_mse,
                rel_mse_converged: noise.map(|n| e.rel_mse - n),
                rmse: e.rmse,
                mean_rel_error: e.mean_rel_error,
                over_5: e.over_5,
                over_15: e.over_15,
                over_30: e.over_30,
                nan: e.nan,
            };
            let phases: BTreeMap<String, f64> = out.stats.phases.iter().cloned().collect();
            for (qi, o) in denoising.iter().enumerate().filter(|_| denoised_rows) {
                let mut film = out.film.clone();
                let report = denoise::denoise_film(&mut film, o, s.threads)?;
                let e = image::compare(&film.rgb("").expect("beauty"), &ref_rgb);
                let mut p = params.clone();
                p.insert("denoise".into(), o.quality.name().into());
                let mut ph = phases.clone();
                ph.insert("denoise".into(), report.seconds);
                let name = if denoising.len() > 1 { format!("{m}{DENOISED}-{}", o.quality) } else { format!("{m}{DENOISED}") };
                rows.push(((vi, bi, qi + 1), row(name, p, seconds + report.seconds, ph, e)));
            }
            if raw_rows {
                rows.push(((vi, bi, 0), row(m.to_string(), params, seconds, phases, image::compare(&rgb, &ref_rgb))));
            }
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    // raw rows first, then the denoised ones (by quality), each variant by budget
    rows.sort_by_key(|&((vi, bi, qi), _)| (vi, qi, bi));
    let rows: Vec<Row> = rows.into_iter().map(|(_, r)| r).collect();
    write_outputs(&a.output, &a.scene, &rows, noise, &skipped)?;
    print!("{}", markdown_table(&rows));
    let dn = if denoised_rows { ", denoise.md" } else { "" };
    eprintln!("study: wrote {}/study.json, study.csv, study.md{dn}, error-vs-time.png", a.output.display());
    Ok(())
}

/// An f32 setting as the f64 a reader expects (0.3, not 0.30000001192092896).
fn round6(x: f32) -> f64 {
    (x as f64 * 1e6).round() / 1e6
}

fn params_text(p: &BTreeMap<String, serde_json::Value>) -> String {
    let text = |v: &serde_json::Value| v.as_str().map_or_else(|| v.to_string(), str::to_string);
    p.iter().map(|(k, v)| format!("{k}={}", text(v))).collect::<Vec<_>>().join(" ")
}

fn markdown_table(rows: &[Row]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "| method | parameters | seconds | phases (s) | peak memory | rel. MSE | rel. MSE, converged | RMSE | >5 % | >15 % | >30 % | NaN |");
    let _ = writeln!(s, "|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in rows {
        let phases: Vec<String> = r.phase_seconds.iter().map(|(k, v)| format!("{k} {v:.2}")).collect();
        let _ = writeln!(
            s,
            "| {} | {} | {:.2} | {} | {:.0} MiB | {:.5} | {} | {:.5} | {:.3} | {:.3} | {:.3} | {} |",
            r.method,
            params_text(&r.params),
            r.seconds,
            phases.join(", "),
            r.peak_bytes as f64 / (1024.0 * 1024.0),
            r.rel_mse,
            r.rel_mse_converged.map_or("—".into(), |e| format!("{e:.5}")),
            r.rmse,
            r.over_5,
            r.over_15,
            r.over_30,
            r.nan
        );
    }
    s
}

/// The error a row is judged by: against the converged image when the reference's noise is known.
fn judged(r: &Row) -> f64 {
    r.rel_mse_converged.unwrap_or(r.rel_mse)
}

/// For a few error targets: the render that reached it in the least time in this study (denoised
/// ones included), and the path tracer's and the fastest photon method's times to it as rendered
/// (their ratio is the speed-up).
fn fastest_table(rows: &[Row]) -> String {
    let against = if rows.iter().all(|r| r.rel_mse_converged.is_some()) { "against the converged image" } else { "against the reference" };
    let mut s = format!("| target rel. MSE ({against}) | fastest render (parameters) | seconds | pt | fastest photon method | speed-up over pt |\n|---:|---|---:|---|---|---:|\n");
    let text = |r: Option<&Row>| r.map_or("not reached".to_string(), |r| format!("{} ({}) in {:.2} s", r.method, params_text(&r.params), r.seconds));
    for target in [0.05, 0.02, 0.01, 0.005, 0.002] {
        let first = |keep: &dyn Fn(&Row) -> bool| rows.iter().filter(|r| keep(r) && judged(r) <= target).min_by(|a, b| a.seconds.total_cmp(&b.seconds));
        let photon = |r: &Row| r.method != "pt" && !base_method(r).1;
        let (best, pt, photon) = (first(&|_| true), first(&|r| r.method == "pt"), first(&photon));
        let speedup = match (pt, photon) {
            (Some(p), Some(f)) => format!("{:.1}×", p.seconds / f.seconds),
            _ => "—".into(),
        };
        let _ = match best {
            Some(r) => writeln!(s, "| {target} | {} ({}) | {:.2} | {} | {} | {speedup} |", r.method, params_text(&r.params), r.seconds, text(pt), text(photon)),
            None => writeln!(s, "| {target} | not reached by any budget of this study | — | {} | {} | — |", text(pt), text(photon)),
        };
    }
    s
}

/// A row's method with its main budget: `pt 16 spp`, `rs 100k photons 2+16 spp`, `pt+oidn high 4 spp`.
fn short_name(r: &Row) -> String {
    let p = |k: &str| r.params.get(k).and_then(|v| v.as_u64());
    let mut s = r.method.clone();
    if let Some(q) = r.params.get("denoise").and_then(|v| v.as_str()).filter(|q| !r.method.ends_with(q)) {
        s += &format!(" {q}");
    }
    if let Some(n) = p("photons") {
        s += &format!(" {}k photons", n / 1000);
    }
    match (p("spp"), p("aa_spp")) {
        (Some(n), Some(aa)) => s += &format!(" {n}+{aa} spp"),
        (Some(n), None) => s += &format!(" {n} spp"),
        _ => {}
    }
    s
}

/// Each render as rendered and denoised side by side: its error raw and after each denoiser
/// quality, with the seconds including the denoise (rows with `--denoise both`).
fn denoise_table(rows: &[Row]) -> String {
    let qualities: Vec<String> = {
        let mut q: Vec<String> = rows.iter().filter_map(|r| r.params.get("denoise")).map(|v| v.as_str().unwrap_or_default().to_string()).collect();
        q.sort_by_key(|q| denoise::Quality::ALL.iter().position(|a| a.name() == q));
        q.dedup();
        q
    };
    let against = if rows.iter().all(|r| r.rel_mse_converged.is_some()) { "converged" } else { "reference" };
    let mut s = format!("| method | parameters | seconds | rel. MSE ({against}) | {} |\n|---|---|---:|---:|", qualities.iter().map(|q| format!("+ OIDN {q}: rel. MSE (seconds)")).collect::<Vec<_>>().join(" | "));
    s += &"---:|".repeat(qualities.len());
    s += "\n";
    for r in rows.iter().filter(|r| !base_method(r).1) {
        let cells: Vec<String> = qualities
            .iter()
            .map(|q| {
                let twin = rows.iter().find(|d| {
                    let (m, dn) = base_method(d);
                    let mut p = d.params.clone();
                    dn && m == r.method && p.remove("denoise").is_some_and(|v| v.as_str() == Some(q.as_str())) && p == r.params
                });
                twin.map_or("—".into(), |d| format!("{:.5} ({:.2})", judged(d), d.seconds))
            })
            .collect();
        let _ = writeln!(s, "| {} | {} | {:.2} | {:.5} | {} |", r.method, params_text(&r.params), r.seconds, judged(r), cells.join(" | "));
    }
    s
}

/// For a few time limits: the lowest error any render reached within it, for the path tracer and
/// for the photon methods, as rendered and denoised (`--denoise`).
fn within_table(rows: &[Row]) -> String {
    let against = if rows.iter().all(|r| r.rel_mse_converged.is_some()) { "against the converged image" } else { "against the reference" };
    let pt = |r: &Row| base_method(r).0 == "pt";
    let denoised = |r: &Row| base_method(r).1;
    let families: [(&str, &dyn Fn(&Row) -> bool); 4] = [
        ("pt", &|r| pt(r) && !denoised(r)),
        ("pt + OIDN", &|r| pt(r) && denoised(r)),
        ("photon methods", &|r| !pt(r) && !denoised(r)),
        ("photon methods + OIDN", &|r| !pt(r) && denoised(r)),
    ];
    let present: Vec<_> = families.iter().filter(|(_, keep)| rows.iter().any(|r| keep(r))).collect();
    let mut s = format!("| within (seconds) | {} |\n|---:|", present.iter().map(|(name, _)| format!("lowest rel. MSE, {name} ({against})")).collect::<Vec<_>>().join(" | "));
    s += &"---|".repeat(present.len());
    s += "\n";
    for limit in [0.5, 1.0, 2.0, 4.0, 8.0, 16.0] {
        let cells: Vec<String> = present
            .iter()
            .map(|(_, keep)| {
                let best = rows.iter().filter(|r| keep(r) && r.seconds <= limit).min_by(|a, b| judged(a).total_cmp(&judged(b)));
                best.map_or("—".into(), |r| format!("{:.5} ({}, {:.2} s)", judged(r), short_name(r), r.seconds))
            })
            .collect();
        let _ = writeln!(s, "| {limit} | {} |", cells.join(" | "));
    }
    s
}

fn write_outputs(dir: &Path, scene: &Path, rows: &[Row], noise: Option<f64>, skipped: &[String]) -> anyhow::Result<()> {
    let json = serde_json::to_vec_pretty(rows)?;
    raysplat::io::write_file(&dir.join("study.json"), Format::Json, &json)?;
    let mut csv = String::from("method,params,seconds,phase_seconds,peak_bytes,rel_mse,rel_mse_converged,rmse,mean_rel_error,over_5,over_15,over_30,nan\n");
    for r in rows {
        let phases: Vec<String> = r.phase_seconds.iter().map(|(k, v)| format!("{k}={v:.4}")).collect();
        let _ = writeln!(
            csv,
            "{},\"{}\",{:.4},\"{}\",{},{:.6e},{},{:.6e},{:.6e},{:.5},{:.5},{:.5},{}",
            r.method,
            params_text(&r.params),
            r.seconds,
            phases.join(" "),
            r.peak_bytes,
            r.rel_mse,
            r.rel_mse_converged.map_or(String::new(), |e| format!("{e:.6e}")),
            r.rmse,
            r.mean_rel_error,
            r.over_5,
            r.over_15,
            r.over_30,
            r.nan
        );
    }
    raysplat::io::write_file(&dir.join("study.csv"), Format::Csv, csv.as_bytes())?;
    let mut md = format!("Scene `{}`\n\n", scene.display());
    if let Some(n) = noise {
        let _ = writeln!(md, "The reference's own relative MSE (from its two halves) is {n:.5}; \"converged\" errors are the errors against the reference less it.\n");
    }
    md += &markdown_table(rows);
    if !skipped.is_empty() {
        md += "\n";
        for k in skipped {
            let _ = writeln!(md, "- {k}");
        }
    }
    md += "\n";
    md += &fastest_table(rows);
    raysplat::io::write_file(&dir.join("study.md"), Format::Markdown, md.as_bytes())?;
    if rows.iter().any(|r| base_method(r).1) {
        // the denoising summary on its own (docs/accuracy.md's denoising section)
        let mut dn = within_table(rows);
        if rows.iter().any(|r| !base_method(r).1) {
            dn += "\n";
            dn += &denoise_table(rows);
        }
        raysplat::io::write_file(&dir.join("denoise.md"), Format::Markdown, dn.as_bytes())?;
    }
    super::plot::error_vs_time(&dir.join("error-vs-time.png"), &scene.file_name().map_or(scene.display().to_string(), |f| f.to_string_lossy().into_owned()), rows, noise)?;
    Ok(())
}
