//! BSDF tests: sampling against the pdf (chi-square, Mitsuba-style), sample/eval/pdf consistency,
//! reciprocity, flags and robustness here; energy conservation in `energy`, delta lobes, Fresnel
//! and the PreviewSurface workflows in `specular`.

use super::albedo::albedo_table;
use super::*;
use super::{albedo, fresnel, lobe, microfacet};
use crate::sampling::chi2::{sphere_chi2, SphereBins};
use crate::sampling::{square_to_uniform_sphere, Rng};

mod energy;
mod specular;

const RADIANCE: TransportMode = TransportMode::Radiance;
const IMPORTANCE: TransportMode = TransportMode::Importance;

/// UsdPreviewSurface defaults (spec) with overrides applied by `f`.
fn preview(f: impl FnOnce(&mut SurfaceParams)) -> Bsdf {
    let mut p = SurfaceParams::default();
    f(&mut p);
    Bsdf::from_preview_surface(&p)
}

/// Direction at polar angle `theta_deg` (may exceed 90°) and azimuth `phi`.
fn dir(theta_deg: f32, phi: f32) -> Vec3 {
    let (st, ct) = theta_deg.to_radians().sin_cos();
    Vec3::new(st * phi.cos(), st * phi.sin(), ct)
}

fn close(a: f32, b: f32, rel: f32) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()) + 1e-6
}

fn close3(a: Vec3, b: Vec3, rel: f32) -> bool {
    (0..3).all(|i| close(a[i], b[i], rel))
}

/// Non-delta test cases (name, bsdf).
fn rough_cases() -> Vec<(&'static str, Bsdf)> {
    let metal = |r: f32| preview(|p| (p.diffuse, p.metallic, p.roughness) = (Vec3::new(0.9, 0.6, 0.3), 1.0, r));
    vec![
        ("lambert", Bsdf::lambert(Vec3::new(0.7, 0.5, 0.3))),
        ("rough dielectric", preview(|p| (p.diffuse, p.roughness) = (Vec3::new(0.8, 0.4, 0.2), 0.5))),
        ("metal r=0.1", metal(0.1)),
        ("metal r=0.5", metal(0.5)),
        ("metal r=1", metal(1.0)),
        (
            "specular workflow",
            preview(|p| {
                (p.use_specular_workflow, p.specular, p.diffuse, p.roughness) =
                    (true, Vec3::new(0.9, 0.5, 0.2), Vec3::new(0.2, 0.4, 0.6), 0.3)
            }),
        ),
        (
            "clearcoat",
            preview(|p| (p.metallic, p.roughness, p.clearcoat, p.clearcoat_roughness) = (0.5, 0.6, 1.0, 0.2)),
        ),
        ("transmissive blend", preview(|p| (p.diffuse, p.roughness, p.opacity) = (Vec3::splat(0.6), 0.4, 0.5))),
        (
            "tinted specular, tinted transmission",
            preview(|p| {
                (p.diffuse, p.roughness, p.specular_tint, p.opacity, p.transmission_color) =
                    (Vec3::new(0.2, 0.5, 0.7), 0.35, Vec3::new(0.4, 0.7, 1.0), 0.6, Vec3::new(0.9, 0.5, 0.2))
            }),
        ),
        (
            "smooth specular + diffuse",
            preview(|p| {
                (p.diffuse, p.roughness, p.clearcoat, p.clearcoat_roughness) = (Vec3::splat(0.5), 0.0, 0.7, 0.3)
            }),
        ),
    ]
}

const CHI2_WO: [(f32, f32); 4] = [(10.0, 0.3), (50.0, 2.0), (80.0, -1.0), (125.0, 1.0)];

