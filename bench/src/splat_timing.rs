//! The splatting paper's cost comparison (§9: "the ray splatting and search in a conical frustum is
//! approximately 1.5 to 2 times slower than for photon splatting in a spherical footprint with the
//! same precomputed radius"): whole splats, query plus feasibility tests, kernel and accumulation,
//! timed both ways on one tree of eye samples. For `raysplat-bench photons`.

use raysplat::kdtree::{is_front_facing, KdTree};
use raysplat::photon::PhotonRay;
use raysplat::splat::for_each_splat;
use glam::Vec3;
use std::f32::consts::PI;

/// Seconds and (eye sample, ray) pairs of [`time_ray_vs_spherical_splats`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SplatTiming {
    pub ray_seconds: f64,
    pub sphere_seconds: f64,
    pub ray_pairs: u64,
    pub sphere_pairs: u64,
}

/// What one splat adds at an eye sample, as `splat` accumulates it per pixel: radiance, kernel
/// weight, inverse distance and count.
#[derive(Clone, Copy, Default)]
struct Acc {
    radiance: Vec3,
    weight: f32,
    inv_dist: f32,
    count: u32,
}

/// Splats `rays` onto the eye samples `pts` / `nrm` of `tree`, single-threaded, twice:
/// - as ray splatting does (the cone query with its feasibility tests and Eq. 6's kernel), and
/// - as photon splatting in a spherical footprint: a ball of the ray's radius at the photon hit,
///   the front-facing test, the 2D Epanechnikov kernel of the distance to the hit;
///
/// with the same accumulation, and `clock` read around each. Rays need not reach the tree.
pub fn time_ray_vs_spherical_splats(tree: &KdTree, pts: &[Vec3], nrm: &[Vec3], rays: &[&PhotonRay], clock: &dyn Fn() -> f64) -> SplatTiming {
    let mut acc = vec![Acc::default(); pts.len()];
    let mut out = SplatTiming::default();
    let start = clock();
    for r in rays {
        let flux = r.flux();
        for_each_splat(r, tree, pts, nrm, |_, i, t, k, _, cos| {
            let a = &mut acc[i];
            a.radiance += flux * (k * cos);
            a.weight += k;
            a.inv_dist += 1.0 / t.max(1e-30);
            a.count += 1;
            out.ray_pairs += 1;
        });
    }
    out.ray_seconds = clock() - start;
    let start = clock();
    for r in rays {
        let (flux, dir) = (r.flux(), r.dir());
        let h = r.radius_at(r.length);
        if !(h > 0.0) {
            continue;
        }
        let (h2, inv_len) = (h * h, 1.0 / r.length.max(1e-30));
        tree.for_each_in_radius(r.origin() + dir * r.length, h, |i, d2| {
            let i = i as usize;
            let n = nrm[i];
            if !is_front_facing(n, dir) {
                return;
            }
            let k = (2.0 / PI) * (h2 - d2) / (h2 * h2);
            if !(k > 0.0) {
                return;
            }
            let a = &mut acc[i];
            a.radiance += flux * (k * -n.dot(dir));
            a.weight += k;
            a.inv_dist += inv_len;
            a.count += 1;
            out.sphere_pairs += 1;
        });
    }
    out.sphere_seconds = clock() - start;
    std::hint::black_box(&acc);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use raysplat::kdtree::BuildParams;

    /// Both ways splat a photon that hits a plane of eye samples, so their pair counts are the areas
    /// of their footprints on it: the same disc at normal incidence, and at 60° the ray's ellipse
    /// (1/cos θ = 2 times the disc) against the ball's disc — the figure the bench's note quotes.
    #[test]
    fn footprints_on_a_plane_are_the_disc_and_the_ellipse() {
        let mut pts = Vec::new();
        for i in 0..200 {
            for j in 0..200 {
                pts.push(Vec3::new(-1.0 + 0.01 * i as f32 + 0.003, -1.0 + 0.01 * j as f32 + 0.007, 0.0));
            }
        }
        let nrm = vec![Vec3::Z; pts.len()];
        let tree = KdTree::build_with_normals(&pts, &nrm, &BuildParams { empty_cut: raysplat::splat::EMPTY_CUT, ..BuildParams::default() }).unwrap();
        let pairs = |theta: f32| {
            let dir = Vec3::new(theta.sin(), 0.0, -theta.cos());
            let mut ray = PhotonRay::new(-dir, dir, 1.0, Vec3::ONE, dir, Vec3::Z);
            (ray.h0, ray.dh) = (0.1, 0.0);
            let t = time_ray_vs_spherical_splats(&tree, &pts, &nrm, &[&ray], &|| 0.0);
            (t.ray_pairs as f64, t.sphere_pairs as f64)
        };
        let (ray, ball) = pairs(0.0);
        // π · 0.1² / 0.01² ≈ 314 samples in the disc
        assert!((ball - 314.0).abs() < 25.0 && (ray / ball - 1.0).abs() < 0.05, "normal incidence: {ray} ray pairs, {ball} ball pairs");
        let (ray, ball) = pairs(60f32.to_radians());
        assert!((ball - 314.0).abs() < 25.0 && (ray / ball - 2.0).abs() < 0.1, "60°: {ray} ray pairs, {ball} ball pairs");
    }
}
