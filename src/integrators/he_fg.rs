//! `--method he-fg`: photon mapping with final gathering and strong secondary lights
//! (`strong-secondary-lighting.md`). Direct light comes from the eye pass's light sampling, caustics
//! from the caustic map at the eye samples, and the rest of the indirect light from the gather of
//! [`crate::secondary::gather`]: `--fg-rays` stratified rays into the low-energy map plus
//! `--explicit-rays` rays toward the high-energy voxels. With `--explicit-rays 0` there is no split:
//! every global photon is in one map and the gather is the uniform stratified final gather.
//! With `--irradiance-cache`, Lambertian eye samples interpolate Ward's cache (`--cache-error`).
//!
//! The global map holds direct, indirect and caustic photons (the radiance leaving a gather hit), so
//! the photon budget includes direct photons. The high-energy map is built only when the split finds
//! high-energy voxels.

use super::compose;
use super::{Progress, RenderSettings, Stats};
use crate::error::{Error, Result};
use crate::image::Film;
use crate::kdtree::KnnHeap;
use crate::photon::{IrradianceMap, PhotonMap, PhotonSet};
use crate::prepare::PreparedScene;
use crate::sampling::{hash, Rng};
use crate::secondary::{self, gather::gather, CacheSettings, GatherMaps, GatherSettings, IrradianceCache, Split};
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

const FG_STREAM: u64 = 0x4647_4154; // "FGAT"
const CACHE_STREAM: u64 = 0x4943_4143; // "ICAC"
/// Eye samples per parallel work item (fixed: results do not depend on the thread count).
const CHUNK: usize = 64;
/// Christensen's precomputed irradiance at every 4th low-energy photon (every high-energy photon).
const LOW_STRIDE: usize = 4;
/// The precomputed irradiance uses `--knn / 4` neighbours (at least 8): the gather averages hundreds
/// of look-ups, so it needs less smoothing than a direct visualisation, and the direct light at the
/// gather hits (steep near small lights) is blurred less. Measured on the extremes suite's room with
/// emissive needles (20k photons): the light they add is 8.8 % below the path tracer with k = 100,
/// 4.1 % with k = 25; the plain room 3.6 % below with k = 100, 0.2 % above with k = 25.
const KNN_DIVISOR: usize = 4;

/// The split of a traced photon set (classes direct, indirect, caustic).
pub fn split_photons(scene: &PreparedScene, photons: &PhotonSet, s: &RenderSettings) -> Split {
    secondary::split(scene, photons, &[0, 1, 2], &s.split)
}

/// Trace the light pass of `he-fg` with `s.photons` photons and split it: what `raysplat info`
/// reports (how many high-energy voxels the scene has).
pub fn survey(scene: &PreparedScene, s: &RenderSettings) -> Split {
    split_photons(scene, &survey_photons(scene, s), s)
}

/// The light pass of [`survey`], before the split (direct, indirect and caustic photons).
pub fn survey_photons(scene: &PreparedScene, s: &RenderSettings) -> crate::photon::PhotonSet {
    let budget = compose::photon_budget(&RenderSettings { method: super::Method::HeFg, ..s.clone() }, scene);
    crate::photon::trace_photons(
        scene,
        &crate::photon::PhotonSettings {
            budget,
            seed: s.seed,
            max_depth: s.max_depth.min(256),
            bandwidth: s.bandwidth,
            emission_guiding: s.emission_guiding,
            ..Default::default()
        },
    )
}

/// `pm-fg --irradiance-cache`: photon mapping with final gathering and Ward's irradiance cache is
/// this method's gather with one global photon map (no low/high split, no explicit rays), `--fg-rays`
/// stratified rays per gather point (pm-fg's default 64), Christensen's precomputed irradiance at
/// the gather hits, and the cache at the eye samples whose BSDF is close to Lambertian.
pub fn pm_fg_cached(s: &RenderSettings) -> RenderSettings {
    RenderSettings { explicit_rays: 0, fg_rays: s.fg.rays, ..s.clone() }
}

