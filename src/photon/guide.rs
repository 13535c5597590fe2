//! Guided photon emission: where in each emitter's position sample space `u1 ∈ [0,1)²` the paths
//! that produce stored photons start, learned while the light pass runs, and sampled from.
//!
//! The light pass picks an emitter by power and a uniform `u1` for the position (`Emitter::sample_le`:
//! the point on a distant or dome light's scene silhouette, or on an area light). On a scene like
//! Crytek Sponza most of the sun and sky lands on the roof and outer walls, and only the paths that
//! enter the atrium store indirect photons. The guide keeps, per *key* (an emitter, and for a dome
//! also a coarse bin of its direction sample `u2`, since the dome's position mapping turns with its
//! direction), a `MAX_RES²` histogram per class of the paths that stored at least one segment of the
//! class, each weighted by `1/q` (the density its `u1` was drawn with): an unbiased estimate of the
//! probability that a path from that cell stores something, whatever the guide was when the path
//! was traced. From it, a piecewise-constant density `q` over `[0,1)²` is built, proportional to that
//! probability, mixed half and half with the uniform density ([`UNIFORM`]): `u1` is warped through
//! it, the photon's flux divided by `q(u1)` and its path density `p̃` (bandwidth, Eq. 8) multiplied
//! by it. The estimator stays unbiased: every path's contribution is `f/p` with the density it was
//! drawn from, and no flux grows by more than `1/UNIFORM` = 2×.
//!
//! Why "stored anything" and not the number of stored segments, and why half uniform: at a fixed
//! photon budget, guiding moves photons toward the regions fed by the favoured cells. A region fed
//! by cells of density `q` gets `E_y[q] · E_y[1/q] ≥ 1` times the variance (Cauchy–Schwarz, `E_y`
//! over where its photons start): no cost if `q` is flat where paths yield, a large one if it
//! follows how *much* they yield (docs/architecture.md, "Guided photon emission", has the figures
//! on Crytek Sponza).
//!
//! The classes combine with weights `budget_k / Σ yield_k`: each class with a budget draws the
//! guide in proportion to its share of the budget, whether its photons are common (direct) or rare.
//!
//! Learning: the light pass's batches are traced with the guide as it stands, then their paths are
//! added in path order and the guide rebuilt, so it never depends on the thread count. A key's grid
//! grows with its data, `res² · EVENTS_PER_CELL ≤` its paths that stored something (8² … 64²);
//! below 8² cells' worth it stays uniform, and so does a key whose grid would not raise the yield
//! per path by [`MIN_GAIN`] (a light whose paths all store alike, like a Cornell box's ceiling lamp).

use crate::light::Emitter;
use crate::sampling::Distribution2D;
use glam::Vec2;

/// Finest grid side of a key's histogram (coarser grids sum blocks of it).
pub const MAX_RES: usize = 64;
/// Coarsest guided grid side.
const MIN_RES: usize = 8;
/// Yielding paths per cell a grid needs before it is used.
const EVENTS_PER_CELL: f64 = 8.0;
/// Weight of the uniform density in the mixture (a photon's flux grows by at most 1/UNIFORM).
pub const UNIFORM: f32 = 0.5;
/// A key is guided only if its grid is expected to raise the yield per path by this factor (the
/// rest is not worth the flux variance: a uniform yield learned from 8 paths per cell looks ~1.06).
const MIN_GAIN: f64 = 1.25;
/// Dome lights: bins per axis of the direction sample `u2` (each bin has its own grid).
const DOME_DIR_BINS: usize = 4;

/// Where a path started in the guide's terms: its key, the (warped) position sample, the density
/// it was drawn with and whether that came from a learned grid.
#[derive(Clone, Copy, Debug)]
pub struct PathStart {
    pub key: u32,
    pub u: Vec2,
    pub q: f32,
    pub guided: bool,
}

/// One key's statistics and current density.
#[derive(Clone)]
struct KeyGuide {
    /// Per class, `Σ 1/q` over the paths that stored a segment of the class, per cell of the
    /// `MAX_RES²` grid (row-major, row = `u.y`).
    sums: [Vec<f64>; 3],
    /// Paths that stored at least one segment of a budgeted class.
    events: u64,
    dist: Option<Distribution2D>,
}

/// What the guide learned (for the render summary).
#[derive(Clone, Copy, Debug, Default)]
pub struct GuideSummary {
    /// Keys with a grid in use, and their cells in total.
    pub grids: usize,
    pub cells: usize,
    /// Emitted paths traced with a guided `u1` (of [`super::PhotonSet::paths`]).
    pub guided_paths: u64,
    pub bytes: u64,
}

