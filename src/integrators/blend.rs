//! Blending a timed render's photon passes with the path tracer's samples. Two estimates of a
//! layer with independent errors `a` (the passes') and `c` (the path tracer's) combine with the
//! weight `c / (a + c)` on the passes ([`allocation::blend_weight`]).
//!
//! The direct light takes a weight per pixel, by both estimates' variances around it: both are
//! unbiased, but how their variances per sample compare changes across the image. On a surface
//! the passes' camera samples, with several light samples each, are the less noisy; along the
//! edge of a light in view both are the pixel's anti-aliasing, alike per sample, and the more
//! samples win ([`direct_weights`]). The indirect light, when the path tracer has too few samples
//! for [`super::regression`] to correct the passes' by them, takes a weight per pixel, from both
//! errors measured in a window around it: a density estimate's bias lies along edges, corners
//! and silhouettes, where the window finds the passes far from the path tracer's samples and hands
//! the pixels to them, while elsewhere the passes' smooth estimate keeps its weight
//! ([`indirect_weights`]). Both errors are weighed per pixel as the relative error weighs it.

use super::allocation::{self, lum};
use crate::image::Film;

/// Half the side of the window (9 × 9 pixels) the indirect light's errors are averaged over: wide
/// enough that the path tracer's one-pair variance estimates average (81 of them, about 16 %
/// relative noise), narrow enough to follow a bias along an edge.
pub const WINDOW_RADIUS: usize = 4;

/// Per-pixel weights of the passes' indirect light and the predicted MSE of the blend (mean over
/// pixels). `passes` and `pt` are the two indirect layers (RGB), `pair` one path's variance per
/// pixel (the pilot's pair, `[direct, indirect]`), `spp` the path tracer's samples per pixel,
/// `scale` the per-pixel factor of the relative error (its square weighs squared errors).
///
/// The passes' error around a pixel is the square of their mean difference to the path tracer's
/// samples over 3×3 pixels, less the samples' noise in that mean, averaged over the window: a
/// bias (and the passes' own noise, which is smooth over a few pixels) stays in a 3×3 mean, while
/// the path tracer's noise, independent from pixel to pixel, falls ninefold. The mean of squared
/// differences less the samples' variance would measure the same in expectation, but with few
/// path-traced samples, rare bright paths and a variance known from one pair of paths per pixel,
/// the error of that subtraction would dominate it.
pub fn indirect_weights(passes: &[f32], pt: &[f32], pair: &[[f32; 2]], spp: u32, scale: &[f32], w: usize, h: usize) -> Option<(Vec<f32>, f64)> {
    let n = w * h;
    if passes.len() != 3 * n || pt.len() != 3 * n || pair.len() != n || scale.len() != n || n == 0 {
        return None;
    }
    let k2 = |p: usize| (scale[p] as f64).powi(2);
    let diff: Vec<f64> = (0..n).map(|p| scale[p] as f64 * (lum(&passes[3 * p..3 * p + 3]) - lum(&pt[3 * p..3 * p + 3]))).collect();
    let noise: Vec<f64> = (0..n).map(|p| k2(p) * pair[p][1] as f64 / spp.max(1) as f64).collect();
    // the squared mean difference over 3x3 pixels, less the path tracer's noise of that mean
    let (m, m_noise) = (window_means(&diff, w, h, 1), window_means(&noise, w, h, 1));
    let mean_noise: Vec<f64> = (0..n).map(|p| m_noise[p] / window_count(p % w, p / w, w, h, 1)).collect();
    let b2: Vec<f64> = (0..n).map(|p| m[p] * m[p] - mean_noise[p]).collect();
    let (d, c) = (trimmed_window_means(&b2, w, h, WINDOW_RADIUS, TRIMMED), window_means(&noise, w, h, WINDOW_RADIUS));
    let threshold = window_means(&mean_noise, w, h, WINDOW_RADIUS);
    let mut predicted = 0.0;
    let weights = (0..n)
        .map(|p| {
            // the passes' error counts beyond its own estimate's noise only (a soft threshold)
            let (a, c) = ((d[p] - NOISE_MARGIN * threshold[p]).max(0.0), c[p]);
            let weight = allocation::blend_weight(a, c);
            predicted += (weight * weight * a + (1.0 - weight) * (1.0 - weight) * c) / n as f64;
            weight as f32
        })
        .collect();
    Some((weights, predicted))
}

/// The multiple of the path tracer's noise in a 3×3 mean that a window's measured error of the
/// passes must exceed to count, and is lowered by: with few path-traced samples per pixel, whose
/// rare bright paths one pair of paths per pixel does not show, the measured error is otherwise
/// mostly the path tracer's own.
const NOISE_MARGIN: f64 = 2.0;

