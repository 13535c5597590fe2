//! `raysplat-bench real`: the real-scene table. Per scene (the workplace's shared scenes, skipped
//! with a printed reason when missing, and the repository's): a path-traced reference (two halves,
//! its noise measured and subtracted, see `reference`), then `auto` and each single method at equal
//! wall-clock times, their error against the reference — relative MSE of the image and of its
//! direct and indirect layers, and the exposure-independent error: the MSE over the reference's
//! squared mean (the error of both images scaled to the reference's mean; relative MSE, with its
//! fixed 0.01 in the denominator, turns into plain MSE on a dark image). `auto` splits its time by
//! plain MSE (`integrators::allocation`), which the scaled error measures up to a constant.
//! `auto`'s survey counts against its time (its seconds include it).

use raysplat::integrators::{self, auto, Method, RenderRequest, RenderSettings, SilentProgress};
use raysplat::usd;
use std::path::{Path, PathBuf};

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
}

/// The shared scenes of the table, relative to the shared directory.
const SHARED: [&str; 5] = [
    "classic/crytek_sponza/sponza.usdc",
    "usd/usd-wg-assets/full_assets/StandardShaderBall/standard_shader_ball_scene.usda",
    "usd/MiniCarKit_scene.usda",
    "classic/cornell_box/CornellBox-Original.usda",
    "classic/cornell_box/CornellBox-Sphere.usda",
];
/// The repository's scenes of the table.
const REPOSITORY: [&str; 3] = ["scenes/cornell-box.usda", "scenes/bumpy-box.usda", "scenes/cornell-glossy.usda"];

fn scenes(a: &RealTableArgs) -> Vec<PathBuf> {
    if !a.real_scenes.is_empty() {
        return a.real_scenes.clone();
    }
    let mut out = Vec::new();
    for s in SHARED {
        let p = a.shared_scenes.join(s);
        if p.exists() {
            out.push(p);
        } else {
            println!("skipped: {} is missing (the workplace's shared scenes; --shared-scenes DIR)", p.display());
        }
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    out.extend(REPOSITORY.iter().map(|s| root.join(s)));
    out
}

/// MSE over the reference's squared mean (RGB).
fn scaled_mse(test: &[f32], reference: &[f32]) -> f64 {
    let n = reference.len().max(1) as f64;
    let mean = reference.iter().map(|&v| v as f64).sum::<f64>() / n;
    let mse = test.iter().zip(reference).map(|(&t, &r)| (t as f64 - r as f64).powi(2)).sum::<f64>() / n;
    mse / (mean * mean).max(1e-30)
}

pub fn run(a: &RealTableArgs) -> anyhow::Result<()> {
    let methods: Vec<Method> = a.real_methods.iter().map(|m| m.parse()).collect::<Result<_, _>>()?;
    println!(
        "real scenes: auto and {} at {:?} s, longer side {} px, against a {}-spp path-traced reference (noise subtracted from the relative MSE)",
        a.real_methods.join(", "),
        a.real_times,
        a.real_size,
        a.real_reference_spp
    );
    println!("columns: seconds, relative MSE of the image / direct / indirect layer, MSE over the reference's squared mean (exposure-independent)");
    for path in scenes(a) {
        let desc = match usd::load_scene(&path) {
            Ok(d) => d,
            Err(e) => {
                println!("\nskipped: {}: {e}", path.display());
                continue;
            }
        };
        let [w0, h0] = desc.resolution.unwrap_or([512, 512]);
        let scale = a.real_size as f32 / w0.max(h0) as f32;
        let res = [((w0 as f32 * scale).round() as u32).max(1), ((h0 as f32 * scale).round() as u32).max(1)];
        let request = RenderRequest { resolution: Some(res), seed: 1, ..Default::default() };
        let base = RenderSettings { resolution: Some(res), seed: 1, ..Default::default() };
        let layers = ["", "direct", "indirect"];
        let reference = raysplat_cli::reference::Reference::render(&desc, &base, a.real_reference_spp, [1000, 1001], &layers)?;
        let ref_rgb = reference.film.rgb("").expect("beauty");
        println!("\n{} at {}x{} (reference noise {:.5}, {:.0} s)", path.display(), res[0], res[1], reference.noise(""), reference.seconds);
        println!("  {:<6} {:<8} {:>8} {:>10} {:>10} {:>10} {:>10}", "time", "method", "seconds", "image", "direct", "indirect", "scaled");
        for &t in &a.real_times {
            let row = |name: &str, s: &RenderSettings, extra: f64| -> anyhow::Result<[f64; 2]> {
                let out = integrators::render(desc.clone(), s, &SilentProgress)?;
                let e: Vec<f64> = layers.iter().map(|l| out.film.rgb(l).map_or(f64::NAN, |rgb| reference.error(l, &rgb))).collect();
                let scaled = scaled_mse(&out.film.rgb("").expect("beauty"), &ref_rgb);
                let secs = out.stats.total_seconds + extra;
                println!("  {t:<6} {name:<8} {secs:>8.2} {:>10.5} {:>10.5} {:>10.5} {scaled:>10.5}", e[0], e[1], e[2]);
                Ok([e[0], scaled])
            };
            let (chosen, reason) = auto::choose(&desc, &RenderRequest { time: Some(t), ..request.clone() })?;
            println!("  {reason}");
            let auto_err = row("auto", &chosen, reason.survey_seconds())?;
            let mut best = [f64::INFINITY; 2];
            let mut pt = [f64::INFINITY; 2];
            for &m in &methods {
                let s = RenderRequest { method: Some(m), time: Some(t), ..request.clone() }.settings()?;
                let e = row(m.name(), &s, 0.0)?;
                for k in 0..2 {
                    best[k] = best[k].min(e[k]);
                }
                if m == Method::Pt {
                    pt = e;
                }
            }
            println!(
                "  {t:<6} auto / best single method: {:.2} (scaled {:.2}; goal ≤ 1.25), auto / pt: {:.2} (scaled {:.2}; goal ≤ 1)",
                auto_err[0] / best[0],
                auto_err[1] / best[1],
                auto_err[0] / pt[0],
                auto_err[1] / pt[1]
            );
        }
    }
    Ok(())
}
