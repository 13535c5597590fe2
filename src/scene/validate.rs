//! Validation of a `SceneDesc`: hard errors for data that cannot be rendered (NaN, out-of-range
//! indices, zero-area lights), counted repairs for data that can (degenerate triangles, zero normals).

use super::{mat4, Light, Material, SceneDesc, Warning};
use crate::error::{Error, Result};
use glam::Vec3;

/// What validation repaired.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Repairs {
    pub degenerate_triangles: usize,
    pub zero_normals: usize,
}

/// Largest coordinate of any placed geometry, in metres.
pub const MAX_COORD: f32 = 1e15;

fn finite3(v: &[f32]) -> bool {
    v.iter().all(|x| x.is_finite())
}

impl SceneDesc {
    /// Check the scene and repair what can be repaired. Errors name the source file and the prim.
    /// Repairs are also appended to `warnings`.
    pub fn validate(&mut self) -> Result<Repairs> {
        let file = self.source.clone();
        let err = |prim: &str, msg: String| Error::scene(&file, prim, msg);
        let mut repairs = Repairs::default();
        let n_mat = self.materials.len() as u32;
        let n_tex = self.textures.len() as u32;
        if self.meshes.is_empty() || self.instances.is_empty() {
            return Err(err("/", "the scene has no geometry".into()));
        }
        for t in &self.textures {
            let numbers = t.scale.iter().chain(&t.bias).chain(&t.fallback).chain(t.st_transform.iter().flatten());
            if !numbers.into_iter().all(|v| v.is_finite()) {
                let who = if t.prim.is_empty() { &t.path } else { &t.prim };
                return Err(err(who, format!("texture {:?} has a non-finite scale, bias, fallback or st transform", t.path)));
            }
        }
        for m in &self.materials {
            let (name, colors) = match m {
                Material::Lambert { name, diffuse_color, emissive_color } => (name, vec![("diffuse", diffuse_color), ("emissive", emissive_color)]),
                Material::PreviewSurface(p) => (&p.name, vec![("diffuse", &p.diffuse_color), ("emissive", &p.emissive_color), ("specular", &p.specular_color)]),
                Material::Error { name } => (name, vec![]),
            };
            for (what, c) in colors {
                if c.vertex && (c.texture.is_some() || what != "diffuse") {
                    return Err(err(name, format!("the {what} colour cannot read vertex colours{}", if c.texture.is_some() { " and a texture" } else { "" })));
                }
            }
            if let Material::Lambert { name, diffuse_color, emissive_color } = m {
                let texs = [diffuse_color.texture, emissive_color.texture];
                if texs.iter().flatten().any(|&t| t >= n_tex) {
                    return Err(err(name, "texture index out of range".into()));
                }
                if !finite3(&diffuse_color.value) || !finite3(&emissive_color.value) {
                    return Err(err(name, "material parameter is NaN or infinite".into()));
                }
                if emissive_color.value.iter().any(|&c| c < 0.0) {
                    return Err(err(name, "negative emissiveColor".into()));
                }
            }
            if let Material::PreviewSurface(p) = m {
                let texs = [
                    p.diffuse_color.texture,
                    p.emissive_color.texture,
                    p.specular_color.texture,
                    p.metallic.texture,
                    p.roughness.texture,
                    p.clearcoat.texture,
                    p.clearcoat_roughness.texture,
                    p.opacity.texture,
                    p.normal_map,
                ];
                if texs.iter().flatten().any(|&t| t >= n_tex) {
                    return Err(err(&p.name, "texture index out of range".into()));
                }
                let colors = [p.diffuse_color.value, p.emissive_color.value, p.specular_color.value];
                let scalars = [
                    p.metallic.value,
                    p.roughness.value,
                    p.clearcoat.value,
                    p.clearcoat_roughness.value,
                    p.opacity.value,
                    p.opacity_threshold,
                    p.ior,
                ];
                if !colors.iter().all(|c| finite3(c)) || !finite3(&scalars) {
                    return Err(err(&p.name, "material parameter is NaN or infinite".into()));
                }
                if p.emissive_color.value.iter().any(|&c| c < 0.0) {
                    return Err(err(&p.name, "negative emissiveColor".into()));
                }
                if p.ior <= 0.0 {
                    return Err(err(&p.name, format!("ior must be positive, got {}", p.ior)));
                }
            }
        }
        for mesh in &mut self.meshes {
            let name = mesh.name.clone();
            let nv = mesh.positions.len();
            if mesh.positions.iter().any(|p| !p.is_finite()) {
                return Err(err(&name, "point positions contain NaN or infinite values".into()));
            }
            if let Some(sd) = &mesh.subdivision {
                if !mesh.indices.is_empty() || mesh.normals.is_some() || mesh.uvs.is_some() || mesh.colors.is_some() {
                    return Err(err(&name, "a subdivision surface keeps its faces and primvars in its cage, not in triangles".into()));
                }
                sd.validate(nv, &mesh.material_ids, n_mat).map_err(|m| err(&name, m))?;
                continue;
            }
            if let Some(n) = &mesh.normals {
                if n.len() != nv {
                    return Err(err(&name, format!("{} normals for {} points", n.len(), nv)));
                }
                if n.iter().any(|v| !v.is_finite()) {
                    return Err(err(&name, "normals contain NaN or infinite values".into()));
                }
            }
            if let Some(uv) = &mesh.uvs {
                if uv.len() != nv {
                    return Err(err(&name, format!("{} texture coordinates for {} points", uv.len(), nv)));
                }
                if uv.iter().any(|v| !v.is_finite()) {
                    return Err(err(&name, "texture coordinates contain NaN or infinite values".into()));
                }
            }
            if let Some(c) = &mesh.colors {
                if c.len() != nv {
                    return Err(err(&name, format!("{} vertex colours for {} points", c.len(), nv)));
                }
                if c.iter().any(|v| !v.is_finite()) {
                    return Err(err(&name, "vertex colours contain NaN or infinite values".into()));
                }
            }
            if let Some(bad) = mesh.indices.iter().flatten().find(|&&i| i as usize >= nv) {
                return Err(err(&name, format!("vertex index {bad} out of range (mesh has {nv} points)")));
            }
            let nt = mesh.indices.len();
            if !(mesh.material_ids.len() == 1 || mesh.material_ids.len() == nt) {
                return Err(err(&name, format!("{} material ids for {} triangles", mesh.material_ids.len(), nt)));
            }
            if let Some(bad) = mesh.material_ids.iter().find(|&&m| m >= n_mat) {
                return Err(err(&name, format!("material index {bad} out of range ({n_mat} materials)")));
            }
            // Drop degenerate (zero-area) triangles.
            let keep: Vec<bool> = mesh
                .indices
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
                    let (e1, e2) = (b - a, c - a);
                    let scale = e1.length_squared().max(e2.length_squared()).max((c - b).length_squared());
                    e1.cross(e2).length() > 1e-10 * scale
                })
                .collect();
            let dropped = keep.iter().filter(|k| !**k).count();
            if dropped > 0 {
                repairs.degenerate_triangles += dropped;
                let mut it = keep.iter();
                mesh.indices.retain(|_| *it.next().unwrap());
                if mesh.material_ids.len() > 1 {
                    let mut it = keep.iter();
                    mesh.material_ids.retain(|_| *it.next().unwrap());
                }
                self.warnings.push(Warning {
                    prim: name.clone(),
                    message: format!("dropped {dropped} degenerate (zero-area) triangles"),
                });
            }
            if let Some(n) = &mut mesh.normals {
                let mut fixed = 0;
                for v in n.iter_mut() {
                    if v.length_squared() < 1e-20 {
                        *v = Vec3::ZERO; // the shading code falls back to the geometric normal
                        fixed += 1;
                    } else {
                        *v = v.normalize();
                    }
                }
                if fixed > 0 {
                    repairs.zero_normals += fixed;
                    self.warnings.push(Warning {
                        prim: name.clone(),
                        message: format!("{fixed} zero-length normals replaced by the geometric normal"),
                    });
                }
            }
        }
        let n_mesh = self.meshes.len() as u32;
        for inst in &self.instances {
            if inst.mesh >= n_mesh {
                return Err(err(&inst.name, format!("instance of mesh {} out of range", inst.mesh)));
            }
            if !inst.transform.is_finite() {
                return Err(err(&inst.name, "transform contains NaN or infinite values".into()));
            }
            if inst.transform.determinant().abs() < 1e-30 {
                return Err(err(&inst.name, "transform is singular (zero scale)".into()));
            }
        }
        // Geometry far out overflows single precision where distances are squared (|v|² passes
        // f32::MAX at 1.8e19): every placed mesh's bounds must lie within ±MAX_COORD metres.
        let mut local: Vec<Option<(Vec3, Vec3)>> = vec![None; self.meshes.len()];
        for inst in &self.instances {
            let (lo, hi) = *local[inst.mesh as usize].get_or_insert_with(|| {
                let ps = &self.meshes[inst.mesh as usize].positions;
                ps.iter().fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(lo, hi), p| (lo.min(*p), hi.max(*p)))
            });
            if lo.x > hi.x {
                continue; // no points
            }
            for k in 0..8 {
                let c = Vec3::new(if k & 1 == 0 { lo.x } else { hi.x }, if k & 2 == 0 { lo.y } else { hi.y }, if k & 4 == 0 { lo.z } else { hi.z });
                let far = inst.transform.transform_point3(c).abs().max_element();
                if !(far <= MAX_COORD) {
                    return Err(err(&inst.name, format!("geometry reaches {far:.3e} m from the origin; coordinates must lie within ±{MAX_COORD:.0e} m (single precision)")));
                }
            }
        }
        for light in &self.lights {
            validate_light(light, n_tex).map_err(|m| err(light.name(), m))?;
        }
        let cam = &self.camera;
        if !mat4(&cam.transform).is_finite() {
            return Err(err(&cam.name, "camera transform has a non-finite value (NaN or infinite)".into()));
        }
        if !finite3(&[cam.focal_length, cam.horizontal_aperture, cam.vertical_aperture])
            || cam.focal_length <= 0.0
            || cam.horizontal_aperture <= 0.0
            || cam.vertical_aperture <= 0.0
        {
            return Err(err(&cam.name, "camera focal length and apertures must be positive and finite".into()));
        }
        if !(cam.clipping[0] >= 0.0 && cam.clipping[1] > cam.clipping[0]) {
            return Err(err(&cam.name, format!("invalid clipping range {:?}", cam.clipping)));
        }
        if !cam.aperture_offset.iter().all(|o| o.is_finite()) {
            return Err(err(&cam.name, format!("camera aperture offset {:?} is not finite", cam.aperture_offset)));
        }
        if !(cam.lens_radius >= 0.0 && cam.lens_radius < 1e6) {
            return Err(err(&cam.name, format!("camera lens radius {} m must be finite and at least 0", cam.lens_radius)));
        }
        if !(cam.pixel_aspect > 1e-3 && cam.pixel_aspect < 1e3) {
            return Err(err(&cam.name, format!("pixel aspect ratio {} must be between 0.001 and 1000", cam.pixel_aspect)));
        }
        if !(cam.exposure_scale > 0.0 && cam.exposure_scale.is_finite()) {
            return Err(err(&cam.name, format!("camera exposure scale {} must be positive and finite", cam.exposure_scale)));
        }
        if !crate::scene::ASPECT_CONFORM.contains(&cam.aspect_conform.as_str()) {
            return Err(err(&cam.name, format!("unknown aspect ratio conform policy {:?} (known: {})", cam.aspect_conform, crate::scene::ASPECT_CONFORM.join(", "))));
        }
        if cam.lens_radius > 0.0 {
            if cam.projection == "orthographic" {
                return Err(err(&cam.name, "a lens (depth of field) needs a perspective camera".into()));
            }
            if !(cam.focus_distance > 0.0 && cam.focus_distance < 1e30) {
                return Err(err(&cam.name, format!("camera focus distance {} m must be positive and finite with a lens", cam.focus_distance)));
            }
        }
        Ok(repairs)
    }
}

