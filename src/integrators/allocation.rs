//! How a photon method spends a time budget (`--time`): between photon passes (new photons and
//! eye samples: they lower the indirect light's noise), camera samples that only add direct light
//! (an eye pass without eye samples and without photons: cheap, it lowers the direct light's and
//! the anti-aliasing's noise), the kernel bandwidth of later passes, and — when `auto` chose the
//! method and gave the path tracer's figures ([`Rival`]) — the path tracer for the time left,
//! blended with the passes, all from figures the first passes measured.
//!
//! The image's expected error is modelled as `v_d / N + b² (B/P)² + V_i S / P²`: `N` camera
//! samples per pixel of direct light in all, of variance `v_d` each (the mean over pixels of the
//! luminance variance of one camera sample's estimate, measured from the spread of each pixel's
//! camera samples), and `P` photon passes of indirect light. A pass at the first pass's bandwidth
//! has variance `V_i` (half the mean squared luminance difference of two passes' indirect layers)
//! and bias `b`; a pass whose kernel's squared radius is `ρ` times the first's has bias `ρ b` and
//! variance `V_i / ρ` (a kernel of order two: its bias goes as the squared radius, its variance as
//! one over its area), `B = Σ ρ_k` and `S = Σ 1/ρ_k` over the passes ([`Done`]). `b²` comes from a
//! pass at half the squared radius ([`variance_and_bias`]). The error is plain MSE, not relative:
//! scaling the image scales every term alike, so the choice does not depend on the exposure (it
//! minimises the error of images scaled to a common mean).
//!
//! Two estimates of a layer with independent errors `a` and `c` blend with the weight `c / (a + c)`
//! on the first into an estimate of error `a c / (a + c)` ([`blend_weight`]); the path tracer for
//! `t` seconds has error `v_pt / n` per layer (`n = t / seconds per sample`), so switching to it
//! is predicted by [`switched`] and taken when it beats the best plan of photon passes. With
//! enough samples the path tracer corrects the passes' indirect light instead (`regression`),
//! which keeps their noise and blends their squared bias with a share of its error.

use super::regression;

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
    /// Seconds of one direct-only camera sample per pixel of the whole image: at first
    /// `per_camera_sample` (which also pays for the eye samples: an overestimate), then measured.
    pub per_direct_sample: f64,
    /// `v_d`: variance of one camera sample's direct-light estimate, mean over pixels.
    pub direct_variance: f64,
    /// `V_i`: variance of one pass's indirect light at the first bandwidth, mean over pixels
    /// (`None` before two passes).
    pub indirect_variance: Option<f64>,
    /// `b²`: squared bias of one pass's indirect light at the first bandwidth, mean over pixels
    /// (`None` before a pass at half the squared radius; counted as 0 until then).
    pub bias2: Option<f64>,
    /// Whether `b²` is the bias of every part of the estimate (measured against the path tracer's
    /// samples: a radiance cache's interpolation included), which narrower kernels need not
    /// lower; later passes then keep the first bandwidth.
    pub bias_of_every_part: bool,
}

/// What a timed render has done: photon passes, their bandwidths' sums `B = Σ ρ_k` and
/// `S = Σ 1/ρ_k` (`ρ_k`: pass `k`'s squared kernel radius over the first pass's), and direct-only
/// camera samples per pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Done {
    pub passes: u32,
    pub bias_sum: f64,
    pub variance_sum: f64,
    pub extra: u64,
}

impl Done {
    /// `passes` passes at the first bandwidth and `extra` direct-only camera samples per pixel.
    pub fn at_first_bandwidth(passes: u32, extra: u64) -> Done {
        Done { passes, bias_sum: passes as f64, variance_sum: passes as f64, extra }
    }

    /// With `more` passes at squared-radius ratio `ratio` and `extra` more direct-only samples.
    pub fn then(&self, more: u32, ratio: f64, extra: u64) -> Done {
        Done {
            passes: self.passes + more,
            bias_sum: self.bias_sum + more as f64 * ratio,
            variance_sum: self.variance_sum + more as f64 / ratio,
            extra: self.extra + extra,
        }
    }
}

