//! Padded, scrambled Sobol samples for the path tracer's decisions along a path (light choice,
//! light position, lobe choice, BSDF direction, Russian roulette).
//!
//! Every decision of the first [`PADDED_BOUNCES`] bounces has its own *slot*: slot `d` of a pixel is
//! a [`PixelSampler`] of its own (its own index shuffle and scrambles), so the `2^m` samples of a
//! pixel are stratified in each slot's two dimensions — e.g. sixteen samples of an area light land
//! one per cell of a 4 × 4 grid of its parameter square — and slots are decorrelated from each other
//! and from the pixel position by their independent shuffles ("padding", Kollig & Keller 2002; the
//! shuffle is Burley's 2020 nested hash). One-dimensional decisions use the first coordinate, an
//! Owen-scrambled van der Corput sequence. Each sample is uniform, so estimates stay unbiased.
//!
//! Decisions deeper than the padded bounces draw from a PCG32 stream of the (pixel, sample) pair:
//! there the path's throughput is small and stratification buys little.

use super::{hash, PixelSampler, Rng};
use glam::Vec2;

/// Bounces whose decisions are stratified.
pub const PADDED_BOUNCES: u32 = 4;
/// Decision slots per bounce.
pub const SLOTS_PER_BOUNCE: u32 = 5;

/// The decisions of one bounce, each a slot of its own.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum Decision {
    /// Which light next-event estimation samples (1D).
    LightChoice = 0,
    /// The point on that light (2D).
    LightPoint = 1,
    /// Which BSDF lobe is sampled (1D).
    LobeChoice = 2,
    /// The sampled direction within the lobe (2D).
    BsdfDirection = 3,
    /// Russian roulette (1D).
    Roulette = 4,
}

/// Sample `index` of one pixel's path decisions.
#[derive(Clone, Debug)]
pub struct PathSampler {
    /// Hash of (seed, stream, pixel): the slots' seeds derive from it.
    base: u64,
    index: u32,
    /// The stream beyond the padded bounces, seeded on first use (most samplers, e.g. the eye
    /// pass's light samples, never reach it, and its seed is a 64-bit hash).
    rng: Option<Rng>,
}

impl PathSampler {
    /// Decisions of sample `index` of pixel `pixel`, for a render seed and a stream (the stream
    /// separates methods; each slot derives its own sub-stream from it).
    pub fn new(seed: u64, stream: u64, pixel: u64, index: u32) -> PathSampler {
        PathSampler::of_pixel_hash(Self::pixel_hash(seed, stream, pixel), index)
    }

    /// The pixel's hash that [`Self::of_pixel_hash`] takes: a renderer computes it once per pixel
    /// and reuses it for every sample.
    pub fn pixel_hash(seed: u64, stream: u64, pixel: u64) -> u64 {
        hash(&[seed, stream, pixel])
    }

    /// Sample `index` of the pixel whose hash is `base` (the same as [`Self::new`]).
    #[inline]
    pub fn of_pixel_hash(base: u64, index: u32) -> PathSampler {
        PathSampler { base, index, rng: None }
    }

    /// The stream beyond the padded bounces.
    #[inline]
    fn rng(&mut self) -> &mut Rng {
        let (base, index) = (self.base, self.index);
        self.rng.get_or_insert_with(|| Rng::new(hash(&[base, index as u64]), 0))
    }

    /// The sampler of slot `d` of `bounce` of the pixel whose hash is `base` (`None` beyond the
    /// padded bounces): its three scramble seeds from the pixel's hash and the slot number by a
    /// 32-bit integer hash (a few multiplies per decision instead of a 64-bit hash per pixel). It
    /// is the same for every sample of the pixel, so a renderer drawing many samples of one slot
    /// builds it once and asks it for each sample index
    /// (`slot_of(base, b, d)?.sample(i)` is `of_pixel_hash(base, i).get_2d(b, d)`, bit for bit).
    #[inline]
    pub fn slot_of(base: u64, bounce: u32, d: Decision) -> Option<PixelSampler> {
        Self::is_padded(bounce).then(|| {
            let slot = bounce * SLOTS_PER_BOUNCE + d as u32;
            let k = slot.wrapping_mul(0x9e37_79b9);
            let (lo, hi) = (base as u32, (base >> 32) as u32);
            PixelSampler::from_seeds(mix32(lo ^ k), mix32(hi ^ k), mix32(lo.rotate_left(16) ^ hi ^ k.wrapping_add(0x85eb_ca6b)))
        })
    }

    /// Whether the decisions at `bounce` have slots of their own: leaving one undrawn changes no
    /// other decision (deeper decisions share one stream, where it would).
    #[inline]
    pub fn is_padded(bounce: u32) -> bool {
        bounce < PADDED_BOUNCES
    }

    /// A uniform number in `[0, 1)` for decision `d` at `bounce`.
    #[inline]
    pub fn get_1d(&mut self, bounce: u32, d: Decision) -> f32 {
        match Self::slot_of(self.base, bounce, d) {
            Some(s) => s.sample_1d(self.index),
            None => self.rng().next_f32(),
        }
    }

