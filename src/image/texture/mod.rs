//! Image textures with the semantics of `UsdUVTexture`: wrap modes, source colour space,
//! `texel · scale + bias`, output channel selection and a fallback value.

mod blocked;
mod cache;

use std::fmt;
use std::path::Path;

use glam::{Vec2, Vec3, Vec4};

use super::exr::read_exr;
use super::film::Layer;
use super::srgb::srgb_decode;
use crate::scene::TextureDesc;
use blocked::{Blocked, Rgba8x4x4};

/// An image texture, read once and shared read-only between threads.
///
/// Texels are kept in linear form (sRGB-encoded data is decoded when read, so filtering happens
/// in linear space); 8-bit images stay 8-bit in memory and are decoded through a 256-entry table.
pub struct Texture {
    width: u32,
    height: u32,
    texels: Texels,
    wrap: [Wrap; 2],
    scale: Vec4,
    bias: Vec4,
    output: Output,
    /// The `st` map applied before the lookup (rows `(a, b, c)`, `(d, e, f)`); `None`: identity.
    st: Option<[Vec3; 2]>,
}

/// Texel storage, row 0 = the file's top row.
enum Texels {
    /// 8-bit RGBA in 4×4 cache-line blocks ([`blocked`]); colour channels map through `lut`,
    /// alpha is `a / 255`.
    Ldr { data: Blocked<Rgba8x4x4>, lut: Box<[f32; 256]> },
    /// Float RGBA (16-bit and floating-point files), already linear, row-major (2×2 blocks made
    /// no measurable difference to lookups and cost ~0.2 s of loading on the ShaderBall).
    Hdr(Vec<Vec4>),
}

/// What happens outside `[0, 1]` along one texture axis.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Wrap {
    Repeat,
    Mirror,
    Clamp,
    /// Texels outside the image are transparent black `(0, 0, 0, 0)` (before scale and bias).
    Black,
}

/// The connected `UsdUVTexture` output.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Output {
    Rgb,
    R,
    G,
    B,
    A,
}

/// How the file's colour values are encoded.
#[derive(Clone, Copy, Debug, PartialEq)]
enum ColorSpace {
    Srgb,
    Raw,
    /// sRGB for 8-bit RGB/RGBA images, raw otherwise (see [`Texture::load`]).
    Auto,
}

impl Texture {
    /// Read the texture described by `desc`.
    ///
    /// Files: PNG, JPEG, TGA, BMP and Radiance HDR (by content, through the `image` crate) and
    /// OpenEXR (by the `.exr` extension; the beauty layer's R, G, B, A, or Y, or else the first
    /// layer's channels). Images with one channel give `(c, c, c, 1)`, with two `(c, c, c, a)`,
    /// with three `(r, g, b, 1)` — as `UsdUVTexture` specifies.
    ///
    /// Colour space: `"sRGB"` decodes R, G, B with the sRGB curve, `"raw"` keeps them, `"auto"`
    /// decodes 8-bit RGB and RGBA images and keeps everything else (single-channel 8-bit images,
    /// 16-bit and float images) as is — the rule Hydra applies to `UsdUVTexture`, so grey 8-bit
    /// roughness or mask maps are not gamma-decoded. Alpha is never decoded.
    ///
    /// If the file is missing or unreadable the result is a 1×1 texture of `desc.fallback`
    /// (returned as is, without scale and bias) and a warning saying why. Unknown wrap, colour
    /// space or output tokens also produce a warning (and `repeat`, `auto`, `rgb`).
    pub fn load(desc: &TextureDesc) -> (Texture, Option<String>) {
        let mut warnings = Vec::new();
        let wrap = [parse_wrap(&desc.wrap_s, &mut warnings), parse_wrap(&desc.wrap_t, &mut warnings)];
        let output = parse_output(&desc.output, &mut warnings);
        let color_space = parse_color_space(&desc.color_space, &mut warnings);
        let texture = match read_texels(Path::new(&desc.path), color_space, &mut warnings) {
            Ok((width, height, texels)) => Texture {
                width,
                height,
                texels,
                wrap,
                scale: Vec4::from(desc.scale),
                bias: Vec4::from(desc.bias),
                output,
                st: (desc.st_transform != crate::scene::IDENTITY_ST).then(|| desc.st_transform.map(Vec3::from)),
            },
            Err(why) => {
                warnings.push(format!("texture {:?}: {why}; using the fallback {:?}", desc.path, desc.fallback));
                Texture { output, ..Texture::constant(Vec4::from(desc.fallback)) }
            }
        };
        let warning = if warnings.is_empty() { None } else { Some(warnings.join("; ")) };
        (texture, warning)
    }

