//! `raysplat-bench secondary SCENE`: the strong-secondary-lighting paper's Fig. 3 comparison
//! (`strong-secondary-lighting.md` §4): uniform stratified final gathering with 768 rays into one
//! global photon map versus 48 stratified rays into the low-energy map + 230 explicit rays toward the
//! high-energy voxels, each with and without Ward's irradiance cache, at equal photons, seeds and eye
//! pass. Printed per row: total time, the gather (+ cache) time, and the relative MSE of the beauty
//! and `indirect` layers
//! - against a path-traced reference (mean of two halves of different seeds; the reference's own
//!   noise `relMSE(A, B)/4` is subtracted), which includes the photon map's bias common to all rows;
//! - against the converged uniform final gather of the same photons (4096 rays), which isolates the
//!   gather's own noise and the cache's interpolation error: the quantity the paper's Fig. 3 compares.

use raysplat::image;
use raysplat::integrators::{self, Method, RenderRequest, RenderSettings, SilentProgress};
use raysplat::usd;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct SecondaryTableArgs {
    /// The scene (default: the repository's secondary-light).
    #[arg(value_name = "SCENE", default_value = "scenes/secondary-light.usda")]
    pub scene: PathBuf,
    /// Secondary table: image size WxH.
    #[arg(long, default_value = "80x60")]
    pub secondary_resolution: String,
    /// Secondary table: stored photons.
    #[arg(long, default_value_t = 200_000)]
    pub secondary_photons: usize,
    /// Secondary table: path-traced samples per pixel of the reference (two halves).
    #[arg(long, default_value_t = 2048)]
    pub secondary_reference_spp: u32,
}

const SEED: u64 = 1;
const REFERENCE_SEEDS: [u64; 2] = [2001, 2002];

pub fn run(a: &SecondaryTableArgs) -> anyhow::Result<()> {
    let scene = a.scene.as_path();
    let [w, h] = raysplat::integrators::parse_size(&a.secondary_resolution)?;
    if a.secondary_reference_spp < 2 {
        anyhow::bail!(raysplat::Error::param("secondary-reference-spp", "must be at least 2 (two halves)"));
    }
    let desc = usd::load_scene(scene)?;
    let base = RenderSettings { resolution: Some([w, h]), seed: SEED, ..Default::default() };
    let request = RenderRequest { resolution: Some([w, h]), seed: SEED, spp: Some(1), photons: Some(a.secondary_photons), ..Default::default() };
    let layer = |f: &image::Film, l: &str| f.rgb(l).expect("layer");
    let reference = raysplat_cli::reference::Reference::render(&desc, &base, a.secondary_reference_spp, REFERENCE_SEEDS, &["", "indirect"])?;
    let (noise_beauty, noise_indirect, ref_seconds) = (reference.noise(""), reference.noise("indirect"), reference.seconds);
    let fg = |fg_rays, explicit_rays, irradiance_cache| RenderRequest { method: Some(Method::HeFg), fg_rays: Some(fg_rays), explicit_rays, irradiance_cache, ..request.clone() }.settings();
    let converged = integrators::render(desc.clone(), &fg(4096, 0, false)?, &SilentProgress)?;
    let conv_indirect = layer(&converged.film, "indirect");
    println!(
        "strong secondary lights (Tawara et al., Fig. 3): {} at {w}x{h}, 1 eye sample/pixel, {} photons, {} threads",
        scene.display(),
        a.secondary_photons,
        rayon::current_num_threads()
    );
    println!(
        "path-traced reference {} spp in {:.1}s, its noise (relative MSE): beauty {noise_beauty:.6}, indirect {noise_indirect:.6}; converged uniform gather (4096 rays) {:.1}s",
        a.secondary_reference_spp, ref_seconds, converged.stats.total_seconds
    );
    let sp = integrators::he_fg::survey(&raysplat::prepare::PreparedScene::new(desc.clone(), w, h, 0)?, a.secondary_photons, SEED).split;
    println!("split: {}", sp.summary());
    println!(
        "  {:<34} {:>7} {:>8} {:>8} | {:>11} {:>11} | {:>11}",
        "gather", "ΣT (s)", "T_FG (s)", "records", "rMSE beauty", "rMSE indir.", "vs conv. FG"
    );
    let rows = [("uniform 768", 768, 0, false), ("48 stratified + 230 explicit", 48, 230, false), ("uniform 768 + cache", 768, 0, true), ("48 + 230 explicit + cache", 48, 230, true)];
    for (label, n, m, cache) in rows {
        let out = integrators::render(desc.clone(), &fg(n, m, cache)?, &SilentProgress)?;
        let beauty = reference.error("", &layer(&out.film, ""));
        let ind = layer(&out.film, "indirect");
        let indirect = reference.error("indirect", &ind);
        let vs_conv = image::compare(&ind, &conv_indirect).rel_mse;
        let t_fg = out.stats.phase_seconds("gather").unwrap_or(0.0) + out.stats.phase_seconds("cache").unwrap_or(0.0);
        let records = out.stats.counter("cache_records").map_or("-".to_string(), |r| r.to_string());
        println!(
            "  {:<34} {:>7.2} {:>8.2} {:>8} | {:>11.6} {:>11.6} | {:>11.6}",
            label, out.stats.total_seconds, t_fg, records, beauty, indirect, vs_conv
        );
    }
    Ok(())
}
