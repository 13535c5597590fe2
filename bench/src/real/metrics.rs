//! The real-scene table's errors of a test image against a reference, each less the reference's
//! own noise (from its two independent halves A and B, see [`Measure::noise`]):
//!
//! - **relative MSE**: `mean((t − r)² / (r² + 0.01))` over pixels and RGB, as `raysplat compare`
//!   prints it. Its fixed 0.01 makes it plain MSE (× 100) on a dark image: scaling both images by
//!   k scales it by up to k².
//! - **relative MSE, relative ε**: `mean((t − r)² / (r² + (0.1·m)²))`, `m` the reference image's mean
//!   (RGB). Scaling both images by k leaves it unchanged (exposure-independent), and on an image of
//!   mean 1 it is the relative MSE.
//! - **scaled MSE**: `mean((t − r)²) / m²`, the MSE of both images scaled to a mean of 1:
//!   exposure-independent too, and the plain MSE that `auto`'s time split minimises, up to the
//!   constant m². Bright pixels (a light in view) weigh the most in it.

/// The ε of the relative ε error, relative to the reference's mean: `(0.1·m)²` is `0.01` at m = 1.
pub const RELATIVE_EPS: f64 = 0.1;
/// The fixed ε of the relative MSE (`raysplat compare`).
pub const FIXED_EPS: f64 = 0.01;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Measure {
    /// `(t − r)² / (r² + 0.01)`.
    Relative,
    /// `(t − r)² / (r² + (0.1·m)²)`.
    RelativeEps,
    /// `(t − r)² / m²`.
    Scaled,
}

impl Measure {
    pub const ALL: [Measure; 3] = [Measure::Relative, Measure::RelativeEps, Measure::Scaled];

    /// The weight of a squared difference at a reference value `r`, `m` the reference's mean.
    fn weight(self, r: f64, m: f64) -> f64 {
        match self {
            Measure::Relative => 1.0 / (r * r + FIXED_EPS),
            Measure::RelativeEps => 1.0 / (r * r + (RELATIVE_EPS * m).powi(2)),
            Measure::Scaled => 1.0 / (m * m),
        }
    }

    /// The error of `test` against `reference` (both RGB, the same length), `m` the mean of the
    /// reference's beauty image (the layers of an image share it). A non-finite test value makes it
    /// infinite, as in `raysplat compare`.
    pub fn error(self, test: &[f32], reference: &[f32], m: f64) -> f64 {
        assert_eq!(test.len(), reference.len(), "images of different sizes");
        self.mean_weighted(test.iter().zip(reference).map(|(&t, &r)| ((t as f64 - r as f64).powi(2), r as f64)), m)
    }

    /// The reference's own error against the converged image, from its halves `a` and `b`
    /// (`reference` their mean): `(a − b)²/4` is the variance of the mean of two independent
    /// halves, so a test image independent of the reference has, in expectation,
    /// `error(test, reference) = error(test, converged) + noise`.
    pub fn noise(self, a: &[f32], b: &[f32], reference: &[f32], m: f64) -> f64 {
        assert!(a.len() == b.len() && a.len() == reference.len(), "images of different sizes");
        // a non-finite reference pixel is the reference's fault: leave it out of its noise
        let terms = a.iter().zip(b).zip(reference).map(|((&x, &y), &r)| ((x as f64 - y as f64).powi(2) / 4.0, r as f64)).filter(|(d, r)| d.is_finite() && r.is_finite());
        self.mean_weighted(terms, m)
    }

    fn mean_weighted(self, terms: impl Iterator<Item = (f64, f64)>, m: f64) -> f64 {
        let (mut sum, mut n) = (0.0, 0usize);
        for (d2, r) in terms {
            sum += d2 * self.weight(r, m);
            n += 1;
        }
        if n == 0 {
            0.0
        } else if sum.is_nan() {
            f64::INFINITY
        } else {
            sum / n as f64
        }
    }
}

