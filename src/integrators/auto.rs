//! `--method auto`: pick the method and its budget from what the scene contains and from the trade
//! measured by `raysplat study` and `raysplat-bench target` (docs/auto.md has the decision
//! table).
//!
//! - Specular surfaces (mirrors, glass): caustics (light → specular → diffuse → eye) are found by
//!   the path tracer only when a BSDF-sampled path hits the light, so its error falls slowly; the
//!   photon map resolves them, faster than `rs` at equal error: **`pm`**; under `--time`,
//!   **`rs-rc`**'s passes ([`TIMED_CAUSTICS`]).
//! - Strong secondary light (a spot-lit patch lighting a room): the path tracer finds the small
//!   bright patch only by BSDF sampling. A survey (the `he-fg` light pass of `raysplat info`,
//!   100k photons) measures the share of photons that land in high-energy voxels; at
//!   [`STRONG_SECONDARY_SHARE`] or more: **`rs`** ([`secondary_budget`]).
//! - Otherwise (diffuse and glossy scenes without either), for a draft or a preview of a scene
//!   where at least [`INDIRECT_SHARE`] of the light arriving at surfaces has bounced (a closed
//!   room; measured by the same survey): **`rs`** with one or two eye samples and 8–16 camera
//!   samples per pixel ([`diffuse_budget`]), ahead of the path tracer there in `make study` (a
//!   user's `--spp N` without `--photons` keeps the path tracer with N samples: a sample count is
//!   its budget).
//!   Open scenes lit mostly directly and final quality: **`pt`**, which resolves direct light
//!   best and keeps converging where a density estimate's bias stops the photon methods.
//! - Under `--time` (without caustics or strong secondary light, without `--spp`): the decision
//!   comes from predicted errors. The survey's probe measures the path tracer's variance per
//!   sample and its time per sample ([`Survey::rival`]); **`rs-rc`**'s passes start, as many
//!   photons per pass as let two passes fit in an eighth, a quarter or half of the time left, or in
//!   the time left ([`PASS_PHOTONS`], [`PILOT_SHARES`]), and their measured figures (direct and indirect
//!   variance, bias against the path tracer's samples or from a pass at a narrower kernel) decide
//!   the rest: more passes, direct-only camera samples, or the path tracer for the time left,
//!   blended with the passes or correcting them (`allocation`, `regression`). The first passes are the
//!   pilot and the image's first passes alike. When no pass fits twice: **`pt`**.
//!
//! The budget comes from `--quality` (a preset) or `--time` (the path tracer adds samples, `pm`
//! averages passes, see `passes`; the survey's time counts against it). The photon presets take
//! a few eye samples per pixel for the density estimate and more camera samples (`--aa-spp`) for
//! the direct light and the anti-aliasing. Explicit `--spp` / `--aa-spp` / `--photons` override
//! the preset.

mod pilot;
mod reason;

pub use pilot::{block_means, parts, BiasEstimate, PtFigures, PtSamples, BIAS_SIDE};
pub use reason::{AutoReason, KeepPt, Rule};

use super::request::{Budget, RenderRequest};
use super::{Method, RenderSettings};
use crate::error::{Error, Result};
use crate::prepare::{scene_flags, PreparedScene};
use crate::scene::SceneDesc;
use std::str::FromStr;
use std::time::Instant;