impl Figures {
    /// Seconds of one photon pass.
    pub fn pass_seconds(&self) -> f64 {
        self.pass_fixed + self.per_camera_sample * self.pass_camera_samples as f64
    }

    /// Predicted MSE of the direct and of the indirect light after `done`; `None` without the
    /// indirect variance.
    pub fn parts(&self, done: &Done) -> Option<[f64; 2]> {
        let n = done.passes as u64 * self.pass_camera_samples as u64 + done.extra;
        let [bias2, noise] = self.bias_and_noise(done)?;
        Some([self.direct_variance / n.max(1) as f64, bias2 + noise])
    }

    /// The averaged passes' indirect light's predicted squared bias and variance after `done`.
    pub fn bias_and_noise(&self, done: &Done) -> Option<[f64; 2]> {
        let p = done.passes.max(1) as f64;
        Some([self.bias2.unwrap_or(0.0) * (done.bias_sum / p).powi(2), self.indirect_variance? * done.variance_sum / (p * p)])
    }

    /// Predicted MSE after `done`.
    pub fn predicted_after(&self, done: &Done) -> Option<f64> {
        self.parts(done).map(|[d, i]| d + i)
    }
}

/// The path tracer's figures, measured by `auto`'s probe (`pt::probe`): its rival in a timed
/// render `auto` chose a photon method for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rival {
    /// Seconds of one path-traced sample per pixel of the image.
    pub seconds_per_spp: f64,
    /// Variance of one path's direct and indirect light (luminance, mean over pixels).
    pub variance: [f64; 2],
    /// Whether its samples correct the passes' indirect light (`regression`: the pilot's pair
    /// gives each pixel's noise) rather than blend with it.
    pub corrects: bool,
}

impl Rival {
    /// Samples per pixel the path tracer reaches in `seconds`.
    pub fn spp(&self, seconds: f64) -> f64 {
        if self.seconds_per_spp > 0.0 {
            (seconds / self.seconds_per_spp).floor()
        } else {
            0.0
        }
    }

    /// The path tracer's predicted MSE after `seconds` on its own (infinite below one sample).
    pub fn predicted(&self, seconds: f64) -> f64 {
        let n = self.spp(seconds);
        if n >= 1.0 {
            (self.variance[0] + self.variance[1]) / n
        } else {
            f64::INFINITY
        }
    }
}

/// The weight on an estimate of error `a` blended with an independent one of error `c`
/// (`c / (a + c)`; one half when both are exact).
pub fn blend_weight(a: f64, c: f64) -> f64 {
    if a + c > 0.0 {
        c / (a + c)
    } else {
        0.5
    }
}

/// Error of the blend of two independent estimates of errors `a` and `c` ([`blend_weight`]).
pub fn blended(a: f64, c: f64) -> f64 {
    if a.is_infinite() {
        return c;
    }
    if c.is_infinite() {
        return a;
    }
    if a + c > 0.0 {
        a * c / (a + c)
    } else {
        0.0
    }
}

/// Predicted MSE of handing the `left` seconds to the path tracer after `done`, its direct and
/// indirect layers blended with the passes' ([`blend_weight`]); when it
/// [`corrects`](Rival::corrects) the passes' indirect light with at least
/// [`regression::MIN_SPP`] samples, that layer keeps the passes' noise and their squared bias
/// blends with [`regression::noise_share`] of its error; `None` without the indirect variance.
pub fn switched(f: &Figures, rival: &Rival, done: &Done, left: f64) -> Option<f64> {
    let [d, i] = f.parts(done)?;
    let n = rival.spp(left);
    if n < 1.0 {
        return Some(d + i);
    }
    let c = rival.variance[1] / n;
    let indirect = match f.bias_and_noise(done) {
        Some([bias2, noise]) if rival.corrects && n >= regression::MIN_SPP as f64 => noise + blended(bias2, regression::noise_share() * c),
        _ => blended(i, c),
    };
    Some(blended(d, rival.variance[0] / n) + indirect)
}

