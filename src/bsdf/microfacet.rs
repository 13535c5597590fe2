//! Isotropic Trowbridge-Reitz (GGX) microfacet distribution with Smith masking-shadowing and
//! visible-normal sampling. Directions are in the upper hemisphere of the local frame.

use glam::{Vec2, Vec3};
#[cfg(test)]
use std::f32::consts::PI;
use std::f32::consts::TAU;

/// Smallest roughness `α` of a non-delta lobe (perceptual roughness ≈ 0.032).
pub(crate) const ALPHA_MIN: f32 = 1e-3;

/// GGX distribution of roughness `alpha > 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Ggx {
    pub alpha: f32,
}

impl Ggx {
    /// Normal distribution `D(h)` (per steradian of microfacet normals, projected area normalised).
    #[cfg(test)]
    #[inline]
    pub fn d(&self, h: Vec3) -> f32 {
        if h.z <= 0.0 {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        // cos²θ(α² − 1) + 1 written without cancellation near the pole.
        let t = h.x * h.x + h.y * h.y + a2 * h.z * h.z;
        a2 / (PI * t * t)
    }

    /// Smith `Λ(w)`, the masking auxiliary function.
    #[inline]
    pub fn lambda(&self, w: Vec3) -> f32 {
        if w.z == 0.0 {
            return f32::INFINITY;
        }
        let x = self.alpha * self.alpha * (w.x * w.x + w.y * w.y) / (w.z * w.z);
        // (√(1 + x) − 1) / 2 without cancellation for small x.
        x / (2.0 * (1.0 + (1.0 + x).sqrt()))
    }

    /// Smith masking `G1(w) = 1 / (1 + Λ(w))`.
    #[cfg(test)]
    #[inline]
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated masking-shadowing `G2(wo, wi)`.
    #[cfg(test)]
    #[inline]
    pub fn g2(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// Samples a microfacet normal from the distribution of normals visible from `wo`
    /// (`wo.z > 0`), Heitz 2018 "Sampling the GGX Distribution of Visible Normals".
    pub fn sample_visible_normal(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let a = self.alpha;
        let vh = Vec3::new(a * wo.x, a * wo.y, wo.z).normalize();
        let len2 = vh.x * vh.x + vh.y * vh.y;
        let t1 = if len2 > 0.0 { Vec3::new(-vh.y, vh.x, 0.0) / len2.sqrt() } else { Vec3::X };
        let t2 = vh.cross(t1);
        let r = u.x.sqrt();
        let (sin, cos) = (TAU * u.y).sin_cos();
        let p1 = r * cos;
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * sin;
        let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
        Vec3::new(a * nh.x, a * nh.y, nh.z.max(0.0)).normalize()
    }

    /// Density of reflected directions `wi = reflect(wo, h)` for `h` from
    /// [`sample_visible_normal`](Self::sample_visible_normal): `G1(wo) D(h) / (4 cos θo)`.
    #[cfg(test)]
    #[inline]
    pub fn reflection_pdf(&self, wo: Vec3, h: Vec3) -> f32 {
        self.g1(wo) * self.d(h) / (4.0 * wo.z)
    }

    /// Reflection BRDF without Fresnel, `D G2 / (4 cos θo cos θi)`, for `wo`, `wi` above the surface.
    #[cfg(test)]
    #[inline]
    pub fn reflection_eval(&self, wo: Vec3, wi: Vec3, h: Vec3) -> f32 {
        self.d(h) * self.g2(wo, wi) / (4.0 * wo.z * wi.z)
    }
}

/// Half vector of a reflection pair, `None` when degenerate (`wo = −wi`).
#[cfg(test)]
#[inline]
pub(crate) fn half_vector(wo: Vec3, wi: Vec3) -> Option<Vec3> {
    let h = wo + wi;
    let len2 = h.length_squared();
    if len2 > 0.0 {
        Some(h / len2.sqrt())
    } else {
        None
    }
}
