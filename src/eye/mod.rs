//! The eye pass (§3 of `photon-ray-splatting.md`): primary rays from the camera create *eye samples*
//! at the first non-specular hit — position, shading normal, pixel, RGB weight, and the BSDF for
//! glossy surfaces — while light is explicitly sampled there for the direct component, emission seen
//! directly is recorded, and specular reflections and refractions are followed (one branch per
//! sample, chosen by the BSDF's own probabilities; several samples per pixel cover both branches).
//!
//! Eye samples are compact (36 bytes): diffuse samples fold `albedo/π` into their weight so splatting
//! needs no BSDF evaluation; glossy samples index a side table holding their BSDF and view direction
//! ("model only what the scene requires").
//!
//! Pixel filter: with a filter other than the box over the pixel ([`eye_pass_filtered`]) each
//! camera sample's offset from its pixel centre is drawn from the filter ([`FilterSampler`]) and
//! its throughput weighted by f / pdf; the sample still belongs to its pixel, so everything after
//! the eye pass is unchanged and each pixel estimates the filtered image.

use crate::bsdf::TransportMode;
use crate::embree::{self, Hit, Ray};
use crate::image::{FilterSampler, PixelFilter};
use crate::prepare::PreparedScene;
use crate::sampling::{hash, oct_decode, oct_encode, Decision, Frame, PathSampler, PixelSampler, Rng};
use glam::Vec3;
use rayon::prelude::*;

mod direct;
mod glossy;
pub use direct::{bsdf_sample, light_sample, BSDF_SAMPLES};
pub use glossy::{GlossyLobe, GlossySample, GlossyTable};

const EYE_STREAM: u64 = 0x4559_4550; // "EYEP"
/// Stream of the camera samples' lens points (a camera with depth of field).
const EYE_LENS_STREAM: u64 = 0x4559_4c4e; // "EYLN"
/// Stream of the eye pass's light samples ([`PathSampler`] slots: stratified per pixel).
const EYE_LIGHT_STREAM: u64 = 0x4559_454c; // "EYEL"
/// Stream of the eye pass's BSDF samples of the direct light (stratified per pixel).
const EYE_BSDF_STREAM: u64 = 0x4559_4542; // "EYEB"
/// Maximum number of specular bounces followed from the camera.
const MAX_SPECULAR: u32 = 16;
/// `EyeSample::glossy` of a Lambertian eye sample.
pub const NO_GLOSSY: u32 = u32::MAX;

/// One eye sample.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct EyeSample {
    pub p: [f32; 3],
    /// Octahedral-encoded shading normal, on the side the view ray arrived from.
    pub n: u32,
    /// Pixel weight (throughput / spp); for diffuse samples also × albedo/π.
    pub weight: [f32; 3],
    pub pixel: u32,
    /// Index into `EyePass::glossy`, or `u32::MAX` for a Lambertian sample.
    pub glossy: u32,
}

const _: () = assert!(std::mem::size_of::<EyeSample>() == 36);

impl EyeSample {
    #[inline]
    pub fn pos(&self) -> Vec3 {
        Vec3::from(self.p)
    }
    #[inline]
    pub fn normal(&self) -> Vec3 {
        oct_decode(self.n)
    }
    #[inline]
    pub fn weight(&self) -> Vec3 {
        Vec3::from(self.weight)
    }
    #[inline]
    pub fn is_glossy(&self) -> bool {
        self.glossy != NO_GLOSSY
    }
}

/// Settings of the eye pass.
#[derive(Clone, Copy, Debug)]
pub struct EyeSettings {
    /// Eye samples per pixel (the density estimate's).
    pub spp: u32,
    /// Camera samples per pixel for anti-aliasing, emission, direct light and AOVs; at least `spp`
    /// (smaller values mean `spp`). Samples `0..spp` of the pixel's stratified sequence are the eye
    /// samples; the rest only add emission, direct light and AOVs.
    pub aa_spp: u32,
    pub seed: u64,
    /// Light samples per eye sample for the direct component (0: direct light comes from photons).
    pub light_samples: u32,
}

