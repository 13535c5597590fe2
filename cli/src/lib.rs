//! The `raysplat` command line: `render`, `convert`, `info`, `compare`, `study`, `bench`, `denoise`, a thin
//! layer over the library (`src/main.rs` runs [`run`]). The path-traced [`reference`] and the
//! [`progress`] bars are public for `raysplat-bench`.
//!
//! Exit codes: 0 success; 1 internal failure (Embree, image library); 2 bad input or parameters
//! (missing file, malformed scene, invalid option); 130 cancelled.

pub mod bench;
mod compare;
mod denoise;
mod farm;
mod frames;
mod info;
mod merge;
mod part;
mod plot;
pub mod progress;
pub mod reference;
mod shell;
mod signals;
mod study;

use clap::{Parser, Subcommand};
use raysplat::io::{self, Format};
use raysplat::image;
use raysplat::integrators::{self, RenderRequest};
use raysplat::scene::subdiv::SubdivisionMode;
use raysplat::{usd, Error};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Parser)]
#[command(name = "raysplat", version, about = "Global-illumination renderer: photon ray splatting and an Embree path tracer")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene (USD or .rss) to OpenEXR.
    Render(RenderArgs),
    /// Convert a USD stage to the raysplat scene format (.rss).
    Convert {
        input: PathBuf,
        output: PathBuf,
        #[command(flatten)]
        stage: StageArgs,
        /// Convert each time code FIRST:LAST[:STEP], as --frame would, to the file OUTPUT names with
        /// its last run of # replaced by the frame number (scene.####.rss → scene.0001.rss, …);
        /// `render scene.####.rss --frames` renders them.
        #[arg(long, conflicts_with = "frame", value_name = "FIRST:LAST[:STEP]")]
        frames: Option<String>,
    },
    /// Summarise a scene: geometry, materials by kind, lights, what the scene requires, warnings.
    Info {
        scene: PathBuf,
        #[command(flatten)]
        stage: StageArgs,
    },
    /// Compare an image against a reference: RMSE, relative MSE, share of pixels over 5/15/30 % error.
    Compare {
        test: PathBuf,
        reference: PathBuf,
        /// Write a false-colour error image (blue < 5 %, green 15 %, red ≥ 30 %).
        #[arg(long)]
        error_image: Option<PathBuf>,
        /// Print the metrics as JSON.
        #[arg(long)]
        json: bool,
        /// Compare this layer (e.g. `indirect`, `direct`, `albedo`) instead of the beauty image.
        #[arg(long, default_value = "")]
        layer: String,
        /// Compare averages over blocks of N×N pixels: the error at scales of N pixels and above
        /// (pixel noise averages out, low-frequency error stays).
        #[arg(long, default_value_t = 1)]
        block: u32,
    },
    /// Print throughput figures: Embree rays/s (coherent and incoherent) and path-tracer samples/s
    /// (the papers' tables: `raysplat-bench`).
    Bench(bench::BenchArgs),
    /// Measure every method's error against a path-traced reference at a ladder of budgets.
    Study(study::StudyArgs),
    /// Merge the parts of a render made on several machines: stitch tiles (--tile, --crop),
    /// average passes (--passes with --pass-range), AOVs included.
    Merge(merge::MergeArgs),
    /// Split a render into tasks on a render farm (Slurm): plan, submit, status.
    #[command(subcommand)]
    Farm(farm::FarmCommand),
    /// Denoise an EXR rendered earlier (its beauty, or its `raw` layer, guided by its albedo and
    /// normal layers) with Intel Open Image Denoise.
    Denoise(denoise::DenoiseArgs),
}

