//! Rendering methods. Each method is a composition of shared stages over a `PreparedScene` and
//! returns a `Film` (beauty + AOVs) and `Stats` (phase times, counts, memory).
//!
//! - `pt`: the unbiased reference path tracer (next-event estimation + MIS, Russian roulette).
//! - `rs`: photon ray splatting.
//! - `pm`: classic photon maps visualised directly (the baseline for `rs`).
//! - `pm-fg`, `rpm-fg`, `rs-fg`: final gathering (`fg`, over the shared stage `crate::gather`).
//! - `he-fg`: final gathering with strong secondary lights (`secondary`).

mod aov;
pub mod auto;
mod compose;
pub mod fg;
pub mod he_fg;
mod passes;
pub mod pm;
pub mod pt;
pub mod rs;
pub mod rs_rc;
mod settings;
mod stats;

pub use settings::{Method, RenderSettings};
pub use stats::{current_rss, peak_rss, reset_peak_rss, Progress, SilentProgress, Stats};

use crate::error::{Error, Result};
use crate::image::Film;
use crate::prepare::PreparedScene;
use crate::scene::SceneDesc;
use std::time::Instant;

/// The result of a render.
pub struct RenderOutput {
    pub film: Film,
    pub stats: Stats,
}

/// Image size of a render of `scene` with `settings`: `--resolution`, else the scene's, else
/// 512×512; an error outside 1..=65536 per side.
pub fn image_size(scene: &SceneDesc, settings: &RenderSettings) -> Result<[u32; 2]> {
    let [w, h] = settings.resolution.or(scene.resolution).unwrap_or([512, 512]);
    if w == 0 || h == 0 || w > 65536 || h > 65536 {
        let whose = if settings.resolution.is_some() { String::new() } else { format!(" (the scene's, from {}; give --resolution)", scene.source) };
        return Err(Error::param("resolution", format!("{w}x{h} is out of range (1..=65536 per side){whose}")));
    }
    Ok([w, h])
}

/// A floor under the memory a render takes, in bytes: the film (17 floats per pixel) and what it
/// is assembled from (13 floats per pixel); the path tracer's per-pixel sums (56 B); for the photon
/// methods, the eye pass's per-pixel images (52 B per pixel) and the indirect light (12 B), one
/// 36-byte eye sample per density-estimate sample and the stored photon rays (48 B each). Glossy
/// samples' BSDFs, kd-trees, radiance maps and caches come on top.
pub fn memory_floor(settings: &RenderSettings, w: u32, h: u32) -> u64 {
    let pixels = w as u64 * h as u64;
    let film = pixels * (17 + 13) * 4;
    if !settings.method.uses_photons() {
        return film + pixels * 56;
    }
    film + pixels * (52 + 12) + pixels * settings.spp as u64 * std::mem::size_of::<crate::eye::EyeSample>() as u64 + settings.photons as u64 * std::mem::size_of::<crate::photon::PhotonRay>() as u64
}

/// Refuse a render whose [`memory_floor`] is beyond the memory available ([`crate::memory::available`]:
/// the machine's, and what the process's limits and control group leave): it would abort on a
/// failed allocation, or be killed, part way through.
fn check_memory(settings: &RenderSettings, w: u32, h: u32) -> Result<()> {
    let need = memory_floor(settings, w, h);
    match crate::memory::available() {
        Some(left) if need > left.bytes => Err(Error::param(
            "resolution",
            format!(
                "{w}x{h} at --spp {} with --method {} needs at least {} of memory, more than the {} {}; lower --resolution or --spp",
                settings.spp,
                settings.method,
                stats::human_bytes(need),
                stats::human_bytes(left.bytes),
                left.what
            ),
        )),
        _ => Ok(()),
    }
}

/// Render `scene` with `settings`. Progress is reported to `progress`, which can also cancel.
pub fn render(mut scene: SceneDesc, settings: &RenderSettings, progress: &dyn Progress) -> Result<RenderOutput> {
    settings.validate()?;
    // Scenes built in code reach here without the loader's checks (idempotent for loaded scenes).
    scene.validate()?;
    let [w, h] = image_size(&scene, settings)?;
    check_memory(settings, w, h)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(settings.threads)
        .build()
        .map_err(|e| Error::param("threads", e.to_string()))?;
    pool.install(|| {
        let t0 = Instant::now();
        let mut stats = Stats::default();
        let loaded_warnings = scene.warnings.len();
        let prepared = PreparedScene::new(scene, w, h, settings.threads)?;
        stats.phase("prepare", t0.elapsed().as_secs_f64());
        stats.prepare_warnings = prepared.warnings.iter().skip(loaded_warnings).map(|w| format!("{}: {}", w.prim, w.message)).collect();
        stats.note_requirements(&prepared.requirements);
        let one = |p: &PreparedScene, s: &RenderSettings, pr: &dyn Progress, st: &mut Stats| -> Result<Film> {
            match s.method {
                Method::Pt => pt::render(p, s, pr, st),
                Method::Rs => rs::render(p, s, pr, st),
                Method::Pm => pm::render(p, s, pr, st),
                // with Ward's irradiance cache, photon mapping's final gather runs per point (the
                // cache needs an irradiance function), through he-fg's gather of one global map
                Method::PmFg if s.irradiance_cache => he_fg::render(p, &he_fg::pm_fg_cached(s), pr, st),
                Method::PmFg | Method::RpmFg | Method::RsFg => fg::render(p, s, pr, st),
                Method::HeFg => he_fg::render(p, s, pr, st),
                Method::RsRc => rs_rc::render(p, s, pr, st),
            }
        };
        let mut film = match settings.time_budget {
            // the path tracer spends a budget itself (progressive samples); photon methods in passes
            Some(budget) if settings.method.uses_photons() => {
                passes::render(&prepared, settings, budget, t0, progress, &mut stats, &one)?
            }
            _ => one(&prepared, settings, progress, &mut stats)?,
        };
        film.pixel_aspect = prepared.camera.pixel_aspect;
        stats.total_seconds = t0.elapsed().as_secs_f64();
        stats.warnings = prepared.warnings.len();
        stats.peak_rss_bytes = stats::peak_rss();
        Ok(RenderOutput { film, stats })
    })
}
