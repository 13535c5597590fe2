//! `raysplat-bench auto`: is `--method auto --time T` as good as the best single method at
//! the same T? Per scene: a path-traced reference (`--auto-reference-spp`), then `auto` and every
//! single method with the same wall-clock budget, their relative MSE against the converged image
//! (the reference's measured noise subtracted, see `reference`; each photon method at 4 eye samples
//! per pixel and at 2 eye and 16 camera samples), and the ratio of auto's error
//! to the best single method's (issue goal: at most 1.25). A method whose single pass takes longer
//! than 1.5 × T (and than auto) did not render at T and is listed but not compared.

use raysplat::integrators::{self, auto, Method, RenderRequest, RenderSettings, SilentProgress};
use raysplat::usd;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct AutoTableArgs {
    /// Scenes (comma separated).
    #[arg(required = true, num_args = 1.., value_delimiter = ',', value_name = "SCENES")]
    pub scenes: Vec<PathBuf>,
    /// Auto table: wall-clock budget of each render, in seconds.
    #[arg(long, allow_negative_numbers = true, default_value_t = 3.0)]
    pub auto_time: f64,
    /// Auto table: image size WxH.
    #[arg(long, default_value = "128x128")]
    pub auto_resolution: String,
    /// Auto table: samples per pixel of the path-traced reference.
    #[arg(long, default_value_t = 4096)]
    pub auto_reference_spp: u32,
    /// Auto table: the single methods auto is compared with (comma separated; default: every
    /// method). The final-gathering methods' one pass takes 10-150 s at 128²: leaving them out
    /// makes a table at a short budget quick.
    #[arg(long, value_delimiter = ',')]
    pub auto_methods: Vec<String>,
}

pub fn run(a: &AutoTableArgs) -> anyhow::Result<()> {
    let scenes = &a.scenes;
    let res = raysplat::integrators::parse_size(&a.auto_resolution)?;
    let methods: Vec<Method> = if a.auto_methods.is_empty() { Method::ALL.to_vec() } else { a.auto_methods.iter().map(|m| m.parse()).collect::<Result<_, _>>()? };
    println!("auto against every method at {} s each, {}x{}, relative MSE against a {}-spp path-traced reference (noise subtracted)", a.auto_time, res[0], res[1], a.auto_reference_spp);
    for path in scenes {
        let desc = usd::load_scene(path)?;
        let request = RenderRequest { resolution: Some(res), seed: 1, ..Default::default() };
        let base = RenderSettings { resolution: Some(res), seed: 1, ..Default::default() };
        let reference = raysplat_cli::reference::Reference::render(&desc, &base, a.auto_reference_spp, [1000, 1001], &[""])?;
        let err = |s: &RenderSettings| -> anyhow::Result<(f64, f64)> {
            let out = integrators::render(desc.clone(), s, &SilentProgress)?;
            Ok((reference.error("", &out.film.rgb("").expect("beauty")), out.stats.total_seconds))
        };
        let (chosen, reason) = auto::choose(&desc, &RenderRequest { time: Some(a.auto_time), ..request.clone() })?;
        println!("\n{} (reference noise {:.5}, subtracted)\n  {reason}", path.display(), reference.noise(""));
        let (auto_err, auto_s) = err(&chosen)?;
        println!("  {:<10} {:>8} {:>10}", "method", "seconds", "rel. MSE");
        println!("  {:<10} {:>8.2} {:>10.5}", "auto", auto_s, auto_err);
        // A method whose one pass overruns the budget is not "at that time": it is listed, not compared.
        let limit = (1.5 * a.auto_time).max(auto_s);
        let mut best = f64::INFINITY;
        // Each photon method twice: 4 eye samples per pixel, and 2 eye samples with 16 camera
        // samples (`--aa-spp`, as auto's presets take them).
        let variants = methods.iter().flat_map(|&m| if m.uses_photons() { vec![(m, 4, 0), (m, 2, 16)] } else { vec![(m, 1 << 24, 0)] });
        for (m, spp, aa_spp) in variants {
            let s = RenderRequest { method: Some(m), spp: Some(spp), aa_spp, time: Some(a.auto_time), ..request.clone() }.settings()?;
            let (e, secs) = err(&s)?;
            let over = if secs > limit { "  (over the budget: not compared)" } else { "" };
            let name = if aa_spp > 0 { format!("{} {spp}/{aa_spp}", m.name()) } else { m.name().to_string() };
            println!("  {name:<10} {secs:>8.2} {e:>10.5}{over}");
            if secs <= limit {
                best = best.min(e);
            }
        }
        println!("  auto / best single method within {limit:.1} s: {:.2} (goal ≤ 1.25)", auto_err / best);
    }
    Ok(())
}
