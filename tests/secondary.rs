//! Strong secondary lights (`strong-secondary-lighting.md`): the low/high-energy split, explicit
//! sampling of the high-energy voxels against the uniform final gather, the irradiance cache.

mod common;
use common::repo::{load};

use glam::Vec3;
use raysplat::image::{compare, Film};
use raysplat::integrators::{he_fg, render, Method, RenderRequest, RenderSettings, SilentProgress};
use raysplat::prepare::PreparedScene;
use raysplat::scene::SceneDesc;


fn request(fg: u32, explicit: u32) -> RenderRequest {
    RenderRequest {
        method: Some(Method::HeFg),
        spp: Some(1),
        seed: 5,
        resolution: Some([32, 24]),
        photons: Some(60_000),
        fg_rays: Some(fg),
        explicit_rays: explicit,
        ..Default::default()
    }
}

fn settings(fg: u32, explicit: u32) -> RenderSettings {
    request(fg, explicit).settings().unwrap()
}

fn indirect(scene: &SceneDesc, s: &RenderSettings) -> Vec<f32> {
    let out = render(scene.clone(), s, &SilentProgress).expect("render");
    assert_eq!(out.film.nan_count(), 0);
    ind(&out.film)
}

fn ind(f: &Film) -> Vec<f32> {
    f.rgb("indirect").expect("indirect layer")
}

fn mean(v: &[f32]) -> f64 {
    v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64
}

/// A uniformly lit closed box (the white furnace: every wall emits): no voxel reaches E_max, so
/// the renderer builds no high-energy map.
#[test]
fn uniformly_lit_furnace_has_no_high_energy_photons() {
    let desc = common::furnace(0.5, 1.0);
    let scene = PreparedScene::new(desc.clone(), 16, 16, 0).unwrap();
    let split = he_fg::survey(&scene, 100_000, 5).split;
    assert!(split.e_avg > 0.0 && split.low_photons > 50_000, "{} {}", split.e_avg, split.low_photons);
    assert_eq!(split.high_photons, 0);
    assert!(split.high_voxels.is_empty());
    let out = render(desc, &RenderSettings { resolution: Some([8, 8]), ..settings(16, 16) }, &SilentProgress).unwrap();
    assert!(out.stats.enabled.iter().all(|(n, _)| !n.contains("high-energy")), "{:?}", out.stats.enabled);
    assert_eq!(out.stats.counter("explicit_rays"), Some(0));
}

/// The spot of `scenes/secondary-light.usda` lights a patch of the ceiling around (−0.8, 3, −0.8)
/// (cone of 7° from 2.65 m at 41° incidence: an ellipse of semi-axes ≈ 0.32 and 0.43 m). The high-
/// energy voxels are exactly there: every one touches the ceiling within the patch (plus a voxel
/// diagonal), and the patch centre's voxel is one of them.
#[test]
fn high_energy_map_is_the_lit_patch() {
    let desc = load("secondary-light.usda");
    let scene = PreparedScene::new(desc, 32, 24, 0).unwrap();
    let split = he_fg::survey(&scene, 100_000, 5).split;
    assert!(!split.high_voxels.is_empty());
    assert!(split.high_photons > 5_000, "{}", split.high_photons);
    let centre = Vec3::new(-0.8, 3.0, -0.8);
    let diag = split.grid.edge * 3f32.sqrt();
    for &v in &split.high_voxels.voxels {
        let (lo, hi) = split.grid.bounds(v);
        let c = 0.5 * (lo + hi);
        assert!(hi.y >= 3.0 - 1e-3, "high voxel {c} is not at the ceiling");
        assert!((c - centre).length() < 0.43 + diag, "high voxel {c} is outside the lit patch");
    }
    assert!(split.high_voxels.voxels.contains(&split.grid.index(centre - Vec3::Y * 1e-3)));
}

