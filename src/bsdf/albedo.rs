//! Directional albedo of a GGX specular lobe, tabulated once per process, for the energy-conserving
//! layering of PreviewSurface.
//!
//! With generalised Schlick Fresnel `F = F0·(1 − s) + F90·s`, `s = (1 − wo·h)⁵`, the albedo of the
//! lobe for `μ = cos θo` is linear in `(F0, F90)`: `E(μ) = F0·A(μ, α) + F90·B(μ, α)`. `A` and `B`
//! are stored on a `32 × 32` grid uniform in `(μ^(1/3), ln α)` for `α ∈ [ALPHA_MIN, 1]` and
//! interpolated bilinearly: near grazing angles `E` varies on the scale `μ ~ α`, which this grid
//! resolves down to the smallest `α`. Delta lobes (`α = 0`) use the exact smooth values instead
//! (`A = 1 − (1 − μ)⁵`, `B = (1 − μ)⁵`). Entries are computed by stratified visible-normal sampling
//! (64 × 16 strata, radially concentrated at the rim; estimator `F·G2/G1`; error ~1e-4). The
//! cosine-weighted averages `Ā(α) = 2∫ A μ dμ` are integrated exactly from the interpolant, so
//! `1 − E` integrates to exactly `1 − Ē` and the Kelemen-weighted diffuse layer conserves energy up
//! to the interpolation error (a few 1e-3 at worst, at grazing angles).
//!
//! Each `α` column (32 `μ` entries, 32k GGX samples) is computed on its first use, so a render pays
//! only for the roughnesses of its materials: a lookup reads two neighbouring columns. (Filling the
//! whole table, ~1M samples, took ~0.2 s, most of the start-up time of a small render.) Columns
//! are independent `OnceLock`s: threads that need different columns compute them at the same time;
//! the values do not depend on which thread computes them or when. No heap.

use super::fresnel::{reflect, schlick_weight};
use super::microfacet::{Ggx, ALPHA_MIN};
use glam::{Vec2, Vec3, Vec4, Vec4Swizzles};
use std::sync::OnceLock;

const N_MU: usize = 32;
const N_ALPHA: usize = 32;
/// The table's `μ` axis is uniform in `μ^(1/MU_POWER)`.
const MU_POWER: i32 = 3;
/// Strata of the radial (`u.x`) and azimuthal (`u.y`) visible-normal sample coordinates.
const STRATA_X: usize = 64;
const STRATA_Y: usize = 16;
/// Smallest `μ` sampled for the `μ = 0` row (the integral is continuous there).
const MU_MIN: f32 = 1e-4;

/// One `α` column: `(A, B)` at the `μ` nodes and their cosine-weighted averages.
struct Column {
    ab: [[f32; 2]; N_MU],
    avg: [f32; 2],
}

/// The `A`/`B` tables and their cosine-weighted averages, column by column.
pub(crate) struct AlbedoTable {
    columns: [OnceLock<Column>; N_ALPHA],
}

static TABLE: AlbedoTable = AlbedoTable { columns: [const { OnceLock::new() }; N_ALPHA] };

/// The process-wide table (each column computed on its first use).
pub(crate) fn albedo_table() -> &'static AlbedoTable {
    &TABLE
}

/// GGX roughness `α` of table column `j`: log-uniform from `ALPHA_MIN` to 1.
fn column_alpha(j: usize) -> f32 {
    ALPHA_MIN.powf(1.0 - j as f32 / (N_ALPHA - 1) as f32)
}

