//! Stratified pixel positions: the first two dimensions of the Sobol sequence, Owen-scrambled and
//! shuffled per pixel with hash-based nested uniform scrambling (Burley 2020, "Practical Hash-based
//! Owen Scrambling", after Laine & Karras 2011).
//!
//! Sample `i` of a pixel is point `π(i)` of the Sobol sequence in two dimensions, where `π` is a
//! per-pixel nested uniform scramble of the index, and both coordinates are then Owen-scrambled with
//! per-pixel seeds. Nested scrambling of the index keeps aligned blocks together: the first `2^m`
//! samples of a pixel are one aligned block of `2^m` Sobol points, a (0, m, 2)-net, so every
//! elementary interval of area `2^-m` (e.g. the four quadrants for four samples, or the 4 × 4 grid for
//! sixteen) holds exactly one sample. Owen scrambling keeps that property and makes each point
//! uniform on the pixel, so estimates stay unbiased; pixels are decorrelated by their seeds.
//!
//! Against independent uniform positions this lowers the anti-aliasing noise of edges, which is what
//! limits the photon methods' error at a few eye samples per pixel (docs/architecture.md, "Pixel
//! sampling").

use glam::Vec2;

/// Direction numbers of Sobol's second dimension (primitive polynomial `x + 1`):
/// `v₀ = 2³¹`, `v_k = v_{k−1} ⊕ (v_{k−1} ≫ 1)`. The first dimension is the van der Corput sequence.
#[cfg(test)]
const DIM1: [u32; 32] = {
    let mut v = [0u32; 32];
    v[0] = 1 << 31;
    let mut k = 1;
    while k < 32 {
        v[k] = v[k - 1] ^ (v[k - 1] >> 1);
        k += 1;
    }
    v
};

/// Point `index` of the two-dimensional Sobol sequence, as 32-bit fixed-point fractions (reference
/// form, one XOR per set bit; the tests check [`sobol_dim1_reversed`] against it).
#[cfg(test)]
fn sobol2(index: u32) -> (u32, u32) {
    let x = index.reverse_bits();
    let mut y = 0u32;
    let mut i = index;
    let mut k = 0;
    while i != 0 {
        if i & 1 != 0 {
            y ^= DIM1[k];
        }
        i >>= 1;
        k += 1;
    }
    (x, y)
}

/// Sobol's second dimension of point `index`, bit-reversed (bit `j` is the fraction's bit `j + 1`
/// after the binary point), in five shift-XOR steps: its generator matrix is Pascal's triangle mod 2,
/// so by Lucas' theorem fraction bit `j` is the XOR of the index bits `k ⊇ j` (bitwise superset), a
/// superset transform over the five bits of the position.
#[inline]
fn sobol_dim1_reversed(index: u32) -> u32 {
    let mut a = index;
    a ^= (a >> 1) & 0x5555_5555;
    a ^= (a >> 2) & 0x3333_3333;
    a ^= (a >> 4) & 0x0f0f_0f0f;
    a ^= (a >> 8) & 0x00ff_00ff;
    a ^= (a >> 16) & 0x0000_ffff;
    a
}

