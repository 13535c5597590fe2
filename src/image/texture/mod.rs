//! Image textures with the semantics of `UsdUVTexture`: wrap modes, source colour space,
//! `texel · scale + bias`, output channel selection and a fallback value.

mod blocked;
mod cache;
mod load;
mod mip;

use std::fmt;
use std::path::Path;

use glam::{Vec2, Vec3, Vec4};

use crate::scene::TextureDesc;
use blocked::{Blocked, Rgba8x4x4};
use load::{parse_color_space, parse_output, parse_wrap, read_texels};

/// An image texture, read once and shared read-only between threads.
///
/// Texels are kept in linear form (sRGB-encoded data is decoded when read, so filtering happens
/// in linear space); 8-bit images stay 8-bit in memory and are decoded through a 256-entry table.
/// Below the image, a MIP pyramid ([`mip`]) serves lookups over a footprint
/// ([`eval_filtered`](Texture::eval_filtered)).
pub struct Texture {
    width: u32,
    height: u32,
    texels: Texels,
    /// The MIP levels below the image, each half the one before (rounded up), down to 1 × 1.
    levels: Vec<Level>,
    wrap: [Wrap; 2],
    scale: Vec4,
    bias: Vec4,
    output: Output,
    /// The `st` map applied before the lookup (rows `(a, b, c)`, `(d, e, f)`); `None`: identity.
    st: Option<[Vec3; 2]>,
}

/// One MIP level below the image.
struct Level {
    width: u32,
    height: u32,
    texels: Texels,
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

impl Texels {
    /// The linear texel `(x, y)` of an image `w` texels wide (inside it), before scale and bias.
    #[inline]
    fn texel(&self, w: usize, x: usize, y: usize) -> Vec4 {
        match self {
            Texels::Ldr { data, lut } => decode(data.get(x, y), lut),
            Texels::Hdr(data) => data[y * w + x],
        }
    }

    /// The linear texels `(x, y)`, `(x + 1, y)`, `(x, y + 1)`, `(x + 1, y + 1)` (all inside the
    /// image), before scale and bias.
    #[inline]
    fn quad(&self, w: usize, x: usize, y: usize) -> [Vec4; 4] {
        match self {
            Texels::Ldr { data, lut } => {
                // element by element: `array::map` is a call LLVM may leave out of line
                let [a, b, c, d] = data.quad(x, y);
                [decode(a, lut), decode(b, lut), decode(c, lut), decode(d, lut)]
            }
            Texels::Hdr(data) => {
                let i = y * w + x;
                [data[i], data[i + 1], data[i + w], data[i + w + 1]]
            }
        }
    }
}

/// The area of a texture a lookup covers: two axes of the ellipse a ray cone cuts from the
/// surface, in texture coordinates (both zero: a point, an unfiltered bilinear lookup), and the
/// most lookups along the longer axis (1: trilinear, isotropic).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Footprint {
    pub axes: [Vec2; 2],
    pub max_probes: u32,
}

impl Footprint {
    /// A point: the bilinear lookup of [`Texture::eval`].
    pub const POINT: Footprint = Footprint { axes: [Vec2::ZERO; 2], max_probes: 1 };
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
    /// Linear ACEScg (AP1 primaries): converted to linear Rec.709 when read.
    AcesCg,
}

