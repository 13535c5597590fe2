//! Rendering methods. Each method is a composition of shared stages over a `PreparedScene` and
//! returns a `Film` (beauty + AOVs) and `Stats` (phase times, counts, memory). Each method's file
//! holds its settings type ([`MethodSettings`] gathers them; [`RenderSettings`] adds what every
//! method shares).
//!
//! - `pt`: the unbiased reference path tracer (next-event estimation + MIS, Russian roulette).
//! - `rs`: photon ray splatting.
//! - `pm`: classic photon maps visualised directly (the baseline for `rs`).
//! - `pm-fg`, `rpm-fg`, `rs-fg`: final gathering (`fg`, over the shared stage `crate::gather`).
//! - `he-fg`: final gathering with strong secondary lights (`secondary`).
//! - `rs-rc`: photon ray splatting with radiance caching (`crate::radiance_cache`).
//! - `compose`: the photon methods' shared eye and light passes ([`PhotonPass`]) and film.
//! - `passes`: photon methods in independent passes: under a time budget, or progressive.

mod allocation;
mod aov;
mod blend;
pub mod auto;
mod compose;
pub mod fg;
pub mod he_fg;
mod passes;
mod regression;
pub mod pm;
pub mod pt;
pub mod rs;
pub mod rs_rc;
mod request;
mod settings;
mod stats;

pub use allocation::Rival;
pub use auto::{AutoReason, Quality};
pub use compose::PhotonPass;
pub use request::{parse_method, RenderRequest, Resolved};
pub use fg::{PmFgSettings, RpmFgSettings, RsFgSettings};
pub use he_fg::HeFgSettings;
pub use pm::PmSettings;
pub use rs::RsSettings;
pub use rs_rc::RsRcSettings;
pub use settings::{check_crop, check_size, parse_size, Method, MethodSettings, Passes, RenderSettings};
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
    let size = settings.resolution.or(scene.resolution).unwrap_or([512, 512]);
    check_size(size).map_err(|e| match (e, settings.resolution) {
        // a stage's own resolution is named as the stage's, with the way around it
        (Error::Param { name, message }, None) => Error::Param { name, message: format!("{message} (the scene's, from {}; give --resolution)", scene.source) },
        (e, _) => e,
    })
}

/// A floor under the memory a render takes, in bytes: the film (17 floats per pixel) and what it
/// is assembled from (13 floats per pixel); the path tracer's per-pixel sums (56 B); for the photon
/// methods, the eye pass's per-pixel images (52 B per pixel) and the indirect light (12 B), one
/// 36-byte eye sample per density-estimate sample and the stored photon rays (48 B each). Glossy
/// samples' BSDFs, kd-trees, radiance maps and caches come on top.
pub fn memory_floor(settings: &RenderSettings, w: u32, h: u32) -> u64 {
    let pixels = w as u64 * h as u64;
    let film = pixels * (17 + 13) * 4;
    let Some(pass) = settings.method.photon_pass() else {
        return film + pixels * 56;
    };
    film + pixels * (52 + 12) + pixels * settings.spp as u64 * std::mem::size_of::<crate::eye::EyeSample>() as u64 + pass.photons as u64 * std::mem::size_of::<crate::photon::PhotonRay>() as u64
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
                settings.method.method(),
                stats::human_bytes(need),
                stats::human_bytes(left.bytes),
                left.what
            ),
        )),
        _ => Ok(()),
    }
}

/// Render `scene` with `settings`. Progress is reported to `progress`, which can also cancel.
///
/// A time budget (`settings.time_budget`) counts from the end of the scene's preparation, for
/// every method: the preparation (Embree build, textures) is the same whatever renders after it.
pub fn render(scene: SceneDesc, settings: &RenderSettings, progress: &dyn Progress) -> Result<RenderOutput> {
    run(scene, settings.clone(), None, progress).map(|(out, _)| out)
}

/// What the front end sets after `auto` chose (a crop window, a range of passes), given the full
/// image size.
pub type Adjust<'a> = dyn Fn(&mut RenderSettings, [u32; 2]) -> Result<()> + Sync + 'a;

