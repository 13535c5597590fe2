//! `--method rs`: photon ray splatting (`photon-ray-splatting.md` §3–7). Eye pass → light pass →
//! splatting of every photon ray onto the eye samples in its cone frustum → film.

use super::compose::{self, PhotonPass};
use super::settings::attribute;
use super::{Progress, RenderSettings, Stats};
use crate::error::{Error, Result};
use crate::image::Film;
use crate::prepare::PreparedScene;
use crate::radiance_map::GlossyMode;
use crate::splat;
use std::time::Instant;

/// Settings of `rs`.
#[derive(Clone, Debug, PartialEq)]
pub struct RsSettings {
    pub pass: PhotonPass,
    /// How glossy eye samples receive light (exact BSDF per photon, or a per-pixel SH / histogram
    /// radiance map, §8.1; `Auto`: SH for the lobes SH bands 0–3 hold, exact for the others).
    pub glossy: GlossyMode,
    /// Image-space radiance filter (§8.2), largest box radius in pixels (0: off).
    pub filter_radius: u32,
}

impl Default for RsSettings {
    fn default() -> Self {
        RsSettings { pass: PhotonPass::default(), glossy: GlossyMode::Auto, filter_radius: 0 }
    }
}

impl RsSettings {
    pub fn validate(&self) -> Result<()> {
        if self.filter_radius > 64 {
            return Err(Error::param("filter-radius", format!("{} is out of range (0..=64 pixels)", self.filter_radius)));
        }
        Ok(())
    }

    pub(super) fn attributes(&self) -> Vec<(String, String)> {
        vec![attribute("glossy", self.glossy), attribute("filter_radius", self.filter_radius)]
    }
}

pub fn render(scene: &PreparedScene, s: &RenderSettings, m: &RsSettings, progress: &dyn Progress, stats: &mut Stats) -> Result<Film> {
    let (eye, photons) = compose::eye_and_light(scene, s, progress, stats)?;
    progress.begin("splatting", 1);
    let t = Instant::now();
    let classes: Vec<&[crate::photon::PhotonRay]> = photons.rays.iter().map(|v| v.as_slice()).collect();
    let mut img = splat::splat_with_map(&eye, &classes, m.glossy, &|| progress.cancelled()).ok_or(Error::Cancelled)?;
    stats.phase("splat", t.elapsed().as_secs_f64());
    if m.filter_radius > 0 {
        let t = Instant::now();
        let (rd, rg) = crate::radiance_filter::filter(&eye, &mut img, &crate::radiance_filter::FilterParams::with_radius(m.filter_radius));
        stats.phase("filter", t.elapsed().as_secs_f64());
        stats.count("filter_mean_radius_diffuse_milli", (rd * 1000.0) as u64);
        stats.count("filter_mean_radius_glossy_milli", (rg * 1000.0) as u64);
        stats.enable("image-space radiance filter (segments, summed-area tables)", (img.radiance.len() * 4 * 4) as u64);
    }
    glossy_resolve(&eye, &mut img, s.seed, stats);
    progress.advance(1);
    progress.finish();
    stats.count("splat_pairs", img.pairs);
    stats.count("splat_tiles", img.tiles as u64);
    stats.count("mean_bandwidth_um", (img.mean_bandwidth() * 1e6) as u64);
    stats.enable("splat kd-tree (per tile, largest)", img.tree_bytes);
    stats.enable("splat image (radiance, kernel weights, harmonic distance)", img.bytes());
    stats.enable("splat photon-ray footprint boxes", img.ray_box_bytes);
    compose::film(&eye, &img.radiance)
}

/// The final integration of the radiance map (§8.1) into the splat image, with its statistics:
/// which representation was used and what it cost.
pub(crate) fn glossy_resolve(eye: &crate::eye::EyePass, img: &mut splat::SplatImage, seed: u64, stats: &mut Stats) {
    let glossy_bytes = eye.glossy.bytes();
    let Some(map) = img.map.take() else {
        if !eye.glossy.is_empty() {
            let what = match img.auto_exact {
                Some(why) => format!("glossy: exact BSDF per splatted photon (auto: {why})"),
                None => "glossy: exact BSDF per splatted photon".to_string(),
            };
            stats.enable(&what, glossy_bytes);
        }
        return;
    };
    let t = Instant::now();
    let (table_bytes, tables) = crate::radiance_map::resolve(eye, &map, seed, &mut img.radiance);
    stats.phase("glossy", t.elapsed().as_secs_f64());
    let pixels = map.slots() - map.extra_slots();
    stats.count("glossy_pixels", pixels as u64);
    // slots beyond a pixel's first: glossy samples of one pixel on differently oriented surfaces
    stats.count("glossy_extra_slots", map.extra_slots() as u64);
    let what = match map.mode {
        crate::radiance_map::GlossyMode::Auto => {
            let t = map.tables.as_ref().expect("auto builds its tables");
            let fit = t.tables.iter().filter(|t| t.residual <= crate::radiance_map::SH_RESIDUAL_MAX).count();
            format!(
                "glossy: auto, SH radiance map for the {fit} of {} lobes within bands 0–3 (16 × RGB per slot, {} slots on {pixels} pixels){}",
                t.tables.len(),
                map.slots(),
                if map.exact_samples > 0 { format!(", exact BSDF per photon for {} glossy eye samples", map.exact_samples) } else { String::new() }
            )
        }
        crate::radiance_map::GlossyMode::Sh => format!("glossy: SH radiance map (16 × RGB per slot, {} slots on {pixels} glossy pixels)", map.slots()),
        _ => format!("glossy: histogram radiance map (20 strata × RGB per slot, {} slots on {pixels} glossy pixels)", map.slots()),
    };
    stats.enable(&what, map.bytes());
    if map.exact_samples > 0 {
        stats.count("glossy_exact_samples", map.exact_samples as u64);
    }
    if tables > 0 {
        stats.count("sh_bsdf_tables", tables as u64);
        stats.enable(&format!("glossy: SH BSDF tables ({tables})"), table_bytes);
    }
}
