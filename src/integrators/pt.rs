//! The reference path tracer (`--method pt`): unbiased, next-event estimation with multiple
//! importance sampling (power heuristic) between light and BSDF sampling, Russian roulette.
//!
//! Sampling: the pixel position of sample `s` of pixel `i` is point `s` of the pixel's scrambled
//! Sobol sequence ([`PixelSampler`]), and the path's decisions of its first bounces are points `s`
//! of padded Sobol slots of their own ([`PathSampler`]), so the samples of a pixel are stratified in
//! each decision; deeper decisions draw from PCG32 seeded by `(seed, i, s)`.
//!
//! Determinism: every sample's numbers are a function of `(seed, i, s)` only, and every pixel accumulates its samples in sample order, so the image is bit-identical for any thread
//! count and any tiling of the work. Primary rays of a tile go to Embree in one coherent batch.
//!
//! Pixel filter: with the box over the pixel (the default) a pixel is the mean of its samples;
//! with another filter (`image::filter`) each tile splats its samples' direct and indirect
//! radiance over the pixels the filter reaches, and the tiles merge in tile order (so the image
//! stays the same for any thread count). The AOVs (albedo, normal, depth) stay per pixel.

use super::allocation::lum;
use super::{Progress, RenderSettings, Stats};
use crate::bsdf::TransportMode;
use crate::embree::{self, Hit, Ray};
use crate::error::{Error, Result};
use crate::image::{Film, FilteredImage, SplatTile};
use crate::prepare::{glossy_spread, PreparedScene, RayCone, SurfaceHit};
use crate::sampling::{power_heuristic, Decision, Frame, PathDecisions, PathSampler, PixelSampler, PixelSlots, SlottedPathSampler};
use glam::Vec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

const TILE: u32 = 16;
/// A timed render's next chunk of samples is predicted to take the time left over this.
const TIMED_CHUNKS: f64 = 4.0;
/// Stream of the path tracer's pixel positions ([`PixelSampler`]).
const PIXEL_STREAM: u64 = 0x5054_5058; // "PTPX"
/// Stream of the camera samples' lens points (a camera with depth of field).
const LENS_STREAM: u64 = 0x5054_4c4e; // "PTLN"
/// Stream of the path tracer's path decisions ([`PathSampler`]).
const PATH_STREAM: u64 = 0x5054_5041; // "PTPA"
/// Paths of this depth and beyond are subject to Russian roulette.
const RR_DEPTH: u32 = 3;

/// Per-pixel sums of one tile (channels as in `Accum`).
#[derive(Default, Clone, Copy)]
struct Accum {
    direct: Vec3,
    indirect: Vec3,
    albedo: Vec3,
    normal: Vec3,
    depth: f32,
    depth_n: u32,
    /// The sum of the squares of the samples' direct luminance ([`DIRECT_MOMENTS_LAYER`]).
    direct_sq: f32,
    /// The sum of the squares of the samples' indirect luminance ([`INDIRECT_MOMENTS_LAYER`]).
    indirect_sq: f32,
}

/// The film layer of each pixel's mean luminance of its samples' direct light and the mean of its
/// square (channels `M1`, `M2`; the box over the pixel whatever the filter): the spread of the
/// direct light per sample, by which `auto` blends it with a photon pass's per pixel. The mean of
/// squares, unlike a variance, merges across renders of more samples as the means do.
pub const DIRECT_MOMENTS_LAYER: &str = "direct_moments";

/// The same moments of the indirect light: its variance per pixel, rare bright paths included,
/// by which `auto` weighs passes corrected by these samples against the samples themselves.
pub const INDIRECT_MOMENTS_LAYER: &str = "indirect_moments";

/// First-hit data for the AOVs.
struct FirstHit {
    albedo: Vec3,
    normal: Vec3,
    depth: f32,
}

/// Radiance along one camera path split into direct (emission seen directly and single-bounce
/// lighting) and indirect (everything else).
pub struct PathResult {
    pub direct: Vec3,
    pub indirect: Vec3,
    first: Option<FirstHit>,
}

