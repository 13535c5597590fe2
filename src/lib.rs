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
//! - [`eye`]: the eye pass (eye samples at primary hits, direct light by light sampling).
//! - [`photon`]: the light pass (photon rays with splat bandwidths) and classic photon maps.
//! - [`splat`]: photon ray splatting onto eye samples.
//! - [`secondary`]: strong secondary lights (low/high-energy photon maps, explicit voxel sampling, irradiance cache).
//! - [`subdiv`]: uniform refinement of subdivision surfaces (those Embree does not evaluate).
//! - [`kdtree`]: the point kd-tree (sliding midpoint, 8-byte nodes) with k-NN, radius and cone queries.
//! - [`integrators`]: rendering methods (`pt`, ...).
//! - [`ffi`]: the C++ API (a `cxx` bridge; C++ side in `cpp/`, see `docs/cpp.md`).
//! - [`error`]: the one error type.

pub mod bsdf;
pub mod embree;
pub mod error;
pub mod eye;
pub mod ffi;
pub mod gather;
pub mod image;
pub mod integrators;
pub mod kdtree;
pub mod light;
pub mod photon;
pub mod prepare;
pub mod radiance_cache;
pub mod radiance_filter;
pub mod radiance_map;
pub mod sampling;
pub mod scene;
pub mod sh;
pub mod secondary;
pub mod splat;
pub mod subdiv;
pub mod usd;

pub use error::{Error, Result};
