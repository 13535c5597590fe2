//! Pixel reconstruction filters (`--filter`): how the samples of an image become its pixels.
//!
//! A sample at image position `(x, y)` (pixel `(i, j)` covers `[i, i+1) × [j, j+1)`) adds its value
//! with weight `f(i + ½ − x) · f(j + ½ − y)` to every pixel whose centre lies within the filter's
//! radius, and a pixel is the weighted average of the samples it received (the splatting of
//! pbrt-v3 and Mitsuba 3). The filters are separable and each 1D profile integrates to one, so the
//! 2D filter does too; the weighted average makes a constant image come out constant whatever the
//! filter, also where a filter has negative lobes (Mitchell).
//!
//! The radius scales each filter's shape: box is 1 within it; Gaussian has σ = radius / 4 (its
//! default radius 2 is Mitsuba's σ = 0.5) and is shifted down to reach zero at the radius;
//! Blackman–Harris spans the diameter with its window (radius 0.75 is Cycles' 1.5 px width);
//! Mitchell–Netravali (B = C = ⅓) spans ±2 of its own units over the radius.
//!
//! Methods that keep each sample in its pixel (the photon methods' eye pass) instead draw the
//! sample's offset from the pixel centre in proportion to |f| and weight it by f / pdf
//! ([`FilterSampler`], filter importance sampling as in pbrt-v4): the same filtered image in
//! expectation.
//!
//! Determinism: [`SplatTile`] gathers one tile's samples over the tile and the margin its filter
//! reaches, and [`FilteredImage::merge`] adds tiles into the image in a fixed order, so every
//! pixel's sums are the same for any thread count.

use crate::error::{Error, Result};
use std::f32::consts::PI;

/// Filter shapes (`--filter`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilterKind {
    Box,
    Gaussian,
    BlackmanHarris,
    Mitchell,
}

impl FilterKind {
    /// Every kind, in the order `--filter` lists them.
    pub const ALL: [FilterKind; 4] = [FilterKind::Box, FilterKind::Gaussian, FilterKind::BlackmanHarris, FilterKind::Mitchell];

    /// The name `--filter` takes.
    pub fn name(self) -> &'static str {
        match self {
            FilterKind::Box => "box",
            FilterKind::Gaussian => "gaussian",
            FilterKind::BlackmanHarris => "blackman-harris",
            FilterKind::Mitchell => "mitchell",
        }
    }

    /// The kind called `name` (as [`FilterKind::name`]).
    pub fn parse(name: &str) -> Result<FilterKind> {
        FilterKind::ALL.into_iter().find(|k| k.name() == name).ok_or_else(|| {
            let names: Vec<&str> = FilterKind::ALL.iter().map(|k| k.name()).collect();
            Error::param("filter", format!("{name:?} is not one of {}", names.join(", ")))
        })
    }

    /// The radius in pixels used when none is given: box 0.5 (the pixel itself), Gaussian 2
    /// (Mitsuba's and pbrt's σ = 0.5), Blackman–Harris 0.75 (Cycles' 1.5 px), Mitchell 2.
    pub fn default_radius(self) -> f32 {
        match self {
            FilterKind::Box => 0.5,
            FilterKind::Gaussian => 2.0,
            FilterKind::BlackmanHarris => 0.75,
            FilterKind::Mitchell => 2.0,
        }
    }
}

/// Largest radius accepted, in pixels.
pub const MAX_RADIUS: f32 = 8.0;

/// A filter shape at a radius, with its 1D normalisation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelFilter {
    pub kind: FilterKind,
    /// Half-width of the support in pixels, in [0.5, [`MAX_RADIUS`]].
    pub radius: f32,
    /// 1 / ∫ of the unnormalised 1D profile over [−radius, radius].
    norm: f32,
    /// Gaussian: 1 / 2σ² and the value its bell has at the radius (subtracted; computed once, as
    /// every splat evaluates the profile 2·(2·margin + 1) times).
    inv_2s2: f32,
    tail: f32,
}

impl Default for PixelFilter {
    /// The box over the pixel: each sample counts for its own pixel only (see `docs/filters.md`
    /// for why this is the default).
    fn default() -> Self {
        PixelFilter::BOX
    }
}

