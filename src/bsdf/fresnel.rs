//! Fresnel terms and the reflection / refraction laws in the local frame (normal = +z).

use glam::Vec3;

/// IOR used when the input is not finite and positive: the UsdPreviewSurface default.
pub(crate) const DEFAULT_IOR: f32 = 1.5;

/// `ior` if finite and positive, else [`DEFAULT_IOR`].
pub(crate) fn sanitize_ior(ior: f32) -> f32 {
    if ior.is_finite() && ior > 0.0 {
        ior
    } else {
        DEFAULT_IOR
    }
}

/// Normal-incidence reflectance of an interface of relative IOR `ior`: `((ior−1)/(ior+1))²`.
pub(crate) fn ior_to_f0(ior: f32) -> f32 {
    let r = (ior - 1.0) / (ior + 1.0);
    r * r
}

/// `(1 − cos)⁵`, the Schlick weight (cos clamped to [0, 1]).
#[inline]
pub(crate) fn schlick_weight(cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// Generalised Schlick Fresnel `F0 + (F90 − F0)(1 − cos)⁵`.
#[inline]
pub(crate) fn schlick(f0: Vec3, f90: Vec3, cos: f32) -> Vec3 {
    f0 + (f90 - f0) * schlick_weight(cos)
}

/// Exact unpolarised Fresnel reflectance of a dielectric interface for incident cosine `cos_i`
/// (negative: arriving from inside) and relative IOR `eta` (inside / outside). 1 under total
/// internal reflection.
pub(crate) fn dielectric(cos_i: f32, eta: f32) -> f32 {
    let (cos_i, eta) = if cos_i < 0.0 { (-cos_i, 1.0 / eta) } else { (cos_i, eta) };
    let cos_i = cos_i.min(1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parl * r_parl + r_perp * r_perp)
}

/// Mirror reflection about the normal.
#[inline]
pub(crate) fn reflect_z(w: Vec3) -> Vec3 {
    Vec3::new(-w.x, -w.y, w.z)
}

/// Mirror reflection of `w` about the unit vector `h`.
#[inline]
pub(crate) fn reflect(w: Vec3, h: Vec3) -> Vec3 {
    2.0 * w.dot(h) * h - w
}

/// Refraction of `wo` through the interface with relative IOR `eta` (inside / outside), choosing
/// the side from `wo.z`. Returns the transmitted direction and the relative IOR crossed
/// (`eta` entering, `1/eta` leaving), or `None` under total internal reflection.
pub(crate) fn refract(wo: Vec3, eta: f32) -> Option<(Vec3, f32)> {
    let (cos_o, etap, n) = if wo.z < 0.0 { (-wo.z, 1.0 / eta, -Vec3::Z) } else { (wo.z, eta, Vec3::Z) };
    let sin2_t = (1.0 - cos_o * cos_o).max(0.0) / (etap * etap);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let wt = -wo / etap + (cos_o / etap - cos_t) * n;
    Some((wt.normalize(), etap))
}