/// The next step of a timed render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Step {
    /// Another photon pass, its kernel's squared radius this ratio times the first pass's.
    PhotonPass(f64),
    /// This many direct-only camera samples per pixel (then the next step, with their time measured).
    DirectSamples(u32),
    /// The path tracer for the time left, blended with the passes ([`switched`]).
    PathTracer,
    /// Nothing fits in the time left.
    Stop,
}

/// Largest number of direct-only camera samples per pixel one step takes.
pub const MAX_DIRECT_SAMPLES: u32 = 4096;
/// Share of the time left that direct-only samples are planned for (their cost per sample is the
/// photon passes' eye pass's, which also made eye samples: a margin either way).
const DIRECT_MARGIN: f64 = 0.9;
/// Squared-radius ratio of the pass that measures the bias ([`variance_and_bias`]): the radius
/// over √2.
pub const BIAS_RATIO: f64 = 0.5;
/// Squared-radius ratios later passes may take once the bias is known: a large bias takes narrower
/// kernels (less bias, more variance per pass).
pub const RATIOS: [f64; 4] = [1.0, 0.5, 0.25, 0.125];

/// The plan of lowest predicted error for `left` seconds after `done`: (error, more passes, their
/// squared-radius ratio, direct-only samples); `None` without the indirect variance.
pub fn best_plan(f: &Figures, done: &Done, left: f64) -> Option<(f64, u32, f64, u64)> {
    f.indirect_variance?;
    let pass = f.pass_seconds();
    let most = if pass > 0.0 { (left / pass).floor().clamp(0.0, 1e5) as u32 } else { 0 };
    let ratios: &[f64] = if f.bias2.is_some() && !f.bias_of_every_part { &RATIOS } else { &[1.0] };
    let mut best = (f64::INFINITY, 0u32, 1.0, 0u64);
    for &ratio in ratios {
        for more in 0..=most {
            let d = direct_samples_in(f, left - more as f64 * pass) as u64;
            let e = f.predicted_after(&done.then(more, ratio, d))?;
            if e < best.0 {
                best = (e, more, ratio, d);
            }
        }
    }
    Some(best)
}

/// Direct-only camera samples per pixel planned for `t` seconds.
fn direct_samples_in(f: &Figures, t: f64) -> u32 {
    if f.per_direct_sample <= 0.0 || t <= 0.0 {
        return 0;
    }
    (t * DIRECT_MARGIN / f.per_direct_sample).floor().min(MAX_DIRECT_SAMPLES as f64) as u32
}

/// The step after `done`, with `left` seconds left: the plan of the lowest predicted error
/// ([`best_plan`]), or the path tracer when [`switched`] predicts less. While the indirect
/// variance is unknown, a second photon pass if at least two more fit (to measure it), else
/// direct-only samples for the rest; while the bias is unknown, the next pass planned measures
/// it at [`BIAS_RATIO`].
pub fn next_step(f: &Figures, rival: Option<&Rival>, done: &Done, left: f64) -> Step {
    let samples = || match direct_samples_in(f, left) {
        0 => Step::Stop,
        n => Step::DirectSamples(n),
    };
    let Some((error, more, ratio, _)) = best_plan(f, done, left) else {
        return if left >= 2.0 * f.pass_seconds() { Step::PhotonPass(1.0) } else { samples() };
    };
    if rival.and_then(|r| switched(f, r, done, left)).is_some_and(|e| e < error) {
        return Step::PathTracer;
    }
    match (more, f.bias2) {
        (0, _) => samples(),
        (_, None) => Step::PhotonPass(BIAS_RATIO),
        (_, Some(_)) => Step::PhotonPass(ratio),
    }
}

/// Luminance (Rec. 709) of an RGB triple, as every figure of the timed passes measures it.
pub fn lum(c: &[f32]) -> f64 {
    0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64
}

/// Mean over pixels of half the squared luminance difference of two independent estimates `a` and
/// `b` (RGB triples): the variance of one of them, mean over pixels.
pub fn variance_of_pair(a: &[f32], b: &[f32]) -> f64 {
    let n = a.len() / 3;
    if n == 0 {
        return 0.0;
    }
    a.chunks_exact(3).zip(b.chunks_exact(3)).map(|(x, y)| 0.5 * (lum(x) - lum(y)).powi(2)).sum::<f64>() / n as f64
}

