//! Comparing a render against a reference: error metrics and false-colour error images.
//!
//! Both inputs are RGB buffers (3 linear floats per pixel, same size and order).
//!
//! **Per-pixel relative error** (used by [`Metrics::mean_rel_error`], the `over_*` shares and
//! [`error_image`]): the mean over R, G, B of `|t − r| / (|r| + 0.01)`. The `0.01` keeps the error
//! of (near-)black reference pixels finite: there it measures absolute error in units of 0.01.
//! See [`pixel_relative_error`].

use serde::Serialize;

/// Added to `|reference|` in the per-pixel relative error.
const REL_EPS: f64 = 0.01;
/// Added to `reference²` in the relative MSE.
const REL_MSE_EPS: f64 = 0.01;

/// Error metrics of a test image against a reference (see [`compare`]).
///
/// A NaN or infinite value in either image makes the errors (`rmse`, `rel_mse`, `mean_rel_error`)
/// infinite, so a script gating on them cannot pass; JSON writes them as the string `"inf"`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Metrics {
    /// Number of pixels compared (including the non-finite ones).
    pub pixels: usize,
    /// Root mean squared error over the R, G, B values of all pixels.
    #[serde(serialize_with = "number_or_text")]
    pub rmse: f64,
    /// Relative MSE: mean over pixels and R, G, B of `(t − r)² / (r² + 0.01)`.
    #[serde(serialize_with = "number_or_text")]
    pub rel_mse: f64,
    /// Mean over pixels of the per-pixel relative error (see the module docs).
    #[serde(serialize_with = "number_or_text")]
    pub mean_rel_error: f64,
    /// Share (0..1) of pixels whose relative error exceeds 5 % (a non-finite pixel does).
    pub over_5: f64,
    /// Share (0..1) of pixels whose relative error exceeds 15 %.
    pub over_15: f64,
    /// Share (0..1) of pixels whose relative error exceeds 30 %.
    pub over_30: f64,
    /// Pixels of the test image with a NaN or infinite value.
    pub nan: usize,
    /// Pixels of the reference with a NaN or infinite value.
    pub nan_reference: usize,
}

/// A finite number as a JSON number, infinity and NaN as the strings `"inf"` and `"nan"` (JSON has
/// no such numbers, and `null` would compare as small in some tools).
fn number_or_text<S: serde::Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    if v.is_finite() {
        s.serialize_f64(*v)
    } else if v.is_nan() {
        s.serialize_str("nan")
    } else {
        s.serialize_str(if *v > 0.0 { "inf" } else { "-inf" })
    }
}

/// The per-pixel relative error of test pixel `t` against reference pixel `r`: the mean over R, G,
/// B of `|t − r| / (|r| + 0.01)`. NaN if a value of `t` is NaN.
pub fn pixel_relative_error(t: [f32; 3], r: [f32; 3]) -> f64 {
    let e: f64 = (0..3).map(|c| (t[c] as f64 - r[c] as f64).abs() / ((r[c] as f64).abs() + REL_EPS)).sum();
    e / 3.0
}

/// Compare `test_rgb` against `ref_rgb` (RGB buffers of the same length).
///
/// Pixels with a NaN or infinite value are counted per image ([`Metrics::nan`],
/// [`Metrics::nan_reference`]); any such pixel makes the errors infinite and counts as over every
/// threshold. With no pixel all means and shares are 0.
///
/// # Panics
/// If the buffers differ in length or their length is not a multiple of 3.
pub fn compare(test_rgb: &[f32], ref_rgb: &[f32]) -> Metrics {
    check_lengths(test_rgb, ref_rgb);
    let pixels = test_rgb.len() / 3;
    let (mut nan, mut nan_reference, mut bad) = (0usize, 0usize, 0usize);
    let (mut se, mut rel_se, mut rel_sum) = (0.0f64, 0.0f64, 0.0f64);
    let mut over = [0usize; 3];
    for (t, r) in test_rgb.chunks_exact(3).zip(ref_rgb.chunks_exact(3)) {
        let (t_ok, r_ok) = (t.iter().all(|v| v.is_finite()), r.iter().all(|v| v.is_finite()));
        nan += !t_ok as usize;
        nan_reference += !r_ok as usize;
        if !(t_ok && r_ok) {
            bad += 1;
            continue;
        }
        for c in 0..3 {
            let (tv, rv) = (t[c] as f64, r[c] as f64);
            let d2 = (tv - rv) * (tv - rv);
            se += d2;
            rel_se += d2 / (rv * rv + REL_MSE_EPS);
        }
        let e = pixel_relative_error([t[0], t[1], t[2]], [r[0], r[1], r[2]]);
        rel_sum += e;
        for (count, threshold) in over.iter_mut().zip([0.05, 0.15, 0.30]) {
            if e > threshold {
                *count += 1;
            }
        }
    }
    let (n, n3) = (pixels.max(1) as f64, (3 * pixels).max(1) as f64);
    let error = |sum: f64, count: f64| if bad > 0 { f64::INFINITY } else { sum / count };
    Metrics {
        pixels,
        rmse: error(se, n3).sqrt(),
        rel_mse: error(rel_se, n3),
        mean_rel_error: error(rel_sum, n),
        over_5: (over[0] + bad) as f64 / n,
        over_15: (over[1] + bad) as f64 / n,
        over_30: (over[2] + bad) as f64 / n,
        nan,
        nan_reference,
    }
}

