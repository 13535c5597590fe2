//! Implementations of the bridge's extern "Rust" functions.
//!
//! Each function runs its body through [`guard`]: errors become `rust::Error` with the message the
//! CLI prints (`Display` of [`crate::Error`]) in the API's words (`names`: fields for flags), and a panic becomes an "internal error" instead of
//! unwinding into C++ (which would abort the host process).

use super::bridge::ffi;
use super::convert::{self, MeshArrays};
use super::progress::CppProgress;
use crate::error::Error;
use crate::image::{self, Film};
use crate::integrators::{self, Stats};
use crate::scene::{Light, SceneDesc};
use std::fmt;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;
use std::pin::Pin;

pub use super::progress::CancelToken;

/// The error given to cxx, which throws it in C++ as `rust::Error` with this text as `what()`.
#[derive(Debug)]
pub struct FfiError(pub String);

impl fmt::Display for FfiError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl From<Error> for FfiError {
    /// The message in the C++ API's words: fields where the library names flags.
    fn from(e: Error) -> Self {
        FfiError(super::names::api_message(&e))
    }
}

pub type FfiResult<T> = Result<T, FfiError>;

/// Run `f`, turning a panic into an error (a panic must not unwind across the FFI boundary).
pub fn guard<T>(f: impl FnOnce() -> FfiResult<T>) -> FfiResult<T> {
    // AssertUnwindSafe: after a panic the only state that may be half-updated is a `SceneBuilder`
    // that was being modified (documented in docs/cpp.md); everything else is borrowed immutably.
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic payload".into());
            Err(FfiError(format!("internal error (a bug in raysplat, please report it): {what}")))
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Free functions

pub fn version() -> FfiResult<String> {
    guard(|| Ok(env!("CARGO_PKG_VERSION").to_string()))
}

pub fn remove_temporaries() -> FfiResult<usize> {
    guard(|| Ok(crate::io::temporaries::clean_up_all()))
}

pub fn methods() -> FfiResult<Vec<String>> {
    guard(|| Ok(convert::method_names()))
}

pub fn default_options() -> FfiResult<ffi::RenderOptions> {
    guard(|| Ok(convert::options_default()))
}

pub fn default_material(name: &str) -> FfiResult<ffi::MaterialDesc> {
    guard(|| {
        let mut m = convert::material_out(&crate::scene::Material::PreviewSurface(Default::default()));
        m.name = name.to_string();
        Ok(m)
    })
}

pub fn default_texture(path: &str) -> FfiResult<ffi::TextureDesc> {
    guard(|| Ok(convert::texture_desc_out(&crate::scene::TextureDesc { path: path.to_string(), ..Default::default() })))
}

pub fn default_light(kind: ffi::LightKind, name: &str) -> FfiResult<ffi::LightDesc> {
    guard(|| {
        let d = convert::light_default(kind, name);
        convert::light_in(&d, "default_light")?; // rejects an out-of-range kind
        Ok(d)
    })
}

pub fn default_camera() -> FfiResult<ffi::CameraDesc> {
    guard(|| Ok(convert::camera_out(&crate::scene::Camera::default())))
}

pub fn denoiser() -> FfiResult<String> {
    guard(|| {
        Ok(match crate::denoise::status() {
            crate::denoise::Status::Available(v) => format!("Open Image Denoise {v}"),
            crate::denoise::Status::Unavailable(why) => format!("unavailable: {why}"),
        })
    })
}

pub fn load_scene(path: &str) -> FfiResult<Box<Scene>> {
    guard(|| Ok(Box::new(Scene { desc: crate::usd::load_scene(Path::new(path))? })))
}

pub fn load_stage(path: &str, view: &ffi::StageView) -> FfiResult<Box<Scene>> {
    guard(|| {
        let opts = crate::usd::StageOptions {
            camera: (!view.camera.is_empty()).then(|| view.camera.clone()),
            frame: view.has_frame.then_some(view.frame),
            subdivision: match view.has_subdivision_level.then_some(view.subdivision_level) {
                Some(n) => Some(n.to_string().parse().map_err(|e: String| Error::param("subdivision_level", e))?),
                None => None,
            },
            python: (!view.python.is_empty()).then(|| view.python.clone().into()),
        };
        Ok(Box::new(Scene { desc: crate::usd::load_scene_with(Path::new(path), &opts)? }))
    })
}

pub fn new_scene_builder(source: &str) -> FfiResult<Box<SceneBuilder>> {
    guard(|| {
        let source = if source.is_empty() { "<c++>" } else { source };
        Ok(Box::new(SceneBuilder { desc: SceneDesc { source: source.to_string(), ..Default::default() } }))
    })
}

pub fn new_cancel_token() -> FfiResult<Box<CancelToken>> {
    guard(|| Ok(Box::new(CancelToken::new())))
}

// ---------------------------------------------------------------------------------------------
// SceneBuilder

/// Scene data being assembled from C++.
pub struct SceneBuilder {
    desc: SceneDesc,
}

fn index_of(len: usize, what: &str) -> FfiResult<u32> {
    u32::try_from(len).map_err(|_| FfiError(format!("too many {what} (more than 2^32)")))
}

impl SceneBuilder {
    /// A builder holding `desc` (Rust callers; C++ uses `new_scene_builder` or `Scene::to_builder`).
    pub fn from_desc(desc: SceneDesc) -> SceneBuilder {
        SceneBuilder { desc }
    }

    pub fn add_texture(&mut self, texture: &ffi::TextureDesc) -> FfiResult<u32> {
        guard(|| {
            let i = index_of(self.desc.textures.len(), "textures")?;
            self.desc.textures.push(convert::texture_desc_in(texture));
            Ok(i)
        })
    }

    pub fn add_material(&mut self, material: &ffi::MaterialDesc) -> FfiResult<u32> {
        guard(|| {
            let i = index_of(self.desc.materials.len(), "materials")?;
            let m = convert::material_in(material, &self.desc.source)?;
            self.desc.materials.push(m);
            Ok(i)
        })
    }

    #[allow(clippy::too_many_arguments)]
    pub fn add_mesh(
        &mut self,
        name: &str,
        positions: &[f32],
        indices: &[u32],
        normals: &[f32],
        uvs: &[f32],
        material_ids: &[u32],
        double_sided: bool,
    ) -> FfiResult<u32> {
        guard(|| {
            let i = index_of(self.desc.meshes.len(), "meshes")?;
            let fallback = format!("/Mesh{i}");
            let name = if name.is_empty() { fallback.as_str() } else { name };
            let arrays = MeshArrays { name, positions, indices, normals, uvs, material_ids, double_sided };
            let mesh = convert::mesh_in(&arrays, &self.desc.source)?;
            self.desc.meshes.push(mesh);
            Ok(i)
        })
    }

    pub fn set_mesh_colors(&mut self, mesh: u32, colors: &[f32]) -> FfiResult<()> {
        guard(|| {
            let n = self.desc.meshes.len();
            let source = self.desc.source.clone();
            let m = self.desc.meshes.get_mut(mesh as usize).ok_or_else(|| Error::param("mesh", format!("mesh index {mesh} out of range ({n} meshes)")))?;
            m.colors = convert::colors_in(m, colors, &source)?;
            Ok(())
        })
    }

    pub fn add_instance(&mut self, instance: &ffi::InstanceDesc) -> FfiResult<u32> {
        guard(|| {
            let i = index_of(self.desc.instances.len(), "instances")?;
            self.desc.instances.push(convert::instance_in(instance));
            Ok(i)
        })
    }

    pub fn add_light(&mut self, light: &ffi::LightDesc) -> FfiResult<u32> {
        guard(|| {
            let i = index_of(self.desc.lights.len(), "lights")?;
            let l: Light = convert::light_in(light, &self.desc.source)?;
            self.desc.lights.push(l);
            Ok(i)
        })
    }

    pub fn set_camera(&mut self, camera: &ffi::CameraDesc) -> FfiResult<()> {
        guard(|| {
            self.desc.camera = convert::camera_in(camera);
            Ok(())
        })
    }

    pub fn set_resolution(&mut self, width: u32, height: u32) -> FfiResult<()> {
        guard(|| {
            self.desc.resolution = (width != 0 || height != 0).then_some([width, height]);
            Ok(())
        })
    }

    pub fn build(&self) -> FfiResult<Box<Scene>> {
        guard(|| {
            let mut desc = self.desc.clone();
            desc.validate()?;
            Ok(Box::new(Scene { desc }))
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Scene

/// A validated scene; immutable, so `&Scene` may be used from any number of threads.
pub struct Scene {
    desc: SceneDesc,
}

impl Scene {
    /// The scene description (for Rust callers and tests).
    pub fn desc(&self) -> &SceneDesc {
        &self.desc
    }

    pub fn source(&self) -> FfiResult<String> {
        guard(|| Ok(self.desc.source.clone()))
    }

    /// The refinements `mesh` and `triangle_count` give subdivision surfaces: the view's level
    /// (0: the cages), 2 by default.
    fn triangle_level(&self) -> u32 {
        match self.desc.subdivision {
            crate::scene::subdiv::SubdivisionMode::Auto => 2,
            crate::scene::subdiv::SubdivisionMode::Cage => 0,
            crate::scene::subdiv::SubdivisionMode::Level(n) => n,
        }
    }

    pub fn mesh_count(&self) -> FfiResult<usize> {
        guard(|| Ok(self.desc.meshes.len()))
    }

    pub fn mesh(&self, index: usize) -> FfiResult<ffi::MeshData> {
        guard(|| {
            let m = self.desc.meshes.get(index).ok_or_else(|| out_of_range("mesh", index, self.desc.meshes.len()))?;
            match m.subdivision.as_deref() {
                None => Ok(convert::mesh_out(m)),
                Some(sd) => {
                    let level = crate::subdiv::mesh::fitting_levels(sd, self.triangle_level());
                    let level = if crate::subdiv::mesh::cage_reason(sd).is_some() { 0 } else { level };
                    let refined = crate::subdiv::mesh::refine_mesh(m, level).map_err(|e| FfiError(format!("{}: {e}", m.name)))?;
                    Ok(convert::mesh_out(&refined))
                }
            }
        })
    }

    pub fn instance_count(&self) -> FfiResult<usize> {
        guard(|| Ok(self.desc.instances.len()))
    }

    pub fn instance(&self, index: usize) -> FfiResult<ffi::InstanceDesc> {
        guard(|| {
            let i = self
                .desc
                .instances
                .get(index)
                .ok_or_else(|| out_of_range("instance", index, self.desc.instances.len()))?;
            Ok(convert::instance_out(i))
        })
    }

    pub fn materials(&self) -> FfiResult<Vec<ffi::MaterialDesc>> {
        guard(|| Ok(self.desc.materials.iter().map(convert::material_out).collect()))
    }

    pub fn textures(&self) -> FfiResult<Vec<ffi::TextureDesc>> {
        guard(|| Ok(self.desc.textures.iter().map(convert::texture_desc_out).collect()))
    }

    pub fn lights(&self) -> FfiResult<Vec<ffi::LightDesc>> {
        guard(|| Ok(self.desc.lights.iter().map(convert::light_out).collect()))
    }

    pub fn camera(&self) -> FfiResult<ffi::CameraDesc> {
        guard(|| Ok(convert::camera_out(&self.desc.camera)))
    }

    pub fn resolution(&self) -> FfiResult<[u32; 2]> {
        guard(|| Ok(self.desc.resolution.unwrap_or([0, 0])))
    }

    pub fn triangle_count(&self) -> FfiResult<u64> {
        guard(|| {
            let d = &self.desc;
            let level = self.triangle_level();
            let count = |m: &crate::scene::Mesh| match m.subdivision.as_deref() {
                None => m.indices.len() as u64,
                Some(sd) => crate::subdiv::mesh::triangle_count(sd, crate::subdiv::mesh::fitting_levels(sd, level)) as u64,
            };
            Ok(d.instances.iter().filter_map(|i| d.meshes.get(i.mesh as usize)).map(count).sum())
        })
    }

    pub fn warnings(&self) -> FfiResult<Vec<ffi::SceneWarning>> {
        guard(|| Ok(self.desc.warnings.iter().map(convert::warning_out).collect()))
    }

    pub fn to_builder(&self) -> FfiResult<Box<SceneBuilder>> {
        guard(|| Ok(Box::new(SceneBuilder { desc: self.desc.clone() })))
    }
}

fn out_of_range(what: &str, index: usize, len: usize) -> FfiError {
    FfiError(format!("{what} index {index} out of range (the scene has {len})"))
}

// ---------------------------------------------------------------------------------------------
// CancelToken (bridge methods; the type lives in progress.rs)

impl CancelToken {
    pub fn cancel(&self) -> FfiResult<()> {
        guard(|| {
            self.set();
            Ok(())
        })
    }

    pub fn reset(&self) -> FfiResult<()> {
        guard(|| {
            self.clear();
            Ok(())
        })
    }

    pub fn is_cancelled(&self) -> FfiResult<bool> {
        guard(|| Ok(self.get()))
    }
}

// ---------------------------------------------------------------------------------------------
// Rendering

/// The output of one render.
pub struct RenderResult {
    film: Film,
    stats: Stats,
    /// EXR header attributes (as the CLI writes them).
    attributes: Vec<(String, String)>,
    /// The method rendered and auto's reason.
    choice: ffi::MethodChoice,
}

pub fn render(
    scene: &Scene,
    options: &ffi::RenderOptions,
    progress: Pin<&mut ffi::ProgressCallback>,
    cancel: &CancelToken,
) -> FfiResult<Box<RenderResult>> {
    guard(|| {
        // the CLI's conversion and checks, auto's choice included
        let resolved = convert::request_in(options)?.resolve(&scene.desc)?;
        let reporter = CppProgress::new(progress, cancel);
        let out = integrators::render(scene.desc.clone(), &resolved.settings, &reporter);
        if let Some(e) = reporter.close() {
            return Err(FfiError(e));
        }
        let out = out?;
        let mut attributes = resolved.attributes();
        attributes.push(("raysplat:scene".into(), scene.desc.source.clone()));
        attributes.push(("raysplat:render_seconds".into(), format!("{:.3}", out.stats.total_seconds)));
        Ok(Box::new(RenderResult { film: out.film, stats: out.stats, attributes, choice: convert::choice_out(&resolved) }))
    })
}

impl RenderResult {
    /// The film (for Rust callers and tests).
    pub fn film(&self) -> &Film {
        &self.film
    }

    fn layer(&self, name: &str) -> FfiResult<&crate::image::Layer> {
        self.film.layer(name).ok_or_else(|| {
            let names: Vec<String> = self.film.layers.iter().map(|l| format!("{:?}", l.name)).collect();
            FfiError::from(Error::param("layer", format!("no layer {name:?} (layers: {})", names.join(", "))))
        })
    }

    pub fn width(&self) -> FfiResult<u32> {
        guard(|| Ok(self.film.width))
    }

    pub fn height(&self) -> FfiResult<u32> {
        guard(|| Ok(self.film.height))
    }

    pub fn layer_names(&self) -> FfiResult<Vec<String>> {
        guard(|| Ok(self.film.layers.iter().map(|l| l.name.clone()).collect()))
    }

    pub fn channels(&self, layer: &str) -> FfiResult<Vec<String>> {
        guard(|| Ok(self.layer(layer)?.channels.clone()))
    }

    pub fn pixels(&self, layer: String) -> FfiResult<&[f32]> {
        guard(|| Ok(self.layer(&layer)?.data.as_slice()))
    }

    pub fn rgba(&self) -> FfiResult<&[f32]> {
        guard(|| Ok(self.layer("")?.data.as_slice()))
    }

    pub fn stats(&self) -> FfiResult<ffi::RenderStats> {
        guard(|| Ok(convert::stats_out(&self.stats)))
    }

    pub fn choice(&self) -> FfiResult<ffi::MethodChoice> {
        guard(|| Ok(self.choice.clone()))
    }

    pub fn write_exr(&self, path: &str) -> FfiResult<()> {
        guard(|| Ok(image::write_exr(Path::new(path), &self.film, &self.attributes)?))
    }
}

// Everything C++ may share between threads must be Send + Sync.
const _: () = {
    const fn shareable<T: Send + Sync>() {}
    shareable::<Scene>();
    shareable::<CancelToken>();
    shareable::<RenderResult>();
    shareable::<SceneBuilder>();
};