    /// A 1×1 texture whose [`eval`](Texture::eval) returns `value` everywhere.
    pub fn constant(value: Vec4) -> Texture {
        Texture {
            width: 1,
            height: 1,
            texels: Texels::Hdr(vec![value]),
            wrap: [Wrap::Clamp; 2],
            scale: Vec4::ONE,
            bias: Vec4::ZERO,
            output: Output::Rgb,
            st: None,
        }
    }

    /// Width in texels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in texels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// RGBA at texture coordinate `uv` (mapped by the desc's `st_transform` first): bilinear
    /// filtering of the four nearest texels (texel centres at `((x + ½) / width, 1 − (y + ½) /
    /// height)`: `v` points up, row 0 of the file is at `v = 1`), each wrapped by the wrap modes,
    /// then `texel · scale + bias`. A non-finite `uv` is treated as `(0, 0)`.
    pub fn eval(&self, uv: Vec2) -> Vec4 {
        let uv = match &self.st {
            Some([r0, r1]) => {
                let h = uv.extend(1.0);
                Vec2::new(r0.dot(h), r1.dot(h))
            }
            None => uv,
        };
        let uv = if uv.is_finite() { uv } else { Vec2::ZERO };
        let x = uv.x * self.width as f32 - 0.5;
        let y = (1.0 - uv.y) * self.height as f32 - 0.5;
        let (fx, fy) = (x.floor(), y.floor());
        let (tx, ty) = (x - fx, y - fy);
        let xs = wrap_pair(fx as i64, self.width, self.wrap[0]);
        let ys = wrap_pair(fy as i64, self.height, self.wrap[1]);
        let [a, b, c, d] = match (xs, ys) {
            // Neighbours side by side in the image (most lookups, also of tiled textures): one
            // footprint of the blocked layout.
            ([Some(x0), Some(x1)], [Some(y0), Some(y1)]) if x1 == x0 + 1 && y1 == y0 + 1 => {
                self.quad(x0 as usize, y0 as usize)
            }
            _ => {
                let t = |x: Option<u32>, y: Option<u32>| match (x, y) {
                    (Some(x), Some(y)) => self.texel(x as usize, y as usize),
                    _ => Vec4::ZERO,
                };
                [t(xs[0], ys[0]), t(xs[1], ys[0]), t(xs[0], ys[1]), t(xs[1], ys[1])]
            }
        };
        let top = a.lerp(b, tx);
        let bottom = c.lerp(d, tx);
        top.lerp(bottom, ty) * self.scale + self.bias
    }

    /// The connected output at `uv` as a colour: `"rgb"` → R, G, B; `"r"`, `"g"`, `"b"`, `"a"` →
    /// that channel in all three components.
    pub fn eval_rgb(&self, uv: Vec2) -> Vec3 {
        self.select_rgb(self.eval(uv))
    }

    /// The connected output at `uv` as a scalar: that channel, or R for `"rgb"`.
    pub fn eval_scalar(&self, uv: Vec2) -> f32 {
        let v = self.eval(uv);
        match self.output {
            Output::Rgb | Output::R => v.x,
            Output::G => v.y,
            Output::B => v.z,
            Output::A => v.w,
        }
    }

    /// The value [`eval_rgb`](Texture::eval_rgb) returns at the centre of texel `(x, y)` (row 0 is
    /// the top row of the file): decoded, scaled, biased, output selected. Coordinates outside
    /// the image are wrapped. Meant for building sampling distributions over the texels.
    pub fn texel_rgb(&self, x: u32, y: u32) -> Vec3 {
        self.select_rgb(self.fetch(x as i64, y as i64) * self.scale + self.bias)
    }

    fn select_rgb(&self, v: Vec4) -> Vec3 {
        match self.output {
            Output::Rgb => v.truncate(),
            Output::R => Vec3::splat(v.x),
            Output::G => Vec3::splat(v.y),
            Output::B => Vec3::splat(v.z),
            Output::A => Vec3::splat(v.w),
        }
    }