/// Chi-square test of the non-delta samples against `pdf`, checking on the way that each sample's
/// `f` and `pdf` equal `eval` and `pdf`.
fn check_sampling(name: &str, bsdf: &Bsdf, seed: u64) {
    for (k, &(theta, phi)) in CHI2_WO.iter().enumerate() {
        let wo = dir(theta, phi);
        let sample = |rng: &mut Rng| {
            let s = bsdf.sample(wo, rng.next_f32(), rng.next_2d(), RADIANCE)?;
            if s.is_specular() {
                return None;
            }
            assert!(s.wi.z * wo.z > 0.0 && (s.wi.length() - 1.0).abs() < 1e-4, "{name}: {s:?}");
            assert!(
                close3(s.f, bsdf.eval(wo, s.wi, RADIANCE), 1e-4),
                "{name}: f {s:?} vs eval {}",
                bsdf.eval(wo, s.wi, RADIANCE)
            );
            assert!(close(s.pdf, bsdf.pdf(wo, s.wi), 1e-4), "{name}: pdf {} vs {}", s.pdf, bsdf.pdf(wo, s.wi));
            Some(s.wi)
        };
        let pdf = |wi: Vec3| bsdf.pdf(wo, wi);
        let r = sphere_chi2(SphereBins { n_cos: 20, n_phi: 20 }, 100_000, seed * 10 + k as u64, sample, &pdf);
        assert!(r.p_value > 1e-3, "{name}, θo = {theta}: {r:?}");
        assert!(r.integral <= 1.0 + 1e-3, "{name}, θo = {theta}: pdf integrates to {}", r.integral);
        if name == "lambert" {
            assert!((r.integral - 1.0).abs() < 1e-3, "{r:?}");
        }
    }
}

#[test]
fn sampling_matches_pdf_lambert_dielectric_metal() {
    for (i, (name, b)) in rough_cases().into_iter().enumerate().take(5) {
        check_sampling(name, &b, i as u64 + 1);
    }
}

#[test]
fn sampling_matches_pdf_workflows_coat_blend() {
    for (i, (name, b)) in rough_cases().into_iter().enumerate().skip(5) {
        check_sampling(name, &b, i as u64 + 1);
    }
}

#[test]
fn chi2_rejects_a_wrong_pdf() {
    // The sampling test must be able to fail: a rough metal sampled against a slightly too wide lobe.
    let b = preview(|p| (p.metallic, p.roughness) = (1.0, 0.5));
    let wider = preview(|p| (p.metallic, p.roughness) = (1.0, 0.55));
    let wo = dir(40.0, 0.0);
    let sample = |rng: &mut Rng| b.sample(wo, rng.next_f32(), rng.next_2d(), RADIANCE).map(|s| s.wi);
    let r = sphere_chi2(SphereBins { n_cos: 20, n_phi: 20 }, 100_000, 7, sample, &|wi| wider.pdf(wo, wi));
    assert!(r.p_value < 1e-6, "{r:?}");
}

/// Monte Carlo estimate of `∫ f |cos θi| dωi` by the BSDF's own sampling (all lobes), with
/// refraction weights multiplied by `eta²` when `undo_eta2` (radiance compression is not loss).
/// Returns the mean and its standard error (largest channel).
fn albedo_mc(bsdf: &Bsdf, wo: Vec3, n: usize, seed: u64, mode: TransportMode, undo_eta2: bool) -> (Vec3, f32) {
    let mut rng = Rng::new(seed, 77);
    let (mut sum, mut sum2) = (Vec3::ZERO, Vec3::ZERO);
    for _ in 0..n {
        if let Some(s) = bsdf.sample(wo, rng.next_f32(), rng.next_2d(), mode) {
            let mut w = s.weight();
            if undo_eta2 && s.flags.contains(BsdfFlags::TRANSMISSION) {
                w *= s.eta * s.eta;
            }
            assert!(w.is_finite() && w.min_element() >= 0.0, "{s:?}");
            sum += w;
            sum2 += w * w;
        }
    }
    let mean = sum / n as f32;
    let var = (sum2 / n as f32 - mean * mean).max(Vec3::ZERO);
    (mean, (var / n as f32).max_element().sqrt())
}

