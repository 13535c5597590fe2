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
//! Ray shooting cache (§6.4): the eye samples are taken in fixed windows holding about C·Q gather
//! rays (C = 400 directional cells of a 20 × 20 octahedral map, Q = [`RAYS_PER_CELL`]); a window's
//! rays are binned into the C cells (a stable counting sort: within a cell, eye sample then ray
//! order) and traced in that order through Embree's batched path, so Embree sees runs of about Q
//! rays of similar direction from nearby origins. Windows start at the first eye sample of the
//! range traced and their size depends only on the gather rays per sample and the memory share of
//! the rays in flight (never on the thread count), and the reverse photons of a window come out in
//! cell order: the output is the same for any number of threads.

use super::reverse::{oct16_encode, ReversePhoton};
use crate::bsdf::TransportMode;
use crate::embree::{self, Hit, Ray};
use crate::eye::{EyePass, EyeSample};
use crate::prepare::PreparedScene;
use crate::sampling::{hash, oct_encode, square_to_cosine_hemisphere, Frame, Rng};
use glam::Vec3;
use rayon::prelude::*;
use std::ops::Range;

const FG_STREAM: u64 = 0x4647_5259; // "FGRY"
/// Directional cells per axis of the octahedral map (§6.4: C = 400 cells).
const CELLS: u32 = 20;
/// §6.4: gather rays per directional cell a window aims at (the paper's cache holds Q = 50).
pub const RAYS_PER_CELL: usize = 50;
/// Gather rays a window aims at: C·Q.
pub const WINDOW_RAYS: usize = (CELLS * CELLS) as usize * RAYS_PER_CELL;
/// Consecutive sorted rays per parallel work item (traced by `intersect_batch`, then shaded).
const PIECE: usize = 256;
/// Eye samples per parallel work item of the sampling.
const SAMPLE_CHUNK: usize = 16;

/// What tracing produced.
#[derive(Default, Clone, Copy, Debug)]
pub struct GatherCounts {
    /// Gather rays traced.
    pub rays: u64,
    /// Rays whose hit became a reverse photon.
    pub hits: u64,
}

/// What a sampled gather ray carries besides the ray.
#[derive(Clone, Copy, Default)]
struct Meta {
    /// Eye throughput × f·cos/pdf / N.
    weight: Vec3,
    pixel: u32,
    cell: u32,
}

/// One sampled, not yet traced, gather ray.
#[derive(Clone, Copy)]
struct Pending {
    ray: Ray,
    meta: Meta,
}

const _: () = assert!(size_of::<Meta>() == 20 && size_of::<Pending>() == 52 && size_of::<Ray>() == 32);

/// Bytes one gather ray costs while its window is in flight: the sampled ray and its data, their
/// cell-sorted copies and its reverse photon in the window's output.
pub const TRACE_BYTES_PER_RAY: u64 = (size_of::<Pending>() + size_of::<Ray>() + size_of::<Meta>() + size_of::<ReversePhoton>()) as u64;

/// Eye samples per window for `rays_per_sample` gather rays each: about [`WINDOW_RAYS`] rays, at
/// most `max_rays` (the memory share of the rays in flight), at least one eye sample.
pub fn window_samples(rays_per_sample: u32, max_rays: u64) -> usize {
    let r = rays_per_sample.max(1) as u64;
    (WINDOW_RAYS as u64).div_ceil(r).min(max_rays / r).max(1) as usize
}

/// Trace gather rays `rays` (of `n_total` per eye sample) for the eye samples `samples` and return
/// their hits as reverse photons, in a deterministic order, with windows of
/// [`window_samples`]`(rays.len(), u64::MAX)` eye samples. The result is written into one array
/// reserved for every ray (pages not touched stay virtual), window by window, so the transient
/// memory is one window, not a second copy of `A_r`.
pub fn trace_gather(
    scene: &PreparedScene,
    eye: &EyePass,
    samples: Range<usize>,
    rays: Range<u32>,
    n_total: u32,
    seed: u64,
) -> (Vec<ReversePhoton>, GatherCounts) {
    let window = window_samples(rays.len() as u32, u64::MAX);
    let mut out = Vec::with_capacity(samples.len() * rays.len());
    let counts = trace_gather_each(scene, eye, samples, rays, n_total, seed, window, |w| out.extend_from_slice(w));
    (out, counts)
}

