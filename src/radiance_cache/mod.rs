//! Radiance caching in image space (§8.3 of `photon-ray-splatting.md`): photon rays are splatted
//! only onto sparse *cache records* (one eye sample per record pixel), each record holding the SH
//! coefficients of its cosine-weighted incoming radiance; records are extrapolated to the other
//! pixels by cache splatting in image space within a radius derived from the harmonic mean distance
//! of the photon rays that reached the record (gathered during splatting), projected to pixels, and
//! cut short at records that see other light ([`radius`]), and reaching a pixel less the more its
//! normal turns from the record's ([`reach`]: Ward's error estimate in image space).
//!
//! Multi-pass [GKBP05]: records on a grid of spacing 8, then 4, 2, 1 pixels, where a candidate
//! becomes a record only if fewer than `min_records` records already cover its pixel. Extrapolation
//! never crosses the discontinuities of [`crate::radiance_filter::segment`]. The final integration
//! is that of the SH radiance map: the single coefficient for Lambertian eye samples, the BSDF
//! tables for glossy ones.

use crate::eye::EyePass;
use crate::photon::PhotonRay;
use crate::radiance_filter::{segment, FilterParams};
use crate::radiance_map::{Encoder, SAME_SURFACE_COS};
use crate::sh;
use crate::splat::records::{splat_records, RecordSplat};
use glam::Vec3;
use rayon::prelude::*;

pub mod grid;
pub mod radius;
use radius::RecordLight;

/// Parameters of the cache.
#[derive(Clone, Copy, Debug)]
pub struct CacheParams {
    /// Record radius in world space = `error` × harmonic mean distance (the cache error ε).
    pub error: f32,
    /// Records that must cover a pixel before no further record is placed there.
    pub min_records: u32,
    /// Largest record radius in pixels.
    pub max_radius_px: f32,
    /// Splat the candidates of passes 4, 2 and 1 in one traversal when there are at most this
    /// many ([`REFINE_TOGETHER_MAX`]; 0: a traversal per pass).
    pub refine_together_max: usize,
    /// Weight of the normal term of [`reach`] ([`NORMAL_WEIGHT`]; 0: a record reaches every pixel
    /// of its segment within its radius, whatever its normal).
    pub normal_weight: f32,
}

impl Default for CacheParams {
    fn default() -> Self {
        CacheParams { error: 0.5, min_records: 4, max_radius_px: 24.0, refine_together_max: REFINE_TOGETHER_MAX, normal_weight: NORMAL_WEIGHT }
    }
}

/// What the cache did.
pub struct CacheOut {
    /// Indirect radiance per pixel.
    pub radiance: Vec<Vec3>,
    pub records: usize,
    /// Eye samples off their pixel's surface, given coefficients splatted at their own position.
    pub off_surface_samples: usize,
    /// Eye samples off their pixel's surface, given another pixel's coefficients (a neighbour of
    /// theirs, or the pixel that sees their point directly).
    pub neighbour_samples: usize,
    pub passes: usize,
    /// Records on the image grids of `grid_rays` (0 without them).
    pub grid_records: usize,
    pub pairs: u64,
    pub record_bytes: u64,
}

/// Weight of the normal term in a record's [`reach`]. A record holds the light its own surface
/// point receives, the cosine about its own normal included, so it speaks less for a pixel whose
/// normal turns away from it (a column's round shaft, an arch, a drape's folds, a bumpy floor);
/// pixels no longer covered by enough records get records of their own in the later passes.
/// 0.7 had the lowest `indirect` error of 0, 0.5, 0.7 and 1 on Crytek Sponza at 400² (0 was 13 %
/// higher) and changes cornell-glossy by under 1 %.
pub const NORMAL_WEIGHT: f32 = 0.7;