/// Which view of a USD stage to read.
#[derive(clap::Args, Clone, Default)]
pub(crate) struct StageArgs {
    /// USD stages: the camera prim to render, e.g. /World/Cam (default: the render settings'
    /// camera, else the stage's first camera). `raysplat info` lists the stage's cameras.
    #[arg(long)]
    camera: Option<String>,
    /// USD stages: the time code to read animated values at (default: the stage's start time code).
    #[arg(long, allow_negative_numbers = true)]
    frame: Option<f64>,
    /// Subdivision surfaces: auto (Catmull–Clark tessellated by Embree at edge rates that follow
    /// the camera, about 2 pixels a segment; Loop and bilinear refined 1 to 3 times to match),
    /// cage (the control cages as polygons) or a level N of 1 to 6 (2^N segments per cage edge;
    /// Loop and bilinear refined N times). Applies to .rss files too.
    #[arg(long, value_name = "auto|cage|N")]
    subdivision: Option<SubdivisionMode>,
    /// The same as --subdivision N (0: cage).
    #[arg(long, value_name = "N", conflicts_with = "subdivision", value_parser = parse_level)]
    subdivision_level: Option<SubdivisionMode>,
}

fn parse_level(s: &str) -> Result<SubdivisionMode, String> {
    s.parse::<u32>().map_err(|e| e.to_string())?;
    s.parse()
}

impl StageArgs {
    fn options(&self) -> usd::StageOptions {
        usd::StageOptions { camera: self.camera.clone(), frame: self.frame, subdivision: self.subdivision.or(self.subdivision_level), python: None }
    }
}

