//! Photon methods under a wall-clock budget (`--time`): independent passes — new eye samples and new
//! photons, each pass seeded by `hash(seed, pass)` — averaged until the budget is spent (at least one
//! pass; another starts only if the mean pass time says it will end within the budget).
//!
//! Averaging passes lowers the noise of everything a pass estimates (anti-aliasing, the direct light
//! of the eye pass, the photon noise of the density estimates) as 1/passes; it does not lower the
//! bias of the density estimation, which is set by the bandwidth (`--photons`, `--knn`, `-C`, …) of
//! each pass. The image depends on the number of passes, which depends on the machine: for a
//! reproducible image give `--spp`/`--photons` instead of `--time`.

use super::{Progress, RenderSettings, Stats};
use crate::error::{Error, Result};
use crate::image::Film;
use crate::prepare::PreparedScene;
use crate::sampling::hash;
use std::time::Instant;

/// Stream tag of the per-pass seeds.
const PASS_STREAM: u64 = 0x7061_7373; // "pass"

/// Seed of pass `k` (pass 0 keeps the user's seed: a one-pass render equals the untimed render).
pub fn pass_seed(seed: u64, k: u32) -> u64 {
    if k == 0 {
        seed
    } else {
        hash(&[seed, PASS_STREAM, k as u64])
    }
}

type PassFn<'a> = dyn Fn(&PreparedScene, &RenderSettings, &dyn Progress, &mut Stats) -> Result<Film> + 'a;

/// Render passes of `one` until `budget` seconds (counted from `start`) are spent.
pub fn render(
    scene: &PreparedScene,
    s: &RenderSettings,
    budget: f64,
    start: Instant,
    progress: &dyn Progress,
    stats: &mut Stats,
    one: &PassFn<'_>,
) -> Result<Film> {
    let single = RenderSettings { time_budget: None, ..s.clone() };
    let t = Instant::now();
    let mut sum = one(scene, &single, progress, stats)?;
    let mut passes = 1u32;
    loop {
        let elapsed = start.elapsed().as_secs_f64();
        let per_pass = t.elapsed().as_secs_f64() / passes as f64;
        if elapsed + per_pass > budget || passes == u32::MAX {
            break;
        }
        if progress.cancelled() {
            return Err(Error::Cancelled);
        }
        let mut pass_stats = Stats::default();
        let si = RenderSettings { seed: pass_seed(s.seed, passes), ..single.clone() };
        let film = one(scene, &si, progress, &mut pass_stats)?;
        accumulate(&mut sum, &film);
        merge(stats, &pass_stats);
        passes += 1;
    }
    finish(&mut sum, passes);
    stats.count("passes", passes as u64);
    Ok(sum)
}

/// Add `f` into `sum`; the depth layer keeps the nearest non-zero depth (as the path tracer does).
fn accumulate(sum: &mut Film, f: &Film) {
    for (a, b) in sum.layers.iter_mut().zip(&f.layers) {
        debug_assert_eq!(a.name, b.name);
        if a.name == "depth" {
            for (x, &y) in a.data.iter_mut().zip(&b.data) {
                if y > 0.0 && (*x == 0.0 || y < *x) {
                    *x = y;
                }
            }
        } else {
            for (x, &y) in a.data.iter_mut().zip(&b.data) {
                *x += y;
            }
        }
    }
}

fn finish(sum: &mut Film, passes: u32) {
    let inv = 1.0 / passes as f32;
    for l in sum.layers.iter_mut().filter(|l| l.name != "depth") {
        l.data.iter_mut().for_each(|x| *x *= inv);
    }
}

/// Phase times and counters of later passes add to the first pass's (same names).
fn merge(stats: &mut Stats, pass: &Stats) {
    for (name, secs) in &pass.phases {
        match stats.phases.iter_mut().find(|(n, _)| n == name) {
            Some((_, t)) => *t += secs,
            None => stats.phases.push((name.clone(), *secs)),
        }
    }
    for (name, v) in &pass.counters {
        match stats.counters.iter_mut().find(|(n, _)| n == name) {
            Some((_, c)) => *c += v,
            None => stats.counters.push((name.clone(), *v)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Layer;

    fn film(v: f32, depth: f32) -> Film {
        let mut f = Film::new(1, 1);
        f.layers.push(Layer { name: String::new(), channels: vec!["R".into()], data: vec![v] });
        f.layers.push(Layer { name: "depth".into(), channels: vec!["Z".into()], data: vec![depth] });
        f
    }

    #[test]
    fn passes_average_and_keep_the_nearest_depth() {
        let mut sum = film(1.0, 0.0);
        accumulate(&mut sum, &film(2.0, 5.0));
        accumulate(&mut sum, &film(6.0, 3.0));
        finish(&mut sum, 3);
        assert_eq!(sum.layers[0].data, vec![3.0]);
        assert_eq!(sum.layers[1].data, vec![3.0]);
    }

    #[test]
    fn pass_seeds_differ_and_pass_zero_is_the_seed() {
        assert_eq!(pass_seed(42, 0), 42);
        let s: std::collections::HashSet<u64> = (0..1000).map(|k| pass_seed(42, k)).collect();
        assert_eq!(s.len(), 1000);
    }
}