#[test]
fn reflection_is_reciprocal_and_two_sided() {
    let mut rng = Rng::new(12, 0);
    for (name, b) in rough_cases() {
        for _ in 0..2000 {
            let wo = square_to_uniform_sphere(rng.next_2d());
            let mut wi = square_to_uniform_sphere(rng.next_2d());
            wi.z = wi.z.copysign(wo.z);
            let (f1, f2) = (b.eval(wo, wi, RADIANCE), b.eval(wi, wo, RADIANCE));
            assert!(close3(f1, f2, 2e-4), "{name}: {wo} {wi}: {f1} vs {f2}");
            let flip = |v: Vec3| Vec3::new(v.x, v.y, -v.z);
            assert!(close3(f1, b.eval(flip(wo), flip(wi), RADIANCE), 1e-6), "{name}: not two-sided");
            assert_eq!(b.eval(wo, flip(wi), RADIANCE), Vec3::ZERO, "{name}: opaque lobes leak through");
            assert_eq!(b.pdf(wo, flip(wi)), 0.0);
        }
    }
}

#[test]
fn preview_flags() {
    let f = |b: Bsdf| b.flags();
    use BsdfFlags as F;
    assert_eq!(f(Bsdf::lambert(Vec3::ONE)), F::DIFFUSE | F::REFLECTION);
    assert!(f(Bsdf::lambert(Vec3::ZERO)).is_empty());
    assert_eq!(f(preview(|_| ())), F::DIFFUSE | F::GLOSSY | F::REFLECTION);
    assert_eq!(f(preview(|p| p.metallic = 1.0)), F::GLOSSY | F::REFLECTION);
    assert_eq!(f(preview(|p| p.roughness = 0.0)), F::DIFFUSE | F::SPECULAR | F::REFLECTION);
    assert_eq!(
        f(preview(|p| (p.roughness, p.clearcoat) = (0.0, 0.5))),
        F::DIFFUSE | F::SPECULAR | F::GLOSSY | F::REFLECTION
    );
    assert_eq!(f(preview(|p| p.opacity = 0.0)), F::SPECULAR | F::REFLECTION | F::TRANSMISSION);
    assert!(f(preview(|p| p.opacity = 0.5)).contains(F::DIFFUSE | F::GLOSSY | F::SPECULAR | F::TRANSMISSION));
    assert!(f(preview(|p| (p.metallic, p.diffuse) = (1.0, Vec3::ZERO))).is_empty());
    assert!(
        F::DIFFUSE.is_diffuse()
            && F::GLOSSY.is_glossy()
            && F::SPECULAR.is_specular()
            && (F::DIFFUSE | F::GLOSSY).is_non_specular()
    );
    assert!(
        (F::REFLECTION | F::SPECULAR).intersects(F::SPECULAR) && !(F::REFLECTION).contains(F::REFLECTION | F::SPECULAR)
    );
    assert_eq!((F::DIFFUSE | F::REFLECTION) & F::REFLECTION, F::REFLECTION);
    assert!(std::mem::size_of::<Bsdf>() <= 96, "Bsdf is {} bytes", std::mem::size_of::<Bsdf>());
}

