//! Tests of the sampling module: PCG32 reference values, hashing, frames, warp densities
//! (chi-square against a histogram at fixed seeds) and tabulated distributions.

use super::chi2::{chi2_test, integrate_2d, sphere_chi2, SphereBins};
use super::rng::u32_to_unit_f32;
use super::*;
use glam::{Vec2, Vec3};
use std::collections::HashSet;

const P_MIN: f64 = 1e-3;

#[test]
fn pcg32_matches_reference_output() {
    // pcg32-global demo / rand_pcg `Lcg64Xsh32::new(42, 54)` reference sequence.
    let mut rng = Rng::new(42, 54);
    let expected = [0xa15c02b7u32, 0x7b47f409, 0xba1d3330, 0x83d2f293, 0xbfa4784b, 0xcbed606e];
    for e in expected {
        assert_eq!(rng.next_u32(), e);
    }
}

#[test]
fn rng_is_deterministic_and_streams_differ() {
    let draw = |seed, stream| {
        let mut r = Rng::new(seed, stream);
        (0..64).map(|_| r.next_u32()).collect::<Vec<_>>()
    };
    assert_eq!(draw(7, 3), draw(7, 3));
    for (a, b) in [(draw(7, 3), draw(7, 4)), (draw(7, 3), draw(8, 3)), (draw(0, 0), draw(0, 1))] {
        let same = a.iter().zip(&b).filter(|(x, y)| x == y).count();
        assert!(same <= 1, "{same} equal outputs of 64");
    }
    // Copies continue the same sequence independently.
    let mut a = Rng::new(1, 2);
    a.next_u32();
    let mut b = a;
    assert_eq!(a.next_u32(), b.next_u32());
}

#[test]
fn unit_floats_stay_below_one_and_are_uniform() {
    assert!(u32_to_unit_f32(u32::MAX) < 1.0);
    assert_eq!(u32_to_unit_f32(0), 0.0);
    let mut rng = Rng::new(3, 9);
    let n = 200_000;
    let mut counts = vec![0.0; 100];
    for _ in 0..n {
        let v = rng.next_2d();
        assert!((0.0..1.0).contains(&v.x) && (0.0..1.0).contains(&v.y));
        counts[(v.x * 100.0) as usize] += 1.0;
    }
    let r = chi2_test(&counts, &vec![n as f64 / 100.0; 100], n, 5.0);
    assert!(r.p_value > P_MIN, "{r:?}");
}

#[test]
fn hash_mixes_well_and_is_order_sensitive() {
    assert_eq!(hash(&[1, 2, 3]), hash(&[1, 2, 3]));
    assert_ne!(hash(&[1, 2]), hash(&[2, 1]));
    assert_ne!(hash(&[]), hash(&[0]));
    assert_ne!(hash(&[0]), hash(&[0, 0]));
    // No collisions over a (seed, pass, index) grid of small integers.
    let mut seen = HashSet::new();
    for s in 0..4u64 {
        for p in 0..64u64 {
            for i in 0..256u64 {
                assert!(seen.insert(hash(&[s, p, i])));
            }
        }
    }
    // Avalanche: flipping any input bit flips about half the output bits.
    let mut rng = Rng::new(11, 0);
    let (mut total, mut trials) = (0u64, 0u64);
    let mut worst = 0.0f64;
    for bit in 0..64 {
        let mut flips = 0u64;
        for _ in 0..64 {
            let v = [rng.next_u32() as u64 | ((rng.next_u32() as u64) << 32), rng.next_u32() as u64];
            let mut w = v;
            w[1] ^= 1 << bit;
            flips += (hash(&v) ^ hash(&w)).count_ones() as u64;
        }
        worst = worst.max((flips as f64 / 64.0 - 32.0).abs());
        total += flips;
        trials += 64;
    }
    let mean = total as f64 / trials as f64;
    assert!((mean - 32.0).abs() < 0.5, "mean flipped bits {mean}");
    assert!(worst < 3.0, "worst per-bit mean deviation {worst}");
}