    /// The linear texel at integer coordinates (wrapped), before scale and bias.
    fn fetch(&self, x: i64, y: i64) -> Vec4 {
        if (0..self.width as i64).contains(&x) && (0..self.height as i64).contains(&y) {
            return self.texel(x as usize, y as usize);
        }
        let (Some(x), Some(y)) = (wrap(x, self.width, self.wrap[0]), wrap(y, self.height, self.wrap[1])) else {
            return Vec4::ZERO;
        };
        self.texel(x as usize, y as usize)
    }

    /// The linear texel `(x, y)` (inside the image), before scale and bias.
    #[inline]
    fn texel(&self, x: usize, y: usize) -> Vec4 {
        match &self.texels {
            Texels::Ldr { data, lut } => decode(data.get(x, y), lut),
            Texels::Hdr(data) => data[y * self.width as usize + x],
        }
    }

    /// The linear texels `(x, y)`, `(x + 1, y)`, `(x, y + 1)`, `(x + 1, y + 1)` (all inside the
    /// image), before scale and bias.
    #[inline]
    fn quad(&self, x: usize, y: usize) -> [Vec4; 4] {
        match &self.texels {
            Texels::Ldr { data, lut } => data.quad(x, y).map(|t| decode(t, lut)),
            Texels::Hdr(data) => {
                let (i, w) = (y * self.width as usize + x, self.width as usize);
                [data[i], data[i + 1], data[i + w], data[i + w + 1]]
            }
        }
    }
}

/// An 8-bit texel in linear form.
#[inline(always)]
fn decode([r, g, b, a]: [u8; 4], lut: &[f32; 256]) -> Vec4 {
    Vec4::new(lut[r as usize], lut[g as usize], lut[b as usize], a as f32 / 255.0)
}

impl fmt::Debug for Texture {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let kind = match self.texels {
            Texels::Ldr { .. } => "8-bit",
            Texels::Hdr(_) => "float",
        };
        f.debug_struct("Texture")
            .field("size", &(self.width, self.height))
            .field("texels", &kind)
            .field("wrap", &self.wrap)
            .field("scale", &self.scale)
            .field("bias", &self.bias)
            .field("output", &self.output)
            .finish()
    }
}

/// Texel index `i` along an axis of `n` texels, or `None` for black outside the image.
fn wrap(i: i64, n: u32, mode: Wrap) -> Option<u32> {
    let n = n as i64;
    let j = match mode {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::Mirror => {
            let m = i.rem_euclid(2 * n);
            if m < n {
                m
            } else {
                2 * n - 1 - m
            }
        }
        Wrap::Clamp => i.clamp(0, n - 1),
        Wrap::Black if (0..n).contains(&i) => i,
        Wrap::Black => return None,
    };
    Some(j as u32)
}

/// `[wrap(i), wrap(i + 1)]` (the neighbour saturating, as `f32 as i64` does), with at most one
/// integer division.
#[inline]
fn wrap_pair(i: i64, n: u32, mode: Wrap) -> [Option<u32>; 2] {
    let n64 = n as i64;
    if i >= 0 && i < n64 - 1 {
        return [Some(i as u32), Some(i as u32 + 1)];
    }
    const FAR: i64 = 1 << 40;
    match mode {
        Wrap::Repeat if i.abs() < FAR => {
            let j = i.rem_euclid(n64) as u32;
            [Some(j), Some(if j + 1 == n { 0 } else { j + 1 })]
        }
        Wrap::Mirror if i.abs() < FAR => {
            let m = i.rem_euclid(2 * n64) as u32;
            let m1 = if m + 1 == 2 * n { 0 } else { m + 1 };
            let fold = |m: u32| if m < n { m } else { 2 * n - 1 - m };
            [Some(fold(m)), Some(fold(m1))]
        }
        _ => [wrap(i, n, mode), wrap(i.saturating_add(1), n, mode)],
    }
}

