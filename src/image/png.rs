//! 8-bit sRGB PNG previews.

use std::io::{BufWriter, Write};
use std::path::Path;

use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};

use crate::io::atomic::{shown, write_atomically};
use super::srgb::srgb_encode;
use crate::{Error, Result};

/// Write an RGB buffer (`3 · width · height` linear floats, top row first) as an 8-bit sRGB PNG.
///
/// Each value is multiplied by `2^exposure`, clamped to `[0, 1]`, encoded with the sRGB OETF and
/// rounded to 8 bits; NaN becomes 0 (+∞ saturates to 255). The file is written to a temporary file
/// in the same directory and renamed.
///
/// # Errors
/// [`Error::Image`] if `rgb` does not hold `3 · width · height` values or the size is 0,
/// [`Error::Io`] if the file cannot be written.
pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[f32], exposure: f32) -> Result<()> {
    write_png_unsqueezed(path, width, height, rgb, exposure, 1.0)
}

/// [`write_png`] of an image whose pixels are `pixel_aspect` wide (over their height), stretched
/// to square pixels (linear interpolation; wider for `pixel_aspect > 1`, taller below 1), so that
/// viewers without a notion of pixel aspect show it as it is meant (an anamorphic render).
pub fn write_png_unsqueezed(path: &Path, width: u32, height: u32, rgb: &[f32], exposure: f32, pixel_aspect: f32) -> Result<()> {
    let expected = 3 * width as usize * height as usize;
    if width == 0 || height == 0 || rgb.len() != expected {
        return Err(Error::image(
            shown(path),
            format!("{} values for a {width}x{height} RGB image ({expected} expected)", rgb.len()),
        ));
    }
    let gain = exposure.exp2();
    let mut bytes: Vec<u8> = rgb.iter().map(|&v| to_8bit(v * gain)).collect();
    let (mut width, mut height) = (width, height);
    if pixel_aspect.is_finite() && pixel_aspect > 0.0 && (pixel_aspect - 1.0).abs() > 1e-6 {
        let (w, h) = if pixel_aspect > 1.0 {
            (((width as f32 * pixel_aspect).round() as u32).clamp(1, 1 << 16), height)
        } else {
            (width, ((height as f32 / pixel_aspect).round() as u32).clamp(1, 1 << 16))
        };
        let img = image::RgbImage::from_raw(width, height, bytes).expect("3 bytes per pixel");
        bytes = image::imageops::resize(&img, w, h, image::imageops::FilterType::Triangle).into_raw();
        (width, height) = (w, h);
    }

    write_atomically(path, crate::io::Format::Png, |tmp, file| {
        let mut out = BufWriter::new(file);
        PngEncoder::new(&mut out)
            .write_image(&bytes, width, height, ExtendedColorType::Rgb8)
            .map_err(|e| Error::image(shown(path), format!("PNG encoding: {e}")))?;
        out.flush().map_err(|e| Error::io(tmp, e))
    })
}

/// Linear value → 8-bit sRGB code value (NaN → 0).
fn to_8bit(linear: f32) -> u8 {
    (srgb_encode(linear) * 255.0).round() as u8
}