/// A scene without specular surfaces counts as lit by strong secondary light when at least this
/// share of the survey's photons lands in high-energy voxels (irradiance above 10 × the average,
/// docs/secondary-lights.md): `raysplat info` gives `scenes/secondary-light.usda` 25.7 % and every
/// other scene measured under 5 % (docs/auto.md).
pub const STRONG_SECONDARY_SHARE: f64 = 0.10;
/// A diffuse or glossy scene takes ray splatting for a draft or a preview when at least this share
/// of the power arriving at its surfaces has bounced at least once ([`Survey::indirect_share`]):
/// closed rooms (about 50 %), where splatting is ahead, lie far above it and open scenes lit
/// mostly directly (1–3 %), where the path tracer is, far below (docs/auto.md).
pub const INDIRECT_SHARE: f64 = 0.2;
/// ... unless at least this share of the surface area emits ([`Survey::emitter_area_share`]): the
/// path tracer's BSDF-sampled paths find large emitters themselves (docs/auto.md); the threshold
/// lies between the Cornell boxes' 1 % and the furnace's 100 %.
pub const EMITTER_AREA_SHARE: f64 = 0.1;
/// ... and the image has at least this many pixels: the light pass does not shrink with the
/// image, so at 64×64 the path tracer is ahead and from 128×128 splatting (docs/auto.md).
pub const MIN_PIXELS: u64 = 128 * 128;
/// Under `--time`, a scene that would take ray splatting for a draft or a preview takes its passes
/// while the path tracer would reach fewer than this many samples per pixel in the time left
/// ([`Survey::pt_seconds_per_spp`]), and the path tracer beyond: averaged photon passes approach
/// their bandwidth's bias while the path tracer's error keeps falling as 1/T.
pub const TIMED_PT_SPP: f64 = 128.0;
/// ... the draft preset's passes below this many samples, the preview's above.
pub const TIMED_DRAFT_SPP: f64 = 32.0;
/// Under `--time`, a scene without caustics or strong secondary light takes `rs-rc`'s passes with
/// the path tracer as their rival (`allocation`): its first passes measure their figures, and the
/// split of the time left of the lowest predicted error follows — more passes, direct-only camera
/// samples, or the path tracer for the rest, blended. The passes' photons are the most of these
/// whose pass, as the survey estimates it ([`pass_seconds`]), fits [`PILOT_PASSES`] times in
/// the least of [`PILOT_SHARES`] of the time left in which any does, or in the time left; when none
/// does, the path tracer.
pub const PASS_PHOTONS: [usize; 4] = [200_000, 100_000, 50_000, 25_000];
/// The passes that measure the figures take at most the first of these shares of the time left in
/// which passes of some size of [`PASS_PHOTONS`] fit (else the most that fit in the time left):
/// with time for many path-traced samples after them, the path tracer takes the rest in most plans
/// and corrects the passes' indirect light (`regression`), which then hardly depends on their
/// photons, so the time of the passes is better spent on path-traced samples. Crytek Sponza at
/// 200², 16 s: passes of 200k, 100k and 50k photons (about 3.2, 1.7 and 1.0 s each on a machine
/// of half the speed of the figures after, four seeds each) gave a mean relative MSE of 6.2e-4,
/// 5.5e-4 and 5.4e-4, the path tracer reaching 80, 106 and 113 spp; with an eighth, two passes of
/// 100k left the path tracer 247–290 spp and auto / pt 0.31–0.32, against 221–241 spp and 0.34
/// with a quarter (two passes of 200k). At 4 s no size fits in an eighth, and a quarter takes two
/// passes of 50k where the time left would take 200k (auto / pt 0.24 against 0.32–0.42). At 2 s
/// nothing fits in a quarter, and half the time takes two passes of 50k where the time left took
/// 100k, leaving more time for camera samples of the direct light (auto / pt 0.24 and 0.24
/// against 0.31 and 0.32; the boxes of the real-scene table at 1 and 2 s unchanged).
pub const PILOT_SHARES: [f64; 3] = [0.125, 0.25, 0.5];
/// Passes that measure the figures: two at the first bandwidth (the indirect variance; a third, at
/// half the squared radius, measures the bias when the plan takes more passes).
pub const PILOT_PASSES: f64 = 2.0;
/// A photon pass's time over its light pass's: the density estimation and the radiance cache
/// (Crytek Sponza at 200², `rs-rc` defaults: light pass 4.5 s, splatting 1.3 s, eye pass 0.75 s).
const PASS_OVER_LIGHT: f64 = 1.5;
/// A camera sample's time in an eye pass over a path's, as [`pass_seconds`] predicts it: Crytek
/// Sponza at 200² (load 4.5–7.5), passes of 1 eye / 2 camera and 4 eye / 4 camera samples per
/// pixel spent 0.095 s and 0.11 s per camera sample per pixel, the path tracer 0.20–0.25 s per
/// sample per pixel (0.4–0.55); the margin covers the eye samples.
const CAMERA_OVER_PATH: f64 = 0.6;
/// Eye and camera samples per pixel of the timed `rs-rc` passes (`raysplat-bench real` on Crytek
/// Sponza 200² at 16 s: passes of 1 eye spp and 100k photons reached an indirect layer of
/// relative MSE 0.0026, of 4 eye spp and 200k 0.0013).
pub const PASS_SPP: u32 = 4;
/// Eye and camera samples per pixel of a single timed pass (when two do not fit): one each, the
/// direct light's variance measured against the path tracer's first samples (as the pass's indirect
/// light's error is, `passes`); more camera samples for the direct light follow as direct-only
/// samples, which cost less (Crytek Sponza at 200², load 7.5: 0.13 s per sample per pixel against
/// 0.16 s in a pass of 1 eye and 4 camera samples). One `rs-rc` pass of 25k photons at 1 eye and 4
/// camera samples per pixel had relative MSE 0.0088 in 2.1 s against the path tracer's 0.038 at 8
/// spp in 2.6 s.
pub const SINGLE_PASS_SPP: u32 = 1;
pub const SINGLE_PASS_CAMERA_SPP: u32 = 1;
/// Photons traced by the survey (as `raysplat info`).
const SURVEY_PHOTONS: usize = 100_000;
/// ... under `--time`, where its time counts against the budget (Crytek Sponza at 200²: 100 000
/// took most of the survey's 3.5 s on a loaded machine, 25 000 0.44 s of a 4 s budget at a load of
/// 7.5); the shares it measures keep about a thousand photons at the 10 % threshold.
const TIMED_SURVEY_PHOTONS: usize = 10_000;

/// Quality presets of `--method auto`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quality {
    Draft,
    Preview,
    Final,
}

impl Quality {
    pub fn name(self) -> &'static str {
        match self {
            Quality::Draft => "draft",
            Quality::Preview => "preview",
            Quality::Final => "final",
        }
    }
}

impl FromStr for Quality {
    type Err = Error;
    fn from_str(s: &str) -> Result<Quality> {
        match s {
            "draft" => Ok(Quality::Draft),
            "preview" => Ok(Quality::Preview),
            "final" => Ok(Quality::Final),
            _ => Err(Error::param("quality", format!("unknown quality {s:?} (available: draft, preview, final)"))),
        }
    }
}

/// Path-tracer samples per pixel for each preset.
fn pt_spp(q: Quality) -> u32 {
    match q {
        Quality::Draft => 16,
        Quality::Preview => 64,
        Quality::Final => 1024,
    }
}

/// A preset's budget: samples per pixel (a photon method's eye samples, for its density estimate),
/// camera samples per pixel (`--aa-spp`: emission, direct light and anti-aliasing; 0 = `spp`) and
/// stored photons.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Preset {
    spp: u32,
    aa_spp: u32,
    photons: usize,
}

const fn budget(spp: u32, aa_spp: u32, photons: usize) -> Preset {
    Preset { spp, aa_spp, photons }
}

/// Photon map: few eye samples and more camera samples, since the error of a few eye samples is
/// mostly the direct light and the anti-aliasing, which camera samples resolve without a density
/// estimate (docs/auto.md, "Camera samples in the photon presets").
fn pm_budget(q: Quality) -> Preset {
    match q {
        Quality::Draft => budget(2, 16, 50_000),
        Quality::Preview => budget(4, 16, 200_000),
        Quality::Final => budget(8, 64, 1_000_000),
    }
}

/// Under `--time`, specular scenes take `rs-rc`'s passes of 200k photons at 4 eye and 4 camera
/// samples per pixel (its defaults), averaged and split with direct-only camera samples: in the
/// real-scene table (docs/accuracy.md, 200 px) they were below `pm`'s passes (4 eye, 16 camera
/// spp) on the three caustic boxes at 1, 4 and 16 s, by 1.2–3.2× on `cornell-glossy` and 1.1–6.8×
/// on `CornellBox-Sphere`.
const TIMED_CAUSTICS: Preset = budget(4, 4, 200_000);

