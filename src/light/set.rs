//! Building the emitters of a scene and choosing among them by power.

use super::{Emitter, SceneBox, Spot};
use crate::image::Texture;
use std::sync::Arc;
use crate::sampling::{Distribution1D, Distribution2D, Frame};
use crate::scene::{mat4, Light, SceneDesc, Warning};
use glam::{Mat3, Vec3};
use std::collections::HashMap;
use std::f32::consts::PI;

/// All emitters of a scene plus the power-proportional sampler over them.
pub struct LightSet {
    pub emitters: Vec<Emitter>,
    /// Scene lights (not emissive triangles) that rays can hit analytically (rect, disk, sphere).
    pub analytic: Vec<u32>,
    /// Distant lights with a finite angle and dome lights (seen by escaping rays).
    pub infinite: Vec<u32>,
    sampler: Option<Distribution1D>,
    /// (instance << 32 | triangle) → emitter index, for emissive mesh triangles.
    triangles: HashMap<u64, u32>,
    /// Prim path of each emitter (emissive triangles share their instance's path).
    pub names: Vec<String>,
    /// The scene's bounding box: photons of infinite lights start on its silhouette.
    pub scene_box: SceneBox,
}

impl LightSet {
    /// Build the emitters. `textures` are the scene's loaded textures (for dome maps and emission).
    pub fn build(scene: &SceneDesc, textures: &[Arc<Texture>], warnings: &mut Vec<Warning>) -> LightSet {
        let mut emitters = Vec::new();
        let mut names = Vec::new();
        let (lo, hi) = scene.world_bounds();
        let scene_box = SceneBox::new(lo, hi);
        for l in &scene.lights {
            if let Some(e) = emitter_of(l, textures, warnings) {
                emitters.push(e);
                names.push(l.name().to_string());
            }
        }
        // Emissive triangles.
        let mut triangles = HashMap::new();
        for (ii, inst) in scene.instances.iter().enumerate() {
            let mesh = &scene.meshes[inst.mesh as usize];
            for (ti, tri) in mesh.indices.iter().enumerate() {
                let Some(emission) = scene.materials[mesh.material_of(ti) as usize].emission() else { continue };
                let mut le = Vec3::from(emission.value);
                if let Some(t) = emission.texture {
                    // Constant per triangle: the texture at the triangle's centroid.
                    let uv = mesh.uvs.as_ref().map(|uv| (uv[tri[0] as usize] + uv[tri[1] as usize] + uv[tri[2] as usize]) / 3.0);
                    le = textures[t as usize].eval_rgb(uv.unwrap_or_default());
                }
                if le.max_element() <= 0.0 {
                    continue;
                }
                let v = tri.map(|i| inst.transform.transform_point3(mesh.positions[i as usize]));
                // Area and normal in f64: for sliver triangles the f32 cross product cancels (a
                // needle of aspect 1e-6 lost 3 % of its area and 1° of its normal), biasing NEE
                // and photon emission, which use this area while sampling the true triangle.
                let [a, b, c] = v.map(|p| p.as_dvec3());
                let c = (b - a).cross(c - a);
                let area = (0.5 * c.length()) as f32;
                if !(area > 0.0 && area.is_finite()) {
                    continue;
                }
                triangles.insert(((ii as u64) << 32) | ti as u64, emitters.len() as u32);
                let n = c.normalize().as_vec3();
                emitters.push(Emitter::Triangle { p: v, n, area, radiance: le, two_sided: mesh.double_sided });
                names.push(inst.name.clone());
            }
        }
        let mut analytic = Vec::new();
        let mut infinite = Vec::new();
        for (i, e) in emitters.iter().enumerate() {
            match e {
                Emitter::Rect { .. } | Emitter::Disk { .. } | Emitter::Sphere { .. } => analytic.push(i as u32),
                Emitter::Dome { .. } => infinite.push(i as u32),
                Emitter::Distant { .. } if !e.is_delta() => infinite.push(i as u32),
                _ => {}
            }
        }
        let powers: Vec<f32> = emitters.iter().map(|e| e.power(&scene_box, textures).max(0.0)).collect();
        let sampler = if powers.iter().any(|&p| p > 0.0) { Some(Distribution1D::new(&powers)) } else { None };
        if sampler.is_none() {
            let what = if emitters.is_empty() { "no light: no UsdLux light and no emissive surface" } else { "no light with power above zero" };
            warnings.push(Warning { prim: "/".into(), message: format!("the scene has {what}; every method renders it black") });
        }
        LightSet { emitters, analytic, infinite, sampler, triangles, names, scene_box }
    }

    pub fn is_empty(&self) -> bool {
        self.sampler.is_none()
    }

    /// Choose an emitter in proportion to its power: (index, probability).
    pub fn choose(&self, u: f32) -> Option<(usize, f32)> {
        let (i, pmf, _) = self.sampler.as_ref()?.sample_discrete(u)?;
        Some((i, pmf))
    }

    /// [`choose`](Self::choose) with `u` drawn only when there is a choice to make: with one
    /// emitter and `may_skip` (not drawing `u` leaves the caller's later draws unchanged, e.g. a
    /// padded sampler slot of its own) that emitter is taken without drawing (the same emitter
    /// and probability, bit for bit).
    #[inline]
    pub fn choose_with(&self, may_skip: bool, u: impl FnOnce() -> f32) -> Option<(usize, f32)> {
        match &self.sampler {
            Some(s) if may_skip && s.len() == 1 => Some((0, s.pmf(0))),
            _ => self.choose(u()),
        }
    }