/// The largest values [`indirect_weights`] leaves out of a window's mean of squared 3×3 means: one
/// rare bright path of the path tracer's is in nine of them, and left in, it would hand the window
/// to the estimate that carries it.
const TRIMMED: usize = 12;

/// Each pixel's mean of `values` over the window of `(2r + 1)²` pixels around it, clipped at the
/// image's edges, without its `drop` largest values (all kept in a window of at most `2 drop`).
pub fn trimmed_window_means(values: &[f64], w: usize, h: usize, r: usize, drop: usize) -> Vec<f64> {
    let mut window = Vec::with_capacity((2 * r + 1) * (2 * r + 1));
    let mut out = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            window.clear();
            for j in y.saturating_sub(r)..(y + r + 1).min(h) {
                window.extend_from_slice(&values[j * w + x.saturating_sub(r)..j * w + (x + r + 1).min(w)]);
            }
            let keep = if window.len() > 2 * drop { window.len() - drop } else { window.len() };
            if keep < window.len() {
                window.select_nth_unstable_by(keep, |a, b| a.total_cmp(b));
            }
            out[y * w + x] = window[..keep].iter().sum::<f64>() / keep as f64;
        }
    }
    out
}

/// Pixels in the window of `(2r + 1)²` around `(x, y)` clipped at the image's edges.
fn window_count(x: usize, y: usize, w: usize, h: usize, r: usize) -> f64 {
    (((x + r + 1).min(w) - x.saturating_sub(r)) * ((y + r + 1).min(h) - y.saturating_sub(r))) as f64
}

/// Each pixel's mean of `values` (`w` × `h`, row by row) over the window of `(2r + 1)²` pixels
/// around it, clipped at the image's edges (separable running sums).
pub fn window_means(values: &[f64], w: usize, h: usize, r: usize) -> Vec<f64> {
    let box1 = |get: &dyn Fn(usize) -> f64, len: usize| -> Vec<(f64, f64)> {
        let mut prefix = vec![0.0; len + 1];
        for i in 0..len {
            prefix[i + 1] = prefix[i] + get(i);
        }
        (0..len).map(|i| (prefix[(i + r + 1).min(len)] - prefix[i.saturating_sub(r)], ((i + r + 1).min(len) - i.saturating_sub(r)) as f64)).collect()
    };
    // rows: sums and counts; then columns of both
    let mut rows = vec![(0.0, 0.0); w * h];
    for y in 0..h {
        for (x, s) in box1(&|x| values[y * w + x], w).into_iter().enumerate() {
            rows[y * w + x] = s;
        }
    }
    let mut out = vec![0.0; w * h];
    for x in 0..w {
        let sums = box1(&|y| rows[y * w + x].0, h);
        let counts = box1(&|y| rows[y * w + x].1, h);
        for y in 0..h {
            out[y * w + x] = sums[y].0 / counts[y].0.max(1.0);
        }
    }
    out
}

/// Per-pixel weights of the passes' direct light: `c / (a + c)` of the variances of both means,
/// `a` the passes' (`passes`, per pixel) and `c` the path tracer's (from its `moments`, the layer
/// [`super::pt::DIRECT_MOMENTS_LAYER`] of `spp` samples), each the mean over the window around
/// the pixel ([`DIRECT_WINDOW_RADIUS`]) without the pixel itself. Leaving the pixel out keeps its
/// weight independent of its own samples: a weight drawn from them would lean on whichever
/// estimate happened to miss a small bright light (no spread, no variance) and darken the light's
/// edges. `fallback` where neither varies. `None` when the sizes differ or the path tracer has
/// fewer than [`DIRECT_MIN_SPP`] samples.
pub fn direct_weights(passes: &[f32], moments: &[f32], spp: u32, w: usize, h: usize, fallback: f64) -> Option<Vec<f32>> {
    let n = w * h;
    if passes.len() != n || moments.len() != 2 * n || spp < DIRECT_MIN_SPP || n == 0 {
        return None;
    }
    let a: Vec<f64> = passes.iter().map(|&v| v.max(0.0) as f64).collect();
    let c: Vec<f64> = moments.chunks_exact(2).map(|m| (m[1] as f64 - (m[0] as f64).powi(2)).max(0.0) / (spp - 1) as f64).collect();
    let (a, c) = (neighbours_means(&a, w, h), neighbours_means(&c, w, h));
    Some(a.iter().zip(&c).map(|(&a, &c)| if a + c > 0.0 { allocation::blend_weight(a, c) as f32 } else { fallback as f32 }).collect())
}