/// How much a record `d` pixels away, of radius `r`, whose normal makes cosine `cos` with the
/// pixel's, speaks for that pixel: `1 − d/r − normal_weight · √(1 − cos)`, Ward's error estimate
/// `|x − xᵢ|/Rᵢ + √(1 − n·nᵢ)` [WRC88] with the distance in image space. The record covers the
/// pixel (for the coverage count) where this is positive, and it is the record's weight in the
/// pixel's extrapolation.
#[inline(always)]
pub fn reach(d: f32, r: f32, cos: f32, normal_weight: f32) -> f32 {
    1.0 - d / r - normal_weight * (1.0 - cos).max(0.0).sqrt()
}

/// An eye sample farther than this many pixel footprints (at its pixel's depth) from its pixel's
/// first eye sample does not share that sample's records (see `own` in [`render`]): the samples of
/// a pixel seen through a lens lie far apart, and 4 keeps them apart at no cost in error on
/// cornell-glossy.
pub const OFF_PIXEL_FOOTPRINTS: f32 = 4.0;

/// The pixels next to a pixel, in the order an edge pixel's off-surface sample looks for one on
/// its surface (the nearest first sample wins; ties go to the earlier).
const NEIGHBOURS: [(i64, i64); 8] = [(-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (1, -1), (-1, 1), (1, 1)];

/// Passes 4, 2 and 1 can only place records at pixels that pass 8 left covered by fewer than
/// `min_records` records. When there are at most this many such pixels, all of them are splatted
/// in one traversal of the photon rays and each pass takes its records' sums from there (the same
/// records, bit for bit, as a traversal per pass). A traversal costs about as much as splatting
/// 3 000 such points and there are two to save, so joint splatting pays up to about twice that.
pub const REFINE_TOGETHER_MAX: usize = 6144;

/// Which eye samples the cache integrates, and the SH tables of their glossy lobes.
pub struct Integrated<'a> {
    /// SH tables of the glossy eye samples ([`crate::radiance_map::ShTables`]); empty tables only where `cached`
    /// is false.
    pub tables: &'a crate::radiance_map::ShTables,
    /// Per glossy eye sample: integrated from the cache (false: its light comes from elsewhere,
    /// and the cache adds nothing to it). Lambertian eye samples are always integrated.
    pub cached: &'a [bool],
}

/// How the camera sees the world: the width of a pixel at a world point seen directly
/// ([`crate::prepare::CameraModel::pixel_size_at`]), and the image position (pixels, y down) where
/// a world point is seen directly, if it is in front of the camera
/// ([`crate::prepare::CameraModel::raster`]).
pub struct View<'a> {
    pub pixel_size: &'a (dyn Fn(Vec3) -> f32 + Sync),
    pub raster: &'a (dyn Fn(Vec3) -> Option<glam::Vec2> + Sync),
}