pub fn render(scene: &PreparedScene, s: &RenderSettings, progress: &dyn Progress, stats: &mut Stats) -> Result<Film> {
    let (eye, photons) = compose::eye_and_light(scene, s, progress, stats)?;
    let t = Instant::now();
    let split = (s.explicit_rays > 0).then(|| split_photons(scene, &photons, s));
    if let Some(sp) = &split {
        stats.phase("split", t.elapsed().as_secs_f64());
        stats.count("high_voxels", sp.high_voxels.len() as u64);
        stats.count("high_photons", sp.high_photons as u64);
        stats.count("low_photons", sp.low_photons as u64);
        stats.count("c_max", sp.c_max.round() as u64);
        stats.enable(&format!("voxel grid {:?} (E_max {:.4e} = {:.3} x E_avg)", sp.grid.dims, sp.e_max, sp.e_max / sp.e_avg.max(1e-30)), sp.bytes());
    }
    let t = Instant::now();
    let rays = [&photons.rays[0][..], &photons.rays[1][..], &photons.rays[2][..]];
    let low_mask: [&[bool]; 3] = match &split {
        Some(sp) => [&sp.low[0], &sp.low[1], &sp.low[2]],
        None => [&photons.ends_diffuse[0], &photons.ends_diffuse[1], &photons.ends_diffuse[2]],
    };
    let low = PhotonMap::build(&rays, &low_mask)?;
    let high = match &split {
        Some(sp) if !sp.high_voxels.is_empty() => Some(PhotonMap::build(&rays, &[&sp.high[0], &sp.high[1], &sp.high[2]])?),
        _ => None,
    };
    let caustic = PhotonMap::build(&[&photons.rays[2]], &[&photons.ends_diffuse[2]])?;
    stats.phase("build", t.elapsed().as_secs_f64());
    let name = if split.is_some() { "low-energy photon map" } else { "global photon map" };
    stats.enable(name, low.bytes());
    if let Some(h) = &high {
        stats.enable("high-energy photon map", h.bytes());
    }
    if !caustic.is_empty() {
        stats.enable("caustic photon map", caustic.bytes());
    }
    let max_r = photons.bandwidth.h_max.max(1e-30) as f32 * 5.0;
    let t = Instant::now();
    let k = (s.knn / KNN_DIVISOR).max(8);
    let low_e = IrradianceMap::build(&low, LOW_STRIDE, k, max_r)?;
    let high_e = high.as_ref().map(|h| IrradianceMap::build(h, 1, k, max_r)).transpose()?;
    stats.phase("precompute", t.elapsed().as_secs_f64());
    stats.enable("precomputed irradiance (low)", low_e.bytes());
    if let Some(h) = &high_e {
        stats.enable("precomputed irradiance (high)", h.bytes());
    }
    let maps = GatherMaps::new(
        &low_e,
        match (&high_e, &split) {
            (Some(h), Some(sp)) => Some((h, &sp.high_voxels, sp.grid)),
            _ => None,
        },
        s.explicit_allocation,
        max_r,
    );
    let gs = GatherSettings { fg_rays: s.fg_rays, explicit_rays: if maps.high.is_some() { s.explicit_rays } else { 0 } };
    stats.count("fg_rays", gs.fg_rays as u64);
    stats.count("explicit_rays", gs.explicit_rays as u64);

    // Ward's irradiance cache over the eye samples whose BSDF is close to Lambertian.
    let factors: Vec<Option<Vec3>> = if s.irradiance_cache {
        eye.samples.par_iter().map(|e| diffuse_factor(e, &eye)).collect()
    } else {
        Vec::new()
    };
    let cache = if s.irradiance_cache {
        let t = Instant::now();
        let idx: Vec<u32> = (0..eye.samples.len() as u32).filter(|&i| factors[i as usize].is_some()).collect();
        let points: Vec<(Vec3, Vec3)> = idx.iter().map(|&i| (eye.samples[i as usize].pos(), eye.samples[i as usize].normal())).collect();
        let compute = |k: usize| {
            let mut rng = Rng::new(hash(&[s.seed, CACHE_STREAM, idx[k] as u64]), 0);
            let mut heap = KnnHeap::with_capacity(8);
            let (p, n) = points[k];
            let g = gather(scene, &maps, &gs, p, n, &|_| Vec3::ONE, &mut rng, &mut heap);
            (g.value, g.harmonic)
        };
        let c = IrradianceCache::build(&points, scene.radius, &CacheSettings { error: s.cache_error() }, &compute);
        stats.phase("cache", t.elapsed().as_secs_f64());
        stats.count("cache_points", points.len() as u64);
        stats.count("cache_records", c.records.len() as u64);
        stats.count("cache_rounds", c.rounds as u64);
        stats.count("cache_gather_rays", c.records.len() as u64 * (gs.fg_rays + gs.explicit_rays) as u64);
        stats.enable(&format!("irradiance cache (error {})", s.cache_error()), c.bytes());
        Some(c)
    } else {
        None
    };

    progress.begin("final gathering", eye.samples.len().div_ceil(CHUNK) as u64);
    let t = Instant::now();
    let k_caustic = (s.knn / 2).max(1);
    let per_sample: Vec<(Vec3, u64)> = eye
        .samples
        .par_chunks(CHUNK)
        .enumerate()
        .flat_map_iter(|(c, chunk)| {
            if progress.cancelled() {
                return vec![(Vec3::ZERO, 0); chunk.len()]; // discarded below
            }
            let mut heap = KnnHeap::with_capacity(k_caustic.max(8));
            let out: Vec<(Vec3, u64)> = chunk
                .iter()
                .enumerate()
                .map(|(j, e)| {
                    let (p, n) = (e.pos(), e.normal());
                    // the sample's BSDF with its per-`wo` work done once, for every photon found
                    let g = e.is_glossy().then(|| eye.glossy.sample(e.glossy as usize));
                    let f = |wi: Vec3| g.as_ref().map_or(Vec3::ONE, |g| g.eval(wi));
                    let i = c * CHUNK + j;
                    let cached = cache.as_ref().and_then(|cc| Some(factors[i]? * cc.interpolate(p, n)?));
                    let (value, rays) = match cached {
                        Some(v) => (v, 0),
                        None => {
                            let mut rng = Rng::new(hash(&[s.seed, FG_STREAM, i as u64]), 0);
                            let g = gather(scene, &maps, &gs, p, n, &f, &mut rng, &mut heap);
                            (g.value, g.rays as u64)
                        }
                    };
                    let (lc, _, _) = caustic.estimate(p, n, k_caustic, max_r, &mut heap, f);
                    (e.weight() * value + e.weight() * lc, rays)
                })
                .collect();
            progress.advance(1);
            out
        })
        .collect();
    if progress.cancelled() {
        return Err(Error::Cancelled);
    }
    stats.phase("gather", t.elapsed().as_secs_f64());
    progress.finish();
    let mut indirect = vec![Vec3::ZERO; (eye.width * eye.height) as usize];
    let mut rays = 0u64;
    for (e, (l, r)) in eye.samples.iter().zip(&per_sample) {
        indirect[e.pixel as usize] += *l;
        rays += r;
    }
    stats.count("gather_rays", rays);
    compose::film(&eye, &indirect)
}

