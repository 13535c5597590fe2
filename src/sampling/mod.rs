//! Random numbers, hashing, shading frames, warping functions and tabulated distributions.
//!
//! - [`Rng`]: PCG32 (O'Neill). [`hash`] turns `(seed, pass, index)` into seeds/streams, so every
//!   render is a deterministic function of its inputs regardless of thread scheduling.
//! - [`Frame`]: orthonormal basis around a normal (Duff et al. 2017); local `z` is the normal.
//! - Warps `square_to_*` map `[0, 1)²` to disks, hemispheres, spheres, cones and triangles, each with
//!   its density (solid-angle densities are per steradian).
//! - [`Distribution1D`] / [`Distribution2D`]: piecewise-constant distributions for light selection
//!   and environment maps.
//! - [`PixelSampler`]: stratified pixel positions (Owen-scrambled Sobol, shuffled per pixel).
//! - [`PathSampler`]: the path tracer's decisions, one padded scrambled-Sobol slot per decision.
//! - [`power_heuristic`]: multiple importance sampling weights.
//! - [`oct_encode`] / [`oct_decode`]: unit vectors in 32 bits (octahedral mapping).
//!
//! Nothing here allocates except the distribution constructors.

mod distribution;
mod frame;
mod octahedral;
mod padded;
mod rng;
mod sobol;
mod warp;

#[cfg(test)]
pub(crate) mod chi2;
#[cfg(test)]
mod tests;

pub use distribution::{Distribution1D, Distribution2D};
pub use frame::Frame;
pub use octahedral::{oct_decode, oct_encode, oct_fold, oct_unfold};
pub use padded::{Decision, PathDecisions, PathSampler, PixelSlots, SlottedPathSampler, PADDED_BOUNCES};
pub use rng::{hash, Rng};
pub use sobol::PixelSampler;
pub use warp::{
    cosine_hemisphere_pdf, power_heuristic, square_to_cosine_hemisphere, square_to_uniform_cone,
    square_to_uniform_disk_concentric, square_to_uniform_hemisphere, square_to_uniform_sphere,
    square_to_uniform_triangle, uniform_cone_pdf, UNIFORM_HEMISPHERE_PDF, UNIFORM_SPHERE_PDF,
};