/// The colour ramp of [`error_image`]: `(relative error, linear RGB)` stops, interpolated
/// linearly in between and held constant outside.
pub const ERROR_RAMP: [(f64, [f32; 3]); 3] =
    [(0.05, [0.0, 0.0, 1.0]), (0.15, [0.0, 1.0, 0.0]), (0.30, [1.0, 0.0, 0.0])];

/// Colour of pixels whose test value is NaN or infinite (or whose reference is).
const NAN_COLOR: [f32; 3] = [1.0, 0.0, 1.0];

/// A false-colour image of the per-pixel relative error (as in Fig. 10 of the photon splatting
/// paper): blue up to 5 %, blue → green up to 15 %, green → red up to 30 %, red above (see
/// [`ERROR_RAMP`]); magenta where a value is NaN or infinite. Returns an RGB buffer with values in
/// `[0, 1]`, ready for [`write_png`](super::write_png) with exposure 0.
///
/// # Panics
/// As [`compare`].
pub fn error_image(test_rgb: &[f32], ref_rgb: &[f32]) -> Vec<f32> {
    check_lengths(test_rgb, ref_rgb);
    let mut out = Vec::with_capacity(test_rgb.len());
    for (t, r) in test_rgb.chunks_exact(3).zip(ref_rgb.chunks_exact(3)) {
        let finite = t.iter().chain(r).all(|v| v.is_finite());
        let colour =
            if finite { ramp(pixel_relative_error([t[0], t[1], t[2]], [r[0], r[1], r[2]])) } else { NAN_COLOR };
        out.extend_from_slice(&colour);
    }
    out
}

/// The [`ERROR_RAMP`] colour of relative error `e`.
fn ramp(e: f64) -> [f32; 3] {
    let (first, last) = (ERROR_RAMP[0], ERROR_RAMP[ERROR_RAMP.len() - 1]);
    if e <= first.0 {
        return first.1;
    }
    for pair in ERROR_RAMP.windows(2) {
        let ((e0, c0), (e1, c1)) = (pair[0], pair[1]);
        if e <= e1 {
            let s = ((e - e0) / (e1 - e0)) as f32;
            return [0, 1, 2].map(|i| c0[i] + (c1[i] - c0[i]) * s);
        }
    }
    last.1
}

/// The RGB buffer of a `width × height` image averaged over blocks of `block × block` pixels (the
/// blocks at the right and bottom edges average what remains of the image), with its size.
/// Comparing block averages measures the error at scales of `block` pixels and above: pixel noise
/// averages out, low-frequency error (a density estimate's blotches) stays. A block of 0 or 1
/// returns the image.
///
/// # Panics
/// If `rgb` does not hold `3 · width · height` values.
pub fn block_average(rgb: &[f32], width: u32, height: u32, block: u32) -> (Vec<f32>, u32, u32) {
    let (w, h) = (width as usize, height as usize);
    assert_eq!(rgb.len(), 3 * w * h, "RGB buffer of {width}x{height} pixels expected");
    let b = block.max(1) as usize;
    let (bw, bh) = (w.div_ceil(b), h.div_ceil(b));
    let mut out = vec![0.0f32; 3 * bw * bh];
    for by in 0..bh {
        for bx in 0..bw {
            let (x1, y1) = (((bx + 1) * b).min(w), ((by + 1) * b).min(h));
            let mut sum = [0.0f64; 3];
            for y in by * b..y1 {
                for px in rgb[3 * (y * w + bx * b)..3 * (y * w + x1)].chunks_exact(3) {
                    (0..3).for_each(|c| sum[c] += px[c] as f64);
                }
            }
            let n = ((x1 - bx * b) * (y1 - by * b)) as f64;
            (0..3).for_each(|c| out[3 * (by * bw + bx) + c] = (sum[c] / n) as f32);
        }
    }
    (out, bw as u32, bh as u32)
}

fn check_lengths(test_rgb: &[f32], ref_rgb: &[f32]) {
    assert_eq!(test_rgb.len(), ref_rgb.len(), "test and reference images differ in size");
    assert_eq!(test_rgb.len() % 3, 0, "RGB buffer length is not a multiple of 3");
}