/// `(A, B)` for one `(μ, α)` pair.
fn lobe_albedo(mu: f32, alpha: f32) -> [f32; 2] {
    let ggx = Ggx { alpha };
    let mu = mu.max(MU_MIN);
    let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
    let lambda_o = ggx.lambda(wo);
    let (mut a, mut b) = (0.0f64, 0.0f64);
    for i in 0..STRATA_X {
        // u.x = 1 − (1 − t)², Jacobian 2(1 − t): concentrates samples at the rim of the visible
        // hemisphere, where grazing reflections make G2 fall steeply.
        let t = (i as f64 + 0.5) / STRATA_X as f64;
        let jacobian = 2.0 * (1.0 - t);
        let ux = (1.0 - (1.0 - t) * (1.0 - t)) as f32;
        for k in 0..STRATA_Y {
            let u = Vec2::new(ux, (k as f32 + 0.5) / STRATA_Y as f32);
            let h = ggx.sample_visible_normal(wo, u);
            let wi = reflect(wo, h);
            if wi.z <= 0.0 {
                continue;
            }
            // f·cos/pdf without Fresnel = G2/G1(wo).
            let w = jacobian * ((1.0 + lambda_o) / (1.0 + lambda_o + ggx.lambda(wi))) as f64;
            let s = schlick_weight(wo.dot(h)) as f64;
            a += w * (1.0 - s);
            b += w * s;
        }
    }
    let n = (STRATA_X * STRATA_Y) as f64;
    [(a / n) as f32, (b / n) as f32]
}

impl Column {
    fn compute(j: usize) -> Column {
        let mut ab = [[0.0f32; 2]; N_MU];
        let mut avg = [0.0f32; 2];
        let h = 1.0 / (N_MU - 1) as f64;
        // 4-point Gauss-Legendre on [0, 1]: exact for the degree-6 integrands below.
        let (g0, g1) = (0.5 * 0.339_981_043_584_856_3, 0.5 * 0.861_136_311_594_052_6);
        let (w0, w1) = (0.5 * 0.652_145_154_862_546_1, 0.5 * 0.347_854_845_137_453_9);
        let gauss = [(0.5 - g1, w1), (0.5 - g0, w0), (0.5 + g0, w0), (0.5 + g1, w1)];
        let alpha = column_alpha(j);
        for (i, e) in ab.iter_mut().enumerate() {
            let x = i as f32 / (N_MU - 1) as f32;
            *e = lobe_albedo(x.powi(MU_POWER), alpha);
        }
        // 2∫ μ E dμ = 2P ∫ x^(2P−1) E(x) dx with μ = x^P and E linear in x on each interval.
        for (c, a) in avg.iter_mut().enumerate() {
            let e = |i: usize| ab[i][c] as f64;
            let mut sum = 0.0;
            for i in 0..N_MU - 1 {
                for (t, w) in gauss {
                    let x = (i as f64 + t) * h;
                    sum += w * h * x.powi(2 * MU_POWER - 1) * (e(i) + (e(i + 1) - e(i)) * t);
                }
            }
            *a = (2.0 * MU_POWER as f64 * sum) as f32;
        }
        Column { ab, avg }
    }
}

impl AlbedoTable {
    /// Column `j`, computed on first use.
    #[inline]
    fn column(&self, j: usize) -> &Column {
        self.columns[j].get_or_init(|| Column::compute(j))
    }

    /// How many columns have been computed (for tests).
    #[cfg(test)]
    pub(crate) fn computed_columns(&self) -> usize {
        self.columns.iter().filter(|c| c.get().is_some()).count()
    }

    /// Grid position of `x ∈ [0, 1]` on `n` nodes: lower index and fraction.
    #[inline]
    fn locate(x: f32, n: usize) -> (usize, f32) {
        let t = x.clamp(0.0, 1.0) * (n - 1) as f32;
        // through i32: one conversion instruction (a float to usize takes a dozen), the same
        // value for t in [0, n − 1] and for NaN (0)
        let i = (t as i32 as usize).min(n - 2);
        (i, t - i as f32)
    }

    /// Table coordinate of a GGX roughness `α` (clamped into `[ALPHA_MIN, 1]`).
    pub fn coordinate(alpha: f32) -> f32 {
        1.0 - alpha.clamp(ALPHA_MIN, 1.0).ln() / ALPHA_MIN.ln()
    }

