//! From an Embree hit to a shading point: position, normals (with the material's normal map),
//! texture coordinates and the texture footprint of the ray's cone, material; and the alpha
//! cut-out test (UsdPreviewSurface `opacityThreshold`) that Embree runs as a hit filter.

use super::cone::{self, RayCone, TextureFilter};
use super::{normal_map, PreparedScene};
use crate::embree::{Hit, Ray};
use crate::image::{Footprint, Texture};
use crate::scene::{Material, Mesh};
use glam::{Mat3, Vec2, Vec3};
use std::sync::Arc;

/// A surface point hit by a ray.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    pub p: Vec3,
    /// Geometric normal (world, normalised, from the triangle's winding).
    pub ng: Vec3,
    /// Shading normal (interpolated vertex normals, perturbed by the material's normal map, on
    /// the same side as `ng`).
    pub ns: Vec3,
    pub uv: Vec2,
    /// Interpolated vertex colour, where the mesh has colours ([`crate::scene::Mesh::colors`]).
    pub color: Option<Vec3>,
    pub t: f32,
    pub material: u32,
    pub instance: u32,
    pub prim: u32,
    /// The area of the material's textures the ray's cone covers ([`super::cone`]);
    /// `Footprint::POINT` for rays without a cone.
    pub footprint: Footprint,
}

/// A per-vertex attribute of triangle `prim` at barycentric coordinates `(u, v)`.
#[inline]
fn interp<T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>>(values: &[T], mesh: &Mesh, prim: u32, u: f32, v: f32) -> T {
    let [a, b, c] = mesh.indices[prim as usize];
    values[a as usize] * (1.0 - u - v) + values[b as usize] * u + values[c as usize] * v
}

pub(super) fn interp_uv(mesh: &Mesh, prim: u32, u: f32, v: f32) -> Vec2 {
    match &mesh.uvs {
        Some(uvs) => interp(uvs, mesh, prim, u, v),
        None => Vec2::new(u, v),
    }
}

impl PreparedScene {
    /// Shading data for an Embree hit of `ray` (no cone: textures are read without filtering).
    #[inline]
    pub fn surface_hit(&self, ray: &Ray, h: &Hit) -> SurfaceHit {
        self.surface_hit_cone(ray, h, None)
    }

    /// Shading data for an Embree hit of `ray`, whose cone (a camera ray's, or one continued
    /// through specular and glossy bounces) gives the texture footprint.
    pub fn surface_hit_cone(&self, ray: &Ray, h: &Hit, cone: Option<RayCone>) -> SurfaceHit {
        let inst = &self.instances[h.instance as usize];
        let mesh = &self.meshes[inst.mesh as usize];
        if let Some(sd) = &mesh.subdivision {
            return self.subdivision_hit(ray, h, mesh, sd, cone);
        }
        let p = ray.org + ray.dir * h.t;
        let ng = h.ng.normalize_or_zero();
        let material = mesh.material_of(h.prim as usize);
        let uv = interp_uv(mesh, h.prim, h.u, h.v);
        let look = &self.looks[material as usize];
        let footprint = match cone {
            Some(c) if look.textured && mesh.uvs.is_some() && self.texture_filter != TextureFilter::Bilinear => self.footprint(inst, mesh, h.prim, ray.dir, h.t, ng, c),
            _ => Footprint::POINT,
        };
        let interpolated = mesh.normals.as_ref().map(|n| (inst.normal_matrix * interp(n, mesh, h.prim, h.u, h.v)).normalize_or_zero());
        let ns = match (look.normal_map, &self.tangents[inst.mesh as usize]) {
            (Some(tex), Some(tangents)) => {
                // the map perturbs the surface's own normal (authored, else the winding's),
                // then the result faces `ng`'s side as interpolated normals do
                let m3 = Mat3::from_mat4(inst.to_world);
                let n = match interpolated {
                    Some(n) if n != Vec3::ZERO => n,
                    _ => self.winding_normal(inst, mesh, h.prim),
                };
                let t4 = interp(tangents, mesh, h.prim, h.u, h.v);
                let sign = if t4.w < 0.0 { -1.0 } else { 1.0 } * if m3.determinant() < 0.0 { -1.0 } else { 1.0 };
                let value = self.textures[tex as usize].eval_rgb_filtered(uv, &footprint);
                let w = normal_map::perturbed(n, m3 * t4.truncate(), sign, value);
                let w = if n.dot(ng) < 0.0 { -w } else { w };
                // keep the view's reflection above the surface (seen from the ray's side)
                let side = if ng.dot(ray.dir) > 0.0 { -1.0 } else { 1.0 };
                let wo = (-ray.dir).normalize_or_zero();
                side * normal_map::keep_reflection_above(side * w, side * ng, wo)
            }
            _ => match interpolated {
                Some(w) if w == Vec3::ZERO => ng,
                Some(w) if w.dot(ng) < 0.0 => -w,
                Some(w) => w,
                None => ng,
            },
        };
        SurfaceHit {
            p,
            ng,
            ns,
            uv,
            color: mesh.colors.as_ref().map(|c| interp(c, mesh, h.prim, h.u, h.v)),
            t: h.t,
            material,
            instance: h.instance,
            prim: h.prim,
            footprint,
        }
    }

