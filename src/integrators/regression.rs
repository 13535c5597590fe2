//! The passes' indirect light corrected by the path tracer's samples through a local linear
//! regression (the guided filter of He, Sun and Tang, with the passes as the guide).
//!
//! A density estimate's bias is smooth in the estimate's own terms: light blurred out of a bright
//! patch makes the patch too dark by a factor and its surroundings too bright by an offset, while
//! the estimate keeps every edge of the textures and geometry in view. Around each pixel the path
//! tracer's samples `Q` are fitted as `a·P + b` of the passes' `P` over a window; the fit's slope
//! and offset, averaged over the windows that hold the pixel, give the corrected value there. It
//! keeps the passes' detail and low noise and takes its level from the path tracer, whose noise
//! falls by about the window's pixel count.
//!
//! Two guards keep the path tracer's noise out where it is larger than what it corrects: the slope
//! is drawn towards 1 by the path tracer's noise in the window (a ridge regression: where the
//! passes hardly vary, their shape is kept and only the level is fitted), and the correction at a
//! pixel is shrunk by its noise over its size around the pixel (a Wiener factor), so that passes
//! the path tracer cannot fault stay as they are.
//!
//! `docs/auto.md` has what it does to `auto`'s error on the real scenes.

use super::blend::window_means;

/// Half the side of the regression's windows (5 × 5 pixels). A wider window averages more of the
/// path tracer's noise and fits less of the bias's detail: on Crytek Sponza (the passes and samples
/// of [`MIN_SPP`]'s figures) 5 × 5 gave a lower error than 7 × 7 with 15, 30 and 120 spp.
pub const RADIUS: usize = 2;

/// The fewest path-traced samples per pixel the correction uses: with fewer, the pilot's pair is
/// all there is, and its variance per pixel misses the rare bright paths the correction would
/// spread over its window. Correcting two `rs-rc` passes of Crytek Sponza (200×200, 200 000
/// photons each) with 2, 4, 15 and 120 path-traced spp gave 1.17, 0.89, 0.80 and 0.81 times the
/// image's relative MSE of the per-pixel blend ([`super::blend::indirect_weights`]).
pub const MIN_SPP: u32 = 4;

/// The variance of a pixel's correction over that of the mean of the path tracer's samples over a
/// window: its slope and offset are each such a mean, averaged over the windows again.
const CORRECTION_NOISE: f64 = 2.0;

/// The variance of a pixel's correction over that of the path tracer's mean at the pixel. The
/// correction keeps the passes' noise and lowers their squared bias `b²` about as blending them
/// with an estimate of this share `s` of the path tracer's error `c` would, to
/// `b² · s c / (b² + s c)`: on Crytek Sponza (two `rs-rc` passes of 200 000 photons, 200×200,
/// relative MSE of the indirect light: noise 1.5e-4, squared bias 5.4e-4) it left 3.0e-4,
/// 2.5e-4, 2.0e-4 and 1.45e-4 of the bias with 15, 30, 60 and 120 spp, as that blend would with
/// `s` 0.04, 0.05, 0.06 and 0.09.
pub fn noise_share() -> f64 {
    CORRECTION_NOISE / ((2 * RADIUS + 1) as f64).powi(2)
}

