//! Splatting onto sparse records (the cache records of §8.3): the same kernel and feasibility as
//! [`super::splat`], but the points are few and spread over the whole image, so instead of one
//! kd-tree per image tile (each tile visiting every photon ray) there is one kd-tree over all
//! records, and every photon ray is traversed once.
//!
//! Parallelism independent of the thread count: the photon rays (all classes, in order) are cut
//! into chunks of [`CHUNK`] rays; each chunk accumulates into its own per-record sums, and the
//! chunks' sums are added to the total in chunk order, [`WAVE`] chunks at a time (which bounds the
//! memory at `WAVE` accumulators).

use super::footprint::{for_each_splat, Footprint};
use crate::kdtree::{BuildParams, KdTree};
use crate::photon::PhotonRay;
use crate::radiance_map::Encoder;
use glam::Vec3;
use rayon::prelude::*;

/// Photon rays per chunk.
pub const CHUNK: usize = 8192;
/// Chunks splatted in parallel before their sums are added to the total.
pub const WAVE: usize = 8;

/// Per-record results: the encoder's coefficients of the cosine-weighted incoming radiance (unit
/// weight), the harmonic mean distance of the photon rays that reached each record, and the
/// second moment of its photons' contributions (its noise).
pub struct RecordSplat {
    /// `records × encoder.records()` values.
    pub coeffs: Vec<Vec3>,
    /// 0 where no photon ray arrived.
    pub harmonic_distance: Vec<f32>,
    /// Σ over the record's photons of their contribution's square, `(K·cos θ·(Φr + Φg + Φb))²`:
    /// the variance estimate of `Σ K·cos θ·(Φr + Φg + Φb)`, the record's irradiance summed over
    /// its channels (its band-0 coefficients' sum / Y₀ with the SH encoder).
    pub second_moment: Vec<f32>,
    /// (record, photon ray) pairs that contributed.
    pub pairs: u64,
    /// Memory of the kd-tree over the records (grouped: the largest group's).
    pub tree_bytes: u64,
}

struct Acc {
    coeffs: Vec<Vec3>,
    inv_dist: Vec<f32>,
    second_moment: Vec<f32>,
    count: Vec<u32>,
    pairs: u64,
}

impl Acc {
    fn new(n: usize, k: usize) -> Acc {
        Acc { coeffs: vec![Vec3::ZERO; n * k], inv_dist: vec![0.0; n], second_moment: vec![0.0; n], count: vec![0; n], pairs: 0 }
    }
    fn clear(&mut self) {
        self.coeffs.fill(Vec3::ZERO);
        self.inv_dist.fill(0.0);
        self.second_moment.fill(0.0);
        self.count.fill(0);
        self.pairs = 0;
    }
    fn add(&mut self, o: &Acc) {
        for (a, b) in self.coeffs.iter_mut().zip(&o.coeffs) {
            *a += *b;
        }
        for (a, b) in self.inv_dist.iter_mut().zip(&o.inv_dist) {
            *a += *b;
        }
        for (a, b) in self.second_moment.iter_mut().zip(&o.second_moment) {
            *a += *b;
        }
        for (a, b) in self.count.iter_mut().zip(&o.count) {
            *a += *b;
        }
        self.pairs += o.pairs;
    }
}