/// The result of the eye pass.
pub struct EyePass {
    pub width: u32,
    pub height: u32,
    pub samples: Vec<EyeSample>,
    pub glossy: GlossyTable,
    /// Per pixel: emission seen directly (possibly through specular bounces).
    pub emitted: Vec<Vec3>,
    /// Per pixel: direct lighting at the eye samples (light and BSDF samples, MIS-weighted).
    pub direct: Vec<Vec3>,
    /// Per pixel: the estimated variance of the luminance of `emitted + direct` (the pixel's mean
    /// over its camera samples), from the spread of its camera samples; 0 with one camera sample.
    pub direct_variance: Vec<f32>,
    pub albedo: Vec<Vec3>,
    pub normal: Vec<Vec3>,
    pub depth: Vec<f32>,
    pub rays: u64,
}

impl EyePass {
    /// Eye samples made elsewhere (final-gather hits, radiance-cache records) to splat onto, with no
    /// per-pixel images and no rays of their own.
    pub fn of_samples(width: u32, height: u32, samples: Vec<EyeSample>, glossy: GlossyTable) -> EyePass {
        EyePass { width, height, samples, glossy, emitted: Vec::new(), direct: Vec::new(), direct_variance: Vec::new(), albedo: Vec::new(), normal: Vec::new(), depth: Vec::new(), rays: 0 }
    }

    pub fn bytes(&self) -> u64 {
        (self.samples.len() * std::mem::size_of::<EyeSample>()) as u64 + self.glossy.bytes()
    }
}

/// The eye samples one image row produced (part of its [`RowBuf`], reused from band to band).
#[derive(Default)]
struct RowOut {
    samples: Vec<EyeSample>,
    glossy: GlossyTable,
    rays: u64,
}

/// A row's light samples waiting for their visibility test: traced together, as one coherent
/// batch, once the row's pixels are done.
#[derive(Default)]
struct Shadows {
    rays: Vec<Ray>,
    /// Per light sample in pixel order: its camera sample's index in the row (`x · aa + k`), the
    /// unoccluded contribution, and the index of its shadow ray in `rays` (`u32::MAX`: nothing can
    /// block it).
    pending: Vec<(u32, Vec3, u32)>,
    blocked: Vec<bool>,
}

impl Shadows {
    fn clear(&mut self) {
        self.rays.clear();
        self.pending.clear();
    }

    fn push(&mut self, slot: u32, contribution: Vec3, ray: Option<Ray>) {
        let r = ray.map_or(u32::MAX, |r| {
            self.rays.push(r);
            (self.rays.len() - 1) as u32
        });
        self.pending.push((slot, contribution, r));
    }

    /// Trace the shadow rays and add the unblocked contributions to their pixels, in the order the
    /// samples were taken (the same sums as testing each sample as it is drawn), and to their camera
    /// samples' totals in `per_sample` (`aa` per pixel).
    fn resolve(&mut self, scene: &PreparedScene, pixels: &mut [PixelOut], per_sample: &mut [Vec3], aa: u32) {
        self.blocked.clear();
        self.blocked.resize(self.rays.len(), false);
        scene.embree.occluded_batch(&self.rays, &mut self.blocked, true);
        for &(slot, c, r) in &self.pending {
            if r == u32::MAX || !self.blocked[r as usize] {
                pixels[(slot / aa) as usize].direct += c;
                per_sample[slot as usize] += c;
            }
        }
    }
}

/// Per-pixel results.
#[derive(Default, Clone, Copy)]
struct PixelOut {
    emitted: Vec3,
    direct: Vec3,
    albedo: Vec3,
    normal: Vec3,
    depth: Option<f32>,
    /// See [`EyePass::direct_variance`].
    direct_variance: f32,
}

/// Image rows per band of the eye pass (see [`eye_pass`]).
const BAND_ROWS: u32 = 32;

/// One row's results and scratch arrays, reused from band to band.
#[derive(Default)]
struct RowBuf {
    out: RowOut,
    pixels: Vec<PixelOut>,
    primary: Vec<Ray>,
    /// Per primary ray: its pixel filter weight (1 with the box over the pixel).
    weights: Vec<f32>,
    hits: Vec<Option<Hit>>,
    shadows: Shadows,
    /// Per camera sample of the row: its share of the pixel's emission and direct light.
    per_sample: Vec<Vec3>,
}