/// The corrected indirect light (RGB, row by row, never negative) and the mean over pixels of the
/// noise the correction brings in (the path tracer's, as the Wiener factor keeps it; what it leaves
/// of the passes' bias is not known), weighed per pixel by `scale²` (the relative error's weight).
/// `passes` and `pt` are the two indirect layers, `variance` one path's luminance variance per
/// pixel (the pilot's pair), `spp` the path tracer's samples per pixel. `None` when the sizes
/// differ or the path tracer has fewer than [`MIN_SPP`] samples.
pub fn correct(passes: &[f32], pt: &[f32], variance: &[f32], spp: u32, scale: &[f32], w: usize, h: usize) -> Option<(Vec<f32>, f64)> {
    let n = w * h;
    if passes.len() != 3 * n || pt.len() != 3 * n || variance.len() != n || scale.len() != n || n == 0 || spp < MIN_SPP {
        return None;
    }
    let r = RADIUS;
    let noise: Vec<f64> = variance.iter().map(|&v| v.max(0.0) as f64 / spp as f64).collect();
    // λ: the path tracer's noise per pixel around each pixel, the ridge term of the slope
    let ridge = window_means(&noise, w, h, r);
    let side = (2 * r + 1) as f64;
    let mut out = vec![0.0f32; 3 * n];
    let mut predicted = 0.0;
    for c in 0..3 {
        let p: Vec<f64> = (0..n).map(|k| passes[3 * k + c] as f64).collect();
        let q: Vec<f64> = (0..n).map(|k| pt[3 * k + c] as f64).collect();
        let product = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(a, b)| a * b).collect::<Vec<f64>>();
        let (mp, mq) = (window_means(&p, w, h, r), window_means(&q, w, h, r));
        let (mpq, mpp) = (window_means(&product(&p, &q), w, h, r), window_means(&product(&p, &p), w, h, r));
        let (slope, offset): (Vec<f64>, Vec<f64>) = (0..n)
            .map(|k| {
                let (cov, var) = (mpq[k] - mp[k] * mq[k], (mpp[k] - mp[k] * mp[k]).max(0.0));
                let a = if var + ridge[k] > 0.0 { (cov + ridge[k]) / (var + ridge[k]) } else { 1.0 };
                (a, mq[k] - a * mp[k])
            })
            .unzip();
        let (slope, offset) = (window_means(&slope, w, h, r), window_means(&offset, w, h, r));
        let delta: Vec<f64> = (0..n).map(|k| slope[k] * p[k] + offset[k] - p[k]).collect();
        // the correction's size around each pixel against its noise: a Wiener factor
        let size = window_means(&product(&delta, &delta), w, h, 1);
        for k in 0..n {
            let nu = CORRECTION_NOISE * ridge[k] / (side * side);
            let keep = if size[k] > nu { (size[k] - nu) / size[k] } else { 0.0 };
            // indirect light is never negative: a fit's noise below zero is cut off
            out[3 * k + c] = (p[k] + keep * delta[k]).max(0.0) as f32;
            let weight = [0.2126, 0.7152, 0.0722][c];
            predicted += weight * (scale[k] as f64).powi(2) * keep * nu / n as f64;
        }
    }
    Some((out, predicted))
}

/// The covariance of a corrected pixel with the path tracer's mean at that pixel, over the mean's
/// variance: the pixel's share of its windows' offsets (each a mean over the window's pixels).
const SELF_SHARE: f64 = 1.0 / (((2 * RADIUS + 1) * (2 * RADIUS + 1)) as f64);

/// How far, in standard errors of the path tracer's mean, a corrected pixel may stand from that
/// mean before the pixel is taken as one the correction may have failed. A density estimate can
/// be wrong by a factor at a single pixel (a kernel that reaches across a thin edge), which a fit
/// over a window cannot follow: on Crytek Sponza (200², 16 s, two passes and about 230
/// path-traced spp) 1 % of the pixels held over half of the corrected indirect light's error.
/// Three standard errors flag about 0.3 % of the pixels where the correction is right (of normal
/// noise); 2 and 2.5 lowered the error a little more and darkened the image more.
pub const OUTLIER_SIGMAS: f64 = 3.0;

/// The fewest path-traced samples per pixel with which pixels are flagged: with fewer, a pixel's
/// variance is too uncertain to test it against. On Crytek Sponza at 4 s the flags lowered the
/// error with 48 spp (by 3 %) and raised it with 15 (by 1 %).
pub const OUTLIER_MIN_SPP: u32 = 32;

