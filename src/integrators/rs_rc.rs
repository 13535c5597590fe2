//! `--method rs-rc`: photon ray splatting with radiance caching (§8.3): eye pass → light pass →
//! multi-pass splatting onto sparse SH cache records → image-space extrapolation → film.
//!
//! The cache assumes low-frequency light (§8.3: radiance caching "requires low-frequency
//! illumination"): caustic photons (light → specular → diffuse) are not cached — a caustic
//! extrapolated from records 8 pixels apart would be spread over its surroundings. Those whose
//! kernel at the hit is at least 4 pixels wide there (light the glass sphere spreads, not
//! focuses) are splatted onto records
//! on an image grid at most a quarter of that apart ([`CAUSTIC_GRIDS`]; not extrapolated but
//! interpolated between nodes on one surface, [`radiance_cache::grid`]), whose SH coefficients the
//! pixel's eye samples integrate with the cache's; the others onto every eye sample, as `rs` does. (When
//! glossy samples stay outside the cache, `--glossy exact|histogram`, all caustic photons take the
//! second way.)
//!
//! The cache holds incoming light in SH bands 0–3, which integrate Lambertian eye samples and the
//! glossy lobes SH holds ([`crate::radiance_map::SH_RESIDUAL_MAX`]); those it always serves. A
//! sharper lobe integrated from SH blurs its reflections, a bias more photons do not remove, so
//! `--glossy` decides for those lobes: `auto` (the default) and `sh` integrate them from the cache
//! too (the paper's method; at the default photon budget it measured lower error there than exact
//! splatting, whose photon noise is higher, and it is faster), `exact` and `histogram` splat the
//! cached photons onto their eye samples alone, as `rs` does (lower error from about 4× the
//! photons on; docs/glossy.md).

use super::compose::{self, PhotonPass};
use super::settings::attribute;
use super::{Progress, RenderSettings, Stats};
use crate::error::{Error, Result};
use crate::eye::{EyePass, GlossyTable, NO_GLOSSY};
use crate::image::Film;
use crate::photon::{PhotonClass, PhotonRay};
use crate::prepare::PreparedScene;
use crate::radiance_cache::{self, CacheParams, Integrated};
use crate::radiance_map::{GlossyMode, AUTO_MAX_TABLES, SH_RESIDUAL_MAX};
use crate::radiance_map::ShTables;
use crate::splat;
use rayon::prelude::*;
use std::borrow::Cow;
use std::time::Instant;

/// Settings of `rs-rc`.
#[derive(Clone, Debug, PartialEq)]
pub struct RsRcSettings {
    /// The photon pass; its light pass traces with [`SMOOTHNESS`] of the bandwidth's smoothness
    /// per photon class.
    pub pass: PhotonPass,
    /// Glossy lobes SH bands 0–3 do not hold: integrated from the cache (`Auto`, `Sh`) or splatted
    /// onto their eye samples (`Exact`, `Histogram`).
    pub glossy: GlossyMode,
    /// Cache error ε: record radius = ε × the harmonic mean distance of the photon rays that reached
    /// it (the splatting paper's Table 2 uses 0.4–0.9).
    pub cache_error: f32,
}

/// Default cache error ε of `rs-rc`.
pub const CACHE_ERROR: f32 = 0.5;

/// `rs-rc` traces its photons with these fractions of the smoothness C (`--smoothness`) that the
/// other photon methods use, per photon class (direct, indirect, caustic): its records are
/// extrapolated by the cache, a filter of their own, so narrower photon kernels lower the blur at
/// little noise (the splatting paper's Table 2 gives RC 0.5–0.6 of RS's C; docs/glossy.md has the
/// measurements).
pub const SMOOTHNESS: [f32; 3] = [0.75, 0.75, 0.5];

impl Default for RsRcSettings {
    fn default() -> Self {
        RsRcSettings { pass: PhotonPass::default(), glossy: GlossyMode::Auto, cache_error: CACHE_ERROR }
    }
}

impl RsRcSettings {
    pub fn validate(&self) -> Result<()> {
        super::settings::check_cache_error(self.cache_error)
    }

    pub(super) fn attributes(&self) -> Vec<(String, String)> {
        vec![attribute("glossy", self.glossy), attribute("cache_error", self.cache_error)]
    }
}

