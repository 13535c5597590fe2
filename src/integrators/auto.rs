//! `--method auto`: pick the method and its budget from what the scene contains and from the trade
//! measured by `raysplat study` (docs/accuracy.md, docs/auto.md has the decision table).
//!
//! - No specular surfaces (mirrors, glass): no caustics. On such scenes the study measured the path
//!   tracer reaching every relative-MSE target first (Cornell box, bumpy box): **`pt`**.
//! - Specular surfaces: caustics (light → specular → diffuse → eye) are found by the path tracer
//!   only when a BSDF-sampled path hits the light: its error falls slowly. On CornellBox-Sphere at
//!   128² the photon map reached a relative MSE of 0.013 in 1.2 s where the path tracer had 0.22
//!   after 0.7 s and 0.051 after 2.8 s; `pm` was also faster than `rs` at equal error: **`pm`**.
//!
//! The budget comes from `--quality` (a preset) or `--time` (the path tracer adds samples, `pm`
//! averages passes, see `passes`). Explicit `--spp` / `--photons` override the preset.

use super::{Method, RenderSettings};
use crate::error::{Error, Result};
use crate::prepare::scene_flags;
use crate::scene::SceneDesc;
use std::str::FromStr;

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
    let (method, spp, photons, why) = if specular {
        let (spp, photons) = pm_budget(q);
        let spp = req.spp.unwrap_or(spp);
        let photons = req.photons.unwrap_or(if req.time.is_some() { 200_000 } else { photons });
        let how = if req.time.is_some() { format!("passes of {photons} photons and {spp} eye spp") } else { format!("{photons} photons, {spp} eye spp") };
        (Method::Pm, spp, photons, format!("specular surfaces make caustics, which the photon map resolves faster than the path tracer; {how}"))
    } else {
        let spp = req.spp.unwrap_or(if req.time.is_some() { 1 << 24 } else { pt_spp(q) });
        let how = if req.time.is_some() { "samples until the time is spent".to_string() } else { format!("{spp} spp") };
        (Method::Pt, spp, base.photons, format!("no specular surfaces (no caustics): the path tracer reaches every error target first on such scenes; {how}"))
    };
    let settings = RenderSettings { method, spp, photons, time_budget: req.time, ..base.clone() };
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
        assert_eq!(timed.settings.time_budget, Some(2.0));
        let given = choose(&scene, &AutoRequest { spp: Some(7), ..Default::default() }, &base).unwrap();
        assert_eq!(given.settings.spp, 7);
        let both = AutoRequest { quality: Some(Quality::Final), time: Some(1.0), ..Default::default() };
        assert!(choose(&scene, &both, &base).is_err());
        assert!("best".parse::<Quality>().is_err());
    }
}
