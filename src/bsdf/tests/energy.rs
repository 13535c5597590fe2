//! Energy: white furnace tests, the analytic GGX albedo, the albedo tables, the smooth limit.

use super::*;
use crate::sampling::chi2::integrate_2d;

const FURNACE_THETAS: [f32; 7] = [0.0, 30.0, 60.0, 80.0, 89.0, 120.0, 175.0];

#[test]
fn white_furnace_exact_for_lossless_bsdfs() {
    let cases = [
        ("lambert", Bsdf::lambert(Vec3::ONE)),
        ("mirror", Bsdf::mirror(Vec3::ONE)),
        ("glass", Bsdf::dielectric(1.5, Vec3::ONE)),
        ("clear blend", preview(|p| (p.opacity, p.ior) = (0.0, 1.33))),
    ];
    for (name, b) in cases {
        for (k, theta) in FURNACE_THETAS.into_iter().enumerate() {
            let wo = dir(theta, 0.7);
            for (mode, undo) in [(RADIANCE, true), (IMPORTANCE, false)] {
                let (e, _) = albedo_mc(&b, wo, 20_000, k as u64, mode, undo);
                assert!((e - Vec3::ONE).abs().max_element() < 1e-4, "{name} θ = {theta}: {e}");
            }
        }
    }
    // Without the eta² correction, radiance through glass entering from air is compressed.
    let (e, _) = albedo_mc(&Bsdf::dielectric(1.5, Vec3::ONE), Vec3::Z, 20_000, 3, RADIANCE, false);
    assert!((e.x - (0.04 + 0.96 / 2.25)).abs() < 5e-3, "{e}");
}

#[test]
fn white_furnace_preview_surface() {
    let white = Vec3::ONE;
    // (name, bsdf, expected albedo when exactly energy-preserving, else None for "≤ 1")
    let cases: Vec<(&str, Bsdf, Option<f32>)> = vec![
        ("white plastic r=0.5", preview(|p| (p.diffuse, p.roughness) = (white, 0.5)), Some(1.0)),
        ("white plastic r=1", preview(|p| (p.diffuse, p.roughness) = (white, 1.0)), Some(1.0)),
        ("white plastic r=0.05", preview(|p| (p.diffuse, p.roughness) = (white, 0.05)), Some(1.0)),
        ("smooth white plastic", preview(|p| (p.diffuse, p.roughness) = (white, 0.0)), Some(1.0)),
        ("white metal r=0.3", preview(|p| (p.diffuse, p.metallic, p.roughness) = (white, 1.0, 0.3)), Some(1.0)),
        ("white metal r=1", preview(|p| (p.diffuse, p.metallic, p.roughness) = (white, 1.0, 1.0)), Some(1.0)),
        ("half metal r=0.7", preview(|p| (p.diffuse, p.metallic, p.roughness) = (white, 0.5, 0.7)), None),
        (
            "gold r=0.6",
            preview(|p| (p.diffuse, p.metallic, p.roughness) = (Vec3::new(1.0, 0.78, 0.34), 1.0, 0.6)),
            None,
        ),
        (
            "specular workflow F0=1",
            preview(|p| (p.use_specular_workflow, p.specular, p.diffuse) = (true, white, white)),
            Some(1.0),
        ),
        (
            "specular workflow F0=.3",
            preview(|p| {
                (p.use_specular_workflow, p.specular, p.diffuse, p.roughness) = (true, Vec3::splat(0.3), white, 0.2)
            }),
            Some(1.0),
        ),
        (
            "specular workflow black diffuse",
            preview(|p| {
                (p.use_specular_workflow, p.specular, p.diffuse, p.roughness) =
                    (true, Vec3::splat(0.3), Vec3::ZERO, 0.8)
            }),
            None,
        ),
        ("coat over plastic", preview(|p| (p.diffuse, p.clearcoat, p.clearcoat_roughness) = (white, 1.0, 0.3)), None),
        (
            "coat over smooth metal",
            preview(|p| {
                (p.diffuse, p.metallic, p.roughness, p.clearcoat, p.clearcoat_roughness) = (white, 1.0, 0.0, 1.0, 0.0)
            }),
            None,
        ),
        ("blend", preview(|p| (p.diffuse, p.opacity, p.roughness) = (white, 0.4, 0.3)), Some(1.0)),
        ("ior 1, coat", preview(|p| (p.diffuse, p.ior, p.clearcoat) = (white, 1.0, 1.0)), None),
    ];
    for (name, b, exact) in cases {
        for (k, theta) in FURNACE_THETAS.into_iter().enumerate() {
            let (e, se) = albedo_mc(&b, dir(theta, 0.4), 40_000, k as u64 + 100, RADIANCE, true);
            let e = e.max_element();
            assert!(e <= 1.0 + 4.0 * se + 3e-3, "{name} θ = {theta}: albedo {e} ± {se}");
            if let Some(x) = exact {
                assert!((e - x).abs() <= 4.0 * se + 5e-3, "{name} θ = {theta}: albedo {e} ± {se}, expected {x}");
            }
        }
    }
}