/// Strong secondary light: ray splatting, with camera samples for the anti-aliasing of the lit
/// patch's edge, which they resolve without the cost of more splat targets (docs/auto.md).
fn secondary_budget(q: Quality, timed: bool) -> Preset {
    match (q, timed) {
        (_, true) => budget(2, 16, 200_000),
        (Quality::Draft, _) => budget(1, 16, 100_000),
        (Quality::Preview, _) => budget(2, 32, 400_000),
        (Quality::Final, _) => budget(4, 64, 1_000_000),
    }
}

/// Diffuse and glossy scenes without caustics or strong secondary light, draft and preview: ray
/// splatting, which reaches a lower error than the path tracer's preset of the same quality in less
/// time on the closed boxes (docs/auto.md, "Why").
fn diffuse_budget(q: Quality) -> Option<Preset> {
    match q {
        Quality::Draft => Some(budget(1, 8, 25_000)),
        Quality::Preview => Some(budget(2, 16, 100_000)),
        Quality::Final => None,
    }
}

/// Estimated seconds of a timed `rs-rc` pass of `photons` photons and `camera` camera samples per
/// pixel, from the survey: its light pass's time per photon (times [`PASS_OVER_LIGHT`]) and
/// [`CAMERA_OVER_PATH`] of the path tracer's time per sample per pixel for each camera sample.
pub fn pass_seconds(sv: &Survey, photons: usize, camera: u32) -> Option<f64> {
    let per_photon = sv.light_seconds / sv.photons.max(1) as f64;
    Some(PASS_OVER_LIGHT * per_photon * photons as f64 + camera as f64 * CAMERA_OVER_PATH * sv.pt_seconds_per_spp?)
}

/// Under `--time`, photon passes start only when the path tracer's pilot puts at least this share
/// of its relative variance in the indirect light ([`Survey::pt_relative_indirect_noise`]): the
/// passes lower the indirect light's noise, while their camera samples resolve the direct light
/// about as a path does, so below it they could lower the error by less than a tenth, which their
/// light pass and first passes do not repay. Measured at 200² (relative share): the Cornell boxes
/// 81–92 %, the car kit 5 %.
pub const MIN_INDIRECT_NOISE: f64 = 0.1;

/// Whether photon passes costing `overhead` seconds before they can decide anything (the passes that
/// measure their figures) could beat the path tracer in the `left` seconds at best: if they removed
/// all of its indirect light's error (share `indirect` of its relative variance) and their camera
/// samples resolved the direct light as efficiently as its paths, their error would be
/// `(1 − indirect) · (kept + left) / (kept + left − overhead)` of the path tracer's, `kept` the
/// seconds of the pilot's path-traced samples, which either plan keeps (the passes blend them in).
/// `indirect` `None` (no pilot pair): nothing speaks against them.
pub fn photons_could_win(indirect: Option<f64>, left: f64, overhead: f64, kept: f64) -> bool {
    match indirect {
        None => true,
        Some(f) => f >= MIN_INDIRECT_NOISE && overhead < left && (1.0 - f) * (kept + left) < kept + left - overhead,
    }
}

/// Photons and eye (and camera) samples per pixel of the timed passes: the most of
/// [`PASS_PHOTONS`] whose pass (at [`PASS_SPP`] eye and camera samples) fits [`PILOT_PASSES`]
/// times in the least of [`PILOT_SHARES`] of `left` seconds in which any does, or if none does in
/// `left`; else, when one pass of the fewest photons at [`SINGLE_PASS_SPP`] eye and
/// [`SINGLE_PASS_CAMERA_SPP`] camera samples fits once, that single pass (its indirect light
/// measured against the pilot's path-traced samples, `passes`; direct-only camera samples or the
/// path tracer take the time after it). With `bound`, only passes after which the photons could
/// still win ([`photons_could_win`]). `None`: not even that, or the scene has no light.
fn pass_photons(sv: &Survey, left: f64, bound: bool) -> Option<(usize, u32, u32)> {
    if sv.photons == 0 {
        return None;
    }
    let share = sv.pt_relative_indirect_noise().filter(|_| bound);
    let kept = sv.pt_seconds_per_spp.unwrap_or(0.0) * sv.pt_spp as f64;
    let fits = |p: usize, spp: u32, n: f64, room: f64| pass_seconds(sv, p, spp).is_some_and(|t| n * t <= room && photons_could_win(share, left, n * t, kept));
    let most = |room: f64| PASS_PHOTONS.iter().copied().find(|&p| fits(p, PASS_SPP, PILOT_PASSES, room));
    let fewest = PASS_PHOTONS[PASS_PHOTONS.len() - 1];
    match PILOT_SHARES.iter().find_map(|&share| most(share * left)).or_else(|| most(left)) {
        Some(p) => Some((p, PASS_SPP, PASS_SPP)),
        None => fits(fewest, SINGLE_PASS_CAMERA_SPP, 1.0, left).then_some((fewest, SINGLE_PASS_SPP, SINGLE_PASS_CAMERA_SPP)),
    }
}

/// What the survey of a scene's light found: photons landing in high-energy voxels, of all; and
/// the share of the power arriving at surfaces that arrives after at least one bounce.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Survey {
    pub high_photons: usize,
    pub photons: usize,
    /// `P_indirect / (P_direct + P_indirect)`: the summed flux of the survey's indirect photons
    /// over that of its direct and indirect photons (each class's flux is an unbiased estimate of
    /// the power it brings to the surfaces, guided emission or not). 0 without light.
    pub indirect_share: f64,
    /// Area of the emitting surfaces (area lights and emissive triangles) over that area plus the
    /// scene's triangles' (world space): large emitters are found by the path tracer's
    /// BSDF-sampled paths, which keeps its indirect light's variance low.
    pub emitter_area_share: f64,
    /// Wall-clock seconds of one path-traced sample per pixel at the render's resolution
    /// ([`super::pt::seconds_per_sample`]), timed only when asked (under `--time`: how many samples
    /// the path tracer would reach).
    pub pt_seconds_per_spp: Option<f64>,
    /// Variance of one path-traced sample's direct and indirect light (luminance, mean over the
    /// probed pixels), measured with [`Survey::pt_seconds_per_spp`].
    pub pt_variance: Option<[f64; 2]>,
    /// The same relative to each pixel's value ([`super::pt::pair_variances`]).
    pub pt_relative_variance: Option<[f64; 2]>,
    /// Path-traced samples per pixel of the pilot's, which the image keeps (0 without a pilot).
    pub pt_spp: u32,
    /// Seconds of the survey's light pass (its photons, [`Survey::photons`]).
    pub light_seconds: f64,
    /// Seconds of the survey in all: the scene's preparation, the light pass and the probe.
    pub seconds: f64,
}