/// Render the image.
pub fn render(scene: &PreparedScene, s: &RenderSettings, progress: &dyn Progress, stats: &mut Stats) -> Result<Film> {
    let cam = &scene.camera;
    let (w, h) = (cam.width, cam.height);
    let tiles = tile_grid(w, h);
    let mut acc = crate::memory::try_vec((w * h) as usize, Accum::default(), || format!("the path tracer's sums of {w}x{h} pixels"))?;
    let mut filtered = (!s.filter.is_pixel_box()).then(|| FilteredImage::new(w, h, 6));
    let rays = AtomicU64::new(0);
    let t0 = Instant::now();
    // Chunks of samples; a time budget stops between chunks (at least one). A timed render starts
    // with one sample, then takes chunks of the time left over [`TIMED_CHUNKS`] at the rate so far:
    // each chunk pays the tiles' per-pixel seeds once, and the last one stays about a sample long.
    let mut chunk = if s.time_budget.is_some() { 1 } else { s.spp };
    progress.begin("path tracing", tiles.len() as u64);
    // a range of passes is the range of sample indices they hold
    let (first, end) = s.passes.map_or((0, s.spp), |p| (p.first * s.spp, p.end * s.spp));
    let mut done = first;
    while done < end {
        let n = chunk.min(end - done);
        let results: Vec<Result<(Vec<Accum>, Option<SplatTile>)>> = tiles
            .par_iter()
            .map(|&(tx, ty)| {
                if progress.cancelled() {
                    return Err(Error::Cancelled);
                }
                embree::set_flush_denormals();
                let r = render_tile(scene, s, tx, ty, done, n, &rays, progress).ok_or(Error::Cancelled)?;
                progress.advance(1);
                Ok(r)
            })
            .collect();
        for (&(tx, ty), r) in tiles.iter().zip(results) {
            let (tile, splats) = r?;
            if let (Some(image), Some(t)) = (filtered.as_mut(), &splats) {
                image.merge(t);
            }
            let (x0, y0) = (tx * TILE, ty * TILE);
            let tw = TILE.min(w - x0);
            for (k, a) in tile.into_iter().enumerate() {
                let (x, y) = (x0 + k as u32 % tw, y0 + k as u32 / tw);
                let dst = &mut acc[(y * w + x) as usize];
                dst.direct += a.direct;
                dst.indirect += a.indirect;
                dst.albedo += a.albedo;
                dst.normal += a.normal;
                dst.direct_sq += a.direct_sq;
                dst.indirect_sq += a.indirect_sq;
                if a.depth_n > 0 {
                    dst.depth = if dst.depth_n > 0 { dst.depth.min(a.depth) } else { a.depth };
                    dst.depth_n += a.depth_n;
                }
            }
        }
        done += n;
        if let Some(budget) = s.time_budget {
            let elapsed = t0.elapsed().as_secs_f64();
            if elapsed >= budget {
                break;
            }
            let per_sample = elapsed / (done - first) as f64;
            chunk = ((budget - elapsed) / (TIMED_CHUNKS * per_sample.max(1e-9))).floor().clamp(1.0, u32::MAX as f64) as u32;
            progress.begin("path tracing", tiles.len() as u64);
        }
    }
    progress.finish();
    stats.phase("trace", t0.elapsed().as_secs_f64());
    stats.count("spp", (done - first) as u64);
    stats.count("rays", rays.load(Ordering::Relaxed));
    film_of(&acc, filtered.as_ref(), w, h, done - first)
}

