//! Shared stages of the photon methods: their eye and light passes ([`PhotonPass`], the settings
//! every photon method has), the photon budget a scene needs, and assembling the film from the eye
//! pass (emission, direct light, AOVs) and an indirect radiance image.

use super::settings::attribute;
use super::{Method, Progress, RenderSettings, Stats};
use crate::error::{Error, Result};
use crate::eye::{eye_pass_filtered, EyePass, EyeSettings};
use crate::image::Film;
use crate::photon::{trace_photons_cancellable, BandwidthParams, PhotonSet, PhotonSettings};
use crate::prepare::PreparedScene;
use glam::Vec3;
use std::time::Instant;

/// The eye pass and the light pass every photon method starts with.
#[derive(Clone, Debug, PartialEq)]
pub struct PhotonPass {
    /// Stored photons in total (split over direct / indirect / caustic budgets, [`photon_budget`]).
    pub photons: usize,
    /// Photon ray splatting bandwidth: smoothness C, sensitivity S, maximum bandwidth R (the photon
    /// maps' search radius is capped at 5 × its largest value).
    pub bandwidth: BandwidthParams,
    /// Direct light from photons instead of explicit light sampling.
    pub direct_photons: bool,
    /// Light samples per eye sample for the direct light (ignored with `direct_photons`). Shadow
    /// rays are cheap next to density estimation, and the direct light of 4 eye samples per pixel
    /// with one light sample each sets the methods' error floor.
    pub light_samples: u32,
    /// Camera samples per pixel for anti-aliasing, emission seen directly, direct light and the
    /// AOVs (0: the same as `spp`). The first `spp` of them are also eye samples for the density
    /// estimate, so the costly indirect estimate stays at `spp` while the edges and the direct
    /// light get `aa_spp` stratified positions.
    pub aa_spp: u32,
    /// Guided emission (each emitter's position sample drawn from where paths that store photons
    /// start, learned during the light pass; see `photon::guide`).
    pub emission_guiding: bool,
}

impl Default for PhotonPass {
    fn default() -> Self {
        PhotonPass { photons: 200_000, bandwidth: BandwidthParams::default(), direct_photons: false, light_samples: 4, aa_spp: 0, emission_guiding: true }
    }
}

impl PhotonPass {
    /// Check the pass for `spp` eye samples per pixel.
    pub fn validate(&self, spp: u32) -> Result<()> {
        if self.photons > 1 << 28 {
            return Err(Error::param("photons", format!("{} is more than 268435456", self.photons)));
        }
        if self.aa_spp != 0 && (self.aa_spp < spp || self.aa_spp > super::settings::MAX_PHOTON_SPP) {
            return Err(Error::param("aa-spp", format!("{} is out of range (--spp {spp} ..= 4096, or 0 for the same as --spp)", self.aa_spp)));
        }
        if self.light_samples == 0 || self.light_samples > 4096 {
            return Err(Error::param("light-samples", format!("{} is out of range (1..=4096)", self.light_samples)));
        }
        self.bandwidth.validate()
    }

    /// As EXR header attributes, with the bandwidth the light pass traces with.
    pub(super) fn attributes(&self, spp: u32, traced: BandwidthParams) -> Vec<(String, String)> {
        vec![
            attribute("photons", self.photons),
            attribute("smoothness", traced.smoothness),
            attribute("class_smoothness", traced.class_smoothness.map(|f| f.to_string()).join(" ")),
            attribute("sensitivity", self.bandwidth.sensitivity),
            attribute("max_bandwidth", self.bandwidth.max_bandwidth),
            attribute("direct_photons", self.direct_photons),
            attribute("light_samples", self.light_samples),
            attribute("aa_spp", self.aa_spp.max(spp)),
            attribute("emission_guiding", self.emission_guiding),
        ]
    }
}

/// Split `photons` over (direct, indirect, caustic) from what the scene contains: no caustic
/// photons without specular surfaces, direct photons only when `direct` (asked for, or needed by a
/// final gather).
pub fn photon_budget(photons: usize, direct: bool, scene: &PreparedScene) -> [usize; 3] {
    let m = photons;
    let specular = scene.requirements.has_specular();
    let (d, i, c) = match (direct, specular) {
        (true, true) => (0.3, 0.6, 0.1),
        (true, false) => (0.3, 0.7, 0.0),
        (false, true) => (0.0, 0.9, 0.1),
        (false, false) => (0.0, 1.0, 0.0),
    };
    let f = |x: f64| (m as f64 * x).round() as usize;
    [f(d), f(i), f(c)]
}

/// The eye pass and the light pass of a photon method, timed as T_E and T_L, reported as one
/// progress stage and checked for cancellation.
pub fn eye_and_light(scene: &PreparedScene, s: &RenderSettings, progress: &dyn Progress, stats: &mut Stats) -> Result<(EyePass, PhotonSet)> {
    let (Some(pass), Some(bandwidth)) = (s.method.photon_pass(), s.method.bandwidth_in_effect()) else {
        return Err(Error::param("method", format!("{} traces no photons", s.method.method())));
    };
    progress.begin("eye + light pass", 2);
    let passes = eye_and_light_passes(scene, s, pass, bandwidth, progress, stats)?;
    progress.advance(2);
    if progress.cancelled() {
        return Err(Error::Cancelled);
    }
    Ok(passes)
}