/// The factor turning irradiance into the eye sample's reflected radiance (before its weight): 1
/// for a Lambertian sample (its weight holds albedo/π); for another BSDF, its mean over 16
/// stratified cosine-distributed directions (`∫ f cos dω / π`: exact under uniform incident light),
/// or `None` when those values differ by more than 4× (a glossy lobe: gathered, not cached).
fn diffuse_factor(e: &crate::eye::EyeSample, eye: &crate::eye::EyePass) -> Option<Vec3> {
    if !e.is_glossy() {
        return Some(Vec3::ONE);
    }
    let g = eye.glossy.sample(e.glossy as usize);
    let frame = crate::sampling::Frame::from_normal(e.normal());
    let (mut sum, mut lo, mut hi) = (Vec3::ZERO, f32::INFINITY, 0.0f32);
    for k in 0..16 {
        let u = glam::Vec2::new(((k % 4) as f32 + 0.5) / 4.0, ((k / 4) as f32 + 0.5) / 4.0);
        let f = g.eval(frame.to_world(crate::sampling::square_to_cosine_hemisphere(u)));
        let l = f.dot(Vec3::new(0.2126, 0.7152, 0.0722));
        sum += f;
        lo = lo.min(l);
        hi = hi.max(l);
    }
    (lo > 0.0 && hi <= 4.0 * lo).then_some(sum / 16.0)
}
