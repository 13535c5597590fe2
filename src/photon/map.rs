//! Classic photon maps (Jensen): photon hit points on non-specular surfaces in the shared kd-tree,
//! and the k-nearest-neighbour radiance estimate `L ≈ Σ f_s(ω_i) ΔΦ_i / (π r_k²)` over the photons
//! arriving from the front of the surface (photons from behind never contribute) and lying on a
//! surface facing the same way (Jensen's normal filter: keeps photons on one side of a thin wall,
//! or on a perpendicular wall at a corner, out of estimates on the other).

use super::PhotonRay;
use crate::kdtree::{BuildParams, KdTree, KnnHeap};
use glam::Vec3;

/// A photon map over the hit points of some photon rays.
pub struct PhotonMap {
    pub tree: KdTree,
    /// Photon positions (hit points).
    pub pos: Vec<Vec3>,
    /// Incoming direction (pointing away from the surface, toward where the photon came from).
    pub wi: Vec<Vec3>,
    /// Geometric normal at the photon, on the side it arrived from.
    pub n: Vec<Vec3>,
    pub flux: Vec<Vec3>,
}

impl PhotonMap {
    /// Build from the rays whose end lies on a surface with a non-specular lobe.
    pub fn build(rays: &[&[PhotonRay]], ends_diffuse: &[&[bool]]) -> crate::Result<PhotonMap> {
        let mut pts = Vec::new();
        let mut wi = Vec::new();
        let mut n = Vec::new();
        let mut flux = Vec::new();
        for (rs, ds) in rays.iter().zip(ends_diffuse) {
            for (r, &d) in rs.iter().zip(ds.iter()) {
                if d {
                    pts.push(r.end());
                    let (d, nh) = (r.dir(), r.hit_normal());
                    wi.push(-d);
                    n.push(if nh.dot(d) < 0.0 { nh } else { -nh });
                    flux.push(r.flux());
                }
            }
        }
        let tree = KdTree::build(&pts, &BuildParams::default())?;
        Ok(PhotonMap { tree, pos: pts, wi, n, flux })
    }

    pub fn len(&self) -> usize {
        self.flux.len()
    }

    pub fn is_empty(&self) -> bool {
        self.flux.is_empty()
    }

    pub fn bytes(&self) -> u64 {
        (self.tree.stats().memory_bytes + self.len() * 48) as u64
    }

    /// Radiance estimate at `p` with normal `n` (toward the viewer) from the `k` nearest photons
    /// within `max_radius`; `f(wi)` evaluates the BSDF. Returns (radiance, radius used, photons used).
    pub fn estimate(&self, p: Vec3, n: Vec3, k: usize, max_radius: f32, heap: &mut KnnHeap, f: impl Fn(Vec3) -> Vec3) -> (Vec3, f32, usize) {
        if self.is_empty() {
            return (Vec3::ZERO, 0.0, 0);
        }
        let r2 = self.tree.knn(p, k, max_radius, heap);
        if heap.is_empty() || !(r2 > 0.0) {
            return (Vec3::ZERO, 0.0, 0);
        }
        let mut sum = Vec3::ZERO;
        let mut used = 0;
        for nb in heap.as_slice() {
            let wi = self.wi[nb.index as usize];
            if wi.dot(n) <= 0.0 || self.n[nb.index as usize].dot(n) <= 1e-3 {
                continue;
            }
            sum += f(wi) * self.flux[nb.index as usize];
            used += 1;
        }
        (sum / (std::f32::consts::PI * r2), r2.sqrt(), used)
    }
}

/// Christensen's precomputed irradiance ("Faster photon map global illumination", 2000; the
/// strong-secondary-lighting paper §2): the irradiance estimate of a photon map at every `stride`-th
/// photon, looked up by nearest neighbour (with a compatible normal) at final-gather hits, so that a
/// gather ray costs one short k-NN search instead of a full density estimate.
pub struct IrradianceMap {
    pub tree: KdTree,
    pub n: Vec<Vec3>,
    /// Irradiance (W/m²) from the photons arriving on the front side.
    pub e: Vec<Vec3>,
}

/// Neighbours examined by [`IrradianceMap::lookup`] for one with a compatible normal.
const LOOKUP_K: usize = 4;

impl IrradianceMap {
    /// Precompute from `map` at every `stride`-th photon with `k` neighbours within `max_radius`.
    /// Deterministic: points are estimated in parallel and stored in photon order.
    pub fn build(map: &PhotonMap, stride: usize, k: usize, max_radius: f32) -> crate::Result<IrradianceMap> {
        use rayon::prelude::*;
        let idx: Vec<usize> = (0..map.len()).step_by(stride.max(1)).collect();
        let e: Vec<Vec3> = idx
            .par_chunks(1024)
            .flat_map_iter(|c| {
                let mut heap = KnnHeap::with_capacity(k);
                c.iter()
                    .map(|&i| map.estimate(map.pos[i], map.n[i], k, max_radius, &mut heap, |_| Vec3::ONE).0)
                    .collect::<Vec<_>>()
            })
            .collect();
        let pts: Vec<Vec3> = idx.iter().map(|&i| map.pos[i]).collect();
        let n: Vec<Vec3> = idx.iter().map(|&i| map.n[i]).collect();
        let tree = KdTree::build(&pts, &BuildParams::default())?;
        Ok(IrradianceMap { tree, n, e })
    }

    pub fn len(&self) -> usize {
        self.e.len()
    }

    pub fn is_empty(&self) -> bool {
        self.e.is_empty()
    }

    pub fn bytes(&self) -> u64 {
        (self.tree.stats().memory_bytes + self.len() * 24) as u64
    }

    /// Irradiance at the nearest precomputed point within `max_radius` whose normal faces the same
    /// way as `n` (zero when there is none).
    pub fn lookup(&self, p: Vec3, n: Vec3, max_radius: f32, heap: &mut KnnHeap) -> Vec3 {
        if self.is_empty() {
            return Vec3::ZERO;
        }
        self.tree.knn(p, LOOKUP_K, max_radius, heap);
        let mut best = (f32::INFINITY, Vec3::ZERO);
        for nb in heap.as_slice() {
            if nb.dist2 < best.0 && self.n[nb.index as usize].dot(n) > 0.5 {
                best = (nb.dist2, self.e[nb.index as usize]);
            }
        }
        best.1
    }
}
