//! The light pass: photons emitted in proportion to light power, scattered by BSDF importance
//! sampling with Russian roulette, specular bounces followed. Every path segment `x_i → x_{i+1}` is
//! stored as a compact [`PhotonRay`] (origin, direction, length, flux, and the splat bandwidth of
//! photon ray splatting, §6 of `photon-ray-splatting.md`), in one of three classes with separate
//! budgets: direct (first segment from the light), caustic (after specular bounces only) and indirect.
//!
//! Determinism: path `j` draws from `Rng(hash(seed, PHOTON_STREAM, j))`; paths are traced in fixed
//! batches and stored in path order, so the photon set never depends on the thread count.

mod bandwidth;
mod guide;
mod map;
mod trace;

pub use bandwidth::{Bandwidth, BandwidthParams};
pub use guide::GuideSummary;
pub use map::{IrradianceMap, PhotonMap};
pub use trace::{trace_photons, trace_photons_cancellable};

use crate::sampling::{oct_decode, oct_encode};
use glam::Vec3;

/// Photon class (which budget a stored segment counts against).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PhotonClass {
    /// First segment from the light.
    Direct = 0,
    /// Segments after one or more diffuse or glossy bounces.
    Indirect = 1,
    /// Segments after specular bounces only (L S+ → ·).
    Caustic = 2,
}

pub const CLASSES: [PhotonClass; 3] = [PhotonClass::Direct, PhotonClass::Indirect, PhotonClass::Caustic];

/// A stored photon ray (48 bytes): the segment `origin → origin + dir·length`, the flux arriving at
/// its end, the splat cone (radius `h0 + dh·t` at distance `t` along the ray; zero for a ray that
/// ends on a purely specular surface, which splats nothing), the geometric normal
/// of the surface it left (oriented to the side it left toward: the splatting paper's third
/// feasibility test, "in front of the surface at the ray's origin") and of the surface it hit
/// (which bounds the splat footprint beyond the hit, see `splat`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct PhotonRay {
    pub origin: [f32; 3],
    /// Octahedral-encoded unit direction.
    pub dir: u32,
    pub length: f32,
    pub h0: f32,
    pub dh: f32,
    /// Flux (W) carried, already divided by the number of emitted paths of its class.
    pub flux: [f32; 3],
    /// Octahedral-encoded geometric normal at the hit.
    pub n_hit: u32,
    /// Octahedral-encoded geometric normal at the origin, on the side the ray leaves toward (for a
    /// photon leaving a light with no surface, the ray direction).
    pub n_origin: u32,
}

const _: () = assert!(std::mem::size_of::<PhotonRay>() == 48);

impl PhotonRay {
    #[inline]
    pub fn origin(&self) -> Vec3 {
        Vec3::from(self.origin)
    }
    #[inline]
    pub fn dir(&self) -> Vec3 {
        oct_decode(self.dir)
    }
    #[inline]
    pub fn end(&self) -> Vec3 {
        self.origin() + self.dir() * self.length
    }
    #[inline]
    pub fn hit_normal(&self) -> Vec3 {
        oct_decode(self.n_hit)
    }
    #[inline]
    pub fn origin_normal(&self) -> Vec3 {
        oct_decode(self.n_origin)
    }
    #[inline]
    pub fn flux(&self) -> Vec3 {
        Vec3::from(self.flux)
    }
    /// Splat radius at distance `t` along the ray.
    #[inline]
    pub fn radius_at(&self, t: f32) -> f32 {
        self.h0 + self.dh * t
    }
    pub fn new(origin: Vec3, dir: Vec3, length: f32, flux: Vec3, n_origin: Vec3, n_hit: Vec3) -> PhotonRay {
        PhotonRay {
            origin: origin.to_array(),
            dir: oct_encode(dir),
            length,
            h0: 0.0,
            dh: 0.0,
            flux: flux.to_array(),
            n_hit: oct_encode(n_hit),
            n_origin: oct_encode(n_origin),
        }
    }
}

/// Settings of the light pass.
#[derive(Clone, Debug)]
pub struct PhotonSettings {
    /// Stored photon budget per class (direct, indirect, caustic).
    pub budget: [usize; 3],
    pub seed: u64,
    pub max_depth: u32,
    /// Bandwidth selection (smoothness C, sensitivity S, maximum bandwidth R).
    pub bandwidth: BandwidthParams,
    /// Give up on a class after this many emitted paths per budgeted photon (rare classes).
    pub max_paths_per_photon: usize,
    /// Guided emission: draw each emitter's position sample from where paths that store photons
    /// start (learned during the pass, see `guide`).
    pub emission_guiding: bool,
    /// The eye samples the photon rays are splatted onto (`rs`, `rs-rc`): a ray that leaves the
    /// scene is then stored where it passes them, beside the budget. Ray splatting estimates the
    /// light passing near an eye sample; without those rays every eye sample near a silhouette (as
    /// a photon sees it) misses the light that passes it into the sky (`photon::trace`).
    pub reach: Option<std::sync::Arc<crate::splat::Reach>>,
}

impl Default for PhotonSettings {
    fn default() -> Self {
        PhotonSettings {
            budget: [0, 100_000, 0],
            seed: 0,
            max_depth: 64,
            bandwidth: BandwidthParams::default(),
            max_paths_per_photon: 64,
            emission_guiding: true,
            reach: None,
        }
    }
}

/// The photons of one light pass, per class, with their hit information.
#[derive(Default)]
pub struct PhotonSet {
    pub rays: [Vec<PhotonRay>; 3],
    /// Whether each stored ray ends on a surface with a non-specular lobe (photon maps store only
    /// those, and only those splat).
    pub ends_diffuse: [Vec<bool>; 3],
    /// Emitted paths each class's flux was divided by.
    pub emitted: [u64; 3],
    /// Rays of each class stored beside its budget: those that leave the scene past the eye
    /// samples ([`PhotonSettings::reach`]).
    pub leaving: [usize; 3],
    /// Paths traced in total (pilot excluded).
    pub paths: u64,
    /// Bandwidth statistics from the pilot.
    pub bandwidth: Bandwidth,
    /// What guided emission learned (`None`: off).
    pub guide: Option<GuideSummary>,
}

impl PhotonSet {
    pub fn len(&self) -> usize {
        self.rays.iter().map(Vec::len).sum()
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    pub fn bytes(&self) -> u64 {
        (self.len() * (std::mem::size_of::<PhotonRay>() + 1)) as u64
    }
    /// Iterate over all stored photon rays of all classes.
    pub fn all(&self) -> impl Iterator<Item = &PhotonRay> {
        self.rays.iter().flatten()
    }
}
