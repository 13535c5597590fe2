//! Image-space radiance filtering (§8.2 of `photon-ray-splatting.md`): a second-pass filter over the
//! splatted *incoming* radiance instead of larger splat footprints, never across geometric
//! discontinuities.
//!
//! 1. **Discontinuity buffer**: neighbouring pixels are continuous when both saw geometry, their
//!    depths differ by less than [`FilterParams::depth_tolerance`] (relative) and their normals by less
//!    than [`FilterParams::normal_cos`].
//! 2. **Segmentation**: the connected components of continuous pixels (4-neighbourhood, union-find).
//! 3. **Summed-area tables** per segment (over its bounding box, masked to the segment): box sums of
//!    any radius in O(1).
//! 4. **Filter width** per pixel from the kernel-weight statistics recorded by splatting: the
//!    smallest box (radius ≤ `max_radius`) whose summed kernel weight within the segment reaches
//!    `target × mean kernel weight` — pixels that received little kernel weight (few or far photons,
//!    high variance) average over more neighbours.
//!
//! What is filtered is incoming light, not visible radiance: diffuse pixels' splatted radiance is
//! divided by the sum of their diffuse eye samples' weights (albedo/π × throughput), filtered and
//! multiplied back; glossy pixels' radiance-map records are filtered per SH coefficient or stratum
//! (per glossy eye sample). Pixels mixing diffuse and glossy samples and glossy pixels under
//! `--glossy exact` are left as they are.

#[cfg(test)]
mod tests;

use crate::eye::EyePass;
use crate::splat::SplatImage;
use glam::{DVec3, Vec3};

/// Parameters of the filter.
#[derive(Clone, Copy, Debug)]
pub struct FilterParams {
    /// Largest box radius in pixels (0: no filtering).
    pub max_radius: u32,
    /// Box kernel weight to reach, in mean kernel weights per pixel.
    pub target: f32,
    /// Largest relative depth difference between continuous neighbours.
    pub depth_tolerance: f32,
    /// Smallest cosine between continuous neighbours' normals.
    pub normal_cos: f32,
}

impl FilterParams {
    pub fn with_radius(max_radius: u32) -> FilterParams {
        FilterParams { max_radius, target: 9.0, depth_tolerance: 0.05, normal_cos: 0.8 }
    }
}

/// Segment labels per pixel (`u32::MAX`: no geometry) and the number of segments.
pub fn segment(width: u32, height: u32, depth: &[f32], normal: &[Vec3], p: &FilterParams) -> (Vec<u32>, usize) {
    let n = (width * height) as usize;
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(parent: &mut [u32], mut i: u32) -> u32 {
        while parent[i as usize] != i {
            parent[i as usize] = parent[parent[i as usize] as usize];
            i = parent[i as usize];
        }
        i
    }
    let valid = |i: usize| depth[i] > 0.0 && depth[i].is_finite();
    let continuous = |a: usize, b: usize| {
        valid(a)
            && valid(b)
            && (depth[a] - depth[b]).abs() <= p.depth_tolerance * depth[a].min(depth[b])
            && normal[a].dot(normal[b]) >= p.normal_cos
    };
    for y in 0..height as usize {
        for x in 0..width as usize {
            let i = y * width as usize + x;
            for j in [(x + 1 < width as usize).then(|| i + 1), (y + 1 < height as usize).then(|| i + width as usize)].into_iter().flatten() {
                if continuous(i, j) {
                    let (a, b) = (find(&mut parent, i as u32), find(&mut parent, j as u32));
                    if a != b {
                        parent[a.max(b) as usize] = a.min(b);
                    }
                }
            }
        }
    }
    let mut label = vec![u32::MAX; n];
    let mut id_of_root = vec![u32::MAX; n];
    let mut count = 0usize;
    for (i, l) in label.iter_mut().enumerate() {
        if valid(i) {
            let r = find(&mut parent, i as u32) as usize;
            if id_of_root[r] == u32::MAX {
                id_of_root[r] = count as u32;
                count += 1;
            }
            *l = id_of_root[r];
        }
    }
    (label, count)
}

