//! Errors of `raysplat-bench pt --reference-spp`: how far an image is from its renderer's converged
//! image, and how far the two renderers' converged images are from each other, each net of the
//! references' own noise.
//!
//! A reference is two renders of other seeds, `h1` and `h2`; their mean is the reference `r`. The
//! relative MSE is `raysplat compare`'s, mean over pixels and R, G, B of `(t − r)² / (r² + 0.01)`,
//! with the denominator of one fixed image so that squared differences add: the noise of `r` adds
//! `E[(h1 − h2)²] / 4` per value to any image's squared difference from it, which is subtracted.

/// Added to `reference²` in the relative MSE (as `raysplat compare`).
const REL_MSE_EPS: f64 = 0.01;

/// Mean over all values of `(a − b)² / (w² + 0.01)` (RGB buffers of one length).
fn rel_mse_by(a: &[f32], b: &[f32], w: &[f32]) -> f64 {
    assert!(a.len() == b.len() && a.len() == w.len() && !a.is_empty(), "images of different sizes");
    let sum: f64 = a.iter().zip(b).zip(w).map(|((&a, &b), &w)| (a as f64 - b as f64).powi(2) / ((w as f64).powi(2) + REL_MSE_EPS)).sum();
    sum / a.len() as f64
}

fn mean(a: &[f32], b: &[f32]) -> Vec<f32> {
    a.iter().zip(b).map(|(a, b)| 0.5 * (a + b)).collect()
}

/// A renderer's converged image from two renders of other seeds.
pub struct Reference {
    pub half: [Vec<f32>; 2],
    /// Their mean.
    pub image: Vec<f32>,
}

impl Reference {
    pub fn new(h1: Vec<f32>, h2: Vec<f32>) -> Reference {
        let image = mean(&h1, &h2);
        Reference { half: [h1, h2], image }
    }

    /// The relative MSE the reference's own noise adds to a comparison against it, with
    /// denominators from `w`: a quarter of its halves' difference.
    fn noise_by(&self, w: &[f32]) -> f64 {
        rel_mse_by(&self.half[0], &self.half[1], w) / 4.0
    }

    /// The relative MSE of `test` (noise independent of the reference's) against the converged
    /// image: against the reference, less the reference's noise.
    pub fn error_of(&self, test: &[f32]) -> f64 {
        rel_mse_by(test, &self.image, &self.image) - self.noise_by(&self.image)
    }
}

/// How two renderers' references differ.
pub struct Between {
    /// Relative MSE of one reference against the other (denominators from their mean).
    pub raw: f64,
    /// The part of `raw` that is the two references' noise.
    pub noise: f64,
}

impl Between {
    pub fn new(a: &Reference, b: &Reference) -> Between {
        let w = mean(&a.image, &b.image);
        Between { raw: rel_mse_by(&a.image, &b.image, &w), noise: a.noise_by(&w) + b.noise_by(&w) }
    }

    /// The relative MSE between the renderers' converged images.
    pub fn net(&self) -> f64 {
        self.raw - self.noise
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic uniform numbers in [−1, 1) (a 64-bit LCG's high bits).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f32 {
            self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((self.0 >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
        }
    }

    fn image(n: usize) -> Vec<f32> {
        (0..n).map(|i| 0.2 + 0.6 * ((i * 37 % 101) as f32 / 101.0)).collect()
    }

    fn noisy(x: &[f32], sigma: f32, rng: &mut Lcg) -> Vec<f32> {
        x.iter().map(|v| v + sigma * rng.next()).collect()
    }

    #[test]
    fn error_of_a_noisy_image_is_its_noise_alone() {
        // uniform noise of half-width s has variance s²/3; the reference's is four times smaller
        let (n, s, r) = (200_000, 0.1f32, 0.05f32);
        let x = image(n);
        let mut rng = Lcg(7);
        let reference = Reference::new(noisy(&x, r, &mut rng), noisy(&x, r, &mut rng));
        let test = noisy(&x, s, &mut rng);
        let expected = rel_mse_by(&test, &x, &x);
        let got = reference.error_of(&test);
        assert!((got - expected).abs() < 0.03 * expected, "{got} vs {expected}");
        // without the correction, the reference's noise would show
        let raw = rel_mse_by(&test, &reference.image, &reference.image);
        assert!(raw - expected > 0.1 * expected, "{raw} vs {expected}");
    }

    #[test]
    fn between_recovers_the_difference_of_the_converged_images() {
        let n = 200_000;
        let x = image(n);
        let y: Vec<f32> = x.iter().enumerate().map(|(i, v)| v * if i % 2 == 0 { 1.02 } else { 0.99 }).collect();
        let mut rng = Lcg(11);
        let a = Reference::new(noisy(&x, 0.015, &mut rng), noisy(&x, 0.015, &mut rng));
        let b = Reference::new(noisy(&y, 0.02, &mut rng), noisy(&y, 0.02, &mut rng));
        let truth = rel_mse_by(&x, &y, &mean(&x, &y));
        let between = Between::new(&a, &b);
        assert!(between.noise > truth, "the noise dominates the raw figure here");
        assert!((between.net() - truth).abs() < 0.1 * truth, "{} vs {truth}", between.net());
        // the same images: nothing left after the noise
        let c = Reference::new(noisy(&x, 0.02, &mut rng), noisy(&x, 0.02, &mut rng));
        assert!(Between::new(&a, &c).net().abs() < 0.1 * truth);
    }
}
