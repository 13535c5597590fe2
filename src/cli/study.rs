//! `raysplat study`: the speed–accuracy trade of every method on one scene, measured in one run.
//!
//! Renders (or reads) a path-traced reference, then each method at a ladder of budgets — the budget
//! multipliers scale the path tracer's samples per pixel (base 4) and, for the photon methods, the
//! axes `--ladder` names: photons (base 25 000), eye samples per pixel (base 4), final gather rays
//! (base: the method's default) — optionally for several smoothness values `C` of the splatting
//! methods (`--smoothness`), and records per render: parameters, seconds in total and per phase, peak
//! resident memory, and the error against the reference (`image::compare`: relative MSE, RMSE, share
//! of pixels over 5/15/30 % error, NaN count). Writes `study.json`, `study.csv`, `study.md` and a
//! log-log plot of error against time, `error-vs-time.png`.

use super::progress::Bars;
use super::reference::Reference;
use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use raysplat::image::{self, Metrics};
use raysplat::integrators::{self, Method, RenderSettings, SilentProgress};
use raysplat::{usd, Error};
use serde::Serialize;
use raysplat::files::Format;
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
    let resolution = a.resolution.as_deref().map(super::parse_resolution).transpose()?;
    std::fs::create_dir_all(&a.output).map_err(|e| Error::io(&a.output, e))?;
    // the files the study writes, checked before hours of rendering
    let names = [("reference.exr", Format::Exr), ("study.json", Format::Json), ("study.csv", Format::Csv), ("study.md", Format::Markdown), ("error-vs-time.png", Format::Png)];
    let paths: Vec<(PathBuf, Format)> = names.iter().filter(|(n, _)| a.reference.is_none() || *n != "reference.exr").map(|(n, f)| (a.output.join(n), *f)).collect();
    let outputs: Vec<(&Path, Format)> = paths.iter().map(|(p, f)| (p.as_path(), *f)).collect();
    let inputs: Vec<&Path> = std::iter::once(a.scene.as_path()).chain(a.reference.as_deref()).collect();
    raysplat::files::check_outputs(&outputs, &inputs)?;
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
    let mut rows = Vec::new();
    let mut skipped: Vec<String> = Vec::new();
    for &(m, smoothness) in &variants {
        let mut too_slow: Option<(u32, f64)> = None;
        for &b in &budgets {
            if let Some((prev, secs)) = too_slow {
                let c = smoothness.map_or(String::new(), |c| format!(" (C={c})"));
                skipped.push(format!("{m}{c} ×{b}: skipped, ×{prev} took {secs:.1} s (`--max-seconds`)"));
                bar.inc(1);
                continue;
            }
            let mut s = RenderSettings { method: m, ..base.clone() };
            let mut params = BTreeMap::new();
            if m.uses_photons() {
                let (fp, fs, fr) = ladder_factors(&a.ladder, b);
                s.spp = a.eye_spp * fs;
                s.aa_spp = if a.aa_spp == 0 { 0 } else { (a.aa_spp * fs).max(s.spp) };
                s.photons = PHOTON_BASE * fp as usize;
                s.fg.rays = s.fg.rays.saturating_mul(fr);
                s.fg_rays = s.fg_rays.saturating_mul(fr);
                s.explicit_rays = s.explicit_rays.saturating_mul(fr);
                if let Some(c) = smoothness {
                    s.bandwidth.smoothness = c;
                }
                s.validate()?;
                params.insert("photons".into(), s.photons.into());
                params.insert("spp".into(), s.spp.into());
                if s.aa_spp > s.spp {
                    params.insert("aa_spp".into(), s.aa_spp.into());
                }
                if splats(m) {
                    params.insert("smoothness".into(), round6(s.bandwidth.smoothness).into());
                    params.insert("sensitivity".into(), round6(s.bandwidth.sensitivity).into());
                }
                if m == Method::Pm {
                    params.insert("knn".into(), s.knn.into());
                }
                if m.final_gathers() {
                    params.insert("fg_rays".into(), s.fg.rays.into());
                }
                if m == Method::HeFg {
                    params.insert("fg_rays".into(), s.fg_rays.into());
                    params.insert("explicit_rays".into(), s.explicit_rays.into());
                }
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
                too_slow = Some((b, seconds));
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
            let e: Metrics = image::compare(&rgb, &ref_rgb);
            rows.push(Row {
                method: m.to_string(),
                params,
                seconds,
                phase_seconds: out.stats.phases.iter().cloned().collect(),
                peak_bytes,
                rel_mse: e.rel_mse,
                rel_mse_converged: noise.map(|n| e.rel_mse - n),
                rmse: e.rmse,
                mean_rel_error: e.mean_rel_error,
                over_5: e.over_5,
                over_15: e.over_15,
                over_30: e.over_30,
                nan: e.nan,
            });
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    write_outputs(&a.output, &a.scene, &rows, noise, &skipped)?;
    print!("{}", markdown_table(&rows));
    eprintln!("study: wrote {}/study.json, study.csv, study.md, error-vs-time.png", a.output.display());
    Ok(())
}

/// An f32 setting as the f64 a reader expects (0.3, not 0.30000001192092896).
fn round6(x: f32) -> f64 {
    (x as f64 * 1e6).round() / 1e6
}

fn params_text(p: &BTreeMap<String, serde_json::Value>) -> String {
    p.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>().join(" ")
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

/// For a few error targets: the render that reached it in the least time in this study, and the
/// path tracer's and the fastest photon method's times to it (their ratio is the speed-up).
fn fastest_table(rows: &[Row]) -> String {
    let against = if rows.iter().all(|r| r.rel_mse_converged.is_some()) { "against the converged image" } else { "against the reference" };
    let mut s = format!("| target rel. MSE ({against}) | fastest render (parameters) | seconds | pt | fastest photon method | speed-up over pt |\n|---:|---|---:|---|---|---:|\n");
    let text = |r: Option<&Row>| r.map_or("not reached".to_string(), |r| format!("{} ({}) in {:.2} s", r.method, params_text(&r.params), r.seconds));
    for target in [0.05, 0.02, 0.01, 0.005, 0.002] {
        let first = |keep: &dyn Fn(&Row) -> bool| rows.iter().filter(|r| keep(r) && judged(r) <= target).min_by(|a, b| a.seconds.total_cmp(&b.seconds));
        let (best, pt, photon) = (first(&|_| true), first(&|r| r.method == "pt"), first(&|r| r.method != "pt"));
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

fn write_outputs(dir: &Path, scene: &Path, rows: &[Row], noise: Option<f64>, skipped: &[String]) -> anyhow::Result<()> {
    let json = serde_json::to_vec_pretty(rows)?;
    raysplat::scene::format::write_atomic_as(&dir.join("study.json"), Format::Json, &json)?;
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
    raysplat::scene::format::write_atomic_as(&dir.join("study.csv"), Format::Csv, csv.as_bytes())?;
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
    raysplat::scene::format::write_atomic_as(&dir.join("study.md"), Format::Markdown, md.as_bytes())?;
    super::plot::error_vs_time(&dir.join("error-vs-time.png"), &scene.file_name().map_or(scene.display().to_string(), |f| f.to_string_lossy().into_owned()), rows, noise)?;
    Ok(())
}