impl PixelFilter {
    /// The box over the pixel itself.
    pub const BOX: PixelFilter = PixelFilter { kind: FilterKind::Box, radius: 0.5, norm: 1.0, inv_2s2: 0.0, tail: 0.0 };

    /// `kind` at `radius` pixels (`None`: the kind's default radius); an error for a radius
    /// outside [0.5, [`MAX_RADIUS`]] (a smaller one leaves samples that count for no pixel).
    pub fn new(kind: FilterKind, radius: Option<f32>) -> Result<PixelFilter> {
        let radius = radius.unwrap_or(kind.default_radius());
        if !(0.5..=MAX_RADIUS).contains(&radius) {
            return Err(Error::param("pixel-filter-radius", format!("{radius} is out of range [0.5, {MAX_RADIUS}] pixels")));
        }
        let inv_2s2 = 1.0 / (2.0 * (radius / 4.0) * (radius / 4.0));
        let tail = if kind == FilterKind::Gaussian { (-radius * radius * inv_2s2).exp() } else { 0.0 };
        let mut f = PixelFilter { kind, radius, norm: 1.0, inv_2s2: if kind == FilterKind::Gaussian { inv_2s2 } else { 0.0 }, tail };
        f.norm = 1.0 / f.integral_1d();
        Ok(f)
    }

    /// Whether every sample counts for its own pixel alone with weight one: the pixel is then the
    /// plain mean of its samples, and renderers skip the splatting.
    pub fn is_pixel_box(&self) -> bool {
        self.kind == FilterKind::Box && self.radius == 0.5
    }

    /// Pixels the filter reaches beyond a sample's own pixel on each side.
    pub fn margin(&self) -> u32 {
        ((self.radius + 0.5).ceil() as u32).saturating_sub(1)
    }

    /// The normalised 1D profile at offset `d` pixels (0 outside [−radius, radius]).
    pub fn eval_1d(&self, d: f32) -> f32 {
        self.norm * self.profile(d.abs())
    }

    /// The normalised 2D filter at offset `(dx, dy)`.
    pub fn eval(&self, dx: f32, dy: f32) -> f32 {
        self.eval_1d(dx) * self.eval_1d(dy)
    }

    /// The unnormalised profile at distance `a ≥ 0` from the centre.
    fn profile(&self, a: f32) -> f32 {
        let r = self.radius;
        if a > r {
            return 0.0;
        }
        match self.kind {
            FilterKind::Box => 1.0,
            FilterKind::Gaussian => ((-a * a * self.inv_2s2).exp() - self.tail).max(0.0),
            FilterKind::BlackmanHarris => {
                let t = 2.0 * PI * (a / (2.0 * r) + 0.5);
                0.35875 - 0.48829 * t.cos() + 0.14128 * (2.0 * t).cos() - 0.01168 * (3.0 * t).cos()
            }
            FilterKind::Mitchell => {
                let (b, c) = (1.0 / 3.0, 1.0 / 3.0);
                let u = 2.0 * a / r;
                let m = if u < 1.0 {
                    (12.0 - 9.0 * b - 6.0 * c) * u * u * u + (-18.0 + 12.0 * b + 6.0 * c) * u * u + (6.0 - 2.0 * b)
                } else if u < 2.0 {
                    (-b - 6.0 * c) * u * u * u + (6.0 * b + 30.0 * c) * u * u + (-12.0 * b - 48.0 * c) * u + (8.0 * b + 24.0 * c)
                } else {
                    0.0
                };
                m / 6.0
            }
        }
    }

    /// ∫ of the unnormalised profile over [−radius, radius]: closed forms where they are simple
    /// (box 2r, Blackman–Harris 2r·a₀ as its cosines span whole periods, Mitchell r/2 as its
    /// kernel integrates to one over ±2), Simpson's rule on 2048 intervals for the Gaussian.
    fn integral_1d(&self) -> f32 {
        let r = self.radius;
        match self.kind {
            FilterKind::Box => 2.0 * r,
            FilterKind::BlackmanHarris => 2.0 * r * 0.35875,
            FilterKind::Mitchell => r / 2.0,
            FilterKind::Gaussian => {
                const N: usize = 2048;
                let h = 2.0 * r as f64 / N as f64;
                let f = |i: usize| self.profile((-r as f64 + i as f64 * h).abs() as f32) as f64;
                let inner: f64 = (1..N).map(|i| if i % 2 == 1 { 4.0 * f(i) } else { 2.0 * f(i) }).sum();
                ((f(0) + f(N) + inner) * h / 3.0) as f32
            }
        }
    }