/// The emission guide of one light pass.
pub struct EmissionGuide {
    /// Per emitter: its first key and its number of direction bins per axis (1: one key).
    first_key: Vec<(u32, u32)>,
    keys: Vec<KeyGuide>,
    budget: [usize; 3],
}

impl EmissionGuide {
    /// An empty (uniform) guide for `emitters`, learning the classes with a budget.
    pub fn new(emitters: &[Emitter], budget: [usize; 3]) -> EmissionGuide {
        let mut first_key = Vec::with_capacity(emitters.len());
        let mut n = 0u32;
        for e in emitters {
            let bins = if matches!(e, Emitter::Dome { .. }) { DOME_DIR_BINS as u32 } else { 1 };
            first_key.push((n, bins));
            n += bins * bins;
        }
        let empty = KeyGuide { sums: [vec![], vec![], vec![]], events: 0, dist: None };
        EmissionGuide { first_key, keys: vec![empty; n as usize], budget }
    }

    /// The key of a path of emitter `li` with direction sample `u2`.
    fn key(&self, li: usize, u2: Vec2) -> u32 {
        let (first, bins) = self.first_key[li];
        if bins == 1 {
            return first;
        }
        let b = bins as f32;
        let (x, y) = (((u2.x * b) as u32).min(bins - 1), ((u2.y * b) as u32).min(bins - 1));
        first + y * bins + x
    }

    /// Warp the uniform position sample `u1` of emitter `li` (direction sample `u2`): the sample
    /// to use and its density (1 where the guide is still uniform).
    pub fn warp(&self, li: usize, u1: Vec2, u2: Vec2) -> PathStart {
        let key = self.key(li, u2);
        match &self.keys[key as usize].dist {
            Some(d) => {
                let (u, q) = d.sample(u1);
                PathStart { key, u, q, guided: true }
            }
            None => PathStart { key, u: u1, q: 1.0, guided: false },
        }
    }

    /// Add a traced path: where it started and how many segments of each class it stored (what
    /// counts is whether a class got any, see the module notes).
    pub fn record(&mut self, start: &PathStart, counts: [u32; 3]) {
        let budget = self.budget;
        let k = &mut self.keys[start.key as usize];
        let mut any = false;
        let cell = cell_of(start.u, MAX_RES);
        for c in 0..3 {
            if budget[c] == 0 || counts[c] == 0 {
                continue;
            }
            if k.sums[c].is_empty() {
                k.sums[c] = vec![0.0; MAX_RES * MAX_RES];
            }
            k.sums[c][cell] += 1.0 / start.q.max(1e-30) as f64;
            any = true;
        }
        k.events += any as u64;
    }

    /// Rebuild every key's density from the statistics so far.
    pub fn rebuild(&mut self) {
        // Class weights: each class with a budget draws the guide by its share of the budget.
        let mut totals = [0.0f64; 3];
        for k in &self.keys {
            for (c, t) in totals.iter_mut().enumerate() {
                *t += k.sums[c].iter().sum::<f64>();
            }
        }
        let class_w: [f64; 3] = std::array::from_fn(|c| if totals[c] > 0.0 { self.budget[c] as f64 / totals[c] } else { 0.0 });
        for k in &mut self.keys {
            let mut res = MAX_RES;
            while res >= MIN_RES && ((res * res) as f64 * EVENTS_PER_CELL) > k.events as f64 {
                res /= 2;
            }
            if res < MIN_RES {
                k.dist = None;
                continue;
            }
            let block = MAX_RES / res;
            let mut w = vec![0.0f64; res * res];
            for (c, sums) in k.sums.iter().enumerate() {
                if sums.is_empty() || class_w[c] == 0.0 {
                    continue;
                }
                for (i, &v) in sums.iter().enumerate() {
                    let (x, y) = (i % MAX_RES / block, i / MAX_RES / block);
                    w[y * res + x] += v * class_w[c];
                }
            }
            let sum: f64 = w.iter().sum();
            if !(sum > 0.0 && sum.is_finite()) {
                k.dist = None;
                continue;
            }
            let cells = (res * res) as f64;
            let mixed: Vec<f64> = w.iter().map(|&v| UNIFORM as f64 / cells + (1.0 - UNIFORM as f64) * v / sum).collect();
            // Expected yield per path with the guide over that without: Σ p_cell · q_cell.
            let gain: f64 = w.iter().zip(&mixed).map(|(&v, &m)| v / sum * m * cells).sum();
            k.dist = (gain >= MIN_GAIN).then(|| Distribution2D::new(&mixed.iter().map(|&m| m as f32).collect::<Vec<_>>(), res, res));
        }
    }

