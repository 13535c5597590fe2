//! `--method rs-rc`: photon ray splatting with radiance caching (§8.3): eye pass → light pass →
//! multi-pass splatting onto sparse SH cache records → image-space extrapolation → film.

use super::compose;
use super::{Progress, RenderSettings, Stats};
use crate::error::{Error, Result};
use crate::image::Film;
use crate::prepare::PreparedScene;
use crate::radiance_cache::{self, CacheParams};
use std::time::Instant;

pub fn render(scene: &PreparedScene, s: &RenderSettings, progress: &dyn Progress, stats: &mut Stats) -> Result<Film> {
    let (eye, photons) = compose::eye_and_light(scene, s, progress, stats)?;
    progress.begin("radiance cache", 1);
    let t = Instant::now();
    let classes: Vec<&[crate::photon::PhotonRay]> = photons.rays.iter().map(|v| v.as_slice()).collect();
    let out = radiance_cache::render(&eye, &classes, &CacheParams { error: s.cache_error(), ..CacheParams::default() }, &|| progress.cancelled()).ok_or(Error::Cancelled)?;
    stats.phase("splat", t.elapsed().as_secs_f64());
    progress.advance(1);
    progress.finish();
    stats.count("cache_records", out.records as u64);
    stats.count("cache_passes", out.passes as u64);
    stats.count("splat_pairs", out.pairs);
    stats.enable(&format!("radiance cache ({} SH records, ε {})", out.records, s.cache_error()), out.record_bytes);
    stats.enable("SH BSDF tables", out.table_bytes);
    Ok(compose::film(&eye, &out.radiance))
}