pub fn render(scene: &PreparedScene, s: &RenderSettings, m: &RsRcSettings, progress: &dyn Progress, stats: &mut Stats) -> Result<Film> {
    let (eye, photons) = compose::eye_and_light(scene, s, progress, stats)?;
    progress.begin("radiance cache", 3);
    let t = Instant::now();
    let caustic = PhotonClass::Caustic as usize;
    let cached_rays: Vec<&[PhotonRay]> = photons.rays.iter().enumerate().filter(|&(k, _)| k != caustic).map(|(_, v)| v.as_slice()).collect();
    let (mut tables, cached, why) = cached_glossy(&eye, m.glossy);
    let params = CacheParams { error: m.cache_error, ..CacheParams::default() };
    let integrated = Integrated { tables: &tables, cached: &cached };
    // wide caustic kernels go to records on image grids when the cache integrates every glossy
    // sample: `wide[k]` on the grid of spacing CAUSTIC_GRIDS[k]
    let all = photons.rays[caustic].as_slice();
    let mut wide: [Vec<PhotonRay>; CAUSTIC_GRIDS.len()] = Default::default();
    let narrow: Cow<[PhotonRay]> = if cached.iter().all(|&c| c) {
        let mut narrow = Vec::new();
        for r in all {
            // kernel radius in pixels; the coarsest grid at most a quarter of it apart
            let px = r.radius_at(r.length) / scene.camera.pixel_size_at(r.end());
            match CAUSTIC_GRIDS.iter().rposition(|&s| px >= 4.0 * s as f32) {
                Some(k) => wide[k].push(*r),
                None => narrow.push(*r),
            }
        }
        // a grid costs a tree over all its records: a grid's few rays go to the next finer one
        for k in (0..CAUSTIC_GRIDS.len()).rev() {
            if wide[k].len() < MIN_GRID_RAYS {
                let few = std::mem::take(&mut wide[k]);
                if k == 0 { narrow.extend(few) } else { wide[k - 1].extend(few) }
            }
        }
        Cow::Owned(narrow)
    } else {
        Cow::Borrowed(all)
    };
    let grids: Vec<(&[PhotonRay], usize)> = wide.iter().zip(CAUSTIC_GRIDS).map(|(v, s)| (v.as_slice(), s)).collect();
    let view = radiance_cache::View { pixel_size: &|p| scene.camera.pixel_size_at(p), raster: &|p| scene.camera.raster(p) };
    let out = radiance_cache::render(&eye, &cached_rays, &grids, &view, &params, &integrated, &|| progress.cancelled()).ok_or(Error::Cancelled)?;
    stats.phase("splat", t.elapsed().as_secs_f64());
    progress.advance(1);
    // the factors of every class as traced (direct and indirect photons are cached, caustic ones not)
    let [direct_c, indirect_c, caustic_c] = SMOOTHNESS;
    let c = m.pass.bandwidth.smoothness;
    stats.note(format!(
        "rs-rc photon kernels at smoothness C = {} / {} for the cached direct / indirect photons, {} for the caustic ones ({direct_c}, {indirect_c} and {caustic_c} × --smoothness {c}: the cache filters too)",
        direct_c * c,
        indirect_c * c,
        caustic_c * c,
    ));
    if !cached.is_empty() {
        stats.note(format!("rs-rc glossy: {why}"));
    }
    let (mut radiance, mut pairs) = (out.radiance, out.pairs);
    let uncached = cached.iter().filter(|&&c| !c).count();
    if uncached > 0 {
        // the glossy eye samples the cache does not serve receive the cached photons directly
        let t = Instant::now();
        let sub = uncached_samples(&eye, &cached);
        let mut img = splat::splat_with_map(&sub, &cached_rays, m.glossy, &|| progress.cancelled()).ok_or(Error::Cancelled)?;
        if let Some(map) = img.map.take() {
            crate::radiance_map::resolve(&sub, &map, s.seed, &mut img.radiance);
            stats.enable(&format!("histogram radiance map for the uncached glossy samples ({} slots)", map.slots()), map.bytes());
        }
        stats.phase("uncached glossy splat", t.elapsed().as_secs_f64());
        for (r, c) in radiance.iter_mut().zip(&img.radiance) {
            *r += *c;
        }
        pairs += img.pairs;
        stats.count("uncached_glossy_samples", uncached as u64);
        stats.count("uncached_glossy_pairs", img.pairs);
        stats.enable(&format!("glossy samples outside the cache: cached photons splatted onto {uncached} of them"), sub.bytes() + img.tree_bytes + img.bytes() + img.ray_box_bytes);
    }
    progress.advance(1);
    if !narrow.is_empty() {
        let t = Instant::now();
        // as `rs` splats them, glossy samples included (`--glossy`, default auto)
        // the cache's SH tables (every lobe projected) serve the map of `auto`
        // (the map holds them then, and its summary line counts them)
        let prebuilt = (m.glossy == GlossyMode::Auto).then(|| std::mem::take(&mut tables));
        // the map only where the narrow caustic reaches (a few percent of the image)
        let mut img = splat::splat_with_tables(&eye, &[&narrow], m.glossy, prebuilt, true, &|| progress.cancelled()).ok_or(Error::Cancelled)?;
        stats.phase("caustic splat", t.elapsed().as_secs_f64());
        super::rs::glossy_resolve(&eye, &mut img, s.seed, stats); // phase "glossy"
        for (r, c) in radiance.iter_mut().zip(&img.radiance) {
            *r += *c;
        }
        pairs += img.pairs;
        stats.enable("caustic splatting onto every eye sample (not cached)", img.tree_bytes + img.bytes() + img.ray_box_bytes);
    }
    progress.advance(1);
    progress.finish();
    stats.count("wide_caustic_photons", wide.iter().map(|v| v.len() as u64).sum());
    stats.count("caustic_grid_records", out.grid_records as u64);
    stats.count("cache_records", out.records as u64);
    stats.count("cache_passes", out.passes as u64);
    stats.count("cache_off_surface_samples", out.off_surface_samples as u64);
    stats.count("cache_neighbour_samples", out.neighbour_samples as u64);
    stats.count("splat_pairs", pairs);
    stats.enable(&format!("radiance cache ({} SH records, ε {})", out.records, m.cache_error), out.record_bytes);
    if tables.bytes() > 0 {
        stats.enable("SH BSDF tables", tables.bytes());
    }
    compose::film(&eye, &radiance)
}