/// The film of the sums `acc`, its direct and indirect radiance from `filtered` when the pixel
/// filter is not the box over the pixel.
fn film_of(acc: &[Accum], filtered: Option<&FilteredImage>, w: u32, h: u32, spp: u32) -> Result<Film> {
    let inv = 1.0 / spp as f32;
    let what = || format!("the {w}x{h} image's layers");
    let (direct, indirect): (Vec<Vec3>, Vec<Vec3>) = match filtered {
        Some(image) => image.resolve().chunks_exact(6).map(|v| (Vec3::new(v[0], v[1], v[2]), Vec3::new(v[3], v[4], v[5]))).unzip(),
        None => (
            crate::memory::try_collect(acc.iter().map(|a| a.direct * inv), what)?,
            crate::memory::try_collect(acc.iter().map(|a| a.indirect * inv), what)?,
        ),
    };
    let albedo: Vec<Vec3> = crate::memory::try_collect(acc.iter().map(|a| a.albedo * inv), what)?;
    let normal: Vec<Vec3> = crate::memory::try_collect(acc.iter().map(|a| a.normal.normalize_or_zero()), what)?;
    let depth: Vec<f32> = crate::memory::try_collect(acc.iter().map(|a| if a.depth_n > 0 { a.depth } else { 0.0 }), what)?;
    let mut film = super::aov::film(w, h, &super::aov::Aovs { direct: &direct, indirect: &indirect, albedo: &albedo, normal: &normal, depth: &depth })?;
    for (name, part) in [(DIRECT_MOMENTS_LAYER, 0), (INDIRECT_MOMENTS_LAYER, 1)] {
        let moments = film.try_add_layer(name, &["M1", "M2"])?;
        for (m, a) in film.layers[moments].data.chunks_exact_mut(2).zip(acc) {
            let (sum, sq) = if part == 0 { (a.direct, a.direct_sq) } else { (a.indirect, a.indirect_sq) };
            m[0] = lum(&sum.to_array()) as f32 * inv;
            m[1] = sq * inv;
        }
    }
    Ok(film)
}

/// One tile's samples `s0 .. s0 + n`: per-pixel sums, and the filtered radiance when the pixel
/// filter is not the box over the pixel; `None` when cancelled (checked before every sample).
#[allow(clippy::too_many_arguments)]
fn render_tile(
    scene: &PreparedScene,
    s: &RenderSettings,
    tx: u32,
    ty: u32,
    s0: u32,
    n: u32,
    rays: &AtomicU64,
    progress: &dyn Progress,
) -> Option<(Vec<Accum>, Option<SplatTile>)> {
    let cam = &scene.camera;
    let (w, h) = (cam.width, cam.height);
    let (x0, y0) = (tx * TILE, ty * TILE);
    let (tw, th) = (TILE.min(w - x0), TILE.min(h - y0));
    let npix = (tw * th) as usize;
    let mut acc = vec![Accum::default(); npix];
    let mut splats = (!s.filter.is_pixel_box()).then(|| SplatTile::new(s.filter, [x0, y0, tw, th], [w, h], 6));
    let mut film_pos = Vec::with_capacity(npix);
    let mut primary = Vec::with_capacity(npix);
    let mut hits: Vec<Option<Hit>> = vec![None; npix];
    let mut samplers = Vec::with_capacity(npix);
    let seeds = tile_seeds(scene, s.seed, [x0, y0, tw, th]);
    let forward = cam.forward();
    let pixel_cone = cam.cone();
    let mut traced = 0u64;
    for sample in s0..s0 + n {
        if progress.cancelled() {
            rays.fetch_add(traced, Ordering::Relaxed);
            return None;
        }
        primary.clear();
        samplers.clear();
        film_pos.clear();
        for (pixel_sampler, path_hash, slots, lens, [x, y, ix, iy]) in &seeds {
            let jitter = pixel_sampler.sample(sample);
            if splats.is_some() {
                film_pos.push((x + jitter.x, y + jitter.y));
            }
            primary.push(cam.ray_lens(ix + jitter.x, iy + jitter.y, || lens.sample(sample)));
            samplers.push(SlottedPathSampler::new(slots, *path_hash, sample));
        }
        scene.embree.intersect_batch(&primary, &mut hits, true);
        // each of the image's samples stands for its share of the pixel (a time budget adds
        // samples one at a time: sample `sample` is then one of `sample + 1`)
        let cone = pixel_cone.per_sample(match (s.time_budget, s.passes) {
            (Some(_), _) => sample + 1,
            (None, Some(p)) => p.total * s.spp,
            (None, None) => s.spp,
        });
        for k in 0..npix {
            let first = hits[k].map(|hh| scene.surface_hit_cone(&primary[k], &hh, Some(cone)));
            let (r, nrays) = trace_path(scene, primary[k], first, Some(cone), &mut samplers[k], s.max_depth);
            traced += nrays;
            if let Some(t) = splats.as_mut() {
                let (fx, fy) = film_pos[k];
                t.add(fx, fy, &[r.direct.x, r.direct.y, r.direct.z, r.indirect.x, r.indirect.y, r.indirect.z]);
            }
            let a = &mut acc[k];
            a.direct += r.direct;
            a.indirect += r.indirect;
            a.direct_sq += (lum(&r.direct.to_array()) as f32).powi(2);
            a.indirect_sq += (lum(&r.indirect.to_array()) as f32).powi(2);
            if let Some(f) = r.first {
                a.albedo += f.albedo;
                a.normal += f.normal;
                let z = f.depth * primary[k].dir.dot(forward);
                a.depth = if a.depth_n > 0 { a.depth.min(z) } else { z };
                a.depth_n += 1;
            }
        }
    }
    rays.fetch_add(traced, Ordering::Relaxed);
    Some((acc, splats))
}

