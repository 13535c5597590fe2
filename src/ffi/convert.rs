//! Lossless conversions between the bridge's plain structs and the scene/settings types.
//!
//! Every conversion from C++ data to a scene type is exact (the same bits), so a scene exported
//! through the API and rebuilt from the exported arrays renders bit-identically.

use super::bridge::ffi;
use crate::error::{Error, Result};
use crate::integrators::{Method, RenderRequest, Resolved, Stats};
use crate::scene::{
    Camera, Cone, Instance, Light, Material, Mesh, PreviewSurface, TextureDesc, TexturedColor, TexturedScalar, Warning,
};
use glam::{Mat4, Vec2, Vec3};

/// A 4×4 matrix in the scene's column-major nested layout, flattened.
pub fn flat(m: &[[f32; 4]; 4]) -> [f32; 16] {
    let mut out = [0.0; 16];
    for (c, col) in m.iter().enumerate() {
        out[4 * c..4 * c + 4].copy_from_slice(col);
    }
    out
}

/// Flattened column-major 4×4 to the scene's nested layout.
pub fn nested(m: &[f32; 16]) -> [[f32; 4]; 4] {
    [[m[0], m[1], m[2], m[3]], [m[4], m[5], m[6], m[7]], [m[8], m[9], m[10], m[11]], [m[12], m[13], m[14], m[15]]]
}

fn identity16() -> [f32; 16] {
    Mat4::IDENTITY.to_cols_array()
}

/// `-1` (none) or a non-negative index.
fn texture_in(index: i32, file: &str, owner: &str, what: &str) -> Result<Option<u32>> {
    match index {
        -1 => Ok(None),
        i if i >= 0 => Ok(Some(i as u32)),
        i => Err(Error::scene(file, owner, format!("{what} texture index {i} is invalid (use -1 for none)"))),
    }
}

fn texture_out(index: Option<u32>) -> i32 {
    // Scenes have far fewer than 2^31 textures; saturate rather than wrap if one ever had more.
    index.map_or(-1, |i| i32::try_from(i).unwrap_or(i32::MAX))
}

fn color_out(c: &TexturedColor) -> ffi::ColorParam {
    ffi::ColorParam { value: c.value, texture: texture_out(c.texture), vertex: c.vertex }
}

fn scalar_out(s: &TexturedScalar) -> ffi::ScalarParam {
    ffi::ScalarParam { value: s.value, texture: texture_out(s.texture) }
}

// ---------------------------------------------------------------------------------------------
// Materials and textures

pub fn material_out(m: &Material) -> ffi::MaterialDesc {
    match m {
        Material::PreviewSurface(p) => ffi::MaterialDesc {
            name: p.name.clone(),
            is_error: false,
            is_lambert: false,
            diffuse_color: color_out(&p.diffuse_color),
            emissive_color: color_out(&p.emissive_color),
            use_specular_workflow: p.use_specular_workflow,
            specular_color: color_out(&p.specular_color),
            metallic: scalar_out(&p.metallic),
            roughness: scalar_out(&p.roughness),
            clearcoat: scalar_out(&p.clearcoat),
            clearcoat_roughness: scalar_out(&p.clearcoat_roughness),
            opacity: scalar_out(&p.opacity),
            opacity_threshold: p.opacity_threshold,
            ior: p.ior,
            normal_map: texture_out(p.normal_map),
        },
        Material::Error { name } => {
            let mut d = material_out(&Material::PreviewSurface(PreviewSurface::default()));
            d.name = name.clone();
            d.is_error = true;
            d
        }
        Material::Lambert { name, diffuse_color, emissive_color } => {
            let mut d = material_out(&Material::PreviewSurface(PreviewSurface::default()));
            d.name = name.clone();
            d.is_lambert = true;
            d.diffuse_color = color_out(diffuse_color);
            d.emissive_color = color_out(emissive_color);
            d
        }
    }
}

