//! Materials as BSDFs: sample / eval / pdf in the local shading frame.
//!
//! # Conventions
//! Directions are in the shading frame (`z` = shading normal, see `sampling::Frame`); `wo` and `wi`
//! both point away from the surface (pbrt). [`Bsdf::eval`] excludes the `|cos θi|` factor.
//! Delta lobes (mirror, smooth glass, roughness-0 specular and clearcoat) never appear in `eval` or
//! `pdf`; [`Bsdf::sample`] returns them with `f` including `1/|cos θi|` and `pdf` equal to the
//! discrete probability of that choice, so `f·|cos θi|/pdf` is the path weight. When several delta
//! reflection lobes coincide (e.g. a smooth coat over a smooth metal) the sample carries their sum.
//!
//! **Sidedness.** Opaque lobes (Lambert, mirror, PreviewSurface reflection) are two-sided: for
//! `wo.z < 0` they act as if the normal were flipped toward `wo`, as most renderers do. Refractive
//! lobes use the true side: `wo.z > 0` is outside, entering a medium of relative IOR `eta`.
//! [`BsdfSample::eta`] is the relative IOR crossed (`eta` entering, `1/eta` leaving, 1 for reflection).
//! In [`TransportMode::Radiance`] refracted `f` is divided by `eta²` (radiance compression);
//! importance (photon) transport leaves it unscaled, so the BSDF is adjoint-correct in both modes.
//!
//! # UsdPreviewSurface model ([`Bsdf::from_preview_surface`])
//! Layered top to bottom, all lobes sharing the shading frame:
//! - **Clearcoat**: GGX with `α = clearcoatRoughness²`, white Schlick Fresnel with `F0` from `ior`
//!   (`((ior−1)/(ior+1))²`, 0.04 at the default 1.5; the spec says `ior` drives the clearcoat too),
//!   weight `clearcoat`. Everything under it is scaled by `1 − clearcoat·max(Ec(μo), Ec(μi))`, where
//!   `Ec` is the coat's directional albedo: symmetric (reciprocal) and never more than the light
//!   the coat let through, so energy is conserved for any base.
//! - **Specular**: GGX (Trowbridge-Reitz), height-correlated Smith `G2`, visible-normal sampling
//!   (Heitz 2018), generalised Schlick Fresnel `F0 + (F90 − F0)(1 − cos)⁵`. Metallic workflow (spec
//!   v2.5+): `F0 = lerp(((ior−1)/(ior+1))², diffuseColor, metallic)`,
//!   `F90 = lerp(1, diffuseColor, metallic)`. Specular workflow: `F0 = specularColor`, `F90 = 1`.
//!   A `specular_tint` (MaterialX's specular weight × colour; 1 for UsdPreviewSurface) scales the
//!   metallic workflow's dielectric `F0` and `F90` (the terms `lerp` starts from).
//!   Single-scattering GGX loses much energy when rough (a white metal of roughness 1 reflects only
//!   `1 − ln 2 ≈ 31%` at normal incidence), so the lobe carries Kulla & Conty's (2017) reciprocal
//!   multiple-scattering term (cosine-sampled, Fresnel-tinted): a white rough metal reflects 100%.
//! - **Diffuse**: Lambert with `ρ = (1 − metallic)·diffuseColor` (metallic workflow) or
//!   `diffuseColor` (specular workflow), weighted by what the specular layer does not reflect in the
//!   reciprocal, energy-conserving form of Kelemen & Szirmay-Kalos (2001):
//!   `ρ/π · (1 − Es(μo))(1 − Es(μi)) / (1 − Ēs)`, with `Es` the specular directional albedo
//!   (GGX albedo tables computed once per process, see `albedo.rs`) and `Ēs` its cosine-weighted
//!   average. A white diffuse base therefore makes the surface reflect exactly 100% (up to ~3e-3 of
//!   table interpolation) and every PreviewSurface has albedo ≤ 1 (white furnace).
//! - **Opacity** `< 1` (cut-outs are resolved upstream): the surface is `opacity ×` the opaque
//!   layers `+ (1 − opacity) ×` a smooth clear dielectric of `ior` (reflection + refraction,
//!   total internal reflection; the refracted light tinted by `transmission_color`, white for
//!   UsdPreviewSurface); `ior = 1` gives straight see-through transmission.
//!
//! Roughness → `α = roughness²`. Exactly 0 makes that lobe a perfect (delta) mirror with the same
//! Fresnel (and no multiple-scattering term, which vanishes there); any positive roughness is
//! clamped to `α ≥ 1e-3` (roughness ≈ 0.032): narrower GGX lobes are visually mirrors and lose f32
//! accuracy. The clamp only widens such lobes; nothing is dropped. The clearcoat has no
//! multiple-scattering term (it would be < 1% of its ≤ 10% albedo).
//! Non-finite or non-positive `ior` is replaced by the spec default 1.5; colours and scalars are
//! clamped to [0, 1] (NaN → 0). Lobe selection probabilities are proportional to each lobe's
//! albedo at `wo` (diffuse, single- and multiple-scattering specular, coat, glass), and
//! [`Bsdf::pdf`] is the matching mixture density. Lobes of zero weight are absent from
//! [`Bsdf::flags`] (e.g. no DIFFUSE for a pure metal).