/// One pixel's seeds: its positions' sampler, the hash of its path decisions and their padded
/// slots (the samplers a `PathSampler` per sample would build at every decision), its lens
/// sampler, and its corner on the film and in the whole image (a crop window's pixels are placed as
/// the whole image's; the film position is the window's).
type PixelSeeds = (PixelSampler, u64, PixelSlots, PixelSampler, [f32; 4]);

/// The seeds of the pixels of tile `[x0, y0, width, height]`, row by row: built once per chunk of
/// samples.
fn tile_seeds(scene: &PreparedScene, seed: u64, [x0, y0, tw, th]: [u32; 4]) -> Vec<PixelSeeds> {
    let cam = &scene.camera;
    (0..tw * th)
        .map(|k| {
            let (x, y) = (x0 + k % tw, y0 + k / tw);
            let pixel = cam.pixel_index(x, y);
            let path_hash = PathSampler::pixel_hash(seed, PATH_STREAM, pixel);
            let lens = PixelSampler::new(seed, LENS_STREAM, pixel);
            let corner = [x as f32, y as f32, (x + cam.offset[0]) as f32, (y + cam.offset[1]) as f32];
            (PixelSampler::new(seed, PIXEL_STREAM, pixel), path_hash, PixelSlots::new(path_hash), lens, corner)
        })
        .collect()
}

/// Wall-clock seconds of building every tile's seeds ([`tile_seeds`]) on the current rayon pool:
/// what a one-sample render pays besides its paths and a chunk of many samples pays once.
pub fn seeds_seconds(scene: &PreparedScene, seed: u64) -> f64 {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let tiles = tile_grid(w, h);
    let t = Instant::now();
    let built: usize = tiles
        .par_iter()
        .map(|&(tx, ty)| {
            let (x0, y0) = (tx * TILE, ty * TILE);
            std::hint::black_box(tile_seeds(scene, seed, [x0, y0, TILE.min(w - x0), TILE.min(h - y0)])).len()
        })
        .sum();
    debug_assert_eq!(built, (w * h) as usize);
    t.elapsed().as_secs_f64()
}

/// The tiles of a `w` × `h` image, `(tx, ty)` row by row.
fn tile_grid(w: u32, h: u32) -> Vec<(u32, u32)> {
    (0..h.div_ceil(TILE)).flat_map(|ty| (0..w.div_ceil(TILE)).map(move |tx| (tx, ty))).collect()
}

