//! Final gather rays: for every primary eye sample, N directions by BSDF importance sampling
//! (cosine-weighted for Lambertian eye samples, the BSDF's own sampling for glossy ones; delta lobes
//! are skipped, the eye pass follows them), traced in batches through Embree. Each hit on a surface
//! with a non-specular lobe becomes a [`ReversePhoton`]. Emission found by a gather ray is not
//! added: direct light comes from light sampling in the eye pass.
//!
//! Ray `k` of eye sample `e` draws from `Rng(hash(seed, FG_STREAM, e, k))`: a gather ray is the same
//! whatever task, tile or thread traces it, which is what makes `pm-fg` and `rpm-fg` comparable
//! pixel by pixel and a render split into memory tasks equal to an unsplit one.
//!
//! Ray shooting cache (§6.4): the rays of a chunk are put into C = 400 directional cells (20 × 20
//! octahedral cells) and traced cell by cell, so that Embree sees runs of similar directions.

use super::reverse::{oct16_encode, ReversePhoton};
use crate::bsdf::TransportMode;
use crate::embree::{self, Hit, Ray};
use crate::eye::EyePass;
use crate::prepare::PreparedScene;
use crate::sampling::{hash, oct_encode, square_to_cosine_hemisphere, Frame, Rng};
use glam::Vec3;
use rayon::prelude::*;
use std::ops::Range;

const FG_STREAM: u64 = 0x4647_5259; // "FGRY"
/// Eye samples per parallel work item (fixed: the output never depends on the thread count).
pub(crate) const CHUNK: usize = 64;
/// Directional cells per axis of the octahedral map (§6.4: C = 400 cells).
const CELLS: u32 = 20;

/// What tracing produced.
#[derive(Default, Clone, Copy, Debug)]
pub struct GatherCounts {
    /// Gather rays traced.
    pub rays: u64,
    /// Rays whose hit became a reverse photon.
    pub hits: u64,
}

/// One sampled, not yet traced, gather ray.
struct Pending {
    ray: Ray,
    /// Eye throughput × f·cos/pdf / N.
    weight: Vec3,
    pixel: u32,
    cell: u32,
}

/// Trace gather rays `rays` (of `n_total` per eye sample) for the eye samples `samples` and return
/// their hits as reverse photons, in a deterministic order. The result is written into one array
/// reserved for every ray (pages not touched stay virtual), group by group, so the transient memory
/// is one group of chunks, not a second copy of `A_r`.
pub fn trace_gather(
    scene: &PreparedScene,
    eye: &EyePass,
    samples: Range<usize>,
    rays: Range<u32>,
    n_total: u32,
    seed: u64,
) -> (Vec<ReversePhoton>, GatherCounts) {
    let mut out = Vec::with_capacity(samples.len() * rays.len());
    let counts = trace_gather_each(scene, eye, samples, rays, n_total, seed, |group| out.extend_from_slice(group));
    (out, counts)
}

/// Chunks traced in parallel before their reverse photons are handed on (per worker thread).
pub(crate) const GROUP_PER_THREAD: usize = 4;

/// As [`trace_gather`], handing the reverse photons to `sink` group by group, in the same order.
pub fn trace_gather_each(
    scene: &PreparedScene,
    eye: &EyePass,
    samples: Range<usize>,
    rays: Range<u32>,
    n_total: u32,
    seed: u64,
    mut sink: impl FnMut(&[ReversePhoton]),
) -> GatherCounts {
    let mut counts = GatherCounts::default();
    let group = CHUNK * GROUP_PER_THREAD * rayon::current_num_threads().max(1);
    let mut g0 = samples.start;
    while g0 < samples.end {
        let g1 = (g0 + group).min(samples.end);
        for (v, c) in trace_group(scene, eye, g0..g1, rays.clone(), n_total, seed) {
            sink(&v);
            counts.rays += c.rays;
            counts.hits += c.hits;
        }
        g0 = g1;
    }
    counts
}

/// One group of chunks of `CHUNK` eye samples, traced in parallel (chunk boundaries are at multiples
/// of `CHUNK` from the group start: groups are multiples of `CHUNK`, so the order never depends on
/// the group size).
fn trace_group(
    scene: &PreparedScene,
    eye: &EyePass,
    samples: Range<usize>,
    rays: Range<u32>,
    n_total: u32,
    seed: u64,
) -> Vec<(Vec<ReversePhoton>, GatherCounts)> {
    let base = samples.start;
    eye.samples[samples]
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(c, chunk)| {
            embree::set_flush_denormals();
            let mut pending = Vec::with_capacity(chunk.len() * rays.len());
            for (i, e) in chunk.iter().enumerate() {
                let index = (base + c * CHUNK + i) as u64;
                for k in rays.clone() {
                    let mut rng = Rng::new(hash(&[seed, FG_STREAM, index, k as u64]), 0);
                    let (dir, w) = if e.is_glossy() {
                        let g = &eye.glossy[e.glossy as usize];
                        let Some(bs) = g.bsdf.bsdf().sample(g.bsdf.wo(), rng.next_f32(), rng.next_2d(), TransportMode::Radiance) else { continue };
                        if bs.is_specular() || bs.pdf <= 0.0 {
                            continue;
                        }
                        (g.frame.to_world(bs.wi), e.weight() * bs.weight())
                    } else {
                        // weight = throughput·albedo/π and f·cos/pdf = albedo for cosine sampling.
                        let d = Frame::from_normal(e.normal()).to_world(square_to_cosine_hemisphere(rng.next_2d()));
                        (d, e.weight() * std::f32::consts::PI)
                    };
                    let w = w / n_total as f32;
                    if !(w.max_element() > 0.0) || !w.is_finite() || !dir.is_finite() {
                        continue;
                    }
                    let code = oct_encode(dir);
                    let cell = ((code & 0xffff) * CELLS / 65536) * CELLS + (code >> 16) * CELLS / 65536;
                    pending.push(Pending { ray: scene.spawn(e.pos(), e.normal(), dir), weight: w, pixel: e.pixel, cell });
                }
            }
            pending.sort_by_key(|p| p.cell); // stable: deterministic
            let batch: Vec<Ray> = pending.iter().map(|p| p.ray).collect();
            let mut hits: Vec<Option<Hit>> = vec![None; batch.len()];
            scene.embree.intersect_batch(&batch, &mut hits, false);
            let mut out = Vec::with_capacity(pending.len());
            for (p, h) in pending.iter().zip(&hits) {
                let Some(h) = h else { continue };
                let sh = scene.surface_hit(&p.ray, h);
                let bsdf = scene.bsdf(&sh);
                let flags = bsdf.flags();
                if !(flags.is_diffuse() || flags.is_glossy()) {
                    continue;
                }
                let weight = p.weight * bsdf.albedo() * std::f32::consts::FRAC_1_PI;
                if !(weight.max_element() > 0.0) || !sh.p.is_finite() {
                    continue;
                }
                let n = if sh.ng.dot(p.ray.dir) < 0.0 { sh.ng } else { -sh.ng };
                out.push(ReversePhoton {
                    p: sh.p.to_array(),
                    weight: weight.to_array(),
                    n: oct16_encode(n),
                    wi: oct16_encode(-p.ray.dir),
                    pixel: p.pixel,
                });
            }
            let counts = GatherCounts { rays: pending.len() as u64, hits: out.len() as u64 };
            (out, counts)
        })
        .collect()
}