#[derive(clap::Args, Clone)]
pub(crate) struct RenderArgs {
    scene: PathBuf,
    /// Output EXR file.
    #[arg(short, long)]
    output: PathBuf,
    #[command(flatten)]
    stage: StageArgs,
    /// USD stages: render the whole time codes FIRST:LAST[:STEP], each as --frame would, to the
    /// files -o (and --preview) name with their last run of # replaced by the frame number
    /// (out.####.exr → out.0001.exr, …). Every frame uses --seed. A scene named with a # (e.g.
    /// scene.####.rss, from `convert --frames`) is one converted file per frame, named the same way.
    #[arg(long, conflicts_with = "frame", value_name = "FIRST:LAST[:STEP]")]
    frames: Option<String>,
    /// Rendering method: auto (chosen from the scene, see docs/auto.md), pt, rs, pm, pm-fg, rpm-fg,
    /// rs-fg, he-fg, rs-rc.
    #[arg(long, default_value = "auto")]
    method: String,
    /// With --method auto: draft, preview (default) or final.
    #[arg(long)]
    quality: Option<String>,
    /// Samples per pixel (with --time: the maximum; photon methods: eye samples per pass).
    #[arg(long)]
    spp: Option<u32>,
    /// Wall-clock budget in seconds (path tracer: samples until spent; photon methods: passes).
    #[arg(long, allow_negative_numbers = true)]
    time: Option<f64>,
    #[arg(long, default_value_t = RenderRequest::DEFAULT.seed)]
    seed: u64,
    /// Worker threads (0 = one per core). The image does not depend on it.
    #[arg(long, default_value_t = RenderRequest::DEFAULT.threads)]
    threads: usize,
    /// Image size WxH (default: the scene's RenderSettings, else 512x512).
    #[arg(long)]
    resolution: Option<String>,
    /// Maximum path length.
    #[arg(long, default_value_t = RenderRequest::DEFAULT.max_depth)]
    max_depth: u32,
    /// Photon methods: stored photons (split over direct / indirect / caustic budgets; default 200000).
    #[arg(long)]
    photons: Option<usize>,
    /// Ray splatting: smoothness C (scales every splat bandwidth; rs-rc uses 0.75 of it for the
    /// photons it caches and 0.5 for the caustic ones, as its cache filters too).
    #[arg(long, allow_negative_numbers = true, default_value_t = RenderRequest::DEFAULT.smoothness)]
    smoothness: f32,
    /// Ray splatting: bandwidth sensitivity S ∈ (0, 1] to the photon path density.
    #[arg(long, allow_negative_numbers = true, default_value_t = RenderRequest::DEFAULT.sensitivity)]
    sensitivity: f32,
    /// Ray splatting: maximum bandwidth R, in mean photon-segment lengths.
    #[arg(long, allow_negative_numbers = true, default_value_t = RenderRequest::DEFAULT.max_bandwidth)]
    max_bandwidth: f32,
    /// Photon mapping: nearest neighbours per estimate (caustic map: half).
    #[arg(long, default_value_t = RenderRequest::DEFAULT.knn)]
    knn: usize,
    /// Photon methods: direct light from photons instead of explicit light sampling.
    #[arg(long)]
    direct_photons: bool,
    /// Photon methods: light samples per eye sample for the direct light.
    #[arg(long, default_value_t = RenderRequest::DEFAULT.light_samples)]
    light_samples: u32,
    /// Photon methods: camera samples per pixel for anti-aliasing, emission, direct light and AOVs
    /// (at least --spp; default: --spp, 0 the same). The first --spp are the density estimate's eye
    /// samples.
    #[arg(long, default_value_t = RenderRequest::DEFAULT.aa_spp)]
    aa_spp: u32,
    /// Ray splatting: glossy transport — `auto` (the SH map for materials whose lobe SH bands 0–3
    /// hold, the exact BSDF for the others), `exact` (BSDF per photon), `sh` (spherical-harmonics
    /// radiance map) or `histogram` (20-strata radiance map), §8.1. rs-rc caches the lobes SH holds
    /// and, under `auto` and `sh`, the others too (the paper); `exact` and `histogram` splat the
    /// photons onto those others' eye samples instead.
    #[arg(long, default_value_t = RenderRequest::DEFAULT.glossy.name().to_string())]
    glossy: String,
    /// Final gathering: gather rays per eye sample (pm-fg, rpm-fg, rs-fg: default 64; he-fg:
    /// stratified rays into the low-energy map per gather point, default 48).
    #[arg(long)]
    fg_rays: Option<u32>,
    /// Final gathering: a fixed kernel radius in metres (instead of kNN for pm-fg, adaptive for rpm-fg).
    #[arg(long, allow_negative_numbers = true)]
    gather_radius: Option<f32>,
    /// Final gathering: memory budget for the gather arrays of one task, e.g. 512M (splits the work
    /// into tasks).
    #[arg(long)]
    memory: Option<String>,
    /// Final gathering: spill the gather hits (A_r) to a temporary directory inside DIR, in
    /// spatially coherent pages, and process them chunk by chunk (removed afterwards).
    #[arg(long, value_name = "DIR")]
    spill_dir: Option<PathBuf>,
    /// Final gathering: never spill automatically; a --memory budget is met by tasks alone (by
    /// default, a budget needing more than a few tasks spills into the temporary directory, TMPDIR).
    #[arg(long, conflicts_with = "spill_dir")]
    no_spill: bool,
    /// Final gathering (pm-fg, rpm-fg): density control of the global photon map — photons where
    /// the map is denser than this many photons per m² give their energy to their neighbours.
    #[arg(long, allow_negative_numbers = true, value_name = "PHOTONS_PER_M2")]
    density_limit: Option<f32>,
    /// he-fg: explicit rays toward the high-energy voxels per gather point (0: one global map,
    /// uniform final gathering).
    #[arg(long, default_value_t = RenderRequest::DEFAULT.explicit_rays)]
    explicit_rays: u32,
    /// he-fg: share of the explicit rays per high-energy voxel: per-voxel (equal) or proportional
    /// (to its photon count).
    #[arg(long, default_value_t = RenderRequest::DEFAULT.explicit_allocation.name().to_string())]
    explicit_allocation: String,
    /// he-fg: threshold irradiance E_max of the high-energy map (default: multiplier x E_avg).
    #[arg(long, allow_negative_numbers = true)]
    emax: Option<f32>,
    /// he-fg: E_max / E_avg when --emax is not given (E_avg from the first 10 % of the photons).
    #[arg(long, allow_negative_numbers = true, default_value_t = RenderRequest::DEFAULT.emax_multiplier)]
    emax_multiplier: f32,
    /// he-fg: voxels along the longest side of the scene (default: automatic, docs/secondary-lights.md).
    #[arg(long)]
    voxel_resolution: Option<u32>,
    /// he-fg and pm-fg: Ward's irradiance cache for the gather at Lambertian surfaces.
    #[arg(long)]
    irradiance_cache: bool,
    /// Cache error ε: of the irradiance cache of `he-fg --irradiance-cache` [default: 0.2], and of
    /// the radiance cache of `rs-rc` (record radius = ε × harmonic mean distance) [default: 0.5].
    #[arg(long, allow_negative_numbers = true)]
    cache_error: Option<f32>,
    /// Ray splatting: image-space radiance filter (§8.2) — largest box radius in pixels, chosen per
    /// pixel from the splat kernel weights, never across depth/normal discontinuities (0: off).
    #[arg(long, default_value_t = RenderRequest::DEFAULT.filter_radius)]
    filter_radius: u32,
    /// Photon methods: guided emission — `on` draws each light's photon origins from where the
    /// paths that store photons start (learned during the light pass), `off` uniformly.
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    emission_guiding: String,
    /// Denoise the beauty with Intel Open Image Denoise, guided by the albedo and normal AOVs:
    /// `on` (an error when this build has no denoiser), `auto` (when it has one) or `off`. The EXR
    /// keeps the raw beauty as the layer `raw`.
    #[arg(long, default_value = "off", value_parser = ["auto", "on", "off"])]
    denoise: String,
    /// The denoiser's quality: fast, balanced or high.
    #[arg(long, default_value = "high", value_parser = ["fast", "balanced", "high"])]
    denoise_quality: String,
    /// Texture filtering over each camera ray's footprint: MIP levels and up to 8 lookups along
    /// its long axis (anisotropic), MIP levels only (trilinear), or none (bilinear).
    #[arg(long, default_value = "anisotropic", value_parser = ["anisotropic", "trilinear", "bilinear"])]
    texture_filter: String,
    /// Render only the window X0,Y0,X1,Y1 of the image (pixels; X1, Y1 exclusive), each pixel as
    /// the whole image's render has it (same rays, same photons): `raysplat merge` stitches crops.
    #[arg(long, value_name = "X0,Y0,X1,Y1", conflicts_with = "tile")]
    crop: Option<String>,
    /// Render tile I of N (from 0): band I of N bands of whole rows, as --crop would.
    #[arg(long, value_name = "I/N")]
    tile: Option<String>,
    /// Render a run of N independent passes (path tracer: N × --spp samples per pixel, --spp per
    /// pass; photon methods: progressive passes, each with new eye samples and photons and a
    /// bandwidth that shrinks with the pass; see docs/distributed.md).
    #[arg(long, value_name = "N", conflicts_with = "time")]
    passes: Option<u32>,
    /// With --passes: render only passes FIRST up to END (from 0); `raysplat merge` averages ranges.
    #[arg(long, value_name = "FIRST:END", requires = "passes")]
    pass_range: Option<String>,
    /// With --passes, photon methods: every pass with the first pass's bandwidth (not progressive).
    #[arg(long, requires = "passes")]
    fixed_bandwidth: bool,
    /// Pixel reconstruction filter: pt spreads each sample over the pixels within the filter's
    /// radius (a pixel is the weighted average of what it received); the photon methods draw their
    /// camera samples from the filter (`docs/filters.md`).
    #[arg(long, default_value = "box", value_parser = ["box", "gaussian", "blackman-harris", "mitchell"])]
    filter: String,
    /// The pixel filter's radius in pixels, 0.5–8 [default: box 0.5, gaussian 2 (σ 0.5),
    /// blackman-harris 0.75, mitchell 2].
    #[arg(long)]
    pixel_filter_radius: Option<f32>,
    /// Also write a tonemapped sRGB PNG preview.
    #[arg(long)]
    preview: Option<PathBuf>,
    /// Exposure (stops) for the preview [default: automatic, the image's log-average luminance
    /// at middle grey].
    #[arg(long, allow_negative_numbers = true)]
    exposure: Option<f32>,
    /// Print statistics as JSON on stdout.
    #[arg(long)]
    json: bool,
}

