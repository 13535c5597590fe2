//! One tile of the splat: a kd-tree over the tile's eye samples, and every photon ray whose
//! footprint box reaches them splatted onto it, accumulating into the tile's own pixels.
//!
//! A tile's rays run in [`chunks`] of consecutive rays, each a parallel task with its own
//! accumulators, summed in chunk order at the end. The chunk count depends only on how many tiles
//! some ray reaches, so the image is the same for any thread count; it is more than one only when
//! few tiles receive rays (a small image, or rs-rc's caustic photons under a glass sphere), where
//! one task per tile would leave threads idle at the end of the splat.

use super::footprint::for_each_splat;
use super::{RayBox, Slots, EMPTY_CUT};
use crate::bsdf::AbMemo;
use crate::eye::{EyePass, GlossySample, NO_GLOSSY};
use crate::kdtree::{BuildParams, KdTree};
use crate::photon::PhotonRay;
use crate::radiance_map::Encoder;
use glam::Vec3;
use rayon::prelude::*;
use std::ops::Range;

/// Tasks the splat aims at: a tile's rays are cut into chunks until there are this many (tile,
/// chunk) tasks, at most [`MAX_CHUNKS`] per tile.
const MIN_TASKS: usize = 64;
/// Largest number of ray chunks per tile.
const MAX_CHUNKS: usize = 8;

/// Ray chunks per tile when `tiles` tiles receive rays (a count that does not depend on the thread
/// count, and neither does the result).
pub(super) fn chunks(tiles: usize) -> usize {
    MIN_TASKS.div_ceil(tiles.max(1)).clamp(1, MAX_CHUNKS)
}

#[derive(Clone, Copy)]
pub(super) struct Tile {
    pub x0: u32,
    pub y0: u32,
    pub tw: u32,
    pub th: u32,
}

/// What one tile (or one chunk of its rays) accumulated, per pixel of the tile.
pub(super) struct TileOut {
    pub x0: u32,
    pub y0: u32,
    pub tw: u32,
    pub radiance: Vec<Vec3>,
    pub weight: Vec<f32>,
    pub inv_dist: Vec<f32>,
    pub count: Vec<u32>,
    /// Radiance-map records of the tile's glossy pixels, in tile pixel order (empty when no
    /// photon ray reached the tile: all zero).
    pub records: Vec<Vec3>,
    pub pairs: u64,
    pub bw_sum: f64,
    pub tree_bytes: u64,
}

impl TileOut {
    /// Nothing accumulated yet, for `tile` with `n_slots` radiance-map slots of `k_rec` records.
    fn zeros(tile: Tile, n_slots: usize, k_rec: usize) -> TileOut {
        TileOut { records: vec![Vec3::ZERO; n_slots * k_rec], ..TileOut::unreached(tile) }
    }

    /// A tile no photon ray reaches: zero pixels and no radiance-map records (empty `records`,
    /// which leave the map's zeroed slots untouched; a sparse ray set, e.g. rs-rc's narrow
    /// caustic photons, reaches few of a map's tiles).
    fn unreached(tile: Tile) -> TileOut {
        let npix = (tile.tw * tile.th) as usize;
        TileOut {
            x0: tile.x0,
            y0: tile.y0,
            tw: tile.tw,
            radiance: vec![Vec3::ZERO; npix],
            weight: vec![0.0; npix],
            inv_dist: vec![0.0; npix],
            count: vec![0; npix],
            records: Vec::new(),
            pairs: 0,
            bw_sum: 0.0,
            tree_bytes: 0,
        }
    }

    /// Adds what another chunk of the same tile accumulated.
    fn add(&mut self, o: &TileOut) {
        fn add_all<T: Copy + std::ops::AddAssign>(a: &mut [T], b: &[T]) {
            a.iter_mut().zip(b).for_each(|(a, b)| *a += *b);
        }
        add_all(&mut self.radiance, &o.radiance);
        add_all(&mut self.weight, &o.weight);
        add_all(&mut self.inv_dist, &o.inv_dist);
        add_all(&mut self.count, &o.count);
        add_all(&mut self.records, &o.records);
        self.pairs += o.pairs;
        self.bw_sum += o.bw_sum;
    }
}

/// The tile's eye samples as the inner loop reads them, tile-local and decoded once.
struct Samples {
    tree: KdTree,
    pts: Vec<Vec3>,
    nrm: Vec<Vec3>,
    /// Per sample: its pixel in the tile (no integer division per pair), its glossy index and its
    /// weight.
    at: Vec<(u32, u32, Vec3)>,
    /// With a map: each sample's tile-local slot (`u32::MAX`: diffuse, or glossy with the exact
    /// BSDF per photon).
    slot: Vec<u32>,
    n_slots: usize,
    /// The glossy samples with the exact BSDF per photon, expanded once per tile (the eye pass
    /// stores them compact), and each sample's index there (`u32::MAX`: none).
    exact: Vec<GlossySample>,
    exact_of: Vec<u32>,
}