mod albedo;
mod dielectric;
mod flags;
mod fresnel;
mod lobe;
mod microfacet;
mod preview;

#[cfg(test)]
mod tests;

pub use flags::BsdfFlags;
pub use lobe::AbMemo;
pub use preview::PreviewBsdf;

use glam::{Vec2, Vec3};

/// What a path carries, which decides the `eta²` scaling of refraction.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum TransportMode {
    /// Paths from the camera (radiance): refraction scales `f` by `1/eta²`.
    Radiance,
    /// Paths from lights (importance, photons): no scaling.
    Importance,
}

/// Result of [`Bsdf::sample`].
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Sampled incident direction (local frame).
    pub wi: Vec3,
    /// BSDF value (for delta lobes including `1/|cos θi|`).
    pub f: Vec3,
    /// Solid-angle density for non-delta lobes, discrete probability for delta lobes.
    pub pdf: f32,
    /// The sampled lobe: one of DIFFUSE/GLOSSY/SPECULAR with REFLECTION or TRANSMISSION.
    pub flags: BsdfFlags,
    /// Relative index of refraction crossed (1 for reflection).
    pub eta: f32,
}

impl BsdfSample {
    /// Whether the sample came from a delta lobe.
    pub fn is_specular(&self) -> bool {
        self.flags.is_specular()
    }

    /// Path throughput factor `f·|cos θi| / pdf` (`sample` never returns `pdf <= 0`).
    pub fn weight(&self) -> Vec3 {
        self.f * self.wi.z.abs() / self.pdf
    }
}

/// Resolved UsdPreviewSurface inputs (textures already looked up).
#[derive(Clone, Copy, Debug)]
pub struct SurfaceParams {
    /// `diffuseColor` (albedo in the metallic workflow).
    pub diffuse: Vec3,
    /// `specularColor` (F0 in the specular workflow).
    pub specular: Vec3,
    /// `useSpecularWorkflow`.
    pub use_specular_workflow: bool,
    /// `metallic` (metallic workflow only).
    pub metallic: f32,
    /// `roughness` (perceptual; `α = roughness²`).
    pub roughness: f32,
    /// `clearcoat` weight.
    pub clearcoat: f32,
    /// `clearcoatRoughness`.
    pub clearcoat_roughness: f32,
    /// `opacity` (non-cut-out transparency).
    pub opacity: f32,
    /// `ior`.
    pub ior: f32,
    /// Weight × colour of the dielectric specular reflection (metallic workflow; 1 for
    /// UsdPreviewSurface): scales its `F0` and `F90`.
    pub specular_tint: Vec3,
    /// Tint of the refracted light of the transparent part (white for UsdPreviewSurface).
    pub transmission_color: Vec3,
}

impl Default for SurfaceParams {
    /// The UsdPreviewSurface defaults of the spec.
    fn default() -> SurfaceParams {
        SurfaceParams {
            diffuse: Vec3::splat(0.18),
            specular: Vec3::ZERO,
            use_specular_workflow: false,
            metallic: 0.0,
            roughness: 0.5,
            clearcoat: 0.0,
            clearcoat_roughness: 0.01,
            opacity: 1.0,
            ior: 1.5,
            specular_tint: Vec3::ONE,
            transmission_color: Vec3::ONE,
        }
    }
}

#[cfg(test)]
impl SurfaceParams {
    /// For tests: an opaque UsdPreviewSurface without clearcoat, ior 1.5 — a coat of
    /// `specular` (or the metallic workflow's dielectric F0) and `roughness` over `diffuse`.
    pub(crate) fn coat(diffuse: Vec3, specular: Vec3, use_specular_workflow: bool, roughness: f32) -> SurfaceParams {
        SurfaceParams { diffuse, specular, use_specular_workflow, roughness, ..SurfaceParams::default() }
    }
}

