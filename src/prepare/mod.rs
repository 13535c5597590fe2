//! The render-time scene: one consuming step from a validated `SceneDesc` to everything a method
//! traces against — the committed Embree scene, loaded textures, the light set, the camera — plus
//! what the scene requires (diffuse / glossy / specular surfaces, emitters), so that methods build
//! only what is needed.

mod camera;
mod cone;
mod normal_map;
mod shading;
mod subdivision;
mod tangents;
#[cfg(test)]
mod tests_subdivision;

pub use camera::CameraModel;
pub use cone::{glossy_spread, RayCone, TextureFilter, MAX_PROBES};
pub use shading::SurfaceHit;
pub use subdivision::{surface_area, TARGET_PIXELS};

use crate::bsdf::{Bsdf, BsdfAt, BsdfFlags, PreviewBsdf, SurfaceParams};
use crate::embree::{self, Device, Ray, SceneBuilder};
use crate::error::Result;
use crate::image::{Footprint, Texture};
use crate::light::LightSet;
use crate::scene::{Material, Mesh, SceneDesc, Warning};
use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
use rayon::prelude::*;
use std::sync::Arc;

/// What the scene contains, so that methods build only what it needs.
#[derive(Clone, Debug, Default)]
pub struct Requirements {
    pub triangles: usize,
    /// Cage faces of the subdivision surfaces Embree tessellates, and the quads it makes of them
    /// (estimated), counted per instance.
    pub subdivision_faces: usize,
    pub subdivision_quads: f64,
    pub instances: usize,
    pub lights: usize,
    pub emissive_triangles: usize,
    /// Union of the lobes of every material that some triangle uses.
    pub flags: BsdfFlags,
    pub cutouts: bool,
    pub textures: usize,
}

impl Requirements {
    pub fn has_specular(&self) -> bool {
        self.flags.contains(BsdfFlags::SPECULAR)
    }
    pub fn has_glossy(&self) -> bool {
        self.flags.contains(BsdfFlags::GLOSSY)
    }
    pub fn has_diffuse(&self) -> bool {
        self.flags.contains(BsdfFlags::DIFFUSE)
    }
}

/// A placed mesh at render time.
pub struct PreparedInstance {
    pub mesh: u32,
    pub to_world: Mat4,
    /// Inverse transpose of the upper 3×3, for normals.
    pub normal_matrix: Mat3,
}

/// Everything a rendering method traces against. `Send + Sync`.
pub struct PreparedScene {
    pub embree: embree::Scene,
    pub meshes: Vec<Mesh>,
    pub instances: Vec<PreparedInstance>,
    pub materials: Vec<Material>,
    pub textures: Vec<Arc<Texture>>,
    pub lights: LightSet,
    pub camera: CameraModel,
    pub bounds: (Vec3, Vec3),
    /// Radius of the bounding sphere of the scene.
    pub radius: f32,
    pub requirements: Requirements,
    pub warnings: Vec<Warning>,
    pub source: String,
    /// How textures are filtered over the footprints of ray cones (default anisotropic).
    pub texture_filter: TextureFilter,
    /// What of every material's BSDF is resolved once, at prepare.
    resolved: Vec<ResolvedBsdf>,
    /// Per material: whether shading reads texture coordinates or vertex colours at a hit (a
    /// subdivision surface's are interpolated only then).
    reads_surface_data: Vec<bool>,
    /// Per material: whether it may emit (an emission texture or a non-zero colour).
    emits: Vec<bool>,
    /// Per material: what its hits need (footprints, a normal map).
    looks: Vec<Look>,
    /// Per mesh: MikkTSpace tangents, for meshes with texture coordinates that a normal-mapped
    /// material is on.
    tangents: Vec<Option<Vec<Vec4>>>,
    _device: Device,
}

/// What a material's hits need beyond the BSDF.
#[derive(Clone, Copy, Debug, Default)]
struct Look {
    /// Some input reads a texture (its lookups filter over the ray cone's footprint).
    textured: bool,
    /// The tangent-space normal map.
    normal_map: Option<u32>,
}