/// Run the CLI; returns the process exit code.
pub fn run() -> i32 {
    signals::install();
    let cli = Cli::parse();
    match dispatch(cli.command) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {}", message(&e));
            exit_code(&e)
        }
    }
}

/// The exit code of an error (see the module's documentation).
pub fn exit_code(e: &anyhow::Error) -> i32 {
    match e.downcast_ref::<Error>() {
        Some(Error::Cancelled) => 130,
        Some(Error::Embree(_)) => 1,
        Some(_) => 2,
        None => 1,
    }
}

/// An error and its causes on one line, each cause once: our errors already show the cause they
/// wrap (`{path}: {source}`), which `{:#}` would print again.
pub fn message(e: &anyhow::Error) -> String {
    let mut msg = e.to_string();
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if !msg.contains(&c) {
            msg = format!("{msg}: {c}");
        }
    }
    msg
}

fn dispatch(cmd: Command) -> anyhow::Result<()> {
    match cmd {
        Command::Render(a) => render(&a),
        Command::Convert { input, output, stage, frames } => match frames {
            None => convert(&input, &output, &stage),
            Some(spec) => {
                let list = frames::parse(&spec)?;
                if frames::name(&output, 0).is_none() {
                    return Err(Error::param("output", format!("{}: --frames needs a # in the file name for the frame number (e.g. scene.####.rss)", output.display())).into());
                }
                for f in list {
                    let one = StageArgs { frame: Some(f as f64), ..stage.clone() };
                    convert(&input, &frames::name(&output, f).expect("checked above"), &one).map_err(|e| e.context(format!("frame {f}")))?;
                }
                Ok(())
            }
        },
        Command::Info { scene, stage } => info::info(&scene, &stage.options()),
        Command::Compare { test, reference, error_image, json, layer, block } => {
            compare::compare(&test, &reference, &layer, error_image.as_deref(), json, block)
        }
        Command::Bench(a) => bench::run(&a),
        Command::Study(a) => study::run(&a),
        Command::Denoise(a) => denoise::run(&a),
        Command::Merge(a) => merge::run(&a),
        Command::Farm(c) => farm::run(&c),
    }
}