#[test]
fn frames_are_orthonormal_and_right_handed() {
    let mut rng = Rng::new(5, 5);
    let mut normals = vec![
        Vec3::Z,
        -Vec3::Z,
        Vec3::X,
        -Vec3::Y,
        Vec3::new(1e-7, 0.0, -1.0).normalize(),
        Vec3::new(0.0, 1e-4, -1.0).normalize(),
    ];
    normals.extend((0..1000).map(|_| square_to_uniform_sphere(rng.next_2d())));
    for n in normals {
        let f = Frame::from_normal(n);
        for (a, b) in [(f.s, f.t), (f.s, f.n), (f.t, f.n)] {
            assert!(a.dot(b).abs() < 1e-5, "{n:?}: {f:?}");
        }
        for v in [f.s, f.t, f.n] {
            assert!((v.length() - 1.0).abs() < 1e-5, "{n:?}: {f:?}");
        }
        assert!(f.s.cross(f.t).distance(n) < 1e-5, "left-handed frame for {n:?}");
        let v = Vec3::new(0.3, -0.7, 0.2);
        assert!(f.to_world(f.to_local(v)).distance(v) < 1e-5);
        assert!(f.to_local(n).distance(Vec3::Z) < 1e-5);
    }
}

fn sphere_bins() -> SphereBins {
    SphereBins { n_cos: 20, n_phi: 20 }
}

fn assert_warp(name: &str, seed: u64, warp: impl Fn(Vec2) -> Vec3, pdf: impl Fn(Vec3) -> f32) {
    let r = sphere_chi2(sphere_bins(), 100_000, seed, |rng| Some(warp(rng.next_2d())), &pdf);
    assert!((r.integral - 1.0).abs() < 1e-3, "{name}: pdf integrates to {}", r.integral);
    assert!(r.p_value > P_MIN, "{name}: {r:?}");
}

#[test]
fn direction_warps_match_their_densities() {
    assert_warp("uniform sphere", 1, square_to_uniform_sphere, |_| UNIFORM_SPHERE_PDF);
    let hemi = |w: Vec3| if w.z >= 0.0 { UNIFORM_HEMISPHERE_PDF } else { 0.0 };
    assert_warp("uniform hemisphere", 2, square_to_uniform_hemisphere, hemi);
    assert_warp("cosine hemisphere", 3, square_to_cosine_hemisphere, |w| cosine_hemisphere_pdf(w.z));
    for (i, cos_max) in [0.95f32, 0.3, -0.5].into_iter().enumerate() {
        let pdf = move |w: Vec3| if w.z >= cos_max { uniform_cone_pdf(cos_max) } else { 0.0 };
        assert_warp("cone", 4 + i as u64, move |u| square_to_uniform_cone(u, cos_max), pdf);
    }
}

#[test]
fn direction_warps_detect_a_wrong_density() {
    // The test must be able to fail: cosine samples are not uniform on the hemisphere.
    let hemi = |w: Vec3| if w.z >= 0.0 { UNIFORM_HEMISPHERE_PDF } else { 0.0 };
    let r = sphere_chi2(sphere_bins(), 100_000, 9, |rng| Some(square_to_cosine_hemisphere(rng.next_2d())), &hemi);
    assert!(r.p_value < 1e-10, "{r:?}");
}