/// Half the side of the windows over which, with [`OUTLIER_MIN_SPP`] samples or more, each
/// pixel's weight is measured (7 × 7 pixels). What a correction leaves of the passes' bias varies
/// over the image (large along the edges a kernel blurs, nothing on flat walls), and one weight
/// for the image gives the samples' noise to the walls and the bias to the edges. On Crytek Sponza
/// (200², three renders each) the indirect light's relative MSE fell from 2.8–3.1e-4 with one
/// weight to 2.1–2.3e-4 at 16 s (240–270 spp) and from 6.1e-4 to 5.4e-4 at 4 s (51 spp); 5 × 5 and
/// 9 × 9 windows did as well, 17 × 17 1–3 % worse and 33 × 33 5–10 % worse. With 16–19 spp it rose
/// by 14 %, which is why the windows need as many samples as the flags.
pub const WEIGHT_RADIUS: usize = 3;

/// What [`against_samples`] measured, and the corrected light's weights.
#[derive(Clone, Debug, PartialEq)]
pub struct Check {
    /// The corrected light's error, bias included, mean over the pixels not flagged.
    pub corrected: f64,
    /// The path tracer's samples' own error (their variance) over the same pixels.
    pub samples: f64,
    /// The corrected light's weight per pixel in its blend with the samples.
    pub weights: Vec<f32>,
    /// The pixels flagged as ones the correction may have failed ([`OUTLIER_SIGMAS`]), row by row.
    pub flagged: Vec<usize>,
    /// The predicted error of the blend at these weights, mean over every pixel.
    pub blended: f64,
}

impl Check {
    /// The corrected light's weight at the pixels not flagged: the one of least error.
    pub fn weight(&self) -> f64 {
        super::allocation::blend_weight(self.corrected, self.samples)
    }
}

