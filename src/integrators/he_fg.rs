//! `--method he-fg`: photon mapping with final gathering and strong secondary lights
//! (`strong-secondary-lighting.md`). Direct light comes from the eye pass's light sampling, caustics
//! from the caustic map at the eye samples, and the rest of the indirect light from the gather of
//! [`crate::secondary::gather`]: `--fg-rays` stratified rays into the low-energy map plus
//! `--explicit-rays` rays toward the high-energy voxels. With `--explicit-rays 0` there is no split:
//! every global photon is in one map and the gather is the uniform stratified final gather.
//! With `--irradiance-cache`, Lambertian eye samples interpolate Ward's cache (`--cache-error`).
//! `pm-fg --irradiance-cache` runs the same per-point gather ([`gather_per_point`]) on one global
//! map, without explicit rays.
//!
//! The global map holds direct, indirect and caustic photons (the radiance leaving a gather hit), so
//! the photon budget includes direct photons. The high-energy map is built only when the split finds
//! high-energy voxels.

use super::compose::{self, PhotonPass};
use super::settings::{attribute, check_cache_error};
use super::{Progress, RenderSettings, Stats};
use crate::error::{Error, Result};
use crate::image::Film;
use crate::kdtree::KnnHeap;
use crate::photon::{IrradianceMap, PhotonMap, PhotonSet};
use crate::prepare::PreparedScene;
use crate::sampling::{hash, Rng};
use crate::secondary::{self, gather::gather, Allocation, CacheSettings, GatherMaps, GatherSettings, IrradianceCache, Split, SplitSettings};
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
/// gather hits (steep near small lights) is blurred less (`tests/extremes.rs`' emissive needles are
/// 8.8 % dark with k = 100, 4.1 % with k = 25).
const KNN_DIVISOR: usize = 4;
/// Default stratified gather rays per gather point.
pub const STRATIFIED_RAYS: u32 = 48;
/// Default explicit rays toward the high-energy voxels per gather point.
pub const EXPLICIT_RAYS: u32 = 230;
/// Default error ε of Ward's irradiance cache (`he-fg` and `pm-fg` with `--irradiance-cache`).
pub const CACHE_ERROR: f32 = 0.2;

/// Settings of `he-fg`.
#[derive(Clone, Debug, PartialEq)]
pub struct HeFgSettings {
    /// The photon pass (its photon map holds direct photons too: the radiance leaving a gather hit).
    pub pass: PhotonPass,
    /// Neighbours of the caustic map's estimate (half of it) and of the precomputed irradiance (a
    /// quarter, [`KNN_DIVISOR`]).
    pub knn: usize,
    /// Stratified final-gather rays into the low-energy photon map per gather point (`--fg-rays`).
    pub stratified_rays: u32,
    /// Explicit rays toward the high-energy voxels per gather point (0: no split, one map).
    pub explicit_rays: u32,
    /// How explicit rays are shared between high-energy voxels.
    pub explicit_allocation: Allocation,
    /// The low/high-energy split (E_max or its multiplier of E_avg, voxel resolution).
    pub split: SplitSettings,
    /// Ward's irradiance cache for the gather at Lambertian eye samples.
    pub irradiance_cache: bool,
    /// The cache's error ε.
    pub cache_error: f32,
}

impl Default for HeFgSettings {
    fn default() -> Self {
        HeFgSettings {
            pass: PhotonPass::default(),
            knn: super::pm::KNN,
            stratified_rays: STRATIFIED_RAYS,
            explicit_rays: EXPLICIT_RAYS,
            explicit_allocation: Allocation::PerVoxel,
            split: SplitSettings::default(),
            irradiance_cache: false,
            cache_error: CACHE_ERROR,
        }
    }
}

impl HeFgSettings {
    pub fn validate(&self) -> Result<()> {
        super::pm::check_knn(self.knn)?;
        if self.stratified_rays > 65536 || self.explicit_rays > 65536 {
            return Err(Error::param("fg-rays", format!("{} gather + {} explicit rays per point is out of range (0..=65536 each)", self.stratified_rays, self.explicit_rays)));
        }
        if self.stratified_rays == 0 && self.explicit_rays == 0 {
            return Err(Error::param("fg-rays", "--fg-rays and --explicit-rays are both 0"));
        }
        self.split.validate()?;
        check_cache_error(self.cache_error)
    }

    pub(super) fn attributes(&self) -> Vec<(String, String)> {
        vec![
            attribute("knn", self.knn),
            attribute("fg_rays", self.stratified_rays),
            attribute("explicit_rays", self.explicit_rays),
            attribute("explicit_allocation", self.explicit_allocation.name()),
            attribute("emax", self.split.e_max.map_or("auto".into(), |e| e.to_string())),
            attribute("emax_multiplier", self.split.multiplier),
            attribute("voxel_resolution", self.split.resolution.map_or("auto".into(), |r| r.to_string())),
            attribute("irradiance_cache", self.irradiance_cache),
            attribute("cache_error", self.cache_error),
        ]
    }
}

