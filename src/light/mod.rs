//! Emitters at render time: UsdLux lights (rect, disk, sphere/spot, distant, dome) and emissive
//! triangles, with sampling toward a point (`sample_li`, for next-event estimation), the matching
//! solid-angle pdf (`pdf_li`, for MIS), ray intersection of the analytic lights (they are not Embree
//! geometry), emission sampling for photons (`sample_le`), and a power-proportional light sampler.
//!
//! Conventions: rect and disk lights emit from their front face (local −Z); sphere lights emit
//! outward, shaped by an optional spot cone around local −Z; a distant light of apex angle 0 is a
//! delta light; the dome's lat-long texture follows OpenEXR: local +Y is the top row, local +Z the
//! image centre, longitude decreasing to the right.

mod set;
mod silhouette;
pub use set::LightSet;
pub use silhouette::SceneBox;

use crate::image::Texture;
use std::sync::Arc;
use crate::sampling::{self, Frame};
use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::PI;

/// A sample of incident light at a point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Direction toward the light (normalised).
    pub wi: Vec3,
    /// Distance to the sampled point (`f32::INFINITY` for distant and dome lights).
    pub dist: f32,
    /// Radiance arriving along `-wi` (for delta lights: irradiance-like quantity, weight 1/pdf=1).
    pub li: Vec3,
    /// Solid-angle pdf (1 for delta lights).
    pub pdf: f32,
    pub delta: bool,
}

/// A sampled emission (photon origin) of a light.
#[derive(Clone, Copy, Debug)]
pub struct EmissionSample {
    pub pos: Vec3,
    pub dir: Vec3,
    /// Flux carried by the photon: `Le·|cos| / (pdf_pos·pdf_dir)`.
    pub weight: Vec3,
    /// Area density of `pos` (1/m²).
    pub pdf_pos: f32,
    /// Density of `dir` per projected solid angle (1 for a delta direction).
    pub pdf_dir: f32,
}

/// Spot-light shaping (UsdLuxShapingAPI): smoothstep between the outer and inner cone, times a
/// cosine power (`focus`).
#[derive(Clone, Copy, Debug)]
pub struct Spot {
    pub axis: Vec3,
    pub cos_outer: f32,
    pub cos_inner: f32,
    pub focus: f32,
}

impl Spot {
    pub fn falloff(&self, dir: Vec3) -> f32 {
        let c = dir.dot(self.axis);
        if c <= self.cos_outer {
            return 0.0;
        }
        let s = if self.cos_inner > self.cos_outer {
            let t = ((c - self.cos_outer) / (self.cos_inner - self.cos_outer)).clamp(0.0, 1.0);
            t * t * (3.0 - 2.0 * t)
        } else {
            1.0
        };
        if self.focus > 0.0 {
            s * c.max(0.0).powf(self.focus)
        } else {
            s
        }
    }
}

/// One emitter, in world space.
#[derive(Clone, Debug)]
pub enum Emitter {
    /// Parallelogram `corner + a·ex + b·ey`, a, b ∈ [0,1], emitting along `n`.
    Rect { corner: Vec3, ex: Vec3, ey: Vec3, n: Vec3, area: f32, radiance: Vec3, two_sided: bool },
    Disk { center: Vec3, frame: Frame, radius: f32, area: f32, radiance: Vec3 },
    Sphere { center: Vec3, radius: f32, radiance: Vec3, spot: Option<Spot> },
    /// `dir` is the direction light travels; `cos_max` the cosine of the half apex angle (1 → delta).
    Distant { dir: Vec3, cos_max: f32, irradiance: Vec3, radiance: Vec3, frame: Frame },
    Dome { to_local: Mat3, radiance: Vec3, texture: Option<usize>, dist: Option<sampling::Distribution2D> },
    /// Emissive triangle of a mesh (world-space vertices).
    Triangle { p: [Vec3; 3], n: Vec3, area: f32, radiance: Vec3, two_sided: bool },
}

impl Emitter {
    pub fn is_delta(&self) -> bool {
        matches!(self, Emitter::Distant { cos_max, .. } if *cos_max >= 1.0)
    }

