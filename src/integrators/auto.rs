//! `--method auto`: pick the method and its budget from what the scene contains and from the trade
//! measured by `raysplat study` and `raysplat bench --target-table` (docs/auto.md has the decision
//! table).
//!
//! - Specular surfaces (mirrors, glass): caustics (light → specular → diffuse → eye) are found by
//!   the path tracer only when a BSDF-sampled path hits the light: its error falls slowly. On
//!   CornellBox-Sphere at 128² the photon map reached a relative MSE of 0.013 in 1.2 s where the
//!   path tracer had 0.22 after 0.7 s and 0.051 after 2.8 s; `pm` was also faster than `rs` at
//!   equal error: **`pm`**.
//! - Strong secondary light (a spot-lit patch lighting a room): the path tracer finds the small
//!   bright patch only by BSDF sampling. A survey (the `he-fg` light pass of `raysplat info`,
//!   100k photons) measures the share of photons that land in high-energy voxels; at
//!   [`STRONG_SECONDARY_SHARE`] or more: **`rs`** ([`secondary_budget`]).
//! - Otherwise (diffuse and glossy scenes without either), for a draft or a preview of a scene
//!   where at least [`INDIRECT_SHARE`] of the light arriving at surfaces has bounced (a closed
//!   room; measured by the same survey): **`rs`** with one or two eye samples and 8–16 camera
//!   samples per pixel ([`diffuse_budget`]). `make study` measured it ahead of the path tracer
//!   at every error down to 0.002 on the Cornell box and the bumpy box (a user's `--spp N`
//!   without `--photons` keeps the path tracer with N samples: a sample count is its budget).
//!   Under `--time`, the same while the path tracer would reach fewer than [`TIMED_PT_SPP`]
//!   samples per pixel in the time (the survey times a few of its paths). Open scenes lit mostly
//!   directly, final quality, and longer `--time` budgets: **`pt`**, which resolves direct light
//!   best and keeps converging where a density estimate's bias stops the photon methods.
//!
//! The budget comes from `--quality` (a preset) or `--time` (the path tracer adds samples, `pm`
//! averages passes, see `passes`; the survey's time counts against it). The photon presets take
//! a few eye samples per pixel for the density estimate and more camera samples (`--aa-spp`) for
//! the direct light and the anti-aliasing. Explicit `--spp` / `--aa-spp` / `--photons` override
//! the preset.

use super::{Method, RenderSettings};
use crate::error::{Error, Result};
use crate::prepare::{scene_flags, PreparedScene};
use crate::scene::SceneDesc;
use std::str::FromStr;
use std::time::Instant;

/// A scene without specular surfaces counts as lit by strong secondary light when at least this
/// share of the survey's photons lands in high-energy voxels (irradiance above 10 × the average,
/// docs/secondary-lights.md). Measured by `raysplat info`: `scenes/secondary-light.usda` 25.7 %,
/// Crytek Sponza (sun and sky) 4.1 %, the Cornell boxes 0.03–0.06 %, the furnace and the car kit 0.
pub const STRONG_SECONDARY_SHARE: f64 = 0.10;
/// A diffuse or glossy scene takes ray splatting for a draft or a preview when at least this share
/// of the power arriving at its surfaces has bounced at least once ([`Survey::indirect_share`]).
/// Measured by `raysplat info`: the repository's closed boxes 49–55 % (cornell-box, bumpy-box,
/// concave-corners, furnace) and CornellBox-Original 50 %, where ray splatting was ahead of the
/// path tracer; Crytek Sponza and the shader ball 3 %, the car kit 1 %, open scenes lit mostly
/// directly, where the path tracer was ahead (car kit: 16 spp 0.00007 in 0.13 s against
/// splatting's 0.0041 in 0.90 s; docs/auto.md).
pub const INDIRECT_SHARE: f64 = 0.2;
/// ... unless at least this share of the surface area emits ([`Survey::emitter_area_share`]): the
/// white furnace (every wall emits, 50 % of the light bounced) gave the path tracer 0.0008 at
/// 64 spp in 0.10 s against ray splatting's 0.015 at the preview preset in 0.24 s. The
/// Cornell boxes' lights are about 1 % of their area.
pub const EMITTER_AREA_SHARE: f64 = 0.1;
/// ... and the image has at least this many pixels: the light pass does not shrink with the
/// image. concave-corners at its 64×64: the path tracer's 64 spp 0.0029 in 0.34 s, the preview
/// preset 0.0034 in 0.44 s (0.12 s of it the light pass); at 128×128 (bumpy-box) and 256×256
/// (cornell-box) splatting was ahead.
pub const MIN_PIXELS: u64 = 128 * 128;
/// Under `--time`, a scene that would take ray splatting for a draft or a preview takes its passes
/// while the path tracer would reach fewer than this many samples per pixel in the time left
/// ([`Survey::pt_seconds_per_spp`]), and the path tracer beyond: averaged photon passes approach
/// their bandwidth's bias while the path tracer's error keeps falling as 1/T.
pub const TIMED_PT_SPP: f64 = 128.0;
/// ... the draft preset's passes below this many samples, the preview's above.
pub const TIMED_DRAFT_SPP: f64 = 32.0;
/// Photons traced by the survey (as `raysplat info`).
const SURVEY_PHOTONS: usize = 100_000;

