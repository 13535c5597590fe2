//! Test support (compiled only for tests): Pearson's chi-square goodness-of-fit test with pooling of
//! low-expectation cells, adaptive Simpson cubature, and a (cos θ, φ) histogram of directions
//! (the scheme of Mitsuba's `ChiSquareTest`).

use super::Rng;
use glam::Vec3;
use statrs::distribution::{ChiSquared, ContinuousCDF};
use std::f64::consts::TAU;

/// Outcome of a chi-square test (all fields appear in failure messages through `Debug`).
#[allow(dead_code)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct Chi2 {
    /// Test statistic.
    pub stat: f64,
    /// Degrees of freedom after pooling.
    pub dof: usize,
    /// Probability of a statistic at least this large if the samples follow the expected law.
    pub p_value: f64,
    /// Sum of the expected frequencies divided by the sample count (the integrated density).
    pub integral: f64,
}

/// Pearson's test of `observed` counts against `expected` counts. Cells expecting fewer than
/// `min_expected` are pooled (smallest first) until the pool reaches `min_expected`. Observations in
/// a pool expecting nothing make the statistic infinite (p = 0).
pub(crate) fn chi2_test(observed: &[f64], expected: &[f64], n_samples: usize, min_expected: f64) -> Chi2 {
    assert_eq!(observed.len(), expected.len());
    let mut order: Vec<usize> = (0..expected.len()).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut stat, mut dof) = (0.0f64, 0usize);
    let (mut pool_obs, mut pool_exp) = (0.0f64, 0.0f64);
    for &i in &order {
        if expected[i] < min_expected || (pool_exp > 0.0 && pool_exp < min_expected) {
            pool_obs += observed[i];
            pool_exp += expected[i];
        } else {
            stat += (observed[i] - expected[i]).powi(2) / expected[i];
            dof += 1;
        }
    }
    if pool_obs > 0.0 || pool_exp > 0.0 {
        stat += if pool_exp > 0.0 { (pool_obs - pool_exp).powi(2) / pool_exp } else { f64::INFINITY };
        dof += 1;
    }
    let dof = dof.saturating_sub(1).max(1);
    let p_value = if stat.is_finite() { ChiSquared::new(dof as f64).unwrap().sf(stat) } else { 0.0 };
    Chi2 { stat, dof, p_value, integral: expected.iter().sum::<f64>() / n_samples as f64 }
}

/// Adaptive Simpson quadrature of `f` over `[a, b]` to absolute tolerance `eps`, always subdividing
/// at least `min_depth` times (so narrow peaks are not skipped) and at most `max_depth` times.
pub(crate) fn integrate_1d(
    f: &mut dyn FnMut(f64) -> f64,
    a: f64,
    b: f64,
    eps: f64,
    min_depth: u32,
    max_depth: u32,
) -> f64 {
    let (fa, fm, fb) = (f(a), f(0.5 * (a + b)), f(b));
    let whole = (b - a) / 6.0 * (fa + 4.0 * fm + fb);
    simpson_rec(f, [a, b], [fa, fm, fb], whole, eps, 0, (min_depth, max_depth))
}

fn simpson_rec(
    f: &mut dyn FnMut(f64) -> f64,
    [a, b]: [f64; 2],
    [fa, fm, fb]: [f64; 3],
    whole: f64,
    eps: f64,
    depth: u32,
    (min_d, max_d): (u32, u32),
) -> f64 {
    let m = 0.5 * (a + b);
    let (flm, frm) = (f(0.5 * (a + m)), f(0.5 * (m + b)));
    let left = (m - a) / 6.0 * (fa + 4.0 * flm + fm);
    let right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
    let delta = left + right - whole;
    if depth >= max_d || (depth >= min_d && delta.abs() <= 15.0 * eps) {
        return left + right + delta / 15.0;
    }
    simpson_rec(f, [a, m], [fa, flm, fm], left, 0.5 * eps, depth + 1, (min_d, max_d))
        + simpson_rec(f, [m, b], [fm, frm, fb], right, 0.5 * eps, depth + 1, (min_d, max_d))
}

/// Nested adaptive Simpson over the rectangle `[x0, x1] × [y0, y1]`.
pub(crate) fn integrate_2d(
    f: &mut dyn FnMut(f64, f64) -> f64,
    [x0, x1]: [f64; 2],
    [y0, y1]: [f64; 2],
    eps: f64,
) -> f64 {
    let mut outer = |x: f64| integrate_1d(&mut |y| f(x, y), y0, y1, eps, 3, 12);
    integrate_1d(&mut outer, x0, x1, eps, 3, 12)
}

/// Histogram of unit directions over `n_cos × n_phi` cells, uniform in `cos θ ∈ [-1, 1]` and
/// `φ ∈ [0, 2π)`. Since `dω = d(cos θ) dφ`, a density per steradian integrates over a cell with
/// no Jacobian.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SphereBins {
    pub n_cos: usize,
    pub n_phi: usize,
}

impl SphereBins {
    fn cell(&self, i: usize) -> ([f64; 2], [f64; 2]) {
        let (ic, ip) = (i / self.n_phi, i % self.n_phi);
        let dc = 2.0 / self.n_cos as f64;
        let dp = TAU / self.n_phi as f64;
        ([-1.0 + ic as f64 * dc, -1.0 + (ic + 1) as f64 * dc], [ip as f64 * dp, (ip + 1) as f64 * dp])
    }

    /// Cell of direction `w` (normalised here).
    pub fn index(&self, w: Vec3) -> usize {
        let w = w.as_dvec3().normalize();
        let c = ((w.z + 1.0) * 0.5 * self.n_cos as f64) as usize;
        let phi = w.y.atan2(w.x).rem_euclid(TAU);
        let p = (phi / TAU * self.n_phi as f64) as usize;
        c.min(self.n_cos - 1) * self.n_phi + p.min(self.n_phi - 1)
    }

    /// Integral of `pdf` over each cell.
    pub fn integrate(&self, pdf: &dyn Fn(Vec3) -> f32) -> Vec<f64> {
        (0..self.n_cos * self.n_phi)
            .map(|i| {
                let (zc, pc) = self.cell(i);
                let mut f = |z: f64, phi: f64| {
                    let r = (1.0 - z * z).max(0.0).sqrt();
                    pdf(Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32)) as f64
                };
                integrate_2d(&mut f, zc, pc, 1e-7)
            })
            .collect()
    }
}

/// Draws `n` samples of a direction warp (samples returning `None` count as drawn but land in no
/// cell), bins them, and tests them against the integrated `pdf`.
pub(crate) fn sphere_chi2(
    bins: SphereBins,
    n: usize,
    seed: u64,
    mut sample: impl FnMut(&mut Rng) -> Option<Vec3>,
    pdf: &dyn Fn(Vec3) -> f32,
) -> Chi2 {
    let mut rng = Rng::new(seed, 0x5eed);
    let mut observed = vec![0.0f64; bins.n_cos * bins.n_phi];
    for _ in 0..n {
        if let Some(w) = sample(&mut rng) {
            observed[bins.index(w)] += 1.0;
        }
    }
    let expected: Vec<f64> = bins.integrate(pdf).into_iter().map(|p| p * n as f64).collect();
    chi2_test(&observed, &expected, n, 5.0)
}