/// Grid spacings, in pixels, of the records of wide caustic photon rays: a ray whose kernel at the
/// hit is at least 4 spacings wide there (radius, at the pixel size of the hit seen directly) is
/// splatted onto the records of the coarsest such grid ([`radiance_cache::grid`]) instead of every
/// eye sample ([`MIN_GRID_RAYS`] moves the rays of a sparsely used grid to the next finer one).
/// Three spacings suffice because caustic radii are bimodal: a focused caustic is a few pixels
/// wide, light a lens spreads is near the model's largest bandwidth.
pub const CAUSTIC_GRIDS: [usize; 3] = [1, 2, 4];
/// A grid of [`CAUSTIC_GRIDS`] with fewer rays than this gives them to the next finer grid (or the
/// eye samples): its records' tree would cost more than those rays' splats there (a tree over
/// 60 000 records costs about as much as a million splat pairs, a thousand wide rays' worth).
pub const MIN_GRID_RAYS: usize = 1000;

/// The SH tables of the glossy eye samples, which of them the cache integrates (see the module
/// documentation), and what was decided, for the render summary.
fn cached_glossy(eye: &EyePass, mode: GlossyMode) -> (ShTables, Vec<bool>, String) {
    let n = eye.glossy.len();
    let fits = |t: &ShTables, g: usize| t.tables[t.table_of[g] as usize].residual <= SH_RESIDUAL_MAX;
    // (in parallel: a million glossy samples at 500² × 4 spp)
    let share = |cached: &(dyn Fn(usize) -> bool + Sync)| 100.0 * eye.samples.par_iter().filter(|e| e.is_glossy() && !cached(e.glossy as usize)).count() as f64 / eye.samples.len().max(1) as f64;
    match mode {
        GlossyMode::Sh | GlossyMode::Auto => {
            let t = ShTables::build(&eye.glossy);
            let p = share(&|g| fits(&t, g));
            let why = if p == 0.0 {
                "every glossy lobe within SH bands 0–3, all in the SH cache".to_string()
            } else {
                format!("{mode}: the {p:.1} % of eye samples whose lobes SH bands 0–3 blur are integrated from the SH cache too (as the paper does; --glossy exact splats the photons onto them instead)")
            };
            (t, vec![true; n], why)
        }
        GlossyMode::Exact | GlossyMode::Histogram => match ShTables::build_where(&eye.glossy, AUTO_MAX_TABLES, |r| r <= SH_RESIDUAL_MAX) {
            Some(t) => {
                let cached: Vec<bool> = (0..n).into_par_iter().map(|g| fits(&t, g)).collect();
                let why = format!("{mode}: the {:.1} % of eye samples whose lobes SH bands 0–3 blur receive the cached photons directly", share(&|g| cached[g]));
                (t, cached, why)
            }
            None => {
                (ShTables::default(), vec![false; n], format!("{mode}: more distinct glossy lobes than can be projected, every glossy eye sample receives the cached photons directly"))
            }
        },
    }
}

/// The glossy eye samples that are not `cached`, as an eye pass of their own (same image, same
/// pixels and weights; in pixel order, as the splatting needs).
fn uncached_samples(eye: &EyePass, cached: &[bool]) -> EyePass {
    let (mut samples, mut glossy) = (Vec::new(), GlossyTable::default());
    for e in eye.samples.iter().filter(|e| e.glossy != NO_GLOSSY && !cached[e.glossy as usize]) {
        let g = eye.glossy.lobe(e.glossy as usize);
        samples.push(crate::eye::EyeSample { glossy: glossy.push(g.bsdf, g.wo, g.frame.n), ..*e });
    }
    EyePass::of_samples(eye.width, eye.height, samples, glossy)
}