pub fn material_in(d: &ffi::MaterialDesc, file: &str) -> Result<Material> {
    if d.is_error {
        return Ok(Material::Error { name: d.name.clone() });
    }
    let name = d.name.as_str();
    let color = |c: &ffi::ColorParam, what: &str| -> Result<TexturedColor> {
        Ok(TexturedColor { value: c.value, texture: texture_in(c.texture, file, name, what)?, vertex: c.vertex })
    };
    let scalar = |s: &ffi::ScalarParam, what: &str| -> Result<TexturedScalar> {
        Ok(TexturedScalar { value: s.value, texture: texture_in(s.texture, file, name, what)? })
    };
    if d.is_lambert {
        return Ok(Material::Lambert {
            name: d.name.clone(),
            diffuse_color: color(&d.diffuse_color, "diffuseColor")?,
            emissive_color: color(&d.emissive_color, "emissiveColor")?,
        });
    }
    Ok(Material::PreviewSurface(PreviewSurface {
        name: d.name.clone(),
        diffuse_color: color(&d.diffuse_color, "diffuseColor")?,
        emissive_color: color(&d.emissive_color, "emissiveColor")?,
        use_specular_workflow: d.use_specular_workflow,
        specular_color: color(&d.specular_color, "specularColor")?,
        metallic: scalar(&d.metallic, "metallic")?,
        roughness: scalar(&d.roughness, "roughness")?,
        clearcoat: scalar(&d.clearcoat, "clearcoat")?,
        clearcoat_roughness: scalar(&d.clearcoat_roughness, "clearcoatRoughness")?,
        opacity: scalar(&d.opacity, "opacity")?,
        opacity_threshold: d.opacity_threshold,
        ior: d.ior,
        normal_map: texture_in(d.normal_map, file, name, "normal")?,
        ..PreviewSurface::default()
    }))
}

pub fn texture_desc_out(t: &TextureDesc) -> ffi::TextureDesc {
    ffi::TextureDesc {
        path: t.path.clone(),
        wrap_s: t.wrap_s.clone(),
        wrap_t: t.wrap_t.clone(),
        scale: t.scale,
        bias: t.bias,
        color_space: t.color_space.clone(),
        output: t.output.clone(),
        fallback: t.fallback,
        st_transform: [t.st_transform[0][0], t.st_transform[0][1], t.st_transform[0][2], t.st_transform[1][0], t.st_transform[1][1], t.st_transform[1][2]],
    }
}

pub fn texture_desc_in(d: &ffi::TextureDesc) -> TextureDesc {
    TextureDesc {
        path: d.path.clone(),
        wrap_s: d.wrap_s.clone(),
        wrap_t: d.wrap_t.clone(),
        scale: d.scale,
        bias: d.bias,
        color_space: d.color_space.clone(),
        output: d.output.clone(),
        fallback: d.fallback,
        st_transform: [[d.st_transform[0], d.st_transform[1], d.st_transform[2]], [d.st_transform[3], d.st_transform[4], d.st_transform[5]]],
        // (textures built in C++ have no prim: their warnings name the file)
        prim: String::new(),
    }
}

// ---------------------------------------------------------------------------------------------
// Lights

/// A light description of `kind` with every field at a neutral default.
pub fn light_default(kind: ffi::LightKind, name: &str) -> ffi::LightDesc {
    ffi::LightDesc {
        kind,
        name: name.to_string(),
        transform: identity16(),
        width: 1.0,
        height: 1.0,
        radius: 0.5,
        radiance: [1.0; 3],
        texture: -1,
        has_cone: false,
        cone_angle_deg: 90.0,
        cone_softness: 0.0,
        cone_focus: 0.0,
        direction: [0.0, 0.0, -1.0],
        angle_deg: 0.53,
    }
}

pub fn light_out(l: &Light) -> ffi::LightDesc {
    use ffi::LightKind as K;
    match l {
        Light::Rect { name, transform, width, height, radiance, texture } => ffi::LightDesc {
            transform: flat(transform),
            width: *width,
            height: *height,
            radiance: *radiance,
            texture: texture_out(*texture),
            ..light_default(K::Rect, name)
        },
        Light::Disk { name, transform, radius, radiance } => ffi::LightDesc {
            transform: flat(transform),
            radius: *radius,
            radiance: *radiance,
            ..light_default(K::Disk, name)
        },
        Light::Sphere { name, transform, radius, radiance, cone } => {
            let mut d = ffi::LightDesc {
                transform: flat(transform),
                radius: *radius,
                radiance: *radiance,
                ..light_default(K::Sphere, name)
            };
            if let Some(c) = cone {
                d.has_cone = true;
                d.cone_angle_deg = c.angle_deg;
                d.cone_softness = c.softness;
                d.cone_focus = c.focus;
            }
            d
        }
        Light::Distant { name, direction, angle_deg, irradiance } => ffi::LightDesc {
            direction: *direction,
            angle_deg: *angle_deg,
            radiance: *irradiance,
            ..light_default(K::Distant, name)
        },
        Light::Dome { name, transform, radiance, texture } => ffi::LightDesc {
            transform: flat(transform),
            radiance: *radiance,
            texture: texture_out(*texture),
            ..light_default(K::Dome, name)
        },
    }
}

