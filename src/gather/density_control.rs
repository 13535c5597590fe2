//! Density control (`reverse-photon-mapping.md` §6.2, after Suykens & Willems 2000): thin the
//! photon map where it is denser than a user threshold (photons per m²), keeping its energy.
//!
//! The paper's iterative algorithm: photons are picked in random order; around each, the density
//! is estimated by a kNN search among the photons still valid; above the threshold, the photon's
//! energy is distributed to its neighbours "with similar normal and incoming direction" and the
//! photon is invalidated for the following searches. Here:
//!
//! - *similar*: a valid photon other than itself whose normal is within ~25° (`n·n' ≥ 0.9`) and
//!   whose incoming direction lies on the same side of the photon's surface (`ω'·n > 0`);
//! - *density*: `m / (π R²)` over the [`K`] nearest similar photons within `max_radius` — `m` of
//!   them found, `R` the distance of the `K`-th (or `max_radius` when fewer were found);
//! - *distribution*: the flux is split equally among those `m` neighbours (total flux is kept
//!   exactly, up to rounding);
//! - *order*: a permutation drawn from the seed (the result is deterministic and single-threaded:
//!   each decision depends on the earlier ones).
//!
//! What it guarantees: total flux is conserved; no photon is touched where the density is already
//! below the threshold; and afterwards every surviving photon's density among the survivors is at
//! most the threshold (when a photon was checked its density was ≤ D, and each later removal can
//! only lower it: the similar set shrinks, so `m` drops or `R` grows).

use crate::error::{Error, Result};
use crate::kdtree::{BuildParams, KdTree, KnnHeap};
use crate::photon::PhotonMap;
use crate::sampling::{hash, Rng};
use glam::Vec3;
use std::f32::consts::PI;

/// Neighbours of the density estimate.
pub const K: usize = 16;
/// Minimum cosine between the normals of similar photons.
pub const SIMILAR_NORMAL: f32 = 0.9;
const STREAM: u64 = 0x4445_4e53; // "DENS"

/// Is photon `j` similar to photon `i` (for density and energy distribution)?
#[inline]
pub fn similar(map: &PhotonMap, i: usize, j: usize) -> bool {
    i != j && map.n[i].dot(map.n[j]) >= SIMILAR_NORMAL && map.wi[j].dot(map.n[i]) > 0.0
}

/// What density control did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DensityStats {
    pub before: usize,
    pub after: usize,
}