    pub fn is_infinite(&self) -> bool {
        matches!(self, Emitter::Distant { .. } | Emitter::Dome { .. })
    }

    /// Radiance leaving a point of an area emitter with normal `n` toward `w` (outgoing).
    fn area_le(radiance: Vec3, n: Vec3, two_sided: bool, w: Vec3) -> Vec3 {
        let c = n.dot(w);
        if c > 0.0 || (two_sided && c < 0.0) {
            radiance
        } else {
            Vec3::ZERO
        }
    }

    /// Radiance arriving at `origin` along direction `-wi` from the infinite lights (escaped rays).
    pub fn le_infinite(&self, wi: Vec3, textures: &[Arc<Texture>]) -> Vec3 {
        match self {
            Emitter::Distant { dir, cos_max, radiance, .. } if *cos_max < 1.0 => {
                if (-*dir).dot(wi) >= *cos_max {
                    *radiance
                } else {
                    Vec3::ZERO
                }
            }
            Emitter::Dome { to_local, radiance, texture, .. } => {
                let d = *to_local * wi;
                match texture {
                    Some(t) => *radiance * textures[*t].eval_rgb(dome_uv(d)),
                    None => *radiance,
                }
            }
            _ => Vec3::ZERO,
        }
    }

    /// Intersect a ray with an analytic area emitter; returns (t, radiance toward the ray origin),
    /// `None` where the ray misses it or meets a one-sided light from behind (no radiance).
    /// Inlined for the rect light (a path tracer tests every ray against every analytic light, and
    /// most rays leave at the first comparison); the other shapes are a call.
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, tmax: f32) -> Option<(f32, Vec3)> {
        match self {
            Emitter::Rect { corner, ex, ey, n, radiance, two_sided, .. } => {
                let denom = n.dot(d);
                // (a one-sided light seen from behind emits nothing toward the ray: no test)
                if denom.abs() < 1e-12 || (!*two_sided && denom >= 0.0) {
                    return None;
                }
                let t = n.dot(*corner - o) / denom;
                if !(t > 0.0 && t < tmax) {
                    return None;
                }
                let q = o + d * t - *corner;
                let a = q.dot(*ex) / ex.length_squared();
                let b = q.dot(*ey) / ey.length_squared();
                if !(0.0..=1.0).contains(&a) || !(0.0..=1.0).contains(&b) {
                    return None;
                }
                Some((t, Self::area_le(*radiance, *n, *two_sided, -d)))
            }
            _ => self.intersect_curved(o, d, tmax),
        }
    }

    /// [`intersect`](Self::intersect) for the disk and sphere lights.
    #[inline(never)]
    fn intersect_curved(&self, o: Vec3, d: Vec3, tmax: f32) -> Option<(f32, Vec3)> {
        match self {
            Emitter::Disk { center, frame, radius, radiance, .. } => {
                let denom = frame.n.dot(d);
                if denom.abs() < 1e-12 || denom >= 0.0 {
                    return None;
                }
                let t = frame.n.dot(*center - o) / denom;
                if !(t > 0.0 && t < tmax) || (o + d * t - *center).length_squared() > radius * radius {
                    return None;
                }
                Some((t, Self::area_le(*radiance, frame.n, false, -d)))
            }
            Emitter::Sphere { center, radius, radiance, spot } => {
                let oc = o - *center;
                let b = oc.dot(d);
                let c = oc.length_squared() - radius * radius;
                let disc = b * b - c;
                if disc < 0.0 {
                    return None;
                }
                let sq = disc.sqrt();
                let t = if -b - sq > 0.0 { -b - sq } else { -b + sq };
                if !(t > 0.0 && t < tmax) || c < 0.0 {
                    return None; // rays from inside the light see nothing (lights are not geometry)
                }
                let w = -d;
                let le = spot.map_or(1.0, |s| s.falloff(w));
                Some((t, *radiance * le))
            }
            _ => None,
        }
    }

    /// Sample a direction toward the emitter from `p`.
    pub fn sample_li(&self, p: Vec3, u: Vec2, textures: &[Arc<Texture>]) -> Option<LightSample> {
        // a point `q` on a surface emitter with normal `nq`: the direction toward it, normalised
        // once, also decides which side of the emitter `p` sees
        let area_sample = |q: Vec3, nq: Vec3, area: f32, radiance: Vec3, two_sided: bool| -> Option<LightSample> {
            let d = q - p;
            let dist2 = d.length_squared();
            if dist2 <= 0.0 {
                return None;
            }
            let dist = dist2.sqrt();
            let wi = d / dist;
            let le = Self::area_le(radiance, nq, two_sided, -wi);
            let cos = nq.dot(-wi).abs();
            if cos <= 1e-8 || le == Vec3::ZERO {
                return None;
            }
            Some(LightSample { wi, dist, li: le, pdf: dist2 / (cos * area), delta: false })
        };
        match self {
            Emitter::Rect { corner, ex, ey, n, area, radiance, two_sided } => {
                let q = *corner + *ex * u.x + *ey * u.y;
                area_sample(q, *n, *area, *radiance, *two_sided)
            }
            Emitter::Disk { center, frame, radius, area, radiance } => {
                let d = sampling::square_to_uniform_disk_concentric(u) * *radius;
                let q = *center + frame.s * d.x + frame.t * d.y;
                area_sample(q, frame.n, *area, *radiance, false)
            }
            Emitter::Triangle { p: v, n, area, radiance, two_sided } => {
                let (b1, b2) = sampling::square_to_uniform_triangle(u);
                let q = v[0] * (1.0 - b1 - b2) + v[1] * b1 + v[2] * b2;
                area_sample(q, *n, *area, *radiance, *two_sided)
            }
            Emitter::Sphere { center, radius, radiance, spot } => {
                let to_c = *center - p;
                let dc2 = to_c.length_squared();
                if dc2 <= radius * radius {
                    return None;
                }
                let dc = dc2.sqrt();
                let sin2 = (radius * radius / dc2).min(1.0);
                let cos_max = (1.0 - sin2).max(0.0).sqrt();
                let frame = Frame::from_normal(to_c / dc);
                let wi = frame.to_world(sampling::square_to_uniform_cone(u, cos_max));
                // distance to the sphere along wi
                let b = -to_c.dot(wi);
                let c = dc2 - radius * radius;
                let disc = (b * b - c).max(0.0);
                let t = (-b - disc.sqrt()).max(0.0);
                let le = spot.map_or(1.0, |s| s.falloff(-wi));
                if le <= 0.0 {
                    return None;
                }
                Some(LightSample { wi, dist: t, li: *radiance * le, pdf: sampling::uniform_cone_pdf(cos_max), delta: false })
            }
            Emitter::Distant { dir, cos_max, irradiance, radiance, frame } => {
                if *cos_max >= 1.0 {
                    Some(LightSample { wi: -*dir, dist: f32::INFINITY, li: *irradiance, pdf: 1.0, delta: true })
                } else {
                    let wi = frame.to_world(sampling::square_to_uniform_cone(u, *cos_max));
                    Some(LightSample {
                        wi,
                        dist: f32::INFINITY,
                        li: *radiance,
                        pdf: sampling::uniform_cone_pdf(*cos_max),
                        delta: false,
                    })
                }
            }
            Emitter::Dome { to_local, radiance, texture, dist } => {
                let (wl, pdf) = match dist {
                    Some(d) => {
                        let (uv, pdf_uv) = d.sample(u);
                        let (w, jac) = dome_dir(uv);
                        if jac <= 0.0 {
                            return None;
                        }
                        (w, pdf_uv / jac)
                    }
                    None => (sampling::square_to_uniform_sphere(u), sampling::UNIFORM_SPHERE_PDF),
                };
                let wi = to_local.transpose() * wl;
                let li = match texture {
                    Some(t) => *radiance * textures[*t].eval_rgb(dome_uv(wl)),
                    None => *radiance,
                };
                if pdf <= 0.0 {
                    return None;
                }
                Some(LightSample { wi, dist: f32::INFINITY, li, pdf, delta: false })
            }
        }
    }

    /// Solid-angle pdf with which `sample_li` from `p` produces direction `wi`, given that the ray hits
    /// this emitter at distance `t` (ignored for infinite lights).
    pub fn pdf_li(&self, p: Vec3, wi: Vec3, t: f32) -> f32 {
        let area_pdf = |n: Vec3, area: f32| {
            let cos = n.dot(wi).abs();
            if cos <= 1e-8 {
                0.0
            } else {
                t * t / (cos * area)
            }
        };
        match self {
            Emitter::Rect { n, area, .. } | Emitter::Triangle { n, area, .. } => area_pdf(*n, *area),
            Emitter::Disk { frame, area, .. } => area_pdf(frame.n, *area),
            Emitter::Sphere { center, radius, .. } => {
                let dc2 = (*center - p).length_squared();
                if dc2 <= radius * radius {
                    return 0.0;
                }
                let cos_max = (1.0 - radius * radius / dc2).max(0.0).sqrt();
                sampling::uniform_cone_pdf(cos_max)
            }
            Emitter::Distant { dir, cos_max, .. } => {
                if *cos_max >= 1.0 || (-*dir).dot(wi) < *cos_max {
                    0.0
                } else {
                    sampling::uniform_cone_pdf(*cos_max)
                }
            }
            Emitter::Dome { to_local, dist, .. } => {
                let wl = *to_local * wi;
                match dist {
                    Some(d) => {
                        let uv = dome_uv(wl);
                        let (_, jac) = dome_dir(uv);
                        if jac <= 0.0 {
                            0.0
                        } else {
                            d.pdf(uv) / jac
                        }
                    }
                    None => sampling::UNIFORM_SPHERE_PDF,
                }
            }
        }
    }

    /// Emitted flux (luminance-weighted scalar) used to choose lights by power. Infinite lights count
    /// the flux entering the silhouette of `scene`, where their photons start.
    pub fn power(&self, scene: &SceneBox, textures: &[Arc<Texture>]) -> f32 {
        let lum = |c: Vec3| 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
        match self {
            Emitter::Rect { area, radiance, two_sided, .. } | Emitter::Triangle { area, radiance, two_sided, .. } => {
                PI * area * lum(*radiance) * if *two_sided { 2.0 } else { 1.0 }
            }
            Emitter::Disk { area, radiance, .. } => PI * area * lum(*radiance),
            Emitter::Sphere { radius, radiance, spot, .. } => {
                let full = 4.0 * PI * PI * radius * radius * lum(*radiance);
                match spot {
                    // fraction of directions inside the cone
                    Some(s) => full * (0.5 * (1.0 - s.cos_outer)).max(1e-4),
                    None => full,
                }
            }
            // The flux through the scene box's silhouette (where `sample_le` emits).
            Emitter::Distant { dir, irradiance, .. } => scene.projected_area(*dir) * lum(*irradiance),
            // πL (a hemisphere's irradiance: the sky lights a scene from above; the whole sphere's
            // 4πL gave the photons from below the horizon, which mostly leave again, four times
            // more of the budget on Crytek Sponza) over the mean silhouette.
            Emitter::Dome { radiance, texture, .. } => {
                let avg = match texture {
                    Some(t) => average_texture(&textures[*t]),
                    None => Vec3::ONE,
                };
                PI * scene.mean_projected_area() * lum(*radiance * avg)
            }
        }
    }

    /// Sample a photon leaving the emitter: position, direction and its flux weight
    /// `Le·|cosθ| / (pdf_A · pdf_ω)`. Photons of infinite lights start on the silhouette of `scene`
    /// ([`SceneBox::sample_origin`]).
    pub fn sample_le(&self, u1: Vec2, u2: Vec2, scene: &SceneBox, textures: &[Arc<Texture>]) -> Option<EmissionSample> {
        let cosine_out = |n: Vec3, u: Vec2| -> Vec3 { Frame::from_normal(n).to_world(sampling::square_to_cosine_hemisphere(u)) };
        // A surface emitter's direction about its normal `n`, and the number of sides it emits
        // from: a two-sided one picks its side with the first half of `u.x` (rescaled to [0, 1)).
        let surface_out = |n: Vec3, two_sided: bool, mut u: Vec2| -> (Vec3, f32) {
            if !two_sided {
                return (cosine_out(n, u), 1.0);
            }
            let nn = if u.x < 0.5 {
                u.x *= 2.0;
                n
            } else {
                u.x = (u.x - 0.5) * 2.0;
                -n
            };
            (cosine_out(nn, u), 2.0)
        };
        match self {
            Emitter::Rect { corner, ex, ey, n, area, radiance, two_sided } => {
                let pos = *corner + *ex * u1.x + *ey * u1.y;
                let (dir, k) = surface_out(*n, *two_sided, u2);
                // Le cos / (1/A · cos/π · 1/k)
                Some(EmissionSample { pos, dir, weight: *radiance * (PI * area * k), pdf_pos: 1.0 / area, pdf_dir: 1.0 / (PI * k) })
            }
            Emitter::Triangle { p, n, area, radiance, two_sided } => {
                let (b1, b2) = sampling::square_to_uniform_triangle(u1);
                let pos = p[0] * (1.0 - b1 - b2) + p[1] * b1 + p[2] * b2;
                let (dir, k) = surface_out(*n, *two_sided, u2);
                Some(EmissionSample { pos, dir, weight: *radiance * (PI * area * k), pdf_pos: 1.0 / area, pdf_dir: 1.0 / (PI * k) })
            }
            Emitter::Disk { center, frame, radius, area, radiance } => {
                let d = sampling::square_to_uniform_disk_concentric(u1) * *radius;
                let pos = *center + frame.s * d.x + frame.t * d.y;
                let dir = cosine_out(frame.n, u2);
                Some(EmissionSample { pos, dir, weight: *radiance * (PI * area), pdf_pos: 1.0 / area, pdf_dir: 1.0 / PI })
            }
            Emitter::Sphere { center, radius, radiance, spot: Some(sp) } if sp.cos_outer > -1.0 => {
                // Spot: a direction uniformly in the outer cone, then a point of the sphere's disc
                // seen from that direction (every point of it emits along `dir`: flux L·πr²·dω).
                let fr = Frame::from_normal(sp.axis);
                let dir = fr.to_world(sampling::square_to_uniform_cone(u2, sp.cos_outer));
                let pdf_dir = sampling::uniform_cone_pdf(sp.cos_outer);
                let le = sp.falloff(dir);
                if le <= 0.0 {
                    return None;
                }
                let f = Frame::from_normal(dir);
                let q = sampling::square_to_uniform_disk_concentric(u1) * *radius;
                let pos = *center + f.s * q.x + f.t * q.y + dir * (radius * radius - q.length_squared()).max(0.0).sqrt();
                let disc = PI * radius * radius;
                Some(EmissionSample { pos, dir, weight: *radiance * (le * disc / pdf_dir), pdf_pos: 1.0 / disc, pdf_dir })
            }
            Emitter::Sphere { center, radius, radiance, spot } => {
                let n = sampling::square_to_uniform_sphere(u1);
                let pos = *center + n * *radius;
                let dir = cosine_out(n, u2);
                let le = spot.map_or(1.0, |s| s.falloff(dir));
                if le <= 0.0 {
                    return None;
                }
                let area = 4.0 * PI * radius * radius;
                Some(EmissionSample { pos, dir, weight: *radiance * (le * PI * area), pdf_pos: 1.0 / area, pdf_dir: 1.0 / PI })
            }
            Emitter::Distant { dir, cos_max, irradiance, radiance, frame } => {
                let (d, li, pdf_dir) = if *cos_max >= 1.0 {
                    (*dir, *irradiance, 1.0)
                } else {
                    let w = frame.to_world(sampling::square_to_uniform_cone(u2, *cos_max));
                    let pdf = sampling::uniform_cone_pdf(*cos_max);
                    (-w, *radiance / pdf, pdf)
                };
                let area = scene.projected_area(d);
                Some(EmissionSample { pos: scene.sample_origin(d, u1), dir: d, weight: li * area, pdf_pos: 1.0 / area, pdf_dir })
            }
            Emitter::Dome { .. } => {
                let s = self.sample_li(scene.center(), u2, textures)?;
                let d = -s.wi;
                let area = scene.projected_area(d);
                Some(EmissionSample { pos: scene.sample_origin(d, u1), dir: d, weight: s.li * (area / s.pdf), pdf_pos: 1.0 / area, pdf_dir: s.pdf })
            }
        }
    }
}