/// Quality presets of `--method auto`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quality {
    Draft,
    Preview,
    Final,
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

/// What the user fixed; everything else is chosen.
#[derive(Clone, Copy, Debug, Default)]
pub struct AutoRequest {
    pub quality: Option<Quality>,
    pub time: Option<f64>,
    pub spp: Option<u32>,
    pub photons: Option<usize>,
}

/// The choice and the one-line reason for it.
#[derive(Clone, Debug)]
pub struct AutoChoice {
    pub settings: RenderSettings,
    pub reason: String,
}

/// Path-tracer samples per pixel for each preset.
fn pt_spp(q: Quality) -> u32 {
    match q {
        Quality::Draft => 16,
        Quality::Preview => 64,
        Quality::Final => 1024,
    }
}

/// A chosen budget: samples per pixel (a photon method's eye samples, for its density estimate),
/// camera samples per pixel (`--aa-spp`: emission, direct light and anti-aliasing; 0 = `spp`) and
/// stored photons.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Budget {
    spp: u32,
    aa_spp: u32,
    photons: usize,
}

const fn budget(spp: u32, aa_spp: u32, photons: usize) -> Budget {
    Budget { spp, aa_spp, photons }
}

/// Photon map. `raysplat bench --target-table CornellBox-Sphere.usda` (mirror and glass spheres,
/// 96², errors against the converged image, mean of 2 seeds): 50k photons at 4 eye spp 0.0069 in
/// 0.63 s, at 4 eye spp and 16 camera spp 0.0041 in 0.66 s, at 2 and 16 0.0048 in 0.52 s; 200k at 4
/// eye spp 0.0055 in 1.63 s, at 4 and 16 0.0027 in 1.29 s, at 8 and 32 0.0021 in 2.1 s. The error of a few eye samples is mostly the direct light and the
/// anti-aliasing of the camera samples, which cost less than eye samples (no density estimate).
fn pm_budget(q: Quality, timed: bool) -> Budget {
    match (q, timed) {
        (_, true) => budget(4, 16, 200_000),
        (Quality::Draft, _) => budget(2, 16, 50_000),
        (Quality::Preview, _) => budget(4, 16, 200_000),
        (Quality::Final, _) => budget(8, 64, 1_000_000),
    }
}

/// Strong secondary light: ray splatting. `raysplat bench --target-table scenes/secondary-light.usda`
/// (96×72, errors against the converged image, mean of 2 seeds): 100k photons at 4 eye spp 0.0198
/// in 1.09 s, at 1 eye spp and 16 camera spp 0.0108 in 0.63 s; 400k at 4 eye spp 0.0159 in 3.9 s,
/// at 2 and 32 0.0040 in 2.9 s; the path tracer needs 121 s for 0.005. The error of 4 eye samples
/// per pixel is the anti-aliasing of the lit patch's edge in the direct light, which camera samples
/// resolve without the cost of more splat targets.
fn secondary_budget(q: Quality, timed: bool) -> Budget {
    match (q, timed) {
        (_, true) => budget(2, 16, 200_000),
        (Quality::Draft, _) => budget(1, 16, 100_000),
        (Quality::Preview, _) => budget(2, 32, 400_000),
        (Quality::Final, _) => budget(4, 64, 1_000_000),
    }
}