fn validate_light(light: &Light, n_tex: u32) -> std::result::Result<(), String> {
    let check_radiance = |r: &[f32; 3]| {
        if !finite3(r) {
            Err("radiance is NaN or infinite".to_string())
        } else if r.iter().any(|&c| c < 0.0) {
            Err("radiance is negative".to_string())
        } else {
            Ok(())
        }
    };
    let check_xf = |m: &[[f32; 4]; 4]| {
        if mat4(m).is_finite() {
            Ok(())
        } else {
            Err("transform contains NaN or infinite values".to_string())
        }
    };
    let check_size = |what: &str, v: f32| {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(format!("{what} must be positive (zero-area light), got {v}"))
        }
    };
    match light {
        Light::Rect { transform, width, height, radiance, texture, .. } => {
            check_xf(transform)?;
            check_size("width", *width)?;
            check_size("height", *height)?;
            check_radiance(radiance)?;
            if texture.is_some_and(|t| t >= n_tex) {
                return Err("texture index out of range".into());
            }
        }
        Light::Disk { transform, radius, radiance, .. } => {
            check_xf(transform)?;
            check_size("radius", *radius)?;
            check_radiance(radiance)?;
        }
        Light::Sphere { transform, radius, radiance, cone, .. } => {
            check_xf(transform)?;
            check_size("radius", *radius)?;
            check_radiance(radiance)?;
            if let Some(c) = cone {
                if !(c.angle_deg.is_finite() && c.angle_deg > 0.0 && c.softness.is_finite() && c.focus.is_finite()) {
                    return Err(format!(
                        "spot cone (ShapingAPI) out of range: shaping:cone:angle {}° must be above 0, softness {} and focus {} finite",
                        c.angle_deg, c.softness, c.focus
                    ));
                }
            }
        }
        Light::Distant { direction, angle_deg, irradiance, .. } => {
            if !finite3(direction) || Vec3::from(*direction).length_squared() < 1e-12 {
                return Err("direction is zero, NaN or infinite".into());
            }
            if !(angle_deg.is_finite() && *angle_deg >= 0.0 && *angle_deg < 180.0) {
                return Err(format!("angle must be in [0, 180) degrees, got {angle_deg}"));
            }
            check_radiance(irradiance)?;
        }
        Light::Dome { transform, radiance, texture, .. } => {
            check_xf(transform)?;
            check_radiance(radiance)?;
            if texture.is_some_and(|t| t >= n_tex) {
                return Err("texture index out of range".into());
            }
        }
    }
    Ok(())
}