impl Survey {
    /// Share of the photons in high-energy voxels (0 for a scene without light).
    pub fn share(&self) -> f64 {
        self.high_photons as f64 / self.photons.max(1) as f64
    }

    /// Share of the path tracer's relative variance in its indirect light: the most of its error
    /// (relative, per pixel) that photons could remove (`None` without a pilot's pair).
    pub fn pt_relative_indirect_noise(&self) -> Option<f64> {
        let [d, i] = self.pt_relative_variance?;
        (d + i > 0.0).then(|| i / (d + i))
    }

    /// The path tracer's figures from the probe (`None` without it).
    pub fn rival(&self) -> Option<super::Rival> {
        Some(super::Rival { seconds_per_spp: self.pt_seconds_per_spp?, variance: self.pt_variance?, corrects: false })
    }
}

/// What `auto` reads of a scene before it is prepared: whether it has specular surfaces, and the
/// area of its triangles (world space).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneFacts {
    pub specular: bool,
    pub geometry_area: f64,
}

impl SceneFacts {
    pub fn of(scene: &SceneDesc) -> SceneFacts {
        let mut geometry_area = 0.0f64;
        for inst in &scene.instances {
            let Some(mesh) = scene.meshes.get(inst.mesh as usize) else { continue };
            geometry_area += crate::prepare::surface_area(mesh, &inst.transform);
        }
        SceneFacts { specular: scene_flags(scene).contains(crate::bsdf::BsdfFlags::SPECULAR), geometry_area }
    }
}

/// Trace the survey's light pass for `scene` and, if `time_pt`, the path tracer's first samples at
/// the image size, on the request's threads with its seed.
pub fn survey(scene: &SceneDesc, request: &RenderRequest, time_pt: bool) -> Result<Survey> {
    let t = Instant::now();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(request.threads).build().map_err(|e| Error::param("threads", e.to_string()))?;
    let [w, h] = request.image_size(scene)?;
    pool.install(|| {
        let prepared = PreparedScene::new(scene.clone(), w, h, request.threads)?;
        Ok(survey_prepared(&prepared, &SceneFacts::of(scene), request, time_pt, t)?.0)
    })
}

/// The survey on a prepared scene, its time counted from `start`; with `time_pt`, the path
/// tracer's first samples of the image (the pilot's, kept by the render: [`PtSamples`]).
fn survey_prepared(prepared: &PreparedScene, facts: &SceneFacts, request: &RenderRequest, time_pt: bool, start: Instant) -> Result<(Survey, Option<PtSamples>)> {
    let emitter_area_share = emitter_area_share(facts, prepared);
    // under --time the path tracer's samples come first: when not even one pass's camera samples
    // fit in the time left, no photon pass can, and the light pass is not traced (its time would
    // be lost; the samples are not: they are the path tracer's first)
    let left = |t: f64| t - start.elapsed().as_secs_f64();
    let pilot = match time_pt {
        true => Some(pilot::trace(prepared, &request.settings_with(super::Method::Pt, &Default::default())?, request.time.map_or(f64::INFINITY, left), request.time.unwrap_or(f64::INFINITY))?),
        false => None,
    };
    // nor when the pilot says the photons could not win even with free passes (their light pass
    // would be lost too)
    let no_time = match (&pilot, request.time) {
        (Some((_, p)), Some(time)) => {
            let indirect = p.relative_variance.and_then(|[d, i]| (d + i > 0.0).then(|| i / (d + i)));
            p.variance.is_none() || left(time) < SINGLE_PASS_CAMERA_SPP as f64 * CAMERA_OVER_PATH * p.seconds_per_spp || !photons_could_win(indirect, left(time), 0.0, 0.0)
        }
        _ => false,
    };
    let light_start = Instant::now();
    let (high_photons, photons, indirect_share) = if prepared.lights.is_empty() || no_time {
        (0, 0, 0.0)
    } else {
        let light = super::he_fg::survey(prepared, if time_pt { TIMED_SURVEY_PHOTONS } else { SURVEY_PHOTONS }, request.seed);
        let [direct, indirect, _] = light.power;
        let share = if direct + indirect > 0.0 { indirect / (direct + indirect) } else { 0.0 };
        (light.split.high_photons, light.split.high_photons + light.split.low_photons, share)
    };
    let light_seconds = light_start.elapsed().as_secs_f64();
    let figures = pilot.as_ref().map(|p| p.1);
    let (pt_seconds_per_spp, pt_variance, pt_relative_variance) = (figures.map(|p| p.seconds_per_spp), figures.and_then(|p| p.variance), figures.and_then(|p| p.relative_variance));
    let pt_spp = pilot.as_ref().map_or(0, |p| p.0.spp);
    let sv = Survey { high_photons, photons, indirect_share, emitter_area_share, pt_seconds_per_spp, pt_variance, pt_relative_variance, pt_spp, light_seconds, seconds: start.elapsed().as_secs_f64() };
    Ok((sv, pilot.map(|p| p.0)))
}

