//! 8-bit sRGB PNG previews.

use std::io::{BufWriter, Write};
use std::path::Path;

use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};

use super::atomic::{shown, write_atomically};
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
    let expected = 3 * width as usize * height as usize;
    if width == 0 || height == 0 || rgb.len() != expected {
        return Err(Error::image(
            shown(path),
            format!("{} values for a {width}x{height} RGB image ({expected} expected)", rgb.len()),
        ));
    }
    let gain = exposure.exp2();
    let bytes: Vec<u8> = rgb.iter().map(|&v| to_8bit(v * gain)).collect();

    write_atomically(path, |tmp, file| {
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
