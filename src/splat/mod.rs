//! Photon ray splatting (§4–7 of `photon-ray-splatting.md`): every photon ray splats its flux to the
//! eye samples inside its cone frustum (plus the hemisphere beyond its hit), found by the cone
//! traversal of a kd-tree over eye samples. The weight is the 2D Epanechnikov kernel perpendicular to
//! the ray times the cosine at the eye sample (Eq. 6):
//!
//! `L(x, ω') += f_s(ω_i, x, ω') · K_h(x, x_i, ω_i) · ΔΦ_i · cos θ_i`,  `K_h(d) = 2/(πh²)·(1 − d²/h²)`.
//!
//! Feasibility at the leaves (§7.2): distance to the ray within `h(t)`, the eye sample's normal
//! facing the photon (photons from behind never contribute), and the eye sample in front of the
//! surface at the ray's origin (`(p − origin)·n_origin > ε`, which also keeps photons leaving one
//! side of a zero-thickness wall away from eye samples on its other side), and, before the hit, the
//! ray's point of closest approach on the eye sample's side of its surface
//! (`(origin + t·dir − p)·n ≥ −ε`: a photon running inside a box along a wall does not light the
//! wall's outer face; photons ending on the next wall at their common edge still leak about 1e-4 of
//! the light inside a closed box onto its outer faces, see `tests/extremes.rs`).
//!
//! **Beyond the photon hit** the paper cuts the footprint to a hemisphere of radius `h` around the
//! hit (§5, Fig. 4) to limit light leaking onto surfaces behind the hit. On the hit surface itself
//! that cut removes the part of the footprint's ellipse beyond the hit, i.e. a fraction
//! `(1 − cos θ)/2` of every photon arriving at angle θ — for diffuse interreflection about 17 % of
//! the indirect light (measured on the Cornell box). We keep the paper's intent with a cut that is
//! exact on planar surfaces: beyond the hit, the cylinder of radius `h(t_max)` continues but only
//! within a slab of half-thickness `h(t_max)` around the hit surface's plane (the photon ray stores
//! the geometric normal at its hit), and at most [`MAX_EXTENSION`] radii along the ray.
//!
//! Parallelism without locks and independent of the thread count: the image is cut into tiles, each
//! with its own kd-tree over its eye samples; tiles run in parallel and each visits every photon ray
//! in the same order (after a cheap bounding-box rejection), accumulating into its own pixels. When
//! the image has few tiles, a tile's rays also run in parallel chunks summed in chunk order
//! (`splat/tile.rs`; the chunk count depends on the image size only).
//! Per pixel we also record the sum of kernel weights and the harmonic mean distance of incident
//! photon rays (for filtering and radiance caching).
//!
//! Glossy eye samples either evaluate their BSDF per photon (`GlossyMode::Exact`) or accumulate the
//! photon's cosine-weighted radiance into their pixel's radiance map (§8.1, [`crate::radiance_map`]),
//! integrated against the BSDF after splatting.
//! The exact evaluation keeps the BSDF's albedo-table lookup at the photon's direction from one eye
//! sample to the next ([`crate::bsdf::AbMemo`]): one photon ray's samples mostly lie on one flat
//! surface of one material, where that lookup repeats bit for bit.
//!
//! Per-tile trees rather than one tree over all eye samples: a tile's samples stay in the L2 cache
//! while every ray visits it (docs/architecture.md, "Performance").

use crate::eye::EyePass;
use crate::kdtree::Cone;
use crate::photon::PhotonRay;
pub use footprint::{for_each_splat, Footprint};
pub use reach::Reach;
use tile::{splat_tile, Tile, TileOut};
use crate::radiance_map::{Encoder, GlossyMode, RadianceMap};
use glam::Vec3;
use rayon::prelude::*;

mod footprint;
mod reach;
pub mod records;
#[cfg(test)]
mod tests;
mod tile;

/// [`BuildParams::empty_cut`] of the splat's kd-trees over eye samples (and cache records).
pub const EMPTY_CUT: f32 = 0.25;

/// The kd-tree query of photon ray `r` in the splat: its cone (the segment, the extension beyond
/// the hit, backface culling) and the largest radius along it; `None` for a ray that splats
/// nothing. For benchmarks that time the query apart from the kernel.
pub fn splat_cone(r: &PhotonRay) -> Option<(Cone, f32)> {
    Footprint::of(r).map(|fp| (fp.cone, fp.rmax))
}

