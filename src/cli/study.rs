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
use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use raysplat::image::{self, Metrics};
use raysplat::integrators::{self, Method, RenderSettings, SilentProgress};
use raysplat::{usd, Error};
use serde::Serialize;
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
    /// Use this EXR as the reference instead of rendering one.
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
    pub rmse: f64,
    pub mean_rel_error: f64,
    pub over_5: f64,
    pub over_15: f64,
    pub over_30: f64,
    pub nan: usize,
}

const PT_BASE_SPP: u32 = 4;
const PHOTON_BASE: usize = 25_000;
const EYE_BASE_SPP: u32 = 4;

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
    if let Some(c) = a.smoothness.iter().find(|c| !(c.is_finite() && **c > 0.0 && **c <= 10.0)) {
        return Err(Error::param("smoothness", format!("{c} is out of range (0, 10]")).into());
    }
    let resolution = a.resolution.as_deref().map(super::parse_resolution).transpose()?;
    std::fs::create_dir_all(&a.output).map_err(|e| Error::io(&a.output, e))?;
    let scene = usd::load_scene(&a.scene)?;
    let base = RenderSettings { seed: a.seed, resolution, ..Default::default() };

    // The reference.
    let reference = match &a.reference {
        Some(p) => image::read_exr(p)?,
        None => {
            eprintln!("study: rendering the path-traced reference ({} spp)", a.reference_spp);
            let s = RenderSettings { spp: a.reference_spp, seed: a.seed ^ 0x5eed, ..base.clone() };
            let out = integrators::render(scene.clone(), &s, &Bars::new())?;
            let path = a.output.join("reference.exr");
            image::write_exr(&path, &out.film, &s.attributes())?;
            out.film
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
    for &(m, smoothness) in &variants {
        for &b in &budgets {
            let mut s = RenderSettings { method: m, ..base.clone() };
            let mut params = BTreeMap::new();
            if m.uses_photons() {
                let (fp, fs, fr) = ladder_factors(&a.ladder, b);
                s.spp = EYE_BASE_SPP * fs;
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
    write_outputs(&a.output, &a.scene, &rows)?;
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
    let _ = writeln!(s, "| method | parameters | seconds | phases (s) | peak memory | rel. MSE | RMSE | >5 % | >15 % | >30 % | NaN |");
    let _ = writeln!(s, "|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|");
    for r in rows {
        let phases: Vec<String> = r.phase_seconds.iter().map(|(k, v)| format!("{k} {v:.2}")).collect();
        let _ = writeln!(
            s,
            "| {} | {} | {:.2} | {} | {:.0} MiB | {:.5} | {:.5} | {:.3} | {:.3} | {:.3} | {} |",
            r.method,
            params_text(&r.params),
            r.seconds,
            phases.join(", "),
            r.peak_bytes as f64 / (1024.0 * 1024.0),
            r.rel_mse,
            r.rmse,
            r.over_5,
            r.over_15,
            r.over_30,
            r.nan
        );
    }
    s
}

/// For a few error targets: the method that reached it in the least time in this study.
fn fastest_table(rows: &[Row]) -> String {
    let mut s = String::from("| target rel. MSE | fastest method (parameters) | seconds |\n|---:|---|---:|\n");
    for target in [0.05, 0.02, 0.01, 0.005, 0.002] {
        let best = rows.iter().filter(|r| r.rel_mse <= target).min_by(|a, b| a.seconds.total_cmp(&b.seconds));
        let _ = match best {
            Some(r) => writeln!(s, "| {target} | {} ({}) | {:.2} |", r.method, params_text(&r.params), r.seconds),
            None => writeln!(s, "| {target} | not reached by any budget of this study | — |"),
        };
    }
    s
}

fn write_outputs(dir: &Path, scene: &Path, rows: &[Row]) -> anyhow::Result<()> {
    let json = serde_json::to_vec_pretty(rows)?;
    raysplat::scene::format::write_atomic(&dir.join("study.json"), &json)?;
    let mut csv = String::from("method,params,seconds,phase_seconds,peak_bytes,rel_mse,rmse,mean_rel_error,over_5,over_15,over_30,nan\n");
    for r in rows {
        let phases: Vec<String> = r.phase_seconds.iter().map(|(k, v)| format!("{k}={v:.4}")).collect();
        let _ = writeln!(
            csv,
            "{},\"{}\",{:.4},\"{}\",{},{:.6e},{:.6e},{:.6e},{:.5},{:.5},{:.5},{}",
            r.method,
            params_text(&r.params),
            r.seconds,
            phases.join(" "),
            r.peak_bytes,
            r.rel_mse,
            r.rmse,
            r.mean_rel_error,
            r.over_5,
            r.over_15,
            r.over_30,
            r.nan
        );
    }
    raysplat::scene::format::write_atomic(&dir.join("study.csv"), csv.as_bytes())?;
    let md = format!("Scene `{}`\n\n{}\n{}", scene.display(), markdown_table(rows), fastest_table(rows));
    raysplat::scene::format::write_atomic(&dir.join("study.md"), md.as_bytes())?;
    super::plot::error_vs_time(&dir.join("error-vs-time.png"), &format!("{}", scene.file_name().map_or(scene.display().to_string(), |f| f.to_string_lossy().into_owned())), rows)?;
    Ok(())
}