/// The corrected indirect light `corrected` measured against the path tracer's samples of which
/// it was made (`pt`, both RGB row by row, `w` × `h`; `moments` their indirect luminance's mean
/// and mean square per pixel over `spp` samples), and the weights of least error to blend the two.
///
/// The samples' error is their variance, from their moments (`(M2 − M1²)/(spp − 1)` per pixel:
/// every sample counts, rare bright paths included, as they do in the mean). The mean squared
/// difference `E[(C − Q)²]` is the correction's error plus that variance, less twice what the
/// correction holds of it ([`SELF_SHARE`]). The correction keeps what the passes leave of their
/// bias where the path tracer's noise is too high to fault it: with many samples that rest can
/// exceed the samples' own error (the standard shader ball at 200² and 16 s: relative MSE 4.9e-4
/// against the path tracer's 3.7e-4 with the same samples), and then the samples weigh more.
///
/// With [`OUTLIER_MIN_SPP`] samples or more, a pixel whose corrected value stands more than
/// [`OUTLIER_SIGMAS`] standard errors from the samples' mean is flagged. What its squared
/// difference exceeds that bound by is taken as the correction's error there, and the pixel gets
/// the weight of least error from it (so the weight falls from the image's at the bound towards
/// the samples far beyond it). The other pixels each get the weight of least error from both
/// errors measured over the [`WEIGHT_RADIUS`] window around them, without the flagged pixels (their
/// squared differences lack the noise of the pixels flagged by chance, at most 3 % of the
/// samples' variance: the weights lean that little towards the correction). With fewer samples
/// every pixel not flagged shares the image's weight (`Check::weight`). The samples' variance
/// at a pixel is here the larger of its own and its 3 × 3 neighbours' mean: a pixel whose samples
/// happen to agree has no spread of its own to test against. Luminance, each pixel weighed by
/// `scale²` (a relative error's weight). `None` with fewer than two samples or sizes that differ.
pub fn against_samples(corrected: &[f32], pt: &[f32], moments: &[f32], spp: u32, scale: &[f32], w: usize, h: usize) -> Option<Check> {
    let n = w * h;
    if spp < 2 || n == 0 || scale.len() != n || corrected.len() != 3 * n || pt.len() != 3 * n || moments.len() != 2 * n {
        return None;
    }
    let lum = super::allocation::lum;
    let own: Vec<f64> = moments.chunks_exact(2).map(|m| (m[1] as f64 - (m[0] as f64).powi(2)).max(0.0) / (spp - 1) as f64).collect();
    let around = window_means(&own, w, h, 1);
    let squared: Vec<f64> = (0..n).map(|k| (lum(&corrected[3 * k..3 * k + 3]) - lum(&pt[3 * k..3 * k + 3])).powi(2)).collect();
    let bound = if spp >= OUTLIER_MIN_SPP { OUTLIER_SIGMAS * OUTLIER_SIGMAS } else { f64::INFINITY };
    let (mut difference, mut samples, mut kept) = (0.0, 0.0, 0usize);
    // the flagged pixels: index, the correction's error, the samples' variance
    let mut flagged = Vec::new();
    for (k, &d2) in squared.iter().enumerate() {
        let v = own[k].max(around[k]);
        if v > 0.0 && d2 > bound * v {
            flagged.push((k, d2 - bound * v, v));
            continue;
        }
        let weight = (scale[k] as f64).powi(2);
        difference += weight * d2;
        samples += weight * own[k];
        kept += 1;
    }
    let (difference, samples) = (difference / kept.max(1) as f64, samples / kept.max(1) as f64);
    let corrected_error = (difference - (1.0 - 2.0 * SELF_SHARE) * samples).max(0.0);
    let one = super::allocation::blend_weight(corrected_error, samples);
    let mut weights = vec![one as f32; n];
    let mut blended = super::allocation::blended(corrected_error, samples) * kept as f64;
    if spp >= OUTLIER_MIN_SPP {
        // both errors measured over the window around each pixel, from the pixels not flagged
        let mut is_flagged = vec![false; n];
        flagged.iter().for_each(|f| is_flagged[f.0] = true);
        let local = |term: &dyn Fn(usize) -> f64| window_means(&(0..n).map(|k| if is_flagged[k] { 0.0 } else { term(k) }).collect::<Vec<f64>>(), w, h, WEIGHT_RADIUS);
        let weighed = |k: usize| (scale[k] as f64).powi(2);
        let errors = local(&|k| weighed(k) * (squared[k] - (1.0 - 2.0 * SELF_SHARE) * own[k]));
        let (variances, counts) = (local(&|k| weighed(k) * own[k]), local(&|_| 1.0));
        blended = 0.0;
        // an unflagged pixel's window holds the pixel itself; a flagged one's may hold no other
        for k in (0..n).filter(|&k| counts[k] > 0.0) {
            let (error, variance) = ((errors[k] / counts[k]).max(0.0), variances[k] / counts[k]);
            let weight = if error + variance > 0.0 { super::allocation::blend_weight(error, variance) } else { one };
            weights[k] = weight as f32;
            if !is_flagged[k] {
                blended += weight * weight * error + (1.0 - weight) * (1.0 - weight) * variance;
            }
        }
    }
    for &(k, error, v) in &flagged {
        let weight = super::allocation::blend_weight(error, v).min(weights[k] as f64);
        weights[k] = weight as f32;
        blended += (scale[k] as f64).powi(2) * (weight * weight * error + (1.0 - weight) * (1.0 - weight) * v);
    }
    Some(Check { corrected: corrected_error, samples, weights, flagged: flagged.iter().map(|f| f.0).collect(), blended: blended / n as f64 })
}

