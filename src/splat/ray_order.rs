//! The order in which photon rays are splatted: Morton order of their hit points. With one kd-tree
//! over a large block of eye samples, consecutive rays then reach nearby eye samples, so the
//! samples' positions, normals, BSDFs and sums stay in the cache from one ray to the next (in
//! emission order every ray touches a cold part of the block). The order changes only the order
//! of the per-pixel sums, and it never depends on the thread count (ties keep emission order).

use crate::photon::PhotonRay;
use glam::Vec3;
use rayon::prelude::*;

/// 21-bit-per-axis Morton code of `p` in the box starting at `lo`, `scale` = 2²¹−1 / extent.
fn morton(p: Vec3, lo: Vec3, scale: Vec3) -> u64 {
    let spread = |x: u64| {
        let mut x = x & 0x1f_ffff;
        x = (x | x << 32) & 0x1f_0000_0000_ffff;
        x = (x | x << 16) & 0x1f_0000_ff00_00ff;
        x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
        x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
        x = (x | x << 2) & 0x1249_2492_4924_9249;
        x
    };
    let c = ((p - lo) * scale).clamp(Vec3::ZERO, Vec3::splat(2_097_151.0));
    spread(c.x as u64) | spread(c.y as u64) << 1 | spread(c.z as u64) << 2
}

/// The photon ray at flat index `i` of the classes `rays` laid end to end.
#[inline]
pub(crate) fn ray_at<'a>(rays: &[&'a [PhotonRay]], mut i: usize) -> &'a PhotonRay {
    for s in rays {
        if i < s.len() {
            return &s[i];
        }
        i -= s.len();
    }
    panic!("photon ray index out of range")
}

/// Flat indices of all rays of `rays` (classes laid end to end) in Morton order of their hit
/// points (a transient 16 bytes per ray while sorting, 4 bytes per ray kept).
pub(crate) fn morton_order(rays: &[&[PhotonRay]]) -> Vec<u32> {
    let hit = |r: &PhotonRay| r.origin() + r.dir() * r.length;
    let mut hits: Vec<Vec3> = Vec::with_capacity(rays.iter().map(|s| s.len()).sum());
    for s in rays {
        hits.par_extend(s.par_iter().map(hit));
    }
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for p in hits.iter().filter(|p| p.is_finite()) {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    if !(lo.cmple(hi).all()) {
        return (0..hits.len() as u32).collect();
    }
    let scale = Vec3::splat(2_097_151.0) / (hi - lo).max(Vec3::splat(1e-30));
    let mut keys: Vec<(u64, u32)> = hits
        .par_iter()
        .enumerate()
        .map(|(i, p)| (if p.is_finite() { morton(*p, lo, scale) } else { u64::MAX }, i as u32))
        .collect();
    drop(hits);
    keys.par_sort_unstable(); // keys are unique (index), so the order is fixed
    keys.into_iter().map(|(_, i)| i).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_order_is_a_permutation_along_a_space_filling_curve() {
        // rays hitting a 2D grid in scrambled order: the order is a permutation, and successive
        // hits are close (a Morton curve's steps are mostly to a neighbour cell)
        let n = 64usize;
        let rays: Vec<PhotonRay> = (0..n * n)
            .map(|k| {
                let k = (k * 2671) % (n * n);
                let p = Vec3::new((k % n) as f32, (k / n) as f32, 0.0);
                PhotonRay::new(p + Vec3::Z, -Vec3::Z, 1.0, Vec3::ONE, -Vec3::Z, Vec3::Z)
            })
            .collect();
        let (a, b) = rays.split_at(1000);
        let classes: [&[PhotonRay]; 2] = [a, b];
        let order = morton_order(&classes);
        let mut seen = order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..(n * n) as u32).collect::<Vec<_>>());
        let hit = |i: u32| {
            let r = ray_at(&classes, i as usize);
            r.origin() + r.dir() * r.length
        };
        let steps: f32 = order.windows(2).map(|w| (hit(w[0]) - hit(w[1])).length()).sum();
        let mean_step = steps / (order.len() - 1) as f32;
        assert!(mean_step < 2.0, "mean step {mean_step} between successive hits");
        // emission order's mean step, for comparison, is ~n/2
        let scrambled: f32 = (0..order.len() as u32 - 1).map(|i| (hit(i) - hit(i + 1)).length()).sum::<f32>() / (order.len() - 1) as f32;
        assert!(scrambled > 10.0 * mean_step);
    }
}