#[test]
fn degenerate_inputs_stay_finite() {
    let mut cases = rough_cases();
    cases.push((
        "nan params",
        preview(|p| (p.roughness, p.metallic, p.ior, p.opacity) = (f32::NAN, f32::NAN, f32::NAN, f32::NAN)),
    ));
    cases.push((
        "huge params",
        preview(|p| (p.diffuse, p.roughness, p.ior, p.clearcoat) = (Vec3::splat(5.0), 7.0, 1e9, 3.0)),
    ));
    cases.push(("ior 0", preview(|p| (p.ior, p.opacity) = (0.0, 0.5))));
    cases.push(("glass", Bsdf::dielectric(-1.0, Vec3::ONE)));
    let dirs = [
        Vec3::Z,
        -Vec3::Z,
        Vec3::X,
        Vec3::new(1.0, 0.0, 1e-7).normalize(),
        Vec3::new(0.0, 1.0, -1e-7).normalize(),
        dir(89.99, 0.1),
    ];
    for (name, b) in &cases {
        for &wo in &dirs {
            for &wi in &dirs {
                assert!(b.eval(wo, wi, RADIANCE).is_finite() && b.pdf(wo, wi).is_finite(), "{name}: {wo} {wi}");
            }
            for uc in [0.0, 0.3, 0.999_999] {
                for u in [Vec2::ZERO, Vec2::splat(0.5), Vec2::splat(0.999_999)] {
                    if let Some(s) = b.sample(wo, uc, u, IMPORTANCE) {
                        assert!(
                            s.f.is_finite() && s.pdf.is_finite() && s.pdf > 0.0 && s.wi.is_finite(),
                            "{name}: {wo}: {s:?}"
                        );
                    }
                }
            }
        }
    }
}

/// The hot-path forms (per-`wo` context, fused eval + pdf with one division each) give the
/// reference formulas' values up to float rounding, and `BsdfAt` gives the plain calls' results
/// bit for bit.
#[test]
fn fused_evaluations_match_reference() {
    let mut rng = Rng::new(11, 0);
    for r in [0.0f32, 0.05, 0.3, 0.7, 1.0] {
        for ms in [false, true] {
            let lobe = lobe::SpecLobe::new(Vec3::new(0.9, 0.5, 0.1), Vec3::new(1.0, 0.8, 0.6), r, ms);
            for _ in 0..2000 {
                let mut wo = square_to_uniform_sphere(rng.next_2d());
                let mut wi = square_to_uniform_sphere(rng.next_2d());
                (wo.z, wi.z) = (wo.z.abs(), wi.z.abs());
                let lo = lobe.lambda(wo);
                let (f, pdf) = lobe.eval_pdf_ss(wo, wi, lo);
                assert!(close3(f, lobe.eval_ss(wo, wi), 2e-5), "r {r}: {wo} {wi}: {f} vs {}", lobe.eval_ss(wo, wi));
                assert!(close(pdf, lobe.pdf_ss(wo, wi), 2e-5), "r {r}: {wo} {wi}: {pdf} vs {}", lobe.pdf_ss(wo, wi));
                assert_eq!(f, lobe.eval_ss_with(wo, wi, lo));
                assert_eq!(pdf.to_bits(), lobe.pdf_ss_with(wo, wi, lo).to_bits());
                let (ab_o, ab_i) = (lobe.ab(wo.z), lobe.ab(wi.z));
                assert_eq!(lobe.eval_ms(ab_o, ab_i), lobe.eval_ms_with(lobe.ms_factor(ab_o), ab_i));
            }
        }
    }
    for (name, b) in rough_cases() {
        for _ in 0..500 {
            let wo = square_to_uniform_sphere(rng.next_2d());
            let wi = square_to_uniform_sphere(rng.next_2d());
            let at = b.at(wo);
            let (f, pdf) = at.eval_pdf(wi, RADIANCE);
            assert_eq!(f, b.eval(wo, wi, RADIANCE), "{name}");
            assert_eq!(f, at.eval(wi), "{name}");
            assert_eq!(pdf.to_bits(), b.pdf(wo, wi).to_bits(), "{name}");
            let (uc, u) = (rng.next_f32(), rng.next_2d());
            let (s1, s2) = (at.sample(uc, u, RADIANCE), b.sample(wo, uc, u, RADIANCE));
            assert_eq!(s1.map(|s| (s.wi, s.f, s.pdf.to_bits())), s2.map(|s| (s.wi, s.f, s.pdf.to_bits())), "{name}");
            if let Some(s) = s1 {
                if !s.is_specular() {
                    assert_eq!(s.pdf.to_bits(), b.pdf(wo, s.wi).to_bits(), "{name}");
                    assert_eq!(s.f, b.eval(wo, s.wi, RADIANCE), "{name}");
                }
            }
        }
    }
}

