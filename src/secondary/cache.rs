//! Ward's irradiance cache (Ward, Rubinstein & Clear 1988; the paper's Fig. 4): irradiance records
//! `(x_i, n_i, E_i, R_i)` with `R_i` the harmonic mean distance of the record's gather rays, reused
//! at points where the error estimate `ε(x) = |x − x_i| / R_i + sqrt(1 − n·n_i)` is below `ε`
//! (`--cache-error`), interpolated with weights `w_i = 1 / ε_i(x)`. Records in front of `x`
//! (`(x − x_i)·(n + n_i)/2 < −0.05 R_i`) are not used. No irradiance gradients.
//!
//! Determinism. Ward creates records lazily in pixel order, which is sequential. Here records are
//! created in rounds over the gather points (eye samples on Lambertian surfaces, in sample order):
//! every round (1) finds, in parallel against the cache so far, the points no record covers,
//! (2) picks among them greedily, in order, those farther than a separation `δ` from the points
//! already picked in this round (`δ` halves every round from `ε·R_max`; the last round picks every
//! uncovered point, and a point is always covered by its own record), (3) computes their records in
//! parallel, each from its own random stream, and appends them in order. The cache therefore never
//! depends on the thread count.
//!
//! `R_i` is clamped to `[R_min, R_max] = [0.002, 0.2] ×` the scene radius.

use crate::kdtree::{BuildParams, KdTree};
use glam::Vec3;
use rayon::prelude::*;
use std::collections::HashMap;

/// Rounds before the last one (which picks every uncovered point).
const ROUNDS: u32 = 10;
const R_MIN: f32 = 0.002;
const R_MAX: f32 = 0.2;
/// Parallel work items of fixed size (results do not depend on the thread count).
const CHUNK: usize = 256;

#[derive(Clone, Copy, Debug)]
pub struct CacheSettings {
    /// Error threshold ε.
    pub error: f32,
}

/// One record.
#[derive(Clone, Copy, Debug)]
pub struct Record {
    pub p: Vec3,
    pub n: Vec3,
    pub e: Vec3,
    pub r: f32,
}

/// The cache: records and a kd-tree over their positions.
pub struct IrradianceCache {
    pub records: Vec<Record>,
    tree: Option<KdTree>,
    pub error: f32,
    r_max: f32,
    pub rounds: u32,
}

impl IrradianceCache {
    pub fn bytes(&self) -> u64 {
        (self.records.len() * std::mem::size_of::<Record>()) as u64 + self.tree.as_ref().map_or(0, |t| t.stats().memory_bytes as u64)
    }

    /// Ward's weighted interpolation at `(p, n)`: `None` when no record is valid there.
    pub fn interpolate(&self, p: Vec3, n: Vec3) -> Option<Vec3> {
        let tree = self.tree.as_ref()?;
        let (mut sw, mut se) = (0.0f32, Vec3::ZERO);
        tree.for_each_in_radius(p, self.error * self.r_max, |i, _| {
            let r = &self.records[i as usize];
            let d = p - r.p;
            if d.dot(0.5 * (n + r.n)) < -0.05 * r.r {
                return;
            }
            let eps = d.length() / r.r + (1.0 - n.dot(r.n)).max(0.0).sqrt();
            if eps < self.error {
                let w = 1.0 / eps.max(1e-6);
                sw += w;
                se += w * r.e;
            }
        });
        (sw > 0.0).then(|| se / sw)
    }