/// Box-filter `k` RGB records per pixel (`data[slot(p)·k ..]`, pixels with `slot(p) == None` take no
/// part) within the segments of `label`, with per-pixel radii chosen from `weight` (see the module
/// docs). Returns the mean radius used and the radius per pixel (0 where not filtered).
#[allow(clippy::too_many_arguments)]
pub fn filter_records(
    width: u32,
    height: u32,
    label: &[u32],
    segments: usize,
    weight: &[f32],
    slot: &dyn Fn(usize) -> Option<usize>,
    k: usize,
    data: &mut [Vec3],
    p: &FilterParams,
) -> (f64, Vec<u32>) {
    let mut radii = vec![0u32; (width * height) as usize];
    if p.max_radius == 0 || k == 0 {
        return (0.0, radii);
    }
    let (w, h) = (width as usize, height as usize);
    let part: Vec<bool> = (0..w * h).map(|i| label[i] != u32::MAX && slot(i).is_some()).collect();
    let n_part = part.iter().filter(|&&b| b).count();
    if n_part == 0 {
        return (0.0, radii);
    }
    let mean_w = (0..w * h).filter(|&i| part[i]).map(|i| weight[i] as f64).sum::<f64>() / n_part as f64;
    let target = p.target as f64 * mean_w;
    // bounding boxes of the segments
    let mut bbox = vec![(usize::MAX, usize::MAX, 0usize, 0usize); segments];
    for i in (0..w * h).filter(|&i| part[i]) {
        let (x, y) = (i % w, i / w);
        let b = &mut bbox[label[i] as usize];
        *b = (b.0.min(x), b.1.min(y), b.2.max(x), b.3.max(y));
    }
    let src = data.to_vec();
    let (mut radius_sum, mut filtered) = (0u64, 0u64);
    for (s, &(x0, y0, x1, y1)) in bbox.iter().enumerate() {
        if x0 == usize::MAX {
            continue;
        }
        let (bw, bh) = (x1 - x0 + 1, y1 - y0 + 1);
        let inside = |x: usize, y: usize| {
            let i = (y0 + y) * w + x0 + x;
            part[i] && label[i] == s as u32
        };
        // summed-area tables of the count and the kernel weight, then of each record
        let sat = |f: &dyn Fn(usize, usize) -> DVec3| -> Vec<DVec3> {
            let mut t = vec![DVec3::ZERO; (bw + 1) * (bh + 1)];
            for y in 0..bh {
                let mut row = DVec3::ZERO;
                for x in 0..bw {
                    if inside(x, y) {
                        row += f(x, y);
                    }
                    t[(y + 1) * (bw + 1) + x + 1] = t[y * (bw + 1) + x + 1] + row;
                }
            }
            t
        };
        let boxsum = |t: &[DVec3], x: usize, y: usize, r: usize| {
            let (xa, ya, xb, yb) = (x.saturating_sub(r), y.saturating_sub(r), (x + r + 1).min(bw), (y + r + 1).min(bh));
            t[yb * (bw + 1) + xb] - t[ya * (bw + 1) + xb] - t[yb * (bw + 1) + xa] + t[ya * (bw + 1) + xa]
        };
        let cw = sat(&|x, y| DVec3::new(1.0, weight[(y0 + y) * w + x0 + x] as f64, 0.0));
        // radius per pixel of the segment
        let mut radius = vec![0usize; bw * bh];
        for y in 0..bh {
            for x in 0..bw {
                if !inside(x, y) {
                    continue;
                }
                let mut r = 0;
                while r < p.max_radius as usize && boxsum(&cw, x, y, r).y < target {
                    r += 1;
                }
                radius[y * bw + x] = r;
                radii[(y0 + y) * w + x0 + x] = r as u32;
                radius_sum += r as u64;
                filtered += 1;
            }
        }
        for rec in 0..k {
            let t = sat(&|x, y| src[slot((y0 + y) * w + x0 + x).unwrap() * k + rec].as_dvec3());
            for y in 0..bh {
                for x in 0..bw {
                    if inside(x, y) {
                        let r = radius[y * bw + x];
                        let c = boxsum(&cw, x, y, r).x;
                        let i = slot((y0 + y) * w + x0 + x).unwrap() * k + rec;
                        data[i] = (boxsum(&t, x, y, r) / c).as_vec3();
                    }
                }
            }
        }
    }
    (radius_sum as f64 / filtered.max(1) as f64, radii)
}

/// Filter the splat image of `eye` in place (before the radiance map is resolved). Returns the mean
/// filter radius over diffuse pixels and over glossy pixels.
pub fn filter(eye: &EyePass, img: &mut SplatImage, p: &FilterParams) -> (f64, f64) {
    let (w, h) = (eye.width, eye.height);
    let n = (w * h) as usize;
    let (label, segments) = segment(w, h, &eye.depth, &eye.normal, p);
    // diffuse pixels: incoming light = radiance / Σ diffuse weights, only where no sample is glossy
    let mut dsum = vec![Vec3::ZERO; n];
    let mut glossy = vec![false; n];
    for e in &eye.samples {
        if e.is_glossy() {
            glossy[e.pixel as usize] = true;
        } else {
            dsum[e.pixel as usize] += e.weight();
        }
    }
    let ok = |i: usize| !glossy[i] && dsum[i].min_element() > 1e-12;
    let mut incoming: Vec<Vec3> = (0..n).map(|i| if ok(i) { img.radiance[i] / dsum[i] } else { Vec3::ZERO }).collect();
    let (rd, _) = filter_records(w, h, &label, segments, &img.kernel_weight, &|i| ok(i).then_some(i), 1, &mut incoming, p);
    for i in (0..n).filter(|&i| ok(i)) {
        img.radiance[i] = incoming[i] * dsum[i];
    }
    let mut rg = 0.0;
    if let Some(map) = img.map.as_mut() {
        // per glossy eye sample (the map holds sums over a pixel's glossy samples)
        let k = map.k;
        for (s, c) in map.glossy_count.iter().enumerate() {
            for v in &mut map.records[s * k..(s + 1) * k] {
                *v /= *c as f32;
            }
        }
        let slot_of = map.slot_of.clone();
        rg = filter_records(w, h, &label, segments, &img.kernel_weight, &|i| (slot_of[i] != u32::MAX).then_some(slot_of[i] as usize), k, &mut map.records, p).0;
        for (s, c) in map.glossy_count.iter().enumerate() {
            for v in &mut map.records[s * k..(s + 1) * k] {
                *v *= *c as f32;
            }
        }
    }
    (rd, rg)
}
