//! PCG32 random numbers and 64-bit hashing for deterministic seeding.

use glam::Vec2;

const PCG_MULT: u64 = 0x5851_f42d_4c95_7f2d;

/// PCG32 (O'Neill 2014, `pcg32_srandom_r` / XSH-RR): a 64-bit LCG state with a 32-bit
/// xorshift-rotate output. Small (16 bytes), `Copy`, and with 2^63 independent streams.
///
/// Deterministic: the sequence is a function of `(seed, stream)` only. Renderers derive both from
/// [`hash`] of (scene seed, pass, pixel/photon index) so results do not depend on thread scheduling.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rng {
    state: u64,
    inc: u64,
}

impl Rng {
    /// Generator for `seed` on sequence `stream`. Streams are selected by the low 63 bits of
    /// `stream` (the increment is `stream << 1 | 1`), so streams differing only in bit 63 coincide;
    /// pass hashed values rather than raw counters when that matters.
    pub fn new(seed: u64, stream: u64) -> Rng {
        let mut rng = Rng { state: 0, inc: (stream << 1) | 1 };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    /// Next uniformly distributed 32-bit value.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(PCG_MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform float in `[0, 1)`: 24 random bits, so the largest value is `1 − 2⁻²⁴` (never 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        u32_to_unit_f32(self.next_u32())
    }

    /// Two uniform floats in `[0, 1)²`; `x` is drawn before `y`.
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        let x = self.next_f32();
        let y = self.next_f32();
        Vec2::new(x, y)
    }
}

/// Maps 32 random bits to `[0, 1)` using the top 24 bits (exactly representable in `f32`).
#[inline]
pub(crate) fn u32_to_unit_f32(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Stafford's "Mix13" finaliser of SplitMix64 / MurmurHash3: a bijection on `u64` with full avalanche.
#[inline]
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Strong 64-bit hash of a sequence of values, for per-pixel / per-photon seeds
/// (`hash(&[seed, pass, index])`).
///
/// Each value is mixed into a running state with the SplitMix64 finaliser, position-dependently
/// (order matters: `hash(&[a, b]) != hash(&[b, a])` in general) and length-dependently
/// (`hash(&[]) != hash(&[0])`). Not cryptographic.
pub fn hash(values: &[u64]) -> u64 {
    const GOLDEN: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut h = mix64(0x243f_6a88_85a3_08d3 ^ (values.len() as u64).wrapping_mul(GOLDEN));
    for &v in values {
        h = mix64(h.rotate_left(29) ^ mix64(v.wrapping_add(GOLDEN)));
    }
    mix64(h.wrapping_add(GOLDEN))
}