fn parse_wrap(token: &str, warnings: &mut Vec<String>) -> Wrap {
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

fn parse_output(token: &str, warnings: &mut Vec<String>) -> Output {
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

fn parse_color_space(token: &str, warnings: &mut Vec<String>) -> ColorSpace {
    match token {
        "sRGB" | "srgb" => ColorSpace::Srgb,
        "raw" => ColorSpace::Raw,
        "auto" | "" => ColorSpace::Auto,
        other => {
            warnings.push(format!("unsupported colour space {other:?}, using \"auto\""));
            ColorSpace::Auto
        }
    }
}

/// Read the file at `path` as linear texels: `(width, height, texels)` or why not; what the user
/// should hear besides (a damaged cache entry decoded again) is added to `notes`.
fn read_texels(path: &Path, color_space: ColorSpace, notes: &mut Vec<String>) -> Result<(u32, u32, Texels), String> {
    if path.as_os_str().is_empty() {
        return Err("no file given".into());
    }
    if !path.is_file() {
        return Err("file not found".into());
    }
    let is_exr = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    let (w, h, texels) =
        if is_exr { read_exr_texels(path, color_space)? } else { read_ldr_texels(path, color_space, &crate::usd::cache::usable_dir().0, notes)? };
    if w == 0 || h == 0 {
        return Err("the image is empty".into());
    }
    Ok((w, h, texels))
}

/// Texels of a PNG/JPEG/TGA/BMP/HDR file; 8-bit ones through the decoded-texture cache under
/// `cache_dir` ([`cache`]; a damaged entry is decoded again, and `notes` says so).
fn read_ldr_texels(path: &Path, color_space: ColorSpace, cache_dir: &Path, notes: &mut Vec<String>) -> Result<(u32, u32, Texels), String> {
    let content = crate::files::input::read_input(path).map_err(|e| match e {
        crate::Error::Io { source, .. } => source.to_string(),
        other => other.to_string(),
    })?;
    let cached = cache::path_for(cache_dir, &content, color_space);
    match cache::read(&cached) {
        Ok(Some(d)) => return Ok((d.width, d.height, Texels::Ldr { data: d.texels, lut: ldr_lut(d.srgb) })),
        Ok(None) => {}
        Err(why) => notes.push(format!("the cached decoded texture {} is damaged ({why}); decoded again", cached.display())),
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
        ColorSpace::Raw => false,
        ColorSpace::Auto => eight_bit && color.channel_count() >= 3,
    };
    let (w, h) = (img.width(), img.height());
    let texels = if eight_bit {
        let rgba = img.into_rgba8();
        let d = cache::Decoded { width: w, height: h, srgb, texels: Blocked::from_rows(w, h, bytemuck::cast_slice(rgba.as_raw())) };
        cache::write(&cached, &d);
        Texels::Ldr { data: d.texels, lut: ldr_lut(srgb) }
    } else {
        Texels::Hdr(img.to_rgba32f().pixels().map(|p| decoded(Vec4::from(p.0), srgb)).collect())
    };
    Ok((w, h, texels))
}

/// The colour table of 8-bit texels: sRGB-decoded or linear.
fn ldr_lut(srgb: bool) -> Box<[f32; 256]> {
    Box::new(std::array::from_fn(|i| if srgb { srgb_decode(i as f32 / 255.0) } else { i as f32 / 255.0 }))
}

/// Texels of an OpenEXR file (float data: `auto` means raw).
fn read_exr_texels(path: &Path, color_space: ColorSpace) -> Result<(u32, u32, Texels), String> {
    let film = read_exr(path).map_err(|e| e.to_string())?;
    let layer = film.layer("").or(film.layers.first()).ok_or("the file has no channels")?;
    let pick = exr_channel_map(layer);
    let srgb = color_space == ColorSpace::Srgb;
    let data = layer
        .data
        .chunks_exact(layer.channels.len())
        .map(|px| decoded(Vec4::from(pick.map(|c| c.map_or(1.0, |i| px[i]))), srgb))
        .collect();
    Ok((film.width, film.height, Texels::Hdr(data)))
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

/// `v` with R, G, B sRGB-decoded if `srgb`.
fn decoded(v: Vec4, srgb: bool) -> Vec4 {
    if srgb {
        Vec4::new(srgb_decode(v.x), srgb_decode(v.y), srgb_decode(v.z), v.w)
    } else {
        v
    }
}

#[cfg(test)]
mod tests;
