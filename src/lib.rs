//! raysplat — a global-illumination renderer built around photon density estimation.
//!
//! The library renders; the command line (`cli/`, the `raysplat` binary), the C++ API ([`ffi`]) and
//! the paper tables (`bench/`, `raysplat-bench`) are front ends over it.
//!
//! Module map (one concept per module, named for it; each depends only on modules above it in the
//! data flow, `scripts/module_graph.py` lists the graph and checks it has no cycle):
//! - [`error`]: the one error type. [`io`]: the output rule of every writer, atomic file output,
//!   input checks, temporaries and their cleanup, OpenEXR's thread pool, the cache folder, sizes.
//! - [`memory`]: the memory budget (machine, process limits, control groups) and fallible buffers.
//! - [`scene`]: the scene description (`SceneDesc`), its file format and validation.
//! - [`usd`]: conversion of USD stages to the scene format through `usd-core`.
//! - [`image`]: film, EXR/PNG output, textures, image comparison.
//! - [`embree`]: the only module that talks to Embree (bindgen bindings + safe wrapper).
//! - [`sampling`]: random numbers and warping functions. [`bsdf`]: materials as BSDFs (sample /
//!   eval / pdf). [`light`]: emitters and the light sampler.
//! - [`subdiv`]: uniform refinement of subdivision surfaces (those Embree does not evaluate).
//! - [`prepare`]: the render-time scene built from a `SceneDesc`.
//! - [`kdtree`]: the point kd-tree (sliding midpoint, 8-byte nodes) with k-NN, radius and cone queries.
//! - [`eye`]: the eye pass (eye samples at primary hits, direct light by light sampling).
//! - [`photon`]: the light pass (photon rays with splat bandwidths) and classic photon maps.
//! - [`sh`]: spherical harmonics, bands 0–3. [`radiance_map`]: the per-pixel glossy radiance maps
//!   (SH, histogram) and the BSDFs' SH tables.
//! - [`splat`]: photon ray splatting onto eye samples. [`radiance_filter`]: the image-space
//!   radiance filter. [`radiance_cache`]: radiance caching in image space (`rs-rc`).
//! - [`gather`]: final gathering (gather rays, photon-map and reverse searches, memory schedule,
//!   spill). [`secondary`]: strong secondary lights (low/high-energy photon maps, explicit voxel
//!   sampling, irradiance cache).
//! - [`integrators`]: the rendering methods, their settings, and `auto`, which picks one.
//! - [`denoise`]: Intel Open Image Denoise on the beauty, guided by the albedo and normal AOVs
//!   (optional: linked when the build finds the library).
//! - [`ffi`]: the C++ API (a `cxx` bridge; C++ side in `cpp/`, see `docs/cpp.md`).
//!
//! `docs/papers.md` summarises the papers the methods follow and maps each to its module.

pub mod bsdf;
pub mod denoise;
pub mod embree;
pub mod error;
pub mod eye;
pub mod ffi;
pub mod gather;
pub mod image;
pub mod integrators;
pub mod io;
pub mod kdtree;
pub mod light;
pub mod memory;
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