/// A textured image for tests of the correction: stripes two pixels wide over a gradient, the
/// detail a density estimate keeps and a window's mean would blur.
#[cfg(test)]
pub(super) fn textured(w: usize, h: usize) -> Vec<f64> {
    (0..w * h).map(|k| (0.5 + 0.5 * (k % w) as f64 / w as f64) * if (k % w / 2 + k / w / 3) % 2 == 0 { 1.0 } else { 0.4 }).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn gauss(rng: &mut Rng) -> f64 {
        let (u, v) = (rng.next_f32().max(1e-7) as f64, rng.next_f32() as f64);
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }

    fn truth(w: usize, h: usize) -> Vec<f64> {
        textured(w, h)
    }

    fn mse(img: &[f32], truth: &[f64]) -> f64 {
        truth.iter().enumerate().map(|(k, t)| (img[3 * k] as f64 - t).powi(2)).sum::<f64>() / truth.len() as f64
    }

    /// The path tracer's samples an exact affine function of the passes: the fit recovers it
    /// (slope and offset in every window, no noise to shrink by), so the result is the samples.
    #[test]
    fn an_affine_bias_is_removed_exactly() {
        let (w, h) = (24, 17);
        let t = truth(w, h);
        let passes: Vec<f32> = t.iter().flat_map(|&v| [v as f32; 3]).collect();
        let pt: Vec<f32> = t.iter().flat_map(|&v| [(1.3 * v + 0.05) as f32; 3]).collect();
        let (out, predicted) = correct(&passes, &pt, &vec![0.0; w * h], 16, &vec![1.0; w * h], w, h).unwrap();
        for (a, b) in out.iter().zip(&pt) {
            assert!((a - b).abs() < 1e-5, "{a} against {b}");
        }
        assert_eq!(predicted, 0.0);
    }

    /// Passes too dark by a fifth on the image's right half (light blurred out of a bright patch),
    /// exact on the left, and a path tracer with noise far above that bias per pixel: the
    /// correction's error is well below both inputs' and below the passes' on each half.
    #[test]
    fn a_multiplicative_bias_is_corrected_under_heavy_noise() {
        let (w, h) = (64, 48);
        let t = truth(w, h);
        let mut rng = Rng::new(5, 0);
        let (spp, var) = (16u32, 0.64f64);
        let passes: Vec<f32> = t.iter().enumerate().flat_map(|(k, &v)| [(if k % w >= w / 2 { 0.8 * v } else { v }) as f32; 3]).collect();
        let pt: Vec<f32> = t.iter().flat_map(|&v| [(v + (var / spp as f64).sqrt() * gauss(&mut rng)) as f32; 3]).collect();
        let (out, _) = correct(&passes, &pt, &vec![var as f32; w * h], spp, &vec![1.0; w * h], w, h).unwrap();
        let (e, ep, eq) = (mse(&out, &t), mse(&passes, &t), mse(&pt, &t));
        assert!(e < 0.25 * ep && e < 0.25 * eq, "corrected {e:.2e}, passes {ep:.2e}, path tracer {eq:.2e}");
        let half = |img: &[f32], right: bool| (0..w * h).filter(|k| (k % w >= w / 2) == right).map(|k| (img[3 * k] as f64 - t[k]).powi(2)).sum::<f64>() / (w * h / 2) as f64;
        assert!(half(&out, true) < 0.25 * half(&passes, true), "right half {:.2e} against the passes' {:.2e}", half(&out, true), half(&passes, true));
    }

    /// Exact passes and a path tracer with few, noisy samples: the correction is shrunk to little,
    /// and the passes keep an error far below the path tracer's.
    #[test]
    fn exact_passes_stay_under_a_noisy_path_tracer() {
        let (w, h) = (64, 48);
        let t = truth(w, h);
        let mut rng = Rng::new(9, 0);
        let (spp, var) = (MIN_SPP, 0.64f64);
        let passes: Vec<f32> = t.iter().flat_map(|&v| [v as f32; 3]).collect();
        let pt: Vec<f32> = t.iter().flat_map(|&v| [(v + (var / spp as f64).sqrt() * gauss(&mut rng)) as f32; 3]).collect();
        let (out, _) = correct(&passes, &pt, &vec![var as f32; w * h], spp, &vec![1.0; w * h], w, h).unwrap();
        let (e, eq) = (mse(&out, &t), mse(&pt, &t));
        assert!(e < 0.02 * eq, "corrected {e:.2e}, path tracer {eq:.2e}");
        // too few samples to use
        assert!(correct(&passes, &pt, &vec![var as f32; w * h], MIN_SPP - 1, &vec![1.0; w * h], w, h).is_none());
    }

    /// The mean (RGB, grey) and the moments of `spp` samples per pixel of `truth` with normal noise
    /// of deviation `sd`.
    fn samples(truth: &[f64], spp: u32, sd: f64, seed: u64) -> (Vec<f32>, Vec<f32>) {
        let mut rng = Rng::new(seed, 0);
        let (mut pt, mut moments) = (Vec::new(), Vec::new());
        for &v in truth {
            let x: Vec<f64> = (0..spp).map(|_| v + sd * gauss(&mut rng)).collect();
            let m1 = x.iter().sum::<f64>() / spp as f64;
            let m2 = x.iter().map(|y| y * y).sum::<f64>() / spp as f64;
            pt.extend([m1 as f32; 3]);
            moments.extend([m1 as f32, m2 as f32]);
        }
        (pt, moments)
    }

    /// Samples of known spread per pixel, their mean and moments, and a correction that keeps a
    /// bias of a tenth and its share of the samples' noise: the check measures the correction's
    /// error (the bias's square) and the samples' (their variance over their count), and weighs
    /// the correction by them; an exact correction takes the whole weight.
    #[test]
    fn the_correction_is_weighed_against_the_samples_by_their_measured_errors() {
        let (w, h) = (128, 96);
        let t = truth(w, h);
        let (spp, sd) = (64u32, 1.0f64);
        let (pt, moments) = samples(&t, spp, sd, 11);
        let with = |bias: f64| -> Vec<f32> { t.iter().enumerate().flat_map(|(k, &v)| [((1.0 + bias) * v + SELF_SHARE * (pt[3 * k] as f64 - v)) as f32; 3]).collect() };
        let scale = vec![1.0; w * h];
        let variance = sd * sd / spp as f64;
        let bias = 0.1;
        let biased = against_samples(&with(bias), &pt, &moments, spp, &scale, w, h).unwrap();
        // the pixels flagged (the brighter, of the larger bias, the more often) are weighed apart
        assert!(biased.flagged.len() < t.len() / 50, "{} pixels flagged", biased.flagged.len());
        let kept: Vec<usize> = (0..t.len()).filter(|k| biased.flagged.binary_search(k).is_err()).collect();
        let bias2 = kept.iter().map(|&k| (bias * t[k]).powi(2)).sum::<f64>() / kept.len() as f64;
        assert!((biased.samples - variance).abs() < 0.05 * variance, "samples' error {:.3e} against {variance:.3e}", biased.samples);
        // a pixel is kept the more often the less its noise adds to its bias: the error measured
        // over the kept pixels is a little below their bias's square
        assert!(biased.corrected > 0.75 * bias2 && biased.corrected < 1.1 * bias2, "correction's error {:.3e} against {bias2:.3e}", biased.corrected);
        let expected = variance / (variance + bias2);
        assert!((biased.weight() - expected).abs() < 0.05, "weight {} against {expected}", biased.weight());
        assert!(biased.blended < biased.corrected.min(biased.samples));
        let exact = against_samples(&with(0.0), &pt, &moments, spp, &scale, w, h).unwrap();
        assert!(exact.weight() > 0.97, "an exact correction's weight {}", exact.weight());
        assert!(against_samples(&with(0.0), &pt, &moments, 1, &scale, w, h).is_none(), "one sample has no spread");
    }

    /// A correction exact on the image's left half and too bright by a quarter on its right (a
    /// kernel's bias where the light changes, none where it is flat), over a uniform truth: each
    /// pixel's weight follows the errors around it, near 1 on the left and near the weight of least
    /// error on the right, and the blend has a lower error than with one weight for the image,
    /// close to its prediction.
    #[test]
    fn each_pixel_is_weighed_by_the_errors_around_it() {
        let (w, h) = (128, 96);
        let t = vec![0.8; w * h];
        let (spp, sd, bias) = (64u32, 1.0f64, 0.2);
        let (pt, moments) = samples(&t, spp, sd, 17);
        let right = |k: usize| k % w >= w / 2;
        let corrected: Vec<f32> = t.iter().enumerate().flat_map(|(k, &v)| [(v + if right(k) { bias } else { 0.0 } + SELF_SHARE * (pt[3 * k] as f64 - v)) as f32; 3]).collect();
        let check = against_samples(&corrected, &pt, &moments, spp, &vec![1.0; w * h], w, h).unwrap();
        // away from the middle, where the windows hold one half only
        let mean_weight = |side: bool| {
            let ks: Vec<usize> = (0..w * h).filter(|&k| right(k) == side && (k % w).abs_diff(w / 2) > WEIGHT_RADIUS + 1 && check.flagged.binary_search(&k).is_err()).collect();
            ks.iter().map(|&k| check.weights[k] as f64).sum::<f64>() / ks.len() as f64
        };
        let variance = sd * sd / spp as f64;
        let least = variance / (variance + bias * bias);
        assert!(mean_weight(false) > 0.9, "exact half: mean weight {}", mean_weight(false));
        assert!((mean_weight(true) - least).abs() < 0.1, "biased half: mean weight {} against {least}", mean_weight(true));
        let blend = |weight: &dyn Fn(usize) -> f64| (0..w * h).map(|k| (weight(k) * corrected[3 * k] as f64 + (1.0 - weight(k)) * pt[3 * k] as f64 - t[k]).powi(2)).sum::<f64>() / (w * h) as f64;
        let (per_pixel, one) = (blend(&|k| check.weights[k] as f64), blend(&|_| check.weight()));
        assert!(per_pixel < 0.75 * one, "weights per pixel {per_pixel:.3e}, one weight {one:.3e}");
        assert!((check.blended / per_pixel - 1.0).abs() < 0.25, "predicted {:.3e} against {per_pixel:.3e}", check.blended);
        // too few samples to weigh each pixel: one weight, as before the flags
        let (few, few_moments) = samples(&t, OUTLIER_MIN_SPP - 1, sd, 17);
        let coarse = against_samples(&corrected, &few, &few_moments, OUTLIER_MIN_SPP - 1, &vec![1.0; w * h], w, h).unwrap();
        assert!(coarse.weights.iter().all(|&x| x == coarse.weight() as f32));
    }

    /// A correction exact but at a few pixels, where it is three times too bright (a kernel
    /// across a thin edge): those pixels are flagged and lean to the samples, the others keep the
    /// correction, the blend's error is far below the samples' and not much above its prediction,
    /// and few of the exact pixels are flagged.
    #[test]
    fn pixels_the_correction_failed_lean_to_the_samples() {
        let (w, h) = (128, 96);
        let t = truth(w, h);
        let (spp, sd) = (64u32, 0.2f64);
        let (pt, moments) = samples(&t, spp, sd, 13);
        let failed = |k: usize| k % 97 == 0;
        // exact but for its share of the samples' noise, as a fit over 5 × 5 pixels holds it
        let corrected: Vec<f32> = t.iter().enumerate().flat_map(|(k, &v)| [(if failed(k) { 3.0 * v } else { v + SELF_SHARE * (pt[3 * k] as f64 - v) }) as f32; 3]).collect();
        let scale = vec![1.0; w * h];
        let check = against_samples(&corrected, &pt, &moments, spp, &scale, w, h).unwrap();
        let (weights, predicted, flagged) = (&check.weights, check.blended, check.flagged.len());
        let failures = (0..w * h).filter(|&k| failed(k)).count();
        assert!((0..w * h).filter(|&k| failed(k)).all(|k| weights[k] < 0.1), "a failed pixel kept its weight");
        let false_alarms = flagged - failures;
        assert!(false_alarms < (w * h) / 100, "{false_alarms} exact pixels flagged");
        let blend = |weight: &dyn Fn(usize) -> f64| (0..w * h).map(|k| (weight(k) * corrected[3 * k] as f64 + (1.0 - weight(k)) * pt[3 * k] as f64 - t[k]).powi(2)).sum::<f64>() / (w * h) as f64;
        assert!(check.weight() > 0.9, "the exact pixels' weight {}", check.weight());
        let (per_pixel, samples) = (blend(&|k| weights[k] as f64), blend(&|_| 0.0));
        assert!(per_pixel < 0.2 * samples, "blend {per_pixel:.3e}, the samples {samples:.3e}");
        // the prediction is the samples' variance at the failed pixels and a little more
        assert!(predicted > 0.7 * per_pixel && predicted < 0.2 * samples, "predicted {predicted:.3e} against {per_pixel:.3e}");
    }
}
