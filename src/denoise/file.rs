//! Denoising an EXR file rendered earlier (`raysplat denoise in.exr -o out.exr`).

use super::{denoise_film, Options, Report};
use crate::error::{Error, Result};
use crate::image::{self, Film};
use crate::integrators::RenderSettings;
use std::path::Path;

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
/// [`denoise_film`]: its beauty — or, for a file denoised before, its `raw` layer — guided by its
/// `albedo` and `normal` layers when it has them. The output keeps every layer, the raw beauty as
/// the layer `raw`, and the input's raysplat header attributes, with `raysplat:denoise*` set to
/// what was done. Returns the film written and the report.
///
/// # Errors
/// As [`image::read_exr`] and [`image::write_exr`], and [`denoise_film`]'s. Nothing is written
/// when any step fails.
pub fn denoise_exr(input: &Path, output: &Path, options: &Options, threads: usize) -> Result<(Film, Report)> {
    let mut film = image::read_exr(input)?;
    let mut names: Vec<String> = RenderSettings::default().attributes().into_iter().map(|(k, _)| k).collect();
    names.extend(RENDER_ATTRIBUTES.iter().map(|s| s.to_string()));
    let name_refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let mut attrs = image::read_exr_string_attributes(input, &name_refs)?;
    let report = denoise_film(&mut film, options, threads).map_err(|e| match e {
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