/// A BSDF at one shading point. Small, `Copy`, no heap: built per hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bsdf {
    /// Two-sided Lambertian reflection.
    Lambert {
        /// Reflectance.
        albedo: Vec3,
    },
    /// Two-sided perfect mirror (no Fresnel).
    Mirror {
        /// Reflectance.
        reflectance: Vec3,
    },
    /// Smooth dielectric interface: Fresnel-weighted delta reflection and refraction.
    Dielectric {
        /// IOR inside / IOR outside.
        eta: f32,
        /// Transmittance multiplier (a thin stand-in for absorption); reflection stays white.
        tint: Vec3,
    },
    /// UsdPreviewSurface (see the module docs).
    Preview(PreviewBsdf),
}

impl Bsdf {
    /// Lambertian reflector of the given albedo.
    pub fn lambert(albedo: Vec3) -> Bsdf {
        Bsdf::Lambert { albedo }
    }

    /// Perfect mirror.
    pub fn mirror(reflectance: Vec3) -> Bsdf {
        Bsdf::Mirror { reflectance }
    }

    /// Smooth dielectric with relative IOR `ior` (non-finite or non-positive → 1.5) and
    /// transmission tint.
    pub fn dielectric(ior: f32, tint: Vec3) -> Bsdf {
        Bsdf::Dielectric { eta: fresnel::sanitize_ior(ior), tint }
    }

    /// Magenta Lambert: the visible error colour for unsupported shaders.
    pub fn error() -> Bsdf {
        Bsdf::lambert(Vec3::new(1.0, 0.0, 1.0))
    }

    /// The UsdPreviewSurface model (see the module docs).
    pub fn from_preview_surface(p: &SurfaceParams) -> Bsdf {
        Bsdf::Preview(PreviewBsdf::new(p))
    }

    /// Samples `wi` given `wo`: `uc` picks the lobe, `u` the direction. `None` when no direction
    /// results (e.g. `wo` in the tangent plane, or a microfacet reflection below the surface).
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        match self {
            Bsdf::Lambert { albedo } => dielectric::sample_lambert(*albedo, wo, u),
            Bsdf::Mirror { reflectance } => dielectric::sample_mirror(*reflectance, wo),
            Bsdf::Dielectric { eta, tint } => dielectric::sample_dielectric(*eta, *tint, wo, uc, mode),
            Bsdf::Preview(p) => p.sample(wo, uc, u, mode),
        }
    }

    /// BSDF value for the non-delta lobes, without the cosine. (`mode` only affects delta
    /// refraction, which `eval` never includes; it is part of the signature for symmetry.)
    pub fn eval(&self, wo: Vec3, wi: Vec3, _mode: TransportMode) -> Vec3 {
        match self {
            Bsdf::Lambert { albedo } => {
                if wo.z * wi.z > 0.0 {
                    *albedo * std::f32::consts::FRAC_1_PI
                } else {
                    Vec3::ZERO
                }
            }
            Bsdf::Mirror { .. } | Bsdf::Dielectric { .. } => Vec3::ZERO,
            Bsdf::Preview(p) => p.eval(wo, wi),
        }
    }

    /// The BSDF at a fixed `wo`, for evaluating many incident directions (photon splatting and
    /// density estimation at one eye sample): the per-`wo` work is done once here.
    #[inline]
    pub fn at(&self, wo: Vec3) -> BsdfAt {
        let ctx = match self {
            Bsdf::Preview(p) => p.context_for(wo),
            _ => None,
        };
        BsdfAt { bsdf: *self, wo, ctx }
    }

    /// [`eval`](Self::eval) and [`pdf`](Self::pdf) together, sharing the per-`wo` work (lobe
    /// albedos and selection probabilities), as next-event estimation with MIS needs both.
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> (Vec3, f32) {
        match self {
            Bsdf::Preview(p) => p.eval_pdf(wo, wi),
            _ => (self.eval(wo, wi, mode), self.pdf(wo, wi)),
        }
    }

    /// Solid-angle density with which [`sample`](Self::sample) produces `wi` through a non-delta lobe.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Bsdf::Lambert { .. } => {
                if wo.z * wi.z > 0.0 {
                    wi.z.abs() * std::f32::consts::FRAC_1_PI
                } else {
                    0.0
                }
            }
            Bsdf::Mirror { .. } | Bsdf::Dielectric { .. } => 0.0,
            Bsdf::Preview(p) => p.pdf(wo, wi),
        }
    }

    /// Union of the lobes present (lobes of zero weight are absent).
    pub fn flags(&self) -> BsdfFlags {
        let nonzero = |c: Vec3| c.max_element() > 0.0;
        match self {
            Bsdf::Lambert { albedo } if nonzero(*albedo) => BsdfFlags::DIFFUSE | BsdfFlags::REFLECTION,
            Bsdf::Mirror { reflectance } if nonzero(*reflectance) => BsdfFlags::SPECULAR | BsdfFlags::REFLECTION,
            Bsdf::Lambert { .. } | Bsdf::Mirror { .. } => BsdfFlags::EMPTY,
            Bsdf::Dielectric { .. } => BsdfFlags::SPECULAR | BsdfFlags::REFLECTION | BsdfFlags::TRANSMISSION,
            Bsdf::Preview(p) => p.flags(),
        }
    }

    /// Colour for the albedo AOV: the diffuse colour, the mirror reflectance, the glass tint, or for
    /// PreviewSurface the hemispherically averaged albedo of all layers.
    /// The BSDF as `kd ⊙ g + s` where the diffuse factor `kd` (which textures vary per texel) is
    /// the only part that depends on the diffuse colour: `(kd, the BSDF with kd = 0, with kd = 1)`,
    /// so that `f = f₀ + kd ⊙ (f₁ − f₀)`. `None` for BSDFs without such a diffuse layer.
    pub fn diffuse_split(&self) -> Option<(Vec3, Bsdf, Bsdf)> {
        match self {
            Bsdf::Preview(p) => Some((p.diffuse_factor(), Bsdf::Preview(p.with_diffuse_factor(Vec3::ZERO)), Bsdf::Preview(p.with_diffuse_factor(Vec3::ONE)))),
            _ => None,
        }
    }

    /// The `kd` of [`diffuse_split`](Self::diffuse_split) alone.
    pub fn diffuse_factor(&self) -> Option<Vec3> {
        match self {
            Bsdf::Preview(p) => Some(p.diffuse_factor()),
            _ => None,
        }
    }

    pub fn albedo(&self) -> Vec3 {
        match self {
            Bsdf::Lambert { albedo } => *albedo,
            Bsdf::Mirror { reflectance } => *reflectance,
            Bsdf::Dielectric { tint, .. } => *tint,
            Bsdf::Preview(p) => p.albedo(),
        }
    }
}