#[test]
fn ggx_single_scattering_matches_analytic_albedo() {
    // For α = 1 and normal incidence, D is the cosine distribution and θi = 2θh, so the
    // single-scattering albedo with F = 1 is ∫₀^{π/4} 2 tan θ cos 2θ dθ = 1 − ln 2.
    let expected = 1.0 - std::f32::consts::LN_2;
    let lobe = lobe::SpecLobe::new(Vec3::ONE, Vec3::ONE, 1.0, false);
    let mut rng = Rng::new(4, 4);
    let n = 200_000;
    let sum: f32 = (0..n)
        .map(|_| {
            let wi = lobe.sample_ss(Vec3::Z, rng.next_2d());
            if wi.z <= 0.0 {
                0.0
            } else {
                lobe.eval_ss(Vec3::Z, wi).x * wi.z / lobe.pdf_ss(Vec3::Z, wi)
            }
        })
        .sum();
    assert!((sum / n as f32 - expected).abs() < 2e-3, "{} vs {expected}", sum / n as f32);
    let [a, b] = albedo_table().lookup(1.0, albedo::AlbedoTable::coordinate(1.0));
    assert!((a + b - expected).abs() < 2e-3, "table {} vs {expected}", a + b);
    // The compensated lobe of a white metal conserves energy there.
    let ms = lobe::SpecLobe::new(Vec3::ONE, Vec3::ONE, 1.0, true);
    assert!((ms.albedo(ms.ab(1.0)).x - 1.0).abs() < 2e-3 && (ms.average_albedo().x - 1.0).abs() < 2e-3);
}

#[test]
fn eval_integral_matches_sampled_albedo() {
    // ∫ eval·cos by plain quadrature (independent of sample/pdf) against the importance-sampled estimate.
    for (name, b) in rough_cases().into_iter().filter(|(n, _)| !n.contains("r=0.1")) {
        let wo = dir(35.0, 0.2);
        let mut f = |z: f64, phi: f64| {
            let r = (1.0 - z * z).max(0.0).sqrt();
            let wi = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
            (b.eval(wo, wi, RADIANCE).x * wi.z) as f64
        };
        let quad = integrate_2d(&mut f, [0.0, 1.0], [0.0, std::f64::consts::TAU], 1e-6) as f32;
        let mut rng = Rng::new(9, 9);
        let n = 100_000;
        let mc: f32 = (0..n)
            .filter_map(|_| b.sample(wo, rng.next_f32(), rng.next_2d(), RADIANCE))
            .filter(|s| !s.is_specular())
            .map(|s| s.weight().x)
            .sum::<f32>()
            / n as f32;
        assert!((quad - mc).abs() < 0.01 * quad.max(0.05), "{name}: quadrature {quad} vs sampled {mc}");
    }
}

#[test]
fn rough_specular_approaches_mirror() {
    let wo = dir(60.0, 0.0);
    let base = |r: f32| preview(|p| (p.diffuse, p.metallic, p.roughness) = (Vec3::new(0.9, 0.6, 0.3), 1.0, r));
    let (mirror, _) = albedo_mc(&base(0.0), wo, 1000, 1, RADIANCE, false);
    let exact = fresnel::schlick(Vec3::new(0.9, 0.6, 0.3), Vec3::new(0.9, 0.6, 0.3), wo.z);
    assert!(close3(mirror, exact, 1e-5), "{mirror} vs {exact}");
    let mut last_gap = f32::INFINITY;
    let mut last_spread = f32::INFINITY;
    for r in [0.3, 0.1, 0.05, 0.02] {
        let b = base(r);
        let (e, se) = albedo_mc(&b, wo, 40_000, 2, RADIANCE, false);
        let gap = (e - mirror).abs().max_element();
        let mut rng = Rng::new(3, 3);
        let spread = (0..2000)
            .filter_map(|_| b.sample(wo, rng.next_f32(), rng.next_2d(), RADIANCE))
            .map(|s| s.wi.dot(Vec3::new(-wo.x, -wo.y, wo.z)).clamp(-1.0, 1.0).acos())
            .sum::<f32>()
            / 2000.0;
        assert!(gap < last_gap + 3.0 * se && spread < last_spread, "r = {r}: gap {gap}, spread {spread}");
        (last_gap, last_spread) = (gap, spread);
    }
    assert!(last_gap < 0.01 && last_spread < 0.01, "gap {last_gap}, spread {last_spread}");
}

#[test]
fn albedo_table_matches_direct_integration() {
    for (mu, r) in [(0.9f32, 0.2f32), (0.37, 0.45), (0.12, 0.8), (0.6, 1.0), (0.05, 0.6)] {
        let ggx = microfacet::Ggx { alpha: r * r };
        let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let integrand = |c: usize| {
            move |z: f64, phi: f64| {
                let s = (1.0 - z * z).max(0.0).sqrt();
                let wi = Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, z as f32);
                let Some(h) = microfacet::half_vector(wo, wi) else { return 0.0 };
                let sw = fresnel::schlick_weight(wo.dot(h));
                let fr = if c == 0 { 1.0 - sw } else { sw };
                (fr * ggx.reflection_eval(wo, wi, h) * wi.z) as f64
            }
        };
        let [a, b] = albedo_table().lookup(mu, albedo::AlbedoTable::coordinate(r * r));
        let qa = integrate_2d(&mut integrand(0), [1e-6, 1.0], [0.0, std::f64::consts::TAU], 1e-7) as f32;
        let qb = integrate_2d(&mut integrand(1), [1e-6, 1.0], [0.0, std::f64::consts::TAU], 1e-7) as f32;
        assert!((a - qa).abs() < 3e-3 && (b - qb).abs() < 3e-3, "μ = {mu}, r = {r}: table ({a}, {b}) vs ({qa}, {qb})");
    }
    // The smoothest column approaches the exact Schlick integrals (A, B) = (1 − (1−μ)⁵, (1−μ)⁵).
    for mu in [0.2f32, 0.5, 0.9] {
        let [a, b] = albedo_table().lookup(mu, 0.0);
        let s = fresnel::schlick_weight(mu);
        assert!((a - (1.0 - s)).abs() < 2e-3 && (b - s).abs() < 2e-3, "μ = {mu}: ({a}, {b})");
    }
    let [a, b] = albedo_table().average(0.0);
    assert!((a - 20.0 / 21.0).abs() < 3e-3 && (b - 1.0 / 21.0).abs() < 3e-3, "({a}, {b})");
}