/// Lat-long mapping (OpenEXR convention) of a dome-local direction to texture coordinates
/// (v up: the top row is v = 1): longitude `atan2(x, z)` runs from +π at u = 0 to −π at u = 1.
pub fn dome_uv(d: Vec3) -> Vec2 {
    let u = 0.5 - d.x.atan2(d.z) / (2.0 * PI);
    let theta = d.y.clamp(-1.0, 1.0).acos();
    Vec2::new(u.rem_euclid(1.0), 1.0 - theta / PI)
}

/// Inverse of [`dome_uv`]: direction and the Jacobian |dω/d(uv)| = 2π² sinθ.
pub fn dome_dir(uv: Vec2) -> (Vec3, f32) {
    let theta = (1.0 - uv.y) * PI;
    let phi = (0.5 - uv.x) * 2.0 * PI;
    let (st, ct) = theta.sin_cos();
    let d = Vec3::new(st * phi.sin(), ct, st * phi.cos());
    (d, 2.0 * PI * PI * st)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dome_mapping_round_trips_and_follows_openexr() {
        // centre of the image is +Z, top is +Y, u = 0.25 is +X (longitude +π/2)
        assert!((dome_uv(Vec3::Z) - Vec2::new(0.5, 0.5)).length() < 1e-6);
        assert!((dome_uv(Vec3::X) - Vec2::new(0.25, 0.5)).length() < 1e-6);
        assert!((dome_uv(Vec3::Y).y - 1.0).abs() < 1e-6);
        for i in 0..50 {
            for j in 1..50 {
                let uv = Vec2::new(i as f32 / 50.0, j as f32 / 50.0);
                let (d, jac) = dome_dir(uv);
                assert!((d.length() - 1.0).abs() < 1e-5);
                assert!(jac > 0.0);
                let back = dome_uv(d);
                let du = (back.x - uv.x).abs().min(1.0 - (back.x - uv.x).abs());
                assert!(du < 1e-4 && (back.y - uv.y).abs() < 1e-4, "{uv} -> {d} -> {back}");
            }
        }
    }

    /// Spot photons are emitted inside the cone only, with the power of the sphere light's full
    /// emission restricted to it (as sampling a uniform point, a cosine direction and weighting by the falloff gives).
    #[test]
    fn spot_emission_samples_the_cone_with_the_same_power() {
        let spot = Spot { axis: Vec3::new(0.3, 1.0, -0.2).normalize(), cos_outer: 12f32.to_radians().cos(), cos_inner: 8f32.to_radians().cos(), focus: 1.0 };
        let (center, radius, radiance) = (Vec3::new(0.1, 0.2, 0.3), 0.05, Vec3::splat(3.0));
        let e = Emitter::Sphere { center, radius, radiance, spot: Some(spot) };
        let mut rng = crate::sampling::Rng::new(9, 0);
        let n = 400_000;
        let (mut new, mut old) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let (u1, u2) = (rng.next_2d(), rng.next_2d());
            if let Some(s) = e.sample_le(u1, u2, &SceneBox::new(Vec3::splat(-5.0), Vec3::splat(5.0)), &[]) {
                assert!(spot.falloff(s.dir) > 0.0);
                assert!(((s.pos - center).length() - radius).abs() < 1e-4 && (s.pos - center).dot(s.dir) >= -1e-6);
                new += s.weight.x as f64;
            }
            // The unshaped sphere's sampling, weighted by the falloff.
            let nrm = sampling::square_to_uniform_sphere(u1);
            let dir = Frame::from_normal(nrm).to_world(sampling::square_to_cosine_hemisphere(u2));
            old += (radiance.x * spot.falloff(dir) * PI * 4.0 * PI * radius * radius) as f64;
        }
        let (new, old) = (new / n as f64, old / n as f64);
        assert!((new / old - 1.0).abs() < 0.05, "{new} vs {old}");
    }

    /// Rect and triangle emitters send photons out of their lit sides only: a one-sided emitter
    /// along its normal, with the flux weight `π·A·Le`; a two-sided one out of each side for half
    /// of `u2.x` (`< 0.5`: the normal's side), with twice that weight and half the direction density.
    #[test]
    fn surface_emitters_emit_from_their_lit_sides() {
        let radiance = Vec3::new(1.0, 2.0, 3.0);
        let (corner, ex, ey) = (Vec3::new(0.1, 0.2, 0.3), Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.25));
        let n = ex.cross(ey).normalize();
        let tri = [Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.5)];
        let tn = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        let (t_area, tn) = (0.5 * tn.length(), tn.normalize());
        let scene = SceneBox::new(Vec3::splat(-5.0), Vec3::splat(5.0));
        for two_sided in [false, true] {
            let emitters = [
                (Emitter::Rect { corner, ex, ey, n, area: 0.125, radiance, two_sided }, n, 0.125),
                (Emitter::Triangle { p: tri, n: tn, area: t_area, radiance, two_sided }, tn, t_area),
            ];
            for (e, normal, area) in emitters {
                let k = if two_sided { 2.0 } else { 1.0 };
                let mut rng = crate::sampling::Rng::new(17, 0);
                let mut back = 0;
                for _ in 0..4000 {
                    let (u1, u2) = (rng.next_2d(), rng.next_2d());
                    let s = e.sample_le(u1, u2, &scene, &[]).expect("a surface emitter always emits");
                    let side = s.dir.dot(normal);
                    assert!(side.abs() > 0.0 && (s.dir.length() - 1.0).abs() < 1e-5, "{e:?}: {s:?}");
                    assert_eq!(side < 0.0, two_sided && u2.x >= 0.5, "{e:?}: u2 {u2} gave {}", s.dir);
                    back += (side < 0.0) as u32;
                    assert!((s.weight - radiance * (PI * area * k)).abs().max_element() < 1e-5, "{e:?}: {s:?}");
                    assert!((s.pdf_pos - 1.0 / area).abs() < 1e-4 && (s.pdf_dir - 1.0 / (PI * k)).abs() < 1e-6, "{e:?}: {s:?}");
                }
                if two_sided {
                    assert!((1800..2200).contains(&back), "{e:?}: {back} of 4000 from the back");
                } else {
                    assert_eq!(back, 0);
                }
            }
        }
    }

    #[test]
    fn spot_falloff_is_one_inside_zero_outside_and_smooth_between() {
        let s = Spot { axis: Vec3::NEG_Z, cos_outer: 30f32.to_radians().cos(), cos_inner: 20f32.to_radians().cos(), focus: 0.0 };
        assert_eq!(s.falloff(Vec3::NEG_Z), 1.0);
        let dir = |deg: f32| Vec3::new(deg.to_radians().sin(), 0.0, -deg.to_radians().cos());
        assert_eq!(s.falloff(dir(31.0)), 0.0);
        let mid = s.falloff(dir(25.0));
        assert!(mid > 0.0 && mid < 1.0);
        assert!(s.falloff(dir(22.0)) > s.falloff(dir(28.0)));
    }
}

fn average_texture(t: &Texture) -> Vec3 {
    let (w, h) = (t.width().max(1), t.height().max(1));
    let mut sum = Vec3::ZERO;
    let mut wsum = 0.0;
    for y in 0..h {
        let st = ((y as f32 + 0.5) / h as f32 * PI).sin();
        for x in 0..w {
            sum += t.texel_rgb(x, y) * st;
            wsum += st;
        }
    }
    if wsum > 0.0 {
        sum / wsum
    } else {
        Vec3::ZERO
    }
}
