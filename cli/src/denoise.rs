//! `raysplat denoise in.exr -o out.exr`: Open Image Denoise on an image rendered earlier
//! (`raysplat::denoise::denoise_film` on the file's layers, its header carried over).

use raysplat::io::{check_outputs, Format};
use raysplat::denoise::{self, Mode, Options, Report};
use raysplat::image::{self, Film};
use raysplat::integrators::RenderSettings;
use raysplat::Error;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct DenoiseArgs {
    /// An EXR written by `raysplat render` (or any EXR with an RGB beauty; `albedo` and `normal`
    /// layers guide the filter when present).
    input: PathBuf,
    /// The denoised EXR (may be the input): every layer of the input, the raw beauty as `raw`.
    #[arg(short, long)]
    output: PathBuf,
    /// The denoiser's quality: fast, balanced or high.
    #[arg(long, default_value = "high", value_parser = ["fast", "balanced", "high"])]
    quality: String,
    /// Tell the filter the albedo and normal layers are free of noise (rendered with many camera
    /// samples per pixel; by default they are taken as possibly noisy, docs/denoise.md).
    #[arg(long)]
    clean_aux: bool,
    /// Worker threads (0 = one per core).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Also write a tonemapped sRGB PNG preview of the denoised image.
    #[arg(long)]
    preview: Option<PathBuf>,
    /// Exposure (stops) for the preview.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    exposure: f32,
}

pub fn run(a: &DenoiseArgs) -> anyhow::Result<()> {
    // the output rule; the output may be the input (denoised in place: it is read whole first)
    let outputs: Vec<(&std::path::Path, Format)> = std::iter::once((a.output.as_path(), Format::Exr)).chain(a.preview.as_deref().map(|p| (p, Format::Png))).collect();
    check_outputs(&outputs, &[])?;
    if a.threads > 4096 {
        return Err(Error::param("threads", format!("{} is absurd", a.threads)).into());
    }
    let options = Options { mode: Mode::On, quality: a.quality.parse()?, clean_aux: a.clean_aux };
    options.validate()?;
    let (film, report) = denoise_exr(&a.input, &a.output, &options, a.threads)?;
    if let Some(p) = &a.preview {
        let rgb = film.rgb("").expect("denoise_exr checked the beauty");
        image::write_png_unsqueezed(p, film.width, film.height, &rgb, a.exposure, film.pixel_aspect)?;
    }
    eprintln!("{}", report.line());
    eprintln!("wrote {} ({}x{})", a.output.display(), film.width, film.height);
    Ok(())
}

/// Header attributes `render` writes besides the settings', carried over to the denoised file.
const RENDER_ATTRIBUTES: [&str; 6] = [
    "raysplat:scene",
    "raysplat:camera",
    "raysplat:frame",
    "raysplat:auto",
    "raysplat:render_seconds",
    "raysplat:load_seconds",
];

/// Denoise the EXR file `input` into `output` (which may be the same file) with
/// [`denoise::denoise_film`]: its beauty — or, for a file denoised before, its `raw` layer — guided by its
/// `albedo` and `normal` layers when it has them. The output keeps every layer, the raw beauty as
/// the layer `raw`, and the input's raysplat header attributes, with `raysplat:denoise*` set to
/// what was done. Returns the film written and the report.
///
/// # Errors
/// As `image::read_exr` and `image::write_exr`, and [`denoise::denoise_film`]'s. Nothing is written
/// when any step fails.
fn denoise_exr(input: &Path, output: &Path, options: &Options, threads: usize) -> raysplat::Result<(Film, Report)> {
    let mut film = image::read_exr(input)?;
    let mut names: Vec<String> = RenderSettings::default().attributes().into_iter().map(|(k, _)| k).collect();
    names.extend(RENDER_ATTRIBUTES.iter().map(|s| s.to_string()));
    let name_refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let mut attrs = image::read_exr_string_attributes(input, &name_refs)?;
    let report = denoise::denoise_film(&mut film, options, threads).map_err(|e| match e {
        Error::Image { message, .. } => Error::image(input.display().to_string(), message),
        other => other,
    })?;
    attrs.retain(|(k, _)| !k.starts_with("raysplat:denoise"));
    attrs.push(("raysplat:denoise".into(), "on".into()));
    attrs.push(("raysplat:denoise_quality".into(), options.quality.to_string()));
    attrs.push(("raysplat:denoise_seconds".into(), format!("{:.3}", report.seconds)));
    attrs.push(("raysplat:denoise_aux".into(), report.aux.to_string()));
    image::write_exr(output, &film, &attrs)?;
    Ok((film, report))
}