/// Trace one camera path whose first intersection `first` is already known, the camera ray's
/// cone `cone` (kept through specular and glossy bounces, widened by glossy lobes, dropped at
/// diffuse ones: texture lookups filter over its footprint).
/// Returns the path's radiance and the number of rays traced (including shadow rays).
pub fn trace_path(
    scene: &PreparedScene,
    mut ray: Ray,
    first: Option<SurfaceHit>,
    mut cone: Option<RayCone>,
    sampler: &mut impl PathDecisions,
    max_depth: u32,
) -> (PathResult, u64) {
    let lights = &scene.lights;
    let textures = &scene.textures;
    let mut out = PathResult { direct: Vec3::ZERO, indirect: Vec3::ZERO, first: None };
    let mut beta = Vec3::ONE;
    let mut specular = true; // camera rays count as specular (no MIS for emission seen directly)
    let mut prev_pdf = 0.0f32;
    let mut prev_p = ray.org;
    let mut hit = first;
    let mut nrays = 1u64;
    for depth in 0..max_depth {
        // Add to `direct` for the camera vertex and the first bounce, to `indirect` beyond.
        let add = |out: &mut PathResult, bounce: u32, v: Vec3| {
            if bounce <= 1 {
                out.direct += v
            } else {
                out.indirect += v
            }
        };
        let tmax = hit.map_or(f32::INFINITY, |hh| hh.t);
        // Analytic area lights crossed by the ray (they do not occlude).
        for &li in &lights.analytic {
            let e = &lights.emitters[li as usize];
            if let Some((t, le)) = e.intersect(ray.org, ray.dir, tmax) {
                if le != Vec3::ZERO {
                    let w = if specular {
                        1.0
                    } else {
                        power_heuristic(1.0, prev_pdf, 1.0, lights.pmf(li as usize) * e.pdf_li(prev_p, ray.dir, t))
                    };
                    add(&mut out, depth, beta * le * w);
                }
            }
        }
        let Some(h) = hit else {
            for &li in &lights.infinite {
                let e = &lights.emitters[li as usize];
                let le = e.le_infinite(ray.dir, textures);
                if le != Vec3::ZERO {
                    let w = if specular {
                        1.0
                    } else {
                        power_heuristic(1.0, prev_pdf, 1.0, lights.pmf(li as usize) * e.pdf_li(prev_p, ray.dir, 0.0))
                    };
                    add(&mut out, depth, beta * le * w);
                }
            }
            break;
        };
        let wo = -ray.dir;
        let le = scene.emitted(&h, wo);
        if le != Vec3::ZERO {
            let w = match (specular, lights.triangle_emitter(h.instance, h.prim)) {
                (false, Some(li)) => {
                    let e = &lights.emitters[li as usize];
                    power_heuristic(1.0, prev_pdf, 1.0, lights.pmf(li as usize) * e.pdf_li(prev_p, ray.dir, h.t))
                }
                _ => 1.0,
            };
            add(&mut out, depth, beta * le * w);
        }
        let frame = Frame::from_normal(h.ns);
        let wo_l = frame.to_local(wo);
        // The per-`wo` work (lobe albedos and probabilities) once, for both NEE and sampling.
        let bsdf_at = scene.bsdf_at(&h, wo_l);
        let bsdf = bsdf_at.bsdf();
        if depth == 0 {
            out.first = Some(FirstHit { albedo: scene.albedo(&h, bsdf), normal: h.ns, depth: h.t });
        }
        let flags = bsdf.flags();
        // Next-event estimation for non-delta lobes.
        if flags.is_diffuse() || flags.is_glossy() {
            if let Some((li, pmf)) = lights.choose_with(PathSampler::is_padded(depth), || sampler.get_1d(depth, Decision::LightChoice)) {
                let e = &lights.emitters[li];
                let u = sampler.get_2d(depth, Decision::LightPoint);
                if let Some(ls) = e.sample_li(h.p, u, textures) {
                    let wi_l = frame.to_local(ls.wi);
                    let (f, bsdf_pdf) = bsdf_at.eval_pdf(wi_l, TransportMode::Radiance);
                    let f = f * wi_l.z.abs();
                    if f != Vec3::ZERO && ls.li != Vec3::ZERO {
                        nrays += 1;
                        if !scene.occluded(h.p, h.ng, ls.wi, ls.dist) {
                            let w = if ls.delta {
                                1.0
                            } else {
                                power_heuristic(1.0, pmf * ls.pdf, 1.0, bsdf_pdf)
                            };
                            add(&mut out, depth + 1, beta * f * ls.li * (w / (pmf * ls.pdf)));
                        }
                    }
                }
            }
        }
        // Continue the path by BSDF sampling.
        let uc = sampler.get_1d(depth, Decision::LobeChoice);
        let u = sampler.get_2d(depth, Decision::BsdfDirection);
        let Some(bs) = bsdf_at.sample(uc, u, TransportMode::Radiance) else { break };
        if bs.pdf <= 0.0 || bs.f == Vec3::ZERO {
            break;
        }
        beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
        if !beta.is_finite() {
            break;
        }
        specular = bs.flags.is_specular();
        prev_pdf = bs.pdf;
        prev_p = h.p;
        let wi = frame.to_world(bs.wi);
        let arrived = h.t * ray.dir.length();
        cone = match cone {
            Some(c) if specular => Some(c.bounce(arrived, 0.0)),
            Some(c) if bs.flags.is_glossy() => Some(c.bounce(arrived, glossy_spread(bs.pdf))),
            _ => None,
        };
        ray = scene.spawn(h.p, h.ng, wi);
        // Russian roulette with survival probability = throughput (pbrt-v4): the weight after
        // survival is at most 1. A cap below 1 (the former `min(0.95)`) makes the weight grow as
        // (ρ/0.95)^n when the albedo ρ > 0.95, with infinite variance for ρ² > 0.95: the 0.999
        // furnace rendered at ~0.3× its value. Throughput ≥ 1 is not rouletted (max_depth bounds it).
        if depth + 1 >= RR_DEPTH {
            let q = beta.max_element();
            if q < 1.0 {
                if !(q > 0.0) || sampler.get_1d(depth, Decision::Roulette) >= q {
                    break;
                }
                beta /= q;
            }
        }
        nrays += 1;
        hit = scene.intersect_cone(&ray, cone);
    }
    (out, nrays)
}