pub fn light_in(d: &ffi::LightDesc, file: &str) -> Result<Light> {
    use ffi::LightKind as K;
    let name = d.name.clone();
    let texture = || texture_in(d.texture, file, &d.name, "light");
    Ok(match d.kind {
        K::Rect => Light::Rect {
            name,
            transform: nested(&d.transform),
            width: d.width,
            height: d.height,
            radiance: d.radiance,
            texture: texture()?,
        },
        K::Disk => Light::Disk { name, transform: nested(&d.transform), radius: d.radius, radiance: d.radiance },
        K::Sphere => Light::Sphere {
            name,
            transform: nested(&d.transform),
            radius: d.radius,
            radiance: d.radiance,
            cone: d.has_cone.then_some(Cone {
                angle_deg: d.cone_angle_deg,
                softness: d.cone_softness,
                focus: d.cone_focus,
            }),
        },
        K::Distant => Light::Distant { name, direction: d.direction, angle_deg: d.angle_deg, irradiance: d.radiance },
        K::Dome => Light::Dome { name, transform: nested(&d.transform), radiance: d.radiance, texture: texture()? },
        other => {
            return Err(Error::scene(file, &d.name, format!("unknown light kind {}", other.repr)));
        }
    })
}

// ---------------------------------------------------------------------------------------------
// Camera, instances, meshes

pub fn camera_out(c: &Camera) -> ffi::CameraDesc {
    ffi::CameraDesc {
        name: c.name.clone(),
        transform: flat(&c.transform),
        projection: c.projection.clone(),
        focal_length: c.focal_length,
        horizontal_aperture: c.horizontal_aperture,
        vertical_aperture: c.vertical_aperture,
        clipping: c.clipping,
        aperture_offset: c.aperture_offset,
        lens_radius: c.lens_radius,
        focus_distance: c.focus_distance,
        pixel_aspect: c.pixel_aspect,
        aspect_conform: c.aspect_conform.clone(),
    }
}

pub fn camera_in(d: &ffi::CameraDesc) -> Camera {
    Camera {
        name: d.name.clone(),
        transform: nested(&d.transform),
        projection: d.projection.clone(),
        focal_length: d.focal_length,
        horizontal_aperture: d.horizontal_aperture,
        vertical_aperture: d.vertical_aperture,
        clipping: d.clipping,
        aperture_offset: d.aperture_offset,
        lens_radius: d.lens_radius,
        focus_distance: d.focus_distance,
        pixel_aspect: d.pixel_aspect,
        aspect_conform: d.aspect_conform.clone(),
        // not in the C++ API yet: 1 (the image as rendered)
        ..Camera::default()
    }
}

pub fn instance_out(i: &Instance) -> ffi::InstanceDesc {
    ffi::InstanceDesc { mesh: i.mesh, transform: i.transform.to_cols_array(), name: i.name.clone() }
}

pub fn instance_in(d: &ffi::InstanceDesc) -> Instance {
    Instance { mesh: d.mesh, transform: Mat4::from_cols_array(&d.transform), name: d.name.clone() }
}

pub fn mesh_out(m: &Mesh) -> ffi::MeshData {
    let v3 = |v: &[Vec3]| v.iter().flat_map(|p| p.to_array()).collect::<Vec<f32>>();
    ffi::MeshData {
        name: m.name.clone(),
        positions: v3(&m.positions),
        indices: m.indices.iter().flatten().copied().collect(),
        normals: m.normals.as_deref().map(v3).unwrap_or_default(),
        uvs: m.uvs.as_ref().map(|uv| uv.iter().flat_map(|p| p.to_array()).collect()).unwrap_or_default(),
        material_ids: m.material_ids.clone(),
        double_sided: m.double_sided,
        colors: m.colors.as_deref().map(v3).unwrap_or_default(),
    }
}

/// Vertex colours given to `SceneBuilder::set_mesh_colors` (r, g, b per point; empty: none).
pub fn colors_in(mesh: &Mesh, colors: &[f32], file: &str) -> Result<Option<Vec<Vec3>>> {
    if colors.is_empty() {
        return Ok(None);
    }
    if colors.len() != 3 * mesh.positions.len() {
        return Err(Error::scene(file, &mesh.name, format!("{} colour values for {} points (3 per point)", colors.len(), mesh.positions.len())));
    }
    Ok(Some(colors.chunks_exact(3).map(Vec3::from_slice).collect()))
}