/// The fewest path-traced samples per pixel whose spread [`direct_weights`] trusts. The pilot's
/// pair mostly misses a small light's edge, so a window's variance from it is mostly too low, and
/// a pixel where one sample did hit takes the light's value at the weight that low variance gave:
/// on the repository's concave-corners box at 1 s one such pixel beside the light made auto's
/// direct light 16 times the passes' own error (one weight for the image: 7 times).
pub const DIRECT_MIN_SPP: u32 = 4;

/// Half the side of the window (17 × 17 pixels) the direct light's variances are averaged over.
/// A light's edge in view is a line one pixel wide whose pixels a few camera samples mostly miss:
/// a narrow window holds too few of them to compare the two estimates' spread (on the repository's
/// Cornell box at 4 s the direct light's relative MSE was 2.4× that of one weight for the image
/// with 3×3 windows, 0.47× with 5×5, 0.24× with 9×9 and 0.20× with 17×17).
pub const DIRECT_WINDOW_RADIUS: usize = 8;

/// Each pixel's mean of `values` over the window of [`DIRECT_WINDOW_RADIUS`] around it without
/// itself, clipped at the image's edges (its own value in a 1 × 1 image).
fn neighbours_means(values: &[f64], w: usize, h: usize) -> Vec<f64> {
    let r = DIRECT_WINDOW_RADIUS;
    let means = window_means(values, w, h, r);
    (0..w * h)
        .map(|p| {
            let count = window_count(p % w, p / w, w, h, r);
            if count > 1.0 { (means[p] * count - values[p]) / (count - 1.0) } else { values[p] }
        })
        .collect()
}

