//! The footprint of one photon ray and its kernel weight at an eye sample (Eq. 6 with the
//! feasibility tests of §7.2 and the cut beyond the hit described in [`super`]). Shared by the
//! tile-parallel splatting of every eye sample and by the splatting onto sparse cache records.

use super::{misses_box, MAX_EXTENSION};
use crate::kdtree::{is_front_facing, Cone, KdTree};
use crate::photon::PhotonRay;
use glam::Vec3;
use std::f32::consts::PI;

/// What the kd-tree query of one photon ray needs: its cone (extended beyond the hit) and the
/// largest radius, for bounding-box rejection.
pub struct Footprint {
    pub cone: Cone,
    /// Largest splat radius along the cone.
    pub rmax: f32,
    pub dir: Vec3,
    length: f32,
    h_end: f32,
    hit: Vec3,
    n_hit: Vec3,
}

impl Footprint {
    /// `None` for a ray whose radius at the hit is not positive (it splats nothing).
    #[inline]
    pub fn of(r: &PhotonRay) -> Option<Footprint> {
        let dir = r.dir();
        let h_end = r.radius_at(r.length);
        if !(h_end > 0.0) {
            return None;
        }
        let n_hit = r.hit_normal();
        let ext = (h_end / n_hit.dot(dir).abs().max(1.0 / MAX_EXTENSION)).min(MAX_EXTENSION * h_end);
        let hit = r.origin() + dir * r.length;
        let cone = Cone::new(r.origin(), dir, r.length + ext, r.h0, r.dh);
        let rmax = cone.radius_at(cone.t_max).max(r.h0);
        Some(Footprint { cone, rmax, dir, length: r.length, h_end, hit, n_hit })
    }

    /// A box that holds the whole footprint (the segment `[0, t_max]` grown by `rmax`), padded
    /// well beyond float rounding: a tile whose points' box it misses gets nothing from the ray.
    #[inline]
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let (a, b) = (self.cone.origin, self.cone.origin + self.cone.dir * self.cone.t_max);
        let r = self.rmax + 1e-5 * (a.abs().max_element() + self.cone.t_max + self.rmax);
        (a.min(b) - Vec3::splat(r), a.max(b) + Vec3::splat(r))
    }

    /// The kernel of this footprint (decodes what only feasible rays need).
    #[inline]
    pub(crate) fn kernel<'a>(&'a self, r: &'a PhotonRay) -> Kernel<'a> {
        let origin = r.origin();
        // ε: the scale of float error at the origin (the spawn offset is 1e-5 of the scene size).
        let eps = 1e-5 * (origin.abs().max_element() + r.length);
        Kernel { fp: self, ray: r, origin, n_origin: r.origin_normal(), eps }
    }
}

/// Kernel weights of one photon ray at the eye samples its cone query finds.
pub(crate) struct Kernel<'a> {
    fp: &'a Footprint,
    ray: &'a PhotonRay,
    origin: Vec3,
    n_origin: Vec3,
    eps: f32,
}

impl Kernel<'_> {
    /// `(K_h(d), h)` for the eye sample at `p` with normal `n`, found by the cone query at
    /// parameter `t` and squared distance `d2` from the ray; `None` where the sample is infeasible
    /// or outside the kernel.
    #[inline(always)]
    pub fn weight(&self, p: Vec3, n: Vec3, t: f32, d2: f32) -> Option<(f32, f32)> {
        let (fp, origin) = (self.fp, self.origin);
        if !(t > 0.0) || (p - origin).dot(self.n_origin) <= self.eps || !is_front_facing(n, fp.dir) {
            return None;
        }
        let h = if t <= fp.length {
            // the ray's point of closest approach must lie on the eye sample's side of its surface:
            // a photon running just inside a zero-thickness wall, nearly parallel to it, must not
            // light the wall's outer face (tolerance: the direction's octahedral quantisation,
            // < 5e-5 rad, moves that point by up to 5e-5·t). Not applied beyond the hit: on convex
            // surfaces every eye sample near the hit lies below the hit point (it removed a third of
            // the light on the bumps of `bumpy-box`).
            if (origin + fp.dir * t - p).dot(n) < -(self.eps + 1e-4 * t) {
                return None;
            }
            self.ray.radius_at(t)
        } else {
            // beyond the hit: the cylinder of radius h_end, within the slab around the hit plane
            if d2 >= fp.h_end * fp.h_end || (p - fp.hit).dot(fp.n_hit).abs() >= fp.h_end {
                return None;
            }
            fp.h_end
        };
        // K_h(d) = 2/(πh²)·(1 − d²/h²) = (2/π)·(h² − d²)/h⁴, with one division
        let h2 = h * h;
        let k = (2.0 / PI) * (h2 - d2) / (h2 * h2);
        (k > 0.0).then_some((k, h))
    }
}