/// Run the multi-pass cache over `eye` with photon rays `rays`, seen through `view`. Each set of
/// photon rays of `grid_rays` (`(rays, spacing)`) is splatted onto records on an image grid of that spacing
/// instead ([`grid`]; spacing 1: a record at every pixel, its first eye sample), and the samples off
/// their pixel's surface: not extrapolated, but interpolated between grid nodes and integrated with
/// the cache's light (wide kernels, whose light a pixel's eye samples share).
pub fn render(
    eye: &EyePass,
    rays: &[&[PhotonRay]],
    grid_rays: &[(&[PhotonRay], usize)],
    view: &View,
    p: &CacheParams,
    integrated: &Integrated,
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Option<CacheOut> {
    let (w, h) = (eye.width as usize, eye.height as usize);
    let n = w * h;
    let (label, _) = segment(eye.width, eye.height, &eye.depth, &eye.normal, &FilterParams::with_radius(1));
    // first eye sample per pixel
    // (a pixel's first sample starts a run of its samples; in pixel order, the only one)
    let mut first = vec![u32::MAX; n];
    let heads: Vec<u32> = (0..eye.samples.len() as u32).into_par_iter().filter(|&i| i == 0 || eye.samples[i as usize - 1].pixel != eye.samples[i as usize].pixel).collect();
    for i in heads {
        let f = &mut first[eye.samples[i as usize].pixel as usize];
        *f = (*f).min(i);
    }
    // pixel footprint per unit depth: median over neighbouring first samples on one segment
    let mut ratios: Vec<f32> = (0..n)
        .into_par_iter()
        .filter(|&i| i % w + 1 < w && first[i] != u32::MAX && first[i + 1] != u32::MAX && label[i] == label[i + 1] && eye.depth[i] > 0.0)
        .map(|i| (eye.samples[first[i] as usize].pos() - eye.samples[first[i + 1] as usize].pos()).length() / eye.depth[i])
        .collect();
    let mid = ratios.len() / 2;
    let per_depth = if ratios.is_empty() { 1e-3 } else { *ratios.select_nth_unstable_by(mid, f32::total_cmp).1 }.max(1e-9);
    // the normal of each pixel's first eye sample (the one its records and coefficients describe)
    let normal: Vec<Vec3> = first.par_iter().map(|&f| if f == u32::MAX { Vec3::ZERO } else { eye.samples[f as usize].normal() }).collect();
    // records: pixel, radius in pixels, SH coefficients
    let mut rec_pixel: Vec<u32> = Vec::new();
    let mut rec_radius: Vec<f32> = Vec::new();
    let mut rec_coeffs: Vec<[Vec3; sh::N]> = Vec::new();
    let mut rec_light: Vec<RecordLight> = Vec::new();
    let y0 = sh::eval(Vec3::Z)[0];
    let mut coverage = vec![0u32; n];
    let mut is_record = vec![false; n];
    // Eye samples off their pixel's surface: a pixel's records and interpolated coefficients
    // describe the surface of its first eye sample (the cosine is encoded about that normal), so a
    // sample whose normal is not within SAME_SURFACE_COS of it (the other surface of an edge pixel),
    // or that lies more than OFF_PIXEL_FOOTPRINTS pixel footprints from it (seen through a lens
    // that spreads the pixel's samples, or the background behind a silhouette), does not take
    // them. It takes those of the nearest neighbouring pixel whose first sample is on its surface
    // (`borrow`: the pixel across the edge or the silhouette; one pixel's extrapolation, as the
    // cache does everywhere), else those of the pixel where its point is seen directly (its
    // projection into the image, or a pixel next to it: a sample seen through a lens, such as the
    // glass sphere, of a surface the camera also sees; a record's coefficients hold the light
    // arriving at its point, whatever the path from the camera); those without one (`own`: the
    // parts of the scene that only a lens shows, sub-pixel slivers) get coefficients splatted at
    // their own position, as rs would give them. Those ride along
    // with the first pass's records (a pass's cost is mostly traversing every photon ray once,
    // and a point's sums do not depend on the other points of the tree).
    let footprint = |px: usize| OFF_PIXEL_FOOTPRINTS * per_depth * eye.depth[px];
    let off: Vec<(u32, u32)> = (0..eye.samples.len() as u32)
        .into_par_iter()
        .filter_map(|i| {
            let e = &eye.samples[i as usize];
            let f = first[e.pixel as usize];
            let fs = &eye.samples[f as usize];
            if f == i {
                return None;
            }
            let (n, p) = (e.normal(), e.pos());
            if (p - fs.pos()).length() <= footprint(e.pixel as usize) && n.dot(normal[e.pixel as usize]) >= SAME_SURFACE_COS {
                return None;
            }
            // the nearest pixel around (x, y) (itself first when `centre`) whose first sample is on
            // this sample's surface
            let nearest_on_surface = |x: i64, y: i64, centre: bool| {
                centre
                    .then_some((0, 0))
                    .into_iter()
                    .chain(NEIGHBOURS)
                    .map(|(dx, dy)| (x + dx, y + dy))
                    .filter(|&(qx, qy)| qx >= 0 && qy >= 0 && (qx as usize) < w && (qy as usize) < h)
                    .map(|(qx, qy)| qy as usize * w + qx as usize)
                    .filter(|&q| first[q] != u32::MAX && label[q] != u32::MAX)
                    .map(|q| (q, &eye.samples[first[q] as usize]))
                    .filter(|&(q, _)| normal[q].dot(n) >= SAME_SURFACE_COS)
                    .map(|(q, s)| (q, (s.pos() - p).length()))
                    .filter(|&(q, d)| d <= footprint(q))
                    .min_by(|a, b| a.1.total_cmp(&b.1))
                    .map(|(q, _)| q as u32)
            };
            // a neighbour of its pixel (across an edge or a silhouette), else the pixels where its
            // point is seen directly (a sample seen through a lens)
            let (x, y) = ((e.pixel as usize % w) as i64, (e.pixel as usize / w) as i64);
            let q = nearest_on_surface(x, y, false)
                .or_else(|| {
                    let r = (view.raster)(p)?;
                    (r.x >= 0.0 && r.y >= 0.0 && (r.x as usize) < w && (r.y as usize) < h).then_some(())?;
                    nearest_on_surface(r.x as i64, r.y as i64, true)
                })
                .unwrap_or(u32::MAX);
            Some((i, q))
        })
        .collect();
    let own: Vec<u32> = off.iter().filter(|&&(_, q)| q == u32::MAX).map(|&(i, _)| i).collect();
    let borrow: Vec<(u32, u32)> = off.into_iter().filter(|&(_, q)| q != u32::MAX).collect();
    let mut own_coeffs: Option<Vec<Vec3>> = if own.is_empty() { Some(Vec::new()) } else { None };
    let (mut passes, mut pairs) = (0, 0u64);
    let candidate = |i: usize, is_record: &[bool], coverage: &[u32]| first[i] != u32::MAX && label[i] != u32::MAX && !is_record[i] && coverage[i] < p.min_records;
    // the record eye samples of `pixels` (the first of each pixel), at unit weight, then the
    // off-surface samples when `with_own`
    let splat_at = |pixels: &[u32], with_own: bool| {
        let at = pixels.iter().map(|&px| first[px as usize]).chain(own.iter().copied().filter(|_| with_own));
        let (pts, nrm): (Vec<Vec3>, Vec<Vec3>) = at.map(|i| (eye.samples[i as usize].pos(), eye.samples[i as usize].normal())).unzip();
        splat_records(&pts, &nrm, rays, Encoder::Sh, cancelled)
    };
    // The sums of the later passes' records, splatted together (`refine_together_max`): the
    // splat and each pixel's index in it.
    let mut together: Option<(RecordSplat, Vec<u32>)> = None;
    for spacing in [8usize, 4, 2, 1] {
        if spacing == 4 && own_coeffs.is_some() {
            // passes 4, 2 and 1 choose among the pixels pass 8 left under-covered (coverage only
            // grows), and a point's sums do not depend on the other points splatted with it
            let left: Vec<u32> = (0..n).filter(|&i| candidate(i, &is_record, &coverage)).map(|i| i as u32).collect();
            if !left.is_empty() && left.len() <= p.refine_together_max {
                let out = splat_at(&left, false)?;
                pairs += out.pairs;
                let mut index = vec![u32::MAX; n];
                for (j, &px) in left.iter().enumerate() {
                    index[px as usize] = j as u32;
                }
                together = Some((out, index));
            }
        }
        let new: Vec<u32> = (0..n)
            .filter(|&i| (i % w) % spacing == 0 && (i / w) % spacing == 0 && candidate(i, &is_record, &coverage))
            .map(|i| i as u32)
            .collect();
        if new.is_empty() {
            continue;
        }
        passes += 1;
        // the splat holding this pass's records' sums, and each record's row in it
        let own_pass;
        let (out, row): (&RecordSplat, Vec<usize>) = match &together {
            Some((all, index)) => (all, new.iter().map(|&px| index[px as usize] as usize).collect()),
            None => {
                let with_own = own_coeffs.is_none();
                let mut out = splat_at(&new, with_own)?;
                pairs += out.pairs;
                if with_own {
                    own_coeffs = Some(out.coeffs.split_off(new.len() * sh::N));
                }
                own_pass = out;
                (&own_pass, (0..new.len()).collect())
            }
        };
        let first_new = rec_pixel.len();
        for (&px, &j) in new.iter().zip(&row) {
            let px = px as usize;
            let c: [Vec3; sh::N] = std::array::from_fn(|k| out.coeffs[j * sh::N + k]);
            let hd = out.harmonic_distance[j];
            let r = if hd > 0.0 { p.error * hd / (per_depth * eye.depth[px].max(1e-9)) } else { p.max_radius_px };
            is_record[px] = true;
            rec_pixel.push(px as u32);
            rec_radius.push(r.clamp(1.0, p.max_radius_px));
            let (x, y) = ((px % w) as f32, (px / w) as f32);
            rec_light.push(RecordLight { x, y, label: label[px], value: c[0].element_sum() / y0, variance: out.second_moment[j] });
            rec_coeffs.push(c);
        }
        // a record reaches no farther than a record of its segment that sees other light
        radius::limit_radii(&rec_light, first_new, &mut rec_radius[first_new..], w, h, p.max_radius_px);
        // cache splatting: each new record covers the pixels of its segment it reaches (image rows
        // in parallel; the counts do not depend on the order)
        // (each record's column, row and window half-width, once: not per image row)
        let windows: Vec<[usize; 3]> = rec_pixel[first_new..].iter().zip(&rec_radius[first_new..]).map(|(&px, &r)| [px as usize % w, px as usize / w, r.ceil() as usize]).collect();
        let (new_pixel, new_radius) = (&rec_pixel[first_new..], &rec_radius[first_new..]);
        coverage.par_chunks_mut(w).enumerate().for_each(|(y, cov)| {
            for ((&px, &r), &[x0, y0, ri]) in new_pixel.iter().zip(new_radius).zip(&windows) {
                if y + ri < y0 || y > y0 + ri {
                    continue;
                }
                for x in x0.saturating_sub(ri)..(x0 + ri + 1).min(w) {
                    let (q, d) = (y * w + x, ((x as f32 - x0 as f32).powi(2) + (y as f32 - y0 as f32).powi(2)).sqrt());
                    if d < r && label[q] == label[px as usize] && reach(d, r, normal[q].dot(normal[px as usize]), p.normal_weight) > 0.0 {
                        cov[x] += 1;
                    }
                }
            }
        });
    }
    let mut own_coeffs = match own_coeffs {
        Some(c) => c,
        None => {
            // no pass placed a record
            let pts: Vec<Vec3> = own.iter().map(|&i| eye.samples[i as usize].pos()).collect();
            let nrm: Vec<Vec3> = own.iter().map(|&i| eye.samples[i as usize].normal()).collect();
            let out = splat_records(&pts, &nrm, rays, Encoder::Sh, cancelled)?;
            pairs += out.pairs;
            out.coeffs
        }
    };
    let surface = grid::ImageSurface { eye, first: &first, label: &label, normal: &normal, pixel_size: view.pixel_size };
    let grids = grid::splat_grids(&surface, &own, grid_rays, &mut own_coeffs, cancelled)?;
    pairs += grids.pairs;
    // Per image row: the pixels' coefficients (the records extrapolated, then the grids' light),
    // then the final integration of the row's eye samples, summed in sample order. A row's
    // coefficients live only while its samples are integrated (a whole image of them is
    // 192 B per pixel).
    let extrapolation = Extrapolation::new(&surface, p.normal_weight, &rec_pixel, &rec_radius, &rec_coeffs);
    let tables = integrated.tables;
    let mut radiance = vec![Vec3::ZERO; n];
    radiance.par_chunks_mut(w).enumerate().for_each_init(
        || (vec![[Vec3::ZERO; sh::N]; w], vec![0.0f32; w]),
        |(coeffs, wsum), (y, out)| {
            // the last borrowed pixel's coefficients (a pixel's off-surface samples mostly
            // borrow from one neighbour)
            let (mut borrowed, mut borrowed_from) = ([Vec3::ZERO; sh::N], usize::MAX);
            extrapolation.row(y, coeffs, wsum);
            grids.add_row(y, coeffs);
            let start = eye.samples.partition_point(|e| (e.pixel as usize) < y * w);
            let end = eye.samples.partition_point(|e| (e.pixel as usize) < (y + 1) * w);
            // cursors into `own` and `borrow` (both in sample order), walked with the samples
            let mut o = own.partition_point(|&s| (s as usize) < start);
            let mut b = borrow.partition_point(|&(s, _)| (s as usize) < start);
            for (i, e) in eye.samples[start..end].iter().enumerate().map(|(k, e)| ((start + k) as u32, e)) {
                let is_own = own.get(o) == Some(&i);
                o += is_own as usize;
                let from = match borrow.get(b) {
                    Some(&(s, q)) if s == i => {
                        b += 1;
                        Some(q as usize)
                    }
                    _ => None,
                };
                if e.is_glossy() && !integrated.cached[e.glossy as usize] {
                    continue;
                }
                let x = e.pixel as usize - y * w;
                let c: &[Vec3; sh::N] = if is_own {
                    own_coeffs[(o - 1) * sh::N..o * sh::N].try_into().expect("N coefficients")
                } else if let Some(q) = from {
                    // the neighbouring pixel's coefficients, as its own row computes them
                    if q != borrowed_from {
                        extrapolation.pixel(q, &mut borrowed);
                        grids.add_pixel(q, &mut borrowed);
                        borrowed_from = q;
                    }
                    &borrowed
                } else {
                    &coeffs[x]
                };
                let l = if e.is_glossy() {
                    tables.integrate(e.glossy as usize, &eye.glossy.lobe(e.glossy as usize), c)
                } else {
                    c[0] / y0 // ∫ L cos dω; the weight holds albedo/π
                };
                out[x] += e.weight() * l.max(Vec3::ZERO);
            }
        },
    );
    Some(CacheOut {
        radiance,
        records: rec_pixel.len(),
        off_surface_samples: own.len(),
        neighbour_samples: borrow.len(),
        grid_records: grids.records,
        passes,
        pairs,
        record_bytes: (rec_pixel.len() * (4 + 4 + sh::N * 12)) as u64,
    })
}

/// `acc += c · s` for SH coefficient sets, as 48 contiguous floats (one vectorisable loop; the
/// same values as adding the `Vec3`s one by one).
#[inline(always)]
fn add_scaled(acc: &mut [Vec3; sh::N], c: &[Vec3], s: f32) {
    let acc: &mut [f32] = bytemuck::cast_slice_mut(acc.as_mut_slice());
    let c: &[f32] = bytemuck::cast_slice(&c[..sh::N]);
    for (a, c) in acc.iter_mut().zip(c) {
        *a += c * s;
    }
}

/// Extrapolation: per pixel, the weighted mean of the coefficients of the records that cover it
/// (same segment, distance `d` below the record's radius `r`; weights [`reach`] where positive),
/// one image row at a time ([`Extrapolation::row`]).
///
/// Each record is scattered over its own window: a row takes the records whose window reaches it
/// in pixel order, so every pixel sums its records in the same order for any thread count (and
/// the order of a gather over its neighbourhood).
struct Extrapolation<'a> {
    w: usize,
    surface: &'a grid::ImageSurface<'a>,
    /// The weight of [`reach`]'s normal term.
    normal_weight: f32,
    rec_pixel: &'a [u32],
    rec_radius: &'a [f32],
    rec_coeffs: &'a [[Vec3; sh::N]],
    /// Per record: its column, its row and the half-width of its window (its radius rounded up).
    windows: Vec<[usize; 3]>,
    /// Row `y`'s records are `by_row[start[y]..start[y + 1]]`, in pixel order.
    start: Vec<usize>,
    by_row: Vec<u32>,
}