    /// `(A, B)` at `μ = cos θo` and table coordinate `tc` (from [`coordinate`](Self::coordinate)).
    #[inline]
    pub fn lookup(&self, mu: f32, tc: f32) -> [f32; 2] {
        let (i, fi) = Self::locate(fast_cbrt(mu.max(0.0)), N_MU);
        let (j, fj) = Self::locate(tc, N_ALPHA);
        let (c0, c1) = (&self.column(j).ab, &self.column(j + 1).ab);
        // (A, B) of both columns in the lanes of one vector: each lane does the scalar
        // `a + (b − a)·t` in the same order, so the values are the same bits
        let lo = Vec4::new(c0[i][0], c0[i][1], c1[i][0], c1[i][1]);
        let hi = Vec4::new(c0[i + 1][0], c0[i + 1][1], c1[i + 1][0], c1[i + 1][1]);
        let v = lo + (hi - lo) * fi;
        let (a, b) = (v.xy(), v.zw());
        let ab = a + (b - a) * fj;
        [ab.x, ab.y]
    }

    /// Cosine-weighted averages `(Ā, B̄)` at table coordinate `tc` (linear; consistent with
    /// [`lookup`](Self::lookup)).
    #[inline]
    pub fn average(&self, tc: f32) -> [f32; 2] {
        let (j, fj) = Self::locate(tc, N_ALPHA);
        let (a, b) = (self.column(j).avg, self.column(j + 1).avg);
        [a[0] + (b[0] - a[0]) * fj, a[1] + (b[1] - a[1]) * fj]
    }
}

/// Cube root of `x ∈ [0, 1]` to ~1e-7 relative: a bit-level first guess refined by two Newton
/// steps (libm's `cbrtf` dominated table lookups in profiles).
#[inline]
pub(crate) fn fast_cbrt(x: f32) -> f32 {
    if x <= 0.0 {
        return 0.0;
    }
    let mut y = f32::from_bits(x.to_bits() / 3 + 0x2a51_4067);
    y = (2.0 * y + x / (y * y)) * (1.0 / 3.0);
    y = (2.0 * y + x / (y * y)) * (1.0 / 3.0);
    y
}

#[cfg(test)]
mod column_tests {
    use super::*;

    /// A render pays only for its roughnesses: one lookup computes the two columns it reads, and
    /// the values are those of the columns computed directly.
    #[test]
    fn columns_are_computed_on_demand() {
        let table = AlbedoTable { columns: [const { OnceLock::new() }; N_ALPHA] };
        assert_eq!(table.computed_columns(), 0);
        let tc = AlbedoTable::coordinate(0.3);
        let v = table.lookup(0.5, tc);
        assert_eq!(table.computed_columns(), 2);
        let _ = table.average(tc);
        assert_eq!(table.computed_columns(), 2);
        let (j, _) = AlbedoTable::locate(tc, N_ALPHA);
        let (a, b) = (Column::compute(j), Column::compute(j + 1));
        let (i, fi) = AlbedoTable::locate(fast_cbrt(0.5), N_MU);
        let (_, fj) = AlbedoTable::locate(tc, N_ALPHA);
        let lerp = |x: f32, y: f32, t: f32| x + (y - x) * t;
        let expect = lerp(lerp(a.ab[i][0], a.ab[i + 1][0], fi), lerp(b.ab[i][0], b.ab[i + 1][0], fi), fj);
        assert_eq!(v[0], expect);
        let _ = table.lookup(0.5, AlbedoTable::coordinate(1.0));
        assert_eq!(table.computed_columns(), 4);
    }
}

#[cfg(test)]
mod cbrt_tests {
    #[test]
    fn fast_cbrt_matches_libm() {
        let mut worst = 0.0f32;
        for i in 0..=100_000 {
            let x = i as f32 / 100_000.0;
            let (a, b) = (super::fast_cbrt(x), x.cbrt());
            worst = worst.max((a - b).abs() / b.max(1e-30));
        }
        assert!(worst < 1e-5, "worst relative error {worst}");
        assert_eq!(super::fast_cbrt(0.0), 0.0);
        assert!((super::fast_cbrt(1e-30) - 1e-10).abs() < 1e-15);
    }
}