/// Splats every ray of `rays` (flat index `k` with footprint box `ray_boxes[k]`) onto the eye
/// samples `idx` of `tile`, in `chunks` (≥ 1) parallel chunks of rays; `None` when cancelled.
/// `reached`: some ray's box meets the box of the tile's samples (otherwise nothing is done).
#[allow(clippy::too_many_arguments)]
pub(super) fn splat_tile(
    eye: &EyePass,
    idx: &[u32],
    rays: &[&[PhotonRay]],
    ray_boxes: &[RayBox],
    reached: bool,
    tile: Tile,
    map: Option<(Encoder, Slots)>,
    chunks: usize,
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Option<TileOut> {
    let Tile { x0, y0, tw, th } = tile;
    let npix = (tw * th) as usize;
    // tile-local radiance-map slots of the glossy pixels, in tile pixel order (each pixel's slots
    // contiguous, as in the map)
    let mut local_slot = Vec::new();
    let mut n_slots = 0usize;
    if let Some((_, slots)) = map {
        local_slot = vec![u32::MAX; npix];
        for (k, ls) in local_slot.iter_mut().enumerate() {
            let (x, y) = (x0 + k as u32 % tw, y0 + k as u32 / tw);
            let p = (y * eye.width + x) as usize;
            if slots.first[p] != u32::MAX {
                *ls = n_slots as u32;
                n_slots += slots.count[p] as usize;
            }
        }
    }
    let k_rec = map.map_or(0, |(e, _)| e.records());
    let empty = || TileOut::zeros(tile, n_slots, k_rec);
    // no photon ray's footprint box reaches the tile's samples (a sparse set of rays, such as
    // rs-rc's narrow caustic photons): no tree to build
    if idx.is_empty() || !reached {
        return Some(TileOut::unreached(tile));
    }
    crate::embree::set_flush_denormals();
    let pts: Vec<Vec3> = idx.iter().map(|&i| eye.samples[i as usize].pos()).collect();
    let nrm: Vec<Vec3> = idx.iter().map(|&i| eye.samples[i as usize].normal()).collect();
    let w = eye.width;
    let at: Vec<(u32, u32, Vec3)> = idx
        .iter()
        .map(|&i| {
            let e = &eye.samples[i as usize];
            (((e.pixel / w - y0) * tw + (e.pixel % w - x0)), e.glossy, e.weight())
        })
        .collect();
    let slot: Vec<u32> = match map {
        Some((_, slots)) => idx
            .iter()
            .zip(&at)
            .map(|(&i, &(local, glossy, _))| {
                let e = &eye.samples[i as usize];
                if glossy == NO_GLOSSY || slots.of_glossy[glossy as usize] == u32::MAX {
                    u32::MAX
                } else {
                    local_slot[local as usize] + (slots.of_glossy[glossy as usize] - slots.first[e.pixel as usize])
                }
            })
            .collect(),
        None => Vec::new(),
    };
    // (none in a diffuse scene, or where the map holds every glossy sample: no table then)
    let is_exact = |i: usize, glossy: u32| glossy != NO_GLOSSY && slot.get(i).is_none_or(|&s| s == u32::MAX);
    let mut exact = Vec::new();
    let exact_of: Vec<u32> = if at.iter().enumerate().any(|(i, &(_, glossy, _))| is_exact(i, glossy)) {
        at.iter()
            .enumerate()
            .map(|(i, &(_, glossy, _))| {
                if !is_exact(i, glossy) {
                    return u32::MAX;
                }
                exact.push(eye.glossy.sample(glossy as usize));
                (exact.len() - 1) as u32
            })
            .collect()
    } else {
        Vec::new()
    };
    let params = BuildParams { parallel_threshold: usize::MAX, empty_cut: EMPTY_CUT, ..BuildParams::default() };
    let Ok(tree) = KdTree::build_with_normals(&pts, &nrm, &params) else { return Some(TileOut::unreached(tile)) };
    let tree_bytes = tree.stats().memory_bytes as u64;
    let samples = Samples { tree, pts, nrm, at, slot, n_slots, exact, exact_of };
    let n = ray_boxes.len();
    let len = n.div_ceil(chunks).max(1);
    let enc = map.map(|(e, _)| e);
    let parts: Option<Vec<TileOut>> = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let mut out = empty();
            splat_chunk(&samples, rays, ray_boxes, (c * len).min(n)..((c + 1) * len).min(n), enc, &mut out, cancelled)?;
            Some(out)
        })
        .collect();
    let mut parts = parts?.into_iter();
    let mut out = parts.next().unwrap_or_else(empty);
    for p in parts {
        out.add(&p);
    }
    out.tree_bytes = tree_bytes;
    Some(out)
}