impl<'a> Extrapolation<'a> {
    fn new(surface: &'a grid::ImageSurface<'a>, normal_weight: f32, rec_pixel: &'a [u32], rec_radius: &'a [f32], rec_coeffs: &'a [[Vec3; sh::N]]) -> Self {
        let (w, h) = (surface.eye.width as usize, surface.eye.height as usize);
        let mut order: Vec<u32> = (0..rec_pixel.len() as u32).collect();
        order.sort_unstable_by_key(|&k| rec_pixel[k as usize]);
        // records per row whose window reaches it, in pixel order (counting sort by row)
        let reach = |k: u32| {
            let (y0, ri) = (rec_pixel[k as usize] as usize / w, rec_radius[k as usize].ceil() as usize);
            y0.saturating_sub(ri)..(y0 + ri + 1).min(h)
        };
        let mut start = vec![0usize; h + 1];
        for &k in &order {
            for y in reach(k) {
                start[y + 1] += 1;
            }
        }
        for y in 0..h {
            start[y + 1] += start[y];
        }
        let mut fill = start.clone();
        let mut by_row = vec![0u32; start[h]];
        for &k in &order {
            for y in reach(k) {
                by_row[fill[y]] = k;
                fill[y] += 1;
            }
        }
        let windows = rec_pixel.iter().zip(rec_radius).map(|(&px, &r)| [px as usize % w, px as usize / w, r.ceil() as usize]).collect();
        Extrapolation { w, surface, normal_weight, rec_pixel, rec_radius, rec_coeffs, windows, start, by_row }
    }