    /// Grids in use and their memory.
    pub fn summary(&self, guided_paths: u64) -> GuideSummary {
        let mut s = GuideSummary { guided_paths, ..Default::default() };
        for k in &self.keys {
            s.bytes += k.sums.iter().map(|v| (v.len() * 8) as u64).sum::<u64>();
            if let Some(d) = &k.dist {
                let (w, h) = d.resolution();
                s.grids += 1;
                s.cells += w * h;
                s.bytes += ((w * h) * 8 + h * 8) as u64;
            }
        }
        s
    }

    /// The density the guide samples `u` with for emitter `li`, direction sample `u2`.
    #[cfg(test)]
    pub fn pdf(&self, li: usize, u: Vec2, u2: Vec2) -> f32 {
        self.keys[self.key(li, u2) as usize].dist.as_ref().map_or(1.0, |d| d.pdf(u))
    }
}

fn cell_of(u: Vec2, res: usize) -> usize {
    let x = ((u.x * res as f32) as usize).min(res - 1);
    let y = ((u.y * res as f32) as usize).min(res - 1);
    y * res + x
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::chi2_test;
    use crate::sampling::{Frame, Rng};
    use glam::{Mat3, Vec3};

    fn sun() -> Emitter {
        let dir = Vec3::new(0.3, -1.0, 0.2).normalize();
        Emitter::Distant { dir, cos_max: 1.0, irradiance: Vec3::ONE, radiance: Vec3::ONE, frame: Frame::from_normal(-dir) }
    }

    fn dome() -> Emitter {
        Emitter::Dome { to_local: Mat3::IDENTITY, radiance: Vec3::ONE, texture: None, dist: None }
    }

    /// A yield that depends on where the path starts: indirect photons from a disc, fewer around it.
    fn yield_at(u: Vec2, rng: &mut Rng) -> [u32; 3] {
        let mean: f32 = if (u - Vec2::new(0.3, 0.6)).length() < 0.15 { 3.0 } else if u.x > 0.8 { 0.2 } else { 0.0 };
        // Integer counts with that mean.
        let n = mean as u32 + (rng.next_f32() < mean.fract()) as u32;
        [5, n, 0]
    }

    fn learn(g: &mut EmissionGuide, emitter: usize, n: usize, seed: u64) {
        let mut rng = Rng::new(seed, 7);
        for _ in 0..n {
            let st = g.warp(emitter, rng.next_2d(), rng.next_2d());
            let counts = yield_at(st.u, &mut rng);
            g.record(&st, counts);
        }
        g.rebuild();
    }

    /// The guide's density over a fine grid: cell integrals (the density is constant on cells of
    /// every grid side dividing `MAX_RES`).
    fn cell_masses(g: &EmissionGuide, li: usize, u2: Vec2) -> Vec<f64> {
        let r = MAX_RES;
        (0..r * r)
            .map(|i| {
                let u = Vec2::new(((i % r) as f32 + 0.5) / r as f32, ((i / r) as f32 + 0.5) / r as f32);
                g.pdf(li, u, u2) as f64 / (r * r) as f64
            })
            .collect()
    }

    #[test]
    fn warp_has_the_density_it_reports_and_it_integrates_to_one() {
        let mut g = EmissionGuide::new(&[sun()], [0, 1000, 0]);
        learn(&mut g, 0, 200_000, 1);
        let s = g.summary(0);
        // ~22 000 yielding paths: a 32² grid (64² needs 8 per cell, 32 768).
        assert_eq!((s.grids, s.cells), (1, 32 * 32), "{s:?}");
        let masses = cell_masses(&g, 0, Vec2::ZERO);
        let total: f64 = masses.iter().sum();
        assert!((total - 1.0).abs() < 1e-4, "density integrates to {total}");
        // Mixed with the uniform density: no sample's flux grows by more than 1/UNIFORM.
        let min = masses.iter().cloned().fold(f64::INFINITY, f64::min) * (MAX_RES * MAX_RES) as f64;
        assert!(min >= UNIFORM as f64 * (1.0 - 1e-4), "minimum density {min}");
        // The disc (always yields) gets q ≈ 0.5 + 0.5 / 0.11 ≈ 5, the strip (yields one time in
        // five; one cell's estimate from ~40 yielding paths) ≈ 1.4, the rest (never) exactly 0.5.
        let at = |x: f32, y: f32| g.pdf(0, Vec2::new(x, y), Vec2::ZERO);
        let (disc, strip, rest) = (at(0.3, 0.6), at(0.9, 0.2), at(0.6, 0.2));
        assert!(disc > 4.0 && disc < 6.0 && strip > 1.1 && strip < 2.0 && (rest - 0.5).abs() < 1e-5, "{disc} {strip} {rest}");
        // Warped samples land in [0,1)² with the reported density (chi-square over the grid).
        let mut rng = Rng::new(5, 5);
        let n = 400_000;
        let mut observed = vec![0.0; MAX_RES * MAX_RES];
        for _ in 0..n {
            let st = g.warp(0, rng.next_2d(), rng.next_2d());
            assert!((0.0..1.0).contains(&st.u.x) && (0.0..1.0).contains(&st.u.y), "{:?}", st.u);
            let p = g.pdf(0, st.u, Vec2::ZERO);
            assert!((st.q - p).abs() <= 1e-4 * p, "reported {} vs pdf {p}", st.q);
            observed[cell_of(st.u, MAX_RES)] += 1.0;
        }
        let expected: Vec<f64> = masses.iter().map(|m| m * n as f64).collect();
        let r = chi2_test(&observed, &expected, n, 5.0);
        assert!(r.p_value > 1e-3 && (r.integral - 1.0).abs() < 1e-4, "{r:?}");
    }

    /// Learning weights each path by 1/q: a guide learned from guided paths estimates the same
    /// yield as one learned from uniform paths (block masses agree within their noise).
    #[test]
    fn learning_from_guided_paths_estimates_the_same_yield() {
        let mut first = EmissionGuide::new(&[sun()], [0, 1000, 0]);
        learn(&mut first, 0, 100_000, 2);
        let mut fresh = EmissionGuide::new(&[sun()], [0, 1000, 0]);
        // Paths drawn from `first`'s density, recorded into `fresh`.
        let mut rng = Rng::new(3, 3);
        for _ in 0..100_000 {
            let st = first.warp(0, rng.next_2d(), rng.next_2d());
            fresh.record(&st, yield_at(st.u, &mut rng));
        }
        fresh.rebuild();
        let mut uniform = EmissionGuide::new(&[sun()], [0, 1000, 0]);
        learn(&mut uniform, 0, 400_000, 4);
        // Compare on 4×4 blocks (each well sampled): the disc's and the strip's shares.
        let block = |g: &EmissionGuide| -> Vec<f64> {
            let m = cell_masses(g, 0, Vec2::ZERO);
            let mut b = vec![0.0; 16];
            for (i, v) in m.iter().enumerate() {
                b[(i / MAX_RES * 4 / MAX_RES) * 4 + (i % MAX_RES) * 4 / MAX_RES] += v;
            }
            b
        };
        let (a, b) = (block(&fresh), block(&uniform));
        for i in 0..16 {
            assert!((a[i] - b[i]).abs() < 0.01 + 0.05 * b[i], "block {i}: guided-learned {} vs uniform-learned {}", a[i], b[i]);
        }
    }

    #[test]
    fn grids_grow_with_their_data_and_domes_bin_their_direction() {
        let mut g = EmissionGuide::new(&[sun(), dome()], [0, 1000, 0]);
        // Too few yielding paths for an 8×8 grid: uniform.
        learn(&mut g, 0, 1_000, 6);
        assert!(g.summary(0).grids == 0 && g.warp(0, Vec2::splat(0.3), Vec2::ZERO).q == 1.0);
        learn(&mut g, 0, 20_000, 7);
        let s = g.summary(0);
        assert!(s.grids == 1 && s.cells < MAX_RES * MAX_RES && s.cells >= MIN_RES * MIN_RES, "{s:?}");
        // The dome's direction bins learn separately: only the bin of u2 ≈ (0.1, 0.1) has data.
        let mut rng = Rng::new(8, 8);
        for _ in 0..20_000 {
            let st = g.warp(1, rng.next_2d(), Vec2::splat(0.1));
            let counts = yield_at(st.u, &mut rng);
            g.record(&st, counts);
        }
        g.rebuild();
        assert!(g.pdf(1, Vec2::new(0.3, 0.6), Vec2::splat(0.1)) > 2.0);
        assert_eq!(g.pdf(1, Vec2::new(0.3, 0.6), Vec2::splat(0.9)), 1.0);
        // A class without a budget is not learned: only direct counts here, and no direct budget.
        let mut h = EmissionGuide::new(&[sun()], [0, 1000, 0]);
        for i in 0..10_000 {
            h.record(&PathStart { key: 0, u: Vec2::new((i % 100) as f32 / 100.0, 0.5), q: 1.0, guided: false }, [3, 0, 0]);
        }
        h.rebuild();
        assert_eq!(h.summary(0).grids, 0);
    }
}