    /// A uniform point in `[0, 1)²` for decision `d` at `bounce`.
    #[inline]
    pub fn get_2d(&mut self, bounce: u32, d: Decision) -> Vec2 {
        match Self::slot_of(self.base, bounce, d) {
            Some(s) => s.sample(self.index),
            None => self.rng().next_2d(),
        }
    }
}

/// The decisions of one path, a uniform number or point per (bounce, decision): what a path
/// tracer asks of its sampler ([`PathSampler`], or [`SlottedPathSampler`] with a pixel's slots
/// built once).
pub trait PathDecisions {
    /// A uniform number in `[0, 1)` for decision `d` at `bounce`.
    fn get_1d(&mut self, bounce: u32, d: Decision) -> f32;
    /// A uniform point in `[0, 1)²` for decision `d` at `bounce`.
    fn get_2d(&mut self, bounce: u32, d: Decision) -> Vec2;
}

impl PathDecisions for PathSampler {
    #[inline]
    fn get_1d(&mut self, bounce: u32, d: Decision) -> f32 {
        PathSampler::get_1d(self, bounce, d)
    }
    #[inline]
    fn get_2d(&mut self, bounce: u32, d: Decision) -> Vec2 {
        PathSampler::get_2d(self, bounce, d)
    }
}

/// Every padded slot of one pixel ([`PathSampler::slot_of`] for each padded bounce and decision),
/// built once for all its samples: a path tracer drawing many samples per pixel skips the slots'
/// hashes per decision.
#[derive(Clone, Copy, Debug)]
pub struct PixelSlots {
    slots: [PixelSampler; (PADDED_BOUNCES * SLOTS_PER_BOUNCE) as usize],
}

impl PixelSlots {
    /// The slots of the pixel whose hash is `base` ([`PathSampler::pixel_hash`]).
    pub fn new(base: u64) -> PixelSlots {
        let slot = |k: u32| PathSampler::slot_of(base, k / SLOTS_PER_BOUNCE, DECISIONS[(k % SLOTS_PER_BOUNCE) as usize]).expect("a padded bounce");
        PixelSlots { slots: std::array::from_fn(|k| slot(k as u32)) }
    }

    #[inline]
    fn get(&self, bounce: u32, d: Decision) -> Option<&PixelSampler> {
        self.slots.get((bounce * SLOTS_PER_BOUNCE + d as u32) as usize)
    }
}

/// The decisions in slot order (`Decision as u32`).
const DECISIONS: [Decision; SLOTS_PER_BOUNCE as usize] = [Decision::LightChoice, Decision::LightPoint, Decision::LobeChoice, Decision::BsdfDirection, Decision::Roulette];

/// Sample `index` of a pixel whose slots are built ([`PixelSlots`]): the numbers of
/// [`PathSampler::of_pixel_hash`]`(base, index)`, bit for bit (beyond the padded bounces, its
/// stream).
pub struct SlottedPathSampler<'a> {
    slots: &'a PixelSlots,
    path: PathSampler,
    /// The sample index with its bits reversed, once for every slot it is drawn from.
    rev_index: u32,
}

impl<'a> SlottedPathSampler<'a> {
    /// Sample `index` of the pixel whose hash is `base` and whose slots are `slots`.
    #[inline]
    pub fn new(slots: &'a PixelSlots, base: u64, index: u32) -> Self {
        SlottedPathSampler { slots, path: PathSampler::of_pixel_hash(base, index), rev_index: super::sobol::reverse(index) }
    }
}

impl PathDecisions for SlottedPathSampler<'_> {
    #[inline]
    fn get_1d(&mut self, bounce: u32, d: Decision) -> f32 {
        match self.slots.get(bounce, d) {
            Some(s) => s.sample_1d_reversed(self.rev_index),
            None => self.path.get_1d(bounce, d),
        }
    }
    #[inline]
    fn get_2d(&mut self, bounce: u32, d: Decision) -> Vec2 {
        match self.slots.get(bounce, d) {
            Some(s) => s.sample_reversed(self.rev_index),
            None => self.path.get_2d(bounce, d),
        }
    }
}

