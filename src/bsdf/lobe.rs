//! A GGX specular reflection lobe with generalised Schlick Fresnel and optional Kulla-Conty
//! multiple-scattering compensation; roughness 0 makes it a delta mirror.

use super::albedo::{albedo_table, AlbedoTable};
use super::fresnel::{reflect, schlick, schlick_weight};
#[cfg(test)]
use super::microfacet::half_vector;
use super::microfacet::{Ggx, ALPHA_MIN};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// `2∫(1 − μ)⁵ μ dμ`: the cosine-weighted average of the Schlick weight.
const SCHLICK_AVG: f32 = 1.0 / 21.0;

/// GGX `α` for a perceptual roughness in [0, 1]: 0 (delta) stays 0, otherwise `max(r², ALPHA_MIN)`.
pub(crate) fn roughness_to_alpha(roughness: f32) -> f32 {
    if roughness > 0.0 {
        (roughness * roughness).max(ALPHA_MIN)
    } else {
        0.0
    }
}

/// Specular lobe `F·D·G2 / (4 cos θo cos θi)` plus, when enabled, the Kulla-Conty (2017) term
/// `f_ms (1 − E₁(μo))(1 − E₁(μi)) / (π (1 − Ē₁))` that restores the energy single scattering loses
/// (`E₁` is the albedo with `F = 1`; `f_ms = F̄² Ē₁ / (1 − F̄ (1 − Ē₁))` tints it with the average
/// Fresnel `F̄`). With the compensation a white rough metal reflects everything it receives.
///
/// Albedo queries take the table pair `ab = (A, B)` at a given `μ` (see `albedo.rs`), so callers
/// look each direction up once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SpecLobe {
    pub f0: Vec3,
    pub f90: Vec3,
    /// GGX roughness; 0 for the delta lobe.
    pub alpha: f32,
    /// Albedo-table coordinate of `alpha`.
    tc: f32,
    /// Multiple-scattering colour `f_ms` (zero when disabled or for the delta lobe).
    f_ms: Vec3,
}

/// The last albedo-table lookup `(A, B)(μ, roughness)` of a series of BSDF evaluations (see
/// [`SpecLobe::ab_memo`]). When one photon ray is splatted onto the eye samples of a flat surface
/// of one material, every evaluation has the same `μ = cos θi` and roughness.
#[derive(Clone, Copy, Debug, Default)]
pub struct AbMemo {
    valid: bool,
    mu: f32,
    tc: f32,
    ab: [f32; 2],
}

impl SpecLobe {
    /// Lobe of perceptual roughness `roughness ∈ [0, 1]`.
    pub fn new(f0: Vec3, f90: Vec3, roughness: f32, multiscatter: bool) -> SpecLobe {
        let alpha = roughness_to_alpha(roughness);
        let tc = AlbedoTable::coordinate(alpha);
        let mut f_ms = Vec3::ZERO;
        if multiscatter && alpha > 0.0 {
            let [a, b] = albedo_table().average(tc);
            let e1 = a + b;
            if e1 < 1.0 - 1e-4 {
                let f_avg = f0 * (1.0 - SCHLICK_AVG) + f90 * SCHLICK_AVG;
                f_ms = f_avg * f_avg * e1 / (Vec3::ONE - f_avg * (1.0 - e1));
            }
        }
        SpecLobe { f0, f90, alpha, tc, f_ms }
    }

    /// Lobe without multiple-scattering compensation from a precomputed `alpha` (from
    /// [`roughness_to_alpha`]) and its table coordinate: the same lobe as `new(.., false)` without
    /// the logarithm.
    #[inline]
    pub fn single_scattering(f0: Vec3, f90: Vec3, alpha: f32, tc: f32) -> SpecLobe {
        SpecLobe { f0, f90, alpha, tc, f_ms: Vec3::ZERO }
    }

    #[inline]
    pub fn is_delta(&self) -> bool {
        self.alpha == 0.0
    }

    /// Whether the lobe reflects anything.
    pub fn present(&self) -> bool {
        self.f0.max_element() > 0.0 || self.f90.max_element() > 0.0
    }

    fn ggx(&self) -> Ggx {
        Ggx { alpha: self.alpha }
    }

