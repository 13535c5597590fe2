#![allow(clippy::needless_range_loop)]

use super::*;
use crate::sampling::Frame;
use glam::{Mat3, Vec3};

fn max_abs(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max)
}

#[test]
fn basis_is_orthonormal_by_numerical_integration() {
    // Gram matrix by a fine midpoint rule (independent of the exact quadrature below)
    let (nt, np) = (200, 400);
    let dw = 4.0 * std::f64::consts::PI / (nt * np) as f64;
    let mut g = [[0.0f64; N]; N];
    for i in 0..nt {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / nt as f64;
        let r = (1.0 - z * z).sqrt();
        for j in 0..np {
            let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / np as f64;
            let y = eval(Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32));
            for a in 0..N {
                for b in 0..N {
                    g[a][b] += y[a] as f64 * y[b] as f64 * dw;
                }
            }
        }
    }
    for a in 0..N {
        for b in 0..N {
            let want = if a == b { 1.0 } else { 0.0 };
            assert!((g[a][b] - want).abs() < 2e-3, "<Y{a}, Y{b}> = {}", g[a][b]);
        }
    }
}

#[test]
fn product_quadrature_is_exact_for_bands_0_to_3() {
    let q = quadrature();
    assert!((q.weights.iter().sum::<f32>() - 4.0 * std::f32::consts::PI).abs() < 1e-4);
    for a in 0..N {
        for b in 0..N {
            let s: f32 = q.dirs.iter().zip(q.weights).map(|(d, w)| eval(*d)[a] * eval(*d)[b] * w).sum();
            let want = if a == b { 1.0 } else { 0.0 };
            assert!((s - want).abs() < 1e-5, "quadrature <Y{a}, Y{b}> = {s}");
        }
    }
}

#[test]
fn clamped_cosine_projects_to_its_analytic_zonal_coefficients() {
    let c = project(|d| d.z.max(0.0), 400, 8);
    let zonal = clamped_cosine_zonal();
    for l in 0..BANDS {
        let k = zonal_index(l);
        assert!((c[k] - zonal[l]).abs() < 2e-3, "band {l}: projected {} vs analytic {}", c[k], zonal[l]);
    }
    // every non-zonal coefficient vanishes for a function symmetric about z
    for (k, v) in c.iter().enumerate() {
        if !(0..BANDS).any(|l| zonal_index(l) == k) {
            assert!(v.abs() < 1e-3, "coefficient {k} = {v}");
        }
    }
}

fn rotations() -> Vec<Mat3> {
    vec![
        Mat3::from_rotation_x(0.7),
        Mat3::from_rotation_y(-1.9),
        Mat3::from_rotation_z(2.4),
        Mat3::from_axis_angle(Vec3::new(0.3, -0.5, 0.8).normalize(), 1.234),
        Mat3::from_cols(Frame::from_normal(Vec3::new(-0.2, 0.9, 0.1).normalize()).s, Frame::from_normal(Vec3::new(-0.2, 0.9, 0.1).normalize()).t, Vec3::new(-0.2, 0.9, 0.1).normalize()),
    ]
}

#[test]
fn reconstruction_is_rotation_invariant() {
    // a band-limited function with all bands populated
    let c: [f32; N] = std::array::from_fn(|k| ((k as f32 * 1.37).sin() + 0.2) / (1.0 + k as f32 * 0.1));
    let probes: Vec<Vec3> = (0..50).map(|i| {
        let z = 1.0 - 2.0 * (i as f32 + 0.5) / 50.0;
        let phi = i as f32 * 2.399_963;
        let r = (1.0 - z * z).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }).collect();
    for rot in rotations() {
        let rc = rotate(&c, rot);
        for d in &probes {
            // rotated function at R·d equals the original at d
            let (a, b) = (reconstruct(&rc, rot * *d), reconstruct(&c, *d));
            assert!((a - b).abs() < 1e-4, "{a} vs {b}");
        }
        // rotation preserves the energy of every band
        for l in 0..BANDS {
            let r = l * l..(l + 1) * (l + 1);
            let e0: f32 = c[r.clone()].iter().map(|x| x * x).sum();
            let e1: f32 = rc[r].iter().map(|x| x * x).sum();
            assert!((e0 - e1).abs() < 1e-4 * (1.0 + e0), "band {l}: {e0} vs {e1}");
        }
        // and rotating by the inverse gives back the coefficients
        assert!(max_abs(&rotate(&rc, rot.transpose()), &c) < 1e-4);
    }
    // projection commutes with rotation for a function that is not band-limited
    let f = |d: Vec3| (3.0 * d.x - d.y * d.z + 0.5).max(0.0);
    for rot in rotations() {
        let direct = project(|d| f(rot.transpose() * d), 200, 400);
        let via = rotate(&project(f, 200, 400), rot);
        assert!(max_abs(&direct, &via) < 5e-3, "{direct:?} vs {via:?}");
    }
}
