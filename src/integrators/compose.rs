//! Shared stages of the photon methods: the photon budget a scene needs, and assembling the film
//! from the eye pass (emission, direct light, AOVs) and an indirect radiance image.

use super::{Progress, RenderSettings, Stats};
use crate::error::{Error, Result};
use crate::eye::{eye_pass, EyePass, EyeSettings};
use crate::image::Film;
use crate::photon::{trace_photons_cancellable, PhotonSet, PhotonSettings};
use crate::prepare::PreparedScene;
use glam::Vec3;
use std::time::Instant;

/// Split the photon budget over (direct, indirect, caustic) from what the scene contains: no caustic
/// photons without specular surfaces, no direct photons unless asked for.
pub fn photon_budget(s: &RenderSettings, scene: &PreparedScene) -> [usize; 3] {
    let m = s.photons;
    let specular = scene.requirements.has_specular();
    // Final gathering needs all light arriving at gather hits in the global map, direct included.
    let direct = s.direct_photons || s.method.final_gathers() || s.method == super::Method::HeFg;
    let (d, i, c) = match (direct, specular) {
        (true, true) => (0.3, 0.6, 0.1),
        (true, false) => (0.3, 0.7, 0.0),
        (false, true) => (0.0, 0.9, 0.1),
        (false, false) => (0.0, 1.0, 0.0),
    };
    let f = |x: f64| (m as f64 * x).round() as usize;
    [f(d), f(i), f(c)]
}

/// The eye pass and the light pass, timed as T_E and T_L, reported as one progress stage and
/// checked for cancellation.
pub fn eye_and_light(scene: &PreparedScene, s: &RenderSettings, progress: &dyn Progress, stats: &mut Stats) -> Result<(EyePass, PhotonSet)> {
    progress.begin("eye + light pass", 2);
    let passes = eye_and_light_passes(scene, s, progress, stats)?;
    progress.advance(2);
    if progress.cancelled() {
        return Err(Error::Cancelled);
    }
    Ok(passes)
}

fn eye_and_light_passes(scene: &PreparedScene, s: &RenderSettings, progress: &dyn Progress, stats: &mut Stats) -> Result<(EyePass, PhotonSet)> {
    let t = Instant::now();
    let eye = eye_pass(scene, &EyeSettings { spp: s.spp, aa_spp: s.aa_spp, seed: s.seed, light_samples: if s.direct_photons { 0 } else { s.light_samples } })?;
    stats.phase("eye", t.elapsed().as_secs_f64());
    stats.count("eye_samples", eye.samples.len() as u64);
    stats.count("glossy_eye_samples", eye.glossy.len() as u64);
    stats.enable("eye samples", eye.bytes());
    let t = Instant::now();
    let budget = photon_budget(s, scene);
    if budget.iter().sum::<usize>() == 0 {
        let left = if s.direct_photons { "neither direct nor indirect light, only the emission seen directly" } else { "no indirect light, only the direct light sampled in the eye pass" };
        stats.note(format!("no photons (--photons {}): the image has {left}", s.photons));
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
            bandwidth: s.bandwidth_in_effect(),
            emission_guiding: s.emission_guiding,
            ..PhotonSettings::default()
        },
        &|| progress.cancelled(),
    )?;
    stats.phase("light", t.elapsed().as_secs_f64());
    stats.count("photon_paths", photons.paths);
    for (k, name) in ["direct_photons", "indirect_photons", "caustic_photons"].iter().enumerate() {
        if budget[k] > 0 {
            stats.count(name, photons.rays[k].len() as u64);
        }
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

/// Beauty = emission + direct + indirect, plus the AOV layers (allocated fallibly).
pub fn film(eye: &EyePass, indirect: &[Vec3]) -> crate::Result<Film> {
    let what = || format!("the {}x{} image's direct light", eye.width, eye.height);
    let direct: Vec<Vec3> = crate::memory::try_collect(eye.emitted.iter().zip(&eye.direct).map(|(e, d)| *e + *d), what)?;
    super::aov::film(
        eye.width,
        eye.height,
        &super::aov::Aovs { direct: &direct, indirect, albedo: &eye.albedo, normal: &eye.normal, depth: &eye.depth },
    )
}