/// Arrays of a mesh as given to `SceneBuilder::add_mesh`.
pub struct MeshArrays<'a> {
    pub name: &'a str,
    pub positions: &'a [f32],
    pub indices: &'a [u32],
    pub normals: &'a [f32],
    pub uvs: &'a [f32],
    pub material_ids: &'a [u32],
    pub double_sided: bool,
}

/// Build a `Mesh`, checking the array lengths (ranges and values are checked by validation).
pub fn mesh_in(a: &MeshArrays, file: &str) -> Result<Mesh> {
    let err = |msg: String| Error::scene(file, a.name, msg);
    let multiple = |what: &str, len: usize, k: usize| {
        if len % k == 0 {
            Ok(())
        } else {
            Err(err(format!("{what} has {len} values, not a multiple of {k}")))
        }
    };
    multiple("positions", a.positions.len(), 3)?;
    multiple("indices", a.indices.len(), 3)?;
    multiple("normals", a.normals.len(), 3)?;
    multiple("uvs", a.uvs.len(), 2)?;
    let points = a.positions.len() / 3;
    if !a.normals.is_empty() && a.normals.len() / 3 != points {
        return Err(err(format!("{} normals for {} points", a.normals.len() / 3, points)));
    }
    if !a.uvs.is_empty() && a.uvs.len() / 2 != points {
        return Err(err(format!("{} texture coordinates for {} points", a.uvs.len() / 2, points)));
    }
    if a.material_ids.is_empty() {
        return Err(err("no material ids (give one per triangle, or one for all)".into()));
    }
    let v3 = |v: &[f32]| v.chunks_exact(3).map(Vec3::from_slice).collect::<Vec<_>>();
    Ok(Mesh {
        name: a.name.to_string(),
        positions: v3(a.positions),
        indices: a.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
        normals: (!a.normals.is_empty()).then(|| v3(a.normals)),
        uvs: (!a.uvs.is_empty()).then(|| a.uvs.chunks_exact(2).map(Vec2::from_slice).collect()),
        colors: None,
        material_ids: a.material_ids.to_vec(),
        double_sided: a.double_sided,
        subdivision: None,
    })
}

pub fn warning_out(w: &Warning) -> ffi::SceneWarning {
    ffi::SceneWarning { prim: w.prim.clone(), message: w.message.clone() }
}

// ---------------------------------------------------------------------------------------------
// Settings and statistics

pub fn options_default() -> ffi::RenderOptions {
    options_out(&RenderRequest::DEFAULT)
}

/// A request as `RenderOptions`: 0 and "" for what it does not give.
pub fn options_out(r: &RenderRequest) -> ffi::RenderOptions {
    let [width, height] = r.resolution.unwrap_or([0, 0]);
    ffi::RenderOptions {
        method: r.method.map_or("auto", Method::name).to_string(),
        quality: r.quality.map_or(String::new(), |q| q.name().to_string()),
        spp: r.spp.unwrap_or(0),
        time_budget: r.time.unwrap_or(0.0),
        seed: r.seed,
        threads: u32::try_from(r.threads).unwrap_or(u32::MAX),
        width,
        height,
        max_depth: r.max_depth,
        photons: r.photons.map_or(0, |p| p as u64),
        knn: u32::try_from(r.knn).unwrap_or(u32::MAX),
        smoothness: r.smoothness,
        sensitivity: r.sensitivity,
        max_bandwidth: r.max_bandwidth,
        direct_photons: r.direct_photons,
        light_samples: r.light_samples,
        aa_spp: r.aa_spp,
        glossy: r.glossy.name().to_string(),
        filter_radius: r.filter_radius,
        gather_rays: r.fg_rays.unwrap_or(0),
        memory_budget: r.memory.unwrap_or(0),
        gather_radius: r.gather_radius.unwrap_or(0.0),
        spill_dir: r.spill_dir.as_ref().map_or(String::new(), |d| d.display().to_string()),
        no_spill: r.no_spill,
        density_limit: r.density_limit.unwrap_or(0.0),
        cache_error: r.cache_error.unwrap_or(0.0),
        denoise: r.denoise.mode.name().to_string(),
        denoise_quality: r.denoise.quality.name().to_string(),
        pixel_filter: r.filter.name().to_string(),
        pixel_filter_radius: r.pixel_filter_radius.unwrap_or(0.0),
    }
}