/// Explicit sampling is unbiased with respect to the density estimate it samples: on the scene
/// with one bright patch, he-fg converges to the uniform final gather of the whole map (one map,
/// 2048 stratified rays) as its rays grow, and the same photons are used by both.
#[test]
fn explicit_sampling_converges_to_the_uniform_gather() {
    let desc = load("secondary-light.usda");
    let uniform = indirect(&desc, &settings(2048, 0));
    let few = indirect(&desc, &settings(12, 24));
    let many = indirect(&desc, &settings(192, 768));
    let (e_few, e_many) = (compare(&few, &uniform).rel_mse, compare(&many, &uniform).rel_mse);
    let (m_u, m_many) = (mean(&uniform), mean(&many));
    eprintln!("rel MSE vs uniform: few {e_few:.5}, many {e_many:.5}; means {m_u:.5} {m_many:.5}");
    assert!(e_many < 0.25 * e_few, "{e_many} vs {e_few}");
    assert!(e_many < 0.01, "{e_many}");
    assert!((m_many / m_u - 1.0).abs() < 0.03, "{m_many} vs {m_u}");
}

/// At the paper's setting the split estimator is closer to the converged uniform gather than the
/// uniform gather with as many rays.
#[test]
fn explicit_sampling_beats_uniform_gathering_at_equal_rays() {
    let desc = load("secondary-light.usda");
    let converged = indirect(&desc, &settings(2048, 0));
    let he = indirect(&desc, &settings(24, 96));
    let uni = indirect(&desc, &settings(120, 0));
    let (e_he, e_uni) = (compare(&he, &converged).rel_mse, compare(&uni, &converged).rel_mse);
    eprintln!("rel MSE vs converged uniform at 120 rays: he-fg {e_he:.5}, uniform {e_uni:.5}");
    assert!(e_he < 0.5 * e_uni, "{e_he} vs {e_uni}");
}

/// he-fg with the irradiance cache is the same image for 1 and 2 threads, and close to the gather
/// without the cache.
#[test]
fn irradiance_cache_is_deterministic_and_close_to_the_gather() {
    let desc = load("secondary-light.usda");
    let s = |threads| RenderRequest { irradiance_cache: true, threads, ..request(48, 96) }.settings().unwrap();
    let a = render(desc.clone(), &s(1), &SilentProgress).unwrap();
    let b = render(desc.clone(), &s(2), &SilentProgress).unwrap();
    assert_eq!(ind(&a.film), ind(&b.film));
    let records = a.stats.counter("cache_records").unwrap();
    let points = a.stats.counter("cache_points").unwrap();
    assert!(records > 0 && records < points, "{records} records for {points} points");
    let plain = indirect(&desc, &settings(48, 96));
    let cached = ind(&a.film);
    let (m_p, m_c) = (mean(&plain), mean(&cached));
    eprintln!("cache: {records} records / {points} points, means {m_c:.5} vs {m_p:.5}, rel MSE {:.5}", compare(&cached, &plain).rel_mse);
    assert!((m_c / m_p - 1.0).abs() < 0.05, "{m_c} vs {m_p}");
}

/// `pm-fg --irradiance-cache`: the cached per-point gather of one global photon map agrees with
/// pm-fg's own final gather (a different estimator of the same quantity: k-NN density at the gather
/// hits versus precomputed irradiance) to within the photon maps' bias, places fewer records than
/// points, and never builds a high-energy map; the cache is refused for methods that do not gather
/// per point.
#[test]
fn pm_fg_takes_the_irradiance_cache() {
    let desc = load("cornell-box.usda");
    let base = RenderRequest { method: Some(Method::PmFg), spp: Some(1), seed: 5, resolution: Some([32, 32]), photons: Some(60_000), ..Default::default() };
    let cached = render(desc.clone(), &RenderRequest { irradiance_cache: true, ..base.clone() }.settings().unwrap(), &SilentProgress).unwrap();
    let records = cached.stats.counter("cache_records").unwrap();
    let points = cached.stats.counter("cache_points").unwrap();
    assert!(records > 0 && records < points, "{records} records for {points} points");
    assert!(cached.stats.enabled.iter().all(|(what, _)| !what.contains("high-energy")), "{:?}", cached.stats.enabled);
    let (m_c, m_p) = (mean(&ind(&cached.film)), mean(&indirect(&desc, &base.settings().unwrap())));
    eprintln!("pm-fg: cached {m_c:.5} ({records} records / {points} points), uncached {m_p:.5}");
    assert!((m_c / m_p - 1.0).abs() < 0.1, "{m_c} vs {m_p}");
    let rs = RenderRequest { method: Some(Method::Rs), irradiance_cache: true, ..base };
    assert!(rs.settings().unwrap_err().to_string().contains("irradiance-cache"));
}