/// Run the eye pass over the whole image. The image is traced in bands of [`BAND_ROWS`] rows, the
/// rows of a band in parallel, and each band is appended to the result in pixel order, so the sample
/// array is the same for any thread count. The rows' buffers are reused from band to band: the pass
/// writes its samples once into memory that stays, not into per-row arrays that are copied and
/// freed (every fresh page costs a fault; a row's buffers were 0.2 GB in all at 500² × 4 spp).
pub fn eye_pass(scene: &PreparedScene, s: &EyeSettings) -> crate::Result<EyePass> {
    eye_pass_filtered(scene, s, PixelFilter::BOX)
}

/// [`eye_pass`] with the pixel filter `filter` (see the module's documentation).
pub fn eye_pass_filtered(scene: &PreparedScene, s: &EyeSettings, filter: PixelFilter) -> crate::Result<EyePass> {
    let fs = (!filter.is_pixel_box()).then(|| FilterSampler::new(filter));
    let (w, h) = (scene.camera.width, scene.camera.height);
    let n = (w * h) as usize;
    // (allocated fallibly: running out of memory is an error, not an abort)
    let per_pixel = || format!("the eye pass's images of {w}x{h} pixels");
    let mut out = EyePass {
        width: w,
        height: h,
        // one eye sample per camera sample of the density estimate, unless glossy-and-specular
        // surfaces add more: reserved, so appending a band does not move the arrays
        samples: crate::memory::try_vec_with_capacity(n * s.spp as usize, || format!("{} eye samples ({w}x{h} pixels, {} per pixel)", n * s.spp as usize, s.spp))?,
        glossy: GlossyTable::default(),
        emitted: crate::memory::try_vec_with_capacity(n, per_pixel)?,
        direct: crate::memory::try_vec_with_capacity(n, per_pixel)?,
        direct_variance: crate::memory::try_vec_with_capacity(n, per_pixel)?,
        albedo: crate::memory::try_vec_with_capacity(n, per_pixel)?,
        normal: crate::memory::try_vec_with_capacity(n, per_pixel)?,
        depth: crate::memory::try_vec_with_capacity(n, per_pixel)?,
        rays: 0,
    };
    let mut bufs: Vec<RowBuf> = (0..BAND_ROWS.min(h)).map(|_| RowBuf::default()).collect();
    for y0 in (0..h).step_by(BAND_ROWS as usize) {
        let band = &mut bufs[..(h - y0).min(BAND_ROWS) as usize];
        band.par_iter_mut().enumerate().for_each(|(i, buf)| row(scene, s, fs.as_ref(), y0 + i as u32, buf));
        if out.glossy.records.capacity() == 0 && band.iter().any(|b| !b.out.glossy.is_empty()) {
            out.glossy.records.reserve(n * s.spp as usize);
        }
        append(&mut out, band);
    }
    Ok(out)
}

/// Trace image row `y` into `buf` (its previous contents discarded).
fn row(scene: &PreparedScene, s: &EyeSettings, fs: Option<&FilterSampler>, y: u32, buf: &mut RowBuf) {
    embree::set_flush_denormals();
    let w = scene.camera.width;
    let RowBuf { out, pixels, primary, weights, hits, shadows, per_sample } = buf;
    out.samples.clear();
    out.glossy.clear();
    out.rays = 0;
    shadows.clear();
    // Primary rays of the whole row go to Embree in one coherent batch.
    let cam = &scene.camera;
    let aa = s.aa_spp.max(s.spp);
    primary.clear();
    weights.clear();
    // a crop window's pixels are seeded and placed as the whole image's
    let (ox, oy) = (cam.offset[0], cam.offset[1]);
    for x in 0..w {
        let sampler = PixelSampler::new(s.seed, EYE_STREAM, cam.pixel_index(x, y));
        let lens = PixelSampler::new(s.seed, EYE_LENS_STREAM, cam.pixel_index(x, y));
        for k in 0..aa {
            let j = sampler.sample(k);
            let (fx, fy, weight) = match fs {
                None => ((x + ox) as f32 + j.x, (y + oy) as f32 + j.y, 1.0),
                Some(fs) => {
                    let ([dx, dy], weight) = fs.sample([j.x, j.y]);
                    ((x + ox) as f32 + 0.5 + dx, (y + oy) as f32 + 0.5 + dy, weight)
                }
            };
            primary.push(cam.ray_lens(fx, fy, || lens.sample(k)));
            weights.push(weight);
        }
    }
    hits.clear();
    hits.resize(primary.len(), None);
    scene.embree.intersect_batch(primary, hits, true);
    let n = aa as usize;
    pixels.clear();
    per_sample.clear();
    per_sample.resize(w as usize * n, Vec3::ZERO);
    for x in 0..w {
        let r = x as usize * n..(x as usize + 1) * n;
        pixels.push(pixel(scene, s, x, y, &primary[r.clone()], &weights[r.clone()], &hits[r.clone()], out, shadows, &mut per_sample[r]));
    }
    shadows.resolve(scene, pixels, per_sample, aa);
    for (px, c) in pixels.iter_mut().zip(per_sample.chunks_exact(n)) {
        px.direct_variance = mean_variance(c);
    }
}