impl Look {
    fn new(m: &Material) -> Look {
        match m {
            Material::PreviewSurface(p) => Look {
                textured: bsdf_is_textured(m) || p.emissive_color.texture.is_some() || p.normal_map.is_some(),
                normal_map: p.normal_map,
            },
            Material::Lambert { emissive_color, .. } => Look { textured: bsdf_is_textured(m) || emissive_color.texture.is_some(), normal_map: None },
            Material::Error { .. } => Look::default(),
        }
    }
}

impl PreparedScene {
    /// Build the render-time scene for a `width`×`height` image. `threads` limits Embree's build
    /// threads (0 = all cores).
    pub fn new(mut desc: SceneDesc, width: u32, height: u32, threads: usize) -> Result<PreparedScene> {
        let mut warnings = desc.warnings.clone();
        let camera = CameraModel::new(&desc.camera, width, height);
        // subdivision surfaces: to Embree, or triangles made here (before the lights: emitting
        // ones are triangles)
        let mut tess = subdivision::tessellate(&mut desc, &camera, &mut warnings);
        // the textures read and decoded in parallel (Crytek Sponza has dozens), kept in order
        let loaded: Vec<(Texture, Option<String>)> = desc.textures.par_iter().map(Texture::load).collect();
        let mut textures = Vec::with_capacity(desc.textures.len());
        for (t, (tex, warn)) in desc.textures.iter().zip(loaded) {
            // (a file the loader already warned about, e.g. as missing, is not reported twice)
            let known = !t.path.is_empty() && desc.warnings.iter().any(|w| w.message.contains(&t.path));
            if let Some(w) = warn.filter(|_| !known) {
                warnings.push(Warning { prim: if t.prim.is_empty() { t.path.clone() } else { t.prim.clone() }, message: w });
            }
            textures.push(Arc::new(tex));
        }
        let lights = LightSet::build(&desc, &textures, &mut warnings);

        let device = Device::new(threads)?;
        let mut builder = SceneBuilder::new(&device)?;
        let mut mesh_ids = Vec::with_capacity(desc.meshes.len());
        for (m, mesh) in desc.meshes.iter().enumerate() {
            let id = match tess.embree[m].take() {
                Some(surface) => builder.add_subdivision_mesh(surface)?,
                None => builder.add_mesh(&mesh.positions, &mesh.indices)?,
            };
            if let Some(filter) = shading::cutout_filter(mesh, &desc.materials, &textures) {
                builder.set_filter(embree::MeshId(id.0), filter);
            }
            mesh_ids.push(id);
        }
        let mut instances = Vec::with_capacity(desc.instances.len());
        for inst in &desc.instances {
            builder.add_instance(embree::MeshId(mesh_ids[inst.mesh as usize].0), inst.transform)?;
            instances.push(PreparedInstance {
                mesh: inst.mesh,
                to_world: inst.transform,
                normal_matrix: Mat3::from_mat4(inst.transform).inverse().transpose(),
            });
        }
        let embree = builder.commit()?;

        let mut req = Requirements {
            instances: instances.len(),
            lights: desc.lights.len(),
            emissive_triangles: lights.triangle_count(),
            textures: textures.len(),
            subdivision_faces: tess.faces,
            subdivision_quads: tess.quads,
            ..Default::default()
        };
        req.triangles = desc.instances.iter().map(|i| desc.meshes[i.mesh as usize].indices.len()).sum();
        let used = used_materials(&desc);
        for (_, mat) in desc.materials.iter().enumerate().filter(|(i, _)| used[*i]) {
            if let Material::PreviewSurface(p) = mat {
                req.cutouts |= p.opacity_threshold > 0.0;
            }
            req.flags = req.flags | material_flags(mat);
        }
        let looks: Vec<Look> = desc.materials.iter().map(Look::new).collect();
        let tangents = mesh_tangents(&desc.meshes, &looks, &mut warnings);
        let bounds = desc.world_bounds();
        let radius = ((bounds.1 - bounds.0).length() * 0.5).max(1e-20);
        let resolved = desc.materials.iter().map(|m| ResolvedBsdf::new(m, &textures)).collect();
        let reads_surface_data = desc.materials.iter().map(reads_surface_data).collect();
        let emits = desc.materials.iter().map(|m| m.emission().is_some_and(|e| e.texture.is_some() || Vec3::from(e.value) != Vec3::ZERO)).collect();
        Ok(PreparedScene {
            embree,
            meshes: desc.meshes,
            instances,
            materials: desc.materials,
            textures,
            lights,
            camera,
            bounds,
            radius,
            requirements: req,
            warnings,
            source: desc.source,
            texture_filter: TextureFilter::default(),
            resolved,
            reads_surface_data,
            emits,
            looks,
            tangents,
            _device: device,
        })
    }