#[test]
fn preview_is_affine_in_its_diffuse_factor() {
    // f = f₀ + kd ⊙ (f₁ − f₀) for every rough case, including clearcoat and partial opacity
    for (name, b) in rough_cases() {
        let Some((kd, b0, b1)) = b.diffuse_split() else { continue };
        for (to, po, ti, pi) in [(10.0, 0.3, 40.0, 2.0), (60.0, 1.0, 20.0, 4.0), (85.0, 0.0, 70.0, 3.1)] {
            let (wo, wi) = (dir(to, po), dir(ti, pi));
            let f = b.eval(wo, wi, TransportMode::Radiance);
            let (f0, f1) = (b0.eval(wo, wi, TransportMode::Radiance), b1.eval(wo, wi, TransportMode::Radiance));
            let g = f0 + kd * (f1 - f0);
            assert!((f - g).abs().max_element() <= 1e-5 * (1.0 + f.abs().max_element()), "{name}: {f} vs {g}");
        }
    }
}

/// `PreviewBsdf::with_diffuse` on a BSDF of another diffuse colour equals `PreviewBsdf::new`, bit for
/// bit, in the specular workflow and with metallic 0 (what `PreparedScene::bsdf` relies on for
/// materials whose only texture is the diffuse colour).
#[test]
fn with_diffuse_equals_new() {
    let mut rng = Rng::new(17, 0);
    for case in 0..2000 {
        let mut v = || rng.next_f32() * 1.4 - 0.2;
        let p = SurfaceParams {
            diffuse: Vec3::new(v(), v(), v()),
            specular: Vec3::new(v(), v(), v()),
            use_specular_workflow: case % 2 == 0,
            metallic: 0.0,
            roughness: if case % 7 == 0 { 0.0 } else { v() },
            clearcoat: if case % 3 == 0 { v() } else { 0.0 },
            clearcoat_roughness: v(),
            opacity: if case % 5 == 0 { v() } else { 1.0 },
            specular_tint: if case % 4 == 0 { Vec3::new(v(), v(), v()) } else { Vec3::ONE },
            transmission_color: if case % 6 == 0 { Vec3::new(v(), v(), v()) } else { Vec3::ONE },
            ior: 1.0 + 2.0 * rng.next_f32(),
        };
        let other = PreviewBsdf::new(&SurfaceParams { diffuse: Vec3::new(0.3, 0.9, 0.1), ..p });
        assert_eq!(other.with_diffuse(p.diffuse), PreviewBsdf::new(&p), "case {case}: {p:?}");
    }
}

#[test]
fn memoised_table_lookups_give_the_plain_evaluation() {
    // the splat's series: one incident direction on many samples (repeated μ, materials and
    // views interleaved, as on neighbouring surfaces), then the next direction; every value is
    // the plain evaluation's, bit for bit, and the memo is actually reused
    let mut rng = Rng::new(12, 0);
    let cases = rough_cases();
    let mut memo = AbMemo::default();
    let (mut calls, mut hits) = (0, 0);
    for _ in 0..300 {
        let wi = square_to_uniform_sphere(rng.next_2d());
        for _ in 0..20 {
            let (_, b) = &cases[1 + (rng.next_f32() * 1.999) as usize]; // two rough preview materials
            let at = b.at(square_to_uniform_sphere(rng.next_2d()));
            let before = memo;
            assert_eq!(at.eval_memo(wi, &mut memo), at.eval(wi));
            calls += 1;
            hits += (format!("{before:?}") == format!("{memo:?}")) as usize;
        }
    }
    assert!(hits > calls / 4, "memo reused in only {hits} of {calls} evaluations");
}