/// Stream of [`seconds_per_sample`]'s paths.
const PROBE_STREAM: u64 = 0x5054_5052; // "PTPR"
/// Paths [`seconds_per_sample`] times (one per pixel of a strided subset of the image).
const PROBE_PATHS: usize = 4096;

/// What [`probe`] measured of the path tracer at the image size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Probe {
    /// Wall-clock seconds of one sample per pixel of the whole image on the current rayon pool.
    pub seconds_per_spp: f64,
    /// Variance of one path's luminance, mean over the probed pixels, of its direct part
    /// (emission seen directly and single-bounce light) and of its indirect part.
    pub variance: [f64; 2],
    /// The same variances relative to each pixel's value ([`pair_variances`]).
    pub relative_variance: [f64; 2],
}

impl Probe {
    /// The path tracer's predicted MSE (luminance, mean over pixels) after `seconds`.
    pub fn predicted(&self, seconds: f64) -> f64 {
        let spp = (seconds / self.seconds_per_spp.max(1e-12)).max(1.0);
        (self.variance[0] + self.variance[1]) / spp
    }
}

/// Time the path tracer and measure its noise: two paths per pixel of a strided subset of at
/// most [`PROBE_PATHS`] pixels (traced once untimed first: the BSDF tables of the materials the
/// paths meet are filled on first use), half the squared difference of each pixel's two paths
/// being an unbiased estimate of one path's variance there. The relative variances weigh each
/// probed pixel by its luminance in `values` (one per pixel of the image, best smoothed, from other
/// paths) when given, else by the mean of its own two paths, whose rare bright path shrinks its
/// own weight: on Crytek Sponza at 400² that put 56–68 % of the relative variance in the indirect
/// light where the converged image's values put 86–90 %, and the 8×8-pixel block means of another
/// sample of the whole image 78–93 %.
pub fn probe(scene: &PreparedScene, seed: u64, max_depth: u32, values: Option<&[f64]>) -> Probe {
    let cam = &scene.camera;
    let pixels = cam.width as usize * cam.height as usize;
    let stride = pixels.div_ceil(PROBE_PATHS).max(1);
    let probe: Vec<u64> = (0..pixels as u64).step_by(stride).collect();
    let lum = |v: Vec3| 0.2126 * v.x as f64 + 0.7152 * v.y as f64 + 0.0722 * v.z as f64;
    let trace = |pass: u32| -> Vec<[f64; 2]> {
        probe
            .par_iter()
            .map(|&pixel| {
                embree::set_flush_denormals();
                let (x, y) = ((pixel % cam.width as u64) as f32, (pixel / cam.width as u64) as f32);
                let jitter = PixelSampler::new(seed, PROBE_STREAM, pixel).sample(pass);
                let ray = cam.ray_lens(x + jitter.x, y + jitter.y, || PixelSampler::new(seed, LENS_STREAM, pixel).sample(pass));
                let mut sampler = PathSampler::new(seed, PROBE_STREAM, pixel, pass);
                let cone = Some(cam.cone());
                let r = trace_path(scene, ray, scene.intersect_cone(&ray, cone), cone, &mut sampler, max_depth).0;
                [lum(r.direct), lum(r.indirect)]
            })
            .collect()
    };
    let warm = trace(2);
    let t = Instant::now();
    let (a, b) = (trace(0), trace(1));
    let seconds_per_spp = t.elapsed().as_secs_f64() / 2.0 * pixels as f64 / probe.len().max(1) as f64;
    drop(warm);
    let values: Vec<f64> = match values.filter(|v| v.len() == pixels) {
        Some(v) => probe.iter().map(|&pixel| v[pixel as usize]).collect(),
        None => a.iter().zip(&b).map(|(x, y)| 0.5 * (x[0] + x[1] + y[0] + y[1])).collect(),
    };
    let (variance, relative_variance) = pair_variances(&a, &b, &values);
    Probe { seconds_per_spp, variance, relative_variance }
}

