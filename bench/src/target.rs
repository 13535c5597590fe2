//! `raysplat-bench target`: how long each method takes to reach a relative MSE (0.01 by default),
//! against the path tracer's time to it (docs/auto.md, "Time to a relative MSE of 0.01").
//!
//! A 4096-spp reference is not converged on every scene (on `secondary-light.usda` its own relative
//! MSE is about 0.01), so the reference is rendered as two independent halves, its noise is
//! measured and taken out ([`raysplat_cli::reference`]). The path tracer's time to the target is measured
//! on renders of 4, 8, 16, … spp up to a quarter of the reference's, interpolated between the two
//! that bracket it (extrapolated with error ∝ 1/spp beyond, and said so).
//!
//! Then the photon methods run a ladder of eye samples per pixel and photons (each method and photon
//! count stops at the first eye-sample count that reaches the target; error and time are means over
//! `--target-seeds` seeds) and the table prints the fastest configuration that reaches it and its
//! speedup over the path tracer.

use raysplat_cli::reference::Reference;
use raysplat::integrators::{self, Method, RenderRequest, RenderSettings, SilentProgress};
use raysplat::usd;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct TargetTableArgs {
    /// Scenes (comma separated).
    #[arg(required = true, num_args = 1.., value_delimiter = ',', value_name = "SCENES")]
    pub scenes: Vec<PathBuf>,
    /// Target table: the relative MSE to reach.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.01)]
    pub target: f64,
    /// Target table: the longer image side in pixels (the scene's aspect ratio is kept); 0: the
    /// scene's own resolution.
    #[arg(long, default_value_t = 96)]
    pub target_size: u32,
    /// Target table: samples per pixel of the reference (two halves).
    #[arg(long, default_value_t = 4096)]
    pub target_reference_spp: u32,
    /// Target table: photon methods to time (comma separated).
    #[arg(long, value_delimiter = ',', default_value = "pm,rs")]
    pub target_methods: Vec<String>,
    /// Target table: eye samples per pixel of the photon methods (comma separated, ascending).
    #[arg(long, value_delimiter = ',', default_value = "1,2,4,8,16,32")]
    pub target_spp: Vec<u32>,
    /// Target table: camera samples per pixel for anti-aliasing and direct light (`--aa-spp`;
    /// comma separated; 0: the same as the eye samples). Eye sample counts above one are skipped.
    #[arg(long, value_delimiter = ',', default_value = "0,8,16")]
    pub target_aa_spp: Vec<u32>,
    /// Target table: k of pm's nearest-neighbour estimate (comma separated; the other methods
    /// render once with the default).
    #[arg(long, value_delimiter = ',', default_value = "100,50")]
    pub target_knn: Vec<usize>,
    /// Target table: light samples per camera sample (`--light-samples`).
    #[arg(long, default_value_t = 1)]
    pub target_light_samples: u32,
    /// Target table: photon counts (comma separated).
    #[arg(long, value_delimiter = ',', default_value = "10000,25000,100000,400000")]
    pub target_photons: Vec<usize>,
    /// Target table: each configuration's error and time are the mean over this many seeds (at 4
    /// eye spp the error of one image varies 2× from seed to seed on `secondary-light.usda`: a few
    /// pixels at the lit patch's edge dominate it).
    #[arg(long, default_value_t = 2)]
    pub target_seeds: u64,
}

pub fn run(a: &TargetTableArgs) -> anyhow::Result<()> {
    let scenes = &a.scenes;
    let methods: Vec<Method> = a.target_methods.iter().map(|m| m.parse()).collect::<Result<_, _>>()?;
    if let Some(m) = methods.iter().find(|m| !m.uses_photons()) {
        anyhow::bail!("--target-methods: {} is not a photon method (the path tracer's time comes from the reference)", m.name());
    }
    println!(
        "time to a relative MSE of {} against the converged image (reference: two path-traced halves of {} spp, their noise subtracted; photon methods: mean of {} seeds)",
        a.target,
        a.target_reference_spp / 2,
        a.target_seeds.max(1)
    );
    for path in scenes {
        let desc = usd::load_scene(path)?;
        let [sw, sh] = desc.resolution.unwrap_or([512, 512]);
        let scale = if a.target_size == 0 { 1.0 } else { a.target_size as f64 / sw.max(sh) as f64 };
        let res = [((sw as f64 * scale).round() as u32).max(1), ((sh as f64 * scale).round() as u32).max(1)];
        let base = RenderSettings { resolution: Some(res), seed: 1, ..Default::default() };
        let reference = Reference::render(&desc, &base, a.target_reference_spp, [1000, 1001], &[""])?;
        let pt = reference.pt_time_to(&desc, &base, a.target, a.target_reference_spp / 4, 7)?;
        let pt_s = pt.seconds;
        println!("\n{} ({}x{})", path.display(), res[0], res[1]);
        println!(
            "  reference: {} spp in {:.1} s, relative MSE {:.5}; pt reaches {} in {:.2} s ({}: {} spp gave {:.5})",
            reference.spp,
            reference.seconds,
            reference.noise(""),
            a.target,
            pt_s,
            if pt.extrapolated { "extrapolated with error ∝ 1/spp" } else { "measured, interpolated" },
            pt.spp_error.0,
            pt.spp_error.1
        );
        println!("  {:<6} {:>4} {:>6} {:>8} {:>4} {:>8} {:>10}", "method", "spp", "aa_spp", "photons", "k", "seconds", "rel. MSE");
        let mut best: Option<(f64, String)> = None;
        for &m in &methods {
            let knns: &[usize] = if m == Method::Pm { &a.target_knn } else { &[RenderRequest::DEFAULT.knn] };
            for (&photons, &knn) in a.target_photons.iter().flat_map(|p| knns.iter().map(move |k| (p, k))) {
                for &aa_spp in &a.target_aa_spp {
                    for &spp in a.target_spp.iter().filter(|&&spp| aa_spp == 0 || spp <= aa_spp) {
                        let (mut e, mut secs) = (0.0, 0.0);
                        for seed in 1..=a.target_seeds.max(1) {
                            let s = RenderRequest { method: Some(m), spp: Some(spp), aa_spp, light_samples: a.target_light_samples, photons: Some(photons), knn, seed, resolution: Some(res), ..Default::default() }.settings()?;
                            let out = integrators::render(desc.clone(), &s, &SilentProgress)?;
                            e += reference.error("", &out.film.rgb("").expect("beauty")) / a.target_seeds.max(1) as f64;
                            secs += out.stats.total_seconds / a.target_seeds.max(1) as f64;
                        }
                        let aa = aa_spp.max(spp);
                        let k = if m == Method::Pm { knn.to_string() } else { "-".into() };
                        println!("  {:<6} {:>4} {:>6} {:>8} {:>4} {:>8.2} {:>10.5}", m.name(), spp, aa, photons, k, secs, e);
                        if e <= a.target {
                            if best.as_ref().is_none_or(|(s, _)| secs < *s) {
                                best = Some((secs, format!("{} spp={spp} aa_spp={aa} photons={photons} k={k}", m.name())));
                            }
                            break; // more eye samples only cost more time
                        }
                    }
                }
            }
        }
        match best {
            Some((secs, what)) => println!("  fastest photon method to {}: {what} in {secs:.2} s: {:.1}x faster than pt (goal ≥ 5)", a.target, pt_s / secs),
            None => println!("  no photon configuration reached {} (pt: {pt_s:.1} s)", a.target),
        }
    }
    Ok(())
}
