//! Denoising with Intel Open Image Denoise (OIDN): its `RT` filter on the beauty image, guided by
//! the first-hit albedo and normal AOVs every method writes.
//!
//! - The library is optional. `build.rs` links it (with a run-path) when it finds it — the `pyoidn`
//!   wheel that `make setup` installs into `.venv`, `$OIDN_DIR/lib`, or the directory named by
//!   `RAYSPLAT_OIDN` — and then sets `cfg(raysplat_oidn)`; `RAYSPLAT_OIDN=off` builds without it.
//!   Without it [`status`] says why and how to get it, `Mode::On` is refused before a render
//!   starts, and `Mode::Auto` leaves the image as rendered, with a note.
//! - Inputs, as OIDN wants them: the colour is HDR linear radiance (non-finite and negative values
//!   are passed as 0); the albedo AOV is the first hit's albedo averaged over the pixel's camera
//!   samples, clamped to [0, 1]; the normal AOV is the first hit's world-space shading normal
//!   averaged over the same samples (OIDN needs [−1, 1], not unit length). They are passed as
//!   possibly noisy (OIDN's `cleanAux` off) unless [`Options::clean_aux`] says otherwise: with a
//!   few camera samples per pixel their edges and textures alias, and that gave lower errors.
//! - [`denoise_film`] keeps the raw beauty as the layer [`RAW_LAYER`] (RGBA) and writes the denoised
//!   colour into the beauty (alpha kept); the AOV layers (`direct`, `indirect`, …) stay raw.
//! - OIDN's CPU device gives the same image for any thread count (see the tests); its device is
//!   made once per process and kept, so the first call also pays its start-up.

#[cfg(raysplat_oidn)]
mod oidn;
#[cfg(test)]
mod tests;

use crate::error::{Error, Result};
use crate::image::Film;
use std::fmt;
use std::str::FromStr;
use std::sync::{Mutex, OnceLock};
use std::time::Instant;

/// The layer that keeps the beauty as rendered when the beauty is denoised (RGBA).
pub const RAW_LAYER: &str = "raw";

/// How to get the denoiser when this build has none.
pub const HOW_TO_GET: &str = "run `make setup` (it installs the pyoidn wheel, which carries the \
    library, into .venv) and rebuild; or build with RAYSPLAT_OIDN=<directory holding \
    libOpenImageDenoise.so> or OIDN_DIR=<OIDN install prefix>";

/// Whether a render is denoised (`render --denoise`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Mode {
    /// Never.
    #[default]
    Off,
    /// When the denoiser is available; otherwise the image stays as rendered and a note says so.
    Auto,
    /// Always: a build without the denoiser refuses the render (parameter error).
    On,
}

impl Mode {
    pub fn name(self) -> &'static str {
        match self {
            Mode::Off => "off",
            Mode::Auto => "auto",
            Mode::On => "on",
        }
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Mode {
    type Err = Error;
    fn from_str(s: &str) -> Result<Mode> {
        [Mode::Off, Mode::Auto, Mode::On]
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| Error::param("denoise", format!("{s:?} is not one of auto, on, off")))
    }
}

/// OIDN's quality setting: faster filters are meant for previews.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Quality {
    Fast,
    Balanced,
    /// OIDN's default on the CPU.
    #[default]
    High,
}

impl Quality {
    pub const ALL: [Quality; 3] = [Quality::Fast, Quality::Balanced, Quality::High];
    pub fn name(self) -> &'static str {
        match self {
            Quality::Fast => "fast",
            Quality::Balanced => "balanced",
            Quality::High => "high",
        }
    }
    /// oidn.h's `OIDNQuality` value.
    #[cfg_attr(not(raysplat_oidn), allow(dead_code))]
    fn oidn_value(self) -> i32 {
        match self {
            Quality::Fast => 4,
            Quality::Balanced => 5,
            Quality::High => 6,
        }
    }
}

impl fmt::Display for Quality {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Quality {
    type Err = Error;
    fn from_str(s: &str) -> Result<Quality> {
        Quality::ALL
            .into_iter()
            .find(|q| q.name() == s)
            .ok_or_else(|| Error::param("denoise-quality", format!("{s:?} is not one of fast, balanced, high")))
    }
}

/// The denoising part of the render settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Options {
    pub mode: Mode,
    pub quality: Quality,
    /// Tell OIDN the albedo and normal images are free of noise (`cleanAux`). Off by default:
    /// averaged over a few camera samples, edges and textures in them still alias, and OIDN's
    /// models for noisy auxiliary images gave lower errors on our renders (docs/denoise.md).
    pub clean_aux: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options::DEFAULT
    }
}

impl Options {
    /// Off; when on, the best quality with possibly noisy auxiliary images.
    pub const DEFAULT: Options = Options { mode: Mode::Off, quality: Quality::High, clean_aux: false };