/// Blend the path tracer's direct and indirect layers into the passes' by the passes' weights per
/// pixel; the beauty is their sum again.
pub fn blend_rival(sum: &mut Film, pt: &Film, direct: &[f32], indirect: &[f32]) {
    for (name, weights) in [("direct", direct), ("indirect", indirect)] {
        if let (Some(theirs), Some(ours)) = (pt.layer(name), sum.layer_mut(name)) {
            for ((x, y), &w) in ours.data.chunks_exact_mut(3).zip(theirs.data.chunks_exact(3)).zip(weights) {
                for c in 0..3 {
                    x[c] = w * x[c] + (1.0 - w) * y[c];
                }
            }
        }
    }
    let (Some(d), Some(i)) = (sum.layer("direct").map(|l| l.data.clone()), sum.layer("indirect").map(|l| l.data.clone())) else { return };
    if let Some(beauty) = sum.layer_mut("") {
        for (k, px) in beauty.data.chunks_exact_mut(4).enumerate() {
            for c in 0..3 {
                px[c] = d[3 * k + c] + i[3 * k + c];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The edge of a small bright light in view: every pixel covered by a twentieth, its samples
    /// `12.5` or `0`, the passes with 4 samples per pixel, the path tracer with 12. Per sample
    /// both are the pixel's anti-aliasing alike, and the weights come out near the sample counts'
    /// 4 / 16 where one weight for the image, set by light samples elsewhere, would favour the
    /// passes. The blend is unbiased: its mean over the pixels is the light's share within its
    /// noise. With each pixel's weight from its own samples' variance it is too dark (a pixel
    /// whose samples all missed the light has no spread and takes all the weight).
    #[test]
    fn a_lights_edge_blends_by_sample_counts_and_stays_unbiased() {
        let (w, h) = (64, 64);
        let n = w * h;
        let (value, cover) = (12.5f64, 0.05f64);
        let mut rng = crate::sampling::Rng::new(7, 0);
        let mut draw = |count: u32| -> (f64, f64) {
            let hits: Vec<f64> = (0..count).map(|_| if (rng.next_f32() as f64) < cover { value } else { 0.0 }).collect();
            let mean = hits.iter().sum::<f64>() / count as f64;
            (mean, hits.iter().map(|x| x * x).sum::<f64>() / count as f64)
        };
        let (ours, theirs): (Vec<(f64, f64)>, Vec<(f64, f64)>) = (0..n).map(|_| (draw(4), draw(12))).unzip();
        // the passes' layer: the variance of their mean of 4; the path tracer's: its moments
        let passes: Vec<f32> = ours.iter().map(|&(m, m2)| ((m2 - m * m) * 4.0 / 3.0 / 4.0) as f32).collect();
        let moments: Vec<f32> = theirs.iter().flat_map(|&(m, m2)| [m as f32, m2 as f32]).collect();
        let weights = direct_weights(&passes, &moments, 12, w, h, 0.8).unwrap();
        let mean_weight = weights.iter().map(|&x| x as f64).sum::<f64>() / n as f64;
        assert!((mean_weight - 0.25).abs() < 0.05, "mean weight of the passes {mean_weight}");
        let blend = |wt: &dyn Fn(usize) -> f64| (0..n).map(|p| wt(p) * ours[p].0 + (1.0 - wt(p)) * theirs[p].0).sum::<f64>() / n as f64;
        let truth = value * cover;
        // a pixel's blend has a variance of about value² cover (1 − cover) / 16
        let tolerance = 4.0 * (value * value * cover * (1.0 - cover) / 16.0 / n as f64).sqrt();
        let unbiased = blend(&|p| weights[p] as f64);
        assert!((unbiased - truth).abs() < tolerance, "blend's mean {unbiased} against {truth} ± {tolerance}");
        let own = |p: usize| {
            let c = (theirs[p].1 - theirs[p].0.powi(2)).max(0.0) / 11.0;
            allocation::blend_weight(passes[p] as f64, c)
        };
        let darker = blend(&own);
        assert!(darker < truth - tolerance, "with each pixel's own variances {darker} against {truth} ± {tolerance}");
    }

    /// A pixel's direct weight does not depend on its own variances, only on its neighbours'.
    #[test]
    fn a_direct_weight_leaves_its_own_pixel_out() {
        let (w, h) = (9, 7);
        let n = w * h;
        let passes: Vec<f32> = (0..n).map(|k| 0.1 + (k % 5) as f32 * 0.05).collect();
        let moments: Vec<f32> = (0..n).flat_map(|k| [1.0, 1.0 + (k % 3) as f32 * 0.2]).collect();
        let before = direct_weights(&passes, &moments, 8, w, h, 0.5).unwrap();
        let (mut p2, mut m2) = (passes.clone(), moments.clone());
        let centre = 3 * w + 4;
        p2[centre] = 100.0;
        m2[2 * centre + 1] = 50.0;
        let after = direct_weights(&p2, &m2, 8, w, h, 0.5).unwrap();
        assert_eq!(before[centre], after[centre]);
        assert_ne!(before[centre + 1], after[centre + 1]);
        // neither estimate varies: the fallback
        let flat = direct_weights(&vec![0.0; n], &vec![1.0; 2 * n], 8, w, h, 0.5).unwrap();
        assert!(flat.iter().all(|&x| x == 0.5));
        // too few path-traced samples to trust their spread: one weight for the image
        assert!(direct_weights(&passes, &moments, DIRECT_MIN_SPP - 1, w, h, 0.5).is_none());
    }

    /// The windowed mean is the brute-force mean over the clipped window.
    #[test]
    fn window_means_are_the_clipped_windows_means() {
        let (w, h, r) = (13, 7, 2);
        let values: Vec<f64> = (0..w * h).map(|k| ((k * 37 % 11) as f64).sin()).collect();
        let got = window_means(&values, w, h, r);
        for y in 0..h {
            for x in 0..w {
                let (ys, xs) = (y.saturating_sub(r)..(y + r + 1).min(h), x.saturating_sub(r)..(x + r + 1).min(w));
                let v = &values;
                let cells: Vec<f64> = ys.flat_map(|j| xs.clone().map(move |i| v[j * w + i])).collect();
                let want = cells.iter().sum::<f64>() / cells.len() as f64;
                assert!((got[y * w + x] - want).abs() < 1e-12, "({x}, {y}): {} against {want}", got[y * w + x]);
            }
        }
    }

    /// One path-traced pixel far off (a rare bright path) among exact ones does not take its
    /// neighbourhood from exact passes: its nine 3×3 means are left out of each window's mean,
    /// while without the trimming they would have set the pixel's weight to about 0.02.
    #[test]
    fn a_rare_bright_path_keeps_the_passes_weight() {
        let (w, h) = (32, 32);
        let n = w * h;
        let passes = vec![1.0f32; 3 * n];
        let mut pt = passes.clone();
        let spike = 16 * w + 16;
        pt[3 * spike..3 * spike + 3].fill(30.0);
        let pair = vec![[0.0f32, 0.16]; n];
        let (weights, _) = indirect_weights(&passes, &pt, &pair, 16, &vec![1.0f32; n], w, h).unwrap();
        let lowest = weights.iter().cloned().fold(1.0f32, f32::min);
        assert!(lowest > 0.9, "lowest weight of the passes {lowest}");
        let diff: Vec<f64> = (0..n).map(|p| (passes[3 * p] - pt[3 * p]) as f64).collect();
        let m = window_means(&diff, w, h, 1);
        let untrimmed = window_means(&m.iter().map(|x| x * x).collect::<Vec<_>>(), w, h, WINDOW_RADIUS)[spike];
        assert!(allocation::blend_weight(untrimmed, 0.01) < 0.05, "without trimming: error {untrimmed}");
    }

    /// The trimmed mean is the brute-force mean of the window's values without its largest.
    #[test]
    fn trimmed_window_means_leave_out_the_largest() {
        let (w, h, r, drop) = (11, 9, 2, 3);
        let values: Vec<f64> = (0..w * h).map(|k| ((k * 53 % 17) as f64).cos()).collect();
        let got = trimmed_window_means(&values, w, h, r, drop);
        for y in 0..h {
            for x in 0..w {
                let mut cells: Vec<f64> = (y.saturating_sub(r)..(y + r + 1).min(h)).flat_map(|j| (x.saturating_sub(r)..(x + r + 1).min(w)).map(move |i| (j, i))).map(|(j, i)| values[j * w + i]).collect();
                cells.sort_by(|a, b| a.total_cmp(b));
                let keep = if cells.len() > 2 * drop { cells.len() - drop } else { cells.len() };
                let want = cells[..keep].iter().sum::<f64>() / keep as f64;
                assert!((got[y * w + x] - want).abs() < 1e-12, "({x}, {y})");
            }
        }
    }

    /// Passes exact on the left half of the image and off by a bias far above the path tracer's
    /// noise on the right: the per-pixel weights keep the passes on the left and the path tracer on
    /// the right, and the blend's error is below both the better single estimate's and the one
    /// image-wide weight's, as predicted.
    #[test]
    fn a_bias_in_one_region_hands_that_region_to_the_path_tracer() {
        let (w, h) = (64, 32);
        let n = w * h;
        let truth = 1.0f32;
        let mut rng = crate::sampling::Rng::new(3, 0);
        // the path tracer: 16 samples of variance 0.16 (noise 0.01 per pixel)
        let (spp, var) = (16u32, 0.16f32);
        let gauss = |rng: &mut crate::sampling::Rng| -> f32 {
            let (u, v) = (rng.next_f32().max(1e-7), rng.next_f32());
            (-2.0 * u.ln()).sqrt() * (std::f32::consts::TAU * v).cos()
        };
        let pt: Vec<f32> = (0..n).flat_map(|_| [truth + (var / spp as f32).sqrt() * gauss(&mut rng); 3]).collect();
        let pair: Vec<[f32; 2]> = (0..n)
            .map(|_| {
                let (a, b) = (var.sqrt() * gauss(&mut rng), var.sqrt() * gauss(&mut rng));
                [0.0, 0.5 * (a - b).powi(2)]
            })
            .collect();
        let passes: Vec<f32> = (0..n).flat_map(|p| [if p % w < w / 2 { truth } else { truth + 0.3 }; 3]).collect();
        let scale = vec![1.0f32; n];
        let (a, c) = (passes.chunks_exact(3).map(|p| ((p[0] - truth) as f64).powi(2)).sum::<f64>() / n as f64, (var / spp as f32) as f64);
        let (weights, predicted) = indirect_weights(&passes, &pt, &pair, spp, &scale, w, h).unwrap();
        let row = |x: usize| (0..h).map(|y| weights[y * w + x] as f64).sum::<f64>() / h as f64;
        assert!(row(5) > 0.85 && row(w - 6) < 0.15, "weights {} on the left, {} on the right", row(5), row(w - 6));
        let mse = |img: &[f32]| img.chunks_exact(3).map(|c| ((c[0] - truth) as f64).powi(2)).sum::<f64>() / n as f64;
        let blend = |wt: &dyn Fn(usize) -> f32| -> Vec<f32> { (0..3 * n).map(|k| wt(k / 3) * passes[k] + (1.0 - wt(k / 3)) * pt[k]).collect() };
        let local = mse(&blend(&|p| weights[p]));
        let global = mse(&blend(&|_| allocation::blend_weight(a, c) as f32));
        assert!(local < 0.7 * global && local < 0.6 * c.min(a), "blend per pixel {local:.2e}, one weight {global:.2e}, passes {a:.2e}, path tracer {c:.2e}");
        assert!((predicted / local - 1.0).abs() < 0.3, "predicted {predicted:.2e}, measured {local:.2e}");
    }
}
