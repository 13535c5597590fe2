//! UsdPreviewSurface: clearcoat over GGX specular over Kelemen-weighted Lambert, blended with a
//! smooth dielectric by opacity. The model is described in the module docs of `bsdf`.

use super::dielectric::{choose_glass_branch, refraction_sample};
use super::fresnel::{self, ior_to_f0, reflect_z, sanitize_ior, schlick};
use super::albedo::AlbedoTable;
use super::lobe::{roughness_to_alpha, AbMemo, SpecLobe};
use super::{BsdfFlags, BsdfSample, SurfaceParams, TransportMode};
use crate::sampling::square_to_cosine_hemisphere;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Resolved UsdPreviewSurface. Build it with [`super::Bsdf::from_preview_surface`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreviewBsdf {
    /// Diffuse reflectance `ρ`.
    rho: Vec3,
    /// `ρ / (π (1 − Ēs))`, the Kelemen-normalised diffuse factor.
    kd: Vec3,
    /// Specular lobe (with multiple-scattering compensation).
    spec: SpecLobe,
    /// Clearcoat GGX roughness (0: delta). (Its Fresnel at normal incidence follows from `eta`
    /// and its albedo-table coordinate from the roughness: both are derived where needed, which
    /// keeps `Bsdf` within 96 bytes.)
    coat_alpha: f32,
    /// Clearcoat weight.
    coat_weight: f32,
    opacity: f32,
    /// Relative IOR of the transmissive part.
    eta: f32,
    /// Tint of the light it refracts, in 16-bit fixed point (1 is 65535: exactly 1 again).
    transmission: [u16; 3],
}

/// Quantities that depend on `wo` only: lobe albedos, selection probabilities and the `wo`
/// factors of every lobe, so that evaluating a `wi` does only the `wi`-dependent work.
#[derive(Clone, Copy, Debug)]
pub struct Context {
    /// `wo` flipped to the upper hemisphere (opaque layers are two-sided).
    wo: Vec3,
    /// The `wo` factor of the specular compensation term ([`SpecLobe::ms_factor`]).
    ms_o: f32,
    /// Kelemen diffuse factor at `wo`: `kd·(1 − Es(μo))`.
    kd_o: Vec3,
    /// Smith `Λ(wo)` of the specular and clearcoat distributions.
    lambda_o: f32,
    coat_lambda_o: f32,
    /// Weighted clearcoat albedo `clearcoat·Ec(μo)`.
    ec_o: f32,
    /// Lobe probabilities, indexed by the constants below.
    prob: [f32; 5],
}

const GLASS: usize = 0;
const SPEC: usize = 1;
const SPEC_MS: usize = 2;
const COAT: usize = 3;
const DIFFUSE: usize = 4;

fn clamp01(x: f32) -> f32 {
    if x > 0.0 {
        x.min(1.0)
    } else {
        0.0
    }
}

/// The Kelemen-normalised diffuse factor `ρ / (π (1 − Ēs))` (zero where the specular lobe reflects
/// everything).
#[inline]
fn kelemen_kd(rho: Vec3, e_avg: Vec3) -> Vec3 {
    Vec3::select(e_avg.cmplt(Vec3::splat(1.0 - 1e-6)), rho * FRAC_1_PI / (Vec3::ONE - e_avg), Vec3::ZERO)
}

#[inline]
fn mean(c: Vec3) -> f32 {
    (c.x + c.y + c.z) * (1.0 / 3.0)
}

impl PreviewBsdf {
    /// Resolves the UsdPreviewSurface inputs (see the module docs of `bsdf`).
    pub fn new(p: &SurfaceParams) -> PreviewBsdf {
        let c01 = |c: Vec3| Vec3::new(clamp01(c.x), clamp01(c.y), clamp01(c.z));
        let ior = sanitize_ior(p.ior);
        let r0 = ior_to_f0(ior);
        let base = c01(p.diffuse);
        let (rho, f0, f90) = if p.use_specular_workflow {
            (base, c01(p.specular), Vec3::ONE)
        } else {
            let m = clamp01(p.metallic);
            let tint = c01(p.specular_tint);
            (base * (1.0 - m), (Vec3::splat(r0) * tint).lerp(base, m), tint.lerp(base, m))
        };
        let spec = SpecLobe::new(f0, f90, clamp01(p.roughness), true);
        let e_avg = spec.average_albedo();
        let kd = kelemen_kd(rho, e_avg);
        let coat_alpha = roughness_to_alpha(clamp01(p.clearcoat_roughness));
        PreviewBsdf {
            rho,
            kd,
            spec,
            coat_alpha,
            coat_weight: clamp01(p.clearcoat),
            opacity: clamp01(p.opacity),
            eta: ior,
            transmission: c01(p.transmission_color).to_array().map(|c| (c * 65535.0).round() as u16),
        }
    }

    /// The clearcoat lobe (kept as scalars to keep the BSDF small; no multiple-scattering term,
    /// which would be below 1% of its ≤ 10% albedo).
    #[inline]
    fn coat(&self) -> SpecLobe {
        SpecLobe::single_scattering(Vec3::splat(ior_to_f0(self.eta)), Vec3::ONE, self.coat_alpha, AlbedoTable::coordinate(self.coat_alpha))
    }

    fn has_diffuse(&self) -> bool {
        self.kd.max_element() > 0.0
    }

    fn has_coat(&self) -> bool {
        self.coat_weight > 0.0
    }

    /// Lobe albedos at `wo`, the selection probabilities derived from them and the lobes' `wo`
    /// factors.
    fn context(&self, wo: Vec3) -> Option<Context> {
        if wo.z == 0.0 || !wo.is_finite() {
            return None;
        }
        let wo = Vec3::new(wo.x, wo.y, wo.z.abs());
        let ab_o = self.spec.ab(wo.z);
        let es_o = self.spec.albedo(ab_o);
        let (ec_o, coat_lambda_o) = if self.has_coat() {
            let coat = self.coat();
            (self.coat_weight * mean(coat.albedo(coat.ab(wo.z))), coat.lambda(wo))
        } else {
            (0.0, 0.0)
        };
        let below_coat = self.opacity * (1.0 - ec_o);
        let mut w = [0.0f32; 5];
        w[GLASS] = 1.0 - self.opacity;
        w[SPEC] = below_coat * mean(self.spec.ss_albedo(ab_o));
        w[SPEC_MS] = below_coat * mean(self.spec.ms_albedo(ab_o));
        w[COAT] = self.opacity * ec_o;
        if self.has_diffuse() {
            w[DIFFUSE] = below_coat * mean(self.rho * (Vec3::ONE - es_o)).max(1e-4 * mean(self.rho));
        }
        let sum: f32 = w.iter().sum();
        if sum.is_nan() || sum <= 0.0 {
            return None;
        }
        Some(Context {
            wo,
            ms_o: self.spec.ms_factor(ab_o),
            kd_o: self.kd * (Vec3::ONE - es_o),
            lambda_o: self.spec.lambda(wo),
            coat_lambda_o,
            ec_o,
            prob: {
                let inv = 1.0 / sum;
                w.map(|x| x * inv)
            },
        })
    }

    /// `f_ss` (the single-scattering specular value) plus the lobes that do not depend on the
    /// half vector (compensation and diffuse), still un-coated, for `wi` above the surface.
    #[inline]
    fn add_smooth(&self, ctx: &Context, wi: Vec3, f_ss: Vec3) -> Vec3 {
        self.add_smooth_ab(ctx, self.spec.ab(wi.z), f_ss)
    }

    /// [`add_smooth`](Self::add_smooth) with the table values `ab_i` at `wi.z` given.
    #[inline]
    fn add_smooth_ab(&self, ctx: &Context, ab_i: [f32; 2], f_ss: Vec3) -> Vec3 {
        let mut f = f_ss + self.spec.eval_ms_with(ctx.ms_o, ab_i);
        if self.has_diffuse() {
            f += ctx.kd_o * (Vec3::ONE - self.spec.albedo(ab_i));
        }
        f
    }

    /// Sum of the non-delta lobes for `wo`, `wi` on the same side (flipped up in `ctx`).
    #[inline]
    fn eval_ctx(&self, ctx: &Context, wi: Vec3) -> Vec3 {
        self.eval_ctx_ab(ctx, wi, self.spec.ab(wi.z))
    }

    /// [`eval_ctx`](Self::eval_ctx) with the specular lobe's table values `ab_i` at `wi.z` given.
    #[inline]
    fn eval_ctx_ab(&self, ctx: &Context, wi: Vec3, ab_i: [f32; 2]) -> Vec3 {
        let wo = ctx.wo;
        let mut f = self.add_smooth_ab(ctx, ab_i, self.spec.eval_ss_with(wo, wi, ctx.lambda_o));
        if self.has_coat() {
            let coat = self.coat();
            let ec_i = self.coat_weight * mean(coat.albedo(coat.ab(wi.z)));
            f = f * (1.0 - ctx.ec_o.max(ec_i)) + self.coat_weight * coat.eval_ss_with(wo, wi, ctx.coat_lambda_o);
        }
        self.opacity * f
    }

    /// Mixture density of the non-delta lobes.
    fn pdf_ctx(&self, ctx: &Context, wi: Vec3) -> f32 {
        let p = &ctx.prob;
        let mut pdf = (p[DIFFUSE] + p[SPEC_MS]) * wi.z * FRAC_1_PI;
        if p[SPEC] > 0.0 {
            pdf += p[SPEC] * self.spec.pdf_ss_with(ctx.wo, wi, ctx.lambda_o);
        }
        if p[COAT] > 0.0 {
            pdf += p[COAT] * self.coat().pdf_ss_with(ctx.wo, wi, ctx.coat_lambda_o);
        }
        pdf
    }

    /// [`eval_ctx`](Self::eval_ctx) and [`pdf_ctx`](Self::pdf_ctx) together: each GGX lobe's half
    /// vector and `D(h)` computed once.
    #[inline]
    fn eval_pdf_ctx(&self, ctx: &Context, wi: Vec3) -> (Vec3, f32) {
        let (wo, p) = (ctx.wo, &ctx.prob);
        let (f_ss, pdf_ss) = self.spec.eval_pdf_ss(wo, wi, ctx.lambda_o);
        let mut f = self.add_smooth(ctx, wi, f_ss);
        let mut pdf = (p[DIFFUSE] + p[SPEC_MS]) * wi.z * FRAC_1_PI;
        if p[SPEC] > 0.0 {
            pdf += p[SPEC] * pdf_ss;
        }
        if self.has_coat() {
            let coat = self.coat();
            let ec_i = self.coat_weight * mean(coat.albedo(coat.ab(wi.z)));
            let (fc, pc) = coat.eval_pdf_ss(wo, wi, ctx.coat_lambda_o);
            f = f * (1.0 - ctx.ec_o.max(ec_i)) + self.coat_weight * fc;
            if p[COAT] > 0.0 {
                pdf += p[COAT] * pc;
            }
        }
        (self.opacity * f, pdf)
    }

    /// `wi` flipped to the upper hemisphere if `wo` and `wi` are on the same side, else `None`.
    fn same_side(wo: Vec3, wi: Vec3) -> Option<Vec3> {
        (wo.z * wi.z > 0.0).then(|| Vec3::new(wi.x, wi.y, wi.z.abs()))
    }

    /// See [`super::Bsdf::eval`].
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        match (Self::same_side(wo, wi), self.context(wo)) {
            (Some(wi), Some(ctx)) => self.eval_ctx(&ctx, wi),
            _ => Vec3::ZERO,
        }
    }

    /// The `wo`-dependent part of [`eval`](Self::eval), for many evaluations at one `wo`.
    pub fn context_for(&self, wo: Vec3) -> Option<Context> {
        self.context(wo)
    }

    /// [`eval`](Self::eval) with a context from [`context_for`](Self::context_for)`(wo)`.
    #[inline]
    pub fn eval_with(&self, ctx: &Context, wo: Vec3, wi: Vec3) -> Vec3 {
        match Self::same_side(wo, wi) {
            Some(wi) => self.eval_ctx(ctx, wi),
            None => Vec3::ZERO,
        }
    }

    /// [`eval_with`](Self::eval_with) with the specular table lookup at `wi` through `memo`
    /// (the same value, bit for bit).
    #[inline]
    pub fn eval_with_memo(&self, ctx: &Context, wo: Vec3, wi: Vec3, memo: &mut AbMemo) -> Vec3 {
        match Self::same_side(wo, wi) {
            Some(wi) => self.eval_ctx_ab(ctx, wi, self.spec.ab_memo(wi.z, memo)),
            None => Vec3::ZERO,
        }
    }

    /// See [`super::Bsdf::eval_pdf`].
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        match (Self::same_side(wo, wi), self.context(wo)) {
            (Some(wi), Some(ctx)) => self.eval_pdf_ctx(&ctx, wi),
            _ => (Vec3::ZERO, 0.0),
        }
    }

    /// [`eval_pdf`](Self::eval_pdf) with a context from [`context_for`](Self::context_for)`(wo)`.
    #[inline]
    pub fn eval_pdf_with(&self, ctx: &Context, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        match Self::same_side(wo, wi) {
            Some(wi) => self.eval_pdf_ctx(ctx, wi),
            None => (Vec3::ZERO, 0.0),
        }
    }

    /// See [`super::Bsdf::pdf`].
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match (Self::same_side(wo, wi), self.context(wo)) {
            (Some(wi), Some(ctx)) => self.pdf_ctx(&ctx, wi),
            _ => 0.0,
        }
    }

    /// See [`super::Bsdf::sample`].
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        self.sample_with(&self.context(wo)?, wo, uc, u, mode)
    }

    /// [`sample`](Self::sample) with a context from [`context_for`](Self::context_for)`(wo)`.
    #[inline]
    pub fn sample_with(&self, ctx: &Context, wo: Vec3, uc: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        let ctx = *ctx;
        let (mut lobe, mut start) = (DIFFUSE, 0.0);
        for (i, &p) in ctx.prob.iter().enumerate() {
            if p > 0.0 {
                lobe = i;
                if uc < start + p {
                    break;
                }
                start += p;
            }
        }
        let (flags, wi_up) = match lobe {
            GLASS => return self.sample_glass(&ctx, wo, ((uc - start) / ctx.prob[GLASS]).clamp(0.0, 1.0), mode),
            SPEC if self.spec.is_delta() => return self.delta_reflection(&ctx, wo),
            COAT if self.coat().is_delta() => return self.delta_reflection(&ctx, wo),
            SPEC => (BsdfFlags::GLOSSY, self.spec.sample_ss(ctx.wo, u)),
            COAT => (BsdfFlags::GLOSSY, self.coat().sample_ss(ctx.wo, u)),
            SPEC_MS => (BsdfFlags::GLOSSY, square_to_cosine_hemisphere(u)),
            _ => (BsdfFlags::DIFFUSE, square_to_cosine_hemisphere(u)),
        };
        if wi_up.z <= 0.0 {
            return None;
        }
        let (f, pdf) = self.eval_pdf_ctx(&ctx, wi_up);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        let wi = Vec3::new(wi_up.x, wi_up.y, wi_up.z.copysign(wo.z));
        Some(BsdfSample { wi, f, pdf, flags: flags | BsdfFlags::REFLECTION, eta: 1.0 })
    }

    /// The mirror direction with every delta reflection lobe that produces it: smooth specular,
    /// smooth clearcoat and the glass reflection (whichever of them sampling picked, the density
    /// and value of the direction are their sums).
    fn delta_reflection(&self, ctx: &Context, wo: Vec3) -> Option<BsdfSample> {
        let mu = ctx.wo.z;
        let glass_r = if ctx.prob[GLASS] > 0.0 { fresnel::dielectric(wo.z, self.eta) } else { 0.0 };
        let (mut f, mut pdf) = (Vec3::splat((1.0 - self.opacity) * glass_r), ctx.prob[GLASS] * glass_r);
        if self.spec.is_delta() && ctx.prob[SPEC] > 0.0 {
            f += self.opacity * (1.0 - ctx.ec_o) * schlick(self.spec.f0, self.spec.f90, mu);
            pdf += ctx.prob[SPEC];
        }
        let coat = self.coat();
        if coat.is_delta() && ctx.prob[COAT] > 0.0 {
            f += self.opacity * self.coat_weight * schlick(coat.f0, coat.f90, mu);
            pdf += ctx.prob[COAT];
        }
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi: reflect_z(wo),
            f: f / mu,
            pdf,
            flags: BsdfFlags::SPECULAR | BsdfFlags::REFLECTION,
            eta: 1.0,
        })
    }

    /// The transmissive part: Fresnel reflection (merged with the other delta reflections) or
    /// refraction through a smooth interface of IOR `eta`, using the true side of `wo`.
    fn sample_glass(&self, ctx: &Context, wo: Vec3, uc: f32, mode: TransportMode) -> Option<BsdfSample> {
        let branch = choose_glass_branch(self.eta, wo, uc);
        match branch.refracted {
            None => self.delta_reflection(ctx, wo),
            Some((wt, etap)) => {
                let t = 1.0 - branch.reflectance;
                refraction_sample(wt, etap, t, Vec3::splat(1.0 - self.opacity) * self.transmission(), ctx.prob[GLASS] * t, mode)
            }
        }
    }

    /// See [`super::Bsdf::flags`].
    pub fn flags(&self) -> BsdfFlags {
        let mut flags = BsdfFlags::EMPTY;
        let kind = |l: &SpecLobe| if l.is_delta() { BsdfFlags::SPECULAR } else { BsdfFlags::GLOSSY };
        if self.opacity > 0.0 {
            if self.has_diffuse() {
                flags |= BsdfFlags::DIFFUSE | BsdfFlags::REFLECTION;
            }
            if self.spec.present() {
                flags |= kind(&self.spec) | BsdfFlags::REFLECTION;
            }
            if self.has_coat() {
                flags |= kind(&self.coat()) | BsdfFlags::REFLECTION;
            }
        }
        if self.opacity < 1.0 {
            flags |= BsdfFlags::SPECULAR | BsdfFlags::REFLECTION | BsdfFlags::TRANSMISSION;
        }
        flags
    }

    /// This BSDF with diffuse colour `base` (before clamping), for a BSDF built by [`new`](Self::new)
    /// in the specular workflow or with metallic 0, where no other lobe depends on the diffuse
    /// colour: equal, bit for bit, to `new` with that diffuse colour, without re-deriving the
    /// specular and clearcoat lobes.
    pub fn with_diffuse(&self, base: Vec3) -> PreviewBsdf {
        let rho = Vec3::new(clamp01(base.x), clamp01(base.y), clamp01(base.z));
        let e_avg = self.spec.average_albedo();
        let kd = kelemen_kd(rho, e_avg);
        PreviewBsdf { rho, kd, ..*self }
    }

    /// The Kelemen diffuse factor `kd`: the BSDF is `kd ⊙ g + s` with `g` and `s` independent of it
    /// (the diffuse term `kd·(1 − Es(μo))·(1 − Es(μi))`, scaled like every opaque lobe by the
    /// clearcoat and opacity).
    pub fn diffuse_factor(&self) -> Vec3 {
        self.kd
    }

    /// This BSDF with the diffuse factor `kd` (and no diffuse reflectance for sampling or albedo:
    /// only its evaluation is meant).
    pub fn with_diffuse_factor(&self, kd: Vec3) -> PreviewBsdf {
        PreviewBsdf { kd, rho: Vec3::ZERO, ..*self }
    }

    /// Whether `other` equals this BSDF up to the diffuse layer (`kd` and `ρ`): the same as
    /// comparing both [`with_diffuse_factor`](Self::with_diffuse_factor)`(0)`, without the copies.
    pub fn same_but_diffuse(&self, other: &PreviewBsdf) -> bool {
        self.spec == other.spec
            && self.coat_alpha == other.coat_alpha
            && self.coat_weight == other.coat_weight
            && self.opacity == other.opacity
            && self.eta == other.eta
            && self.transmission == other.transmission
    }

    /// Hemispherically averaged albedo of all layers (the glass part counts as its transmission
    /// colour).
    pub fn albedo(&self) -> Vec3 {
        self.albedo_with(self.layer_albedos())
    }

    /// The averaged albedos `(Ēs, clearcoat·Ēc)` of the specular and clearcoat layers, which
    /// [`with_diffuse`](Self::with_diffuse) keeps.
    pub fn layer_albedos(&self) -> (Vec3, f32) {
        let es = self.spec.average_albedo();
        let ec = if self.has_coat() { self.coat_weight * mean(self.coat().average_albedo()) } else { 0.0 };
        (es, ec)
    }

    /// [`albedo`](Self::albedo) with [`layer_albedos`](Self::layer_albedos) given.
    #[inline]
    pub fn albedo_with(&self, (es, ec): (Vec3, f32)) -> Vec3 {
        let opaque = (1.0 - ec) * (es + self.rho * (Vec3::ONE - es)) + Vec3::splat(ec);
        self.opacity * opaque + Vec3::splat(1.0 - self.opacity) * self.transmission()
    }

    /// The transmission tint.
    #[inline]
    fn transmission(&self) -> Vec3 {
        Vec3::from(self.transmission.map(|c| c as f32 / 65535.0))
    }
}