/// The rays of flat indices `range` (across the slices of `rays`), with their flat index.
fn flat_range<'a>(rays: &'a [&'a [PhotonRay]], range: Range<usize>) -> impl Iterator<Item = (usize, &'a PhotonRay)> + 'a {
    let mut offset = 0;
    rays.iter().flat_map(move |s| {
        let (first, last) = (range.start.max(offset), range.end.min(offset + s.len()));
        let base = offset;
        offset += s.len();
        (first..last.max(first)).map(move |k| (k, &s[k - base]))
    })
}

/// Splats the rays of flat indices `range` onto the tile's samples, into `out`; `None` when
/// cancelled.
fn splat_chunk(
    s: &Samples,
    rays: &[&[PhotonRay]],
    ray_boxes: &[RayBox],
    range: Range<usize>,
    enc: Option<Encoder>,
    out: &mut TileOut,
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Option<()> {
    crate::embree::set_flush_denormals();
    let (lo, hi) = s.tree.bounds();
    let k_rec = enc.map_or(0, |e| e.records());
    // per ray: the summed kernel weight of each slot it reached, and those slots in order
    let mut slot_sum = vec![0.0f32; s.n_slots];
    let mut touched: Vec<u32> = Vec::new();
    for (ri, r) in flat_range(rays, range) {
        if ri % 4096 == 0 && cancelled() {
            return None;
        }
        if ray_boxes[ri].misses(lo, hi) {
            continue;
        }
        let flux = r.flux();
        // one photon direction on many eye samples of one surface: the BSDF's table lookup at
        // the incident direction repeats (exact BSDF mode)
        let mut memo = AbMemo::default();
        for_each_splat(r, &s.tree, &s.pts, &s.nrm, |fp, i, t, k, h, cos| {
            let (local, glossy, weight) = s.at[i];
            let local = local as usize;
            // the sample's map slot (`u32::MAX`: none, the light goes to the pixel's radiance)
            let slot = if glossy == NO_GLOSSY { u32::MAX } else { s.slot.get(i).copied().unwrap_or(u32::MAX) };
            if glossy == NO_GLOSSY {
                out.radiance[local] += weight * flux * (k * cos);
            } else if slot != u32::MAX {
                // the pixel's eye samples share its slot: sum the weights, add the records once
                let sum = &mut slot_sum[slot as usize];
                if *sum == 0.0 {
                    touched.push(slot);
                }
                *sum += k * cos;
            } else {
                out.radiance[local] += weight * s.exact[s.exact_of[i] as usize].eval_memo(-fp.dir, &mut memo) * flux * (k * cos);
            }
            out.weight[local] += k;
            out.inv_dist[local] += 1.0 / t.max(1e-30);
            out.count[local] += 1;
            out.pairs += 1;
            out.bw_sum += h as f64;
        });
        // with a map: the photon's records (encoded only for a ray that reached a slot), scaled
        // by each slot's summed weight
        if let (Some(enc), false) = (enc, touched.is_empty()) {
            let code = enc.encode(-r.dir(), flux);
            for slot in touched.drain(..) {
                let at = slot as usize * k_rec;
                code.add(std::mem::take(&mut slot_sum[slot as usize]), &mut out.records[at..at + k_rec]);
            }
        }
    }
    Some(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The flat ranges cover every ray once, across slices of any lengths (empty ones included).
    #[test]
    fn flat_ranges_cover_the_rays_once() {
        let ray = PhotonRay::new(Vec3::ZERO, Vec3::Z, 1.0, Vec3::ONE, Vec3::Z, Vec3::Z);
        let (a, b, c) = (vec![ray; 5], Vec::new(), vec![ray; 7]);
        let rays: Vec<&[PhotonRay]> = vec![&a, &b, &c];
        for chunks in 1..15 {
            let len = 12usize.div_ceil(chunks).max(1);
            let got: Vec<usize> = (0..chunks).flat_map(|c| flat_range(&rays, (c * len).min(12)..((c + 1) * len).min(12)).map(|(k, _)| k)).collect();
            assert_eq!(got, (0..12).collect::<Vec<_>>(), "{chunks} chunks");
        }
        assert_eq!(chunks(1), MAX_CHUNKS);
        assert_eq!(chunks(16), 4);
        assert_eq!(chunks(64), 1);
        assert_eq!(chunks(2040), 1);
    }
}