/// Tile edge in pixels.
pub const TILE: u32 = 32;
/// Largest extension of the footprint beyond the hit, in splat radii (bounds grazing photons,
/// θ > 87°, whose contribution is weighted by cos θ < 0.05 anyway).
pub const MAX_EXTENSION: f32 = 20.0;

/// Per-pixel results of splatting.
pub struct SplatImage {
    pub width: u32,
    pub height: u32,
    /// Reflected radiance from splatted photons (already weighted by the eye samples' weights).
    pub radiance: Vec<Vec3>,
    /// Sum of kernel weights of the splats a pixel received.
    pub kernel_weight: Vec<f32>,
    /// Harmonic mean distance of the incident photon rays (0 when none arrived).
    pub harmonic_distance: Vec<f32>,
    /// (eye sample, photon ray) pairs that contributed.
    pub pairs: u64,
    /// Sum over splats of the bandwidth at the eye sample (for the mean bandwidth statistic).
    pub bandwidth_sum: f64,
    /// Memory of the per-tile kd-trees at their largest (bytes).
    pub tree_bytes: u64,
    pub tiles: usize,
    /// Memory of the photon rays' footprint boxes (bytes), held during splatting.
    pub ray_box_bytes: u64,
    /// The radiance map of the glossy pixels (`None` for `GlossyMode::Exact`); the glossy eye
    /// samples' light is then *not* in `radiance` until [`crate::radiance_map::resolve`].
    pub map: Option<RadianceMap>,
    /// Why `GlossyMode::Auto` left every glossy eye sample to the exact BSDF (`None` otherwise).
    pub auto_exact: Option<&'static str>,
}

impl SplatImage {
    /// Memory of the per-pixel arrays (radiance, kernel weight, harmonic distance), map excluded.
    pub fn bytes(&self) -> u64 {
        (self.radiance.len() * (12 + 4 + 4)) as u64
    }

    pub fn mean_bandwidth(&self) -> f64 {
        if self.pairs == 0 {
            0.0
        } else {
            self.bandwidth_sum / self.pairs as f64
        }
    }
}

/// Splat every ray of `rays` (each a slice, e.g. one per photon class) onto the eye samples.
pub fn splat(eye: &EyePass, rays: &[&[PhotonRay]]) -> SplatImage {
    splat_cancellable(eye, rays, &|| false).expect("never cancelled")
}

/// [`splat`] that polls `cancelled` every few thousand photon rays (`None` when cancelled).
pub fn splat_cancellable(eye: &EyePass, rays: &[&[PhotonRay]], cancelled: &(dyn Fn() -> bool + Sync)) -> Option<SplatImage> {
    splat_with_map(eye, rays, GlossyMode::Exact, cancelled)
}

