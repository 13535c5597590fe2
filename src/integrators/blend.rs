//! Blending a timed render's photon passes with the path tracer's samples. Two estimates of a
//! layer with independent errors `a` (the passes') and `c` (the path tracer's) combine with the
//! weight `c / (a + c)` on the passes ([`allocation::blend_weight`]).
//!
//! The direct light takes one weight for the whole image: the passes' camera samples and the
//! path tracer's paths are both unbiased, and their errors differ by sample counts alone. The
//! indirect light takes a weight per pixel, from both errors measured in a window around it: a
//! density estimate's bias lies along edges, corners and silhouettes, where the window finds the
//! passes far from the path tracer's samples and hands the pixels to them, while elsewhere the
//! passes' smooth estimate keeps its weight ([`indirect_weights`]). Both errors are weighed per
//! pixel as the relative error weighs it.

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

/// Blend the path tracer's direct and indirect layers into the passes' (the passes' weights: one
/// for the direct light, one per pixel for the indirect light); the beauty is their sum again.
pub fn blend_rival(sum: &mut Film, pt: &Film, direct: f64, indirect: &[f32]) {
    if let (Some(theirs), Some(ours)) = (pt.layer("direct"), sum.layer_mut("direct")) {
        for (x, y) in ours.data.iter_mut().zip(&theirs.data) {
            *x = (direct * *x as f64 + (1.0 - direct) * *y as f64) as f32;
        }
    }
    if let (Some(theirs), Some(ours)) = (pt.layer("indirect"), sum.layer_mut("indirect")) {
        for ((x, y), &w) in ours.data.chunks_exact_mut(3).zip(theirs.data.chunks_exact(3)).zip(indirect) {
            for c in 0..3 {
                x[c] = w * x[c] + (1.0 - w) * y[c];
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