    /// Table values `(A, B)` at `μ` (exact Schlick integrals for the delta lobe).
    #[inline]
    pub fn ab(&self, mu: f32) -> [f32; 2] {
        if self.is_delta() {
            let s = schlick_weight(mu);
            [1.0 - s, s]
        } else {
            albedo_table().lookup(mu, self.tc)
        }
    }

    /// [`ab`](Self::ab) through `memo`: the table is looked up only when `μ` or the roughness
    /// differs (bit for bit) from the last lookup, so the result is always that of `ab`.
    #[inline]
    pub fn ab_memo(&self, mu: f32, memo: &mut AbMemo) -> [f32; 2] {
        if self.is_delta() {
            return self.ab(mu);
        }
        if memo.valid && memo.mu.to_bits() == mu.to_bits() && memo.tc.to_bits() == self.tc.to_bits() {
            return memo.ab;
        }
        let ab = albedo_table().lookup(mu, self.tc);
        *memo = AbMemo { valid: true, mu, tc: self.tc, ab };
        ab
    }

    /// Single-scattering directional albedo.
    #[inline]
    pub fn ss_albedo(&self, [a, b]: [f32; 2]) -> Vec3 {
        self.f0 * a + self.f90 * b
    }

    /// Directional albedo of the compensation term.
    #[inline]
    pub fn ms_albedo(&self, [a, b]: [f32; 2]) -> Vec3 {
        self.f_ms * (1.0 - a - b).max(0.0)
    }

    /// Total directional albedo `E(μ)`.
    #[inline]
    pub fn albedo(&self, ab: [f32; 2]) -> Vec3 {
        self.ss_albedo(ab) + self.ms_albedo(ab)
    }

    /// Cosine-weighted average `Ē` of [`albedo`](Self::albedo), consistent with the table.
    pub fn average_albedo(&self) -> Vec3 {
        let ab = if self.is_delta() { [1.0 - SCHLICK_AVG, SCHLICK_AVG] } else { albedo_table().average(self.tc) };
        self.albedo(ab)
    }

    /// Single-scattering BRDF for `wo`, `wi` above the surface (zero for the delta lobe): the
    /// reference form, which the tests compare the fused evaluations below against.
    #[cfg(test)]
    pub fn eval_ss(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        match half_vector(wo, wi) {
            Some(h) if !self.is_delta() => {
                schlick(self.f0, self.f90, wo.dot(h)) * self.ggx().reflection_eval(wo, wi, h)
            }
            _ => Vec3::ZERO,
        }
    }

    /// The GGX terms of a reflection pair with `Λ(wo)` given, each with a single division:
    /// `(cos θoh, pdf, G2/(G1(wo)·cos θi))`, so that `pdf = G1(wo)·D(h)/(4 cos θo)` and the BRDF is
    /// `F(cos θoh)·pdf·G2/(G1(wo) cos θi) = F·D·G2/(4 cos θo cos θi)`. With `u = wo + wi` unnormalised,
    /// `D(h) = α²|u|⁴ / (π (uₓ² + u_y² + α²u_z²)²)` and `Λ(wi) = N/M` with `N = α²(wiₓ² + wi_y²)`,
    /// `M = 2 cos θi (cos θi + √(cos²θi + N))`, so `G2 = M / (M(1 + Λ(wo)) + N)`. `None` for the
    /// delta lobe and degenerate pairs (`wo = −wi`, or `h` not above the surface: `D = 0`).
    #[inline(always)]
    fn ggx_terms(&self, wo: Vec3, wi: Vec3, lambda_o: f32) -> Option<(f32, f32, f32)> {
        let u = wo + wi;
        let len2 = u.length_squared();
        if self.is_delta() || !(len2 > 0.0) || u.z <= 0.0 {
            return None;
        }
        let a2 = self.alpha * self.alpha;
        let g1_inv = 1.0 + lambda_o;
        let tu = u.x * u.x + u.y * u.y + a2 * u.z * u.z;
        let pdf = a2 * len2 * len2 / (PI * tu * tu * (4.0 * wo.z) * g1_inv);
        let n = a2 * (wi.x * wi.x + wi.y * wi.y);
        let z = wi.z;
        let m = 2.0 * z * (z + (z * z + n).sqrt());
        let g = m * g1_inv / ((m * g1_inv + n) * z);
        Some((wo.dot(u) / len2.sqrt(), pdf, g))
    }