    /// Closest surface hit along a ray.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<SurfaceHit> {
        self.embree.intersect(ray).map(|h| self.surface_hit(ray, &h))
    }

    /// Closest surface hit along a ray with a cone (texture lookups filter over its footprint).
    #[inline]
    pub fn intersect_cone(&self, ray: &Ray, cone: Option<RayCone>) -> Option<SurfaceHit> {
        self.embree.intersect(ray).map(|h| self.surface_hit_cone(ray, &h, cone))
    }

    /// Is the segment from `p` (a surface point with geometric normal `ng`) toward `wi` blocked
    /// before `dist`?
    #[inline]
    pub fn occluded(&self, p: Vec3, ng: Vec3, wi: Vec3, dist: f32) -> bool {
        self.shadow_ray(p, ng, wi, dist).is_some_and(|r| self.embree.occluded(&r))
    }

    /// The ray [`occluded`](Self::occluded) traces, or `None` when the segment is too short to be
    /// blocked (for batched visibility tests).
    #[inline]
    pub fn shadow_ray(&self, p: Vec3, ng: Vec3, wi: Vec3, dist: f32) -> Option<Ray> {
        let o = self.offset(p, ng, wi);
        let tfar = if dist.is_finite() { dist * (1.0 - 1e-4) - self.eps(p) } else { f32::INFINITY };
        (tfar > 0.0).then(|| Ray::segment(o, wi, 0.0, tfar))
    }

    /// A ray leaving surface point `p` in direction `d`, offset to avoid self-intersection.
    #[inline]
    pub fn spawn(&self, p: Vec3, ng: Vec3, d: Vec3) -> Ray {
        Ray::new(self.offset(p, ng, d), d)
    }

    /// Scale-relative epsilon at `p`.
    #[inline]
    pub fn eps(&self, p: Vec3) -> f32 {
        1e-5 * (p.abs().max_element() + self.radius)
    }

    #[inline]
    fn offset(&self, p: Vec3, ng: Vec3, d: Vec3) -> Vec3 {
        let e = self.eps(p);
        if ng.dot(d) >= 0.0 {
            p + ng * e
        } else {
            p - ng * e
        }
    }

    /// The BSDF at a hit, with textures evaluated (untextured materials: resolved once, at prepare).
    #[inline]
    pub fn bsdf(&self, hit: &SurfaceHit) -> Bsdf {
        match &self.resolved[hit.material as usize] {
            ResolvedBsdf::Constant { bsdf, .. } => *bsdf,
            ResolvedBsdf::DiffuseTexture { template, texture, .. } => {
                Bsdf::Preview(template.with_diffuse(self.textures[*texture as usize].eval_rgb_filtered(hit.uv, &hit.footprint).clamp(Vec3::ZERO, Vec3::ONE)))
            }
            ResolvedBsdf::Textured => material_bsdf(&self.materials[hit.material as usize], &self.textures, hit.uv, &hit.footprint, hit.color),
        }
    }

    /// `self.bsdf(hit).at(wo)`, a constant material's BSDF copied once (into the result).
    #[inline]
    pub fn bsdf_at(&self, hit: &SurfaceHit, wo: Vec3) -> BsdfAt {
        match &self.resolved[hit.material as usize] {
            ResolvedBsdf::Constant { bsdf, .. } => bsdf.at(wo),
            _ => self.bsdf(hit).at(wo),
        }
    }

    /// The albedo AOV's colour of `bsdf`, the BSDF at `hit` ([`Self::bsdf`]): `bsdf.albedo()`, bit
    /// for bit, with what does not vary over the material resolved once (a path tracer asks at
    /// every camera sample that hits).
    #[inline]
    pub fn albedo(&self, hit: &SurfaceHit, bsdf: &Bsdf) -> Vec3 {
        match (&self.resolved[hit.material as usize], bsdf) {
            (ResolvedBsdf::Constant { albedo, .. }, _) => *albedo,
            (ResolvedBsdf::DiffuseTexture { layers, .. }, Bsdf::Preview(p)) => p.albedo_with(*layers),
            _ => bsdf.albedo(),
        }
    }

    /// Whether shading material `material` reads texture coordinates or vertex colours.
    pub(crate) fn reads_surface_data(&self, material: u32) -> bool {
        self.reads_surface_data.get(material as usize).copied().unwrap_or(true)
    }

    /// The BSDF of material `material` when it is the same at every hit (no textured input).
    pub fn constant_bsdf(&self, material: u32) -> Option<Bsdf> {
        match self.resolved.get(material as usize)? {
            ResolvedBsdf::Constant { bsdf, .. } => Some(*bsdf),
            _ => None,
        }
    }

    /// Radiance emitted by the surface at `hit` toward `wo` (emissive materials, front face unless
    /// the mesh is double-sided). Inlined to the test of [`emits`](Self::emits) (most hits are on
    /// materials that do not emit).
    #[inline]
    pub fn emitted(&self, hit: &SurfaceHit, wo: Vec3) -> Vec3 {
        if !self.emits[hit.material as usize] {
            return Vec3::ZERO;
        }
        self.emitted_by_emitter(hit, wo)
    }

    /// [`emitted`](Self::emitted) at a hit on a material that may emit.
    #[inline(never)]
    fn emitted_by_emitter(&self, hit: &SurfaceHit, wo: Vec3) -> Vec3 {
        let Some(e) = self.materials[hit.material as usize].emission() else { return Vec3::ZERO };
        let le = match e.texture {
            Some(t) => self.textures[t as usize].eval_rgb_filtered(hit.uv, &hit.footprint),
            None => Vec3::from(e.value),
        };
        if le == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let mesh = &self.meshes[self.instances[hit.instance as usize].mesh as usize];
        if hit.ng.dot(wo) > 0.0 || mesh.double_sided {
            le
        } else {
            Vec3::ZERO
        }
    }

    /// Texture coordinates are needed by tests and tools: interpolated uv of a triangle.
    pub fn uv_at(&self, instance: u32, prim: u32, b: Vec2) -> Vec2 {
        let mesh = &self.meshes[self.instances[instance as usize].mesh as usize];
        let mut out = [0.0; 4];
        if mesh.subdivision.as_ref().is_some_and(|sd| sd.uvs.is_some()) && self.embree.attribute(instance, prim, b.x, b.y, 0, &mut out) {
            return Vec2::new(out[0], out[1]);
        }
        shading::interp_uv(mesh, prim, b.x, b.y)
    }
}