/// Render `scene` as `request` asks: the method it names, or `auto`'s choice made on the scene
/// prepared for the render — one preparation for the survey, the pilot and the render, the time
/// budget counted from its end (the survey's and the pilot's time count against it), and the
/// pilot's path-traced samples kept in the image whichever method is chosen. `adjust` sets what
/// the front end decides once the settings are known. Returns the render and the settings
/// (with `auto`'s reason).
pub fn render_request(scene: SceneDesc, request: &RenderRequest, adjust: &Adjust<'_>, progress: &dyn Progress) -> Result<(RenderOutput, Resolved)> {
    if request.method.is_some() {
        let mut settings = request.settings()?;
        let full = image_size(&scene, &settings)?;
        adjust(&mut settings, full)?;
        let (out, _) = run(scene, settings.clone(), None, progress)?;
        return Ok((out, Resolved { settings, auto: None }));
    }
    request.check()?;
    let base = request.settings_with(Method::Pt, &request::Budget::default())?;
    let (out, resolved) = run(scene, base, Some((request, adjust)), progress)?;
    Ok((out, resolved.expect("auto chose")))
}

/// Prepare `scene` and render it with `settings`, or, with a request (`auto`), with what `auto`
/// chooses on the prepared scene (`settings`: the request's shared settings, for the preparation).
fn run(scene: SceneDesc, mut settings: RenderSettings, auto: Option<(&RenderRequest, &Adjust<'_>)>, progress: &dyn Progress) -> Result<(RenderOutput, Option<Resolved>)> {
    settings.validate()?;
    // Scenes built in code reach here without the loader's checks (idempotent for loaded scenes).
    let mut scene = scene;
    scene.validate()?;
    let [w, h] = image_size(&scene, &settings)?;
    let facts = auto.is_some().then(|| auto::SceneFacts::of(&scene));
    // the camera's exposure multiplies the image (its radiance layers)
    let exposure = scene.camera.exposure_scale;
    if auto.is_none() {
        if let Some(c) = settings.crop {
            check_crop(c, [w, h])?;
        }
        let [cw, ch] = settings.crop.map_or([w, h], |[x0, y0, x1, y1]| [x1 - x0, y1 - y0]);
        check_memory(&settings, cw, ch)?;
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(settings.threads)
        .build()
        .map_err(|e| Error::param("threads", e.to_string()))?;
    pool.install(|| {
        let t0 = Instant::now();
        let mut stats = Stats::default();
        let loaded_warnings = scene.warnings.len();
        let mut prepared = PreparedScene::new(scene, w, h, settings.threads)?;
        prepared.texture_filter = settings.texture_filter;
        stats.phase("prepare", t0.elapsed().as_secs_f64());
        stats.prepare_warnings = prepared.warnings.iter().skip(loaded_warnings).map(|w| format!("{}: {}", w.prim, w.message)).collect();
        stats.note_requirements(&prepared.requirements);
        let mut start = Instant::now();
        let mut pilot = None;
        let mut resolved = None;
        if let (Some((request, adjust)), Some(facts)) = (auto, facts.as_ref()) {
            let (mut chosen, reason, samples) = auto::choose_prepared(&prepared, facts, [w, h], request, start)?;
            stats.phase("survey", reason.survey_seconds());
            adjust(&mut chosen, [w, h])?;
            chosen.validate()?;
            if let Some(c) = chosen.crop {
                check_crop(c, [w, h])?;
            }
            let [cw, ch] = chosen.crop.map_or([w, h], |[x0, y0, x1, y1]| [x1 - x0, y1 - y0]);
            check_memory(&chosen, cw, ch)?;
            // the pilot's samples are of the whole image, and a budget's: kept only in a timed
            // render of the whole image
            pilot = samples.filter(|_| chosen.crop.is_none() && chosen.passes.is_none() && chosen.time_budget.is_some());
            prepared.texture_filter = chosen.texture_filter;
            // the budget left after the survey counts from here
            start = Instant::now();
            settings = chosen.clone();
            resolved = Some(Resolved { settings: chosen, auto: Some(reason) });
        }
        if let Some(c) = settings.crop {
            prepared.camera.crop(c);
        }
        let one = |p: &PreparedScene, s: &RenderSettings, pr: &dyn Progress, st: &mut Stats| -> Result<Film> {
            match &s.method {
                MethodSettings::Pt => pt::render(p, s, pr, st),
                MethodSettings::Rs(m) => rs::render(p, s, m, pr, st),
                MethodSettings::Pm(m) => pm::render(p, s, m, pr, st),
                // with Ward's irradiance cache, photon mapping's final gather runs per point (the
                // cache needs an irradiance function): he-fg's per-point gather of one global map
                MethodSettings::PmFg(m) if m.irradiance_cache => {
                    let gather = he_fg::PointGather { knn: m.knn, stratified_rays: m.fg.rays, explicit: None, cache_error: Some(m.cache_error) };
                    he_fg::gather_per_point(p, s, &gather, pr, st)
                }
                MethodSettings::PmFg(m) => fg::render(p, s, fg::FinalGather::Pm(m), pr, st),
                MethodSettings::RpmFg(m) => fg::render(p, s, fg::FinalGather::Rpm(m), pr, st),
                MethodSettings::RsFg(m) => fg::render(p, s, fg::FinalGather::Rs(m), pr, st),
                MethodSettings::HeFg(m) => he_fg::render(p, s, m, pr, st),
                MethodSettings::RsRc(m) => rs_rc::render(p, s, m, pr, st),
            }
        };
        // the path tracer spends a budget and renders pass ranges itself (sample ranges); photon
        // methods in passes
        let photons = settings.method.photon_pass().is_some();
        let mut film = match (settings.time_budget, settings.passes, pilot) {
            (Some(budget), _, pilot) if photons => {
                // the passes blend the pilot's samples as they are: its second sample's film goes
                let pilot = pilot.map(|p| auto::PtSamples { second: None, ..p });
                passes::render(&prepared, &settings, budget, start, progress, &mut stats, &one, pilot)?
            }
            (None, Some(p), _) if photons => passes::progressive(&prepared, &settings, p, progress, &mut stats, &one)?,
            // the path tracer continues after the pilot's samples
            (Some(budget), _, Some(mut samples)) => {
                let first = samples.spp;
                let restored = samples.restore_sequence(&prepared, &settings, budget - start.elapsed().as_secs_f64(), &mut stats)?;
                samples.continue_for(&prepared, &settings, budget - start.elapsed().as_secs_f64(), &mut stats)?;
                stats.count("spp", samples.spp as u64);
                let how = if restored { ", its second sample traced again from the path tracer's own sequence" } else { "" };
                stats.note(format!("the path tracer's {} spp include the pilot's first {first}{how}", samples.spp));
                samples.film
            }
            _ => one(&prepared, &settings, progress, &mut stats)?,
        };
        film.layers.retain(|l| ![compose::DIRECT_VARIANCE_LAYER, pt::DIRECT_MOMENTS_LAYER, pt::INDIRECT_MOMENTS_LAYER].contains(&l.name.as_str()));
        film.pixel_aspect = prepared.camera.pixel_aspect;
        film.scale_radiance(exposure);
        denoise(&mut film, &settings, &mut stats)?;
        stats.total_seconds = t0.elapsed().as_secs_f64();
        stats.warnings = prepared.warnings.len();
        stats.peak_rss_bytes = stats::peak_rss();
        Ok((RenderOutput { film, stats }, resolved))
    })
}

/// Denoise the film as `settings.denoise` asks (`crate::denoise`): the phase `denoise` and a note
/// saying how; with `Mode::Auto`, a note instead when the denoiser is unavailable.
fn denoise(film: &mut Film, settings: &RenderSettings, stats: &mut Stats) -> Result<()> {
    use crate::denoise::{Mode, Status};
    match (settings.denoise.mode, crate::denoise::status()) {
        (Mode::Off, _) => Ok(()),
        (Mode::Auto, Status::Unavailable(why)) => {
            stats.note(format!("not denoised (--denoise auto): the denoiser is unavailable: {why}"));
            Ok(())
        }
        _ => {
            let report = crate::denoise::denoise_film(film, &settings.denoise, settings.threads)?;
            stats.phase("denoise", report.seconds);
            stats.note(report.line());
            Ok(())
        }
    }
}