/// The request `a` stands for: every option as given, `None` where left out.
pub(crate) fn request_of(a: &RenderArgs) -> Result<RenderRequest, Error> {
    Ok(RenderRequest {
        method: integrators::parse_method(&a.method)?,
        quality: a.quality.as_deref().map(str::parse).transpose()?,
        spp: a.spp,
        time: a.time,
        seed: a.seed,
        threads: a.threads,
        resolution: a.resolution.as_deref().map(integrators::parse_size).transpose()?,
        max_depth: a.max_depth,
        photons: a.photons,
        smoothness: a.smoothness,
        sensitivity: a.sensitivity,
        max_bandwidth: a.max_bandwidth,
        knn: a.knn,
        direct_photons: a.direct_photons,
        light_samples: a.light_samples,
        aa_spp: a.aa_spp,
        glossy: a.glossy.parse()?,
        filter_radius: a.filter_radius,
        emission_guiding: a.emission_guiding == "on",
        fg_rays: a.fg_rays,
        gather_radius: a.gather_radius,
        memory: a.memory.as_deref().map(raysplat::io::parse_size).transpose()?,
        spill_dir: a.spill_dir.clone(),
        no_spill: a.no_spill,
        density_limit: a.density_limit,
        explicit_rays: a.explicit_rays,
        explicit_allocation: raysplat::secondary::Allocation::parse(&a.explicit_allocation)?,
        emax: a.emax,
        emax_multiplier: a.emax_multiplier,
        voxel_resolution: a.voxel_resolution,
        irradiance_cache: a.irradiance_cache,
        cache_error: a.cache_error,
        texture_filter: raysplat::prepare::TextureFilter::parse(&a.texture_filter).expect("clap checked it"),
        filter: raysplat::image::FilterKind::parse(&a.filter)?,
        pixel_filter_radius: a.pixel_filter_radius,
        denoise: raysplat::denoise::Options { mode: a.denoise.parse()?, quality: a.denoise_quality.parse()?, ..Default::default() },
    })
}

