//! Reading texture files: the desc's tokens, the image decoded into linear texels (8-bit ones
//! through the decoded-texture cache), and the MIP levels below it.

use std::path::Path;

use glam::Vec4;

use super::blocked::Blocked;
use super::{cache, decode, mip, ColorSpace, Level, Output, Texels, Wrap};
use crate::image::Layer;
use crate::image::{read_exr, srgb_decode};

pub(super) fn parse_wrap(token: &str, warnings: &mut Vec<String>) -> Wrap {
    match token {
        "repeat" => Wrap::Repeat,
        "mirror" => Wrap::Mirror,
        "clamp" => Wrap::Clamp,
        "black" => Wrap::Black,
        other => {
            warnings.push(format!("unsupported wrap mode {other:?}, using \"repeat\""));
            Wrap::Repeat
        }
    }
}

pub(super) fn parse_output(token: &str, warnings: &mut Vec<String>) -> Output {
    match token {
        "rgb" | "rgba" => Output::Rgb,
        "r" => Output::R,
        "g" => Output::G,
        "b" => Output::B,
        "a" => Output::A,
        other => {
            warnings.push(format!("unsupported texture output {other:?}, using \"rgb\""));
            Output::Rgb
        }
    }
}

pub(super) fn parse_color_space(token: &str, warnings: &mut Vec<String>) -> ColorSpace {
    match token {
        "sRGB" | "srgb" => ColorSpace::Srgb,
        "raw" => ColorSpace::Raw,
        "ACEScg" | "acescg" => ColorSpace::AcesCg,
        "auto" | "" => ColorSpace::Auto,
        other => {
            warnings.push(format!("unsupported colour space {other:?}, using \"auto\""));
            ColorSpace::Auto
        }
    }
}

/// Read the file at `path` as linear texels with their MIP levels (the image first), or why not;
/// what the user should hear besides (a damaged cache entry decoded again) is added to `notes`.
pub(super) fn read_texels(path: &Path, color_space: ColorSpace, notes: &mut Vec<String>) -> Result<Vec<Level>, String> {
    if path.as_os_str().is_empty() {
        return Err("no file given".into());
    }
    if !path.is_file() {
        return Err("file not found".into());
    }
    let is_exr = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if is_exr {
        read_exr_texels(path, color_space)
    } else {
        read_ldr_texels(path, color_space, &crate::io::cache::usable_dir().0, notes)
    }
}

/// Texels of a PNG/JPEG/TGA/BMP/HDR file and their MIP levels; 8-bit ones through the
/// decoded-texture cache under `cache_dir` ([`cache`]), levels included (a damaged entry is
/// decoded again, and `notes` says so).
pub(super) fn read_ldr_texels(path: &Path, color_space: ColorSpace, cache_dir: &Path, notes: &mut Vec<String>) -> Result<Vec<Level>, String> {
    let content = crate::io::input::read_input(path).map_err(|e| match e {
        crate::Error::Io { source, .. } => source.to_string(),
        other => other.to_string(),
    })?;
    let cached = cache::path_for(cache_dir, &content, color_space);
    if color_space != ColorSpace::AcesCg {
        match cache::read(&cached) {
            Ok(Some(d)) => return Ok(ldr_levels(d)),
            Ok(None) => {}
            Err(why) => notes.push(format!("the cached decoded texture {} is damaged ({why}); decoded again", cached.display())),
        }
    }
    // the format from the content's signature, else from the file's extension (TGA files have
    // no signature)
    let mut reader = image::ImageReader::new(std::io::Cursor::new(&content));
    if let Ok(format) = image::ImageFormat::from_path(path) {
        reader.set_format(format);
    }
    let img = reader
        .with_guessed_format()
        .map_err(|e| e.to_string())?
        .decode()
        .map_err(|e| e.to_string())?;
    let color = img.color();
    let eight_bit = color.bytes_per_pixel() == color.channel_count();
    let srgb = match color_space {
        ColorSpace::Srgb => true,
        ColorSpace::Raw | ColorSpace::AcesCg => false,
        ColorSpace::Auto => eight_bit && color.channel_count() >= 3,
    };
    let (w, h) = (img.width(), img.height());
    if w == 0 || h == 0 {
        return Err("the image is empty".into());
    }
    if eight_bit && color_space != ColorSpace::AcesCg {
        let rgba = img.into_rgba8();
        let rows: &[[u8; 4]] = bytemuck::cast_slice(rgba.as_raw());
        let lut = ldr_lut(srgb);
        let mut blocks = vec![Blocked::from_rows(w, h, rows)];
        for (lw, lh, data) in mip::pyramid(w, h, |x, y| decode(rows[y * w as usize + x], &lut)) {
            blocks.push(Blocked::from_rows(lw, lh, &mip::encode_ldr(&data, srgb)));
        }
        let d = cache::Decoded { width: w, height: h, srgb, levels: blocks };
        cache::write(&cached, &d);
        Ok(ldr_levels(d))
    } else {
        let data: Vec<Vec4> = img.to_rgba32f().pixels().map(|p| decoded(Vec4::from(p.0), srgb, color_space)).collect();
        Ok(hdr_levels(w, h, data))
    }
}

