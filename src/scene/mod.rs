//! The scene description: plain data in metres, Y up, linear Rec.709 radiance.
//!
//! A `SceneDesc` comes from a converted USD stage (see [`format`] and `docs/scene-format.md`), or is
//! built directly (tests, the C++ API). It is validated by [`SceneDesc::validate`] and then turned into
//! a render-time scene by `prepare`.
//!
//! Units: lengths in metres; radiance in W·sr⁻¹·m⁻² in linear Rec.709 primaries (USD "nits" are taken as
//! radiance units one-to-one); irradiance of distant lights in W·m⁻².

pub mod format;
pub mod subdiv;
pub mod validate;

use glam::{Mat4, Vec2, Vec3};
use serde::{Deserialize, Serialize};

/// A whole scene.
#[derive(Clone, Debug, Default)]
pub struct SceneDesc {
    /// Triangle meshes in object space. A mesh is placed in the world by one or more `instances`.
    pub meshes: Vec<Mesh>,
    /// Placements of meshes (object-to-world transforms, already in metres and Y-up).
    pub instances: Vec<Instance>,
    pub materials: Vec<Material>,
    pub textures: Vec<TextureDesc>,
    pub lights: Vec<Light>,
    pub camera: Camera,
    /// Resolution from `UsdRender.Settings` (if any); the CLI may override it.
    pub resolution: Option<[u32; 2]>,
    /// Everything the converter could not represent, with its prim path.
    pub warnings: Vec<Warning>,
    /// Where the scene came from (for error messages): the USD or scene file path.
    pub source: String,
    /// What the renderer makes of subdivision surfaces (a render setting, not stored in files).
    pub subdivision: subdiv::SubdivisionMode,
}

/// A triangle mesh in object space. All per-vertex arrays are indexed by `indices`
/// (face-varying USD data is expanded by the converter so that one index addresses all attributes).
///
/// A subdivision surface is a mesh with [`Mesh::subdivision`]: then `positions` are its control
/// points, `indices`, `normals`, `uvs` and `colors` are empty (the faces, tags and primvars are in
/// the [`subdiv::Subdivision`]), and `material_ids` holds one material per face of the cage.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// USD prim path (or a user-given name).
    pub name: String,
    pub positions: Vec<Vec3>,
    pub indices: Vec<[u32; 3]>,
    /// Optional shading normals (same length as `positions`).
    pub normals: Option<Vec<Vec3>>,
    /// Optional texture coordinates (same length as `positions`).
    pub uvs: Option<Vec<Vec2>>,
    /// Optional vertex colours, linear RGB (same length as `positions`): the diffuse colour of
    /// materials whose `diffuse_color.vertex` is set (USD `displayColor`, or the primvar a
    /// `UsdPrimvarReader_float3` reads).
    pub colors: Option<Vec<Vec3>>,
    /// Material index per triangle; a single entry means "all triangles".
    pub material_ids: Vec<u32>,
    /// `doubleSided` in USD. Single-sided meshes are still intersected from both sides (as in most
    /// production renderers); the flag is kept for emitters (emit from the front only) and culling.
    pub double_sided: bool,
    /// The control cage of a subdivision surface, if the mesh is one.
    pub subdivision: Option<Box<subdiv::Subdivision>>,
}

impl Mesh {
    /// Material of triangle `tri` (of face `tri` of a subdivision surface's cage).
    #[inline]
    pub fn material_of(&self, tri: usize) -> u32 {
        if self.material_ids.len() == 1 {
            self.material_ids[0]
        } else {
            self.material_ids[tri]
        }
    }
}

/// A placement of a mesh in the world.
#[derive(Clone, Debug)]
pub struct Instance {
    pub mesh: u32,
    /// Object-to-world transform (metres, Y up).
    pub transform: Mat4,
    /// USD prim path of the placed prim (instance proxies and point-instancer instances included).
    pub name: String,
}

/// A colour or scalar parameter that may come from a texture.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub struct TexturedColor {
    pub value: [f32; 3],
    /// Index into `SceneDesc::textures`; when set, the texture's output replaces `value`.
    #[serde(default)]
    pub texture: Option<u32>,
    /// The mesh's vertex colours ([`Mesh::colors`]) replace `value` on meshes that have them
    /// (honoured for diffuse colours; exclusive with `texture`).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub vertex: bool,
}

impl TexturedColor {
    pub fn constant(v: [f32; 3]) -> Self {
        Self { value: v, texture: None, vertex: false }
    }
}

#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub struct TexturedScalar {
    pub value: f32,
    #[serde(default)]
    pub texture: Option<u32>,
}