/// [`Survey::emitter_area_share`]: emissive triangles are part of the scene's triangles; area
/// lights (rect, disk, sphere) are added to them.
fn emitter_area_share(facts: &SceneFacts, prepared: &PreparedScene) -> f64 {
    use crate::light::Emitter;
    let geometry = facts.geometry_area;
    // emissive triangles are among the scene's triangles; area lights are added to them
    let (mut emitting, mut lights) = (0.0f64, 0.0f64);
    for e in &prepared.lights.emitters {
        match e {
            Emitter::Triangle { area, .. } => emitting += *area as f64,
            Emitter::Rect { area, .. } | Emitter::Disk { area, .. } => lights += *area as f64,
            Emitter::Sphere { radius, .. } => lights += 4.0 * std::f64::consts::PI * (*radius as f64).powi(2),
            Emitter::Distant { .. } | Emitter::Dome { .. } => {}
        }
    }
    let total = geometry + lights;
    if total > 0.0 {
        ((emitting + lights) / total).min(1.0)
    } else {
        0.0
    }
}

/// The preset a time budget in which the path tracer would reach `pt_spp` samples per pixel stands
/// for, for a scene that takes ray splatting's presets: final (the path tracer) from
/// [`TIMED_PT_SPP`], draft below [`TIMED_DRAFT_SPP`], preview between.
fn timed_quality(pt_spp: f64) -> Quality {
    if pt_spp >= TIMED_PT_SPP {
        Quality::Final
    } else if pt_spp < TIMED_DRAFT_SPP {
        Quality::Draft
    } else {
        Quality::Preview
    }
}

/// Choose the method and budget for `scene`: its validated settings (the request's values for
/// what `auto` does not choose: seed, threads, resolution, bandwidth, …) and the reason.
pub fn choose(scene: &SceneDesc, request: &RenderRequest) -> Result<(RenderSettings, AutoReason)> {
    request.check()?;
    let facts = SceneFacts::of(scene);
    let survey = if facts.specular { None } else { Some(survey(scene, request, request.time.is_some())?) };
    decide(&facts, request.image_size(scene)?, survey, request)
}

/// [`choose`] on the scene prepared for the render (`facts` read from its description before it
/// was prepared): the survey and the pilot use it, its time counted from `start`, and under
/// `--time` the pilot's path-traced samples are returned for the render to keep ([`PtSamples`]).
pub fn choose_prepared(prepared: &PreparedScene, facts: &SceneFacts, size: [u32; 2], request: &RenderRequest, start: Instant) -> Result<(RenderSettings, AutoReason, Option<PtSamples>)> {
    request.check()?;
    let (survey, pilot) = match facts.specular {
        true => (None, None),
        false => {
            let (sv, pilot) = survey_prepared(prepared, facts, request, request.time.is_some(), start)?;
            (Some(sv), pilot)
        }
    };
    let (settings, reason) = decide(facts, size, survey, request)?;
    Ok((settings, reason, pilot))
}