/// Splat every ray of `rays` onto the records at `pts` with normals `nrm`, encoding each photon's
/// cosine-weighted radiance with `enc`. `None` when `cancelled`.
pub fn splat_records(
    pts: &[Vec3],
    nrm: &[Vec3],
    rays: &[&[PhotonRay]],
    enc: Encoder,
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Option<RecordSplat> {
    let (n, k_rec) = (pts.len(), enc.records());
    let mut total = Acc::new(n, k_rec);
    let tree = match KdTree::build_with_normals(pts, nrm, &BuildParams { empty_cut: super::EMPTY_CUT, ..BuildParams::default() }) {
        Ok(t) if n > 0 => t,
        _ => return Some(finish(total, 0)),
    };
    // chunk c = rays [c·CHUNK, (c+1)·CHUNK) of the classes laid end to end
    let n_rays: usize = rays.iter().map(|s| s.len()).sum();
    let n_chunks = n_rays.div_ceil(CHUNK);
    let ray_range = |c: usize| {
        let (start, end) = (c * CHUNK, ((c + 1) * CHUNK).min(n_rays));
        let mut offset = 0;
        rays.iter().flat_map(move |s| {
            let (a, b) = (start.saturating_sub(offset).min(s.len()), end.saturating_sub(offset).min(s.len()));
            offset += s.len();
            s[a..b].iter()
        })
    };
    let mut accs: Vec<Acc> = (0..WAVE.min(n_chunks)).map(|_| Acc::new(n, k_rec)).collect();
    for wave in (0..n_chunks).step_by(WAVE) {
        let chunks = wave..(wave + WAVE).min(n_chunks);
        let done = accs.par_iter_mut().zip(chunks.clone()).all(|(acc, c)| {
            acc.clear();
            crate::embree::set_flush_denormals();
            for (j, r) in ray_range(c).enumerate() {
                if j % 4096 == 0 && cancelled() {
                    return false;
                }
                // encoded (and its flux summed) on the ray's first splat (most rays reach no record
                // of a sparse set)
                let mut code = None;
                for_each_splat(r, &tree, pts, nrm, |_, i, t, k, _, cos| {
                    let (code, flux_sum) = code.get_or_insert_with(|| (enc.encode(-r.dir(), r.flux()), r.flux().element_sum()));
                    code.add(k * cos, &mut acc.coeffs[i * k_rec..(i + 1) * k_rec]);
                    acc.second_moment[i] += (k * cos * *flux_sum).powi(2);
                    acc.inv_dist[i] += 1.0 / t.max(1e-30);
                    acc.count[i] += 1;
                    acc.pairs += 1;
                });
            }
            true
        });
        if !done {
            return None; // cancelled
        }
        for acc in &accs[..chunks.len()] {
            total.add(acc);
        }
    }
    Some(finish(total, tree.stats().memory_bytes as u64))
}

/// [`splat_records`] for many records spread over the image (one per pixel): the records are cut
/// into groups by `group` (e.g. an image block per record), each group splatted on its own with
/// only the photon rays whose footprint box reaches the group's records, in parallel. Per-chunk
/// sums of a single tree over every record would be `records × coefficients` large (48 MB per
/// chunk at 500²); a group's stay in the cache. Results in the order of `pts`; the same for any
/// thread count (each group's rays keep their order).
pub fn splat_records_grouped(
    pts: &[Vec3],
    nrm: &[Vec3],
    group: &[u32],
    rays: &[&[PhotonRay]],
    enc: Encoder,
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Option<RecordSplat> {
    let k_rec = enc.records();
    let n_groups = group.iter().map(|&g| g as usize + 1).max().unwrap_or(0);
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); n_groups];
    for (i, &g) in group.iter().enumerate() {
        members[g as usize].push(i as u32);
    }
    let all: Vec<&PhotonRay> = rays.iter().flat_map(|s| s.iter()).collect();
    let boxes: Vec<Option<(Vec3, Vec3)>> = all.par_iter().map(|r| Footprint::of(r).map(|f| f.bounds())).collect();
    // per group its sums, or `Some(None)` when no ray reaches it: its sums are zero, which `out`
    // already holds (the image blocks of a caustic's grid that its light does not reach: no tree,
    // no accumulators)
    let outs: Option<Vec<Option<RecordSplat>>> = members
        .par_iter()
        .map(|m| {
            let (gp, gn): (Vec<Vec3>, Vec<Vec3>) = m.iter().map(|&i| (pts[i as usize], nrm[i as usize])).unzip();
            let (lo, hi) = gp.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
            let near: Vec<PhotonRay> = all.iter().zip(&boxes).filter(|(_, b)| b.is_some_and(|(a, b)| a.cmple(hi).all() && b.cmpge(lo).all())).map(|(r, _)| **r).collect();
            if near.is_empty() {
                return Some(None);
            }
            splat_records(&gp, &gn, &[&near], enc, cancelled).map(Some)
        })
        .collect();
    let mut out = RecordSplat { coeffs: vec![Vec3::ZERO; pts.len() * k_rec], harmonic_distance: vec![0.0; pts.len()], second_moment: vec![0.0; pts.len()], pairs: 0, tree_bytes: 0 };
    for (m, o) in members.iter().zip(outs?) {
        let Some(o) = o else { continue };
        for (j, &i) in m.iter().enumerate() {
            let i = i as usize;
            out.coeffs[i * k_rec..(i + 1) * k_rec].copy_from_slice(&o.coeffs[j * k_rec..(j + 1) * k_rec]);
            out.harmonic_distance[i] = o.harmonic_distance[j];
            out.second_moment[i] = o.second_moment[j];
        }
        out.pairs += o.pairs;
        out.tree_bytes = out.tree_bytes.max(o.tree_bytes);
    }
    Some(out)
}