/// [`splat_cancellable`] with glossy eye samples recorded in a radiance map of kind `mode`.
pub fn splat_with_map(
    eye: &EyePass,
    rays: &[&[PhotonRay]],
    mode: GlossyMode,
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Option<SplatImage> {
    splat_with_tables(eye, rays, mode, None, false, cancelled)
}

/// [`splat_with_map`] with the SH tables of `eye`'s glossy samples, when already built, for
/// `GlossyMode::Auto` to decide with ([`RadianceMap::auto_with`]). With `only_reached` the
/// radiance map holds only the glossy samples of the image tiles some ray's footprint reaches (a
/// sparse set of rays, e.g. rs-rc's narrow caustic photons: their map would otherwise span every
/// glossy pixel for a few percent of them); the map is then not for filtering beyond those tiles.
/// `eye`'s samples must be in pixel order (every eye pass is; panics otherwise).
pub fn splat_with_tables(
    eye: &EyePass,
    rays: &[&[PhotonRay]],
    mode: GlossyMode,
    tables: Option<crate::radiance_map::ShTables>,
    only_reached: bool,
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Option<SplatImage> {
    let (w, h) = (eye.width, eye.height);
    let tiles_x = w.div_ceil(TILE);
    let tiles_y = h.div_ceil(TILE);
    let n_tiles = (tiles_x * tiles_y) as usize;
    // Group eye samples by tile. Samples are in pixel order, so a tile's samples are, row by row,
    // the run of samples of the row's pixels in the tile: found by binary search, and listed in
    // parallel (each tile's list in sample order).
    assert!(eye.samples.par_windows(2).all(|s| s[0].pixel <= s[1].pixel), "splatting needs the eye samples in pixel order");
    let tile_of = |pixel: u32| ((pixel / w) / TILE * tiles_x + (pixel % w) / TILE) as usize;
    let runs = |t: usize| {
        let (x0, y0) = ((t as u32 % tiles_x) * TILE, (t as u32 / tiles_x) * TILE);
        let first_sample = |p: u32| eye.samples.partition_point(|e| e.pixel < p);
        (y0..(y0 + TILE).min(h)).map(move |y| first_sample(y * w + x0)..first_sample(y * w + (x0 + TILE).min(w)))
    };
    let counts: Vec<usize> = (0..n_tiles).into_par_iter().map(|t| runs(t).map(|r| r.len()).sum()).collect();
    let mut starts = vec![0usize; n_tiles + 1];
    for (t, c) in counts.iter().enumerate() {
        starts[t + 1] = starts[t] + c;
    }
    let mut order = vec![0u32; eye.samples.len()];
    let mut lists: Vec<(usize, &mut [u32])> = Vec::with_capacity(n_tiles);
    let mut rest = order.as_mut_slice();
    for (t, &c) in counts.iter().enumerate() {
        let (list, tail) = rest.split_at_mut(c);
        lists.push((t, list));
        rest = tail;
    }
    lists.into_par_iter().for_each(|(t, list)| {
        for (slot, i) in list.iter_mut().zip(runs(t).flatten()) {
            *slot = i as u32;
        }
    });
    // Every ray's footprint box, decoded once (not once per tile): a tile skips the rays whose box
    // misses its eye samples' box without decoding them. An empty box for rays that splat nothing.
    let mut ray_boxes: Vec<RayBox> = Vec::with_capacity(rays.iter().map(|s| s.len()).sum());
    for s in rays {
        ray_boxes.par_extend(s.par_iter().map(|r| {
            Footprint::of(r).map_or(RayBox::EMPTY, |fp| {
                let (lo, hi) = fp.bounds();
                RayBox { lo, hi }
            })
        }));
    }
    // The tiles some ray's footprint box reaches (the box of the tile's eye samples met): the
    // others build no kd-tree and receive nothing.
    let reached: Vec<bool> = (0..n_tiles)
        .into_par_iter()
        .map(|t| {
            let idx = &order[starts[t]..starts[t + 1]];
            let (lo, hi) = idx.iter().map(|&i| eye.samples[i as usize].pos()).fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p), hi.max(p)));
            !idx.is_empty() && !ray_boxes.iter().all(|b| b.misses(lo, hi))
        })
        .collect();
    let within = |e: &crate::eye::EyeSample| !only_reached || reached[tile_of(e.pixel)];
    // no glossy eye sample, no map (a diffuse view keeps one RGB value per pixel); `Auto` maps
    // only the samples whose material's lobe fits SH bands 0–3, and none when no material does
    let mut auto_exact = None;
    let mut map = match (eye.glossy.is_empty(), mode) {
        (true, _) | (_, GlossyMode::Exact) => None,
        (false, GlossyMode::Auto) => tables
            .map_or_else(|| RadianceMap::auto_tables(eye), Ok)
            .and_then(|t| RadianceMap::auto_within(eye, t, within))
            .map_err(|why| auto_exact = Some(why))
            .ok(),
        (false, _) => Some(RadianceMap::new_for(mode, eye, within)),
    };
    let enc = map.as_ref().and_then(|m| Encoder::new(m.mode));
    let slots = map.as_ref().map(|m| Slots { first: &m.slot_of, count: &m.pixel_slots, of_glossy: &m.slot_of_glossy });
    // (the tiles some ray reaches share the work: a caustic reaches a few of them)
    let chunks = tile::chunks(reached.iter().filter(|&&r| r).count());
    let outs: Option<Vec<TileOut>> = (0..n_tiles)
        .into_par_iter()
        .map(|t| {
            let (tx, ty) = (t as u32 % tiles_x, t as u32 / tiles_x);
            let (x0, y0) = (tx * TILE, ty * TILE);
            let tile = Tile { x0, y0, tw: TILE.min(w - x0), th: TILE.min(h - y0) };
            splat_tile(eye, &order[starts[t]..starts[t + 1]], rays, &ray_boxes, reached[t], tile, enc.zip(slots), chunks, cancelled)
        })
        .collect();
    let outs = outs?;
    let n = (w * h) as usize;
    let mut img = SplatImage {
        width: w,
        height: h,
        radiance: vec![Vec3::ZERO; n],
        kernel_weight: vec![0.0; n],
        harmonic_distance: vec![0.0; n],
        pairs: 0,
        bandwidth_sum: 0.0,
        tree_bytes: 0,
        tiles: n_tiles,
        ray_box_bytes: std::mem::size_of_val(ray_boxes.as_slice()) as u64,
        map: None,
        auto_exact,
    };
    for o in outs {
        // a tile no ray reached leaves its map slots zero (the map is allocated zeroed)
        if let Some(m) = map.as_mut().filter(|_| !o.records.is_empty()) {
            let mut next = 0;
            for k in 0..o.radiance.len() {
                let (x, y) = (o.x0 + k as u32 % o.tw, o.y0 + k as u32 / o.tw);
                let p = (y * w + x) as usize;
                if m.slot_of[p] != u32::MAX {
                    // the pixel's slots are contiguous, in the tile as in the map
                    let (s, len) = (m.slot_of[p] as usize * m.k, m.pixel_slots[p] as usize * m.k);
                    m.records[s..s + len].copy_from_slice(&o.records[next..next + len]);
                    next += len;
                }
            }
        }
        // (a tile without pairs holds zeros, which the image already holds: a caustic reaches few)
        for (k, r) in o.radiance.iter().enumerate().filter(|_| o.pairs > 0) {
            let (x, y) = (o.x0 + k as u32 % o.tw, o.y0 + k as u32 / o.tw);
            let p = (y * w + x) as usize;
            img.radiance[p] = *r;
            img.kernel_weight[p] = o.weight[k];
            img.harmonic_distance[p] = if o.count[k] > 0 && o.inv_dist[k] > 0.0 { o.count[k] as f32 / o.inv_dist[k] } else { 0.0 };
        }
        img.pairs += o.pairs;
        img.bandwidth_sum += o.bw_sum;
        img.tree_bytes = img.tree_bytes.max(o.tree_bytes);
    }
    img.map = map;
    Some(img)
}