/// A material's BSDF as far as it can be resolved before rendering.
#[derive(Debug)]
enum ResolvedBsdf {
    /// No textured input: the BSDF itself, and its albedo.
    Constant { bsdf: Bsdf, albedo: Vec3 },
    /// A UsdPreviewSurface whose only textured input is the diffuse colour, in the specular workflow
    /// or with metallic 0: every other lobe is the template's ([`PreviewBsdf::with_diffuse`]).
    /// `layers` are the template's [`PreviewBsdf::layer_albedos`], which the diffuse colour does
    /// not change.
    DiffuseTexture { template: PreviewBsdf, texture: u32, layers: (Vec3, f32) },
    /// Built from its inputs at every hit.
    Textured,
}

impl ResolvedBsdf {
    fn new(m: &Material, textures: &[Arc<Texture>]) -> ResolvedBsdf {
        if !bsdf_is_textured(m) {
            let bsdf = material_bsdf(m, textures, Vec2::ZERO, &Footprint::POINT, None);
            return ResolvedBsdf::Constant { bsdf, albedo: bsdf.albedo() };
        }
        if let Material::PreviewSurface(p) = m {
            let only_diffuse = p.specular_color.texture.is_none()
                && p.specular_tint.texture.is_none()
                && [&p.metallic, &p.roughness, &p.clearcoat, &p.clearcoat_roughness].iter().all(|c| c.texture.is_none())
                && (p.opacity.texture.is_none() || p.opacity_threshold > 0.0);
            let no_metal = p.use_specular_workflow || p.metallic.value.clamp(0.0, 1.0) == 0.0;
            if let (true, true, Some(texture)) = (only_diffuse, no_metal, p.diffuse_color.texture) {
                if let Bsdf::Preview(template) = material_bsdf(m, textures, Vec2::ZERO, &Footprint::POINT, None) {
                    return ResolvedBsdf::DiffuseTexture { template, texture, layers: template.layer_albedos() };
                }
            }
        }
        ResolvedBsdf::Textured
    }
}

