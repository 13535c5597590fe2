//! The simple BSDFs: Lambert, perfect mirror and smooth dielectric (shared with PreviewSurface's
//! transmissive blend).

use super::fresnel::{self, reflect_z, refract};
use super::{BsdfFlags, BsdfSample, TransportMode};
use crate::sampling::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Cosine-weighted sample on the side of `wo` (two-sided Lambert).
pub(crate) fn sample_lambert(albedo: Vec3, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
    if wo.z == 0.0 {
        return None;
    }
    let mut wi = square_to_cosine_hemisphere(u);
    let pdf = cosine_hemisphere_pdf(wi.z);
    if pdf <= 0.0 {
        return None;
    }
    wi.z = wi.z.copysign(wo.z);
    Some(BsdfSample { wi, f: albedo * FRAC_1_PI, pdf, flags: BsdfFlags::DIFFUSE | BsdfFlags::REFLECTION, eta: 1.0 })
}

/// Delta reflection on the side of `wo` (two-sided mirror).
pub(crate) fn sample_mirror(reflectance: Vec3, wo: Vec3) -> Option<BsdfSample> {
    if wo.z == 0.0 {
        return None;
    }
    let wi = reflect_z(wo);
    Some(BsdfSample {
        wi,
        f: reflectance / wi.z.abs(),
        pdf: 1.0,
        flags: BsdfFlags::SPECULAR | BsdfFlags::REFLECTION,
        eta: 1.0,
    })
}

/// One branch of a smooth dielectric interface, before any tint or lobe weight.
#[derive(Clone, Copy, Debug)]
pub(crate) struct GlassBranch {
    /// Fresnel reflectance at `wo`.
    pub reflectance: f32,
    /// `Some((wi, eta crossed))` when refraction was chosen, `None` for reflection.
    pub refracted: Option<(Vec3, f32)>,
}

/// Chooses reflection (with probability equal to the Fresnel reflectance) or refraction with `uc`.
pub(crate) fn choose_glass_branch(eta: f32, wo: Vec3, uc: f32) -> GlassBranch {
    let r = fresnel::dielectric(wo.z, eta);
    let refracted = if uc < r { None } else { refract(wo, eta) };
    GlassBranch { reflectance: r, refracted }
}

/// Refraction sample of weight `scale` (tint × lobe weight) chosen with probability `prob`.
pub(crate) fn refraction_sample(
    wt: Vec3,
    etap: f32,
    t: f32,
    scale: Vec3,
    prob: f32,
    mode: TransportMode,
) -> Option<BsdfSample> {
    if wt.z == 0.0 || prob <= 0.0 {
        return None;
    }
    let mut f = scale * (t / wt.z.abs());
    if mode == TransportMode::Radiance {
        f /= etap * etap;
    }
    Some(BsdfSample { wi: wt, f, pdf: prob, flags: BsdfFlags::SPECULAR | BsdfFlags::TRANSMISSION, eta: etap })
}

/// Smooth dielectric: Fresnel reflection (white) or refraction (tinted), chosen stochastically.
pub(crate) fn sample_dielectric(eta: f32, tint: Vec3, wo: Vec3, uc: f32, mode: TransportMode) -> Option<BsdfSample> {
    if wo.z == 0.0 {
        return None;
    }
    let branch = choose_glass_branch(eta, wo, uc);
    let r = branch.reflectance;
    match branch.refracted {
        None => {
            let wi = reflect_z(wo);
            let f = Vec3::splat(r / wi.z.abs());
            Some(BsdfSample { wi, f, pdf: r, flags: BsdfFlags::SPECULAR | BsdfFlags::REFLECTION, eta: 1.0 })
        }
        Some((wt, etap)) => refraction_sample(wt, etap, 1.0 - r, tint, 1.0 - r, mode),
    }
}
