//! Piecewise-constant 1D and 2D distributions (light selection, environment-map sampling).

use glam::Vec2;

/// The largest `f32` below 1.
pub(crate) const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// Piecewise-constant distribution over `n` entries, equivalently a density on `[0, 1)` made of `n`
/// equal-width steps.
///
/// Weights that are negative, NaN or infinite count as 0. If every weight is 0 (and `n > 0`) the
/// distribution is uniform over the entries while [`total`](Self::total) still reports 0, so callers
/// can tell. An empty distribution is allowed: [`sample_discrete`](Self::sample_discrete) returns
/// `None` and [`sample_continuous`](Self::sample_continuous) returns pdf 0. Entries with zero weight
/// are never sampled. The CDF is accumulated in `f64`, so millions of entries keep their precision.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    /// Probability of each entry (sums to 1 unless empty).
    pmf: Vec<f32>,
    /// `cdf[0] = 0`, `cdf[n] = 1`, non-decreasing.
    cdf: Vec<f32>,
    total: f32,
}

impl Distribution1D {
    /// Distribution proportional to `weights`.
    pub fn new(weights: &[f32]) -> Distribution1D {
        let n = weights.len();
        let clean = |w: f32| if w.is_finite() && w > 0.0 { w as f64 } else { 0.0 };
        let sum: f64 = weights.iter().map(|&w| clean(w)).sum();
        let mut pmf = Vec::with_capacity(n);
        let mut cdf = Vec::with_capacity(n + 1);
        cdf.push(0.0);
        if sum > 0.0 {
            let mut acc = 0.0f64;
            for &w in weights {
                let p = clean(w) / sum;
                acc += p;
                pmf.push(p as f32);
                cdf.push(acc.min(1.0) as f32);
            }
        } else {
            for i in 0..n {
                pmf.push(1.0 / n as f32);
                cdf.push(((i + 1) as f64 / n as f64) as f32);
            }
        }
        if n > 0 {
            // Exactly 1 at the end, also past rounding, so every u < 1 finds an entry.
            cdf[n] = 1.0;
        }
        Distribution1D { pmf, cdf, total: sum as f32 }
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.pmf.len()
    }

    /// Whether there are no entries.
    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }

    /// Sum of the (cleaned) weights; 0 for an all-zero or empty distribution.
    pub fn total(&self) -> f32 {
        self.total
    }

    /// Probability of entry `i` (0 when out of range).
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf.get(i).copied().unwrap_or(0.0)
    }

    /// Index of the entry whose CDF interval contains `u` (clamped into `[0, 1)`): always an entry of
    /// nonzero probability. Requires `n > 0`.
    fn find(&self, u: f32) -> (usize, f32) {
        let u = if u >= 0.0 { u.min(ONE_MINUS_EPSILON) } else { 0.0 };
        // First CDF value > u is cdf[i + 1]; cdf[i] <= u < cdf[i + 1], so entry i has nonzero width.
        let i = self.cdf.partition_point(|&c| c <= u).clamp(1, self.len()) - 1;
        (i, u)
    }

    /// Samples an entry with `u ∈ [0, 1)`: `(index, pmf, u remapped to [0, 1))`. The remapped value
    /// is uniform and independent of the choice, so it can be reused for a further decision.
    pub fn sample_discrete(&self, u: f32) -> Option<(usize, f32, f32)> {
        if self.is_empty() {
            return None;
        }
        let (i, u) = self.find(u);
        let (c0, c1) = (self.cdf[i], self.cdf[i + 1]);
        let du = if c1 > c0 { ((u - c0) / (c1 - c0)).min(ONE_MINUS_EPSILON) } else { 0.0 };
        Some((i, self.pmf[i], du.max(0.0)))
    }

    /// Samples the step density on `[0, 1)`: `(x, pdf(x), index of the step)`. The pdf of step `i`
    /// is `n · pmf(i)`. An empty distribution returns `(0, 0, 0)`.
    pub fn sample_continuous(&self, u: f32) -> (f32, f32, usize) {
        let Some((i, p, du)) = self.sample_discrete(u) else { return (0.0, 0.0, 0) };
        let n = self.len() as f32;
        let x = ((i as f32 + du) / n).min(ONE_MINUS_EPSILON);
        (x, p * n, i)
    }
}

/// Piecewise-constant density on `[0, 1)²` over a `w × h` grid, for lat-long environment maps.
///
/// `weights` is row-major with `h` rows of `w` entries: entry `(x, y)` is `weights[y * w + x]` and
/// covers `u ∈ [x/w, (x+1)/w)`, `v ∈ [y/h, (y+1)/h)`. Sampling picks a row from the marginal over
/// `v` (with `u.y`), then a column from that row's conditional (with `u.x`). Weight cleaning and
/// the all-zero case behave as in [`Distribution1D`] (all zero: uniform).
#[derive(Clone, Debug)]
pub struct Distribution2D {
    conditional: Vec<Distribution1D>,
    marginal: Distribution1D,
    w: usize,
    h: usize,
}

impl Distribution2D {
    /// Distribution proportional to `weights`. Panics unless `w > 0`, `h > 0` and
    /// `weights.len() == w * h` (a caller bug, not a data condition).
    pub fn new(weights: &[f32], w: usize, h: usize) -> Distribution2D {
        assert!(w > 0 && h > 0, "Distribution2D needs a non-empty grid, got {w}x{h}");
        assert_eq!(weights.len(), w * h, "Distribution2D: {} weights for a {w}x{h} grid", weights.len());
        let conditional: Vec<Distribution1D> = weights.chunks_exact(w).map(Distribution1D::new).collect();
        let rows: Vec<f32> = conditional.iter().map(|c| c.total()).collect();
        let marginal = Distribution1D::new(&rows);
        Distribution2D { conditional, marginal, w, h }
    }

    /// Samples `uv ∈ [0, 1)²` and returns it with its density with respect to area in uv space.
    pub fn sample(&self, u: Vec2) -> (Vec2, f32) {
        let (v, pdf_v, row) = self.marginal.sample_continuous(u.y);
        let (x, pdf_u, _) = self.conditional[row].sample_continuous(u.x);
        (Vec2::new(x, v), pdf_v * pdf_u)
    }

    /// Density of [`sample`](Self::sample) at `uv` (coordinates are clamped into the grid).
    pub fn pdf(&self, uv: Vec2) -> f32 {
        // `as usize` saturates (NaN → 0), and the `min` keeps the index in range.
        let x = ((uv.x * self.w as f32) as usize).min(self.w - 1);
        let y = ((uv.y * self.h as f32) as usize).min(self.h - 1);
        let row = &self.conditional[y];
        self.marginal.pmf(y) * self.h as f32 * row.pmf(x) * self.w as f32
    }

    /// Grid size `(w, h)`.
    pub fn resolution(&self) -> (usize, usize) {
        (self.w, self.h)
    }
}
