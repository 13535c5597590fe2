//! The C++ API: a `cxx` bridge (namespace `raysplat`) over the scene, render and image modules.
//!
//! - [`bridge`]: the `#[cxx::bridge]` declarations: plain shared structs (`RenderOptions`,
//!   `MaterialDesc`, `LightDesc`, `CameraDesc`, `MeshData`, …) and opaque Rust handles (`Scene`,
//!   `SceneBuilder`, `RenderResult`, `CancelToken`) owned in C++ through `rust::Box`.
//! - `api`: the implementations; every one runs under `catch_unwind` and returns `Result`, so Rust
//!   errors become `rust::Error` exceptions with the CLI's message and panics cannot abort the host.
//! - `names`: error messages in the API's words (C++ fields where the library names CLI flags).
//! - `convert`: exact conversions between the bridge structs and `scene` / `integrators` types.
//! - `progress`: `integrators::Progress` over a C++ `ProgressCallback` and a `CancelToken`.
//!
//! The C++ side (headers, CMake package, pkg-config file, examples, tests) is in `cpp/`; build and
//! usage are described in `docs/cpp.md`. `build.rs` (`cxx_bridge`) compiles the generated C++ and
//! writes the header and a link description next to the static library
//! (`target/<profile>/raysplat-cxx/include`, `target/<profile>/raysplat-link.txt`).

pub mod bridge;

mod api;
mod convert;
mod names;
mod progress;

pub use api::{CancelToken, FfiError, RenderResult, Scene, SceneBuilder};

/// Rust-side entry points of the bridge (the same functions C++ calls), for tests and tools.
pub mod functions {
    pub use super::api::{
        default_camera, default_light, default_material, default_options, default_texture, denoiser, load_scene, load_stage, methods,
        new_cancel_token, new_scene_builder, version,
    };
}

#[cfg(test)]
mod tests;