#[test]
fn warps_stay_in_their_domains() {
    let mut rng = Rng::new(8, 8);
    for _ in 0..10_000 {
        let u = rng.next_2d();
        assert!(square_to_uniform_disk_concentric(u).length() <= 1.0 + 1e-6);
        assert!((square_to_cosine_hemisphere(u).length() - 1.0).abs() < 1e-5);
        assert!(square_to_cosine_hemisphere(u).z >= 0.0);
        assert!(square_to_uniform_cone(u, 0.99).z >= 0.99 - 1e-6);
        let (b1, b2) = square_to_uniform_triangle(u);
        assert!(b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 + 1e-6);
    }
    assert_eq!(square_to_uniform_disk_concentric(Vec2::splat(0.5)), Vec2::ZERO);
    assert_eq!(uniform_cone_pdf(1.0), f32::INFINITY);
    assert!((uniform_cone_pdf(-1.0) - UNIFORM_SPHERE_PDF).abs() < 1e-7);
    assert_eq!(cosine_hemisphere_pdf(-0.5), 0.0);
}

/// Histogram of 2D points over `res × res` cells of `[x0, x1]²` against a density integrated per cell.
fn planar_chi2(
    res: usize,
    [x0, x1]: [f64; 2],
    seed: u64,
    sample: impl Fn(Vec2) -> Vec2,
    pdf: impl Fn(f64, f64) -> f64,
) -> super::chi2::Chi2 {
    let n = 100_000;
    let mut rng = Rng::new(seed, 1);
    let mut observed = vec![0.0; res * res];
    let cell = |v: f64| (((v - x0) / (x1 - x0) * res as f64) as usize).min(res - 1);
    for _ in 0..n {
        let p = sample(rng.next_2d());
        observed[cell(p.y as f64) * res + cell(p.x as f64)] += 1.0;
    }
    let h = (x1 - x0) / res as f64;
    let expected: Vec<f64> = (0..res * res)
        .map(|i| {
            let (cx, cy) = ((i % res) as f64, (i / res) as f64);
            let xs = [x0 + cx * h, x0 + (cx + 1.0) * h];
            let ys = [x0 + cy * h, x0 + (cy + 1.0) * h];
            n as f64 * integrate_2d(&mut |x, y| pdf(x, y), xs, ys, 1e-9)
        })
        .collect();
    chi2_test(&observed, &expected, n, 5.0)
}

#[test]
fn disk_and_triangle_warps_are_uniform() {
    let disk = |x: f64, y: f64| if x * x + y * y <= 1.0 { std::f64::consts::FRAC_1_PI } else { 0.0 };
    let r = planar_chi2(16, [-1.0, 1.0], 21, square_to_uniform_disk_concentric, disk);
    assert!((r.integral - 1.0).abs() < 2e-3 && r.p_value > P_MIN, "disk: {r:?}");
    // Barycentrics (b1, b2) are uniform over the half square b1 + b2 ≤ 1 with density 2.
    let tri = |x: f64, y: f64| if x + y <= 1.0 { 2.0 } else { 0.0 };
    let r = planar_chi2(16, [0.0, 1.0], 22, |u| Vec2::from(square_to_uniform_triangle(u)), tri);
    assert!((r.integral - 1.0).abs() < 2e-3 && r.p_value > P_MIN, "triangle: {r:?}");
}

#[test]
fn power_heuristic_values() {
    assert_eq!(power_heuristic(1.0, 1.0, 1.0, 1.0), 0.5);
    assert!((power_heuristic(1.0, 3.0, 1.0, 1.0) - 0.9).abs() < 1e-6);
    assert!((power_heuristic(1.0, 3.0, 1.0, 1.0) + power_heuristic(1.0, 1.0, 1.0, 3.0) - 1.0).abs() < 1e-6);
    assert_eq!(power_heuristic(1.0, 0.0, 1.0, 0.0), 0.0);
    assert_eq!(power_heuristic(1.0, 0.0, 1.0, 2.0), 0.0);
    assert_eq!(power_heuristic(1.0, f32::INFINITY, 1.0, 2.0), 1.0);
    assert_eq!(power_heuristic(1.0, 1e30, 1.0, 1.0), 1.0);
}

