//! Strong secondary lights (`strong-secondary-lighting.md`, Tawara, Myszkowski & Seidel): the global
//! photons are split between a *low-energy* and a *high-energy* photon map by a voxel grid with a
//! photon counter per voxel (§3), and at render time the high-energy map is sampled explicitly, like a
//! light source, by rays toward random points in its voxels (Eq. 3–5), while the low-energy map is
//! gathered by a few stratified rays.
//!
//! - [`split`] (`voxels.rs`): the voxel grid, the pilot's `E_avg = nΔΦ / A_total` (Eq. 2), the cap
//!   `c_max = E_max·A / ΔΦ` (Eq. 1) and the split itself;
//! - [`gather`] (`gather.rs`): the per-point estimator of irradiance (stratified cosine-weighted
//!   gather rays into the low-energy map + explicit rays toward the high-energy voxels);
//! - [`cache`] (`cache.rs`): Ward's irradiance cache over that estimator.
//!
//! See `docs/secondary-lights.md` for the design, the options and the measured figures.

pub mod cache;
pub mod gather;
pub mod voxels;

pub use cache::{CacheSettings, IrradianceCache};
pub use gather::{Allocation, GatherMaps, GatherSettings};
pub use voxels::{scene_area, split, HighVoxels, Split, SplitSettings, VoxelGrid};