/// Thin `map` to at most `limit` photons per m² (see the module notes); returns the new map.
pub fn control(map: &PhotonMap, limit: f32, max_radius: f32, seed: u64) -> Result<(PhotonMap, DensityStats)> {
    if !(limit.is_finite() && limit > 0.0) {
        return Err(Error::param("density-limit", format!("{limit} must be a positive number of photons per m²")));
    }
    let n = map.len();
    let mut valid = vec![true; n];
    let mut flux = map.flux.clone();
    let mut order: Vec<u32> = (0..n as u32).collect();
    let mut rng = Rng::new(hash(&[seed, STREAM]), 0);
    for i in (1..n).rev() {
        let j = ((rng.next_u32() as u64 * (i as u64 + 1)) >> 32) as usize;
        order.swap(i, j);
    }
    let mut heap = KnnHeap::with_capacity(K);
    for &i in &order {
        let i = i as usize;
        let r2 = map.tree.knn_filtered(map.pos[i], K, max_radius, &mut heap, |j| valid[j as usize] && similar(map, i, j as usize));
        let m = heap.len();
        if m == 0 || !(r2 > 0.0) || (m as f32) / (PI * r2) <= limit {
            continue;
        }
        let share = flux[i] / m as f32;
        for nb in heap.as_slice() {
            flux[nb.index as usize] += share;
        }
        flux[i] = Vec3::ZERO;
        valid[i] = false;
    }
    let keep: Vec<usize> = (0..n).filter(|&i| valid[i]).collect();
    let pos: Vec<Vec3> = keep.iter().map(|&i| map.pos[i]).collect();
    let tree = KdTree::build(&pos, &BuildParams::default())?;
    let out = PhotonMap {
        tree,
        pos,
        wi: keep.iter().map(|&i| map.wi[i]).collect(),
        n: keep.iter().map(|&i| map.n[i]).collect(),
        flux: keep.iter().map(|&i| flux[i]).collect(),
    };
    Ok((out, DensityStats { before: n, after: keep.len() }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::PhotonRay;
    use proptest::prelude::*;

    /// Photons on two perpendicular planes (a corner), denser near the origin.
    fn corner_map(pts: &[(bool, f32, f32, f32)]) -> PhotonMap {
        let rays: Vec<PhotonRay> = pts
            .iter()
            .map(|&(wall, u, v, f)| {
                let (u, v) = (u * u, v); // crowd toward u = 0
                let (end, n) = if wall { (Vec3::new(0.0, u, v), Vec3::X) } else { (Vec3::new(u, 0.0, v), Vec3::Y) };
                let dir = -(n + Vec3::new(0.2, 0.1, 0.3 * v)).normalize();
                PhotonRay::new(end - dir, dir, 1.0, Vec3::new(f, 1.0, 0.5), n, -n)
            })
            .collect();
        PhotonMap::build(&[&rays], &[&vec![true; rays.len()]]).unwrap()
    }

    /// Brute force: density of photon `i` of `map` among the similar others.
    fn density(map: &PhotonMap, i: usize, max_radius: f32) -> f32 {
        let mut d2: Vec<f32> = (0..map.len()).filter(|&j| similar(map, i, j)).map(|j| (map.pos[j] - map.pos[i]).length_squared()).filter(|&d| d <= max_radius * max_radius).collect();
        d2.sort_by(f32::total_cmp);
        let m = d2.len().min(K);
        if m == 0 {
            return 0.0;
        }
        let r2 = if m == K { d2[K - 1] } else { max_radius * max_radius };
        m as f32 / (PI * r2)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        #[test]
        fn survivors_are_below_the_limit_and_flux_is_conserved(
            pts in prop::collection::vec((any::<bool>(), 0f32..1.0, 0f32..1.0, 0.1f32..2.0), 20..600),
            limit in 100f32..5000.0,
        ) {
            let map = corner_map(&pts);
            let max_r = 0.5;
            let (out, st) = control(&map, limit, max_r, 9).unwrap();
            prop_assert_eq!(st.after, out.len());
            let total = |m: &PhotonMap| m.flux.iter().fold(glam::DVec3::ZERO, |a, f| a + f.as_dvec3());
            let (a, b) = (total(&map), total(&out));
            prop_assert!((a - b).abs().max_element() <= 1e-5 * a.max_element(), "flux {} → {}", a, b);
            for i in 0..out.len() {
                let d = density(&out, i, max_r);
                prop_assert!(d <= limit * (1.0 + 1e-4), "survivor {} at density {} > {}", i, d, limit);
            }
            // A photon at or below the limit in the original map is never removed (its density
            // can only have dropped by the time it is checked).
            let kept: std::collections::HashSet<[u32; 3]> = out.pos.iter().map(|p| p.to_array().map(f32::to_bits)).collect();
            for i in 0..map.len() {
                if density(&map, i, max_r) <= limit * (1.0 - 1e-4) {
                    prop_assert!(kept.contains(&map.pos[i].to_array().map(f32::to_bits)), "sparse photon {} removed", i);
                }
            }
        }
    }

    #[test]
    fn a_dense_map_is_thinned_and_a_bad_limit_is_an_error() {
        let pts: Vec<_> = (0..2000).map(|i| (i % 2 == 0, (i as f32 * 0.618).fract(), (i as f32 * 0.414).fract(), 1.0)).collect();
        let map = corner_map(&pts);
        let (out, st) = control(&map, 500.0, 0.5, 1).unwrap();
        assert!(st.after < st.before / 2, "{st:?}");
        assert_eq!(out.len(), st.after);
        assert!(control(&map, 0.0, 0.5, 1).is_err());
        assert!(control(&map, f32::NAN, 0.5, 1).is_err());
    }
}