    /// Build the cache over the gather points `(p, n)`; `compute(i)` returns the irradiance and the
    /// harmonic mean distance at point `i` (deterministic for a given `i`).
    pub fn build(points: &[(Vec3, Vec3)], scene_radius: f32, s: &CacheSettings, compute: &(dyn Fn(usize) -> (Vec3, f32) + Sync)) -> IrradianceCache {
        let (r_min, r_max) = (R_MIN * scene_radius, R_MAX * scene_radius);
        let mut cache = IrradianceCache { records: Vec::new(), tree: None, error: s.error, r_max, rounds: 0 };
        let mut pending: Vec<u32> = (0..points.len() as u32).collect();
        let mut delta = s.error * r_max;
        for round in 0..=ROUNDS {
            let uncovered: Vec<u32> = pending
                .par_chunks(CHUNK)
                .flat_map_iter(|c| {
                    c.iter().copied().filter(|&i| cache.interpolate(points[i as usize].0, points[i as usize].1).is_none()).collect::<Vec<_>>()
                })
                .collect();
            if uncovered.is_empty() {
                break;
            }
            cache.rounds = round + 1;
            let picked = if round == ROUNDS { uncovered.clone() } else { separate(points, &uncovered, delta) };
            let new: Vec<Record> = picked
                .par_chunks(CHUNK / 16)
                .flat_map_iter(|c| {
                    c.iter()
                        .map(|&i| {
                            let (p, n) = points[i as usize];
                            let (e, h) = compute(i as usize);
                            Record { p, n, e, r: if h.is_finite() { h.clamp(r_min, r_max) } else { r_max } }
                        })
                        .collect::<Vec<_>>()
                })
                .collect();
            cache.records.extend(new);
            let pos: Vec<Vec3> = cache.records.iter().map(|r| r.p).collect();
            cache.tree = KdTree::build(&pos, &BuildParams::default()).ok();
            pending = uncovered;
            delta *= 0.5;
        }
        cache
    }
}

/// Greedy in-order selection of points at least `delta` apart (or with normals more than ~25° apart).
fn separate(points: &[(Vec3, Vec3)], candidates: &[u32], delta: f32) -> Vec<u32> {
    let cell = |p: Vec3| ((p.x / delta).floor() as i64, (p.y / delta).floor() as i64, (p.z / delta).floor() as i64);
    let mut grid: HashMap<(i64, i64, i64), Vec<u32>> = HashMap::new();
    let mut out = Vec::new();
    for &i in candidates {
        let (p, n) = points[i as usize];
        let c = cell(p);
        let mut near = false;
        'search: for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    if let Some(v) = grid.get(&(c.0 + dx, c.1 + dy, c.2 + dz)) {
                        if v.iter().any(|&j| {
                            let (q, m) = points[j as usize];
                            (q - p).length_squared() < delta * delta && m.dot(n) > 0.9
                        }) {
                            near = true;
                            break 'search;
                        }
                    }
                }
            }
        }
        if !near {
            grid.entry(c).or_default().push(i);
            out.push(i);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth irradiance over a plane: the cache reproduces it within its error bound, covers
    /// every point, uses far fewer records than points, and does not depend on the thread count.
    #[test]
    fn cache_interpolates_a_smooth_field_deterministically() {
        let pts: Vec<(Vec3, Vec3)> = (0..4000)
            .map(|i| {
                let (x, z) = ((i % 64) as f32 / 63.0, (i / 64) as f32 / 63.0);
                (Vec3::new(x, 0.0, z), Vec3::Y)
            })
            .collect();
        let field = |p: Vec3| Vec3::splat(1.0 + 0.5 * p.x + 0.25 * p.z);
        let compute = |i: usize| (field(pts[i].0), 0.3f32);
        let s = CacheSettings { error: 0.3 };
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let a = one.install(|| IrradianceCache::build(&pts, 1.0, &s, &compute));
        let b = IrradianceCache::build(&pts, 1.0, &s, &compute);
        assert_eq!(a.records.len(), b.records.len());
        assert!(a.records.iter().zip(&b.records).all(|(x, y)| x.p == y.p));
        assert!(a.records.len() < pts.len() / 10, "{} records", a.records.len());
        for &(p, n) in &pts {
            let e = a.interpolate(p, n).expect("covered");
            // Within ε·R of a record the linear field changes by at most 0.5·0.09·√2.
            assert!((e - field(p)).abs().max_element() < 0.07, "{e} vs {}", field(p));
        }
    }
}
