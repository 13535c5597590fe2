//! `--method rs`: photon ray splatting (`photon-ray-splatting.md` §3–7). Eye pass → light pass →
//! splatting of every photon ray onto the eye samples in its cone frustum → film.

use super::compose;
use super::{Progress, RenderSettings, Stats};
use crate::error::{Error, Result};
use crate::image::Film;
use crate::prepare::PreparedScene;
use crate::splat;
use std::time::Instant;

pub fn render(scene: &PreparedScene, s: &RenderSettings, progress: &dyn Progress, stats: &mut Stats) -> Result<Film> {
    progress.begin("eye + light pass", 2);
    let (eye, photons) = compose::eye_and_light(scene, s, progress, stats)?;
    progress.advance(2);
    if progress.cancelled() {
        return Err(Error::Cancelled);
    }
    progress.begin("splatting", 1);
    let t = Instant::now();
    let classes: Vec<&[crate::photon::PhotonRay]> = photons.rays.iter().map(|v| v.as_slice()).collect();
    let img = splat::splat_cancellable(&eye, &classes, &|| progress.cancelled()).ok_or(Error::Cancelled)?;
    stats.phase("splat", t.elapsed().as_secs_f64());
    progress.advance(1);
    progress.finish();
    stats.count("splat_pairs", img.pairs);
    stats.count("splat_tiles", img.tiles as u64);
    stats.count("mean_bandwidth_um", (img.mean_bandwidth() * 1e6) as u64);
    stats.enable("splat kd-tree (per tile, largest)", img.tree_bytes);
    stats.enable("splat image (radiance, kernel weights, harmonic distance)", (img.radiance.len() * 20) as u64);
    Ok(compose::film(&eye, &img.radiance))
}