/// A BSDF with its outgoing direction fixed (see [`Bsdf::at`]).
#[derive(Clone, Copy, Debug)]
pub struct BsdfAt {
    bsdf: Bsdf,
    wo: Vec3,
    ctx: Option<preview::Context>,
}

impl BsdfAt {
    /// Same as `bsdf.eval(wo, wi, Radiance)`.
    #[inline]
    pub fn eval(&self, wi: Vec3) -> Vec3 {
        match (&self.bsdf, &self.ctx) {
            (Bsdf::Preview(p), Some(ctx)) => p.eval_with(ctx, self.wo, wi),
            (Bsdf::Preview(_), None) => Vec3::ZERO,
            (b, _) => b.eval(self.wo, wi, TransportMode::Radiance),
        }
    }

    /// [`eval`](Self::eval) with the albedo-table lookup at `wi` memoised across calls (the same
    /// value, bit for bit): for many evaluations at one `wi` on samples of one material.
    #[inline]
    pub fn eval_memo(&self, wi: Vec3, memo: &mut AbMemo) -> Vec3 {
        match (&self.bsdf, &self.ctx) {
            (Bsdf::Preview(p), Some(ctx)) => p.eval_with_memo(ctx, self.wo, wi, memo),
            _ => self.eval(wi),
        }
    }

    /// Same as `bsdf.eval_pdf(wo, wi, mode)`, without recomputing the per-`wo` work.
    #[inline]
    pub fn eval_pdf(&self, wi: Vec3, mode: TransportMode) -> (Vec3, f32) {
        match (&self.bsdf, &self.ctx) {
            (Bsdf::Preview(p), Some(ctx)) => p.eval_pdf_with(ctx, self.wo, wi),
            (Bsdf::Preview(_), None) => (Vec3::ZERO, 0.0),
            (b, _) => b.eval_pdf(self.wo, wi, mode),
        }
    }

    /// Same as `bsdf.sample(wo, uc, u, mode)`, without recomputing the per-`wo` work.
    #[inline]
    pub fn sample(&self, uc: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        match (&self.bsdf, &self.ctx) {
            (Bsdf::Preview(p), Some(ctx)) => p.sample_with(ctx, self.wo, uc, u, mode),
            (Bsdf::Preview(_), None) => None,
            (b, _) => b.sample(self.wo, uc, u, mode),
        }
    }

    pub fn bsdf(&self) -> &Bsdf {
        &self.bsdf
    }

    pub fn wo(&self) -> Vec3 {
        self.wo
    }
}