    /// `Mode::On` in a build without the denoiser is a parameter error (before anything renders).
    pub fn validate(&self) -> Result<()> {
        // only `On` asks: the first `status()` starts OIDN's device
        match self.mode {
            Mode::On => match status() {
                Status::Unavailable(reason) => Err(Error::param("denoise", format!("the denoiser is unavailable: {reason}"))),
                Status::Available(_) => Ok(()),
            },
            Mode::Off | Mode::Auto => Ok(()),
        }
    }
}

/// Whether this build can denoise.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Status {
    /// OIDN is linked and its CPU device works; its version.
    Available(String),
    /// Why not, and how to get it ([`HOW_TO_GET`]).
    Unavailable(String),
}

/// Whether this build can denoise (the first call starts OIDN's device).
pub fn status() -> Status {
    static STATUS: OnceLock<Status> = OnceLock::new();
    STATUS.get_or_init(probe).clone()
}

/// True when [`status`] is available.
pub fn available() -> bool {
    matches!(status(), Status::Available(_))
}

#[cfg(raysplat_oidn)]
fn probe() -> Status {
    match oidn::version() {
        Ok(v) => Status::Available(v),
        Err(e) => Status::Unavailable(format!("Open Image Denoise is linked but does not run here ({e})")),
    }
}

#[cfg(not(raysplat_oidn))]
fn probe() -> Status {
    let why = match option_env!("RAYSPLAT_OIDN_BUILD") {
        Some("off") => "this build was made with RAYSPLAT_OIDN=off",
        _ => "this build found no Open Image Denoise library",
    };
    Status::Unavailable(format!("{why}; to denoise, {HOW_TO_GET}"))
}

/// Directory of the OIDN library this build links (empty without it): a C++ program linking the
/// static library links against it with the same run-path (`raysplat-link.txt`).
pub const OIDN_LIB_DIR: &str = env!("RAYSPLAT_OIDN_LIB_DIR");

/// What one denoise did.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// Wall-clock seconds of the filter (including OIDN's start-up on the first call).
    pub seconds: f64,
    pub quality: Quality,
    /// The auxiliary images used: "albedo + normal", "albedo" or "none".
    pub aux: &'static str,
    /// The beauty was taken from the `raw` layer of an already denoised film.
    pub from_raw: bool,
}

impl Report {
    /// One line for the render summary.
    pub fn line(&self) -> String {
        let version = match status() {
            Status::Available(v) => v,
            Status::Unavailable(_) => "?".into(),
        };
        format!(
            "denoised with Open Image Denoise {version} (RT filter, {} quality, HDR, aux: {}{}) in {:.3}s; the raw beauty is the layer `{RAW_LAYER}`",
            self.quality,
            self.aux,
            if self.from_raw { ", from the raw layer" } else { "" },
            self.seconds
        )
    }
}

/// Denoise the beauty of `film` in place: the raw beauty becomes (or, if the film was denoised
/// before, stays) the layer [`RAW_LAYER`], and the beauty's R, G, B become OIDN's output from the
/// raw colour and the film's `albedo` and `normal` layers (those it has). `threads`: OIDN's worker
/// threads, 0 for one per core.
///
/// # Errors
/// [`Error::Param`] when the denoiser is unavailable; [`Error::Image`] when the film has no RGB
/// beauty (or `raw` layer) or OIDN fails.
pub fn denoise_film(film: &mut Film, options: &Options, threads: usize) -> Result<Report> {
    if let Status::Unavailable(reason) = status() {
        return Err(Error::param("denoise", format!("the denoiser is unavailable: {reason}")));
    }
    let has_rgb = |name: &str| film.layer(name).is_some_and(|l| ["R", "G", "B"].iter().all(|c| l.channel_index(c).is_some()));
    if !has_rgb("") {
        return Err(Error::image("denoise", "the image has no beauty layer with R, G, B channels"));
    }
    let from_raw = film.layer(RAW_LAYER).is_some();
    let source = if from_raw { RAW_LAYER } else { "" };
    let what = if from_raw { "the raw layer" } else { "the beauty layer" };
    let color = film.rgb(source).ok_or_else(|| Error::image("denoise", format!("{what} has no R, G, B channels")))?;
    let albedo = film.rgb("albedo");
    let normal = albedo.as_ref().and_then(|_| xyz(film, "normal"));
    let aux = match (&albedo, &normal) {
        (Some(_), Some(_)) => "albedo + normal",
        (Some(_), None) => "albedo",
        _ => "none",
    };
    let t0 = Instant::now();
    let out = denoise_rgb(film.width, film.height, &color, albedo.as_deref(), normal.as_deref(), options, threads)?;
    let seconds = t0.elapsed().as_secs_f64();
    if !from_raw {
        let beauty = film.layer("").expect("checked above").clone();
        film.layers.push(crate::image::Layer { name: RAW_LAYER.into(), ..beauty });
    }
    let beauty = film.layer_mut("").expect("checked above");
    let idx = ["R", "G", "B"].map(|c| beauty.channel_index(c).expect("checked above"));
    let n = beauty.channels.len();
    for (px, rgb) in beauty.data.chunks_exact_mut(n).zip(out.chunks_exact(3)) {
        for (&i, &v) in idx.iter().zip(rgb) {
            px[i] = v;
        }
    }
    Ok(Report { seconds, quality: options.quality, aux, from_raw })
}

