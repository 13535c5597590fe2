//! The only module that talks to Embree: a small safe API over Debian's Embree 3, whose bindings
//! bindgen generates at build time (the private `sys` module), or, with the feature `embree4`,
//! over Embree 4 through `embree4-sys` (`sys4.rs`, under the same names). The two differ only in
//! their ray-query calls (`query3.rs`, `query4.rs`); the API and its tests are the same.
//!
//! - [`Device`]: an owned, reference-counted Embree device (`threads=` build-thread limit).
//! - [`SceneBuilder`]: prototype meshes (triangles, or Catmull–Clark subdivision surfaces
//!   tessellated at per-edge rates: [`SubdivisionMesh`]), their placements (instances) and
//!   optional cut-out filters; [`SceneBuilder::commit`] consumes it into a [`Scene`].
//! - [`Scene`]: `Send + Sync`; closest-hit and occlusion queries, single and batched; the limit
//!   surface and interpolated attributes of subdivision surfaces at a hit
//!   ([`Scene::surface_point`], [`Scene::attribute`]).
//! - [`set_flush_denormals`]: to be called at the start of every task that traces rays.
//! - `timing` (feature `embree-timing`): cycles spent inside Embree's queries, counted on request
//!   (for `raysplat-bench embree`).
//!
//! Nothing Embree-specific leaks out of this module.
//! Rays are always fully initialised (mask all ones, time 0, invalid IDs); Embree errors are
//! collected by a device error callback and checked after each build step, never per ray.

mod builder;
mod device;
mod scene;
mod subdivision;
#[cfg(not(feature = "embree4"))]
mod sys;
#[cfg(feature = "embree4")]
#[path = "sys4.rs"]
mod sys;
#[cfg(not(feature = "embree4"))]
#[path = "query3.rs"]
mod query;
#[cfg(feature = "embree4")]
#[path = "query4.rs"]
mod query;
#[cfg(feature = "embree-timing")]
pub mod timing;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_subdivision;

use glam::Vec3;

pub use builder::{FilterFn, SceneBuilder};
pub use device::Device;
pub use scene::Scene;
pub use subdivision::{SubdivAttribute, SubdivBoundary, SubdivisionMesh, SurfacePoint};

/// Index of a prototype mesh added with [`SceneBuilder::add_mesh`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MeshId(pub u32);

/// A ray (or segment): points `org + t·dir` for `t` in `[tnear, tfar]`. `dir` need not be
/// normalised; `t` is measured in units of `dir`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin.
    pub org: Vec3,
    /// Direction.
    pub dir: Vec3,
    /// Start of the valid interval.
    pub tnear: f32,
    /// End of the valid interval (`f32::INFINITY` for an unbounded ray).
    pub tfar: f32,
}

impl Ray {
    /// An unbounded ray: `tnear = 0`, `tfar = ∞`.
    pub fn new(org: Vec3, dir: Vec3) -> Ray {
        Ray {
            org,
            dir,
            tnear: 0.0,
            tfar: f32::INFINITY,
        }
    }

    /// The segment `t ∈ [tnear, tfar]` of the ray.
    pub fn segment(org: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> Ray {
        Ray {
            org,
            dir,
            tnear,
            tfar,
        }
    }
}

/// A ray–surface hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit point (`org + t·dir`).
    pub t: f32,
    /// Barycentric coordinate of vertex 1 (the hit point is `(1-u-v)·p0 + u·p1 + v·p2`); on a
    /// subdivision surface, the face's first parameter.
    pub u: f32,
    /// Barycentric coordinate of vertex 2; on a subdivision surface, the face's second parameter.
    pub v: f32,
    /// Instance index as returned by [`SceneBuilder::add_instance`].
    pub instance: u32,
    /// Triangle index within the instance's mesh (a subdivision surface: the face of its cage).
    pub prim: u32,
    /// World-space geometric normal, unnormalised, following the winding: the direction of
    /// `(p1 - p0) × (p2 - p0)` of the world-space triangle.
    pub ng: Vec3,
}

/// Set flush-to-zero and denormals-are-zero in this thread's MXCSR, as Embree recommends for
/// speed. MXCSR is per thread: call it at the start of every rayon task that traces rays
/// (cheap and idempotent). No-op on non-x86_64 targets.
pub fn set_flush_denormals() {
    #[cfg(target_arch = "x86_64")]
    {
        #[allow(deprecated)]
        // the intrinsics are deprecated in favour of inline asm, same effect
        use std::arch::x86_64::{_mm_getcsr, _mm_setcsr};
        const FTZ_DAZ: u32 = (1 << 15) | (1 << 6);
        // SAFETY: SSE is part of the x86_64 baseline. FTZ/DAZ only change how this thread's SSE
        // arithmetic treats denormals (they become 0); no memory safety is involved. Results on
        // denormals may differ from compile-time constant folding, which the renderer tolerates.
        #[allow(deprecated)]
        unsafe {
            let csr = _mm_getcsr();
            if csr & FTZ_DAZ != FTZ_DAZ {
                _mm_setcsr(csr | FTZ_DAZ);
            }
        }
    }
}