#[test]
fn distribution1d_sampling_matches_pmf() {
    let weights = [1.0, 0.0, 3.0, 0.5, 0.0, 2.5, 7.0, 0.0];
    let d = Distribution1D::new(&weights);
    assert_eq!(d.len(), 8);
    assert_eq!(d.total(), 14.0);
    let n = 100_000;
    let mut rng = Rng::new(31, 0);
    let mut observed = vec![0.0; weights.len()];
    let mut remapped = vec![0.0; 10];
    for _ in 0..n {
        let (i, pmf, u2) = d.sample_discrete(rng.next_f32()).unwrap();
        assert!(weights[i] > 0.0, "sampled zero-weight entry {i}");
        assert_eq!(pmf, d.pmf(i));
        assert!((0.0..1.0).contains(&u2));
        observed[i] += 1.0;
        remapped[(u2 * 10.0) as usize] += 1.0;
    }
    let expected: Vec<f64> = (0..weights.len()).map(|i| d.pmf(i) as f64 * n as f64).collect();
    let r = chi2_test(&observed, &expected, n, 5.0);
    assert!((r.integral - 1.0).abs() < 1e-6 && r.p_value > P_MIN, "{r:?}");
    let r = chi2_test(&remapped, &[n as f64 / 10.0; 10], n, 5.0);
    assert!(r.p_value > P_MIN, "remapped u not uniform: {r:?}");
    assert_eq!(d.pmf(100), 0.0);
    // Extreme u: the last nonzero entry, and never a zero-weight one.
    assert_eq!(d.sample_discrete(1.0 - f32::EPSILON / 2.0).unwrap().0, 6);
    assert_eq!(d.sample_discrete(1.0).unwrap().0, 6);
    assert_eq!(d.sample_discrete(0.0).unwrap().0, 0);
    assert_eq!(d.sample_discrete(f32::NAN).unwrap().0, 0);
}

#[test]
fn distribution1d_continuous_density_matches_histogram() {
    let d = Distribution1D::new(&[0.2, 1.0, 0.0, 4.0, 2.0]);
    let (n, res) = (100_000, 40);
    let mut rng = Rng::new(32, 0);
    let mut observed = vec![0.0; res];
    for _ in 0..n {
        let (x, pdf, i) = d.sample_continuous(rng.next_f32());
        assert!((0.0..1.0).contains(&x));
        assert_eq!(i, (x * 5.0) as usize);
        assert!((pdf - 5.0 * d.pmf(i)).abs() < 1e-6);
        observed[(x * res as f32) as usize] += 1.0;
    }
    // Each histogram cell lies inside one step of width 1/5: probability pdf · (1/res).
    let expected: Vec<f64> = (0..res).map(|c| n as f64 * 5.0 * d.pmf(c * 5 / res) as f64 / res as f64).collect();
    let r = chi2_test(&observed, &expected, n, 5.0);
    assert!((r.integral - 1.0).abs() < 1e-6 && r.p_value > P_MIN, "{r:?}");
}

#[test]
fn distribution1d_edge_cases() {
    let empty = Distribution1D::new(&[]);
    assert!(empty.is_empty() && empty.sample_discrete(0.3).is_none());
    assert_eq!(empty.sample_continuous(0.3).1, 0.0);
    assert_eq!(empty.total(), 0.0);

    let single = Distribution1D::new(&[2.0]);
    assert_eq!(single.sample_discrete(0.37), Some((0, 1.0, 0.37)));
    let (x, pdf, i) = single.sample_continuous(0.37);
    assert_eq!((x, pdf, i), (0.37, 1.0, 0));

    let zeros = Distribution1D::new(&[0.0, 0.0, 0.0, 0.0]);
    assert_eq!(zeros.total(), 0.0);
    assert_eq!(zeros.pmf(2), 0.25);
    assert_eq!(zeros.sample_discrete(0.6).unwrap().0, 2);

    let dirty = Distribution1D::new(&[-1.0, f32::NAN, 1.0, f32::INFINITY]);
    assert_eq!((dirty.pmf(0), dirty.pmf(1), dirty.pmf(2), dirty.pmf(3)), (0.0, 0.0, 1.0, 0.0));
    assert_eq!(dirty.total(), 1.0);

    // Precision with many entries: pmfs sum to 1 and the last entry stays reachable.
    let many: Vec<f32> = (0..1_000_000).map(|i| 1.0 + (i % 7) as f32).collect();
    let d = Distribution1D::new(&many);
    let sum: f64 = (0..d.len()).map(|i| d.pmf(i) as f64).sum();
    assert!((sum - 1.0).abs() < 1e-5);
    assert_eq!(d.sample_discrete(1.0 - f32::EPSILON / 2.0).unwrap().0 / 1000, 999);
}

