//! The cost of the cone-frustum query against a spherical one on the same kd-tree (the splatting
//! paper §9 compares ray splatting with photon splatting in a ball), for `raysplat-bench photons`.

use glam::Vec3;
use raysplat::kdtree::{Cone, KdTree};

/// How [`time_cone_vs_sphere_with`] sizes the spherical query that each cone is compared with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SphereMatch {
    /// A ball of the cone region's volume (frustum plus cap) at the photon hit.
    EqualVolume,
    /// A ball of radius `h(t_max)` at the photon hit: photon splatting "in a spherical footprint
    /// with the same precomputed radius", the comparison of the splatting paper §9 (1.5–2× there).
    SameRadiusAtHit,
}

/// Timings of [`time_cone_vs_sphere_with`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ConeSphereTiming {
    /// Seconds for all cone queries.
    pub cone_seconds: f64,
    /// Seconds for all sphere queries.
    pub sphere_seconds: f64,
    /// Points found by the cone queries.
    pub cone_found: u64,
    /// Points found by the sphere queries.
    pub sphere_found: u64,
}

/// Times [`KdTree::for_each_in_cone`] for every cone against [`KdTree::for_each_in_radius`] for a
/// matching ball (see [`SphereMatch`]) on the same tree, single-threaded, with the seconds read from
/// `clock` (e.g. the thread's CPU time, which a machine shared with other jobs does not inflate the
/// way it inflates wall-clock time); the callbacks do minimal work (a sum). Prints nothing.
pub fn time_cone_vs_sphere_with(tree: &KdTree, cones: &[Cone], sphere: SphereMatch, clock: &dyn Fn() -> f64) -> ConeSphereTiming {
    let balls: Vec<(Vec3, f32)> = cones
        .iter()
        .map(|c| match sphere {
            SphereMatch::SameRadiusAtHit => (c.hit_point(), c.radius_at(c.t_max).max(0.0)),
            SphereMatch::EqualVolume => {
                let (a, b) = (c.h0.max(0.0), c.radius_at(c.t_max).max(0.0));
                let mut v = std::f32::consts::PI / 3.0 * c.t_max.max(0.0) * (a * a + a * b + b * b);
                if c.hemisphere_cap {
                    v += 2.0 / 3.0 * std::f32::consts::PI * b * b * b;
                }
                (c.hit_point(), (v * 3.0 / (4.0 * std::f32::consts::PI)).cbrt())
            }
        })
        .collect();

    let mut sum = 0.0f32;
    let mut cone_found = 0u64;
    let start = clock();
    for c in cones {
        tree.for_each_in_cone(c, |_, t, d2| {
            sum += t + d2;
            cone_found += 1;
        });
    }
    let cone_seconds = clock() - start;
    let mut sphere_found = 0u64;
    let start = clock();
    for &(c, r) in &balls {
        tree.for_each_in_radius(c, r, |_, d2| {
            sum += d2;
            sphere_found += 1;
        });
    }
    let sphere_seconds = clock() - start;
    std::hint::black_box(sum);
    ConeSphereTiming { cone_seconds, sphere_seconds, cone_found, sphere_found }
}

#[cfg(test)]
mod tests {
    use super::*;
    use raysplat::kdtree::BuildParams;

    /// The timed queries find what a brute-force scan finds: every point the cone's own test
    /// accepts, and every point inside the matching ball (of radius h at the hit, or of the cone's
    /// volume), on a jittered plane of points crossed by cones at several angles.
    #[test]
    fn timed_queries_find_the_points_a_scan_finds() {
        let mut pts = Vec::new();
        for i in 0..120 {
            for j in 0..120 {
                let jitter = ((i * 7 + j * 13) % 11) as f32 * 0.0007;
                pts.push(Vec3::new(-0.6 + 0.01 * i as f32 + jitter, -0.6 + 0.01 * j as f32 + 0.5 * jitter, 0.002 * jitter));
            }
        }
        let nrm = vec![Vec3::Z; pts.len()];
        let tree = KdTree::build_with_normals(&pts, &nrm, &BuildParams::default()).unwrap();
        let cones: Vec<Cone> = [0.0f32, 25.0, 50.0, 70.0]
            .iter()
            .enumerate()
            .map(|(k, deg)| {
                let th = deg.to_radians();
                let dir = Vec3::new(th.sin(), 0.0, -th.cos());
                let hit = Vec3::new(0.1 * k as f32 - 0.15, 0.05 * k as f32, 0.0);
                Cone::new(hit - 2.0 * dir, dir, 2.0, 0.04, 0.01).with_hemisphere_cap(k % 2 == 0)
            })
            .collect();
        for how in [SphereMatch::EqualVolume, SphereMatch::SameRadiusAtHit] {
            let t = time_cone_vs_sphere_with(&tree, &cones, how, &|| 0.0);
            let in_cone: u64 = cones.iter().map(|c| pts.iter().filter(|&&p| c.test(p).is_some()).count() as u64).sum();
            assert_eq!(t.cone_found, in_cone, "{how:?}");
            let in_ball: u64 = cones
                .iter()
                .map(|c| {
                    let r = match how {
                        SphereMatch::SameRadiusAtHit => c.radius_at(c.t_max).max(0.0),
                        SphereMatch::EqualVolume => {
                            let (a, b) = (c.h0.max(0.0), c.radius_at(c.t_max).max(0.0));
                            let mut v = std::f32::consts::PI / 3.0 * c.t_max.max(0.0) * (a * a + a * b + b * b);
                            if c.hemisphere_cap {
                                v += 2.0 / 3.0 * std::f32::consts::PI * b * b * b;
                            }
                            (v * 3.0 / (4.0 * std::f32::consts::PI)).cbrt()
                        }
                    };
                    pts.iter().filter(|&&p| (p - c.hit_point()).length_squared() <= r * r).count() as u64
                })
                .sum();
            assert_eq!(t.sphere_found, in_ball, "{how:?}");
            assert!(t.cone_found > 0 && t.sphere_found > 0);
        }
    }
}
