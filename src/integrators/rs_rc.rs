//! `--method rs-rc`: photon ray splatting with radiance caching (§8.3): eye pass → light pass →
//! multi-pass splatting onto sparse SH cache records → image-space extrapolation → film.
//!
//! The cache assumes low-frequency light (§8.3: radiance caching "requires low-frequency
//! illumination"): caustic photons (light → specular → diffuse) are not cached. They are splatted
//! onto every eye sample, as `rs` does, and added to the extrapolated light — a caustic
//! extrapolated from records 8 pixels apart would be spread over its surroundings.

use super::compose;
use super::{Progress, RenderSettings, Stats};
use crate::error::{Error, Result};
use crate::image::Film;
use crate::photon::{PhotonClass, PhotonRay};
use crate::prepare::PreparedScene;
use crate::radiance_cache::{self, CacheParams};
use std::time::Instant;

pub fn render(scene: &PreparedScene, s: &RenderSettings, progress: &dyn Progress, stats: &mut Stats) -> Result<Film> {
    let (eye, photons) = compose::eye_and_light(scene, s, progress, stats)?;
    progress.begin("radiance cache", 2);
    let t = Instant::now();
    let caustic = PhotonClass::Caustic as usize;
    let cached: Vec<&[PhotonRay]> = photons.rays.iter().enumerate().filter(|&(k, _)| k != caustic).map(|(_, v)| v.as_slice()).collect();
    let params = CacheParams { error: s.cache_error(), ..CacheParams::default() };
    let mut out = radiance_cache::render(&eye, &cached, &params, &|| progress.cancelled()).ok_or(Error::Cancelled)?;
    stats.phase("splat", t.elapsed().as_secs_f64());
    progress.advance(1);
    let mut pairs = out.pairs;
    if !photons.rays[caustic].is_empty() {
        let t = Instant::now();
        // as `rs` splats them, glossy samples included (`--glossy`, default auto)
        let mut img = crate::splat::splat_with_map(&eye, &[&photons.rays[caustic]], s.glossy, &|| progress.cancelled()).ok_or(Error::Cancelled)?;
        stats.phase("caustic splat", t.elapsed().as_secs_f64());
        super::rs::glossy_resolve(&eye, &mut img, s, stats); // phase "glossy"
        for (r, c) in out.radiance.iter_mut().zip(&img.radiance) {
            *r += *c;
        }
        pairs += img.pairs;
        stats.enable("caustic splatting onto every eye sample (not cached)", img.tree_bytes + img.bytes() + img.ray_box_bytes);
    }
    progress.advance(1);
    progress.finish();
    stats.count("cache_records", out.records as u64);
    stats.count("cache_passes", out.passes as u64);
    stats.count("cache_off_surface_samples", out.off_surface_samples as u64);
    stats.count("splat_pairs", pairs);
    stats.enable(&format!("radiance cache ({} SH records, ε {})", out.records, s.cache_error()), out.record_bytes);
    stats.enable("SH BSDF tables", out.table_bytes);
    Ok(compose::film(&eye, &out.radiance))
}
