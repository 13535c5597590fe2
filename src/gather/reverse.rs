//! Reverse photons (`reverse-photon-mapping.md` §3.2): the hit of one final gather ray, 32 bytes —
//! position (12), RGB weight (12), compressed normal and incoming direction (2 + 2), pixel (4).
//!
//! The paper stores a 2-byte incoming direction and pads to 32 bytes; we use the two spare bytes
//! for the geometric normal at the hit (oriented toward where the gather ray came from), which the
//! photon filter needs (photons from behind, or on a surface facing another way, never contribute:
//! the same test as `photon::PhotonMap::estimate`). Both are 8 + 8-bit octahedral codes.
//!
//! The weight is everything the pixel multiplies the gathered radiance by: eye-sample throughput ×
//! `f·cos/pdf` of the gather direction / N × the Lambertian BSDF `albedo/π` at the gather hit (the
//! paper gathers diffuse indirect light: the BSDF at the hit is folded into the weight, so density
//! estimation needs only positions, normals and flux).

use crate::sampling::{oct_fold, oct_unfold};
use glam::Vec3;

/// One reverse photon: a final gather hit.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct ReversePhoton {
    pub p: [f32; 3],
    pub weight: [f32; 3],
    /// Geometric normal at the hit, toward the gather ray's origin (8 + 8-bit octahedral).
    pub n: u16,
    /// Direction toward the gather ray's origin (8 + 8-bit octahedral; kept for glossy gathering).
    pub wi: u16,
    pub pixel: u32,
}

const _: () = assert!(std::mem::size_of::<ReversePhoton>() == 32);

impl ReversePhoton {
    #[inline]
    pub fn pos(&self) -> Vec3 {
        Vec3::from(self.p)
    }
    #[inline]
    pub fn weight(&self) -> Vec3 {
        Vec3::from(self.weight)
    }
    #[inline]
    pub fn normal(&self) -> Vec3 {
        oct16_decode(self.n)
    }
    #[inline]
    pub fn incoming(&self) -> Vec3 {
        oct16_decode(self.wi)
    }
    /// Jensen's photon filter: a photon arriving from direction `wi` (away from its surface) on a
    /// surface with normal `n_photon` lights this hit only if it arrives from the front and lies on a
    /// surface facing the same way.
    #[inline]
    pub fn accepts(n: Vec3, wi: Vec3, n_photon: Vec3) -> bool {
        wi.dot(n) > 0.0 && n_photon.dot(n) > 1e-3
    }
}

/// Encode a unit vector in 16 bits (octahedral, 8 bits per coordinate; error below 1°).
pub fn oct16_encode(v: Vec3) -> u16 {
    let p = oct_fold(v);
    let q = |x: f32| (((x.clamp(-1.0, 1.0) * 0.5 + 0.5) * 255.0).round() as u16) & 0xff;
    q(p.x) | (q(p.y) << 8)
}

/// Decode a 16-bit octahedral code.
pub fn oct16_decode(e: u16) -> Vec3 {
    let f = |x: u16| (x as f32 / 255.0) * 2.0 - 1.0;
    oct_unfold(f(e & 0xff), f(e >> 8))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{square_to_uniform_sphere, Rng};

    #[test]
    fn oct16_round_trip_within_one_degree() {
        let mut rng = Rng::new(7, 0);
        let mut worst = 1.0f32;
        for _ in 0..20_000 {
            let v = square_to_uniform_sphere(rng.next_2d());
            worst = worst.min(oct16_decode(oct16_encode(v)).dot(v));
        }
        for v in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z] {
            worst = worst.min(oct16_decode(oct16_encode(v)).dot(v));
        }
        assert!(worst > 1f32.to_radians().cos(), "worst cosine {worst}");
    }
}