#[test]
fn distribution2d_sampling_matches_pdf() {
    let (w, h) = (8, 5);
    let weights: Vec<f32> = (0..w * h).map(|i| if i % 11 == 3 { 0.0 } else { 1.0 + ((i * 37) % 13) as f32 }).collect();
    let d = Distribution2D::new(&weights, w, h);
    assert_eq!(d.resolution(), (8, 5));
    let n = 100_000;
    let mut rng = Rng::new(33, 0);
    let mut observed = vec![0.0; w * h];
    for _ in 0..n {
        let (uv, pdf) = d.sample(rng.next_2d());
        assert!((0.0..1.0).contains(&uv.x) && (0.0..1.0).contains(&uv.y));
        assert!((pdf - d.pdf(uv)).abs() <= 1e-5 * pdf, "{pdf} vs {}", d.pdf(uv));
        let cell = (uv.y * h as f32) as usize * w + (uv.x * w as f32) as usize;
        assert!(weights[cell] > 0.0);
        observed[cell] += 1.0;
    }
    // The pdf is constant per cell (area 1/(w h)) and proportional to the weights.
    let total: f32 = weights.iter().sum();
    let expected: Vec<f64> = (0..w * h)
        .map(|i| {
            let uv = Vec2::new(((i % w) as f32 + 0.5) / w as f32, ((i / w) as f32 + 0.5) / h as f32);
            let p = d.pdf(uv) as f64 / (w * h) as f64;
            assert!((p - (weights[i] / total) as f64).abs() < 1e-6);
            p * n as f64
        })
        .collect();
    let r = chi2_test(&observed, &expected, n, 5.0);
    assert!((r.integral - 1.0).abs() < 1e-5 && r.p_value > P_MIN, "{r:?}");
}

#[test]
fn distribution2d_edge_cases() {
    let zeros = Distribution2D::new(&[0.0; 6], 3, 2);
    let (uv, pdf) = zeros.sample(Vec2::new(0.5, 0.7));
    assert!((pdf - 1.0).abs() < 1e-6 && (zeros.pdf(uv) - 1.0).abs() < 1e-6);
    let single = Distribution2D::new(&[5.0], 1, 1);
    let (uv, pdf) = single.sample(Vec2::new(0.25, 0.75));
    assert_eq!((uv, pdf), (Vec2::new(0.25, 0.75), 1.0));
    // A zero row is never sampled and has zero density.
    let d = Distribution2D::new(&[1.0, 1.0, 0.0, 0.0, 1.0, 3.0], 2, 3);
    assert_eq!(d.pdf(Vec2::new(0.2, 0.5)), 0.0);
    assert!((d.pdf(Vec2::new(0.9, 0.9)) - 3.0 / 6.0 * 6.0).abs() < 1e-5);
    assert!(d.pdf(Vec2::new(f32::NAN, 2.0)).is_finite());
    let mut rng = Rng::new(4, 4);
    for _ in 0..1000 {
        let (uv, _) = d.sample(rng.next_2d());
        assert!(!(1.0 / 3.0..2.0 / 3.0).contains(&uv.y));
    }
}