/// The box around one photon ray's footprint ([`Footprint::bounds`]), 24 bytes.
#[derive(Clone, Copy)]
struct RayBox {
    lo: Vec3,
    hi: Vec3,
}

const _: () = assert!(std::mem::size_of::<RayBox>() == 24);

impl RayBox {
    const EMPTY: RayBox = RayBox { lo: Vec3::INFINITY, hi: Vec3::NEG_INFINITY };

    /// True when this box and `[lo, hi]` are disjoint.
    #[inline(always)]
    fn misses(&self, lo: Vec3, hi: Vec3) -> bool {
        self.lo.cmpgt(hi).any() || self.hi.cmplt(lo).any()
    }
}

/// The radiance map's slot indices ([`RadianceMap`]): first slot and slot count per pixel, slot
/// per glossy eye sample.
#[derive(Clone, Copy)]
struct Slots<'a> {
    first: &'a [u32],
    count: &'a [u32],
    of_glossy: &'a [u32],
}


/// Conservative rejection: does the capsule around the segment (radius `r`) miss the box? (Also
/// used by `raysplat-bench photons` to query exactly the tiles `splat` queries.)
pub fn misses_box(c: &Cone, r: f32, lo: Vec3, hi: Vec3) -> bool {
    let (lo, hi) = (lo - Vec3::splat(r), hi + Vec3::splat(r));
    let t_end = c.t_max + if c.hemisphere_cap { r } else { 0.0 };
    let (mut t0, mut t1) = (0.0f32, t_end);
    for a in 0..3 {
        let (o, d) = (c.origin[a], c.dir[a]);
        if d.abs() < 1e-12 {
            if o < lo[a] || o > hi[a] {
                return true;
            }
        } else {
            let (mut ta, mut tb) = ((lo[a] - o) / d, (hi[a] - o) / d);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = t0.max(ta);
            t1 = t1.min(tb);
            if t0 > t1 {
                return true;
            }
        }
    }
    false
}