    /// `"<name> <radius>"`, as the EXR header records it (`raysplat:pixel_filter`).
    pub fn describe(&self) -> String {
        format!("{} {}", self.kind.name(), self.radius)
    }
}

/// Bins of [`FilterSampler`]'s table over [0, radius].
const SAMPLER_BINS: usize = 256;

/// Draws a sample's offset from its pixel centre in proportion to |f| (the two axes independently,
/// from a table of |f| over [0, radius] in [`SAMPLER_BINS`] bins, uniform within a bin), with the
/// weight f / pdf that makes the pixel's mean the filtered image in expectation: ≈ 1 for the
/// non-negative filters, negative where Mitchell is.
#[derive(Clone, Debug)]
pub struct FilterSampler {
    filter: PixelFilter,
    /// CDF of |f| over the bins of [0, radius] (`SAMPLER_BINS + 1` values, from 0 to 1).
    cdf: Vec<f32>,
}

impl FilterSampler {
    pub fn new(filter: PixelFilter) -> FilterSampler {
        let bin = filter.radius / SAMPLER_BINS as f32;
        let mut cdf = Vec::with_capacity(SAMPLER_BINS + 1);
        let mut sum = 0.0f64;
        cdf.push(0.0);
        for i in 0..SAMPLER_BINS {
            // the bin's mass by Simpson's rule: a bin holding a zero of Mitchell keeps some mass
            let g = |t: f32| filter.eval_1d((i as f32 + t) * bin).abs() as f64;
            sum += (g(0.0) + 4.0 * g(0.5) + g(1.0)) / 6.0;
            cdf.push(sum as f32);
        }
        for c in &mut cdf {
            *c /= sum as f32;
        }
        FilterSampler { filter, cdf }
    }

    /// One axis: `u` in [0, 1) → (offset, f / pdf).
    fn sample_1d(&self, u: f32) -> (f32, f32) {
        let (sign, u) = if u < 0.5 { (-1.0, 2.0 * u) } else { (1.0, 2.0 * u - 1.0) };
        let i = (self.cdf.partition_point(|&c| c <= u) - 1).min(SAMPLER_BINS - 1);
        let p = self.cdf[i + 1] - self.cdf[i];
        let t = if p > 0.0 { (u - self.cdf[i]) / p } else { 0.5 };
        let bin = self.filter.radius / SAMPLER_BINS as f32;
        let d = (i as f32 + t.min(1.0)) * bin;
        // density over [−r, r]: the bin's probability over its width, halved for the two sides
        let pdf = p / (2.0 * bin);
        let f = self.filter.eval_1d(d);
        (sign * d, if pdf > 0.0 { f / pdf } else { 0.0 })
    }

    /// `u` in [0, 1)² → the offset from the pixel centre (pixels) and the sample's weight.
    pub fn sample(&self, u: [f32; 2]) -> ([f32; 2], f32) {
        let ((dx, wx), (dy, wy)) = (self.sample_1d(u[0]), self.sample_1d(u[1]));
        ([dx, dy], wx * wy)
    }
}

/// One tile's filtered samples: per pixel of the tile and the margin its filter reaches (clipped
/// to the image), the weighted sums of `channels` values and the sum of the weights.
pub struct SplatTile {
    filter: PixelFilter,
    /// First pixel of the region (image coordinates) and its size.
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
    channels: usize,
    /// `(channels + 1)` floats per pixel of the region: the sums, then the weight.
    data: Vec<f32>,
}

impl SplatTile {
    /// An empty tile for samples taken in pixels `[tx, tx + tw) × [ty, ty + th)` of an image of
    /// `width × height` pixels.
    pub fn new(filter: PixelFilter, [tx, ty, tw, th]: [u32; 4], [width, height]: [u32; 2], channels: usize) -> SplatTile {
        let m = filter.margin();
        let (x0, y0) = (tx.saturating_sub(m), ty.saturating_sub(m));
        let (x1, y1) = ((tx + tw + m).min(width), (ty + th + m).min(height));
        let (w, h) = (x1 - x0, y1 - y0);
        SplatTile { filter, x0, y0, w, h, channels, data: vec![0.0; (w * h) as usize * (channels + 1)] }
    }