/// As [`trace_gather`] with windows of `window` eye samples, handing the reverse photons to `sink`
/// piece by piece, in order.
#[allow(clippy::too_many_arguments)]
pub fn trace_gather_each(
    scene: &PreparedScene,
    eye: &EyePass,
    samples: Range<usize>,
    rays: Range<u32>,
    n_total: u32,
    seed: u64,
    window: usize,
    mut sink: impl FnMut(&[ReversePhoton]),
) -> GatherCounts {
    let mut counts = GatherCounts::default();
    let window = window.max(1);
    let cells = (CELLS * CELLS) as usize;
    let mut sorted_rays: Vec<Ray> = Vec::new();
    let mut sorted_meta: Vec<Meta> = Vec::new();
    let mut start = vec![0usize; cells + 1];
    let albedo = MaterialAlbedo::new(scene);
    let mut w0 = samples.start;
    while w0 < samples.end {
        let w1 = (w0 + window).min(samples.end);
        // Sample the window's rays (eye sample, then ray order).
        let pending: Vec<Pending> = eye.samples[w0..w1]
            .par_chunks(SAMPLE_CHUNK)
            .enumerate()
            .flat_map_iter(|(c, chunk)| {
                let base = w0 + c * SAMPLE_CHUNK;
                let rays = rays.clone();
                chunk.iter().enumerate().flat_map(move |(i, e)| rays.clone().filter_map(move |k| sample(scene, eye, e, (base + i) as u64, k, n_total, seed)))
            })
            .collect();
        // Counting sort into the directional cells (stable).
        start.fill(0);
        for p in &pending {
            start[p.meta.cell as usize + 1] += 1;
        }
        for c in 0..cells {
            start[c + 1] += start[c];
        }
        sorted_rays.clear();
        sorted_rays.resize(pending.len(), Ray { org: Vec3::ZERO, dir: Vec3::Z, tnear: 0.0, tfar: 0.0 });
        sorted_meta.clear();
        sorted_meta.resize(pending.len(), Meta::default());
        for p in &pending {
            let slot = &mut start[p.meta.cell as usize];
            sorted_rays[*slot] = p.ray;
            sorted_meta[*slot] = p.meta;
            *slot += 1;
        }
        drop(pending);
        // Trace and shade in pieces of consecutive sorted rays.
        let pieces: Vec<Vec<ReversePhoton>> = sorted_rays
            .par_chunks(PIECE)
            .zip(sorted_meta.par_chunks(PIECE))
            .map(|(rays, meta)| {
                embree::set_flush_denormals();
                let mut hits = [None; PIECE];
                let hits = &mut hits[..rays.len()];
                scene.embree.intersect_batch(rays, hits, false);
                rays.iter().zip(meta).zip(hits.iter()).filter_map(|((ray, m), h)| shade(scene, &albedo, ray, m, h.as_ref()?)).collect()
            })
            .collect();
        counts.rays += sorted_rays.len() as u64;
        for piece in &pieces {
            counts.hits += piece.len() as u64;
            sink(piece);
        }
        w0 = w1;
    }
    counts
}

/// Gather ray `k` of eye sample `e` (index `index`), or `None` when its direction carries nothing.
fn sample(scene: &PreparedScene, eye: &EyePass, e: &EyeSample, index: u64, k: u32, n_total: u32, seed: u64) -> Option<Pending> {
    let mut rng = Rng::new(hash(&[seed, FG_STREAM, index, k as u64]), 0);
    let (dir, w) = if e.is_glossy() {
        let g = eye.glossy.sample(e.glossy as usize);
        // The eye sample's BSDF with its per-`wo` context: the same sample as `bsdf.sample(wo, …)`.
        let bs = g.bsdf.sample(rng.next_f32(), rng.next_2d(), TransportMode::Radiance)?;
        if bs.is_specular() || bs.pdf <= 0.0 {
            return None;
        }
        (g.frame.to_world(bs.wi), e.weight() * bs.weight())
    } else {
        // weight = throughput·albedo/π and f·cos/pdf = albedo for cosine sampling.
        let d = Frame::from_normal(e.normal()).to_world(square_to_cosine_hemisphere(rng.next_2d()));
        (d, e.weight() * std::f32::consts::PI)
    };
    let w = w / n_total as f32;
    if !(w.max_element() > 0.0) || !w.is_finite() || !dir.is_finite() {
        return None;
    }
    let code = oct_encode(dir);
    let cell = ((code & 0xffff) * CELLS / 65536) * CELLS + (code >> 16) * CELLS / 65536;
    Some(Pending { ray: scene.spawn(e.pos(), e.normal(), dir), meta: Meta { weight: w, pixel: e.pixel, cell } })
}

/// What [`shade`] needs of every material whose BSDF is the same at every hit, computed once per
/// call: its albedo, or `None` when it has no diffuse or glossy lobe (the same values `shade`
/// computes per hit for the other materials).
struct MaterialAlbedo(Vec<Option<Option<Vec3>>>);

impl MaterialAlbedo {
    fn new(scene: &PreparedScene) -> MaterialAlbedo {
        MaterialAlbedo((0..scene.materials.len() as u32).map(|m| scene.constant_bsdf(m).map(|b| gather_albedo(&b))).collect())
    }
}

/// The albedo of a BSDF with a diffuse or glossy lobe, else `None`.
fn gather_albedo(bsdf: &crate::bsdf::Bsdf) -> Option<Vec3> {
    let flags = bsdf.flags();
    (flags.is_diffuse() || flags.is_glossy()).then(|| bsdf.albedo())
}

/// The reverse photon of a gather ray's hit, or `None` on a purely specular surface.
fn shade(scene: &PreparedScene, albedo: &MaterialAlbedo, ray: &Ray, m: &Meta, h: &Hit) -> Option<ReversePhoton> {
    let sh = scene.surface_hit(ray, h);
    let a = match albedo.0.get(sh.material as usize) {
        Some(Some(a)) => (*a)?,
        _ => gather_albedo(&scene.bsdf(&sh))?,
    };
    let weight = m.weight * a * std::f32::consts::FRAC_1_PI;
    if !(weight.max_element() > 0.0) || !sh.p.is_finite() {
        return None;
    }
    let n = if sh.ng.dot(ray.dir) < 0.0 { sh.ng } else { -sh.ng };
    Some(ReversePhoton { p: sh.p.to_array(), weight: weight.to_array(), n: oct16_encode(n), wi: oct16_encode(-ray.dir), pixel: m.pixel })
}