/// Does shading `m` read texture coordinates or vertex colours (a textured input, emission or
/// normal map, vertex colours)?
fn reads_surface_data(m: &Material) -> bool {
    bsdf_is_textured(m)
        || m.emission().is_some_and(|e| e.texture.is_some())
        || matches!(m, Material::PreviewSurface(p) if p.normal_map.is_some() || p.opacity.texture.is_some())
}

/// Does any BSDF input of `m` come from a texture (or from vertex colours)?
fn bsdf_is_textured(m: &Material) -> bool {
    match m {
        Material::Error { .. } => false,
        Material::Lambert { diffuse_color, .. } => diffuse_color.texture.is_some() || diffuse_color.vertex,
        Material::PreviewSurface(p) => {
            [&p.diffuse_color, &p.specular_color, &p.specular_tint].iter().any(|c| c.texture.is_some() || c.vertex)
                || [&p.metallic, &p.roughness, &p.clearcoat, &p.clearcoat_roughness, &p.opacity].iter().any(|c| c.texture.is_some())
        }
    }
}

/// The BSDF of `material` at texture coordinates `uv` (textures filtered over the footprint
/// `fp`), on a surface of vertex colour `color` (if its mesh has colours).
fn material_bsdf(material: &Material, textures: &[Arc<Texture>], uv: Vec2, fp: &Footprint, color: Option<Vec3>) -> Bsdf {
    let c = |tc: &crate::scene::TexturedColor| match (tc.texture, color) {
        (Some(t), _) => textures[t as usize].eval_rgb_filtered(uv, fp),
        (None, Some(vertex)) if tc.vertex => vertex,
        _ => Vec3::from(tc.value),
    };
    match material {
        Material::Error { .. } => Bsdf::error(),
        Material::Lambert { diffuse_color, .. } => Bsdf::lambert(c(diffuse_color).clamp(Vec3::ZERO, Vec3::ONE)),
        Material::PreviewSurface(p) => {
            let s = |ts: &crate::scene::TexturedScalar| match ts.texture {
                Some(t) => textures[t as usize].eval_scalar_filtered(uv, fp),
                None => ts.value,
            };
            let opacity = if p.opacity_threshold > 0.0 { 1.0 } else { s(&p.opacity).clamp(0.0, 1.0) };
            Bsdf::from_preview_surface(&SurfaceParams {
                diffuse: c(&p.diffuse_color).clamp(Vec3::ZERO, Vec3::ONE),
                specular: c(&p.specular_color).clamp(Vec3::ZERO, Vec3::ONE),
                use_specular_workflow: p.use_specular_workflow,
                metallic: s(&p.metallic).clamp(0.0, 1.0),
                roughness: s(&p.roughness).clamp(0.0, 1.0),
                clearcoat: s(&p.clearcoat).clamp(0.0, 1.0),
                clearcoat_roughness: s(&p.clearcoat_roughness).clamp(0.0, 1.0),
                opacity,
                ior: p.ior,
                specular_tint: c(&p.specular_tint).clamp(Vec3::ZERO, Vec3::ONE),
                transmission_color: Vec3::from(p.transmission_color),
            })
        }
    }
}

