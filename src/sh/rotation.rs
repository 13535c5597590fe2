//! Rotation of band 0–3 coefficients by band matrices, for our basis (Sloan's ordering and signs,
//! [`super::eval`]): band 1 is a signed permutation of the 3 × 3 rotation, bands 2 and 3 follow from
//! Ivanic and Ruedenberg's recurrence (1996, with their 1998 corrections), unrolled into 266
//! products by `scripts/gen_sh_rotation.py` (`rotation_unrolled.rs`, generated).
//!
//! [`super::rotate`] does the same by re-projection at the 32 quadrature nodes. This is what the
//! final SH integration of every glossy eye sample uses ([`crate::radiance_map::BsdfShTable::integrate`]).

use super::rotation_unrolled::{band2, band3, band3_rows};
use super::N;
use glam::{Mat3, Vec3};

/// The band matrices `M_l` (row `m + l`, column `n + l`) of one rotation.
pub struct ShRotation {
    b1: [[f32; 3]; 3],
    b2: [[f32; 5]; 5],
    b3: [[f32; 7]; 7],
}

impl ShRotation {
    /// The band matrices that turn the coefficients of `g` into those of `d ↦ g(r · d)` (`r`
    /// orthonormal; for `g ∘ r⁻¹`, as [`super::rotate`], pass `r`'s transpose).
    #[inline]
    pub fn new(r: Mat3) -> ShRotation {
        let b1 = band1(r);
        let b2 = band2(&b1, &b1);
        let b3 = band3(&b1, &b2);
        ShRotation { b1, b2, b3 }
    }

    /// Rotated RGB coefficients.
    #[inline]
    pub fn apply(&self, c: &[Vec3; N]) -> [Vec3; N] {
        let mut out = [Vec3::ZERO; N];
        out[0] = c[0];
        for i in 0..3 {
            out[1 + i] = (0..3).fold(Vec3::ZERO, |a, j| a + c[1 + j] * self.b1[i][j]);
        }
        for i in 0..5 {
            out[4 + i] = (0..5).fold(Vec3::ZERO, |a, j| a + c[4 + j] * self.b2[i][j]);
        }
        for i in 0..7 {
            out[9 + i] = (0..7).fold(Vec3::ZERO, |a, j| a + c[9 + j] * self.b3[i][j]);
        }
        out
    }
}

/// Band 1 in the basis order (y, z, x) with the basis' signs (−y, z, −x): entries of rᵀ (the
/// function is evaluated at r·d), permuted and signed.
#[inline(always)]
fn band1(r: Mat3) -> [[f32; 3]; 3] {
    let t = |i: usize, j: usize| r.col(i)[j];
    [[t(1, 1), -t(1, 2), t(1, 0)], [-t(2, 1), t(2, 2), -t(2, 0)], [t(0, 1), -t(0, 2), t(0, 0)]]
}

/// The basis functions even in `y` and in `z` (1, x, 3z² − 1, x² − y², x(5z² − 1), x(x² − 3y²)):
/// the only ones with nonzero coefficients in the table of an isotropic lobe, which is projected
/// with `wo` in the xz plane and extended evenly below the surface ([`crate::radiance_map::BsdfShTable`]).
pub const EVEN_YZ: [usize; 6] = [0, 3, 6, 8, 13, 15];

/// `ShRotation::new(r).apply(c)` at the indices [`EVEN_YZ`] only, bit for bit: the band 3 matrix
/// is built for its two rows there (m = 1, 3), and only those six rows are applied (27 products
/// of RGB coefficients instead of 83).
#[inline]
pub fn rotate_even_yz(r: Mat3, c: &[Vec3; N]) -> [Vec3; 6] {
    let b1 = band1(r);
    let b2 = band2(&b1, &b1);
    let b3 = band3_rows(&b1, &b2);
    let row = |c: &[Vec3], m: &[f32]| c.iter().zip(m).fold(Vec3::ZERO, |a, (c, m)| a + *c * *m);
    [c[0], row(&c[1..4], &b1[2]), row(&c[4..9], &b2[2]), row(&c[4..9], &b2[4]), row(&c[9..16], &b3[0]), row(&c[9..16], &b3[1])]
}

#[cfg(test)]
mod tests {
    use super::super::{reconstruct_rgb, rotate};
    use super::*;
    use crate::sampling::{hash, Rng};

    /// [`rotate_even_yz`] gives the full rotation's coefficients at [`EVEN_YZ`], bit for bit.
    #[test]
    fn even_rows_are_the_full_rotations() {
        for k in 0..200u64 {
            let mut r = Rng::new(hash(&[73, k]), 0);
            let (a, b, c, d) = (r.next_f32() - 0.5, r.next_f32() - 0.5, r.next_f32() - 0.5, r.next_f32() - 0.5);
            let rot = Mat3::from_quat(glam::Quat::from_xyzw(a, b, c, d).normalize());
            let c: [Vec3; N] = std::array::from_fn(|_| Vec3::new(r.next_f32() - 0.5, r.next_f32() - 0.5, r.next_f32() - 0.5));
            let full = ShRotation::new(rot).apply(&c);
            assert_eq!(rotate_even_yz(rot, &c), EVEN_YZ.map(|k| full[k]), "rotation {k}");
        }
    }

    /// The rotated coefficients reconstruct `g(r·d)` at random directions, for the identity, axis
    /// permutations, half and quarter turns and random rotations with random coefficients, and
    /// agree with the quadrature re-projection of [`rotate`].
    #[test]
    fn band_matrices_rotate_the_function() {
        let mut worst = 0.0f32;
        for k in 0..300u64 {
            let mut r = Rng::new(hash(&[71, k]), 0);
            let rot = match k {
                0 => Mat3::IDENTITY,
                1 => Mat3::from_cols(Vec3::Y, Vec3::Z, Vec3::X),
                2 => Mat3::from_rotation_z(std::f32::consts::FRAC_PI_2),
                3 => Mat3::from_rotation_x(std::f32::consts::PI),
                _ => {
                    let (a, b, c, d) = (r.next_f32() - 0.5, r.next_f32() - 0.5, r.next_f32() - 0.5, r.next_f32() - 0.5);
                    Mat3::from_quat(glam::Quat::from_xyzw(a, b, c, d).normalize())
                }
            };
            let c: [Vec3; N] = std::array::from_fn(|_| Vec3::new(r.next_f32() - 0.5, r.next_f32() - 0.5, r.next_f32() - 0.5));
            let rc = ShRotation::new(rot).apply(&c);
            for _ in 0..20 {
                let d = Vec3::new(r.next_f32() - 0.5, r.next_f32() - 0.5, r.next_f32() - 0.5).normalize();
                let (got, want) = (reconstruct_rgb(&rc, d), reconstruct_rgb(&c, rot * d));
                worst = worst.max((got - want).abs().max_element());
            }
            let red: [f32; N] = std::array::from_fn(|i| c[i].x);
            let via = rotate(&red, rot.transpose());
            for i in 0..N {
                assert!((via[i] - rc[i].x).abs() < 1e-4, "rotation {k}, coefficient {i}: {} vs {}", rc[i].x, via[i]);
            }
        }
        assert!(worst < 1e-4, "largest reconstruction error {worst}");
    }
}
