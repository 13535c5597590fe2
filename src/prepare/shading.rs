//! From an Embree hit to a shading point: position, normals, texture coordinates, material; and the
//! alpha cut-out test (UsdPreviewSurface `opacityThreshold`) that Embree runs as a hit filter.

use super::PreparedScene;
use crate::embree::{Hit, Ray};
use crate::image::Texture;
use crate::scene::{Material, Mesh};
use glam::{Vec2, Vec3};
use std::sync::Arc;

/// A surface point hit by a ray.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    pub p: Vec3,
    /// Geometric normal (world, normalised, from the triangle's winding).
    pub ng: Vec3,
    /// Shading normal (interpolated vertex normals, on the same side as `ng`).
    pub ns: Vec3,
    pub uv: Vec2,
    /// Interpolated vertex colour, where the mesh has colours ([`crate::scene::Mesh::colors`]).
    pub color: Option<Vec3>,
    pub t: f32,
    pub material: u32,
    pub instance: u32,
    pub prim: u32,
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
    /// Shading data for an Embree hit of `ray`.
    pub fn surface_hit(&self, ray: &Ray, h: &Hit) -> SurfaceHit {
        let inst = &self.instances[h.instance as usize];
        let mesh = &self.meshes[inst.mesh as usize];
        if let Some(sd) = &mesh.subdivision {
            return self.subdivision_hit(ray, h, mesh, sd);
        }
        let p = ray.org + ray.dir * h.t;
        let ng = h.ng.normalize_or_zero();
        let ns = match &mesh.normals {
            Some(n) => {
                let w = (inst.normal_matrix * interp(n, mesh, h.prim, h.u, h.v)).normalize_or_zero();
                if w == Vec3::ZERO {
                    ng
                } else if w.dot(ng) < 0.0 {
                    -w
                } else {
                    w
                }
            }
            None => ng,
        };
        SurfaceHit {
            p,
            ng,
            ns,
            uv: interp_uv(mesh, h.prim, h.u, h.v),
            color: mesh.colors.as_ref().map(|c| interp(c, mesh, h.prim, h.u, h.v)),
            t: h.t,
            material: mesh.material_of(h.prim as usize),
            instance: h.instance,
            prim: h.prim,
        }
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
