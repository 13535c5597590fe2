//! How a photon method spends a time budget (`--time`): between photon passes (new photons and
//! eye samples: they lower the indirect light's noise) and camera samples that only add direct
//! light (an eye pass without eye samples and without photons: cheap, it lowers the direct light's
//! and the anti-aliasing's noise), from figures the first passes measured.
//!
//! The image's expected error is modelled as `v_d / N + V_i / P` (plus a bias no sample count
//! removes): `N` camera samples per pixel of direct light in all, of variance `v_d` each (the
//! mean over pixels of the luminance variance of one camera sample's estimate, measured from the
//! spread of each pixel's camera samples), and `P` photon passes of indirect light, of variance
//! `V_i` each (half the mean squared luminance difference of two passes' indirect layers). The
//! error is plain MSE, not relative: scaling the image scales every term alike, so the choice
//! does not depend on the exposure (it minimises the error of images scaled to a common mean).

/// What the first passes measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Figures {
    /// Seconds of a photon pass beside its camera samples (light pass, density estimation, film).
    pub pass_fixed: f64,
    /// Seconds of one camera sample per pixel of the whole image (the eye pass's time over its
    /// camera samples per pixel).
    pub per_camera_sample: f64,
    /// Camera samples per pixel a photon pass takes.
    pub pass_camera_samples: u32,
    /// `v_d`: variance of one camera sample's direct-light estimate, mean over pixels.
    pub direct_variance: f64,
    /// `V_i`: variance of one pass's indirect light, mean over pixels (`None` before two passes).
    pub indirect_variance: Option<f64>,
}

impl Figures {
    /// Seconds of one photon pass.
    pub fn pass_seconds(&self) -> f64 {
        self.pass_fixed + self.per_camera_sample * self.pass_camera_samples as f64
    }

    /// Predicted MSE of `passes` photon passes and `extra` direct-only camera samples per pixel
    /// (the bias aside); `None` without the indirect variance.
    pub fn predicted(&self, passes: u32, extra: u64) -> Option<f64> {
        let n = passes as u64 * self.pass_camera_samples as u64 + extra;
        Some(self.direct_variance / n.max(1) as f64 + self.indirect_variance? / passes.max(1) as f64)
    }
}

/// The next step of a timed render.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    /// Another photon pass.
    PhotonPass,
    /// This many direct-only camera samples per pixel, then stop.
    DirectSamples(u32),
    /// Nothing fits in the time left.
    Stop,
}

/// Largest number of direct-only camera samples per pixel one step takes.
pub const MAX_DIRECT_SAMPLES: u32 = 4096;
/// Share of the time left that direct-only samples are planned for (their cost per sample is the
/// photon passes' eye pass's, which also made eye samples: a margin either way).
const DIRECT_MARGIN: f64 = 0.9;

/// The step after `passes` photon passes and `extra` direct-only camera samples per pixel, with
/// `left` seconds left: the split of the time left between photon passes and direct-only samples
/// of the lowest predicted error; while the indirect variance is unknown, a second photon pass if
/// at least two more fit (to measure it), else direct-only samples for the rest.
pub fn next_step(f: &Figures, passes: u32, extra: u64, left: f64) -> Step {
    let pass = f.pass_seconds();
    let direct = |t: f64| {
        if f.per_camera_sample <= 0.0 {
            return 0;
        }
        (t * DIRECT_MARGIN / f.per_camera_sample).floor().min(MAX_DIRECT_SAMPLES as f64) as u32
    };
    let step = |more: u32| {
        if more > 0 {
            return Step::PhotonPass;
        }
        match direct(left) {
            0 => Step::Stop,
            n => Step::DirectSamples(n),
        }
    };
    if f.indirect_variance.is_none() {
        return step(if left >= 2.0 * pass { 1 } else { 0 });
    }
    let most = if pass > 0.0 { (left / pass).floor().min(1e6) as u32 } else { 0 };
    let mut best = (f64::INFINITY, 0u32);
    for more in 0..=most {
        let d = direct(left - more as f64 * pass) as u64;
        let e = f.predicted(passes + more, extra + d).unwrap_or(f64::INFINITY);
        if e < best.0 {
            best = (e, more);
        }
    }
    step(best.1)
}

