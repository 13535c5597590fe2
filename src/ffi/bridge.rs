//! The `cxx` bridge: every type and function the C++ API (namespace `raysplat`) sees.
//!
//! `build.rs` (`cxx_bridge()`) runs `cxx_build` on this file; the generated header is
//! `raysplat/src/ffi/bridge.rs.h`, included by `cpp/include/raysplat/raysplat.hpp`.
//!
//! Rules kept here (see `docs/cpp.md`):
//! - every extern "Rust" function returns `Result`, and its implementation (in `api.rs`) runs under
//!   `catch_unwind`, so neither an error nor a panic can unwind into C++ (a panic becomes a
//!   `rust::Error` saying "internal error");
//! - transforms are 16 floats, column-major (glam's `to_cols_array` layout): element `[4 * c + r]`,
//!   translation in `[12..15]`;
//! - texture references are indices into the scene's textures, `-1` meaning "none".
//!
//! Changing a shared struct changes the C++ ABI: C++ code must be rebuilt against the new header
//! (the static library and the header always come from the same cargo build).

// `add_mesh` mirrors a C++ call with one argument per array.
#![allow(clippy::too_many_arguments)]

use super::api::*;

#[cxx::bridge(namespace = "raysplat")]
pub mod ffi {
    /// Kind of a `LightDesc`.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    enum LightKind {
        /// UsdLux RectLight: `width` × `height` in the local XY plane, emitting along local −Z.
        Rect,
        /// UsdLux DiskLight: `radius` in the local XY plane, emitting along local −Z.
        Disk,
        /// UsdLux SphereLight (a spot light when `has_cone`).
        Sphere,
        /// UsdLux DistantLight: `direction` of travel, `angle_deg` apex angle, `radiance` = irradiance.
        Distant,
        /// UsdLux DomeLight: `radiance` (times the lat-long `texture` if any).
        Dome,
    }

    /// A colour input of a material: `value`, or texture `texture` when `texture >= 0`.
    #[derive(Debug, Clone, Copy, PartialEq)]
    struct ColorParam {
        value: [f32; 3],
        texture: i32,
        /// The mesh's vertex colours replace `value` where the mesh has them (diffuse colour only;
        /// not with a texture). See `SceneBuilder::set_mesh_colors`.
        vertex: bool,
    }

    /// A scalar input of a material: `value`, or texture `texture` when `texture >= 0`.
    #[derive(Debug, Clone, Copy, PartialEq)]
    struct ScalarParam {
        value: f32,
        texture: i32,
    }

    /// A UsdPreviewSurface material (`default_material` gives the specification's defaults).
    /// `is_error` marks a shader the converter could not translate (rendered in an error colour).
    #[derive(Debug, Clone, PartialEq)]
    struct MaterialDesc {
        name: String,
        /// An unsupported shader: rendered in the error colour.
        is_error: bool,
        /// An ideal diffuse reflector: only `diffuse_color` and `emissive_color` are used.
        is_lambert: bool,
        diffuse_color: ColorParam,
        /// Emitted radiance (front side), W·sr⁻¹·m⁻², linear Rec.709.
        emissive_color: ColorParam,
        use_specular_workflow: bool,
        specular_color: ColorParam,
        metallic: ScalarParam,
        roughness: ScalarParam,
        clearcoat: ScalarParam,
        clearcoat_roughness: ScalarParam,
        opacity: ScalarParam,
        /// When > 0, opacity is a cut-out mask: opacity < threshold is a hole.
        opacity_threshold: f32,
        ior: f32,
        /// Normal-map texture index, -1 for none.
        normal_map: i32,
    }

    /// A UsdUVTexture (`default_texture` gives the specification's defaults).
    #[derive(Debug, Clone, PartialEq)]
    struct TextureDesc {
        /// Image file path.
        path: String,
        /// "repeat" | "mirror" | "clamp" | "black"
        wrap_s: String,
        wrap_t: String,
        /// texel * scale + bias (RGBA).
        scale: [f32; 4],
        bias: [f32; 4],
        /// "sRGB" | "raw" | "auto"
        color_space: String,
        /// "rgb" | "r" | "g" | "b" | "a"
        output: String,
        /// RGBA used when the file is missing or unreadable.
        fallback: [f32; 4],
        /// Texture coordinates are mapped to (a s + b t + c, d s + e t + f) before the lookup, for
        /// [a, b, c, d, e, f] (UsdTransform2d; identity: [1, 0, 0, 0, 1, 0]).
        st_transform: [f32; 6],
    }

    /// A light. Which fields matter depends on `kind` (see `LightKind`); the others are ignored.
    #[derive(Debug, Clone, PartialEq)]
    struct LightDesc {
        kind: LightKind,
        name: String,
        /// Light-to-world, metres, column-major (rect, disk, sphere, dome).
        transform: [f32; 16],
        /// Rect size, metres.
        width: f32,
        height: f32,
        /// Disk and sphere radius, metres.
        radius: f32,
        /// Emitted radiance W·sr⁻¹·m⁻² (distant light: irradiance W·m⁻²), linear Rec.709.
        radiance: [f32; 3],
        /// Rect and dome texture index, -1 for none.
        texture: i32,
        /// Sphere: spot-light shaping (UsdLuxShapingAPI) when `has_cone`.
        has_cone: bool,
        cone_angle_deg: f32,
        cone_softness: f32,
        cone_focus: f32,
        /// Distant: direction the light travels (world).
        direction: [f32; 3],
        /// Distant: full apex angle in degrees (0 = a delta light).
        angle_deg: f32,
    }

    /// A pinhole (or orthographic) camera looking down its local −Z with +Y up.
    #[derive(Debug, Clone, PartialEq)]
    struct CameraDesc {
        name: String,
        /// Camera-to-world, metres, column-major, no scale.
        transform: [f32; 16],
        /// "perspective" | "orthographic"
        projection: String,
        /// Focal length and apertures share one unit (only ratios matter for a pinhole).
        focal_length: f32,
        horizontal_aperture: f32,
        vertical_aperture: f32,
        /// Near and far clipping distances, metres.
        clipping: [f32; 2],
        /// Projection-centre offset on the film, in the apertures' unit (right, up).
        aperture_offset: [f32; 2],
        /// Thin-lens radius, metres (0: a pinhole, no depth of field).
        lens_radius: f32,
        /// Distance of the plane in focus, metres (used when `lens_radius > 0`).
        focus_distance: f32,
        /// Width over height of a pixel (1: square pixels).
        pixel_aspect: f32,
        /// How the apertures meet the image's aspect ratio: "expandAperture", "cropAperture",
        /// "adjustApertureWidth", "adjustApertureHeight" or "adjustPixelAspectRatio".
        aspect_conform: String,
    }

    /// Which view of a USD stage `load_stage` reads.
    #[derive(Debug, Clone, PartialEq)]
    struct StageView {
        /// Camera prim path, e.g. "/World/Cam" ("": the render settings' camera, else the first).
        camera: String,
        /// The time code to read animated values at, when `has_frame` (else the stage's start).
        frame: f64,
        has_frame: bool,
        /// Subdivision surfaces at a fixed level N when `has_subdivision_level` (2^N segments per
        /// cage edge; 0: the control cages), else tessellated at edge rates that follow the camera.
        /// `Scene::mesh` and `triangle_count` give them refined N times (2 by default).
        subdivision_level: u32,
        has_subdivision_level: bool,
        /// The Python interpreter that converts the stage (it must import usd-core's `pxr`); empty:
        /// `$RAYSPLAT_PYTHON`, else `python3` on `PATH`. A Python named here or in
        /// `RAYSPLAT_PYTHON` is never replaced by another: when it cannot import `pxr` the load
        /// throws, saying how to install usd-core into it.
        python: String,
    }

    /// A placement of mesh `mesh` in the world.
    #[derive(Debug, Clone, PartialEq)]
    struct InstanceDesc {
        mesh: u32,
        /// Object-to-world, metres, column-major.
        transform: [f32; 16],
        name: String,
    }

    /// A mesh's arrays, as exported by `Scene::mesh` (the arguments of `SceneBuilder::add_mesh`).
    #[derive(Debug, Clone, PartialEq)]
    struct MeshData {
        name: String,
        /// x, y, z per point (object space, metres).
        positions: Vec<f32>,
        /// Three point indices per triangle.
        indices: Vec<u32>,
        /// x, y, z per point, or empty.
        normals: Vec<f32>,
        /// u, v per point, or empty.
        uvs: Vec<f32>,
        /// One material index per triangle, or a single one for all triangles.
        material_ids: Vec<u32>,
        double_sided: bool,
        /// r, g, b per point (linear), or empty.
        colors: Vec<f32>,
    }

    /// Something the converter or validation could not represent exactly, with its prim path.
    #[derive(Debug, Clone, PartialEq)]
    struct SceneWarning {
        prim: String,
        message: String,
    }

    /// Render settings, mirroring `raysplat render` (`default_options` gives the CLI's defaults).
    /// Numbers that are 0 and strings that are empty mean "not given", as a flag left out.
    #[derive(Debug, Clone, PartialEq)]
    struct RenderOptions {
        /// Rendering method, as `--method` (see `methods()`): "auto" (the default) chooses one from
        /// the scene, and the result says which and why (`RenderResult::choice`).
        method: String,
        /// With "auto": "draft", "preview" or "final" (`--quality`); empty = preview.
        quality: String,
        /// Samples per pixel; 0 = the method's default (16 for pt, 4 eye samples per pixel for the
        /// photon methods; pt with a time budget: until the budget is spent; auto: its preset).
        spp: u32,
        /// Wall-clock budget in seconds, 0 for none.
        time_budget: f64,
        seed: u64,
        /// Worker threads, 0 = one per core. The image never depends on it.
        threads: u32,
        /// Image size; both 0 = the scene's resolution (else 512×512).
        width: u32,
        height: u32,
        /// Maximum path length.
        max_depth: u32,
        /// Photon methods: stored photons in total (`--photons`); 0 = the default (200 000; auto: its
        /// preset).
        photons: u64,
        /// Photon mapping: neighbours per density estimate (`--knn`).
        knn: u32,
        /// Photon ray splatting bandwidth: smoothness C, sensitivity S, maximum bandwidth R.
        smoothness: f32,
        sensitivity: f32,
        max_bandwidth: f32,
        /// Photon methods: direct light from photons instead of explicit light sampling.
        direct_photons: bool,
        /// Photon methods: light samples per eye sample for the direct light (`--light-samples`).
        light_samples: u32,
        /// Photon methods: camera samples per pixel for anti-aliasing, emission, direct light and
        /// AOVs (`--aa-spp`); 0 = the same as `spp`.
        aa_spp: u32,
        /// Ray splatting: glossy transport, as `--glossy` (`auto`, `exact`, `sh`, `histogram`).
        glossy: String,
        /// Ray splatting: image-space radiance filter radius in pixels, 0 = off (`--filter-radius`).
        filter_radius: u32,
        /// Final gathering: gather rays per eye sample (`--fg-rays`); 0 = the method's default.
        gather_rays: u32,
        /// Final gathering: memory budget in bytes of one task (`--memory`); 0 = no limit.
        memory_budget: u64,
        /// Final gathering: fixed kernel radius in metres instead of kNN / adaptive (`--gather-radius`);
        /// 0 = kNN / adaptive.
        gather_radius: f32,
        /// Final gathering: spill the reverse photons to a temporary directory under this one
        /// (`--spill-dir`); empty = in memory.
        spill_dir: String,
        /// Final gathering: never spill automatically, meet `memory_budget` by tasks alone
        /// (`--no-spill`); false = automatic (a budget needing more than a few tasks spills into
        /// the temporary directory).
        no_spill: bool,
        /// pm-fg / rpm-fg: thin the global photon map to at most this density in photons per m²
        /// (`--density-limit`, density control); 0 = off.
        density_limit: f32,
        /// rs-rc: cache error ε (`--cache-error`), the record radius in harmonic mean distances of
        /// the photon rays that reached it; 0 = the default (0.5).
        cache_error: f32,
        /// Denoise the beauty with Open Image Denoise, as `--denoise`: `off` (or empty), `auto`
        /// (when the library's build has the denoiser) or `on` (throws when it has not); the raw
        /// beauty is then the layer "raw". See `denoiser()`.
        denoise: String,
        /// The denoiser's quality, as `--denoise-quality`: `fast`, `balanced` or `high` (or empty: high).
        denoise_quality: String,
        /// Pixel reconstruction filter, as `--filter`: `box` (or empty), `gaussian`,
        /// `blackman-harris` or `mitchell` (`docs/filters.md`).
        pixel_filter: String,
        /// The pixel filter's radius in pixels, as `--pixel-filter-radius`; 0 = the filter's default.
        pixel_filter_radius: f32,
    }

    /// A timed phase of a render.
    #[derive(Debug, Clone, PartialEq)]
    struct Phase {
        name: String,
        seconds: f64,
    }

    /// A named count (counters: spp, rays, …; `enabled`: bytes of what was built).
    #[derive(Debug, Clone, PartialEq)]
    struct Counter {
        name: String,
        value: u64,
    }

    /// The method a render used and, when `auto` chose it, why (`RenderResult::choice`).
    #[derive(Debug, Clone, PartialEq)]
    struct MethodChoice {
        /// The method rendered, as `methods()` names it.
        method: String,
        /// Whether `auto` chose it.
        automatic: bool,
        /// auto's rule: "caustics", "strong secondary light", "bounced light", or "path tracer: "
        /// and its reason ("final quality", "time for samples", "direct light", "large emitters",
        /// "small image", "samples given"); empty when the method was given.
        rule: String,
        /// auto's reason in one line, as `raysplat render` prints it; empty when the method was given.
        reason: String,
        /// The survey auto decided on (0 without one): share of its photons in high-energy voxels,
        /// share of the light arriving at surfaces that has bounced, share of the surface area that
        /// emits, and its seconds.
        high_energy_share: f64,
        indirect_share: f64,
        emitter_area_share: f64,
        survey_seconds: f64,
    }

    /// Statistics of one render (the CLI's summary and `--json` output).
    #[derive(Debug, Clone, PartialEq)]
    struct RenderStats {
        /// Human-readable summary (several lines), as the CLI prints it.
        summary: String,
        /// The statistics as JSON (as `raysplat render --json`).
        json: String,
        total_seconds: f64,
        /// Phases in execution order.
        phases: Vec<Phase>,
        /// spp, rays, …
        counters: Vec<Counter>,
        /// What was built for this scene and method, with its memory in bytes.
        enabled: Vec<Counter>,
        warnings: u64,
        /// One-line description of the scene (triangles, lights, surface kinds).
        scene: String,
    }

    extern "Rust" {
        /// An immutable, validated scene. Share it freely between threads (`const Scene &`).
        type Scene;
        /// Collects meshes, materials, lights and a camera; `build()` validates them into a `Scene`.
        type SceneBuilder;
        /// A cancellation flag: `cancel()` may be called from any thread while a render runs.
        type CancelToken;
        /// A rendered image: float layers (beauty RGBA and AOVs) and statistics.
        type RenderResult;

        /// The library version (Cargo package version).
        fn version() -> Result<String>;
        /// For a host's own SIGINT/SIGTERM handling (raysplat installs no signal handler): remove
        /// every temporary file raysplat has made and not yet renamed into place (an EXR being
        /// written, spill directories, conversions in progress) and kill running USD converters.
        /// Call it from a normal thread just before the process exits: afterwards raysplat makes
        /// no temporary file again (writers throw "render cancelled"). Returns how many it removed.
        fn remove_temporaries() -> Result<usize>;
        /// The names accepted by `RenderOptions::method`, as `--method`: "auto", then the methods.
        fn methods() -> Result<Vec<String>>;
        /// The CLI's default render settings (`auto`, its preview preset, seed 0, …).
        fn default_options() -> Result<RenderOptions>;
        /// A UsdPreviewSurface with the specification's defaults.
        fn default_material(name: &str) -> Result<MaterialDesc>;
        /// A UsdUVTexture with the specification's defaults.
        fn default_texture(path: &str) -> Result<TextureDesc>;
        /// A light of `kind` with unit radiance, unit size and identity transform.
        fn default_light(kind: LightKind, name: &str) -> Result<LightDesc>;
        /// The default camera (50 mm, 35 mm-film apertures, at the origin looking down −Z).
        fn default_camera() -> Result<CameraDesc>;
        /// Whether this build can denoise: "Open Image Denoise <version>", or "unavailable: <why
        /// and how to get it>".
        fn denoiser() -> Result<String>;

        /// Load a USD stage (`.usd/.usda/.usdc/.usdz`, converted with usd-core) or a `.rss` scene file,
        /// and validate it. Throws with the message `raysplat render` prints.
        fn load_scene(path: &str) -> Result<Box<Scene>>;
        /// `load_scene` of a USD stage seen from the camera and at the time code of `view`
        /// (`raysplat render --camera --frame`). Throws, naming the prim, for a camera the stage
        /// lacks, and for a view of a `.rss` file (which keeps the view it was converted with).
        fn load_stage(path: &str, view: &StageView) -> Result<Box<Scene>>;

        /// An empty scene builder. `source` names the scene in error messages ("<file>: <prim>: …").
        fn new_scene_builder(source: &str) -> Result<Box<SceneBuilder>>;
        /// Add a texture; returns its index.
        fn add_texture(self: &mut SceneBuilder, texture: &TextureDesc) -> Result<u32>;
        /// Add a material; returns its index.
        fn add_material(self: &mut SceneBuilder, material: &MaterialDesc) -> Result<u32>;
        /// Add a triangle mesh (object space); returns its index. `positions`: x,y,z per point;
        /// `indices`: 3 per triangle; `normals` (x,y,z per point) and `uvs` (u,v per point) may be
        /// empty; `material_ids`: one per triangle or a single one. Array lengths are checked here;
        /// index ranges, NaNs and material indices by `build()`.
        fn add_mesh(
            self: &mut SceneBuilder,
            name: &str,
            positions: &[f32],
            indices: &[u32],
            normals: &[f32],
            uvs: &[f32],
            material_ids: &[u32],
            double_sided: bool,
        ) -> Result<u32>;
        /// Give mesh `mesh` vertex colours: r, g, b per point, linear (empty: none). Materials whose
        /// diffuse `ColorParam::vertex` is set read them.
        fn set_mesh_colors(self: &mut SceneBuilder, mesh: u32, colors: &[f32]) -> Result<()>;
        /// Place a mesh in the world; returns the instance's index.
        fn add_instance(self: &mut SceneBuilder, instance: &InstanceDesc) -> Result<u32>;
        /// Add a light; returns its index.
        fn add_light(self: &mut SceneBuilder, light: &LightDesc) -> Result<u32>;
        fn set_camera(self: &mut SceneBuilder, camera: &CameraDesc) -> Result<()>;
        /// The scene's own resolution (what `RenderOptions` width/height 0 means); 0×0 = none.
        fn set_resolution(self: &mut SceneBuilder, width: u32, height: u32) -> Result<()>;
        /// Validate a copy of the collected data into a `Scene` (the builder stays usable).
        /// Errors name the source and the mesh, material, light or camera at fault.
        fn build(self: &SceneBuilder) -> Result<Box<Scene>>;

        /// The file (or builder source) the scene came from.
        fn source(self: &Scene) -> Result<String>;
        fn mesh_count(self: &Scene) -> Result<usize>;
        /// Copy of mesh `index`'s arrays.
        fn mesh(self: &Scene, index: usize) -> Result<MeshData>;
        fn instance_count(self: &Scene) -> Result<usize>;
        fn instance(self: &Scene, index: usize) -> Result<InstanceDesc>;
        fn materials(self: &Scene) -> Result<Vec<MaterialDesc>>;
        fn textures(self: &Scene) -> Result<Vec<TextureDesc>>;
        fn lights(self: &Scene) -> Result<Vec<LightDesc>>;
        fn camera(self: &Scene) -> Result<CameraDesc>;
        /// The scene's resolution, [0, 0] when it has none.
        fn resolution(self: &Scene) -> Result<[u32; 2]>;
        /// Total triangles over all instances.
        fn triangle_count(self: &Scene) -> Result<u64>;
        /// Converter warnings and validation repairs.
        fn warnings(self: &Scene) -> Result<Vec<SceneWarning>>;
        /// A builder holding a copy of this scene (to edit a loaded scene).
        fn to_builder(self: &Scene) -> Result<Box<SceneBuilder>>;

        fn new_cancel_token() -> Result<Box<CancelToken>>;
        /// Ask every render using this token to stop (they throw "render cancelled").
        fn cancel(self: &CancelToken) -> Result<()>;
        /// Clear the flag so that the token can be used again.
        fn reset(self: &CancelToken) -> Result<()>;
        fn is_cancelled(self: &CancelToken) -> Result<bool>;

        /// Render `scene` with `options`. Blocks the calling thread; the work runs on a thread pool
        /// of its own. `progress` is called from the pool's threads, one call at a time. Throws
        /// "render cancelled" when `cancel` is set, and the CLI's message for any other error.
        fn render(
            scene: &Scene,
            options: &RenderOptions,
            progress: Pin<&mut ProgressCallback>,
            cancel: &CancelToken,
        ) -> Result<Box<RenderResult>>;

        fn width(self: &RenderResult) -> Result<u32>;
        fn height(self: &RenderResult) -> Result<u32>;
        /// Layer names: "" (beauty R,G,B,A), "albedo", "normal", "depth", "direct", "indirect", and
        /// "raw" (the beauty as rendered, R,G,B,A) when the beauty was denoised.
        fn layer_names(self: &RenderResult) -> Result<Vec<String>>;
        /// Channel names of a layer, e.g. ["R","G","B","A"] for "".
        fn channels(self: &RenderResult, layer: &str) -> Result<Vec<String>>;
        /// A layer's pixels: rows top to bottom, pixels left to right, channels interleaved.
        /// Valid as long as the `RenderResult`. (`layer` is taken by value so that the returned
        /// view can only borrow from `self`.)
        fn pixels(self: &RenderResult, layer: String) -> Result<&[f32]>;
        /// The beauty layer, RGBA interleaved (same as `pixels("")`).
        fn rgba(self: &RenderResult) -> Result<&[f32]>;
        fn stats(self: &RenderResult) -> Result<RenderStats>;
        /// The method rendered, and auto's reason when it chose it.
        fn choice(self: &RenderResult) -> Result<MethodChoice>;
        /// Write all layers to an OpenEXR file with the render settings as header attributes
        /// (as `raysplat render -o`).
        fn write_exr(self: &RenderResult, path: &str) -> Result<()>;
    }

    unsafe extern "C++" {
        include!("raysplat/progress.hpp");

        /// Base class of progress receivers (cpp/include/raysplat/progress.hpp).
        type ProgressCallback;

        // Shims that call the virtual methods and turn any C++ exception into a Rust error.
        #[namespace = "raysplat::detail"]
        fn progress_begin(callback: Pin<&mut ProgressCallback>, stage: &str, total: u64) -> Result<()>;
        #[namespace = "raysplat::detail"]
        fn progress_advance(callback: Pin<&mut ProgressCallback>, done: u64, total: u64) -> Result<()>;
        #[namespace = "raysplat::detail"]
        fn progress_finish(callback: Pin<&mut ProgressCallback>) -> Result<()>;
    }
}
