//! raysplat — a global-illumination renderer built around photon density estimation.
//!
//! Module map (one concept per module, named for it):
//! - [`embree`]: the only module that talks to Embree (bindgen bindings + safe wrapper).
//! - [`scene`]: the scene description (`SceneDesc`), its file format and validation.
//! - [`usd`]: conversion of USD stages to the scene format through `usd-core`.
//! - [`bsdf`]: materials as BSDFs (sample / eval / pdf).
//! - [`light`]: emitters and the light sampler.
//! - [`sampling`]: random numbers and warping functions.
//! - [`image`]: film, EXR/PNG output, textures, image comparison.
//! - [`prepare`]: the render-time scene built from a `SceneDesc`.
//! - [`kdtree`]: the point kd-tree (sliding midpoint, 8-byte nodes) with k-NN, radius and cone queries.
//! - [`integrators`]: rendering methods (`pt`, ...).
//! - [`error`]: the one error type.

pub mod bsdf;
pub mod embree;
pub mod error;
pub mod image;
pub mod integrators;
pub mod kdtree;
pub mod light;
pub mod prepare;
pub mod sampling;
pub mod scene;
pub mod usd;

pub use error::{Error, Result};
