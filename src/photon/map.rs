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
        Ok(PhotonMap { tree, wi, n, flux })
    }

    pub fn len(&self) -> usize {
        self.flux.len()
    }

    pub fn is_empty(&self) -> bool {
        self.flux.is_empty()
    }

    pub fn bytes(&self) -> u64 {
        (self.tree.stats().memory_bytes + self.len() * 36) as u64
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