/// `(V, b²)`, mean over pixels, of one pass's indirect light at the first bandwidth, from two passes
/// `a`, `b` at it and one pass `c` at `ratio` times its squared radius (RGB triples): with bias
/// `ρ b` and variance `V / ρ` at ratio `ρ`, `E[(m − c)²] = (1 − ρ)² b² + V/2 + V/ρ` for the mean
/// `m` of `a` and `b`, solved for `b²` (at least 0).
pub fn variance_and_bias(a: &[f32], b: &[f32], c: &[f32], ratio: f64) -> (f64, f64) {
    let v = variance_of_pair(a, b);
    let n = (a.len() / 3).max(1) as f64;
    let q = a
        .chunks_exact(3)
        .zip(b.chunks_exact(3))
        .zip(c.chunks_exact(3))
        .map(|((x, y), z)| (0.5 * (lum(x) + lum(y)) - lum(z)).powi(2))
        .sum::<f64>()
        / n;
    let bias2 = ((q - v / 2.0 - v / ratio) / (1.0 - ratio).powi(2)).max(0.0);
    (v, bias2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn figures(direct_variance: f64, indirect_variance: Option<f64>) -> Figures {
        Figures { pass_fixed: 1.0, per_camera_sample: 0.01, pass_camera_samples: 4, per_direct_sample: 0.01, direct_variance, indirect_variance, bias2: None, bias_of_every_part: false }
    }
    /// A bias measured against the path tracer (every part of the estimate's) keeps later passes
    /// at the first bandwidth; a kernel's bias alone takes narrower kernels when it is large.
    #[test]
    fn a_bias_of_every_part_keeps_the_first_bandwidth() {
        let kernel = Figures { bias2: Some(1e-2), ..figures(1e-4, Some(1e-4)) };
        let (_, more, ratio, _) = best_plan(&kernel, &Done::at_first_bandwidth(3, 0), 20.0).unwrap();
        assert!(more > 0 && ratio < 1.0, "{more} passes at ratio {ratio}");
        let every = Figures { bias_of_every_part: true, ..kernel };
        let (_, more, ratio, _) = best_plan(&every, &Done::at_first_bandwidth(3, 0), 20.0).unwrap();
        assert_eq!(ratio, 1.0, "{more} passes at ratio {ratio}");
    }


    /// A path tracer that corrects the passes (`regression`) keeps their noise and blends their
    /// squared bias with its error's share; one that blends, or has too few samples to correct,
    /// blends their whole indirect error. Two passes of noise 2e-3 and squared bias 4e-3 each,
    /// the path tracer's indirect error 5e-3 after 100 spp.
    #[test]
    fn a_correcting_path_tracer_removes_the_bias_and_keeps_the_noise() {
        let biased = Figures { bias2: Some(4e-3), bias_of_every_part: true, ..figures(0.0, Some(2e-3)) };
        let unbiased = Figures { bias2: Some(0.0), ..biased };
        let done = Done::at_first_bandwidth(2, 0);
        let blends = Rival { seconds_per_spp: 0.1, variance: [0.0, 0.5], corrects: false };
        let corrects = Rival { corrects: true, ..blends };
        let near = |a: Option<f64>, b: f64| a.is_some_and(|a| (a - b).abs() < 1e-9 * b);
        let s = regression::noise_share() * 5e-3;
        assert!(near(switched(&biased, &corrects, &done, 10.0), 1e-3 + 4e-3 * s / (4e-3 + s)));
        assert!(near(switched(&biased, &blends, &done, 10.0), 2.5e-3));
        assert!(near(switched(&unbiased, &corrects, &done, 10.0), 1e-3));
        assert!(near(switched(&unbiased, &blends, &done, 10.0), 1e-3 * 5e-3 / 6e-3));
        // three samples are too few to correct with
        assert_eq!(switched(&biased, &corrects, &done, 0.3), switched(&biased, &blends, &done, 0.3));
    }

    /// Follow a plan's steps with `left` seconds after `done` (the passes' bias known or not):
    /// what it did and whether it ended on the path tracer.
    fn follow(f: &Figures, rival: Option<&Rival>, mut done: Done, mut left: f64) -> (Done, bool) {
        loop {
            match next_step(f, rival, &done, left) {
                Step::PhotonPass(ratio) => {
                    done = done.then(1, ratio, 0);
                    left -= f.pass_seconds();
                }
                Step::DirectSamples(n) => return (done.then(0, 1.0, n as u64), false),
                Step::PathTracer => return (done, true),
                Step::Stop => return (done, false),
            }
        }
    }

    #[test]
    fn direct_light_dominated_images_get_more_camera_samples() {
        let left = 10.0;
        let two = Done::at_first_bandwidth(2, 0);
        let direct = follow(&figures(1.0, Some(0.001)), None, two, left).0.extra;
        let indirect = follow(&figures(0.001, Some(1.0)), None, two, left).0.extra;
        assert!(direct > 8 * indirect.max(1), "direct-dominated {direct}, indirect-dominated {indirect}");
        // all-direct noise: the time goes to camera samples at once
        assert_eq!(next_step(&figures(1.0, Some(0.0)), None, &two, left), Step::DirectSamples((left * 0.9 / 0.01f64).floor() as u32));
    }

    #[test]
    fn the_plan_is_the_best_split_by_brute_force() {
        // the chosen first step agrees with the best of every split of the time left
        for (vd, vi, left) in [(1.0, 0.01, 5.0), (0.05, 0.02, 7.5), (0.3, 0.3, 3.2), (2.0, 0.5, 12.0)] {
            let f = Figures { bias2: Some(0.0), ..figures(vd, Some(vi)) };
            let pass = f.pass_seconds();
            let best = (0..=(left / pass) as u32)
                .map(|m| (f.predicted_after(&Done::at_first_bandwidth(2 + m, ((left - m as f64 * pass) * DIRECT_MARGIN / f.per_camera_sample).floor() as u64)).unwrap(), m))
                .fold((f64::INFINITY, 0), |a, b| if b.0 < a.0 { b } else { a });
            let step = next_step(&f, None, &Done::at_first_bandwidth(2, 0), left);
            assert_eq!(matches!(step, Step::PhotonPass(_)), best.1 > 0, "{vd} {vi} {left}: {step:?}, best {best:?}");
        }
    }

    #[test]
    fn unknown_indirect_variance_takes_a_second_pass_when_two_fit() {
        let f = figures(1.0, None);
        let one = Done::at_first_bandwidth(1, 0);
        assert_eq!(next_step(&f, None, &one, 2.5 * f.pass_seconds()), Step::PhotonPass(1.0));
        assert_eq!(next_step(&f, None, &one, 1.5 * f.pass_seconds()), Step::DirectSamples((1.5 * 1.04 * 0.9 / 0.01f64).floor() as u32));
        assert_eq!(next_step(&f, None, &one, 0.001), Step::Stop);
    }

    /// The third pass measures the bias at half the squared radius; once a large bias is known,
    /// later passes take narrower kernels, and without bias they keep the first bandwidth.
    #[test]
    fn the_bias_is_measured_then_sets_the_bandwidth() {
        let two = Done::at_first_bandwidth(2, 0);
        let f = figures(0.001, Some(1.0));
        assert_eq!(next_step(&f, None, &two, 10.0), Step::PhotonPass(BIAS_RATIO));
        let three = two.then(1, BIAS_RATIO, 0);
        let biased = Figures { bias2: Some(10.0), ..f };
        assert!(matches!(next_step(&biased, None, &three, 10.0), Step::PhotonPass(r) if r < 1.0), "{:?}", next_step(&biased, None, &three, 10.0));
        let unbiased = Figures { bias2: Some(0.0), ..f };
        assert_eq!(next_step(&unbiased, None, &three, 10.0), Step::PhotonPass(1.0));
        // the bias counts: it raises the prediction, by less after a narrower pass
        assert!(biased.predicted_after(&three).unwrap() > unbiased.predicted_after(&three).unwrap());
        assert!(biased.predicted_after(&three).unwrap() < biased.predicted_after(&Done::at_first_bandwidth(3, 0)).unwrap() + 1e-12);
    }

    /// A path tracer far ahead takes the time left; one far behind never does; in between it is
    /// taken exactly when the blend's predicted error is below the best plan's.
    #[test]
    fn the_path_tracer_takes_the_rest_when_predicted_lower() {
        let f = Figures { bias2: Some(0.05), ..figures(0.5, Some(0.5)) };
        let done = Done::at_first_bandwidth(3, 0);
        let fast = Rival { seconds_per_spp: 0.001, variance: [0.1, 0.1], corrects: false };
        let slow = Rival { seconds_per_spp: 1.0, variance: [10.0, 10.0], corrects: false };
        assert_eq!(next_step(&f, Some(&fast), &done, 10.0), Step::PathTracer);
        assert_ne!(next_step(&f, Some(&slow), &done, 10.0), Step::PathTracer);
        for s in [0.002, 0.01, 0.05, 0.2] {
            let r = Rival { seconds_per_spp: s, variance: [0.2, 1.0], corrects: false };
            let plan = best_plan(&f, &done, 10.0).unwrap().0;
            let sw = switched(&f, &r, &done, 10.0).unwrap();
            assert_eq!(next_step(&f, Some(&r), &done, 10.0) == Step::PathTracer, sw < plan, "{s}: switch {sw}, plan {plan}");
        }
        // the blend is never predicted worse than either part
        let sw = switched(&f, &fast, &done, 10.0).unwrap();
        assert!(sw <= fast.predicted(10.0) && sw <= f.predicted_after(&done).unwrap());
    }

    /// The blend of two independent noisy estimates with the weight of [`blend_weight`] has the
    /// error [`blended`] predicts (simulated).
    #[test]
    fn blending_two_estimates_has_the_predicted_error() {
        let mut rng = Rng::new(3, 0);
        let (a, c) = (0.3f64, 1.2f64);
        let w = blend_weight(a, c);
        let n = 400_000;
        let mut sq = 0.0;
        for _ in 0..n {
            // uniform noise of variance a and c around 0
            let x = (rng.next_f32() as f64 - 0.5) * (12.0 * a).sqrt();
            let y = (rng.next_f32() as f64 - 0.5) * (12.0 * c).sqrt();
            sq += (w * x + (1.0 - w) * y).powi(2);
        }
        let mse = sq / n as f64;
        assert!((mse / blended(a, c) - 1.0).abs() < 0.01, "{mse} vs {}", blended(a, c));
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

    /// Passes of a known bias and variance per pixel (a bias that varies over the image, noise of
    /// variance `V / ρ` and bias `ρ β` at ratio `ρ`): the estimates recover the mean `V` and `β²`.
    #[test]
    fn variance_and_bias_recover_known_values() {
        let mut rng = Rng::new(11, 0);
        let n = 300_000;
        let v = 0.04f64;
        let mut noise = |var: f64| ((rng.next_f32() as f64 - 0.5) * (12.0 * var).sqrt()) as f32;
        let (mut a, mut b, mut c, mut beta2) = (Vec::new(), Vec::new(), Vec::new(), 0.0);
        for i in 0..n {
            let truth = 1.0 + (i % 37) as f32 * 0.1;
            let beta = 0.3 * ((i % 11) as f32 / 10.0 - 0.2);
            beta2 += (beta as f64).powi(2);
            a.extend([truth + beta + noise(v); 3]);
            b.extend([truth + beta + noise(v); 3]);
            c.extend([truth + BIAS_RATIO as f32 * beta + noise(v / BIAS_RATIO); 3]);
        }
        let (vi, b2) = variance_and_bias(&a, &b, &c, BIAS_RATIO);
        let want = beta2 / n as f64;
        assert!((vi / v - 1.0).abs() < 0.02, "variance {vi}, want {v}");
        assert!((b2 / want - 1.0).abs() < 0.1, "bias² {b2}, want {want}");
    }
}