impl TexturedScalar {
    pub fn constant(v: f32) -> Self {
        Self { value: v, texture: None }
    }
}

/// A material. `PreviewSurface` follows the UsdPreviewSurface specification; `Lambert` is an ideal
/// diffuse reflector (analytic test scenes, the C++ API); `Error` is any shader the converter could
/// not translate (rendered in a visible error colour, and listed as a warning).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Material {
    PreviewSurface(PreviewSurface),
    Lambert {
        name: String,
        diffuse_color: TexturedColor,
        /// Radiance emitted by the surface (front side), W·sr⁻¹·m⁻².
        emissive_color: TexturedColor,
    },
    Error { name: String },
}

impl Material {
    pub fn name(&self) -> &str {
        match self {
            Material::PreviewSurface(p) => &p.name,
            Material::Lambert { name, .. } | Material::Error { name } => name,
        }
    }

    /// The emission input, if the material can emit.
    pub fn emission(&self) -> Option<&TexturedColor> {
        match self {
            Material::PreviewSurface(p) => Some(&p.emissive_color),
            Material::Lambert { emissive_color, .. } => Some(emissive_color),
            Material::Error { .. } => None,
        }
    }

    /// Multiply the emission by `k`.
    fn scale_emission(&mut self, k: f32) {
        match self {
            Material::PreviewSurface(p) => p.emissive_color.value.iter_mut().for_each(|x| *x *= k),
            Material::Lambert { emissive_color, .. } => emissive_color.value.iter_mut().for_each(|x| *x *= k),
            Material::Error { .. } => {}
        }
    }
}

/// UsdPreviewSurface inputs (defaults are the spec's).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default)]
pub struct PreviewSurface {
    pub name: String,
    pub diffuse_color: TexturedColor,
    /// Radiance emitted by the surface (front side), W·sr⁻¹·m⁻².
    pub emissive_color: TexturedColor,
    pub use_specular_workflow: bool,
    pub specular_color: TexturedColor,
    pub metallic: TexturedScalar,
    pub roughness: TexturedScalar,
    pub clearcoat: TexturedScalar,
    pub clearcoat_roughness: TexturedScalar,
    pub opacity: TexturedScalar,
    /// When > 0, opacity is a cut-out mask: opacity < threshold is a hole.
    pub opacity_threshold: f32,
    pub ior: f32,
    /// A tangent-space normal map: the texture's value (after its scale and bias, usually 2 and
    /// −1) is the normal in the frame of the surface's tangent, bitangent and normal.
    pub normal_map: Option<u32>,
    /// Weight times colour of the dielectric (non-metal) specular reflection in the metallic
    /// workflow: it scales its F0 and F90 (MaterialX `specular · specular_color`; 1 for
    /// UsdPreviewSurface).
    pub specular_tint: TexturedColor,
    /// Colour of the light the transparent part (`1 − opacity`) refracts (MaterialX
    /// `transmission_color`; white for UsdPreviewSurface).
    pub transmission_color: [f32; 3],
}

impl Default for PreviewSurface {
    fn default() -> Self {
        Self {
            name: String::new(),
            diffuse_color: TexturedColor::constant([0.18, 0.18, 0.18]),
            emissive_color: TexturedColor::constant([0.0; 3]),
            use_specular_workflow: false,
            specular_color: TexturedColor::constant([0.0; 3]),
            metallic: TexturedScalar::constant(0.0),
            roughness: TexturedScalar::constant(0.5),
            clearcoat: TexturedScalar::constant(0.0),
            clearcoat_roughness: TexturedScalar::constant(0.01),
            opacity: TexturedScalar::constant(1.0),
            opacity_threshold: 0.0,
            ior: 1.5,
            normal_map: None,
            specular_tint: TexturedColor::constant([1.0; 3]),
            transmission_color: [1.0; 3],
        }
    }
}

/// A texture referenced by materials or the dome light (a `UsdUVTexture`).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default)]
pub struct TextureDesc {
    /// Absolute path of the image file.
    pub path: String,
    /// "repeat" | "mirror" | "clamp" | "black"
    pub wrap_s: String,
    pub wrap_t: String,
    /// Applied as `texel * scale + bias` (RGBA).
    pub scale: [f32; 4],
    pub bias: [f32; 4],
    /// "sRGB" | "raw" | "auto" (auto: sRGB for 8-bit images, raw for float images).
    pub color_space: String,
    /// Which output of the UsdUVTexture is connected: "rgb" | "r" | "g" | "b" | "a".
    pub output: String,
    /// Constant used when the file is missing or unreadable (the spec's `fallback`).
    pub fallback: [f32; 4],
    /// The first prim that reads the file (a `UsdUVTexture` shader, or a light): warnings about
    /// the file name it. Empty for scenes built in code (the warnings then name the file).
    pub prim: String,
    /// Affine map of the texture coordinates before the lookup (the `UsdTransform2d` nodes on the
    /// texture's `st`): `st' = (a s + b t + c, d s + e t + f)` for `[[a, b, c], [d, e, f]]`.
    pub st_transform: [[f32; 3]; 2],
}