/// The request `RenderOptions` stand for (0 and "" = not given), parsed with the CLI's messages;
/// its settings are validated where the CLI's are ([`RenderRequest::resolve`]).
pub fn request_in(o: &ffi::RenderOptions) -> Result<RenderRequest> {
    let d = RenderRequest::DEFAULT;
    // Every field is given: a new setting fails to compile here until the C++ API maps it.
    Ok(RenderRequest {
        method: crate::integrators::parse_method(&o.method)?,
        quality: (!o.quality.is_empty()).then(|| o.quality.parse()).transpose()?,
        spp: (o.spp != 0).then_some(o.spp),
        time: (o.time_budget != 0.0).then_some(o.time_budget),
        seed: o.seed,
        threads: o.threads as usize,
        resolution: (o.width != 0 || o.height != 0).then_some([o.width, o.height]),
        max_depth: o.max_depth,
        photons: (o.photons != 0).then(|| usize::try_from(o.photons).unwrap_or(usize::MAX)),
        smoothness: o.smoothness,
        sensitivity: o.sensitivity,
        max_bandwidth: o.max_bandwidth,
        knn: o.knn as usize,
        direct_photons: o.direct_photons,
        light_samples: o.light_samples,
        aa_spp: o.aa_spp,
        glossy: o.glossy.parse()?,
        filter_radius: o.filter_radius,
        // Not in the C++ API yet: the default (on).
        emission_guiding: d.emission_guiding,
        fg_rays: (o.gather_rays != 0).then_some(o.gather_rays),
        gather_radius: (o.gather_radius != 0.0).then_some(o.gather_radius),
        memory: (o.memory_budget != 0).then_some(o.memory_budget),
        spill_dir: (!o.spill_dir.is_empty()).then(|| std::path::PathBuf::from(&o.spill_dir)),
        no_spill: o.no_spill,
        density_limit: (o.density_limit != 0.0).then_some(o.density_limit),
        // he-fg's own options are not in the C++ API yet: the defaults (230 explicit rays per
        // voxel, automatic E_max and voxels, no irradiance cache).
        explicit_rays: d.explicit_rays,
        explicit_allocation: d.explicit_allocation,
        emax: d.emax,
        emax_multiplier: d.emax_multiplier,
        voxel_resolution: d.voxel_resolution,
        irradiance_cache: d.irradiance_cache,
        cache_error: (o.cache_error != 0.0).then_some(o.cache_error),
        texture_filter: d.texture_filter,
        filter: if o.pixel_filter.is_empty() { d.filter } else { crate::image::FilterKind::parse(&o.pixel_filter)? },
        pixel_filter_radius: (o.pixel_filter_radius != 0.0).then_some(o.pixel_filter_radius),
        // empty: the defaults (off, high quality)
        denoise: crate::denoise::Options {
            mode: if o.denoise.is_empty() { d.denoise.mode } else { o.denoise.parse()? },
            quality: if o.denoise_quality.is_empty() { d.denoise.quality } else { o.denoise_quality.parse()? },
            ..d.denoise
        },
    })
}

/// The names `RenderOptions::method` accepts: "auto", then every method.
pub fn method_names() -> Vec<String> {
    std::iter::once("auto").chain(Method::ALL.iter().map(|m| m.name())).map(String::from).collect()
}

/// The method of a render and auto's reason for it.
pub fn choice_out(r: &Resolved) -> ffi::MethodChoice {
    let auto = r.auto.as_ref();
    ffi::MethodChoice {
        method: r.settings.method.method().name().to_string(),
        automatic: auto.is_some(),
        rule: auto.map_or(String::new(), |a| a.rule.name()),
        reason: auto.map_or(String::new(), |a| a.to_string()),
        high_energy_share: auto.map_or(0.0, |a| a.high_energy_share()),
        indirect_share: auto.map_or(0.0, |a| a.indirect_share()),
        emitter_area_share: auto.map_or(0.0, |a| a.emitter_area_share()),
        survey_seconds: auto.map_or(0.0, |a| a.survey_seconds()),
    }
}

pub fn stats_out(s: &Stats) -> ffi::RenderStats {
    let counter = |(name, value): &(String, u64)| ffi::Counter { name: name.clone(), value: *value };
    ffi::RenderStats {
        summary: s.summary(),
        json: serde_json::to_string(s).unwrap_or_default(),
        total_seconds: s.total_seconds,
        phases: s.phases.iter().map(|(name, seconds)| ffi::Phase { name: name.clone(), seconds: *seconds }).collect(),
        counters: s.counters.iter().map(counter).collect(),
        enabled: s.enabled.iter().map(counter).collect(),
        warnings: s.warnings as u64,
        scene: s.scene.clone(),
    }
}