/// The weight of a pixel of luminance `value` in a relative MSE: `1 / (value² + 0.01)`, as
/// `raysplat compare` weighs it.
pub fn relative_weight(value: f64) -> f64 {
    1.0 / (value * value + RELATIVE_EPS * RELATIVE_EPS)
}

/// `ε` of [`relative_weight`]: `raysplat compare`'s relative MSE divides by `r² + 0.01`.
const RELATIVE_EPS: f64 = 0.1;

/// Variance of one path's direct and indirect luminance from two independent paths per pixel
/// (`[direct, indirect]` each): half the squared difference of a pixel's two paths, mean over the
/// pixels — plain, and relative: each pixel's times [`relative_weight`] of its `values` (its
/// luminance, best smoothed over neighbours: a rare bright path, whose own value would shrink its
/// weight, then counts in full). The relative one weighs the pixels as a relative MSE does: a light
/// in view, whose edge makes most of the plain variance, counts little.
pub fn pair_variances(a: &[[f64; 2]], b: &[[f64; 2]], values: &[f64]) -> ([f64; 2], [f64; 2]) {
    let n = a.len().min(b.len()).max(1) as f64;
    let (mut plain, mut relative) = ([0.0; 2], [0.0; 2]);
    for ((x, y), &m) in a.iter().zip(b).zip(values) {
        let w = relative_weight(m);
        for k in 0..2 {
            let v = 0.5 * (x[k] - y[k]).powi(2);
            plain[k] += v / n;
            relative[k] += v * w / n;
        }
    }
    (plain, relative)
}