    /// Row `y`'s extrapolated coefficients into `row` (`w` pixels; `wsum`: scratch of `w`).
    fn row(&self, y: usize, row: &mut [[Vec3; sh::N]], wsum: &mut [f32]) {
        self.span(y, 0, row, wsum);
    }

    /// Pixel `q`'s extrapolated coefficients (what [`Self::row`] gives it, bit for bit).
    fn pixel(&self, q: usize, out: &mut [Vec3; sh::N]) {
        self.span(q / self.w, q % self.w, std::slice::from_mut(out), &mut [0.0]);
    }

    /// The coefficients of the `out.len()` pixels of row `y` from column `x_start` on.
    fn span(&self, y: usize, x_start: usize, out: &mut [[Vec3; sh::N]], wsum: &mut [f32]) {
        let (w, s) = (self.w, self.surface);
        let x_end = x_start + out.len();
        out.fill([Vec3::ZERO; sh::N]);
        wsum.fill(0.0);
        for &k in &self.by_row[self.start[y]..self.start[y + 1]] {
            let (px, r) = (self.rec_pixel[k as usize] as usize, self.rec_radius[k as usize]);
            let [x0, y0, ri] = self.windows[k as usize];
            if x0 + ri < x_start || x0 >= x_end + ri {
                continue; // (a window left or right of the span: no column to visit)
            }
            let dy2 = (y as f32 - y0 as f32).powi(2);
            for x in x0.saturating_sub(ri).max(x_start)..(x0 + ri + 1).min(x_end) {
                let q = y * w + x;
                if s.first[q] == u32::MAX || s.label[q] == u32::MAX || s.label[q] != s.label[px] {
                    continue;
                }
                let d = ((x as f32 - x0 as f32).powi(2) + dy2).sqrt();
                let wt = reach(d, r, s.normal[q].dot(s.normal[px]), self.normal_weight);
                if d < r && wt > 0.0 {
                    wsum[x - x_start] += wt;
                    add_scaled(&mut out[x - x_start], &self.rec_coeffs[k as usize], wt);
                }
            }
        }
        for (acc, &ws) in out.iter_mut().zip(wsum.iter()) {
            if ws > 0.0 {
                for a in acc.iter_mut() {
                    *a /= ws;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests;
