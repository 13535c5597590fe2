//! Orthonormal shading frames.

use glam::Vec3;

/// Right-handed orthonormal basis `(s, t, n)` with `s × t = n`. Local coordinates have `z` along `n`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// First tangent.
    pub s: Vec3,
    /// Second tangent (`n × s`).
    pub t: Vec3,
    /// Normal (local `z`).
    pub n: Vec3,
}

impl Frame {
    /// Frame around the unit vector `n`, by the branchless construction of Duff et al. 2017
    /// ("Building an Orthonormal Basis, Revisited"); continuous except across `n.z = 0`'s sign flip
    /// and accurate for every unit `n`, including `±z`.
    pub fn from_normal(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// World vector `v` in this frame's coordinates.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local vector `v` in world coordinates.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}