impl Texture {
    /// Read the texture described by `desc`, with its MIP pyramid.
    ///
    /// Files: PNG, JPEG, TGA, BMP and Radiance HDR (by content, through the `image` crate) and
    /// OpenEXR (by the `.exr` extension; the beauty layer's R, G, B, A, or Y, or else the first
    /// layer's channels). Images with one channel give `(c, c, c, 1)`, with two `(c, c, c, a)`,
    /// with three `(r, g, b, 1)` — as `UsdUVTexture` specifies.
    ///
    /// Colour space: `"sRGB"` decodes R, G, B with the sRGB curve, `"raw"` keeps them, `"auto"`
    /// decodes 8-bit RGB and RGBA images and keeps everything else (single-channel 8-bit images,
    /// 16-bit and float images) as is — the rule Hydra applies to `UsdUVTexture`, so grey 8-bit
    /// roughness or mask maps are not gamma-decoded; `"ACEScg"` reads linear AP1 values and
    /// converts them to linear Rec.709 (8-bit ones are then kept as floats, outside the cache).
    /// Alpha is never decoded.
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
            Ok(mut pyramid) => {
                let base = pyramid.remove(0);
                Texture {
                    width: base.width,
                    height: base.height,
                    texels: base.texels,
                    levels: pyramid,
                    wrap,
                    scale: Vec4::from(desc.scale),
                    bias: Vec4::from(desc.bias),
                    output,
                    st: (desc.st_transform != crate::scene::IDENTITY_ST).then(|| desc.st_transform.map(Vec3::from)),
                }
            }
            Err(why) => {
                warnings.push(format!("texture {:?}: {why}; using the fallback {:?}", desc.path, desc.fallback));
                Texture { output, ..Texture::constant(Vec4::from(desc.fallback)) }
            }
        };
        let warning = if warnings.is_empty() { None } else { Some(warnings.join("; ")) };
        (texture.fixed_st(), warning)
    }

    /// This texture, as a constant when its `st` map sends every coordinate to one point (a
    /// `UsdUVTexture` whose `st` reads no primvar): the texel under that point, unfiltered (a
    /// bilinear filter centred on the image's corner would take three quarters of a `black`
    /// border), with scale, bias and output kept.
    fn fixed_st(self) -> Texture {
        let Some([r0, r1]) = self.st else { return self };
        if r0.x != 0.0 || r0.y != 0.0 || r1.x != 0.0 || r1.y != 0.0 {
            return self;
        }
        let index = |c: f32, n: u32| -> i64 {
            // the image's far edge belongs to its last texel
            let i = (c * n as f32).floor();
            if (0.0..=1.0).contains(&c) {
                (i as i64).min(n as i64 - 1)
            } else {
                i.clamp(-1e12, 1e12) as i64
            }
        };
        let texel = self.fetch(index(r0.z, self.width), (self.height as i64 - 1) - index(r1.z, self.height));
        Texture { width: 1, height: 1, texels: Texels::Hdr(vec![texel]), levels: Vec::new(), wrap: [Wrap::Clamp; 2], st: None, ..self }
    }

    /// A 1×1 texture whose [`eval`](Texture::eval) returns `value` everywhere.
    pub fn constant(value: Vec4) -> Texture {
        Texture {
            width: 1,
            height: 1,
            texels: Texels::Hdr(vec![value]),
            levels: Vec::new(),
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

    /// The number of MIP levels, the image included.
    pub fn level_count(&self) -> usize {
        1 + self.levels.len()
    }

    /// `uv` mapped by the desc's `st_transform`.
    #[inline]
    fn map_st(&self, uv: Vec2) -> Vec2 {
        match &self.st {
            Some([r0, r1]) => {
                let h = uv.extend(1.0);
                Vec2::new(r0.dot(h), r1.dot(h))
            }
            None => uv,
        }
    }

    /// RGBA at texture coordinate `uv` (mapped by the desc's `st_transform` first): bilinear
    /// filtering of the four nearest texels (texel centres at `((x + ½) / width, 1 − (y + ½) /
    /// height)`: `v` points up, row 0 of the file is at `v = 1`), each wrapped by the wrap modes,
    /// then `texel · scale + bias`. A non-finite `uv` is treated as `(0, 0)`.
    pub fn eval(&self, uv: Vec2) -> Vec4 {
        let uv = self.map_st(uv);
        let uv = if uv.is_finite() { uv } else { Vec2::ZERO };
        self.bilinear(&self.texels, self.width, self.height, uv) * self.scale + self.bias
    }

    /// RGBA over the footprint `fp` around `uv` (both in texture coordinates, mapped by the
    /// `st_transform`): the footprint's longer axis spans `n` lookups (at most `fp.max_probes`,
    /// enough that each covers about the shorter axis), each a trilinear lookup in the MIP level
    /// whose texels are as wide as the longer axis over `n`; their average, then `· scale + bias`.
    /// A footprint within one texel of the image is [`eval`](Self::eval) itself, bit for bit
    /// (magnified textures stay as sharp as the bilinear filter leaves them).
    pub fn eval_filtered(&self, uv: Vec2, fp: &Footprint) -> Vec4 {
        let Some((n, lod, major)) = self.lod(fp) else { return self.eval(uv) };
        let uv = self.map_st(uv);
        let uv = if uv.is_finite() { uv } else { Vec2::ZERO };
        let mut sum = Vec4::ZERO;
        for i in 0..n {
            let offset = (i as f32 + 0.5) / n as f32 - 0.5;
            sum += self.trilinear(uv + major * offset, lod);
        }
        sum * (1.0 / n as f32) * self.scale + self.bias
    }

    /// For a footprint: the number of lookups, their level of detail and the longer axis in
    /// (mapped) texture coordinates; `None` when one bilinear lookup in the image covers it.
    #[inline]
    fn lod(&self, fp: &Footprint) -> Option<(u32, f32, Vec2)> {
        if self.levels.is_empty() {
            return None;
        }
        let map = |a: Vec2| match &self.st {
            Some([r0, r1]) => Vec2::new(r0.x * a.x + r0.y * a.y, r1.x * a.x + r1.y * a.y),
            None => a,
        };
        let (a, b) = (map(fp.axes[0]), map(fp.axes[1]));
        let size = Vec2::new(self.width as f32, self.height as f32);
        let (la, lb) = ((a * size).length(), (b * size).length());
        let (major, long, short) = if la >= lb { (a, la, lb) } else { (b, lb, la) };
        if !(long > 1.0) || !long.is_finite() {
            return None;
        }
        let n = if fp.max_probes > 1 { (long / short.max(1e-12)).ceil().clamp(1.0, fp.max_probes as f32) as u32 } else { 1 };
        let lod = (long / n as f32).log2().max(0.0);
        Some((n, lod, major))
    }

    /// Trilinear lookup at level of detail `lod` ≥ 0 (0: the image), before scale and bias.
    #[inline]
    fn trilinear(&self, uv: Vec2, lod: f32) -> Vec4 {
        let last = self.levels.len() as f32;
        let lod = lod.min(last);
        let l0 = lod.floor();
        let t = lod - l0;
        let at = |l: usize| match l {
            0 => self.bilinear(&self.texels, self.width, self.height, uv),
            _ => {
                let lv = &self.levels[l - 1];
                self.bilinear(&lv.texels, lv.width, lv.height, uv)
            }
        };
        let c0 = at(l0 as usize);
        if t == 0.0 {
            c0
        } else {
            c0.lerp(at(l0 as usize + 1), t)
        }
    }

    /// Bilinear filtering of a `w × h` level at `uv` (finite), before scale and bias.
    #[inline]
    fn bilinear(&self, texels: &Texels, w: u32, h: u32, uv: Vec2) -> Vec4 {
        let x = uv.x * w as f32 - 0.5;
        let y = (1.0 - uv.y) * h as f32 - 0.5;
        let (fx, fy) = (x.floor(), y.floor());
        let (tx, ty) = (x - fx, y - fy);
        let xs = wrap_pair(fx as i64, w, self.wrap[0]);
        let ys = wrap_pair(fy as i64, h, self.wrap[1]);
        let [a, b, c, d] = match (xs, ys) {
            // Neighbours side by side in the image (most lookups, also of tiled textures): one
            // footprint of the blocked layout.
            ([Some(x0), Some(x1)], [Some(y0), Some(y1)]) if x1 == x0 + 1 && y1 == y0 + 1 => texels.quad(w as usize, x0 as usize, y0 as usize),
            _ => {
                let t = |x: Option<u32>, y: Option<u32>| match (x, y) {
                    (Some(x), Some(y)) => texels.texel(w as usize, x as usize, y as usize),
                    _ => Vec4::ZERO,
                };
                [t(xs[0], ys[0]), t(xs[1], ys[0]), t(xs[0], ys[1]), t(xs[1], ys[1])]
            }
        };
        let top = a.lerp(b, tx);
        let bottom = c.lerp(d, tx);
        top.lerp(bottom, ty)
    }

    /// The connected output at `uv` as a colour: `"rgb"` → R, G, B; `"r"`, `"g"`, `"b"`, `"a"` →
    /// that channel in all three components.
    pub fn eval_rgb(&self, uv: Vec2) -> Vec3 {
        self.select_rgb(self.eval(uv))
    }

    /// [`eval_rgb`](Self::eval_rgb) over a footprint ([`eval_filtered`](Self::eval_filtered)).
    pub fn eval_rgb_filtered(&self, uv: Vec2, fp: &Footprint) -> Vec3 {
        self.select_rgb(self.eval_filtered(uv, fp))
    }

    /// The connected output at `uv` as a scalar: that channel, or R for `"rgb"`.
    pub fn eval_scalar(&self, uv: Vec2) -> f32 {
        self.select_scalar(self.eval(uv))
    }

    /// [`eval_scalar`](Self::eval_scalar) over a footprint ([`eval_filtered`](Self::eval_filtered)).
    pub fn eval_scalar_filtered(&self, uv: Vec2, fp: &Footprint) -> f32 {
        self.select_scalar(self.eval_filtered(uv, fp))
    }

    fn select_scalar(&self, v: Vec4) -> f32 {
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

    /// The average of [`eval_rgb`](Self::eval_rgb) over the image (its 1 × 1 MIP level, or the
    /// texels themselves for a texture without levels).
    pub fn average_rgb(&self) -> Vec3 {
        match self.levels.last() {
            Some(top) => self.select_rgb(top.texels.texel(1, 0, 0) * self.scale + self.bias),
            None => {
                let n = (self.width * self.height) as f32;
                (0..self.height).flat_map(|y| (0..self.width).map(move |x| (x, y))).map(|(x, y)| self.texel_rgb(x, y)).sum::<Vec3>() / n
            }
        }
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

    /// The linear texel of the image at integer coordinates (wrapped), before scale and bias.
    fn fetch(&self, x: i64, y: i64) -> Vec4 {
        if (0..self.width as i64).contains(&x) && (0..self.height as i64).contains(&y) {
            return self.texel(x as usize, y as usize);
        }
        let (Some(x), Some(y)) = (wrap(x, self.width, self.wrap[0]), wrap(y, self.height, self.wrap[1])) else {
            return Vec4::ZERO;
        };
        self.texel(x as usize, y as usize)
    }

    /// The linear texel `(x, y)` of the image (inside it), before scale and bias.
    #[inline]
    fn texel(&self, x: usize, y: usize) -> Vec4 {
        self.texels.texel(self.width as usize, x, y)
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

#[cfg(test)]
mod tests;