/// The identity [`TextureDesc::st_transform`].
pub const IDENTITY_ST: [[f32; 3]; 2] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

impl Default for TextureDesc {
    fn default() -> Self {
        Self {
            path: String::new(),
            wrap_s: "repeat".into(),
            wrap_t: "repeat".into(),
            scale: [1.0; 4],
            bias: [0.0; 4],
            color_space: "auto".into(),
            output: "rgb".into(),
            fallback: [0.0, 0.0, 0.0, 1.0],
            prim: String::new(),
            st_transform: IDENTITY_ST,
        }
    }
}

/// Spot-light shaping (UsdLuxShapingAPI).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub struct Cone {
    /// Half angle of the cone, degrees.
    pub angle_deg: f32,
    /// 0..1: fraction of the cone over which the edge falls off smoothly.
    pub softness: f32,
    /// Angular falloff exponent (`shaping:focus`).
    #[serde(default)]
    pub focus: f32,
}

/// A light. All transforms are light-to-world in metres; each light's local frame follows UsdLux
/// (rect/disk emit along local −Z; distant light travels along local −Z).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Light {
    Rect {
        name: String,
        transform: [[f32; 4]; 4],
        width: f32,
        height: f32,
        /// Emitted radiance (final: colour · intensity · 2^exposure · temperature, ÷ area if normalize).
        radiance: [f32; 3],
        #[serde(default)]
        texture: Option<u32>,
    },
    Disk {
        name: String,
        transform: [[f32; 4]; 4],
        radius: f32,
        radiance: [f32; 3],
    },
    Sphere {
        name: String,
        transform: [[f32; 4]; 4],
        radius: f32,
        radiance: [f32; 3],
        #[serde(default)]
        cone: Option<Cone>,
    },
    Distant {
        name: String,
        /// Direction the light travels (world, normalised).
        direction: [f32; 3],
        /// Full apex angle of the source, degrees (0 → a delta light).
        angle_deg: f32,
        /// Irradiance on a surface facing the light, W·m⁻².
        irradiance: [f32; 3],
    },
    Dome {
        name: String,
        transform: [[f32; 4]; 4],
        radiance: [f32; 3],
        /// Lat-long texture (its RGB multiplies `radiance`).
        #[serde(default)]
        texture: Option<u32>,
    },
}

impl Light {
    pub fn name(&self) -> &str {
        match self {
            Light::Rect { name, .. }
            | Light::Disk { name, .. }
            | Light::Sphere { name, .. }
            | Light::Distant { name, .. }
            | Light::Dome { name, .. } => name,
        }
    }
}

/// A pinhole or thin-lens (or orthographic) camera. Local frame as in USD: looking down −Z, +Y up.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default)]
pub struct Camera {
    pub name: String,
    /// Camera-to-world transform (metres, Y up; no scale).
    pub transform: [[f32; 4]; 4],
    /// "perspective" | "orthographic"
    pub projection: String,
    /// Focal length and apertures share one unit (USD: tenths of a scene unit, "mm"); only ratios
    /// matter for a pinhole, except for orthographic apertures, which the converter gives in metres.
    pub focal_length: f32,
    pub horizontal_aperture: f32,
    pub vertical_aperture: f32,
    /// Near and far clipping distances in metres.
    pub clipping: [f32; 2],
    /// Offset of the projection centre on the film (USD `horizontalApertureOffset`,
    /// `verticalApertureOffset`), in the apertures' unit: positive moves the view right and up.
    pub aperture_offset: [f32; 2],
    /// Thin-lens radius in metres (USD: `focalLength / (2 fStop)`); 0 is a pinhole, everything in
    /// focus. Perspective cameras only.
    pub lens_radius: f32,
    /// Distance of the plane in focus from the lens, in metres along the view axis (USD
    /// `focusDistance`); used when `lens_radius > 0`.
    pub focus_distance: f32,
    /// Width over height of a pixel (USD `pixelAspectRatio` of the render settings).
    pub pixel_aspect: f32,
    /// How the apertures meet the image's aspect ratio (USD `aspectRatioConformPolicy`):
    /// "expandAperture" (the default), "cropAperture", "adjustApertureWidth",
    /// "adjustApertureHeight" or "adjustPixelAspectRatio".
    pub aspect_conform: String,
    /// The factor the image is multiplied by (USD `ComputeLinearExposureScale`: `2^exposure ·
    /// exposure:time · exposure:iso / 100 / exposure:fStop² · exposure:responsivity`; 1 by default).
    pub exposure_scale: f32,
}