fn finish(total: Acc, tree_bytes: u64) -> RecordSplat {
    let harmonic_distance = total
        .count
        .iter()
        .zip(&total.inv_dist)
        .map(|(&c, &s)| if c > 0 && s > 0.0 { c as f32 / s } else { 0.0 })
        .collect();
    RecordSplat { coeffs: total.coeffs, harmonic_distance, second_moment: total.second_moment, pairs: total.pairs, tree_bytes }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eye::{EyePass, EyeSample, NO_GLOSSY};
    use crate::sampling::{hash, oct_encode, Rng};

    /// Eye samples on a bumpy floor (one per pixel) and photon rays falling onto it from above.
    fn setup(n_rays: usize) -> (EyePass, Vec<PhotonRay>) {
        let (w, h) = (24u32, 20u32);
        let samples = (0..w * h)
            .map(|p| {
                let mut r = Rng::new(hash(&[11, p as u64]), 0);
                let (x, y) = ((p % w) as f32 + r.next_f32(), (p / w) as f32 + r.next_f32());
                let n = Vec3::new(0.3 * (r.next_f32() - 0.5), 0.3 * (r.next_f32() - 0.5), 1.0).normalize();
                EyeSample { p: [x * 0.05, y * 0.05, 0.01 * (x * 0.7).sin()], n: oct_encode(n), weight: [1.0; 3], pixel: p, glossy: NO_GLOSSY }
            })
            .collect();
        let rays = (0..n_rays)
            .map(|i| {
                let mut r = Rng::new(hash(&[12, i as u64]), 0);
                let o = Vec3::new(r.next_f32() * 1.4 - 0.1, r.next_f32() * 1.2 - 0.1, 0.5 + r.next_f32());
                let d = Vec3::new(r.next_f32() - 0.5, r.next_f32() - 0.5, -1.0).normalize();
                let len = (o.z - 0.005) / -d.z;
                let mut ray = PhotonRay::new(o, d, len, Vec3::new(1.0, 0.5, 0.25) * r.next_f32(), -Vec3::Z, Vec3::Z);
                (ray.h0, ray.dh) = (0.02 + 0.05 * r.next_f32(), 0.02 * r.next_f32());
                ray
            })
            .collect();
        (EyePass::of_samples(w, h, samples, Default::default()), rays)
    }

    #[test]
    fn records_receive_what_tiled_splatting_gives_their_pixels() {
        // every pixel a record: the same pairs, radiance (SH band 0 / Y₀ = Σ flux·K·cos at unit
        // weight) and harmonic distance as the tiled splatting of the same eye samples
        let (eye, rays) = setup(3 * CHUNK + 123);
        let classes: [&[PhotonRay]; 2] = [&rays[..5000], &rays[5000..]];
        let tiled = crate::splat::splat(&eye, &classes);
        let pts: Vec<Vec3> = eye.samples.iter().map(|e| e.pos()).collect();
        let nrm: Vec<Vec3> = eye.samples.iter().map(|e| e.normal()).collect();
        let rec = splat_records(&pts, &nrm, &classes, Encoder::Sh, &|| false).unwrap();
        assert!(tiled.pairs > 10_000, "too few pairs to mean anything: {}", tiled.pairs);
        assert_eq!(rec.pairs, tiled.pairs);
        let y0 = crate::sh::eval(Vec3::Z)[0];
        for (i, e) in eye.samples.iter().enumerate() {
            let (a, b) = (rec.coeffs[i * crate::sh::N] / y0, tiled.radiance[e.pixel as usize]);
            assert!((a - b).abs().max_element() <= 1e-4 * (1.0 + b.max_element()), "pixel {}: {a} vs {b}", e.pixel);
            let (ha, hb) = (rec.harmonic_distance[i], tiled.harmonic_distance[e.pixel as usize]);
            assert!((ha - hb).abs() <= 1e-4 * hb, "pixel {}: {ha} vs {hb}", e.pixel);
        }
    }

    #[test]
    fn records_are_the_same_for_any_thread_count() {
        let (eye, rays) = setup(2 * CHUNK + 7);
        let pts: Vec<Vec3> = eye.samples.iter().step_by(3).map(|e| e.pos()).collect();
        let nrm: Vec<Vec3> = eye.samples.iter().step_by(3).map(|e| e.normal()).collect();
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| splat_records(&pts, &nrm, &[&rays], Encoder::Sh, &|| false).unwrap())
        };
        let (a, b) = (run(1), run(3));
        assert!(a.pairs > 1000);
        assert_eq!(a.coeffs, b.coeffs);
        assert_eq!(a.harmonic_distance, b.harmonic_distance);
        assert_eq!(a.second_moment, b.second_moment);
        // and no records, no work
        assert_eq!(splat_records(&[], &[], &[&rays], Encoder::Sh, &|| false).unwrap().pairs, 0);
    }

    #[test]
    fn second_moment_sums_each_photons_squared_contribution() {
        // the rays splatted one at a time: each call's channel-summed irradiance is that photon's
        // contribution, whose squares the splat of all rays at once must sum
        // (two chunks: their sums are added)
        let (eye, rays) = setup(CHUNK + 2000);
        let rays = &rays[..];
        let pts: Vec<Vec3> = eye.samples.iter().step_by(2).map(|e| e.pos()).collect();
        let nrm: Vec<Vec3> = eye.samples.iter().step_by(2).map(|e| e.normal()).collect();
        let y0 = crate::sh::eval(Vec3::Z)[0];
        let value = |s: &RecordSplat, i: usize| s.coeffs[i * crate::sh::N].element_sum() / y0;
        let mut sq = vec![0.0f64; pts.len()];
        for r in rays {
            let one = splat_records(&pts, &nrm, &[std::slice::from_ref(r)], Encoder::Sh, &|| false).unwrap();
            for (i, s) in sq.iter_mut().enumerate() {
                *s += (value(&one, i) as f64).powi(2);
            }
        }
        let all = splat_records(&pts, &nrm, &[rays], Encoder::Sh, &|| false).unwrap();
        assert!(all.pairs > 1000, "too few pairs to mean anything: {}", all.pairs);
        let mut reached = 0;
        for (i, (&m, &s)) in all.second_moment.iter().zip(&sq).enumerate() {
            assert!((m as f64 - s).abs() <= 1e-4 * s.max(1e-12), "record {i}: {m} vs {s}");
            reached += (m > 0.0) as usize;
            // the mean square of positive contributions lies between (Σ/n)² and Σ²
            assert!(m as f64 <= value(&all, i) as f64 * value(&all, i) as f64 * (1.0 + 1e-4));
        }
        assert!(reached > pts.len() / 2, "only {reached} of {} records reached", pts.len());
    }

    #[test]
    fn grouped_records_receive_what_one_tree_gives_them() {
        // groups of 6×5 pixels (as image blocks): the same pairs and coefficients as one tree over
        // all records (up to summation order), and the same for any thread count
        let (eye, rays) = setup(CHUNK + 500);
        let pts: Vec<Vec3> = eye.samples.iter().map(|e| e.pos()).collect();
        let nrm: Vec<Vec3> = eye.samples.iter().map(|e| e.normal()).collect();
        let group: Vec<u32> = eye.samples.iter().map(|e| (e.pixel / 24 / 5) * 4 + (e.pixel % 24) / 6).collect();
        let one = splat_records(&pts, &nrm, &[&rays], Encoder::Sh, &|| false).unwrap();
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| splat_records_grouped(&pts, &nrm, &group, &[&rays], Encoder::Sh, &|| false).unwrap())
        };
        let (a, b) = (run(1), run(3));
        assert!(one.pairs > 10_000, "too few pairs to mean anything: {}", one.pairs);
        assert_eq!(a.pairs, one.pairs);
        assert_eq!(a.coeffs, b.coeffs);
        for (i, (x, y)) in a.coeffs.iter().zip(&one.coeffs).enumerate() {
            assert!((*x - *y).abs().max_element() <= 1e-5 * (1.0 + y.abs().max_element()), "coefficient {i}: {x} vs {y}");
        }
        for (x, y) in a.harmonic_distance.iter().zip(&one.harmonic_distance) {
            assert!((x - y).abs() <= 1e-4 * y, "{x} vs {y}");
        }
    }
}
