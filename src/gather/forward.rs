//! Normal photon mapping with final gathering (the baseline, Jensen): for every gather hit, a search
//! in the global photon map and the radiance estimate of Eq. 2 with a box kernel,
//! `L_i = Σ_p ΔΦ_p / (π R_i²)` over the photons accepted by the photon filter (the Lambertian BSDF at
//! the hit is in the reverse photon's weight). `R_i` is the distance of the k-th neighbour (kNN) or
//! the fixed gather radius.

use super::reverse::ReversePhoton;
use super::Kernel;
use crate::kdtree::KnnHeap;
use crate::photon::PhotonMap;
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::PI;

/// Gather hits per parallel work item (fixed: results do not depend on the thread count).
const CHUNK: usize = 4096;

/// Radiance along every gather ray (one entry per reverse photon) and the photons used in total.
pub fn estimate(map: &PhotonMap, a_r: &[ReversePhoton], kernel: Kernel) -> (Vec<Vec3>, u64) {
    let parts: Vec<(Vec<Vec3>, u64)> = a_r
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut heap = KnnHeap::with_capacity(match kernel {
                Kernel::Knn { k, .. } => k,
                _ => 0,
            });
            let mut found = 0u64;
            let out = chunk
                .iter()
                .map(|rp| {
                    let (p, n) = (rp.pos(), rp.normal());
                    match kernel {
                        Kernel::Knn { k, max_radius } => {
                            let (l, _, used) = map.estimate(p, n, k, max_radius, &mut heap, |_| Vec3::ONE);
                            found += used as u64;
                            l
                        }
                        Kernel::Fixed(r) => {
                            let mut sum = Vec3::ZERO;
                            map.tree.for_each_in_radius(p, r, |i, _| {
                                let i = i as usize;
                                if ReversePhoton::accepts(n, map.wi[i], map.n[i]) {
                                    sum += map.flux[i] * (1.0 / (PI * r * r));
                                    found += 1;
                                }
                            });
                            sum
                        }
                        Kernel::Adaptive { .. } => unreachable!("adaptive radius is a reverse photon mapping kernel"),
                    }
                })
                .collect();
            (out, found)
        })
        .collect();
    let mut found = 0;
    let mut out = Vec::with_capacity(a_r.len());
    for (v, f) in parts {
        out.extend_from_slice(&v);
        found += f;
    }
    (out, found)
}

/// The search alone (no density estimation), for the search-time comparison of `raysplat-bench fg`:
/// returns the number of photons found (kNN: the neighbours; fixed radius: the pairs the photon
/// filter accepts, the same pairs and count as `rpm::search_only` with that radius).
pub fn search_only(map: &PhotonMap, a_r: &[ReversePhoton], kernel: Kernel) -> u64 {
    a_r.par_chunks(CHUNK)
        .map(|chunk| {
            let mut heap = KnnHeap::with_capacity(64);
            let mut found = 0u64;
            for rp in chunk {
                match kernel {
                    Kernel::Knn { k, max_radius } => {
                        map.tree.knn(rp.pos(), k, max_radius, &mut heap);
                        found += heap.len() as u64;
                    }
                    Kernel::Fixed(r) => {
                        let n = rp.normal();
                        map.tree.for_each_in_radius(rp.pos(), r, |i, _| {
                            found += ReversePhoton::accepts(n, map.wi[i as usize], map.n[i as usize]) as u64;
                        })
                    }
                    Kernel::Adaptive { .. } => {}
                }
            }
            found
        })
        .sum()
}