/// The choice from what the survey found.
fn decide(facts: &SceneFacts, size: [u32; 2], survey: Option<Survey>, request: &RenderRequest) -> Result<(RenderSettings, AutoReason)> {
    let q = request.quality.unwrap_or(Quality::Preview);
    let specular = facts.specular;
    let timed = request.time.is_some();
    let strong = survey.as_ref().map_or(0.0, Survey::share);
    let indirect = survey.as_ref().map_or(0.0, |sv| sv.indirect_share);
    let emitters = survey.as_ref().map_or(0.0, |sv| sv.emitter_area_share);
    // the survey's time counts against a time budget
    let spent = survey.as_ref().map_or(0.0, |sv| sv.seconds);
    let time_left = request.time.map(|t| (t - spent).max(1e-3));
    // Under `--time`: the path tracer's samples per pixel in the time left, predicted.
    let pt_spp_in_time = match (time_left, survey.as_ref().and_then(|sv| sv.pt_seconds_per_spp)) {
        (Some(t), Some(per_spp)) if per_spp > 0.0 => t / per_spp,
        _ => f64::INFINITY,
    };
    // Under `--time`, the preset that budget stands for (final: the path tracer).
    let timed_q = request.time.map(|_| timed_quality(pt_spp_in_time));
    // Under `--time`, a scene without caustics or strong secondary light and without a sample count
    // takes photon passes that decide by their figures (`None`: not such a render; `Some(None)`:
    // no pass fits)
    let timed_passes = (timed && !specular && strong < STRONG_SECONDARY_SHARE && request.spp.is_none())
        .then(|| survey.as_ref().zip(time_left).and_then(|(sv, left)| pass_photons(sv, left, true)));
    // ... and whether none does because the photons could not win even at best (the time would hold one)
    let cannot_win = timed_passes == Some(None)
        && survey.as_ref().zip(time_left).is_some_and(|(sv, left)| {
            !photons_could_win(sv.pt_relative_indirect_noise(), left, 0.0, 0.0) || (sv.photons > 0 && pass_photons(sv, left, false).is_some())
        });
    // Why a diffuse or glossy scene keeps the path tracer (`None`: ray splatting's preset).
    let keep_pt = if !timed && q == Quality::Final {
        Some(KeepPt::Converges)
    } else if timed_q == Some(Quality::Final) {
        Some(KeepPt::TimeForSamples(pt_spp_in_time.min(1e12) as u64))
    } else if indirect < INDIRECT_SHARE {
        Some(KeepPt::DirectLight)
    } else if emitters >= EMITTER_AREA_SHARE {
        Some(KeepPt::LargeEmitters)
    } else if (size[0] as u64) * (size[1] as u64) < MIN_PIXELS {
        Some(KeepPt::SmallImage)
    } else if request.spp.is_some() && request.photons.is_none() {
        // a sample count without photons: the path tracer's budget
        Some(KeepPt::SamplesGiven)
    } else {
        None
    };
    // The ray-splatting preset: under `--time`, by the samples the path tracer would reach.
    let diffuse_quality = timed_q.unwrap_or(q);
    // The preset with the user's overrides; camera samples never fewer than eye samples.
    let resolve = |b: Preset| {
        let spp = request.spp.unwrap_or(b.spp);
        let aa_spp = if request.aa_spp != 0 { request.aa_spp } else { b.aa_spp.max(spp) };
        Preset { spp, aa_spp, photons: request.photons.unwrap_or(b.photons) }
    };
    let (method, rule, b) = if specular && timed {
        (Method::RsRc, Rule::Caustics, resolve(TIMED_CAUSTICS))
    } else if specular {
        (Method::Pm, Rule::Caustics, resolve(pm_budget(q)))
    } else if strong >= STRONG_SECONDARY_SHARE {
        (Method::Rs, Rule::StrongSecondaryLight, resolve(secondary_budget(q, timed)))
    } else if let Some(Some((photons, eye_spp, camera_spp))) = timed_passes {
        (Method::RsRc, Rule::PredictedError, resolve(budget(eye_spp, camera_spp, photons)))
    } else if let Some(None) = timed_passes {
        let keep = if cannot_win { KeepPt::DirectNoise } else { KeepPt::NoTimeForPasses };
        (Method::Pt, Rule::PathTracer(keep), Preset { spp: 1 << 24, aa_spp: request.aa_spp, photons: request.photons.unwrap_or(0) })
    } else if let (None, Some(b)) = (keep_pt, diffuse_budget(diffuse_quality)) {
        (Method::Rs, Rule::BouncedLight, resolve(b))
    } else {
        let spp = request.spp.unwrap_or(if timed { 1 << 24 } else { pt_spp(q) });
        let keep = keep_pt.unwrap_or(KeepPt::Converges);
        (Method::Pt, Rule::PathTracer(keep), Preset { spp, aa_spp: request.aa_spp, photons: request.photons.unwrap_or(0) })
    };
    let photon_budget = method.uses_photons();
    let chosen = Budget {
        spp: Some(b.spp),
        aa_spp: photon_budget.then_some(b.aa_spp),
        photons: photon_budget.then_some(b.photons),
        time: time_left,
    };
    let mut settings = request.settings_with(method, &chosen)?;
    if rule == Rule::PredictedError {
        settings.rival = survey.as_ref().and_then(Survey::rival);
    }
    let reason = AutoReason {
        method,
        rule,
        quality: q,
        time: request.time,
        survey,
        pt_spp_in_time: timed.then_some(pt_spp_in_time),
        time_left,
        size,
        spp: b.spp,
        aa_spp: b.aa_spp,
        photons: b.photons,
    };
    Ok((settings, reason))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Camera, Instance, Material, Mesh, PreviewSurface};
    use glam::{Mat4, Vec3};

    fn quad_scene(material: Material) -> SceneDesc {
        let mesh = Mesh {
            name: "/Quad".into(),
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            material_ids: vec![0],
            ..Default::default()
        };
        SceneDesc {
            meshes: vec![mesh],
            instances: vec![Instance { name: "/Quad".into(), mesh: 0, transform: Mat4::IDENTITY }],
            materials: vec![material],
            camera: Camera::default(),
            ..Default::default()
        }
    }

    fn preview(metallic: f32, roughness: f32) -> Material {
        let mut p = PreviewSurface::default();
        p.metallic.value = metallic;
        p.roughness.value = roughness;
        Material::PreviewSurface(p)
    }

    /// What `choose` gave, flattened for the assertions.
    struct Pick {
        method: Method,
        spp: u32,
        aa_spp: u32,
        photons: usize,
        time_budget: Option<f64>,
        why: AutoReason,
        reason: String,
    }

    fn pick(scene: &SceneDesc, request: &RenderRequest) -> Pick {
        let (s, why) = choose(scene, request).unwrap();
        let pass = s.method.photon_pass();
        Pick {
            method: s.method.method(),
            spp: s.spp,
            aa_spp: pass.map_or(0, |p| p.aa_spp),
            photons: pass.map_or(0, |p| p.photons),
            time_budget: s.time_budget,
            reason: why.to_string(),
            why,
        }
    }

    fn asked(quality: Option<Quality>, time: Option<f64>, spp: Option<u32>, photons: Option<usize>) -> RenderRequest {
        RenderRequest { quality, time, spp, photons, ..Default::default() }
    }

    #[test]
    fn closed_rooms_take_ray_splatting_open_scenes_the_path_tracer_specular_ones_the_photon_map() {
        let none = RenderRequest::default();
        // an open quad without light: nothing bounces
        let diffuse = pick(&quad_scene(preview(0.0, 1.0)), &none);
        assert_eq!((diffuse.method, diffuse.spp), (Method::Pt, 64), "{}", diffuse.reason);
        assert_eq!(diffuse.why.rule, Rule::PathTracer(KeepPt::DirectLight));
        let glossy = pick(&quad_scene(preview(1.0, 0.3)), &none);
        assert_eq!(glossy.method, Method::Pt);
        // a closed box: about half the light arriving at its walls has bounced
        let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.usda"));
        let cornell = crate::usd::load_scene(path).unwrap();
        let sv = survey(&cornell, &none, false).unwrap();
        // under --time the survey traces fewer photons and probes the path tracer
        let timed_sv = survey(&cornell, &asked(None, Some(10.0), None, None), true).unwrap();
        assert_eq!(timed_sv.photons, TIMED_SURVEY_PHOTONS);
        assert!((0.4..0.6).contains(&sv.indirect_share), "{sv:?}");
        assert!(sv.emitter_area_share > 0.0 && sv.emitter_area_share < 0.05, "{sv:?}");
        let room = pick(&cornell, &none);
        assert_eq!((room.method, room.spp, room.aa_spp, room.photons), (Method::Rs, 2, 16, 100_000), "{}", room.reason);
        assert_eq!(room.why.rule, Rule::BouncedLight);
        assert!(room.reason.contains("% of the light bounced"), "{}", room.reason);
        // the reason carries the survey it decided on (the same seed: the same photons)
        assert_eq!(room.why.survey.map(|s| (s.high_photons, s.photons, s.indirect_share)), Some((sv.high_photons, sv.photons, sv.indirect_share)));
        let draft = pick(&cornell, &asked(Some(Quality::Draft), None, None, None));
        assert_eq!((draft.method, draft.spp, draft.aa_spp, draft.photons), (Method::Rs, 1, 8, 25_000));
        // a small image does not repay the light pass
        let tiny = pick(&cornell, &RenderRequest { resolution: Some([64, 64]), ..Default::default() });
        assert_eq!((tiny.method, tiny.why.rule), (Method::Pt, Rule::PathTracer(KeepPt::SmallImage)), "{}", tiny.reason);
        assert!(tiny.reason.contains("64x64 pixels"), "{}", tiny.reason);
        // a closed box whose walls all emit (the white furnace): the path tracer's paths find the
        // emitters by themselves
        let furnace = crate::usd::load_scene(&path.with_file_name("furnace.usda")).unwrap();
        let f = pick(&furnace, &none);
        assert_eq!((f.method, f.why.rule), (Method::Pt, Rule::PathTracer(KeepPt::LargeEmitters)), "{}", f.reason);
        assert!(f.reason.contains("100 % of the surface area emits"), "{}", f.reason);
        // final quality and a time budget: the path tracer, which converges
        let fin = pick(&cornell, &asked(Some(Quality::Final), None, None, None));
        assert_eq!((fin.method, fin.spp), (Method::Pt, 1024));
        // a time budget: rs-rc's passes with the path tracer's probe figures as their rival (the
        // passes measure theirs and the split follows), when two passes fit; else the path tracer
        assert!(timed_sv.pt_seconds_per_spp.is_some_and(|t| t > 0.0 && t.is_finite()), "{timed_sv:?}");
        let (long_settings, long_why) = choose(&cornell, &asked(None, Some(1e5), None, None)).unwrap();
        assert_eq!((long_settings.method.method(), long_why.rule), (Method::RsRc, Rule::PredictedError), "{long_why}");
        assert_eq!(long_settings.method.photon_pass().map(|p| p.photons), Some(PASS_PHOTONS[0]));
        let rival = long_settings.rival.expect("the path tracer's figures");
        assert!(rival.seconds_per_spp > 0.0 && rival.variance[0] > 0.0 && rival.variance[1] > 0.0, "{rival:?}");
        assert!(long_why.to_string().contains("predicted MSE"), "{long_why}");
        // the probe measured both parts of the path tracer's noise: in the Cornell box most of it
        // is direct (the light's edges seen directly)
        let [vd, vi] = timed_sv.pt_variance.unwrap();
        assert!(vi > 0.0 && vd > vi, "{timed_sv:?}");
        // relative to each pixel's value (the light's pixels count little) most of the Cornell
        // box's noise is indirect: the photons' lead
        assert!(timed_sv.pt_relative_indirect_noise().is_some_and(|f| f > 0.5), "{timed_sv:?}");
        // a plane under a rect light: nothing bounces, the path tracer's noise is direct, and the
        // passes could not repay their light pass — it is not traced
        let plane = crate::usd::load_scene(&path.with_file_name("plane-rect.usda")).unwrap();
        let lit = pick(&plane, &asked(None, Some(1e5), None, None));
        assert_eq!((lit.method, lit.why.rule), (Method::Pt, Rule::PathTracer(KeepPt::DirectNoise)), "{}", lit.reason);
        assert_eq!(lit.why.survey.map(|s| s.photons), Some(0), "{}", lit.reason);
        assert!(lit.reason.contains("% of its relative variance"), "{}", lit.reason);
        let short = pick(&cornell, &asked(None, Some(1e-3), None, None));
        assert_eq!((short.method, short.why.rule), (Method::Pt, Rule::PathTracer(KeepPt::NoTimeForPasses)), "{}", short.reason);
        assert!(short.reason.contains("do not fit"), "{}", short.reason);
        assert_eq!([timed_quality(10.0), timed_quality(64.0), timed_quality(1000.0)], [Quality::Draft, Quality::Preview, Quality::Final]);
        // a sample count is the path tracer's budget
        let given = pick(&cornell, &asked(None, None, Some(64), None));
        assert_eq!((given.method, given.spp, given.why.rule), (Method::Pt, 64, Rule::PathTracer(KeepPt::SamplesGiven)), "{}", given.reason);
        assert!(given.reason.contains("--spp fixes"), "{}", given.reason);
        let both = pick(&cornell, &asked(None, None, Some(2), Some(5000)));
        assert_eq!((both.method, both.spp, both.photons), (Method::Rs, 2, 5000));
        let mirror = pick(&quad_scene(preview(1.0, 0.0)), &none);
        assert_eq!((mirror.method, mirror.photons, mirror.why.rule), (Method::Pm, 200_000, Rule::Caustics));
        assert!(mirror.why.survey.is_none() && mirror.reason.contains("caustics"), "{}", mirror.reason);
        // photon methods resolve the direct light and the anti-aliasing with camera samples
        assert_eq!((mirror.spp, mirror.aa_spp), (4, 16));
        assert!(mirror.reason.contains("16 camera spp"), "{}", mirror.reason);
        // under --time the caustics take rs-rc's passes
        let timed_mirror = pick(&quad_scene(preview(1.0, 0.0)), &asked(None, Some(10.0), None, None));
        assert_eq!((timed_mirror.method, timed_mirror.spp, timed_mirror.aa_spp, timed_mirror.photons, timed_mirror.why.rule), (Method::RsRc, 4, 4, 200_000, Rule::Caustics), "{}", timed_mirror.reason);
    }

    /// The timed passes take the most photons whose pass fits twice in a quarter of the time left
    /// (the path tracer then has most of it), or when none does the most that fit twice in the
    /// time left (the passes are then most of the image), a single pass of the fewest when two do
    /// not fit, and none without light.
    #[test]
    fn timed_passes_take_the_photons_that_fit() {
        let sv = Survey {
            high_photons: 0,
            photons: 100_000,
            indirect_share: 0.5,
            emitter_area_share: 0.01,
            pt_seconds_per_spp: Some(0.01),
            pt_variance: Some([1.0, 1.0]),
            pt_relative_variance: Some([1.0, 1.0]),
            pt_spp: 0,
            light_seconds: 1.0,
            seconds: 1.0,
        };
        // a pass: 1.5 × 1 s per 100k photons, plus 4 camera samples of 0.6 × 0.01 s
        assert!((pass_seconds(&sv, 200_000, PASS_SPP).unwrap() - 3.024).abs() < 1e-9);
        // two passes of 200k take 6.048 s, of 100k 3.048 s, of 50k 1.548 s, of 25k 0.798 s: the
        // most that fit in an eighth of the time left
        assert_eq!(pass_photons(&sv, 48.4, false), Some((200_000, PASS_SPP, PASS_SPP)));
        assert_eq!(pass_photons(&sv, 48.0, false), Some((100_000, PASS_SPP, PASS_SPP)));
        assert_eq!(pass_photons(&sv, 24.2, false), Some((50_000, PASS_SPP, PASS_SPP)));
        // under 8 × 0.798 s nothing fits in an eighth: the most that fit in a quarter
        assert_eq!(pass_photons(&sv, 6.3, false), Some((50_000, PASS_SPP, PASS_SPP)));
        assert_eq!(pass_photons(&sv, 6.1, false), Some((25_000, PASS_SPP, PASS_SPP)));
        // under 4 × 0.798 s nothing fits in a quarter: the most that fit in half of it
        assert_eq!(pass_photons(&sv, 3.1, false), Some((50_000, PASS_SPP, PASS_SPP)));
        assert_eq!(pass_photons(&sv, 3.0, false), Some((25_000, PASS_SPP, PASS_SPP)));
        // under 2 × 0.798 s nothing fits in half: the most that fit in the time left
        assert_eq!(pass_photons(&sv, 1.55, false), Some((50_000, PASS_SPP, PASS_SPP)));
        assert_eq!(pass_photons(&sv, 0.9, false), Some((25_000, PASS_SPP, PASS_SPP)));
        // two passes of 0.399 s do not fit, one of 0.375 s + a camera sample does: a single pass
        assert_eq!(pass_photons(&sv, 0.79, false), Some((25_000, SINGLE_PASS_SPP, SINGLE_PASS_CAMERA_SPP)));
        assert_eq!(pass_photons(&sv, 0.385, false), Some((25_000, SINGLE_PASS_SPP, SINGLE_PASS_CAMERA_SPP)));
        assert_eq!(pass_photons(&sv, 0.38, false), None);
        assert_eq!(pass_photons(&Survey { photons: 0, ..sv }, 100.0, true), None);
        // half the path tracer's relative variance indirect: the passes that measure must leave
        // more than half the time (two of 100k take 3.048 s of 3.1, two of 50k 1.548 s)
        assert_eq!(pass_photons(&sv, 3.1, true), Some((50_000, PASS_SPP, PASS_SPP)));
        // in 1.55 s neither two passes of 50k (1.548 s) nor of 25k (0.798 s) leave half the time:
        // a single pass; with the pilot's 300 samples (3 s) kept by both plans, 1.548 s is less
        // than half of 4.55 s
        assert_eq!(pass_photons(&sv, 1.55, true), Some((25_000, SINGLE_PASS_SPP, SINGLE_PASS_CAMERA_SPP)));
        assert_eq!(pass_photons(&Survey { pt_spp: 300, ..sv }, 1.55, true), Some((50_000, PASS_SPP, PASS_SPP)));
        // a twentieth indirect: no pass could win
        let direct = Survey { pt_relative_variance: Some([19.0, 1.0]), ..sv };
        assert_eq!(pass_photons(&direct, 100.0, true), None);
        assert_eq!(pass_photons(&direct, 100.0, false), Some((200_000, PASS_SPP, PASS_SPP)));
    }

    /// The photons' best case: all of the path tracer's indirect error removed, the direct light
    /// as efficient as its paths, after an overhead.
    #[test]
    fn photons_could_win_only_where_the_indirect_noise_repays_the_overhead() {
        // 60 % indirect: error 0.4 · 10 / (10 − o) of the path tracer's, below 1 while o < 6
        assert!(photons_could_win(Some(0.6), 10.0, 5.9, 0.0));
        assert!(!photons_could_win(Some(0.6), 10.0, 6.1, 0.0));
        // with 5 s of the pilot's samples kept by both plans: 0.4 · 15 / (15 − o), while o < 9
        assert!(photons_could_win(Some(0.6), 10.0, 8.9, 5.0));
        assert!(!photons_could_win(Some(0.6), 10.0, 9.1, 5.0));
        // below the least share nothing is worth the light pass, even free
        assert!(!photons_could_win(Some(MIN_INDIRECT_NOISE * 0.9), 10.0, 0.0, 0.0));
        assert!(photons_could_win(Some(MIN_INDIRECT_NOISE * 1.1), 10.0, 0.0, 0.0));
        // an overhead longer than the time, and no pilot pair
        assert!(!photons_could_win(Some(0.99), 1.0, 1.0, 5.0));
        assert!(photons_could_win(None, 1.0, 0.5, 0.0));
    }

    #[test]
    fn presets_time_and_overrides() {
        let scene = quad_scene(preview(0.0, 1.0));
        let draft = pick(&scene, &asked(Some(Quality::Draft), None, None, None));
        let fin = pick(&scene, &asked(Some(Quality::Final), None, None, None));
        assert!(draft.spp < fin.spp);
        // the survey's time (here an Embree build of two triangles) counts against the budget
        let timed = pick(&scene, &asked(None, Some(2.0), None, None));
        assert_eq!(timed.time_budget, Some((2.0 - timed.why.survey_seconds()).max(1e-3)), "{}", timed.reason);
        assert!(timed.why.survey_seconds() > 0.0);
        let given = pick(&scene, &asked(None, None, Some(7), None));
        assert_eq!(given.spp, 7);
        // a photon preset keeps at least as many camera samples as eye samples, and the user's
        // --aa-spp wins
        let mirror = quad_scene(preview(1.0, 0.0));
        let many = pick(&mirror, &asked(None, None, Some(32), None));
        assert_eq!((many.spp, many.aa_spp), (32, 32));
        let given_aa = pick(&mirror, &RenderRequest { aa_spp: 8, ..Default::default() });
        assert_eq!((given_aa.spp, given_aa.aa_spp), (4, 8));
        let fin_pm = pick(&mirror, &asked(Some(Quality::Final), None, None, None));
        assert_eq!((fin_pm.spp, fin_pm.aa_spp, fin_pm.photons), (8, 64, 1_000_000));
        assert!(choose(&scene, &asked(Some(Quality::Final), Some(1.0), None, None)).is_err());
        assert!("best".parse::<Quality>().is_err());
    }
}