/// Which materials some placed triangle uses.
pub fn used_materials(desc: &SceneDesc) -> Vec<bool> {
    let mut used = vec![false; desc.materials.len()];
    for inst in &desc.instances {
        let m = &desc.meshes[inst.mesh as usize];
        if m.material_ids.len() == 1 {
            used[m.material_ids[0] as usize] = true;
        } else {
            m.material_ids.iter().for_each(|&i| used[i as usize] = true);
        }
    }
    used
}

/// Union of the lobes of the materials the scene's triangles use (without building anything).
pub fn scene_flags(desc: &SceneDesc) -> BsdfFlags {
    desc.materials.iter().zip(used_materials(desc)).filter(|(_, u)| *u).fold(BsdfFlags::EMPTY, |f, (m, _)| f | material_flags(m))
}

pub fn material_flags(mat: &Material) -> BsdfFlags {
    match mat {
        Material::Error { .. } => Bsdf::error().flags(),
        Material::Lambert { diffuse_color, .. } => Bsdf::lambert(Vec3::from(diffuse_color.value)).flags(),
        Material::PreviewSurface(p) => Bsdf::from_preview_surface(&SurfaceParams {
            diffuse: Vec3::from(p.diffuse_color.value),
            specular: Vec3::from(p.specular_color.value),
            use_specular_workflow: p.use_specular_workflow,
            metallic: p.metallic.value,
            roughness: p.roughness.value,
            clearcoat: p.clearcoat.value,
            clearcoat_roughness: p.clearcoat_roughness.value,
            opacity: if p.opacity_threshold > 0.0 { 1.0 } else { p.opacity.value },
            ior: p.ior,
            specular_tint: Vec3::from(p.specular_tint.value),
            transmission_color: Vec3::from(p.transmission_color),
        })
        .flags(),
    }
}

/// MikkTSpace tangents of the meshes a normal-mapped material is on (`None` for the others); a
/// warning for such a mesh without texture coordinates, whose map is then not applied.
fn mesh_tangents(meshes: &[Mesh], looks: &[Look], warnings: &mut Vec<Warning>) -> Vec<Option<Vec<Vec4>>> {
    let mapped = |m: &Mesh| m.material_ids.iter().any(|&i| looks.get(i as usize).is_some_and(|l| l.normal_map.is_some()));
    // (a subdivision surface Embree tessellates takes its frame from the limit surface at a hit)
    let tangents: Vec<Option<Vec<Vec4>>> =
        meshes.par_iter().map(|m| if mapped(m) && m.subdivision.is_none() { tangents::mikktspace(m) } else { None }).collect();
    for (m, t) in meshes.iter().zip(&tangents) {
        let usable = match &m.subdivision {
            Some(sd) => sd.uvs.is_some(),
            None => t.is_some(),
        };
        if mapped(m) && !usable {
            warnings.push(Warning { prim: m.name.clone(), message: "a normal map needs texture coordinates (tangents), and the mesh has none usable; its interpolated normals are used".into() });
        }
    }
    tangents
}
