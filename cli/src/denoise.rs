//! `raysplat denoise in.exr -o out.exr`: Open Image Denoise on an image rendered earlier
//! (`raysplat::denoise::denoise_exr`).

use super::check_output_dir;
use raysplat::denoise::{self, Mode, Options};
use raysplat::{image, Error};
use std::path::PathBuf;

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
    check_output_dir(&a.output)?;
    if let Some(p) = &a.preview {
        check_output_dir(p)?;
    }
    if a.threads > 4096 {
        return Err(Error::param("threads", format!("{} is absurd", a.threads)).into());
    }
    let options = Options { mode: Mode::On, quality: a.quality.parse()?, clean_aux: a.clean_aux };
    options.validate()?;
    let (film, report) = denoise::denoise_exr(&a.input, &a.output, &options, a.threads)?;
    if let Some(p) = &a.preview {
        let rgb = film.rgb("").expect("denoise_exr checked the beauty");
        image::write_png_unsqueezed(p, film.width, film.height, &rgb, a.exposure, film.pixel_aspect)?;
    }
    eprintln!("{}", report.line());
    eprintln!("wrote {} ({}x{})", a.output.display(), film.width, film.height);
    Ok(())
}