/// Check `render` flags (`args`: `render SCENE ... -o OUT`) as the command would, before a farm
/// runs them: a bad flag fails at planning, not on every task.
pub(crate) fn check_render_flags(args: &[String]) -> anyhow::Result<()> {
    let cli = Cli::try_parse_from(std::iter::once("raysplat".to_string()).chain(args.iter().cloned())).map_err(|e| Error::param("render flags", e.to_string().trim().to_string()))?;
    let Command::Render(a) = cli.command else { unreachable!("a render command") };
    request_of(&a)?.check()?;
    Ok(())
}

/// `convert`: one USD stage at one time code to an `.rss` file, loaded back to validate it.
fn convert(input: &Path, output: &Path, stage: &StageArgs) -> anyhow::Result<()> {
    let t0 = Instant::now();
    if !input.exists() {
        return Err(Error::io(input, std::io::Error::new(std::io::ErrorKind::NotFound, "no such file")).into());
    }
    // (validated before it is renamed into place: a failed conversion writes nothing)
    let warnings = usd::convert(input, output, &stage.options())?;
    eprint!("{warnings}");
    if stage.options().subdivision.is_some() {
        eprintln!("note: --subdivision applies when rendering; the .rss keeps subdivision surfaces as their cages");
    }
    // Load it back to validate and report.
    let scene = usd::load_scene(output)?;
    let placed = || scene.instances.iter().map(|i| &scene.meshes[i.mesh as usize]);
    let tris: usize = placed().map(|m| m.indices.len()).sum();
    let faces: usize = placed().filter_map(|m| m.subdivision.as_ref()).map(|s| s.face_counts.len()).sum();
    eprintln!(
        "converted {} → {} in {:.2}s: {} meshes, {} instances, {} triangles{}, {} materials, {} lights, {} warnings",
        input.display(),
        output.display(),
        t0.elapsed().as_secs_f64(),
        scene.meshes.len(),
        scene.instances.len(),
        tris,
        if faces > 0 { format!(" + {faces} subdivision faces") } else { String::new() },
        scene.materials.len(),
        scene.lights.len(),
        scene.warnings.len()
    );
    Ok(())
}

/// `render --frames`: every frame of the range in turn, stopping at the first that fails.
fn render_frames(a: &RenderArgs, spec: &str) -> anyhow::Result<()> {
    let list = frames::parse(spec)?;
    // a USD stage is read at each time code; a scene named with a # is one converted file a frame
    let per_frame = !usd::is_usd(&a.scene) && frames::name(&a.scene, 0).is_some();
    if !usd::is_usd(&a.scene) && !per_frame {
        return Err(Error::param("frames", format!("{}: --frames reads the time codes of a USD stage (.usd, .usda, .usdc, .usdz) or files named with a # for the frame number (scene.####.rss, from `convert --frames`), and this file is neither", a.scene.display())).into());
    }
    let scenes: Vec<PathBuf> = list.iter().map(|&f| if per_frame { frames::name(&a.scene, f).expect("checked above") } else { a.scene.clone() }).collect();
    if let Some(missing) = scenes.iter().find(|p| !p.exists()) {
        return Err(Error::io(missing, std::io::Error::new(std::io::ErrorKind::NotFound, "no such file (a frame of the sequence)")).into());
    }
    for (p, what) in std::iter::once((&a.output, "output")).chain(a.preview.iter().map(|p| (p, "preview"))) {
        if frames::name(p, 0).is_none() {
            return Err(Error::param(what, format!("{}: a frame sequence needs a # in the file name for the frame number (e.g. out.####.exr)", p.display())).into());
        }
    }
    // every frame's files, before the first renders
    let names: Vec<(PathBuf, Format)> = list
        .iter()
        .flat_map(|&f| {
            let preview = a.preview.as_ref().map(|p| (frames::name(p, f).expect("checked above"), Format::Png));
            std::iter::once((frames::name(&a.output, f).expect("checked above"), Format::Exr)).chain(preview)
        })
        .collect();
    let outputs: Vec<(&Path, Format)> = names.iter().map(|(p, f)| (p.as_path(), *f)).collect();
    let inputs: Vec<&Path> = scenes.iter().map(|p| p.as_path()).collect();
    io::check_outputs(&outputs, &inputs)?;
    let t0 = Instant::now();
    // (a converted file keeps the time code it was converted at)
    let stage_at = |f: i64| if per_frame { a.stage.clone() } else { StageArgs { frame: Some(f as f64), ..a.stage.clone() } };
    for (k, &f) in list.iter().enumerate() {
        eprintln!("frame {f} ({} of {})", k + 1, list.len());
        let one = RenderArgs {
            scene: scenes[k].clone(),
            output: frames::name(&a.output, f).expect("checked above"),
            preview: a.preview.as_ref().map(|p| frames::name(p, f).expect("checked above")),
            stage: stage_at(f),
            frames: None,
            ..a.clone()
        };
        // The next frame's conversion (a Python process of its own) runs while this frame
        // renders; its render then finds it in the cache. A conversion that fails here is
        // simply done again there, where its error is reported.
        std::thread::scope(|scope| {
            if let (Some(&next), false) = (list.get(k + 1), per_frame) {
                let opts = stage_at(next).options();
                scope.spawn(move || usd::convert_cached(&a.scene, &opts).ok());
            }
            render(&one).map_err(|e| e.context(format!("frame {f}")))
        })?;
    }
    eprintln!("rendered {} frames in {:.2}s", list.len(), t0.elapsed().as_secs_f64());
    Ok(())
}