/// Wall-clock seconds one sample per pixel of the whole image costs the path tracer on the current
/// rayon pool ([`probe`]'s timing).
pub fn seconds_per_sample(scene: &PreparedScene, seed: u64, max_depth: u32) -> f64 {
    probe(scene, seed, max_depth, None).seconds_per_spp
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::SilentProgress;

    /// A timed render traces its samples in chunks of growing and shrinking size: its image is the
    /// untimed render of as many samples (to rounding: the sums are added chunk by chunk), so no
    /// sample is skipped or traced twice. On the Cornell box, which has no textures, the ray
    /// cones (one sample's share of a pixel) change nothing.
    #[test]
    fn a_timed_render_is_the_untimed_render_of_its_samples() {
        let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.usda"));
        let scene = PreparedScene::new(crate::usd::load_scene(path).expect("scene"), 16, 16, 1).expect("prepare");
        let base = RenderSettings { seed: 9, ..Default::default() };
        let mut stats = Stats::default();
        let timed = render(&scene, &RenderSettings { time_budget: Some(0.3), spp: 1 << 20, ..base.clone() }, &SilentProgress, &mut stats).unwrap();
        let n = stats.counter("spp").unwrap() as u32;
        assert!(n >= 16, "{n} samples in 0.3 s");
        let untimed = render(&scene, &RenderSettings { spp: n, ..base }, &SilentProgress, &mut Stats::default()).unwrap();
        let (a, b) = (&timed.layer("").unwrap().data, &untimed.layer("").unwrap().data);
        let worst = a.iter().zip(b).map(|(x, y)| (x - y).abs() / y.abs().max(1e-3)).fold(0.0f32, f32::max);
        assert!(worst < 1e-4, "{n} samples: largest relative difference {worst}");
    }

    /// The probe's relative variances weigh each probed pixel by the value given for it: values of
    /// zero weigh every pixel by `1 / 0.01`, leaving the plain variances (the same paths) times 100.
    #[test]
    fn the_probe_weighs_its_pixels_by_the_values_given() {
        let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.usda"));
        let scene = PreparedScene::new(crate::usd::load_scene(path).expect("scene"), 24, 24, 1).expect("prepare");
        let own = probe(&scene, 5, 16, None);
        let zeros = probe(&scene, 5, 16, Some(&vec![0.0; 24 * 24]));
        for k in 0..2 {
            assert_eq!(own.variance[k], zeros.variance[k], "the same paths");
            assert!(own.variance[k] > 0.0);
            let expected = own.variance[k] / (RELATIVE_EPS * RELATIVE_EPS);
            assert!((zeros.relative_variance[k] - expected).abs() <= 1e-9 * expected, "{} against {expected}", zeros.relative_variance[k]);
            assert!(own.relative_variance[k] < zeros.relative_variance[k], "lit pixels weigh less by their own values");
        }
    }

    /// The direct and indirect light's moments per pixel: the first is the layer's luminance (the
    /// box filter), the second at least its square, and above it where the samples differ: on
    /// the Cornell box the light's edge in view and the shadows' penumbrae for the direct light,
    /// nearly every pixel for the indirect.
    #[test]
    fn the_moments_are_the_samples_mean_and_mean_square() {
        let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.usda"));
        let scene = PreparedScene::new(crate::usd::load_scene(path).expect("scene"), 24, 24, 1).expect("prepare");
        let film = render(&scene, &RenderSettings { seed: 3, spp: 16, ..Default::default() }, &SilentProgress, &mut Stats::default()).unwrap();
        for (layer, moments_layer, least) in [("direct", DIRECT_MOMENTS_LAYER, 24 * 24 / 10), ("indirect", INDIRECT_MOMENTS_LAYER, 24 * 24 / 2)] {
            let (values, moments) = (film.layer(layer).unwrap(), film.layer(moments_layer).unwrap());
            let mut spread = 0;
            for (d, m) in values.data.chunks_exact(3).zip(moments.data.chunks_exact(2)) {
                let l = lum(d) as f32;
                assert!((m[0] - l).abs() <= 1e-5 * l.abs().max(1.0), "{layer}: mean {} against the layer's {l}", m[0]);
                assert!(m[1] >= m[0] * m[0] * (1.0 - 1e-5), "{layer}: mean square {} below the mean's square {}", m[1], m[0] * m[0]);
                spread += (m[1] > 1.01 * m[0] * m[0] + 1e-6) as usize;
            }
            assert!(spread > least, "{spread} pixels whose samples' {layer} light differs");
        }
    }
}
