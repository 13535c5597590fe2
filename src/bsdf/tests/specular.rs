//! Delta lobes (mirror, dielectric, coinciding PreviewSurface lobes), Fresnel and refraction laws,
//! and the PreviewSurface workflows.

use super::*;
use std::f32::consts::PI;

#[test]
fn dielectric_fresnel_and_refraction() {
    assert!((fresnel::dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
    assert!((fresnel::dielectric(-1.0, 1.5) - 0.04).abs() < 1e-6);
    assert!((fresnel::ior_to_f0(1.5) - 0.04).abs() < 1e-7);
    assert!(fresnel::dielectric(1e-4, 1.5) > 0.99);
    let glass = Bsdf::dielectric(1.5, Vec3::ONE);
    // Normal incidence: 4% reflection, 96% transmission with eta² compression in radiance mode.
    let r = glass.sample(Vec3::Z, 0.01, Vec2::ZERO, RADIANCE).unwrap();
    assert_eq!(r.wi, Vec3::Z);
    assert!(close(r.pdf, 0.04, 1e-5) && close(r.weight().x, 1.0, 1e-5) && r.f.x * r.wi.z > 0.0399);
    assert_eq!((r.flags, r.eta), (BsdfFlags::SPECULAR | BsdfFlags::REFLECTION, 1.0));
    let t = glass.sample(Vec3::Z, 0.5, Vec2::ZERO, RADIANCE).unwrap();
    assert!(t.wi.distance(-Vec3::Z) < 1e-6 && close(t.pdf, 0.96, 1e-5) && t.eta == 1.5);
    assert!(close(t.weight().x, 1.0 / 2.25, 1e-5), "{t:?}");
    let ti = glass.sample(Vec3::Z, 0.5, Vec2::ZERO, IMPORTANCE).unwrap();
    assert!(close(ti.weight().x, 1.0, 1e-5));
    // Snell's law at 40° from outside, and the reflected fraction follows Fresnel.
    let wo = dir(40.0, 1.0);
    let t = glass.sample(wo, 0.99, Vec2::ZERO, RADIANCE).unwrap();
    let sin_t = (1.0 - t.wi.z * t.wi.z).sqrt();
    assert!(t.wi.z < 0.0 && close(40f32.to_radians().sin(), 1.5 * sin_t, 1e-5), "{t:?}");
    assert!(t.wi.x * wo.x < 0.0 && t.wi.y * wo.y < 0.0, "refracted ray must continue across the normal");
    let f60 = fresnel::dielectric(dir(60.0, 0.0).z, 1.5);
    let mut rng = Rng::new(1, 1);
    let refl = (0..100_000)
        .filter(|_| glass.sample(dir(60.0, 0.0), rng.next_f32(), Vec2::ZERO, RADIANCE).unwrap().wi.z > 0.0)
        .count();
    assert!((refl as f32 / 1e5 - f60).abs() < 4.0 * (f60 * (1.0 - f60) / 1e5).sqrt(), "{refl} vs {f60}");
    // From inside: critical angle asin(1/1.5) ≈ 41.8°.
    let inside = |deg: f32| dir(180.0 - deg, 0.5);
    assert_eq!(fresnel::dielectric(inside(50.0).z, 1.5), 1.0);
    for uc in [0.0, 0.5, 0.999] {
        let s = glass.sample(inside(50.0), uc, Vec2::ZERO, RADIANCE).unwrap();
        assert!(s.wi.z < 0.0 && s.pdf == 1.0 && close(s.weight().x, 1.0, 1e-5), "TIR: {s:?}");
    }
    let s = glass.sample(inside(40.0), 0.999, Vec2::ZERO, RADIANCE).unwrap();
    assert!(
        s.wi.z > 0.0
            && close(s.eta, 1.0 / 1.5, 1e-6)
            && close(1.5 * 40f32.to_radians().sin(), (1.0 - s.wi.z * s.wi.z).sqrt(), 1e-4)
    );
    assert!(close(s.weight().x, 2.25, 1e-4), "leaving glass expands radiance: {s:?}");
    // Tint applies to transmission only.
    let tinted = Bsdf::dielectric(1.5, Vec3::new(1.0, 0.5, 0.0));
    assert!(close3(
        tinted.sample(Vec3::Z, 0.5, Vec2::ZERO, IMPORTANCE).unwrap().weight(),
        Vec3::new(1.0, 0.5, 0.0),
        1e-5
    ));
    assert!(close3(tinted.sample(Vec3::Z, 0.01, Vec2::ZERO, IMPORTANCE).unwrap().weight(), Vec3::ONE, 1e-5));
    assert_eq!((glass.eval(Vec3::Z, -Vec3::Z, RADIANCE), glass.pdf(Vec3::Z, Vec3::Z)), (Vec3::ZERO, 0.0));
}

#[test]
fn mirror_and_lambert_basics() {
    let m = Bsdf::mirror(Vec3::new(0.9, 0.8, 0.7));
    for wo in [dir(30.0, 1.0), dir(150.0, 2.0)] {
        let s = m.sample(wo, 0.3, Vec2::new(0.2, 0.9), RADIANCE).unwrap();
        assert!(s.wi.distance(Vec3::new(-wo.x, -wo.y, wo.z)) < 1e-6 && s.pdf == 1.0 && s.is_specular());
        assert!(close3(s.weight(), Vec3::new(0.9, 0.8, 0.7), 1e-6));
        assert_eq!((m.eval(wo, s.wi, RADIANCE), m.pdf(wo, s.wi)), (Vec3::ZERO, 0.0));
    }
    let l = Bsdf::lambert(Vec3::splat(0.5));
    let s = l.sample(dir(120.0, 0.0), 0.0, Vec2::new(0.3, 0.6), RADIANCE).unwrap();
    assert!(s.wi.z < 0.0 && close(s.pdf, s.wi.z.abs() / PI, 1e-6) && close3(s.weight(), Vec3::splat(0.5), 1e-6));
    assert!(l.sample(Vec3::X, 0.5, Vec2::splat(0.5), RADIANCE).is_none());
    assert_eq!(Bsdf::error().albedo(), Vec3::new(1.0, 0.0, 1.0));
}

#[test]
fn delta_lobes_that_coincide_are_summed() {
    // Smooth coat over smooth metal with a transmissive part: three lobes reflect into the mirror
    // direction; whichever is picked, the sample must carry their summed value and probability.
    let b = preview(|p| {
        (p.diffuse, p.metallic, p.roughness, p.clearcoat, p.clearcoat_roughness, p.opacity) =
            (Vec3::new(0.9, 0.5, 0.1), 1.0, 0.0, 0.6, 0.0, 0.7)
    });
    assert_eq!(b.flags(), BsdfFlags::SPECULAR | BsdfFlags::REFLECTION | BsdfFlags::TRANSMISSION);
    let wo = dir(45.0, 0.3);
    let mut rng = Rng::new(2, 2);
    let mut reference: Option<BsdfSample> = None;
    let (mut reflections, mut transmissions) = (0, 0);
    for _ in 0..10_000 {
        let s = b.sample(wo, rng.next_f32(), rng.next_2d(), RADIANCE).unwrap();
        assert!(s.is_specular());
        if s.wi.z > 0.0 {
            reflections += 1;
            let r = *reference.get_or_insert(s);
            assert!(close3(s.f, r.f, 1e-6) && close(s.pdf, r.pdf, 1e-6), "{s:?} vs {r:?}");
        } else {
            transmissions += 1;
            assert!(close(s.eta, 1.5, 1e-6));
        }
    }
    let r = reference.unwrap();
    let frac = reflections as f32 / 10_000.0;
    assert!((frac - r.pdf).abs() < 0.02, "reflection frequency {frac} vs summed probability {}", r.pdf);
    assert!(transmissions > 0);
}

#[test]
fn preview_workflows_follow_the_spec() {
    // Metallic 1: the smooth specular colour at normal incidence is diffuseColor (F0 = F90 = albedo).
    let c = Vec3::new(0.95, 0.64, 0.54);
    let s = preview(|p| (p.diffuse, p.metallic, p.roughness) = (c, 1.0, 0.0))
        .sample(Vec3::Z, 0.5, Vec2::ZERO, RADIANCE)
        .unwrap();
    assert!(close3(s.weight(), c, 1e-5), "{s:?}");
    // Metallic 0, ior 1.5: F0 = 0.04, and the diffuse colour does not tint the reflection.
    let b = preview(|p| (p.diffuse, p.roughness) = (Vec3::new(1.0, 0.0, 0.0), 0.0));
    let s = (0..100)
        .map(|i| b.sample(Vec3::Z, i as f32 / 100.0, Vec2::splat(0.5), RADIANCE).unwrap())
        .find(|s| s.is_specular())
        .unwrap();
    assert!(close3(s.f * s.wi.z, Vec3::splat(0.04), 1e-4), "{s:?}");
    // Specular workflow: F0 = specularColor.
    let b = preview(|p| {
        (p.use_specular_workflow, p.specular, p.diffuse, p.roughness) =
            (true, Vec3::new(0.5, 0.2, 0.1), Vec3::ZERO, 0.0)
    });
    let s = b.sample(Vec3::Z, 0.5, Vec2::ZERO, RADIANCE).unwrap();
    assert!(close3(s.weight(), Vec3::new(0.5, 0.2, 0.1), 1e-5), "{s:?}");
    // Albedo AOV: diffuse-dominated for plastic, metal colour for metals.
    assert!(preview(|p| p.diffuse = Vec3::new(0.8, 0.1, 0.1)).albedo().x > 0.7);
    assert!(close3(preview(|p| (p.diffuse, p.metallic, p.roughness) = (c, 1.0, 0.0)).albedo(), c, 0.06));
}