fn render(a: &RenderArgs) -> anyhow::Result<()> {
    if let Some(spec) = &a.frames {
        return render_frames(a, spec);
    }
    let request = request_of(a)?;
    request.check()?; // bad parameters fail before the scene is loaded
    let crop = a.crop.as_deref().map(part::parse_crop).transpose()?;
    let tile = a.tile.as_deref().map(part::parse_tile).transpose()?;
    let passes = match (a.passes, a.pass_range.as_deref().map(part::parse_pass_range).transpose()?) {
        (Some(n), Some((first, end))) => Some(integrators::Passes { total: n, first, end, fixed_bandwidth: a.fixed_bandwidth }),
        (Some(n), None) => Some(integrators::Passes { fixed_bandwidth: a.fixed_bandwidth, ..integrators::Passes::all(n) }),
        (None, _) => None,
    };
    if let Some(p) = &passes {
        p.validate()?;
    }
    // the output rule (a new path or a regular file, never the scene, never each other, named for
    // their formats) before anything is loaded or rendered
    let outputs: Vec<(&Path, Format)> = std::iter::once((a.output.as_path(), Format::Exr)).chain(a.preview.as_deref().map(|p| (p, Format::Png))).collect();
    io::check_outputs(&outputs, &[&a.scene])?;
    if let Some(e) = a.exposure.filter(|e| !(e.is_finite() && e.abs() <= 64.0)) {
        return Err(Error::param("exposure", format!("{e} stops is out of range (-64..=64)")).into());
    }
    // OpenEXR's pool (EXR textures, the output's compression) follows --threads; it is sized once
    // per process, before the first EXR file is opened.
    let _ = match a.threads {
        0 => raysplat::io::exr_threads::size_pool_for_caller(),
        n => raysplat::io::exr_threads::size_pool_once(n),
    };
    let t0 = Instant::now();
    let (scene, file_info) = usd::load_scene_info(&a.scene, &a.stage.options())?;
    for w in &scene.warnings {
        eprintln!("warning: {}: {}", w.prim, w.message);
    }
    let load_s = t0.elapsed().as_secs_f64();
    let scene_camera = scene.camera.name.clone();
    let scene_sha256 = usd::sha256_file(&a.scene)?;
    let full = request.image_size(&scene)?;
    // the crop window or tile and the pass range, once the settings are chosen (auto chooses on the
    // scene it renders: one preparation)
    let adjust = |s: &mut integrators::RenderSettings, full: [u32; 2]| -> raysplat::Result<()> {
        s.crop = match tile {
            Some((i, n)) => Some(part::tile_window(i, n, full)?),
            None => crop,
        };
        s.passes = passes;
        s.validate()
    };
    let progress = progress::Bars::new();
    let (out, resolved) = integrators::render_request(scene, &request, &adjust, &progress)?;
    if let Some(r) = &resolved.auto {
        eprintln!("{r}");
    }
    let mut attrs = resolved.attributes();
    attrs.push(("raysplat:scene".into(), a.scene.display().to_string()));
    attrs.extend(part::part_attributes(&scene_sha256, full, resolved.settings.crop));
    // what parts must share to be merged: every setting but the passes' range
    let shared: Vec<(String, String)> = resolved.settings.attributes().into_iter().filter(|(k, _)| k != "raysplat:pass_range").collect();
    attrs.push((merge::SETTINGS.into(), serde_json::to_string(&shared)?));
    attrs.push(("raysplat:camera".into(), scene_camera));
    if let Some(t) = file_info.time {
        attrs.push(("raysplat:frame".into(), format!("{t}")));
    }
    attrs.push(("raysplat:render_seconds".into(), format!("{:.3}", out.stats.total_seconds)));
    attrs.push(("raysplat:load_seconds".into(), format!("{load_s:.3}")));
    image::write_exr(&a.output, &out.film, &attrs)?;
    if let Some(p) = &a.preview {
        let rgb = out.film.rgb("").expect("beauty layer");
        let stops = a.exposure.unwrap_or_else(|| {
            let auto = image::auto_exposure(&rgb);
            eprintln!("preview exposure: {:+.2} stops (automatic: log-average luminance {:.4} at middle grey; --exposure sets it)", auto.stops, auto.key);
            auto.stops
        });
        image::write_png_unsqueezed(p, out.film.width, out.film.height, &rgb, stops, out.film.pixel_aspect)?;
    }
    let nan = out.film.nan_count();
    if a.json {
        println!("{}", serde_json::to_string(&out.stats)?);
    }
    eprint!("{}", out.stats.summary());
    eprintln!(
        "wrote {} ({}x{}, method {}) in {:.2}s (scene load {:.2}s){}",
        a.output.display(),
        out.film.width,
        out.film.height,
        resolved.settings.method.method(),
        t0.elapsed().as_secs_f64(),
        load_s,
        if nan > 0 { format!(" — WARNING: {nan} NaN/Inf values") } else { String::new() }
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn request(args: &[&str]) -> Result<RenderRequest, Error> {
        let cli = Cli::try_parse_from(["raysplat", "render", "scene.usda", "-o", "out.exr"].iter().chain(args)).expect("arguments parse");
        let Command::Render(a) = cli.command else { unreachable!("a render command") };
        request_of(&a)
    }

    /// A render without options asks for the library's defaults, which the C++ API's
    /// `default_options()` gives too (`raysplat::ffi` tests that side).
    #[test]
    fn defaults_are_the_librarys() {
        assert_eq!(request(&[]).unwrap(), RenderRequest::DEFAULT);
    }

    /// Each flag sets one option, and `--fg-rays` one setting of whichever gathering method runs.
    #[test]
    fn flags_set_one_option_each() {
        use raysplat::integrators::MethodSettings;
        let r = request(&["--method", "he-fg", "--fg-rays", "7", "--cache-error", "0.4", "--resolution", "32x16"]).unwrap();
        assert_eq!(r, RenderRequest { method: Some(integrators::Method::HeFg), fg_rays: Some(7), cache_error: Some(0.4), resolution: Some([32, 16]), ..RenderRequest::DEFAULT });
        let MethodSettings::HeFg(he) = r.settings().unwrap().method else { panic!("he-fg") };
        assert_eq!((he.stratified_rays, he.explicit_rays, he.cache_error), (7, 230, 0.4));
        let pm = request(&["--method", "pm-fg", "--fg-rays", "7"]).unwrap().settings().unwrap();
        let MethodSettings::PmFg(fg) = pm.method else { panic!("pm-fg") };
        assert_eq!((fg.fg.rays, fg.cache_error), (7, 0.2));
        assert!(request(&["--method", "nope"]).unwrap_err().to_string().contains("available: auto, pt"));
        assert!(request(&["--resolution", "0x3"]).unwrap_err().to_string().contains("resolution"));
    }
}