/// The X, Y, Z channels of layer `name` as 3 floats per pixel.
fn xyz(film: &Film, name: &str) -> Option<Vec<f32>> {
    let layer = film.layer(name)?;
    let idx = [layer.channel_index("X")?, layer.channel_index("Y")?, layer.channel_index("Z")?];
    let n = layer.channels.len();
    Some(layer.data.chunks_exact(n).flat_map(|px| idx.map(|i| px[i])).collect())
}

/// Denoise an RGB image (`3 · width · height` floats, top row first) guided by optional albedo and
/// normal images of the same layout (a normal image is used only with an albedo image, as OIDN
/// requires). Inputs are brought into OIDN's ranges first (see the module docs). Returns the
/// denoised RGB image.
///
/// # Errors
/// [`Error::Param`] when the denoiser is unavailable or a buffer has the wrong length;
/// [`Error::Image`] when OIDN reports an error.
pub fn denoise_rgb(
    width: u32,
    height: u32,
    color: &[f32],
    albedo: Option<&[f32]>,
    normal: Option<&[f32]>,
    options: &Options,
    threads: usize,
) -> Result<Vec<f32>> {
    let n = width as usize * height as usize * 3;
    for (what, b) in [("colour", Some(color)), ("albedo", albedo), ("normal", normal)] {
        if let Some(b) = b.filter(|b| b.len() != n) {
            return Err(Error::param("denoise", format!("the {what} image has {} values, {width}x{height} pixels need {n}", b.len())));
        }
    }
    let clamp = |b: &[f32], lo: f32, hi: f32| -> Vec<f32> { b.iter().map(|&v| if v.is_finite() { v.clamp(lo, hi) } else { 0.0 }).collect() };
    let color = clamp(color, 0.0, f32::MAX);
    let albedo = albedo.map(|a| clamp(a, 0.0, 1.0));
    let normal = albedo.as_ref().and(normal).map(|v| clamp(v, -1.0, 1.0));
    run(width, height, &color, albedo.as_deref(), normal.as_deref(), options, threads)
}

#[cfg(raysplat_oidn)]
fn run(w: u32, h: u32, color: &[f32], albedo: Option<&[f32]>, normal: Option<&[f32]>, o: &Options, threads: usize) -> Result<Vec<f32>> {
    let images = oidn::Images { width: w as usize, height: h as usize, color, albedo, normal };
    oidn::denoise(&images, o.quality.oidn_value(), o.clean_aux, threads).map_err(|e| Error::image("denoise", e))
}

#[cfg(not(raysplat_oidn))]
fn run(_: u32, _: u32, _: &[f32], _: Option<&[f32]>, _: Option<&[f32]>, _: &Options, _: usize) -> Result<Vec<f32>> {
    match status() {
        Status::Unavailable(reason) => Err(Error::param("denoise", format!("the denoiser is unavailable: {reason}"))),
        Status::Available(_) => unreachable!("a build without Open Image Denoise reports it unavailable"),
    }
}

/// Side of the square image [`seconds_per_pixel`] times.
const COST_SIDE: u32 = 128;

/// OIDN's measured time per pixel at `quality` on `threads` threads (0: all), in seconds, or `None`
/// without the denoiser. Measured once per process and setting: the denoise of a 128×128 image
/// with albedo and normal, timed after a first call that starts the device, the faster of two.
/// The filter's time grows with the pixel count, so `pixels × this` estimates a denoise (under
/// the machine's load when it was measured).
pub fn seconds_per_pixel(quality: Quality, threads: usize) -> Option<f64> {
    static MEASURED: Mutex<Vec<(Quality, usize, f64)>> = Mutex::new(Vec::new());
    if !available() {
        return None;
    }
    let mut cache = MEASURED.lock().unwrap_or_else(|p| p.into_inner());
    if let Some(&(_, _, s)) = cache.iter().find(|(q, t, _)| *q == quality && *t == threads) {
        return Some(s);
    }
    let side = COST_SIDE as usize;
    let mut color = Vec::with_capacity(side * side * 3);
    let mut state = 0x9e37_79b9_u32;
    for _ in 0..side * side * 3 {
        // a cheap noise: the filter's time does not depend on the values
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        color.push((state >> 8) as f32 / (1u32 << 24) as f32);
    }
    let albedo = vec![0.5f32; side * side * 3];
    let normal: Vec<f32> = (0..side * side).flat_map(|_| [0.0, 0.0, 1.0]).collect();
    let options = Options { mode: Mode::On, quality, ..Default::default() };
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let t0 = Instant::now();
        denoise_rgb(COST_SIDE, COST_SIDE, &color, Some(&albedo), Some(&normal), &options, threads).ok()?;
        best = best.min(t0.elapsed().as_secs_f64());
    }
    let s = best / (side * side) as f64;
    cache.push((quality, threads, s));
    Some(s)
}