/// The values of [`Camera::aspect_conform`].
pub const ASPECT_CONFORM: [&str; 5] = ["expandAperture", "cropAperture", "adjustApertureWidth", "adjustApertureHeight", "adjustPixelAspectRatio"];

impl Default for Camera {
    fn default() -> Self {
        Self {
            name: "/default_camera".into(),
            transform: Mat4::IDENTITY.to_cols_array_2d(),
            projection: "perspective".into(),
            focal_length: 50.0,
            horizontal_aperture: 20.955,
            vertical_aperture: 15.2908,
            clipping: [1e-4, 1e30],
            aperture_offset: [0.0, 0.0],
            lens_radius: 0.0,
            focus_distance: 0.0,
            pixel_aspect: 1.0,
            aspect_conform: "expandAperture".into(),
            exposure_scale: 1.0,
        }
    }
}

/// Something the converter could not represent exactly.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Warning {
    pub prim: String,
    pub message: String,
}

/// Column-major 4×4 (glam's `to_cols_array_2d` layout) to `Mat4`.
pub fn mat4(m: &[[f32; 4]; 4]) -> Mat4 {
    Mat4::from_cols_array_2d(m)
}

impl SceneDesc {
    /// World-space bounding box of all instances (min, max); empty scenes give an inverted box.
    pub fn world_bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for inst in &self.instances {
            if let Some(mesh) = self.meshes.get(inst.mesh as usize) {
                for p in &mesh.positions {
                    let w = inst.transform.transform_point3(*p);
                    lo = lo.min(w);
                    hi = hi.max(w);
                }
            }
        }
        (lo, hi)
    }

    /// Place the camera so that it frames the scene bounds (used when a stage has no camera).
    pub fn frame_default_camera(&mut self) {
        let (lo, hi) = self.world_bounds();
        let (center, radius) = if lo.x <= hi.x {
            ((lo + hi) * 0.5, ((hi - lo).length() * 0.5).max(1e-6))
        } else {
            (Vec3::ZERO, 1.0)
        };
        let mut cam = Camera::default();
        let half_fov = (0.5 * cam.vertical_aperture.min(cam.horizontal_aperture) / cam.focal_length).atan();
        let dist = radius / half_fov.sin();
        let eye = center + Vec3::new(0.0, 0.0, dist);
        cam.transform = Mat4::from_translation(eye).to_cols_array_2d();
        cam.clipping = [dist * 1e-4, dist + 2.0 * radius];
        self.camera = cam;
    }

    /// The same scene uniformly scaled by `s` about the origin (geometry, lights, camera). Radiance
    /// is unchanged, so the rendered image must be unchanged: the scale-invariance tests use this.
    pub fn scaled(&self, s: f32) -> SceneDesc {
        let mut out = self.clone();
        let scale = Mat4::from_scale(Vec3::splat(s));
        for inst in &mut out.instances {
            inst.transform = scale * inst.transform;
        }
        let scale_rigid = |m: &mut [[f32; 4]; 4]| {
            m[3][0] *= s;
            m[3][1] *= s;
            m[3][2] *= s;
        };
        for l in &mut out.lights {
            match l {
                Light::Rect { transform, width, height, .. } => {
                    scale_rigid(transform);
                    *width *= s;
                    *height *= s;
                }
                Light::Disk { transform, radius, .. } | Light::Sphere { transform, radius, .. } => {
                    scale_rigid(transform);
                    *radius *= s;
                }
                Light::Dome { .. } | Light::Distant { .. } => {}
            }
        }
        scale_rigid(&mut out.camera.transform);
        out.camera.clipping = [self.camera.clipping[0] * s, self.camera.clipping[1] * s];
        out
    }

    /// Multiply every emitter (lights and emissive materials) by `k`; images scale linearly.
    pub fn scale_emission(&mut self, k: f32) {
        let mul = |c: &mut [f32; 3]| c.iter_mut().for_each(|x| *x *= k);
        for l in &mut self.lights {
            match l {
                Light::Rect { radiance, .. }
                | Light::Disk { radiance, .. }
                | Light::Sphere { radiance, .. }
                | Light::Dome { radiance, .. } => mul(radiance),
                Light::Distant { irradiance, .. } => mul(irradiance),
            }
        }
        for m in &mut self.materials {
            m.scale_emission(k);
        }
    }
}