/// The variance of the luminance of a pixel's mean from its camera samples' shares `c` of it (each
/// `1 / len` of its own estimate): the unbiased sample variance of the estimates over their count.
fn mean_variance(c: &[Vec3]) -> f32 {
    let n = c.len();
    if n < 2 {
        return 0.0;
    }
    let lum = |v: Vec3| (0.2126 * v.x + 0.7152 * v.y + 0.0722 * v.z) as f64 * n as f64;
    let mean = c.iter().map(|&v| lum(v)).sum::<f64>() / n as f64;
    let ss: f64 = c.iter().map(|&v| (lum(v) - mean).powi(2)).sum();
    (ss / ((n - 1) * n) as f64) as f32
}

/// Append a band's rows to the pass, in parallel: element `i` of the band comes from the row whose
/// range holds it (glossy indices shifted to the whole pass's).
fn append(out: &mut EyePass, rows: &[RowBuf]) {
    let offsets = |len: &dyn Fn(&RowOut) -> usize| {
        let mut o = Vec::with_capacity(rows.len() + 1);
        o.push(0usize);
        for b in rows {
            o.push(o.last().copied().unwrap_or(0) + len(&b.out));
        }
        o
    };
    let (s_off, g_off) = (offsets(&|r| r.samples.len()), offsets(&|r| r.glossy.len()));
    // each task walks its range of rows in order: the row is searched once per task, not per element
    let row_at = |off: &[usize], r: &mut usize, i: usize| {
        if *r >= rows.len() || i < off[*r] || i >= off[*r + 1] {
            *r = off.partition_point(|&o| o <= i) - 1;
        }
        *r
    };
    let g_base = out.glossy.len() as u32;
    out.samples.par_extend((0..s_off[rows.len()]).into_par_iter().map_init(
        || usize::MAX,
        |r, i| {
            let r = row_at(&s_off, r, i);
            let mut e = rows[r].out.samples[i - s_off[r]];
            if e.glossy != NO_GLOSSY {
                e.glossy += g_base + g_off[r] as u32;
            }
            e
        },
    ));
    // the rows' BSDFs laid end to end, the records' indices shifted to match
    let b_off = offsets(&|r| r.glossy.bsdfs.len());
    let b_base = out.glossy.bsdfs.len() as u32;
    out.glossy.records.par_extend((0..g_off[rows.len()]).into_par_iter().map_init(
        || usize::MAX,
        |r, i| {
            let r = row_at(&g_off, r, i);
            let mut g = rows[r].out.glossy.records[i - g_off[r]];
            g.bsdf += b_base + b_off[r] as u32;
            g
        },
    ));
    for b in rows {
        out.glossy.bsdfs.extend_from_slice(&b.out.glossy.bsdfs);
    }
    for b in rows {
        out.rays += b.out.rays;
        for px in &b.pixels {
            out.emitted.push(px.emitted);
            out.direct.push(px.direct);
            out.direct_variance.push(px.direct_variance);
            out.albedo.push(px.albedo);
            out.normal.push(px.normal.normalize_or_zero());
            out.depth.push(px.depth.unwrap_or(0.0));
        }
    }
}