/// Diffuse and glossy scenes without caustics or strong secondary light, draft and preview: ray
/// splatting. `make study` (docs/accuracy.md, 2026-12-02, errors against the converged image):
/// - Cornell box, 256²: 25k photons, 1 eye spp, 8 camera spp 0.0045 in 0.74 s, where the path
///   tracer's draft (16 spp) had 0.0108 in 1.22 s; 100k photons at 2 / 16 0.0017 in 2.13 s against
///   the preview's 64 spp, 0.0024 in 4.47 s;
/// - bumpy box, 128²: 0.0069 in 0.25 s against 0.0123 in 0.35 s; 0.0023 in 0.72 s against 0.0026 in
///   1.33 s.
fn diffuse_budget(q: Quality) -> Option<Budget> {
    match q {
        Quality::Draft => Some(budget(1, 8, 25_000)),
        Quality::Preview => Some(budget(2, 16, 100_000)),
        Quality::Final => None,
    }
}

/// What the survey of a scene's light found: photons landing in high-energy voxels, of all; and
/// the share of the power arriving at surfaces that arrives after at least one bounce.
#[derive(Clone, Copy, Debug)]
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
    pub seconds: f64,
}

impl Survey {
    /// Share of the photons in high-energy voxels (0 for a scene without light).
    pub fn share(&self) -> f64 {
        self.high_photons as f64 / self.photons.max(1) as f64
    }
}

/// Trace the survey's light pass for `scene` and, if `time_pt`, time a path-traced sample at the
/// render's resolution, on `base.threads` threads with `base.seed`.
pub fn survey(scene: &SceneDesc, base: &RenderSettings, time_pt: bool) -> Result<Survey> {
    let t = Instant::now();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(base.threads).build().map_err(|e| Error::param("threads", e.to_string()))?;
    let [w, h] = super::image_size(scene, base)?;
    pool.install(|| {
        let prepared = PreparedScene::new(scene.clone(), w, h, base.threads)?;
        let emitter_area_share = emitter_area_share(scene, &prepared);
        let (high_photons, photons, indirect_share) = if prepared.lights.is_empty() {
            (0, 0, 0.0)
        } else {
            let s = RenderSettings { photons: SURVEY_PHOTONS, seed: base.seed, ..Default::default() };
            let set = super::he_fg::survey_photons(&prepared, &s);
            let sp = super::he_fg::split_photons(&prepared, &set, &s);
            let power = |c: usize| set.rays[c].iter().map(|r| r.flux().element_sum() as f64).sum::<f64>();
            let (direct, indirect) = (power(0), power(1));
            let share = if direct + indirect > 0.0 { indirect / (direct + indirect) } else { 0.0 };
            (sp.high_photons, sp.high_photons + sp.low_photons, share)
        };
        let pt_seconds_per_spp = time_pt.then(|| super::pt::seconds_per_sample(&prepared, base.seed, base.max_depth));
        Ok(Survey { high_photons, photons, indirect_share, emitter_area_share, pt_seconds_per_spp, seconds: t.elapsed().as_secs_f64() })
    })
}

/// Why a scene without caustics or strong secondary light keeps the path tracer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum KeepPt {
    /// Final quality: the path tracer keeps converging.
    Converges,
    /// A time budget in which the path tracer reaches at least [`TIMED_PT_SPP`] samples per pixel
    /// (this many).
    TimeForSamples(u64),
    /// Less than [`INDIRECT_SHARE`] of the light bounced.
    DirectLight,
    /// At least [`EMITTER_AREA_SHARE`] of the surface area emits.
    LargeEmitters,
    /// Fewer than [`MIN_PIXELS`] pixels.
    SmallImage,
    /// `--spp` without `--photons`.
    SamplesGiven,
}

