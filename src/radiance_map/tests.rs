use super::histogram::*;
use crate::bsdf::Bsdf;
use crate::eye::GlossySample;
use crate::sampling::Frame;
use glam::Vec3;

fn fib(n: usize) -> impl Iterator<Item = Vec3> {
    (0..n).map(move |i| {
        let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
        let phi = i as f32 * 2.399_963_2 + 0.1;
        let r = (1.0 - z * z).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    })
}

#[test]
fn dodecahedron_is_regular() {
    let v = dodecahedron();
    // every vertex has exactly 3 nearest neighbours at the same angle (41.81°)
    for a in &v {
        let mut d: Vec<f32> = v.iter().filter(|b| *b != a).map(|b| a.dot(*b)).collect();
        d.sort_by(|x, y| y.total_cmp(x));
        assert!((d[0] - d[2]).abs() < 1e-5 && d[3] < d[0] - 0.1, "{d:?}");
        assert!((d[0].acos().to_degrees() - 41.81).abs() < 0.01);
    }
}

#[test]
fn strata_partition_the_sphere() {
    let s = Strata::get();
    let n = 200_000;
    let mut count = [0usize; STRATA];
    for d in fib(n) {
        // exactly one stratum: the nearest centre, strictly nearer than every other (ties have
        // measure zero)
        let k = s.stratum(d);
        let best = d.dot(s.centres[k]);
        assert_eq!(s.centres.iter().filter(|c| c.dot(d) >= best).count(), 1);
        count[k] += 1;
    }
    // solid angles: the 20 cells are congruent, so each covers 4π/20
    assert_eq!(count.iter().sum::<usize>(), n);
    for c in count {
        assert!((c as f64 / n as f64 - 0.05).abs() < 0.001, "{count:?}");
    }
    // the shortcut for strata entirely above or below a plane agrees with counting every direction
    for n in fib(40) {
        let brute: Vec<usize> = (0..STRATA).map(|k| fib(4096).filter(|d| s.stratum(*d) == k && d.dot(n) > 0.0).count()).collect();
        let fast = s.solid_angles_above(n);
        for k in 0..STRATA {
            let b = brute[k] as f32 * 4.0 * std::f32::consts::PI / 4096.0;
            assert!((fast[k] - b).abs() < 0.02, "stratum {k} above {n}: {} vs {b}", fast[k]);
        }
    }
    // the solid angles above any plane sum to 2π
    for n in [Vec3::Z, Vec3::new(0.3, -0.8, 0.2).normalize()] {
        let a: f32 = s.solid_angles_above(n).iter().sum();
        assert!((a - 2.0 * std::f32::consts::PI).abs() < 0.03, "{a}");
    }
}

#[test]
fn filter_weights_sum_to_one_and_favour_the_own_stratum() {
    let s = Strata::get();
    assert_eq!(s.filter.len(), RES * RES);
    for (c, w) in s.filter.iter().enumerate() {
        let sum: f32 = w.iter().map(|x| x.1).sum();
        assert!((sum - 1.0).abs() < 1e-5, "cell {c}: {sum}");
        assert!(w.iter().all(|x| x.1 >= 0.0));
        // the largest weight goes to the stratum containing the cell's centre
        assert_eq!(w[0].0 as usize, s.stratum(cell_centre(c)));
    }
    // a photon spreads over neighbouring strata, not only its own
    let w = s.weights(s.centres[0]);
    assert!(w[0].1 < 0.8 && w[1].1 > 0.05, "{w:?}");
}

#[test]
fn octahedral_cells_round_trip() {
    for c in 0..RES * RES {
        assert_eq!(cell(cell_centre(c)), c);
    }
    for d in fib(1000) {
        assert!(cell_centre(cell(d)).dot(d) > (0.15f32).cos(), "{d}");
    }
}

#[test]
fn histogram_integrates_uniform_light_on_lambert() {
    // uniform radiance L = 1 above the surface: strata sums h_s = ∫_{s, above} cos, and the
    // histogram must give ∫ ρ/π cos = ρ up to the BSDF sampling noise
    let s = Strata::get();
    let n = Vec3::new(0.1, 0.5, 0.8).normalize();
    let mut h = [Vec3::ZERO; STRATA];
    let m = 100_000;
    for d in fib(m) {
        let c = d.dot(n);
        if c > 0.0 {
            h[s.stratum(d)] += Vec3::splat(c * 4.0 * std::f32::consts::PI / m as f32);
        }
    }
    let g = GlossySample { bsdf: Bsdf::lambert(Vec3::new(0.8, 0.5, 0.2)).at(Vec3::new(0.2, 0.3, 0.9).normalize()), frame: Frame::from_normal(n) };
    let mut mean = Vec3::ZERO;
    for k in 0..50 {
        mean += s.integrate(&g.lobe(), &h, 8, k) / 50.0;
    }
    assert!((mean - Vec3::new(0.8, 0.5, 0.2)).abs().max_element() < 0.04, "{mean}");
}