    /// Add a sample at image position `(x, y)` (inside the tile's pixels) with `values` (one per
    /// channel) to every pixel the filter reaches.
    pub fn add(&mut self, x: f32, y: f32, values: &[f32]) {
        debug_assert_eq!(values.len(), self.channels);
        const MAX_SPAN: usize = 2 * MAX_RADIUS as usize + 3;
        let m = self.filter.margin() as i64;
        let (ix, iy) = (x.floor() as i64, y.floor() as i64);
        let span = |i: i64, lo: u32, n: u32| ((i - m).max(lo as i64), (i + m).min((lo + n) as i64 - 1));
        let ((qx0, qx1), (qy0, qy1)) = (span(ix, self.x0, self.w), span(iy, self.y0, self.h));
        let (nx, ny) = ((qx1 - qx0 + 1).max(0) as usize, (qy1 - qy0 + 1).max(0) as usize);
        let (mut wx, mut wy) = ([0.0f32; MAX_SPAN], [0.0f32; MAX_SPAN]);
        for (i, w) in wx[..nx].iter_mut().enumerate() {
            *w = self.filter.eval_1d((qx0 + i as i64) as f32 + 0.5 - x);
        }
        for (i, w) in wy[..ny].iter_mut().enumerate() {
            *w = self.filter.eval_1d((qy0 + i as i64) as f32 + 0.5 - y);
        }
        let (c, stride) = (self.channels, self.channels + 1);
        let values = &values[..c];
        for (j, &wy) in wy[..ny].iter().enumerate() {
            if wy == 0.0 {
                continue;
            }
            let at = (((qy0 + j as i64 - self.y0 as i64) as usize) * self.w as usize + (qx0 - self.x0 as i64) as usize) * stride;
            for (px, &wx) in self.data[at..at + nx * stride].chunks_exact_mut(stride).zip(&wx[..nx]) {
                let wgt = wy * wx;
                if wgt == 0.0 {
                    continue;
                }
                for (d, v) in px[..c].iter_mut().zip(values) {
                    *d += wgt * v;
                }
                px[c] += wgt;
            }
        }
    }
}

/// The weighted sums of a whole image, gathered from [`SplatTile`]s.
pub struct FilteredImage {
    width: u32,
    channels: usize,
    data: Vec<f32>,
}

impl FilteredImage {
    /// An empty image of `width × height` pixels and `channels` values per pixel.
    pub fn new(width: u32, height: u32, channels: usize) -> FilteredImage {
        FilteredImage { width, channels, data: vec![0.0; (width * height) as usize * (channels + 1)] }
    }

    /// Add a tile's sums. Callers merge tiles in a fixed order: the sums (and so the image) are
    /// then the same for any thread count.
    pub fn merge(&mut self, tile: &SplatTile) {
        assert_eq!(tile.channels, self.channels, "tile and image differ in channels");
        let stride = self.channels + 1;
        for row in 0..tile.h as usize {
            let src = &tile.data[row * tile.w as usize * stride..(row + 1) * tile.w as usize * stride];
            let at = ((tile.y0 as usize + row) * self.width as usize + tile.x0 as usize) * stride;
            for (d, s) in self.data[at..at + src.len()].iter_mut().zip(src) {
                *d += s;
            }
        }
    }

    /// Per pixel, the weighted average of its samples (`channels` values per pixel, rows top
    /// first); 0 where no sample reached a pixel or the weights cancel.
    pub fn resolve(&self) -> Vec<f32> {
        let stride = self.channels + 1;
        let mut out = Vec::with_capacity(self.data.len() / stride * self.channels);
        for px in self.data.chunks_exact(stride) {
            let w = px[self.channels];
            let inv = if w.abs() > 1e-20 { 1.0 / w } else { 0.0 };
            out.extend(px[..self.channels].iter().map(|v| v * inv));
        }
        out
    }
}

#[cfg(test)]
mod tests;