/// The mean of an RGB image over pixels and channels (non-finite values left out).
pub fn mean(rgb: &[f32]) -> f64 {
    let (sum, n) = rgb.iter().filter(|v| v.is_finite()).fold((0.0, 0usize), |(s, n), &v| (s + v as f64, n + 1));
    if n == 0 {
        0.0
    } else {
        sum / n as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reference-like image: bright, dark and black pixels.
    fn image() -> Vec<f32> {
        (0..300).map(|i| ((i * 37 % 101) as f32 / 40.0).powi(2) * if i % 7 == 0 { 0.0 } else { 1.0 }).collect()
    }

    fn noisy(reference: &[f32], amount: f32) -> Vec<f32> {
        reference.iter().enumerate().map(|(i, &r)| (r + amount * (((i * 7919) % 13) as f32 - 6.0) / 6.0).max(0.0)).collect()
    }

    #[test]
    fn an_image_against_itself_has_no_error() {
        let r = image();
        for m in Measure::ALL {
            assert_eq!(m.error(&r, &r, mean(&r)), 0.0, "{m:?}");
        }
    }

    /// Scaling both images by k (an exposure) leaves the relative ε and scaled errors as they are
    /// and changes the relative MSE with its fixed ε (dark images: about k² times).
    #[test]
    fn the_exposure_independent_errors_do_not_change_with_exposure() {
        let r = image();
        let t = noisy(&r, 0.3);
        let before: Vec<f64> = Measure::ALL.iter().map(|m| m.error(&t, &r, mean(&r))).collect();
        for k in [0.01f32, 0.5, 40.0] {
            let (rk, tk): (Vec<f32>, Vec<f32>) = (r.iter().map(|v| v * k).collect(), t.iter().map(|v| v * k).collect());
            let m = mean(&rk);
            for (i, measure) in Measure::ALL.iter().enumerate() {
                let after = measure.error(&tk, &rk, m);
                let ratio = after / before[i];
                if *measure == Measure::Relative {
                    assert!((ratio - 1.0).abs() > 0.2, "relative MSE at exposure {k}: ratio {ratio}");
                } else {
                    assert!((ratio - 1.0).abs() < 1e-5, "{measure:?} at exposure {k}: ratio {ratio}");
                }
            }
        }
        // on a dark image the fixed ε dominates: the relative MSE is nearly plain MSE / 0.01
        let (rk, tk): (Vec<f32>, Vec<f32>) = (r.iter().map(|v| v * 0.001).collect(), t.iter().map(|v| v * 0.001).collect());
        let plain = tk.iter().zip(&rk).map(|(a, b)| ((a - b) as f64).powi(2)).sum::<f64>() / rk.len() as f64;
        let rel = Measure::Relative.error(&tk, &rk, mean(&rk));
        assert!((rel / (plain / FIXED_EPS) - 1.0).abs() < 0.01, "dark image: relative MSE {rel}, MSE / 0.01 {}", plain / FIXED_EPS);
    }

    /// Hand-computed figures: reference (1, 0, 3) of mean 4/3, test (2, 1, 3).
    #[test]
    fn known_numbers() {
        let (r, t) = ([1.0f32, 0.0, 3.0], [2.0f32, 1.0, 3.0]);
        let m = mean(&r);
        assert!((m - 4.0 / 3.0).abs() < 1e-12);
        let eps = (0.1 * 4.0 / 3.0f64).powi(2); // 0.017777…
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12 * b.abs().max(1.0);
        assert!(close(Measure::RelativeEps.error(&t, &r, m), (1.0 / (1.0 + eps) + 1.0 / eps + 0.0) / 3.0));
        assert!(close(Measure::Relative.error(&t, &r, m), (1.0 / 1.01 + 1.0 / 0.01) / 3.0));
        assert!(close(Measure::Scaled.error(&t, &r, m), (2.0 / 3.0) / (16.0 / 9.0)));
        // the relative MSE agrees with `raysplat compare`'s
        let compare = raysplat::image::compare(&t, &r).rel_mse;
        assert!(close(Measure::Relative.error(&t, &r, m), compare), "{compare}");
    }

    #[test]
    fn a_nan_pixel_makes_the_error_infinite() {
        let r = image();
        let mut t = r.clone();
        t[5] = f32::NAN;
        for m in Measure::ALL {
            assert_eq!(m.error(&t, &r, mean(&r)), f64::INFINITY, "{m:?}");
        }
    }

    /// The noise from two halves is a quarter of their squared difference: halves r ± d give d²
    /// (weighted as the error of a test image r + d is).
    #[test]
    fn the_noise_of_two_halves() {
        let r = image();
        let d = 0.05f32;
        let (a, b): (Vec<f32>, Vec<f32>) = (r.iter().map(|v| v + d).collect(), r.iter().map(|v| v - d).collect());
        let t: Vec<f32> = r.iter().map(|v| v + d).collect();
        for m in Measure::ALL {
            let (noise, error) = (m.noise(&a, &b, &r, mean(&r)), m.error(&t, &r, mean(&r)));
            assert!((noise / error - 1.0).abs() < 1e-3, "{m:?}: noise {noise}, error {error}");
        }
    }
}
