//! The memory task scheduler (`reverse-photon-mapping.md` §5.1): from the memory budget, the
//! number of eye samples (resolution × samples per pixel) and the final gather rays per sample, plan
//! a sequence of tasks — splits of the gather rays first, then bands of eye samples (image tiles of
//! whole rows, eye samples being in pixel order) — so that the arrays of one task (`A_r`, `A_w` and
//! the ordering keys) stay within the budget. Photons are traced once, before the first task, and
//! reused by all. Tasks are ordered for a progressive preview: every ray split covers the whole
//! image before the next one starts.
//!
//! Gather ray `k` of eye sample `e` is the same ray whichever task traces it (see `rays`), so a
//! split render sums exactly the same terms as an unsplit one.

use crate::error::{Error, Result};
use std::ops::Range;

/// Bytes one gather ray costs while its task runs: the reverse photon in `A_r` (32), its entry in
/// `A_w` (12) and its Morton ordering key (16).
pub const BYTES_PER_GATHER_RAY: u64 = 32 + 12 + 16;

/// One task: gather rays `rays` of the eye samples `samples`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Task {
    pub samples: Range<usize>,
    pub rays: Range<u32>,
}

/// Plan the tasks for `samples` eye samples with `rays` gather rays each within `budget` bytes
/// (`None`: one task).
pub fn plan(samples: usize, rays: u32, budget: Option<u64>) -> Result<Vec<Task>> {
    let total = samples as u64 * rays as u64;
    let cap = match budget {
        None => u64::MAX,
        Some(b) => b / BYTES_PER_GATHER_RAY,
    };
    if total <= cap || samples == 0 {
        return Ok(vec![Task { samples: 0..samples, rays: 0..rays }]);
    }
    if cap == 0 {
        return Err(Error::param("memory", format!("{} bytes cannot hold a single gather ray ({BYTES_PER_GATHER_RAY} bytes)", budget.unwrap_or(0))));
    }
    // Split the gather rays first (each split is a full-image preview), then the eye samples.
    let splits = total.div_ceil(cap).min(rays as u64) as u32;
    let per_split = rays.div_ceil(splits);
    let band = (cap / per_split as u64).max(1) as usize;
    let mut tasks = Vec::new();
    let mut r0 = 0;
    while r0 < rays {
        let r1 = (r0 + per_split).min(rays);
        let mut s0 = 0;
        while s0 < samples {
            let s1 = (s0 + band).min(samples);
            tasks.push(Task { samples: s0..s1, rays: r0..r1 });
            s0 = s1;
        }
        r0 = r1;
    }
    Ok(tasks)
}

/// Largest number of gather rays of any task.
pub fn peak_rays(tasks: &[Task]) -> u64 {
    tasks.iter().map(|t| t.samples.len() as u64 * t.rays.len() as u64).max().unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Every (eye sample, gather ray) pair is in exactly one task, and every task fits.
        #[test]
        fn tasks_partition_the_gather_rays_within_budget(samples in 0usize..5000, rays in 1u32..700, budget in 60u64..2_000_000) {
            let tasks = plan(samples, rays, Some(budget)).unwrap();
            let mut covered = vec![0u8; samples * rays as usize];
            for t in &tasks {
                prop_assert!(t.samples.len() as u64 * t.rays.len() as u64 * BYTES_PER_GATHER_RAY <= budget);
                for s in t.samples.clone() {
                    for r in t.rays.clone() {
                        covered[s * rays as usize + r as usize] += 1;
                    }
                }
            }
            prop_assert!(covered.iter().all(|&c| c == 1));
        }
    }

    #[test]
    fn unconstrained_is_one_task_and_ray_splits_come_first() {
        assert_eq!(plan(100, 64, None).unwrap().len(), 1);
        let t = plan(100, 64, Some(100 * 16 * BYTES_PER_GATHER_RAY)).unwrap();
        assert_eq!(t.len(), 4);
        assert!(t.iter().all(|t| t.samples == (0..100)));
        assert_eq!(t[0].rays, 0..16);
        assert!(plan(1, 1, Some(10)).is_err());
    }
}
