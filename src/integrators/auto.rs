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
//! - Otherwise (diffuse and glossy scenes without either) the study measured the path tracer
//!   reaching every relative-MSE target first (Cornell box, bumpy box): **`pt`**.
//!
//! The budget comes from `--quality` (a preset) or `--time` (the path tracer adds samples, `pm`
//! averages passes, see `passes`; the survey's time counts against it). Explicit `--spp` /
//! `--photons` override the preset.

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

/// Photon map: (eye samples per pixel, stored photons) for each preset.
fn pm_budget(q: Quality) -> (u32, usize) {
    match q {
        Quality::Draft => (4, 50_000),
        Quality::Preview => (4, 200_000),
        Quality::Final => (16, 1_000_000),
    }
}

/// Strong secondary light: (eye samples per pixel, photons) of ray splatting for each preset.
/// `raysplat bench --target-table scenes/secondary-light.usda` (96×72, errors against the converged
/// image, mean of 2 seeds): `rs` 4 spp 100k photons 0.0098 in 1.35 s, 400k 0.0059 in 3.9 s; `pm`
/// 4 spp 400k 0.011 in 1.7 s, 8 spp 400k 0.0095 in 2.0 s; the path tracer needs 82 s for 0.01.
/// Beyond ~0.006 the error of 4 eye spp is the anti-aliasing of the lit patch's edge in the direct
/// light, so `final` adds eye samples.
fn secondary_budget(q: Quality) -> (u32, usize) {
    match q {
        Quality::Draft => (4, 100_000),
        Quality::Preview => (4, 400_000),
        Quality::Final => (16, 1_000_000),
    }
}

/// What the survey of a scene's light found: photons landing in high-energy voxels, of all.
#[derive(Clone, Copy, Debug)]
pub struct Survey {
    pub high_photons: usize,
    pub photons: usize,
    pub seconds: f64,
}

impl Survey {
    /// Share of the photons in high-energy voxels (0 for a scene without light).
    pub fn share(&self) -> f64 {
        self.high_photons as f64 / self.photons.max(1) as f64
    }
}

/// Trace the survey's light pass for `scene` (a 1×1 view: the light pass does not use the camera)
/// on `base.threads` threads with `base.seed`.
pub fn survey(scene: &SceneDesc, base: &RenderSettings) -> Result<Survey> {
    let t = Instant::now();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(base.threads).build().map_err(|e| Error::param("threads", e.to_string()))?;
    pool.install(|| {
        let prepared = PreparedScene::new(scene.clone(), 1, 1, base.threads)?;
        let (high_photons, photons) = if prepared.lights.is_empty() {
            (0, 0)
        } else {
            let s = RenderSettings { photons: SURVEY_PHOTONS, seed: base.seed, ..Default::default() };
            let sp = super::he_fg::survey(&prepared, &s);
            (sp.high_photons, sp.high_photons + sp.low_photons)
        };
        Ok(Survey { high_photons, photons, seconds: t.elapsed().as_secs_f64() })
    })
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
    let survey = if specular { None } else { Some(survey(scene, base)?) };
    let strong = survey.as_ref().map_or(0.0, Survey::share);
    let passes = |photons: usize, spp: u32| match req.time {
        Some(_) => format!("passes of {photons} photons and {spp} eye spp"),
        None => format!("{photons} photons, {spp} eye spp"),
    };
    let (method, spp, photons, why) = if specular {
        let (spp, photons) = pm_budget(q);
        let spp = req.spp.unwrap_or(spp);
        let photons = req.photons.unwrap_or(if req.time.is_some() { 200_000 } else { photons });
        (Method::Pm, spp, photons, format!("specular surfaces make caustics, which the photon map resolves faster than the path tracer; {}", passes(photons, spp)))
    } else if strong >= STRONG_SECONDARY_SHARE {
        let (spp, photons) = if req.time.is_some() { (4, 200_000) } else { secondary_budget(q) };
        let (spp, photons) = (req.spp.unwrap_or(spp), req.photons.unwrap_or(photons));
        let why = format!(
            "strong secondary light ({:.1} % of the survey's photons land in high-energy voxels), which the path tracer finds only by BSDF sampling; {}",
            100.0 * strong,
            passes(photons, spp)
        );
        (Method::Rs, spp, photons, why)
    } else {
        let spp = req.spp.unwrap_or(if req.time.is_some() { 1 << 24 } else { pt_spp(q) });
        let how = if req.time.is_some() { "samples until the time is spent".to_string() } else { format!("{spp} spp") };
        let why = format!(
            "no specular surfaces (no caustics) and no strong secondary light ({:.1} % of the survey's photons in high-energy voxels): the path tracer reaches every error target first on such scenes; {how}",
            100.0 * strong
        );
        (Method::Pt, spp, base.photons, why)
    };
    // the survey's time counts against a time budget
    let spent = survey.as_ref().map_or(0.0, |sv| sv.seconds);
    let time_budget = req.time.map(|t| (t - spent).max(1e-3));
    let settings = RenderSettings { method, spp, photons, time_budget, ..base.clone() };
    settings.validate()?;
    Ok(AutoChoice { reason: format!("auto: {method} for {budget} — {why}"), settings })
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
    fn diffuse_and_glossy_scenes_take_the_path_tracer_specular_ones_the_photon_map() {
        let base = RenderSettings::default();
        let none = AutoRequest::default();
        let diffuse = choose(&quad_scene(preview(0.0, 1.0)), &none, &base).unwrap();
        assert_eq!((diffuse.settings.method, diffuse.settings.spp), (Method::Pt, 64));
        let glossy = choose(&quad_scene(preview(1.0, 0.3)), &none, &base).unwrap();
        assert_eq!(glossy.settings.method, Method::Pt);
        let mirror = choose(&quad_scene(preview(1.0, 0.0)), &none, &base).unwrap();
        assert_eq!((mirror.settings.method, mirror.settings.photons), (Method::Pm, 200_000));
        assert!(mirror.reason.contains("caustics"), "{}", mirror.reason);
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
        let both = AutoRequest { quality: Some(Quality::Final), time: Some(1.0), ..Default::default() };
        assert!(choose(&scene, &both, &base).is_err());
        assert!("best".parse::<Quality>().is_err());
    }
}