    /// Probability that `choose` picks emitter `i`.
    pub fn pmf(&self, i: usize) -> f32 {
        self.sampler.as_ref().map_or(0.0, |s| s.pmf(i))
    }

    /// Number of emissive mesh triangles among the emitters.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The emitter of an emissive triangle, if any.
    pub fn triangle_emitter(&self, instance: u32, prim: u32) -> Option<u32> {
        self.triangles.get(&(((instance as u64) << 32) | prim as u64)).copied()
    }
}

fn emitter_of(l: &Light, textures: &[Arc<Texture>], warnings: &mut Vec<Warning>) -> Option<Emitter> {
    let warn = |warnings: &mut Vec<Warning>, msg: &str| {
        warnings.push(Warning { prim: l.name().to_string(), message: msg.to_string() })
    };
    Some(match l {
        Light::Rect { transform, width, height, radiance, texture, .. } => {
            let m = mat4(transform);
            let corner = m.transform_point3(Vec3::new(-0.5 * width, -0.5 * height, 0.0));
            let ex = m.transform_vector3(Vec3::new(*width, 0.0, 0.0));
            let ey = m.transform_vector3(Vec3::new(0.0, *height, 0.0));
            let nz = (Mat3::from_mat4(m).inverse().transpose() * Vec3::NEG_Z).normalize();
            let c = ex.cross(ey);
            let mut rad = Vec3::from(*radiance);
            if let Some(t) = texture {
                warn(warnings, "RectLight texture: using its average colour (textured rect lights are not sampled per texel)");
                rad *= average_rgb(&textures[*t as usize]);
            }
            Emitter::Rect { corner, ex, ey, n: nz, area: c.length(), radiance: rad, two_sided: false }
        }
        Light::Disk { transform, radius, radiance, .. } => {
            let m = mat4(transform);
            let center = m.transform_point3(Vec3::ZERO);
            let n = (Mat3::from_mat4(m).inverse().transpose() * Vec3::NEG_Z).normalize();
            let r = radius * m.transform_vector3(Vec3::X).length();
            Emitter::Disk { center, frame: Frame::from_normal(n), radius: r, area: PI * r * r, radiance: Vec3::from(*radiance) }
        }
        Light::Sphere { transform, radius, radiance, cone, .. } => {
            let m = mat4(transform);
            let center = m.transform_point3(Vec3::ZERO);
            let r = radius * m.transform_vector3(Vec3::X).length();
            let spot = cone.map(|c| {
                let outer = c.angle_deg.min(180.0).to_radians();
                let inner = outer * (1.0 - c.softness.clamp(0.0, 1.0));
                Spot {
                    axis: m.transform_vector3(Vec3::NEG_Z).normalize(),
                    cos_outer: outer.cos(),
                    cos_inner: inner.cos(),
                    focus: c.focus.max(0.0),
                }
            });
            Emitter::Sphere { center, radius: r, radiance: Vec3::from(*radiance), spot }
        }
        Light::Distant { direction, angle_deg, irradiance, .. } => {
            let dir = Vec3::from(*direction).normalize();
            let half = (0.5 * angle_deg).to_radians();
            let cos_max = if *angle_deg > 0.0 { half.cos() } else { 1.0 };
            let sin2 = (half.sin()).powi(2);
            let e = Vec3::from(*irradiance);
            let radiance = if cos_max < 1.0 { e / (PI * sin2) } else { e };
            Emitter::Distant { dir, cos_max, irradiance: e, radiance, frame: Frame::from_normal(-dir) }
        }
        Light::Dome { transform, radiance, texture, .. } => {
            let m = Mat3::from_mat4(mat4(transform));
            let rot = Mat3::from_cols(m.x_axis.normalize(), m.y_axis.normalize(), m.z_axis.normalize());
            let to_local = rot.transpose();
            let (tex, dist) = match texture {
                Some(t) => {
                    let tx = &textures[*t as usize];
                    let (w, h) = (tx.width().max(1) as usize, tx.height().max(1) as usize);
                    let mut weights = Vec::with_capacity(w * h);
                    for y in 0..h {
                        // texture row 0 is the top (v = 1)
                        let st = ((y as f32 + 0.5) / h as f32 * PI).sin();
                        for x in 0..w {
                            let c = tx.texel_rgb(x as u32, y as u32);
                            weights.push((0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z).max(0.0) * st + 1e-8);
                        }
                    }
                    // Distribution2D rows are in v order from v = 0 upward: flip the rows.
                    let mut flipped = Vec::with_capacity(w * h);
                    for y in (0..h).rev() {
                        flipped.extend_from_slice(&weights[y * w..(y + 1) * w]);
                    }
                    (Some(*t as usize), Some(Distribution2D::new(&flipped, w, h)))
                }
                None => (None, None),
            };
            Emitter::Dome { to_local, radiance: Vec3::from(*radiance), texture: tex, dist }
        }
    })
}

fn average_rgb(t: &Texture) -> Vec3 {
    let (w, h) = (t.width().max(1), t.height().max(1));
    let mut s = Vec3::ZERO;
    for y in 0..h {
        for x in 0..w {
            s += t.texel_rgb(x, y);
        }
    }
    s / (w * h) as f32
}