/// Laine–Karras style hash permutation with Burley's constants: output bit `b` depends on input bits
/// `≤ b` only, so applied to bit-reversed values it is a nested uniform (Owen) scramble.
#[inline]
fn lk_permutation(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// `REV_BYTES[k][b]` is byte `b` with its bits reversed, shifted left by `8k`: x86 has no
/// bit-reversal instruction, and `u32::reverse_bits` takes 17; by table it is four loads and ORs, and
/// three for [`reversed_unit`] (a sample draws five to a dozen reversals).
static REV_BYTES: [[u32; 256]; 4] = {
    let mut t = [[0u32; 256]; 4];
    let mut b = 0;
    while b < 256 {
        let r = (b as u8).reverse_bits() as u32;
        t[0][b] = r;
        t[1][b] = r << 8;
        t[2][b] = r << 16;
        t[3][b] = r << 24;
        b += 1;
    }
    t
};

/// `x.reverse_bits()`, by table.
#[inline]
pub(crate) fn reverse(x: u32) -> u32 {
    REV_BYTES[3][(x & 0xff) as usize] | REV_BYTES[2][(x >> 8 & 0xff) as usize] | REV_BYTES[1][(x >> 16 & 0xff) as usize] | REV_BYTES[0][(x >> 24) as usize]
}

/// `u32_to_unit_f32(x.reverse_bits())`: the top 24 bits of the reversal are the low three bytes of
/// `x` reversed, so the top byte is not looked up.
#[inline]
fn reversed_unit(x: u32) -> f32 {
    let top24 = REV_BYTES[2][(x & 0xff) as usize] | REV_BYTES[1][(x >> 8 & 0xff) as usize] | REV_BYTES[0][(x >> 16 & 0xff) as usize];
    top24 as f32 * (1.0 / 16_777_216.0)
}

/// Nested uniform scramble of a 32-bit fixed-point fraction (or of an index, read bit-reversed).
#[cfg(test)]
fn owen_scramble(x: u32, seed: u32) -> u32 {
    lk_permutation(x.reverse_bits(), seed).reverse_bits()
}

/// 32-bit seeds of one pixel's scrambles, from a 64-bit pixel hash.
#[derive(Clone, Copy, Debug)]
pub struct PixelSampler {
    shuffle: u32,
    sx: u32,
    sy: u32,
}

impl PixelSampler {
    /// The sampler of pixel `pixel` for a render seed and a stream (each method that shoots camera
    /// rays has its own stream, so two renders never share pixel positions by accident).
    pub fn new(seed: u64, stream: u64, pixel: u64) -> PixelSampler {
        let h = super::hash(&[seed, stream, pixel]);
        let h2 = super::hash(&[h]);
        PixelSampler { shuffle: h as u32, sx: (h >> 32) as u32, sy: h2 as u32 }
    }

    /// A sampler whose three seeds are given (derived by the caller from a hash).
    #[inline]
    pub(crate) fn from_seeds(shuffle: u32, sx: u32, sy: u32) -> PixelSampler {
        PixelSampler { shuffle, sx, sy }
    }

    /// Position of sample `index` inside the pixel, in `[0, 1)²`.
    #[inline]
    pub fn sample(&self, index: u32) -> Vec2 {
        self.sample_reversed(reverse(index))
    }

    /// [`Self::sample`] of the index whose bits reversed are `rev_index`: a caller drawing many
    /// slots at one sample index reverses it once (x86 has no bit-reversal instruction).
    #[inline]
    pub(crate) fn sample_reversed(&self, rev_index: u32) -> Vec2 {
        // Owen-scrambling the Sobol point (x, y) = (rev(i), rev(a)) is rev(lk(rev(x))) = rev(lk(i)).
        let i = reverse(lk_permutation(rev_index, self.shuffle));
        Vec2::new(reversed_unit(lk_permutation(i, self.sx)), reversed_unit(lk_permutation(sobol_dim1_reversed(i), self.sy)))
    }

    /// The first coordinate of [`Self::sample`] alone: an Owen-scrambled van der Corput sequence.
    #[inline]
    pub fn sample_1d(&self, index: u32) -> f32 {
        self.sample_1d_reversed(reverse(index))
    }

    /// [`Self::sample_1d`] of the index whose bits reversed are `rev_index`.
    #[inline]
    pub(crate) fn sample_1d_reversed(&self, rev_index: u32) -> f32 {
        let i = reverse(lk_permutation(rev_index, self.shuffle));
        reversed_unit(lk_permutation(i, self.sx))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every elementary interval of area 2^-m (cells 2^a × 2^(m−a)) holds exactly one point.
    fn is_net(points: &[Vec2], m: u32) -> bool {
        (0..=m).all(|a| {
            let (nx, ny) = (1usize << a, 1usize << (m - a));
            let mut count = vec![0u32; nx * ny];
            for p in points {
                let (cx, cy) = ((p.x * nx as f32) as usize, (p.y * ny as f32) as usize);
                count[cy.min(ny - 1) * nx + cx.min(nx - 1)] += 1;
            }
            count.iter().all(|&c| c == 1)
        })
    }

    /// The shift-XOR form of the second dimension equals the direction-number sum, and the sampler
    /// equals the Owen scramble of the reference Sobol point.
    #[test]
    fn fast_second_dimension_matches_direction_numbers() {
        let mut v = 0x1234_5678u32;
        for k in 0..100_000u32 {
            v = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
            for i in [k, v, u32::MAX - k] {
                assert_eq!(sobol_dim1_reversed(i).reverse_bits(), sobol2(i).1, "index {i}");
            }
        }
        let s = PixelSampler::new(3, 4, 5);
        for i in 0..4096u32 {
            let (x, y) = sobol2(owen_scramble(i, s.shuffle));
            let (x, y) = (owen_scramble(x, s.sx), owen_scramble(y, s.sy));
            let p = Vec2::new(super::super::rng::u32_to_unit_f32(x), super::super::rng::u32_to_unit_f32(y));
            assert_eq!(s.sample(i), p);
            assert_eq!(s.sample_1d(i), p.x);
        }
    }

    /// The table reversals equal `u32::reverse_bits` (and its unit fraction) on every byte pattern
    /// and on a stream of words.
    #[test]
    fn table_reversal_matches_reverse_bits() {
        let mut v = 0x9e37_79b9u32;
        for k in 0..200_000u32 {
            v = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
            for x in [k, v, k << 24, k.wrapping_mul(0x0101_0101), u32::MAX - k] {
                assert_eq!(reverse(x), x.reverse_bits(), "{x:#x}");
                assert_eq!(reversed_unit(x).to_bits(), super::super::rng::u32_to_unit_f32(x.reverse_bits()).to_bits(), "{x:#x}");
            }
        }
    }

    #[test]
    fn plain_sobol_prefixes_are_nets() {
        for m in 0..=10 {
            let pts: Vec<Vec2> = (0..1u32 << m).map(|i| {
                let (x, y) = sobol2(i);
                Vec2::new(x as f32 / 4294967296.0, y as f32 / 4294967296.0)
            }).collect();
            assert!(is_net(&pts, m), "sobol prefix 2^{m}");
        }
    }

    #[test]
    fn every_pixels_first_power_of_two_samples_are_stratified() {
        for pixel in 0..200u64 {
            let s = PixelSampler::new(7, 0, pixel);
            for m in 0..=8 {
                let pts: Vec<Vec2> = (0..1u32 << m).map(|i| s.sample(i)).collect();
                assert!(pts.iter().all(|p| p.x >= 0.0 && p.x < 1.0 && p.y >= 0.0 && p.y < 1.0));
                assert!(is_net(&pts, m), "pixel {pixel}, 2^{m} samples");
                // and the next aligned block too (progressive rendering continues the sequence)
                let next: Vec<Vec2> = (1u32 << m..2u32 << m).map(|i| s.sample(i)).collect();
                assert!(is_net(&next, m), "pixel {pixel}, second block of 2^{m}");
            }
        }
    }

    /// Each sample index, over many pixels, is uniform on the square (chi-square on an 8 × 8 grid,
    /// 64 cells, 6400 pixels: the 0.1 % critical value of χ²(63) is 103.4).
    #[test]
    fn each_sample_is_uniform_over_pixels() {
        for index in [0u32, 1, 2, 3, 5, 16, 1000] {
            let mut count = [0u32; 64];
            let n = 6400;
            for pixel in 0..n {
                let p = PixelSampler::new(3, 0, pixel).sample(index);
                count[(p.y * 8.0) as usize * 8 + (p.x * 8.0) as usize] += 1;
            }
            let e = n as f64 / 64.0;
            let chi2: f64 = count.iter().map(|&c| (c as f64 - e).powi(2) / e).sum();
            assert!(chi2 < 103.4, "index {index}: chi2 {chi2:.1}");
        }
    }

    /// Different pixels get different point sets (scrambles are per pixel), and a pixel's points are
    /// distinct.
    #[test]
    fn pixels_are_decorrelated() {
        let a = PixelSampler::new(1, 0, 10);
        let b = PixelSampler::new(1, 0, 11);
        assert_ne!(a.sample(0), b.sample(0));
        let pts: Vec<Vec2> = (0..64).map(|i| a.sample(i)).collect();
        for i in 0..64 {
            for j in i + 1..64 {
                assert_ne!(pts[i], pts[j]);
            }
        }
    }
}