/// Mean over pixels of half the squared luminance difference of two independent estimates `a` and
/// `b` (RGB triples): the variance of one of them, mean over pixels.
pub fn variance_of_pair(a: &[f32], b: &[f32]) -> f64 {
    let lum = |c: &[f32]| 0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64;
    let n = a.len() / 3;
    if n == 0 {
        return 0.0;
    }
    a.chunks_exact(3).zip(b.chunks_exact(3)).map(|(x, y)| 0.5 * (lum(x) - lum(y)).powi(2)).sum::<f64>() / n as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn figures(direct_variance: f64, indirect_variance: Option<f64>) -> Figures {
        Figures { pass_fixed: 1.0, per_camera_sample: 0.01, pass_camera_samples: 4, direct_variance, indirect_variance }
    }

    /// The total of direct-only camera samples a plan takes, following its steps with `left`
    /// seconds after two passes.
    fn direct_samples(f: &Figures, mut left: f64) -> u64 {
        let (mut passes, extra) = (2, 0u64);
        loop {
            match next_step(f, passes, extra, left) {
                Step::PhotonPass => {
                    passes += 1;
                    left -= f.pass_seconds();
                }
                Step::DirectSamples(n) => return extra + n as u64,
                Step::Stop => return extra,
            }
        }
    }

    #[test]
    fn direct_light_dominated_images_get_more_camera_samples() {
        let left = 10.0;
        let direct = direct_samples(&figures(1.0, Some(0.001)), left);
        let indirect = direct_samples(&figures(0.001, Some(1.0)), left);
        assert!(direct > 8 * indirect.max(1), "direct-dominated {direct}, indirect-dominated {indirect}");
        // all-direct noise: the time goes to camera samples at once
        assert_eq!(next_step(&figures(1.0, Some(0.0)), 2, 0, left), Step::DirectSamples((left * 0.9 / 0.01f64).floor() as u32));
    }

    #[test]
    fn the_plan_is_the_best_split_by_brute_force() {
        // the chosen first step agrees with the best of every split of the time left
        for (vd, vi, left) in [(1.0, 0.01, 5.0), (0.05, 0.02, 7.5), (0.3, 0.3, 3.2), (2.0, 0.5, 12.0)] {
            let f = figures(vd, Some(vi));
            let pass = f.pass_seconds();
            let best = (0..=(left / pass) as u32)
                .map(|m| (f.predicted(2 + m, ((left - m as f64 * pass) * DIRECT_MARGIN / f.per_camera_sample).floor() as u64).unwrap(), m))
                .fold((f64::INFINITY, 0), |a, b| if b.0 < a.0 { b } else { a });
            let step = next_step(&f, 2, 0, left);
            assert_eq!(step == Step::PhotonPass, best.1 > 0, "{vd} {vi} {left}: {step:?}, best {best:?}");
        }
    }

    #[test]
    fn unknown_indirect_variance_takes_a_second_pass_when_two_fit() {
        let f = figures(1.0, None);
        assert_eq!(next_step(&f, 1, 0, 2.5 * f.pass_seconds()), Step::PhotonPass);
        assert_eq!(next_step(&f, 1, 0, 1.5 * f.pass_seconds()), Step::DirectSamples((1.5 * 1.04 * 0.9 / 0.01f64).floor() as u32));
        assert_eq!(next_step(&f, 1, 0, 0.001), Step::Stop);
    }

    #[test]
    fn variance_of_pair_estimates_a_known_variance() {
        // two independent estimates per pixel, uniform noise of variance 1/12 around a ramp: the
        // mean of half their squared difference is 1/12 (here in luminance: grey pixels)
        let mut rng = Rng::new(7, 0);
        let n = 200_000;
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for i in 0..n {
            let base = (i % 100) as f32;
            let (x, y) = (base + rng.next_f32(), base + rng.next_f32());
            a.extend([x; 3]);
            b.extend([y; 3]);
        }
        let v = variance_of_pair(&a, &b);
        assert!((v - 1.0 / 12.0).abs() < 0.002, "{v}");
    }
}