/// Every splat of photon ray `r` onto the eye samples of `tree` (built over `pts` with normals
/// `nrm`): `f(footprint, i, t, K_h, h, cos θ)` for each feasible sample `i` inside the kernel,
/// after the rejection of the whole tree by its bounding box.
#[inline]
pub fn for_each_splat(r: &PhotonRay, tree: &KdTree, pts: &[Vec3], nrm: &[Vec3], mut f: impl FnMut(&Footprint, usize, f32, f32, f32, f32)) {
    let Some(fp) = Footprint::of(r) else { return };
    let (lo, hi) = tree.bounds();
    if misses_box(&fp.cone, fp.rmax, lo, hi) {
        return;
    }
    let kernel = fp.kernel(r);
    tree.for_each_in_cone(&fp.cone, |i, t, d2| {
        let i = i as usize;
        let n = nrm[i];
        if let Some((k, h)) = kernel.weight(pts[i], n, t, d2) {
            f(&fp, i, t, k, h, -n.dot(fp.dir));
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{hash, Rng};
    use std::f32::consts::TAU;

    /// Every point inside a footprint's cone (the region the kd-tree query reports) lies inside the
    /// footprint's box, which lets a tile skip a ray whose box misses its eye samples' box: rays in
    /// all directions, with grazing hits (long extensions), far from the origin, and points sampled
    /// around the segment and its extension, many on the region's boundary.
    #[test]
    fn footprint_box_holds_the_cone() {
        let mut inside = 0;
        for i in 0..2000u64 {
            let mut r = Rng::new(hash(&[31, i]), 0);
            let mut f = || r.next_f32();
            let unit = |a: f32, b: f32| {
                let z = 2.0 * a - 1.0;
                let s = (1.0 - z * z).max(0.0).sqrt();
                Vec3::new(s * (TAU * b).cos(), s * (TAU * b).sin(), z)
            };
            let scale = [1.0, 100.0, 1e4][i as usize % 3];
            let origin = Vec3::new(f() - 0.5, f() - 0.5, f() - 0.5) * scale;
            let dir = unit(f(), f());
            let n_hit = unit(f(), f());
            let mut ray = PhotonRay::new(origin, dir, f() * 2.0, Vec3::ONE, -dir, n_hit);
            (ray.h0, ray.dh) = (0.001 + 0.05 * f(), [0.0, 0.02 * f(), -0.01 * f()][i as usize % 3]);
            let Some(fp) = Footprint::of(&ray) else { continue };
            let (lo, hi) = fp.bounds();
            for _ in 0..200 {
                let t = (f() * 1.2 - 0.1) * fp.cone.t_max;
                let off = unit(f(), f()) * fp.rmax * (0.9 + 0.2 * f());
                let p = fp.cone.origin + fp.cone.dir * t + off;
                if fp.cone.test(p).is_some() {
                    inside += 1;
                    assert!(p.cmpge(lo).all() && p.cmple(hi).all(), "ray {i}: {p} inside the cone, outside the box {lo} {hi}");
                }
            }
        }
        assert!(inside > 10_000, "only {inside} points fell inside the cones");
    }
}