/// The levels of a decoded 8-bit texture.
fn ldr_levels(d: cache::Decoded) -> Vec<Level> {
    let lut = ldr_lut(d.srgb);
    let sizes = std::iter::once((d.width, d.height)).chain(mip::sizes(d.width, d.height));
    sizes.zip(d.levels).map(|((width, height), data)| Level { width, height, texels: Texels::Ldr { data, lut: lut.clone() } }).collect()
}

/// A float image and its levels.
pub(super) fn hdr_levels(w: u32, h: u32, data: Vec<Vec4>) -> Vec<Level> {
    let below = mip::pyramid(w, h, |x, y| data[y * w as usize + x]);
    let mut levels = vec![Level { width: w, height: h, texels: Texels::Hdr(data) }];
    levels.extend(below.into_iter().map(|(width, height, d)| Level { width, height, texels: Texels::Hdr(d) }));
    levels
}

/// The colour table of 8-bit texels: sRGB-decoded or linear.
pub(super) fn ldr_lut(srgb: bool) -> Box<[f32; 256]> {
    Box::new(std::array::from_fn(|i| if srgb { srgb_decode(i as f32 / 255.0) } else { i as f32 / 255.0 }))
}

/// Texels of an OpenEXR file (float data: `auto` means raw) and their levels.
fn read_exr_texels(path: &Path, color_space: ColorSpace) -> Result<Vec<Level>, String> {
    let film = read_exr(path).map_err(|e| e.to_string())?;
    let layer = film.layer("").or(film.layers.first()).ok_or("the file has no channels")?;
    let pick = exr_channel_map(layer);
    let srgb = color_space == ColorSpace::Srgb;
    let data: Vec<Vec4> = layer
        .data
        .chunks_exact(layer.channels.len())
        .map(|px| decoded(Vec4::from(pick.map(|c| c.map_or(1.0, |i| px[i]))), srgb, color_space))
        .collect();
    if film.width == 0 || film.height == 0 {
        return Err("the image is empty".into());
    }
    Ok(hdr_levels(film.width, film.height, data))
}

/// Which channel of `layer` feeds R, G, B, A (`None` = constant 1).
fn exr_channel_map(layer: &Layer) -> [Option<usize>; 4] {
    let ch = |n: &str| layer.channel_index(n);
    if let (Some(r), Some(g), Some(b)) = (ch("R"), ch("G"), ch("B")) {
        return [Some(r), Some(g), Some(b), ch("A")];
    }
    if let Some(y) = ch("Y") {
        return [Some(y), Some(y), Some(y), ch("A")];
    }
    match layer.channels.len() {
        1 => [Some(0), Some(0), Some(0), None],
        2 => [Some(0), Some(0), Some(0), Some(1)],
        3 => [Some(0), Some(1), Some(2), None],
        _ => [Some(0), Some(1), Some(2), Some(3)],
    }
}

/// `v` with R, G, B sRGB-decoded if `srgb`, or converted from ACEScg to linear Rec.709.
fn decoded(v: Vec4, srgb: bool, color_space: ColorSpace) -> Vec4 {
    if srgb {
        Vec4::new(srgb_decode(v.x), srgb_decode(v.y), srgb_decode(v.z), v.w)
    } else if color_space == ColorSpace::AcesCg {
        (ACESCG_TO_REC709 * v.truncate()).extend(v.w)
    } else {
        v
    }
}

/// Linear AP1 (ACEScg, D60 white) to linear Rec.709 (D65), Bradford-adapted: the matrix OCIO's
/// ACES configurations use; each row sums to 1 (white stays white).
const ACESCG_TO_REC709: glam::Mat3 = glam::Mat3::from_cols_array(&[
    1.705_051, -0.130_256_42, -0.024_003_357, //
    -0.621_792_1, 1.140_804_7, -0.128_968_98, //
    -0.083_258_87, -0.010_548_319, 1.152_972_3,
]);

#[cfg(test)]
mod tests {
    use super::*;

    /// ACEScg white is white; its pure green is Rec.709's green and then some, with negative red
    /// and blue (a colour outside Rec.709), as OCIO converts it.
    #[test]
    fn acescg_converts_to_rec709() {
        let white = decoded(Vec4::ONE, false, ColorSpace::AcesCg);
        assert!((white - Vec4::ONE).abs().max_element() < 1e-5, "{white}");
        let g = decoded(Vec4::new(0.0, 1.0, 0.0, 0.5), false, ColorSpace::AcesCg);
        assert!((g - Vec4::new(-0.621_792_1, 1.140_804_7, -0.128_968_98, 0.5)).abs().max_element() < 1e-6, "{g}");
    }
}