/// A 32-bit integer hash with good avalanche (Wellons' "lowbias32").
#[inline]
fn mix32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cell_counts(pts: &[Vec2], n: usize) -> Vec<u32> {
        let mut c = vec![0u32; n * n];
        for p in pts {
            c[(p.y * n as f32) as usize * n + (p.x * n as f32) as usize] += 1;
        }
        c
    }

    /// Sixteen samples of a pixel put one point in each cell of a 4 × 4 grid, in every padded slot.
    #[test]
    fn every_padded_slot_is_stratified_within_a_pixel() {
        let decisions = [Decision::LightChoice, Decision::LightPoint, Decision::LobeChoice, Decision::BsdfDirection, Decision::Roulette];
        for pixel in 0..50u64 {
            for bounce in 0..PADDED_BOUNCES {
                for d in decisions {
                    let pts: Vec<Vec2> = (0..16).map(|i| PathSampler::new(9, 3, pixel, i).get_2d(bounce, d)).collect();
                    assert!(cell_counts(&pts, 4).iter().all(|&c| c == 1), "pixel {pixel} bounce {bounce} {d:?}");
                    let xs: Vec<f32> = (0..16).map(|i| PathSampler::new(9, 3, pixel, i).get_1d(bounce, d)).collect();
                    let mut strata = [0u32; 16];
                    xs.iter().for_each(|&x| strata[(x * 16.0) as usize] += 1);
                    assert!(strata.iter().all(|&c| c == 1), "1D pixel {pixel} bounce {bounce} {d:?}");
                }
            }
        }
    }

    /// Two slots of one pixel are not the same point set in the same order (padding): the pairs
    /// (slot a's x, slot b's x) of 64 samples spread over an 8 × 8 grid like independent points
    /// (a copy would put all 64 on the diagonal's 8 cells).
    #[test]
    fn slots_are_decorrelated() {
        let mut occupied_min = usize::MAX;
        for pixel in 0..20u64 {
            let pts: Vec<Vec2> = (0..64)
                .map(|i| {
                    let mut s = PathSampler::new(1, 2, pixel, i);
                    Vec2::new(s.get_1d(0, Decision::LobeChoice), s.get_1d(0, Decision::Roulette))
                })
                .collect();
            occupied_min = occupied_min.min(cell_counts(&pts, 8).iter().filter(|&&c| c > 0).count());
        }
        // 64 independent uniform points occupy ~40 of 64 cells on average; 8 means a copy.
        assert!(occupied_min >= 28, "{occupied_min}");
    }

    /// A slot built once for the pixel (`slot_of`) gives every sample index the numbers its
    /// `PathSampler` gives, bit for bit; beyond the padded bounces there is no slot.
    #[test]
    fn a_slot_built_once_gives_each_samples_numbers() {
        for pixel in 0..50u64 {
            let base = PathSampler::pixel_hash(7, 3, pixel);
            for bounce in 0..PADDED_BOUNCES {
                for d in [Decision::LightChoice, Decision::LightPoint, Decision::LobeChoice, Decision::BsdfDirection, Decision::Roulette] {
                    let slot = PathSampler::slot_of(base, bounce, d).expect("padded bounce");
                    for i in [0u32, 1, 5, 16, 63, 1000, u32::MAX] {
                        let (mut a, mut b) = (PathSampler::of_pixel_hash(base, i), PathSampler::of_pixel_hash(base, i));
                        assert_eq!(slot.sample(i).to_array().map(f32::to_bits), a.get_2d(bounce, d).to_array().map(f32::to_bits));
                        assert_eq!(slot.sample_1d(i).to_bits(), b.get_1d(bounce, d).to_bits());
                    }
                }
            }
            assert!(PathSampler::slot_of(base, PADDED_BOUNCES, Decision::LightPoint).is_none());
        }
    }

    /// A pixel's slots built once ([`PixelSlots`]) give every decision of every bounce the numbers
    /// of the sample's own `PathSampler`, padded or not, bit for bit.
    #[test]
    fn slotted_sampler_gives_the_path_samplers_numbers() {
        for pixel in 0..20u64 {
            let base = PathSampler::pixel_hash(3, 9, pixel);
            let slots = PixelSlots::new(base);
            for i in [0u32, 3, 64, 4097] {
                let (mut a, mut b) = (SlottedPathSampler::new(&slots, base, i), PathSampler::of_pixel_hash(base, i));
                for bounce in 0..PADDED_BOUNCES + 3 {
                    for d in DECISIONS {
                        assert_eq!(PathDecisions::get_1d(&mut a, bounce, d).to_bits(), b.get_1d(bounce, d).to_bits(), "pixel {pixel} sample {i} bounce {bounce} {d:?}");
                        assert_eq!(PathDecisions::get_2d(&mut a, bounce, d).to_array().map(f32::to_bits), b.get_2d(bounce, d).to_array().map(f32::to_bits));
                    }
                }
            }
        }
    }

    /// Each sample index is uniform over pixels (chi-square, 8 × 8 grid, 6400 pixels; the 0.1 %
    /// critical value of χ²(63) is 103.4), in a padded slot and beyond the padded bounces.
    #[test]
    fn each_sample_is_uniform_over_pixels() {
        for (bounce, index) in [(0, 0u32), (1, 3), (3, 17), (PADDED_BOUNCES, 0), (PADDED_BOUNCES + 3, 5)] {
            let n = 6400u64;
            let pts: Vec<Vec2> = (0..n).map(|p| PathSampler::new(5, 1, p, index).get_2d(bounce, Decision::BsdfDirection)).collect();
            let e = n as f64 / 64.0;
            let chi2: f64 = cell_counts(&pts, 8).iter().map(|&c| (c as f64 - e).powi(2) / e).sum();
            assert!(chi2 < 103.4, "bounce {bounce} index {index}: chi2 {chi2:.1}");
        }
    }
}