/// `same_but_diffuse` is the equality of the BSDFs with their diffuse factor zeroed, for pairs
/// that differ in the diffuse colour alone and pairs that differ in any other input.
#[test]
fn same_but_diffuse_ignores_only_the_diffuse_layer() {
    let as_preview = |b: Bsdf| match b {
        Bsdf::Preview(p) => p,
        _ => unreachable!("a PreviewSurface"),
    };
    let base = |p: &mut SurfaceParams| {
        p.clearcoat = 0.3;
        p.opacity = 0.8;
    };
    let a = as_preview(preview(base));
    let variants: Vec<(bool, PreviewBsdf)> = vec![
        (true, as_preview(preview(|p| { base(p); p.diffuse = Vec3::new(0.1, 0.9, 0.3) }))),
        (false, as_preview(preview(|p| { base(p); p.roughness = 0.31 }))),
        (false, as_preview(preview(|p| { base(p); p.metallic = 0.2 }))),
        (false, as_preview(preview(|p| { base(p); p.clearcoat = 0.4 }))),
        (false, as_preview(preview(|p| { base(p); p.clearcoat_roughness = 0.2 }))),
        (false, as_preview(preview(|p| { base(p); p.opacity = 0.7 }))),
        (false, as_preview(preview(|p| { base(p); p.ior = 1.4 }))),
    ];
    for (i, (same, b)) in variants.iter().enumerate() {
        assert_eq!(a.same_but_diffuse(b), *same, "variant {i}");
        assert_eq!(a.same_but_diffuse(b), a.with_diffuse_factor(Vec3::ZERO) == b.with_diffuse_factor(Vec3::ZERO), "variant {i}");
    }
}

/// The specular tint scales the dielectric specular reflection: tint 0 leaves a Lambertian
/// reflector of the diffuse colour (MaterialX `specular = 0`), with no glossy lobe; tint 1 is
/// UsdPreviewSurface, bit for bit. The transmission colour tints the refracted light only.
#[test]
fn specular_tint_and_transmission_colour() {
    let rho = Vec3::new(0.6, 0.3, 0.1);
    let matte = preview(|p| (p.diffuse, p.roughness, p.specular_tint) = (rho, 0.4, Vec3::ZERO));
    assert_eq!(matte.flags(), BsdfFlags::DIFFUSE | BsdfFlags::REFLECTION);
    for (t_o, t_i) in [(10.0, 30.0), (60.0, 85.0), (89.0, 5.0)] {
        let f = matte.eval(dir(t_o, 0.3), dir(t_i, 2.0), RADIANCE);
        assert!(close3(f, rho * std::f32::consts::FRAC_1_PI, 1e-5), "{f}");
    }
    assert_eq!(preview(|p| p.specular_tint = Vec3::ONE), preview(|_| ()));
    // half the specular: F0 and F90 halved, so the specular albedo at normal incidence too
    let spec = |tint: f32| preview(|p| (p.diffuse, p.roughness, p.specular_tint) = (Vec3::ZERO, 0.3, Vec3::splat(tint)));
    let (full, half) = (albedo_mc(&spec(1.0), Vec3::Z, 200_000, 3, RADIANCE, false).0, albedo_mc(&spec(0.5), Vec3::Z, 200_000, 3, RADIANCE, false).0);
    assert!(close(half.x, 0.5 * full.x, 0.03), "{half} vs {full}");
    // glass: the refracted sample carries the colour, the reflected one stays white
    let tint = Vec3::new(0.9, 0.5, 0.2);
    let glass = |c: Vec3| preview(|p| (p.opacity, p.transmission_color) = (0.0, c));
    let wo = dir(30.0, 0.0);
    for uc in [0.01f32, 0.99] {
        let (a, b) = (glass(Vec3::ONE).sample(wo, uc, Vec2::new(0.3, 0.6), RADIANCE).unwrap(), glass(tint).sample(wo, uc, Vec2::new(0.3, 0.6), RADIANCE).unwrap());
        if a.flags.contains(BsdfFlags::TRANSMISSION) {
            assert!(close3(b.f, a.f * tint, 1e-4), "{} vs {}", b.f, a.f); // 16-bit tint
        } else {
            assert_eq!(a.f, b.f);
        }
    }
}