    /// The world-space normal of triangle `prim`'s winding (counter-clockwise front).
    fn winding_normal(&self, inst: &super::PreparedInstance, mesh: &Mesh, prim: u32) -> Vec3 {
        let [a, b, c] = mesh.indices[prim as usize].map(|i| mesh.positions[i as usize]);
        (inst.normal_matrix * (b - a).cross(c - a)).normalize_or_zero()
    }

    /// The texture footprint of a cone arriving along `dir` at distance `t` on triangle `prim`.
    #[allow(clippy::too_many_arguments)]
    fn footprint(&self, inst: &super::PreparedInstance, mesh: &Mesh, prim: u32, dir: Vec3, t: f32, ng: Vec3, cone: RayCone) -> Footprint {
        let Some(uvs) = &mesh.uvs else { return Footprint::POINT };
        let [a, b, c] = mesh.indices[prim as usize].map(|i| i as usize);
        let m = &inst.to_world;
        let (p0, p1, p2) = (mesh.positions[a], mesh.positions[b], mesh.positions[c]);
        let e = [m.transform_vector3(p1 - p0), m.transform_vector3(p2 - p0)];
        let d = [uvs[b] - uvs[a], uvs[c] - uvs[a]];
        let len = dir.length();
        cone::footprint(cone.width_at(t * len), dir / len, ng, e, d, self.texture_filter.max_probes())
    }
}

/// Per-mesh data for the cut-out test.
struct Cutout {
    indices: Vec<[u32; 3]>,
    uvs: Option<Vec<Vec2>>,
    material_ids: Vec<u32>,
    /// Per material: (threshold, constant opacity, opacity texture).
    materials: Vec<(f32, f32, Option<Arc<Texture>>)>,
}

impl Cutout {
    fn accept(&self, prim: u32, u: f32, v: f32) -> bool {
        let m = if self.material_ids.len() == 1 { self.material_ids[0] } else { self.material_ids[prim as usize] };
        let (threshold, value, tex) = &self.materials[m as usize];
        if *threshold <= 0.0 {
            return true;
        }
        let opacity = match tex {
            Some(t) => {
                let [a, b, c] = self.indices[prim as usize];
                let uv = match &self.uvs {
                    Some(uvs) => uvs[a as usize] * (1.0 - u - v) + uvs[b as usize] * u + uvs[c as usize] * v,
                    None => Vec2::new(u, v),
                };
                t.eval_scalar(uv)
            }
            None => *value,
        };
        opacity >= *threshold
    }
}

/// The Embree hit filter for a mesh whose materials include cut-outs, or `None`.
pub(super) fn cutout_filter(
    mesh: &Mesh,
    materials: &[Material],
    textures: &[Arc<Texture>],
) -> Option<Arc<dyn Fn(u32, u32, f32, f32) -> bool + Send + Sync>> {
    let used = |i: usize| mesh.material_ids.contains(&(i as u32));
    let mats: Vec<(f32, f32, Option<Arc<Texture>>)> = materials
        .iter()
        .enumerate()
        .map(|(i, m)| match m {
            Material::PreviewSurface(p) if p.opacity_threshold > 0.0 && used(i) => (
                p.opacity_threshold,
                p.opacity.value,
                p.opacity.texture.map(|t| textures[t as usize].clone()),
            ),
            _ => (0.0, 1.0, None),
        })
        .collect();
    if mats.iter().all(|m| m.0 <= 0.0) {
        return None;
    }
    let c = Cutout {
        indices: mesh.indices.clone(),
        uvs: mesh.uvs.clone(),
        material_ids: mesh.material_ids.clone(),
        materials: mats,
    };
    Some(Arc::new(move |_inst, prim, u, v| c.accept(prim, u, v)))
}
