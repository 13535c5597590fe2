//! Unit vectors packed into 32 bits (two 16-bit octahedral coordinates; max error ≈ 0.003°), used
//! for the compact photon rays, eye samples and reverse photons.

use glam::{Vec2, Vec3};

fn sign_not_zero(v: f32) -> f32 {
    if v >= 0.0 {
        1.0
    } else {
        -1.0
    }
}

/// The octahedral map of a unit vector onto the square [-1, 1]² (the lower hemisphere folded out).
pub fn oct_fold(v: Vec3) -> Vec2 {
    let l1 = v.x.abs() + v.y.abs() + v.z.abs();
    let p = Vec2::new(v.x, v.y) / l1.max(1e-30);
    if v.z < 0.0 {
        Vec2::new((1.0 - p.y.abs()) * sign_not_zero(p.x), (1.0 - p.x.abs()) * sign_not_zero(p.y))
    } else {
        p
    }
}

/// The unit vector of a point of [-1, 1]² (inverse of [`oct_fold`]).
pub fn oct_unfold(x: f32, y: f32) -> Vec3 {
    let z = 1.0 - x.abs() - y.abs();
    let t = (-z).max(0.0);
    Vec3::new(x - t * sign_not_zero(x), y - t * sign_not_zero(y), z).normalize()
}

/// Encode a unit vector.
pub fn oct_encode(v: Vec3) -> u32 {
    let p = oct_fold(v);
    let q = |x: f32| (((x.clamp(-1.0, 1.0) * 0.5 + 0.5) * 65535.0).round() as u32) & 0xffff;
    q(p.x) | (q(p.y) << 16)
}

/// Decode to a unit vector.
pub fn oct_decode(e: u32) -> Vec3 {
    let f = |x: u32| (x as f32 / 65535.0) * 2.0 - 1.0;
    oct_unfold(f(e & 0xffff), f(e >> 16))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Angle between two directions in degrees, accurate for tiny angles (f64, atan2 of |a×b| and
    /// a·b; `acos` of an f32 dot product cannot resolve angles below ~0.02°).
    fn angle_deg(a: Vec3, b: Vec3) -> f64 {
        let (a, b) = (a.as_dvec3().normalize(), b.as_dvec3().normalize());
        a.cross(b).length().atan2(a.dot(b)).to_degrees()
    }

    #[test]
    fn round_trip_error_is_tiny_everywhere() {
        let mut worst = 0.0f64;
        for i in 0..200 {
            for j in 0..400 {
                let th = (i as f32 + 0.5) / 200.0 * std::f32::consts::PI;
                let ph = j as f32 / 400.0 * 2.0 * std::f32::consts::PI;
                let v = Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
                worst = worst.max(angle_deg(oct_decode(oct_encode(v)), v));
            }
        }
        for v in [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z] {
            worst = worst.max(angle_deg(oct_decode(oct_encode(v)), v));
        }
        assert!(worst < 0.005, "worst error {worst}°");
    }
}