/// The eye samples of one pixel, given its primary rays and their hits.
#[allow(clippy::too_many_arguments)]
fn pixel(
    scene: &PreparedScene,
    s: &EyeSettings,
    x: u32,
    y: u32,
    primary: &[Ray],
    weights: &[f32],
    primary_hits: &[Option<Hit>],
    row: &mut RowOut,
    shadows: &mut Shadows,
    per_sample: &mut [Vec3],
) -> PixelOut {
    let cam = &scene.camera;
    let pix = y * cam.width + x;
    // a crop window's pixels draw the whole image's random numbers
    let seed_pix = cam.pixel_index(x, y);
    let aa = s.aa_spp.max(s.spp);
    let inv_spp = 1.0 / aa as f32;
    // An eye sample stands for `aa / spp` camera samples of the density estimate.
    let eye_scale = aa as f32 / s.spp as f32;
    // The pixel's hash for its light samples' padded slots, once per pixel.
    let light_hash = PathSampler::pixel_hash(s.seed, EYE_LIGHT_STREAM, seed_pix);
    let light_slots = |bounce: u32| Some((PathSampler::slot_of(light_hash, bounce, Decision::LightChoice)?, PathSampler::slot_of(light_hash, bounce, Decision::LightPoint)?));
    let slots0 = light_slots(0);
    // the BSDF samples' directions, stratified over the pixel's camera samples
    let bsdf_dirs = PixelSampler::new(s.seed, EYE_BSDF_STREAM, seed_pix);
    let bsdf_samples = if s.light_samples > 0 { BSDF_SAMPLES } else { 0 };
    let mut out = PixelOut::default();
    for k in 0..aa as usize {
        let is_eye_sample = k < s.spp as usize;
        // the camera sample's stream for specular bounces, seeded on first use (most samples
        // never reach a specular surface)
        let mut rng: Option<Rng> = None;
        let mut ray = primary[k];
        // the camera ray's cone (its share of the pixel), kept through specular bounces: texture
        // lookups filter over it
        let mut cone = cam.cone().per_sample(aa);
        let mut beta = Vec3::splat(inv_spp * weights[k]);
        for bounce in 0..=MAX_SPECULAR {
            row.rays += 1;
            // Analytic lights seen directly or through specular bounces.
            let hit = if bounce == 0 {
                primary_hits[k].map(|h| scene.surface_hit_cone(&ray, &h, Some(cone)))
            } else {
                scene.intersect_cone(&ray, Some(cone))
            };
            let tmax = hit.map_or(f32::INFINITY, |h| h.t);
            for &li in &scene.lights.analytic {
                if let Some((_, le)) = scene.lights.emitters[li as usize].intersect(ray.org, ray.dir, tmax) {
                    out.emitted += beta * le;
                    per_sample[k] += beta * le;
                }
            }
            let Some(h) = hit else {
                for &li in &scene.lights.infinite {
                    let le = beta * scene.lights.emitters[li as usize].le_infinite(ray.dir, &scene.textures);
                    out.emitted += le;
                    per_sample[k] += le;
                }
                break;
            };
            let wo = -ray.dir;
            let le = beta * scene.emitted(&h, wo);
            out.emitted += le;
            per_sample[k] += le;
            let bsdf = scene.bsdf(&h);
            let frame = Frame::from_normal(h.ns);
            let wo_l = frame.to_local(wo);
            if bounce == 0 {
                out.albedo += scene.albedo(&h, &bsdf) * inv_spp;
                out.normal += h.ns * inv_spp;
                let z = h.t * ray.dir.dot(cam.forward());
                out.depth = Some(out.depth.map_or(z, |d: f32| d.min(z)));
            }
            let flags = bsdf.flags();
            if flags.is_diffuse() || flags.is_glossy() {
                // the per-`wo` work (lobe albedos and probabilities) once, for the glossy eye
                // sample and every light sample
                let at = bsdf.at(wo_l);
                if is_eye_sample {
                    // The eye sample, oriented toward the viewer.
                    let n = if h.ns.dot(wo) >= 0.0 { h.ns } else { -h.ns };
                    let lambert = !flags.is_glossy() && !flags.is_specular() && !flags.contains(crate::bsdf::BsdfFlags::TRANSMISSION);
                    let beta = beta * eye_scale;
                    let (weight, glossy) = if lambert {
                        (beta * scene.albedo(&h, &bsdf) * std::f32::consts::FRAC_1_PI, NO_GLOSSY)
                    } else {
                        (beta, row.glossy.push(&bsdf, wo_l, h.ns))
                    };
                    row.samples.push(EyeSample { p: h.p.to_array(), n: oct_encode(n), weight: weight.to_array(), pixel: pix, glossy });
                }
                // Direct light by explicit light sampling.
                // The bounce's two slots, built once for its light samples (bounce 0's once per
                // pixel): the numbers a `PathSampler` per sample gives; beyond the padded
                // bounces, that sampler's stream.
                let slots = if bounce == 0 { slots0 } else { light_slots(bounce) };
                for j in 0..s.light_samples {
                    // Light sample j of eye sample k is sample k·L + j of the pixel's padded slots
                    // for this bounce: the pixel's S·L light samples are stratified.
                    let index = k as u32 * s.light_samples + j;
                    let (choice, u) = match slots {
                        Some((choice_slot, point_slot)) => {
                            let Some(choice) = scene.lights.choose_with(true, || choice_slot.sample_1d(index)) else { continue };
                            (choice, point_slot.sample(index))
                        }
                        None => {
                            let mut ls = PathSampler::of_pixel_hash(light_hash, index);
                            let Some(choice) = scene.lights.choose_with(false, || ls.get_1d(bounce, Decision::LightChoice)) else { continue };
                            (choice, ls.get_2d(bounce, Decision::LightPoint))
                        }
                    };
                    if let Some((c, shadow)) = light_sample(scene, &h, &at, &frame, choice, u, s.light_samples, bsdf_samples) {
                        row.rays += 1;
                        shadows.push((x as usize * aa as usize + k) as u32, beta * c / s.light_samples as f32, shadow);
                    }
                }
                // Direct light by BSDF sampling (MIS-weighted against the light samples).
                for j in 0..bsdf_samples {
                    let index = k as u32 * bsdf_samples + j;
                    let u = if bounce == 0 { bsdf_dirs.sample(index) } else { let r = rng.get_or_insert_with(|| Rng::new(hash(&[s.seed, EYE_STREAM, seed_pix, k as u64]), 0)); r.next_2d() };
                    let uc = hash_unit(hash(&[s.seed, EYE_BSDF_STREAM, seed_pix, index as u64, bounce as u64]));
                    let (c, traced) = bsdf_sample(scene, &h, &at, &frame, uc, u, s.light_samples, bsdf_samples);
                    if traced {
                        row.rays += 1;
                    }
                    if c != Vec3::ZERO {
                        out.direct += beta * c;
                        per_sample[k] += beta * c;
                    }
                }
            }
            if !flags.is_specular() {
                break;
            }
            // Follow a specular lobe (stop when the BSDF picks a non-specular one: the eye sample
            // above accounts for those, so the continuation stays unbiased).
            let rng = rng.get_or_insert_with(|| Rng::new(hash(&[s.seed, EYE_STREAM, seed_pix, k as u64]), 0));
            let Some(bs) = bsdf.sample(wo_l, rng.next_f32(), rng.next_2d(), TransportMode::Radiance) else { break };
            if !bs.flags.is_specular() || bs.pdf <= 0.0 {
                break;
            }
            beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
            if beta.max_element() <= 0.0 || !beta.is_finite() {
                break;
            }
            cone = cone.bounce(h.t * ray.dir.length(), 0.0);
            ray = scene.spawn(h.p, h.ng, frame.to_world(bs.wi));
        }
    }
    out
}

/// A uniform number in [0, 1) from a hash.
fn hash_unit(h: u64) -> f32 {
    (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_variance_is_the_sample_variance_over_the_count() {
        // four camera samples whose own estimates (share × 4) are grey 1, 3, 5, 7: mean 4, sample
        // variance 20/3, of the mean 20/3/4
        let shares: Vec<Vec3> = [1.0f32, 3.0, 5.0, 7.0].iter().map(|&v| Vec3::splat(v / 4.0)).collect();
        let v = mean_variance(&shares);
        assert!((v - 20.0 / 3.0 / 4.0).abs() < 1e-5, "{v}");
        assert_eq!(mean_variance(&shares[..1]), 0.0);
        assert_eq!(mean_variance(&[Vec3::splat(0.25); 4]), 0.0);
    }
}
