//! The memory task scheduler (`reverse-photon-mapping.md` §5.1): from the memory budget, the
//! number of eye samples (resolution × samples per pixel) and the final gather rays per sample, plan
//! a sequence of tasks — splits of the gather rays first, then bands of eye samples (image tiles of
//! whole rows, eye samples being in pixel order) — so that the gather stage stays within the budget:
//! one task's `A_r + A_w`, the gather rays being traced and the reverse-photon-map blocks being
//! searched (see [`plan`]). Photons are traced once, before the first task, and
//! reused by all. Tasks are ordered for a progressive preview: every ray split covers the whole
//! image before the next one starts.
//!
//! Gather ray `k` of eye sample `e` is the same ray whichever task traces it (see `rays`), so a
//! split render sums exactly the same terms as an unsplit one.

pub use super::rays::TRACE_BYTES_PER_RAY;
use super::rays::window_samples;
use super::rpm::{BLOCK, BLOCK_BYTES_PER_REVERSE_PHOTON};
use crate::error::{Error, Result};
use std::ops::Range;

/// Bytes one gather ray costs for its whole task: its reverse photon in `A_r` (32) and its entry in
/// `A_w` (12), the paper's two arrays (Table 2).
pub const BYTES_PER_GATHER_RAY: u64 = 32 + 12;

/// Tasks above which a budgeted render without `--spill-dir` spills `A_r` to a temporary directory
/// instead of running the tasks in memory (§5.1 + §6.5). Measured (docs/final-gathering.md, "Figures:
/// tasks against spilling"): every task's reverse photon map is searched by every photon, so the
/// search grows with the tasks, while a spill's search costs what the unsplit one does plus the
/// writing and reading of `A_r`; the two break even at about this many tasks.
pub const AUTO_SPILL_TASKS: usize = 4;

/// One task: gather rays `rays` of the eye samples `samples`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Task {
    pub samples: Range<usize>,
    pub rays: Range<u32>,
}

/// The scheduler's plan: the tasks, the window of the ray shooting cache, the block size of the
/// reverse photon map and how many blocks may be searched at once.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Plan {
    pub tasks: Vec<Task>,
    /// Eye samples per window of the ray shooting cache (`rays::window_samples`): its rays in
    /// flight take at most a quarter of the budget.
    pub window: usize,
    /// Reverse photons per block. It never depends on the thread count: the blocks decide the
    /// order of each gather ray's sum, so the image would.
    pub block: usize,
    /// Blocks searched at once at most (the blocks in flight take at most a quarter of the budget;
    /// `usize::MAX`: no budget).
    pub flight: usize,
}

/// Blocks in flight a budget's block size is cut for: with more threads, blocks are searched in
/// waves of `flight` ([`Plan::flight`]), with fewer each thread takes several in turn.
pub const BLOCKS_IN_FLIGHT: u64 = 8;

/// Plan the tasks for `samples` eye samples with `rays` gather rays each within `budget` bytes
/// (`None`: one task). The budget is split: half for one task's `A_r + A_w`, a quarter for the
/// gather rays being traced, a quarter for the reverse photon map blocks being searched. Nothing
/// here depends on the thread count.
pub fn plan(samples: usize, rays: u32, budget: Option<u64>) -> Result<Plan> {
    let Some(budget) = budget else {
        return Ok(Plan { tasks: vec![Task { samples: 0..samples, rays: 0..rays }], window: window_samples(rays, u64::MAX), block: BLOCK, flight: usize::MAX });
    };
    let block = (budget / 4 / (BLOCKS_IN_FLIGHT * BLOCK_BYTES_PER_REVERSE_PHOTON)).clamp(1, BLOCK as u64) as usize;
    let flight = (budget / 4 / (block as u64 * BLOCK_BYTES_PER_REVERSE_PHOTON)).max(1) as usize;
    let cap = budget / 2 / BYTES_PER_GATHER_RAY;
    // Rays in flight: one window (not per thread); at least one eye sample's rays.
    let flight_rays = budget / 4 / TRACE_BYTES_PER_RAY;
    let ray_cap = flight_rays.max(1);
    if cap == 0 {
        return Err(Error::param("memory", format!("{budget} bytes cannot hold a single gather ray")));
    }
    let total = samples as u64 * rays as u64;
    if samples == 0 || (total <= cap && rays as u64 <= ray_cap) {
        return Ok(Plan { tasks: vec![Task { samples: 0..samples, rays: 0..rays }], window: window_samples(rays, flight_rays), block, flight });
    }
    // Split the gather rays first (each split is a full-image preview), then the eye samples.
    let splits = total.div_ceil(cap).max((rays as u64).div_ceil(ray_cap)).min(rays as u64) as u32;
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
    Ok(Plan { tasks, window: window_samples(per_split, flight_rays), block, flight })
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
        fn tasks_partition_the_gather_rays_within_budget(samples in 0usize..5000, rays in 1u32..700, budget in 1u64 << 20..64 << 20) {
            let p = plan(samples, rays, Some(budget)).unwrap();
            let tasks = p.tasks;
            prop_assert!(p.flight as u64 * p.block as u64 * BLOCK_BYTES_PER_REVERSE_PHOTON <= budget / 4);
            prop_assert!(p.flight as u64 >= BLOCKS_IN_FLIGHT);
            let mut covered = vec![0u8; samples * rays as usize];
            for t in &tasks {
                prop_assert!(t.samples.len() as u64 * t.rays.len() as u64 * BYTES_PER_GATHER_RAY <= budget / 2);
                // one window of eye samples is traced at once (none for no samples)
                let in_flight = p.window.min(t.samples.len()) as u64 * t.rays.len() as u64 * TRACE_BYTES_PER_RAY;
                prop_assert!(in_flight <= budget / 4 || t.rays.len() == 1, "{} B traced at once", in_flight);
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
        assert_eq!(plan(100, 64, None).unwrap().tasks.len(), 1);
        let t = plan(4000, 64, Some(2 * 4000 * 16 * BYTES_PER_GATHER_RAY)).unwrap().tasks;
        assert_eq!(t.len(), 4);
        assert!(t.iter().all(|t| t.samples == (0..4000)));
        assert_eq!(t[0].rays, 0..16);
        assert!(plan(1, 1, Some(10)).is_err());
    }
}
