//! Final gathering (`reverse-photon-mapping.md`, §8.4 of `photon-ray-splatting.md`): the stage
//! shared by `pm-fg`, `rpm-fg` and `rs-fg`.
//!
//! - [`rays`]: N final gather rays per primary eye sample, BSDF importance sampled, deterministic
//!   per (seed, eye sample, ray), traced through Embree's batched path; their hits are
//!   [`ReversePhoton`]s (32 bytes, the array `A_r`).
//! - [`forward`]: normal photon mapping — a search in the global photon map per gather hit (Eq. 2).
//! - [`rpm`]: reverse photon mapping — a search in the kd-tree over `A_r` per photon (Eq. 3), in
//!   photon-tree order, batched, into the write-back array `A_w`.
//! - [`density_control`]: thinning the photon map to a density limit (§6.2), `--density-limit`.
//! - [`schedule`]: the memory task scheduler (§5.1).
//! - [`spill`]: the external-memory cache of `A_r` (§6.5), `--spill-dir`.
//! - [`complete`]: the completion phase (§5.2): `A_w × weight` summed into pixels in `A_r` order.

pub mod density_control;
pub mod forward;
pub mod rays;
pub mod reverse;
pub mod rpm;
mod rpm_leaf;
pub mod schedule;
pub mod spill;

pub use rays::{trace_gather, GatherCounts};
pub use reverse::ReversePhoton;
pub use schedule::{plan, Task};

use crate::error::{Error, Result};
use glam::Vec3;

/// The density estimation kernel of final gathering (always a box kernel over a disc of radius R).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kernel {
    /// R = distance of the k-th nearest photon, at most `max_radius` (normal photon mapping).
    Knn { k: usize, max_radius: f32 },
    /// One radius for every estimate (metres).
    Fixed(f32),
    /// R from the photon's leaf in the photon kd-tree (§6.1), aiming at `k` photons per estimate.
    Adaptive { k: usize, max_radius: f32 },
}

/// Settings of the final-gathering methods.
#[derive(Clone, Debug, PartialEq)]
pub struct FgSettings {
    /// Final gather rays per eye sample (`--fg-rays`).
    pub rays: u32,
    /// A fixed kernel radius in metres instead of kNN (`pm-fg`) or the adaptive radius (`rpm-fg`).
    pub gather_radius: Option<f32>,
    /// Memory budget in bytes for one task's arrays (`--memory`); `None`: one task.
    pub memory: Option<u64>,
    /// Batched search in the reverse photon map (§6.3).
    pub batched: bool,
    /// Spill `A_r` to a temporary directory inside this one (§6.5; `--spill-dir`). Without it, a
    /// budgeted render that needs more than [`schedule::AUTO_SPILL_TASKS`] tasks spills into
    /// `std::env::temp_dir()` unless `no_spill` is set.
    pub spill_dir: Option<std::path::PathBuf>,
    /// Never spill automatically: a budget is met by tasks alone (`--no-spill`).
    pub no_spill: bool,
    /// Density control of the global photon map (§6.2; `--density-limit`, photons per m²).
    pub density_limit: Option<f32>,
}

impl Default for FgSettings {
    fn default() -> Self {
        FgSettings { rays: 64, gather_radius: None, memory: None, batched: true, spill_dir: None, no_spill: false, density_limit: None }
    }
}

impl FgSettings {
    pub fn validate(&self) -> Result<()> {
        if self.rays == 0 || self.rays > 1 << 16 {
            return Err(Error::param("fg-rays", format!("{} is out of range (1..=65536)", self.rays)));
        }
        if let Some(r) = self.gather_radius {
            if !(r.is_finite() && r > 0.0) {
                return Err(Error::param("gather-radius", format!("{r} must be a positive number of metres")));
            }
        }
        if let Some(d) = self.density_limit {
            if !(d.is_finite() && d > 0.0) {
                return Err(Error::param("density-limit", format!("{d} must be a positive number of photons per m²")));
            }
        }
        if self.no_spill && self.spill_dir.is_some() {
            return Err(Error::param("no-spill", "contradicts --spill-dir".to_string()));
        }
        if let Some(m) = self.memory {
            if m < 1 << 20 {
                return Err(Error::param("memory", format!("{m} bytes is below the minimum of 1M")));
            }
        }
        Ok(())
    }
}

/// Completion (§5.2): add `weight × radiance` of every reverse photon to its pixel, in `A_r` order.
pub fn complete(a_r: &[ReversePhoton], radiance: &[Vec3], pixels: &mut [Vec3]) {
    for (rp, l) in a_r.iter().zip(radiance) {
        pixels[rp.pixel as usize] += rp.weight() * *l;
    }
}

#[cfg(test)]
mod tests;