/// What a light pass finds in a scene: its low/high-energy split at the automatic `E_max`, and
/// the power its direct, indirect and caustic photons bring to the surfaces (each class's summed
/// flux, an unbiased estimate of it).
pub struct LightSurvey {
    pub split: Split,
    pub power: [f64; 3],
}

/// Trace the light pass of `he-fg` with `photons` photons (default bandwidth and emission
/// guiding) and split it: whether the scene has strong secondary light (`raysplat info`, `auto`).
pub fn survey(scene: &PreparedScene, photons: usize, seed: u64) -> LightSurvey {
    let pass = PhotonPass { photons, ..Default::default() };
    let set = trace_light_pass(scene, &pass, seed, RenderSettings::default().max_depth);
    let split = secondary::split(scene, &set, &[0, 1, 2], &SplitSettings::default());
    let power = std::array::from_fn(|c| set.rays[c].iter().map(|r| r.flux().element_sum() as f64).sum::<f64>());
    LightSurvey { split, power }
}

/// The light pass of `he-fg` (direct, indirect and caustic photons), without the eye pass.
fn trace_light_pass(scene: &PreparedScene, pass: &PhotonPass, seed: u64, max_depth: u32) -> PhotonSet {
    let budget = compose::photon_budget(pass.photons, true, scene);
    crate::photon::trace_photons(
        scene,
        &crate::photon::PhotonSettings {
            budget,
            seed,
            max_depth: max_depth.min(256),
            bandwidth: pass.bandwidth,
            emission_guiding: pass.emission_guiding,
            ..Default::default()
        },
    )
}

/// The per-point final gather of [`render`]: explicit rays toward high-energy voxels (`explicit`,
/// with the split that finds them) or one global map, and Ward's irradiance cache when
/// `cache_error` is given. `pm-fg --irradiance-cache` runs it with one global map.
pub struct PointGather<'a> {
    pub knn: usize,
    pub stratified_rays: u32,
    pub explicit: Option<Explicit<'a>>,
    pub cache_error: Option<f32>,
}

/// Explicit sampling of the high-energy voxels.
pub struct Explicit<'a> {
    pub rays: u32,
    pub allocation: Allocation,
    pub split: &'a SplitSettings,
}

pub fn render(scene: &PreparedScene, s: &RenderSettings, m: &HeFgSettings, progress: &dyn Progress, stats: &mut Stats) -> Result<Film> {
    let gather = PointGather {
        knn: m.knn,
        stratified_rays: m.stratified_rays,
        explicit: (m.explicit_rays > 0).then_some(Explicit { rays: m.explicit_rays, allocation: m.explicit_allocation, split: &m.split }),
        cache_error: m.irradiance_cache.then_some(m.cache_error),
    };
    gather_per_point(scene, s, &gather, progress, stats)
}

/// Render with the per-point gather `g`: eye and light passes (of the photon method `s`), maps,
/// precomputed irradiance, the cache when asked for, and the gather at every eye sample.
pub fn gather_per_point(scene: &PreparedScene, s: &RenderSettings, g: &PointGather, progress: &dyn Progress, stats: &mut Stats) -> Result<Film> {
    let (eye, photons) = compose::eye_and_light(scene, s, progress, stats)?;
    let t = Instant::now();
    let split = g.explicit.as_ref().map(|e| secondary::split(scene, &photons, &[0, 1, 2], e.split));
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
    let k = (g.knn / KNN_DIVISOR).max(8);
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
        g.explicit.as_ref().map_or(Allocation::PerVoxel, |e| e.allocation),
        max_r,
    );
    let explicit_rays = g.explicit.as_ref().map_or(0, |e| e.rays);
    let gs = GatherSettings { fg_rays: g.stratified_rays, explicit_rays: if maps.high.is_some() { explicit_rays } else { 0 } };
    stats.count("fg_rays", gs.fg_rays as u64);
    stats.count("explicit_rays", gs.explicit_rays as u64);

    // Ward's irradiance cache over the eye samples whose BSDF is close to Lambertian.
    let factors: Vec<Option<Vec3>> = if g.cache_error.is_some() {
        eye.samples.par_iter().map(|e| diffuse_factor(e, &eye)).collect()
    } else {
        Vec::new()
    };
    let cache = if let Some(error) = g.cache_error {
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
        let c = IrradianceCache::build(&points, scene.radius, &CacheSettings { error }, &compute);
        stats.phase("cache", t.elapsed().as_secs_f64());
        stats.count("cache_points", points.len() as u64);
        stats.count("cache_records", c.records.len() as u64);
        stats.count("cache_rounds", c.rounds as u64);
        stats.count("cache_gather_rays", c.records.len() as u64 * (gs.fg_rays + gs.explicit_rays) as u64);
        stats.enable(&format!("irradiance cache (error {error})"), c.bytes());
        Some(c)
    } else {
        None
    };

    progress.begin("final gathering", eye.samples.len().div_ceil(CHUNK) as u64);
    let t = Instant::now();
    let k_caustic = (g.knn / 2).max(1);
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