fn eye_and_light_passes(scene: &PreparedScene, s: &RenderSettings, pass: &PhotonPass, bandwidth: BandwidthParams, progress: &dyn Progress, stats: &mut Stats) -> Result<(EyePass, PhotonSet)> {
    let t = Instant::now();
    let eye = eye_pass_filtered(scene, &EyeSettings { spp: s.spp, aa_spp: pass.aa_spp, seed: s.seed, light_samples: if pass.direct_photons { 0 } else { pass.light_samples } }, s.filter)?;
    stats.phase("eye", t.elapsed().as_secs_f64());
    stats.count("eye_samples", eye.samples.len() as u64);
    stats.count("glossy_eye_samples", eye.glossy.len() as u64);
    stats.enable("eye samples", eye.bytes());
    let t = Instant::now();
    let method: Method = s.method.method();
    let budget = photon_budget(pass.photons, pass.direct_photons || method.gathers_direct_light(), scene);
    if budget.iter().sum::<usize>() == 0 {
        let left = if pass.direct_photons { "neither direct nor indirect light, only the emission seen directly" } else { "no indirect light, only the direct light sampled in the eye pass" };
        stats.note(format!("no photons (--photons {}): the image has {left}", pass.photons));
    }
    if progress.cancelled() {
        return Err(Error::Cancelled);
    }
    let photons = trace_photons_cancellable(
        scene,
        &PhotonSettings {
            budget,
            seed: s.seed,
            max_depth: s.max_depth.min(256),
            bandwidth,
            emission_guiding: pass.emission_guiding,
            reach: method.splats_onto_eye_samples().then(|| std::sync::Arc::new(crate::splat::Reach::of(&eye))),
            ..PhotonSettings::default()
        },
        &|| progress.cancelled(),
    )?;
    stats.phase("light", t.elapsed().as_secs_f64());
    stats.count("photon_paths", photons.paths);
    for (k, name) in ["direct_photons", "indirect_photons", "caustic_photons"].iter().enumerate() {
        if budget[k] > 0 {
            stats.count(name, (photons.rays[k].len() - photons.leaving[k]) as u64);
        }
    }
    let leaving: usize = photons.leaving.iter().sum();
    if leaving > 0 {
        stats.count("leaving_rays", leaving as u64);
    }
    stats.enable(
        &format!("photons (direct {}, indirect {}, caustic {})", budget[0], budget[1], budget[2]),
        photons.bytes(),
    );
    if let Some(g) = photons.guide {
        stats.count("guided_photon_paths", g.guided_paths);
        let what = if g.grids > 0 {
            format!("emission guiding ({} grids, {} cells)", g.grids, g.cells)
        } else {
            "emission guiding (learned, not used: no light's yield varies enough)".to_string()
        };
        stats.enable(&what, g.bytes);
    }
    Ok((eye, photons))
}

/// Beauty = emission + direct + indirect, plus the AOV layers and the layer
/// [`DIRECT_VARIANCE_LAYER`] (the render strips it; timed passes read it); allocated fallibly.
pub fn film(eye: &EyePass, indirect: &[Vec3]) -> crate::Result<Film> {
    let what = || format!("the {}x{} image's direct light", eye.width, eye.height);
    let direct: Vec<Vec3> = crate::memory::try_collect(eye.emitted.iter().zip(&eye.direct).map(|(e, d)| *e + *d), what)?;
    let mut film = super::aov::film(
        eye.width,
        eye.height,
        &super::aov::Aovs { direct: &direct, indirect, albedo: &eye.albedo, normal: &eye.normal, depth: &eye.depth },
    )?;
    if eye.direct_variance.len() == direct.len() {
        film.add_layer(DIRECT_VARIANCE_LAYER, &["V"]);
        film.layer_mut(DIRECT_VARIANCE_LAYER).expect("layer just added").data.copy_from_slice(&eye.direct_variance);
    }
    Ok(film)
}

/// The film layer of the per-pixel variance of the direct light (`EyePass::direct_variance`).
pub const DIRECT_VARIANCE_LAYER: &str = "direct_variance";

/// Emission and direct light only: `aa` camera samples per pixel with `light_samples` light samples
/// each, no eye samples and no photons (a timed render's direct-only samples).
pub fn direct_only(scene: &PreparedScene, aa: u32, seed: u64, light_samples: u32, filter: crate::image::PixelFilter) -> crate::Result<Vec<Vec3>> {
    let eye = eye_pass_filtered(scene, &EyeSettings { spp: 0, aa_spp: aa, seed, light_samples }, filter)?;
    Ok(eye.emitted.iter().zip(&eye.direct).map(|(e, d)| *e + *d).collect())
}
