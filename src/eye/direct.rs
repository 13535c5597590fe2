//! Direct light at the eye pass's non-specular vertices: light samples and BSDF samples combined by
//! multiple importance sampling (the power heuristic, with the two strategies' sample counts).
//!
//! Light sampling alone is poor where a large light is mostly hidden (a sky seen through a roof's
//! opening: most of its samples are shadowed) or where a glossy lobe is narrower than the light
//! (a coat reflecting the sun's disc or the sky); BSDF sampling is poor for small lights. The
//! weighted sum of both is unbiased and never much worse than the better one.

use crate::bsdf::{BsdfAt, TransportMode};
use crate::embree::Ray;
use crate::prepare::{PreparedScene, SurfaceHit};
use crate::sampling::{power_heuristic, Frame};
use glam::{Vec2, Vec3};

/// BSDF samples per camera sample at a non-specular vertex (each costs one traced ray).
pub const BSDF_SAMPLES: u32 = 1;

/// One light sample (`choice`: the light chosen by power and its probability; `u`: the point on
/// it) for the non-delta lobes of `bsdf` (the BSDF at the hit's view direction) at a hit, as one of
/// `light_samples` light samples beside `bsdf_samples` BSDF samples (their MIS weight): its
/// contribution if nothing blocks it, and the shadow ray that decides whether something does
/// (`None`: nothing can). `None` for a sample that contributes nothing.
#[allow(clippy::too_many_arguments)]
pub fn light_sample(
    scene: &PreparedScene,
    h: &SurfaceHit,
    bsdf: &BsdfAt,
    frame: &Frame,
    choice: (usize, f32),
    u: Vec2,
    light_samples: u32,
    bsdf_samples: u32,
) -> Option<(Vec3, Option<Ray>)> {
    let (li, pmf) = choice;
    let ls = scene.lights.emitters[li].sample_li(h.p, u, &scene.textures)?;
    let wi_l = frame.to_local(ls.wi);
    let (f, bsdf_pdf) = bsdf.eval_pdf(wi_l, TransportMode::Radiance);
    let f = f * wi_l.z.abs();
    if f == Vec3::ZERO || ls.li == Vec3::ZERO {
        return None;
    }
    let w = if ls.delta || bsdf_samples == 0 { 1.0 } else { power_heuristic(light_samples as f32, pmf * ls.pdf, bsdf_samples as f32, bsdf_pdf) };
    Some((f * ls.li * (w / (pmf * ls.pdf)), scene.shadow_ray(h.p, h.ng, ls.wi, ls.dist)))
}

/// One BSDF sample (`uc`, `u`: the lobe choice and the direction) of the direct light at a hit,
/// as one of `bsdf_samples` BSDF samples beside `light_samples` light samples: the emission its
/// ray finds (lights crossed, an emissive surface hit, or the infinite lights when it escapes)
/// times the BSDF over its pdf and the MIS weight, and whether a ray was traced. Specular lobes
/// contribute nothing: the eye pass follows them itself.
#[allow(clippy::too_many_arguments)]
pub fn bsdf_sample(
    scene: &PreparedScene,
    h: &SurfaceHit,
    bsdf: &BsdfAt,
    frame: &Frame,
    uc: f32,
    u: Vec2,
    light_samples: u32,
    bsdf_samples: u32,
) -> (Vec3, bool) {
    let lights = &scene.lights;
    if lights.is_empty() {
        return (Vec3::ZERO, false);
    }
    let Some(bs) = bsdf.sample(uc, u, TransportMode::Radiance) else { return (Vec3::ZERO, false) };
    if bs.flags.is_specular() || bs.pdf <= 0.0 || bs.f == Vec3::ZERO {
        return (Vec3::ZERO, false);
    }
    let beta = bs.f * (bs.wi.z.abs() / (bs.pdf * bsdf_samples as f32));
    if !beta.is_finite() {
        return (Vec3::ZERO, false);
    }
    let ray = scene.spawn(h.p, h.ng, frame.to_world(bs.wi));
    let (nl, nb) = (light_samples as f32, bsdf_samples as f32);
    let weight = |li: u32, t: f32| {
        if light_samples == 0 {
            1.0
        } else {
            power_heuristic(nb, bs.pdf, nl, lights.pmf(li as usize) * lights.emitters[li as usize].pdf_li(h.p, ray.dir, t))
        }
    };
    let hit = scene.intersect(&ray);
    let tmax = hit.map_or(f32::INFINITY, |hh| hh.t);
    let mut le = Vec3::ZERO;
    for &li in &lights.analytic {
        if let Some((t, l)) = lights.emitters[li as usize].intersect(ray.org, ray.dir, tmax) {
            le += l * weight(li, t);
        }
    }
    match hit {
        None => {
            for &li in &lights.infinite {
                let l = lights.emitters[li as usize].le_infinite(ray.dir, &scene.textures);
                if l != Vec3::ZERO {
                    le += l * weight(li, 0.0);
                }
            }
        }
        Some(hh) => {
            let l = scene.emitted(&hh, -ray.dir);
            if l != Vec3::ZERO {
                // an emissive surface that is not among the sampled lights is found this way only
                le += l * lights.triangle_emitter(hh.instance, hh.prim).map_or(1.0, |li| weight(li, hh.t));
            }
        }
    }
    (beta * le, true)
}