/// [`Survey::emitter_area_share`]: emissive triangles are part of the scene's triangles; area
/// lights (rect, disk, sphere) are added to them.
fn emitter_area_share(scene: &SceneDesc, prepared: &PreparedScene) -> f64 {
    use crate::light::Emitter;
    let mut geometry = 0.0f64;
    for inst in &scene.instances {
        let Some(mesh) = scene.meshes.get(inst.mesh as usize) else { continue };
        geometry += crate::prepare::surface_area(mesh, &inst.transform);
    }
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

/// Choose the method and budget for `scene`. `base` carries the settings the user gave that auto
/// does not choose (seed, threads, resolution, bandwidth, …).
pub fn choose(scene: &SceneDesc, req: &AutoRequest, base: &RenderSettings) -> Result<AutoChoice> {
    if req.quality.is_some() && req.time.is_some() {
        return Err(Error::param("quality", "give --quality or --time, not both".to_string()));
    }
    let q = req.quality.unwrap_or(Quality::Preview);
    let specular = scene_flags(scene).contains(crate::bsdf::BsdfFlags::SPECULAR);
    let budget = match req.time {
        Some(t) => format!("{t} s"),
        None => format!("{q:?} quality").to_lowercase(),
    };
    let [w, h] = super::image_size(scene, base)?;
    let timed = req.time.is_some();
    let survey = if specular { None } else { Some(survey(scene, base, timed)?) };
    let strong = survey.as_ref().map_or(0.0, Survey::share);
    let indirect = survey.as_ref().map_or(0.0, |sv| sv.indirect_share);
    let emitters = survey.as_ref().map_or(0.0, |sv| sv.emitter_area_share);
    // the survey's time counts against a time budget
    let spent = survey.as_ref().map_or(0.0, |sv| sv.seconds);
    let time_budget = req.time.map(|t| (t - spent).max(1e-3));
    // Under `--time`: the path tracer's samples per pixel in the time left, predicted.
    let pt_spp_in_time = match (time_budget, survey.as_ref().and_then(|sv| sv.pt_seconds_per_spp)) {
        (Some(t), Some(per_spp)) if per_spp > 0.0 => t / per_spp,
        _ => f64::INFINITY,
    };
    // Under `--time`, the preset that budget stands for (final: the path tracer).
    let timed_q = req.time.map(|_| timed_quality(pt_spp_in_time));
    // Why a diffuse or glossy scene keeps the path tracer (`None`: ray splatting's preset).
    let keep_pt = if !timed && q == Quality::Final {
        Some(KeepPt::Converges)
    } else if timed_q == Some(Quality::Final) {
        Some(KeepPt::TimeForSamples(pt_spp_in_time.min(1e12) as u64))
    } else if indirect < INDIRECT_SHARE {
        Some(KeepPt::DirectLight)
    } else if emitters >= EMITTER_AREA_SHARE {
        Some(KeepPt::LargeEmitters)
    } else if (w as u64) * (h as u64) < MIN_PIXELS {
        Some(KeepPt::SmallImage)
    } else if req.spp.is_some() && req.photons.is_none() {
        // a sample count without photons: the path tracer's budget
        Some(KeepPt::SamplesGiven)
    } else {
        None
    };
    // The ray-splatting preset: under `--time`, by the samples the path tracer would reach.
    let diffuse_quality = timed_q.unwrap_or(q);
    let no_caustics = format!("no caustics, no strong secondary light ({:.1} % of the survey's photons in high-energy voxels)", 100.0 * strong);
    // The preset with the user's overrides; camera samples never fewer than eye samples.
    let resolve = |b: Budget| {
        let spp = req.spp.unwrap_or(b.spp);
        let aa_spp = if base.aa_spp != 0 { base.aa_spp } else { b.aa_spp.max(spp) };
        Budget { spp, aa_spp, photons: req.photons.unwrap_or(b.photons) }
    };
    let passes = |b: Budget| {
        let what = format!("{} photons, {} eye spp, {} camera spp", b.photons, b.spp, b.aa_spp.max(b.spp));
        if timed {
            format!("passes of {what}")
        } else {
            what
        }
    };
    let (method, b, why) = if specular {
        let b = resolve(pm_budget(q, timed));
        (Method::Pm, b, format!("specular surfaces make caustics, which the photon map resolves faster than the path tracer; {}", passes(b)))
    } else if strong >= STRONG_SECONDARY_SHARE {
        let b = resolve(secondary_budget(q, timed));
        let why = format!(
            "strong secondary light ({:.1} % of the survey's photons land in high-energy voxels), which the path tracer finds only by BSDF sampling; {}",
            100.0 * strong,
            passes(b)
        );
        (Method::Rs, b, why)
    } else if let (None, Some(b)) = (keep_pt, diffuse_budget(diffuse_quality)) {
        let b = resolve(b);
        let what = if timed {
            format!("in {budget} the path tracer would reach about {pt_spp_in_time:.0} spp (fewer than {TIMED_PT_SPP}):")
        } else {
            format!("for a {}", format!("{q:?}").to_lowercase())
        };
        let why = format!(
            "{no_caustics}, {:.0} % of the light bounced, {:.1} % of the surface area emits: {what} ray splatting with camera samples reaches the path tracer's error sooner; {}",
            100.0 * indirect,
            100.0 * emitters,
            passes(b)
        );
        (Method::Rs, b, why)
    } else {
        let spp = req.spp.unwrap_or(if timed { 1 << 24 } else { pt_spp(q) });
        let how = if timed { "samples until the time is spent".to_string() } else { format!("{spp} spp") };
        let bounced = format!("{:.0} % of the light bounced", 100.0 * indirect);
        let because = match keep_pt.unwrap_or(KeepPt::Converges) {
            KeepPt::Converges => "the path tracer converges where the photon methods' bias stops them".to_string(),
            KeepPt::TimeForSamples(n) => format!("in {budget} the path tracer reaches about {n} spp, where it converges past the photon methods' bias"),
            KeepPt::DirectLight => format!("{bounced}: mostly direct light, which the path tracer resolves best"),
            KeepPt::LargeEmitters => format!("{bounced}, but {:.0} % of the surface area emits, which the path tracer's paths find by themselves", 100.0 * emitters),
            KeepPt::SmallImage => format!("{bounced}, but the image has only {w}x{h} pixels, too few to repay a light pass"),
            KeepPt::SamplesGiven => format!("{bounced}; --spp fixes the path tracer's samples (without it a {} would take ray splatting)", format!("{q:?}").to_lowercase()),
        };
        let why = format!("{no_caustics}; {because}; {how}");
        (Method::Pt, Budget { spp, aa_spp: base.aa_spp, photons: base.photons }, why)
    };
    let settings = RenderSettings { method, spp: b.spp, aa_spp: b.aa_spp, photons: b.photons, time_budget, ..base.clone() };
    settings.validate()?;
    let survey_note = if timed && spent > 0.0 { format!(" (the survey took {spent:.2} s of the {budget})") } else { String::new() };
    Ok(AutoChoice { reason: format!("auto: {method} for {budget} — {why}{survey_note}"), settings })
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

    #[test]
    fn closed_rooms_take_ray_splatting_open_scenes_the_path_tracer_specular_ones_the_photon_map() {
        let base = RenderSettings::default();
        let none = AutoRequest::default();
        // an open quad without light: nothing bounces
        let diffuse = choose(&quad_scene(preview(0.0, 1.0)), &none, &base).unwrap();
        assert_eq!((diffuse.settings.method, diffuse.settings.spp), (Method::Pt, 64), "{}", diffuse.reason);
        let glossy = choose(&quad_scene(preview(1.0, 0.3)), &none, &base).unwrap();
        assert_eq!(glossy.settings.method, Method::Pt);
        // a closed box: about half the light arriving at its walls has bounced
        let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.usda"));
        let cornell = crate::usd::load_scene(path).unwrap();
        let sv = survey(&cornell, &base, true).unwrap();
        assert!((0.4..0.6).contains(&sv.indirect_share), "{sv:?}");
        assert!(sv.emitter_area_share > 0.0 && sv.emitter_area_share < 0.05, "{sv:?}");
        let room = choose(&cornell, &none, &base).unwrap();
        let s = &room.settings;
        assert_eq!((s.method, s.spp, s.aa_spp, s.photons), (Method::Rs, 2, 16, 100_000), "{}", room.reason);
        assert!(room.reason.contains("% of the light bounced"), "{}", room.reason);
        let draft = choose(&cornell, &AutoRequest { quality: Some(Quality::Draft), ..Default::default() }, &base).unwrap();
        assert_eq!((draft.settings.method, draft.settings.spp, draft.settings.aa_spp, draft.settings.photons), (Method::Rs, 1, 8, 25_000));
        // a small image does not repay the light pass
        let tiny = choose(&cornell, &none, &RenderSettings { resolution: Some([64, 64]), ..base.clone() }).unwrap();
        assert_eq!(tiny.settings.method, Method::Pt, "{}", tiny.reason);
        assert!(tiny.reason.contains("64x64 pixels"), "{}", tiny.reason);
        // a closed box whose walls all emit (the white furnace): the path tracer's paths find the
        // emitters by themselves
        let furnace = crate::usd::load_scene(&path.with_file_name("furnace.usda")).unwrap();
        let f = choose(&furnace, &none, &base).unwrap();
        assert_eq!(f.settings.method, Method::Pt, "{}", f.reason);
        assert!(f.reason.contains("100 % of the surface area emits"), "{}", f.reason);
        // final quality and a time budget: the path tracer, which converges
        let fin = choose(&cornell, &AutoRequest { quality: Some(Quality::Final), ..Default::default() }, &base).unwrap();
        assert_eq!((fin.settings.method, fin.settings.spp), (Method::Pt, 1024));
        // a time budget: the path tracer when it would reach many samples, else ray splatting's
        // passes (the survey's path-traced probe predicts the samples)
        assert!(sv.pt_seconds_per_spp.is_some_and(|t| t > 0.0 && t.is_finite()), "{sv:?}");
        let long = choose(&cornell, &AutoRequest { time: Some(1e5), ..Default::default() }, &base).unwrap();
        assert_eq!(long.settings.method, Method::Pt, "{}", long.reason);
        assert!(long.reason.contains("spp, where it converges"), "{}", long.reason);
        // shorter than the survey itself: no time left, the draft's passes
        let short = choose(&cornell, &AutoRequest { time: Some(1e-3), ..Default::default() }, &base).unwrap();
        let s = &short.settings;
        assert_eq!((s.method, s.spp, s.aa_spp, s.photons), (Method::Rs, 1, 8, 25_000), "{}", short.reason);
        assert!(short.reason.contains("passes of 25000 photons"), "{}", short.reason);
        assert_eq!([timed_quality(10.0), timed_quality(64.0), timed_quality(1000.0)], [Quality::Draft, Quality::Preview, Quality::Final]);
        // a sample count is the path tracer's budget
        let given = choose(&cornell, &AutoRequest { spp: Some(64), ..Default::default() }, &base).unwrap();
        assert_eq!((given.settings.method, given.settings.spp), (Method::Pt, 64), "{}", given.reason);
        assert!(given.reason.contains("--spp fixes"), "{}", given.reason);
        let both = choose(&cornell, &AutoRequest { spp: Some(2), photons: Some(5000), ..Default::default() }, &base).unwrap();
        assert_eq!((both.settings.method, both.settings.spp, both.settings.photons), (Method::Rs, 2, 5000));
        let mirror = choose(&quad_scene(preview(1.0, 0.0)), &none, &base).unwrap();
        assert_eq!((mirror.settings.method, mirror.settings.photons), (Method::Pm, 200_000));
        assert!(mirror.reason.contains("caustics"), "{}", mirror.reason);
        // photon methods resolve the direct light and the anti-aliasing with camera samples
        assert_eq!((mirror.settings.spp, mirror.settings.aa_spp), (4, 16));
        assert!(mirror.reason.contains("16 camera spp"), "{}", mirror.reason);
    }

    #[test]
    fn presets_time_and_overrides() {
        let base = RenderSettings::default();
        let scene = quad_scene(preview(0.0, 1.0));
        let draft = choose(&scene, &AutoRequest { quality: Some(Quality::Draft), ..Default::default() }, &base).unwrap();
        let fin = choose(&scene, &AutoRequest { quality: Some(Quality::Final), ..Default::default() }, &base).unwrap();
        assert!(draft.settings.spp < fin.settings.spp);
        let timed = choose(&scene, &AutoRequest { time: Some(2.0), ..Default::default() }, &base).unwrap();
        // the survey's time (here an Embree build of two triangles) counts against the budget
        assert!(timed.settings.time_budget.is_some_and(|t| t <= 2.0 && t > 1.5), "{:?}", timed.settings.time_budget);
        let given = choose(&scene, &AutoRequest { spp: Some(7), ..Default::default() }, &base).unwrap();
        assert_eq!(given.settings.spp, 7);
        // a photon preset keeps at least as many camera samples as eye samples, and the user's
        // --aa-spp wins
        let mirror = quad_scene(preview(1.0, 0.0));
        let many = choose(&mirror, &AutoRequest { spp: Some(32), ..Default::default() }, &base).unwrap();
        assert_eq!((many.settings.spp, many.settings.aa_spp), (32, 32));
        let user_aa = RenderSettings { aa_spp: 8, ..RenderSettings::default() };
        let given_aa = choose(&mirror, &AutoRequest::default(), &user_aa).unwrap();
        assert_eq!((given_aa.settings.spp, given_aa.settings.aa_spp), (4, 8));
        let fin_pm = choose(&mirror, &AutoRequest { quality: Some(Quality::Final), ..Default::default() }, &base).unwrap();
        assert_eq!((fin_pm.settings.spp, fin_pm.settings.aa_spp, fin_pm.settings.photons), (8, 64, 1_000_000));
        let both = AutoRequest { quality: Some(Quality::Final), time: Some(1.0), ..Default::default() };
        assert!(choose(&scene, &both, &base).is_err());
        assert!("best".parse::<Quality>().is_err());
    }
}