    /// Single-scattering BRDF with `Λ(wo)` given (computed once per outgoing direction); equal
    /// to [`eval_ss`](Self::eval_ss) up to float rounding.
    #[inline]
    pub fn eval_ss_with(&self, wo: Vec3, wi: Vec3, lambda_o: f32) -> Vec3 {
        match self.ggx_terms(wo, wi, lambda_o) {
            Some((c, pdf, g)) => schlick(self.f0, self.f90, c) * (pdf * g),
            None => Vec3::ZERO,
        }
    }

    /// [`eval_ss_with`](Self::eval_ss_with) and [`pdf_ss_with`](Self::pdf_ss_with) together,
    /// sharing the half vector and `D(h)`.
    #[inline]
    pub fn eval_pdf_ss(&self, wo: Vec3, wi: Vec3, lambda_o: f32) -> (Vec3, f32) {
        match self.ggx_terms(wo, wi, lambda_o) {
            Some((c, pdf, g)) => (schlick(self.f0, self.f90, c) * (pdf * g), pdf),
            None => (Vec3::ZERO, 0.0),
        }
    }

    /// Density of [`sample_ss`](Self::sample_ss) with `Λ(wo)` given; equal to
    /// [`pdf_ss`](Self::pdf_ss) up to float rounding.
    #[inline]
    pub fn pdf_ss_with(&self, wo: Vec3, wi: Vec3, lambda_o: f32) -> f32 {
        let u = wo + wi;
        let len2 = u.length_squared();
        if self.is_delta() || !(len2 > 0.0) || u.z <= 0.0 {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        let tu = u.x * u.x + u.y * u.y + a2 * u.z * u.z;
        a2 * len2 * len2 / (PI * tu * tu * (4.0 * wo.z) * (1.0 + lambda_o))
    }

    /// `Λ(wo)` of the lobe's distribution (infinite for the delta lobe, where it is unused).
    #[inline]
    pub fn lambda(&self, wo: Vec3) -> f32 {
        self.ggx().lambda(wo)
    }

    /// The factor `1/(π(1 − Ē₁)) · (1 − E₁(μo))` of the compensation BRDF that depends on `wo`
    /// only; [`eval_ms_with`](Self::eval_ms_with) completes it.
    #[inline]
    pub fn ms_factor(&self, [ao, bo]: [f32; 2]) -> f32 {
        if self.f_ms == Vec3::ZERO {
            return 0.0;
        }
        let [a, b] = albedo_table().average(self.tc);
        let norm = 1.0 / (PI * (1.0 - a - b));
        norm * (1.0 - ao - bo).max(0.0)
    }

    /// Compensation BRDF from [`ms_factor`](Self::ms_factor) at `wo` and the table values at `wi`
    /// (equal to [`eval_ms`](Self::eval_ms), bit for bit).
    #[inline]
    pub fn eval_ms_with(&self, ms_o: f32, [ai, bi]: [f32; 2]) -> Vec3 {
        if self.f_ms == Vec3::ZERO {
            return Vec3::ZERO;
        }
        self.f_ms * (ms_o * (1.0 - ai - bi).max(0.0))
    }

    /// Compensation BRDF from the table values at `wo` and `wi` (a cosine-sampled lobe).
    #[cfg(test)]
    pub fn eval_ms(&self, [ao, bo]: [f32; 2], [ai, bi]: [f32; 2]) -> Vec3 {
        if self.f_ms == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let [a, b] = albedo_table().average(self.tc);
        let norm = 1.0 / (PI * (1.0 - a - b));
        self.f_ms * (norm * (1.0 - ao - bo).max(0.0) * (1.0 - ai - bi).max(0.0))
    }

    /// Density of [`sample_ss`](Self::sample_ss) (zero for the delta lobe): the reference form.
    #[cfg(test)]
    pub fn pdf_ss(&self, wo: Vec3, wi: Vec3) -> f32 {
        match half_vector(wo, wi) {
            Some(h) if !self.is_delta() => self.ggx().reflection_pdf(wo, h),
            _ => 0.0,
        }
    }

    /// Reflects `wo` about a visible normal (Heitz 2018); the result may point below the surface.
    pub fn sample_ss(&self, wo: Vec3, u: Vec2) -> Vec3 {
        reflect(wo, self.ggx().sample_visible_normal(wo, u))
    }
}
