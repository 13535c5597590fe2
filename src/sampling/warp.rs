//! Warps from the unit square to common domains, with their densities, and MIS weights.
//!
//! Directions are in a local frame with `z` up. Every warp maps `[0, 1)²` onto its domain with the
//! documented density (checked by chi-square tests in `sampling::tests`).

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, FRAC_PI_4, PI, TAU};

/// Density of [`square_to_uniform_sphere`] per steradian: `1 / 4π`.
pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);
/// Density of [`square_to_uniform_hemisphere`] per steradian: `1 / 2π`.
pub const UNIFORM_HEMISPHERE_PDF: f32 = 1.0 / (2.0 * PI);

/// Uniform point on the unit disk by Shirley & Chiu's concentric map (low distortion, keeps
/// stratification).
pub fn square_to_uniform_disk_concentric(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) =
        if o.x.abs() > o.y.abs() { (o.x, FRAC_PI_4 * (o.y / o.x)) } else { (o.y, FRAC_PI_2 - FRAC_PI_4 * (o.x / o.y)) };
    let (sin, cos) = theta.sin_cos();
    Vec2::new(r * cos, r * sin)
}

/// Cosine-weighted direction on the upper hemisphere (Malley's method on the concentric disk).
/// Density [`cosine_hemisphere_pdf`]`(z)`.
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = square_to_uniform_disk_concentric(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Density of [`square_to_cosine_hemisphere`] per steradian: `cos θ / π` for `cos θ > 0`, else 0.
#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    if cos_theta > 0.0 {
        cos_theta * FRAC_1_PI
    } else {
        0.0
    }
}

/// Uniform direction on the unit sphere; density [`UNIFORM_SPHERE_PDF`].
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin, cos) = (TAU * u.y).sin_cos();
    Vec3::new(r * cos, r * sin, z)
}

/// Uniform direction on the upper (`z ≥ 0`) hemisphere; density [`UNIFORM_HEMISPHERE_PDF`].
pub fn square_to_uniform_hemisphere(u: Vec2) -> Vec3 {
    let z = u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin, cos) = (TAU * u.y).sin_cos();
    Vec3::new(r * cos, r * sin, z)
}

/// Uniform point on a triangle as barycentrics `(b1, b2)` (the point is `(1−b1−b2)·p0 + b1·p1 +
/// b2·p2`), by Heitz's area-preserving low-distortion map (2019); density `1 / area`.
pub fn square_to_uniform_triangle(u: Vec2) -> (f32, f32) {
    let (b0, b1) = if u.x < u.y {
        let b0 = 0.5 * u.x;
        (b0, u.y - b0)
    } else {
        let b1 = 0.5 * u.y;
        (u.x - b1, b1)
    };
    (b1, (1.0 - b0 - b1).max(0.0))
}

/// Uniform direction inside the cone of half-angle `acos(cos_theta_max)` around `+z`;
/// density [`uniform_cone_pdf`]`(cos_theta_max)`.
pub fn square_to_uniform_cone(u: Vec2, cos_theta_max: f32) -> Vec3 {
    let z = (1.0 - u.x) + u.x * cos_theta_max;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin, cos) = (TAU * u.y).sin_cos();
    Vec3::new(r * cos, r * sin, z)
}

/// Density of [`square_to_uniform_cone`] per steradian: `1 / (2π (1 − cos θmax))`. Infinite for a
/// degenerate cone (`cos_theta_max ≥ 1`), which callers must treat as a delta direction.
#[inline]
pub fn uniform_cone_pdf(cos_theta_max: f32) -> f32 {
    let solid_angle = TAU * (1.0 - cos_theta_max);
    if solid_angle > 0.0 {
        1.0 / solid_angle
    } else {
        f32::INFINITY
    }
}

/// Veach's power heuristic (β = 2) weight of strategy `f` (taking `nf` samples with density `f_pdf`)
/// against strategy `g`. Returns 0 when both densities are 0 and 1 when `f`'s term overflows.
#[inline]
pub fn power_heuristic(nf: f32, f_pdf: f32, ng: f32, g_pdf: f32) -> f32 {
    let f = nf * f_pdf;
    let g = ng * g_pdf;
    let f2 = f * f;
    if f2.is_infinite() {
        return 1.0;
    }
    let denom = f2 + g * g;
    if denom > 0.0 {
        (f2 / denom).min(1.0)
    } else {
        0.0
    }
}
