//! [`super::splat`] against brute force: every (eye sample, photon ray) pair evaluated directly
//! with the footprint's membership and kernel tests, no kd-tree, no tiles, sums in f64.

use super::footprint::Footprint;
use super::*;
use crate::bsdf::{Bsdf, SurfaceParams};
use crate::eye::{EyeSample, GlossySample, GlossyTable, NO_GLOSSY};
use crate::sampling::{hash, oct_encode, Frame, Rng};

/// Eye samples on a bumpy floor (two per pixel, every third pixel's glossy) over several tiles,
/// and photon rays falling onto it from above, in two classes.
fn setup(n_rays: usize) -> (EyePass, Vec<PhotonRay>) {
    let bsdf = Bsdf::from_preview_surface(&coat(0.3, Vec3::ONE, false));
    setup_with(n_rays, |_| bsdf)
}

/// A UsdPreviewSurface coat on the test's diffuse base.
fn coat(roughness: f32, specular: Vec3, use_specular_workflow: bool) -> SurfaceParams {
    SurfaceParams::coat(Vec3::new(0.5, 0.3, 0.2), specular, use_specular_workflow, roughness)
}

/// [`setup`] with the glossy pixels' BSDF chosen per pixel.
fn setup_with(n_rays: usize, bsdf_of: impl Fn(u32) -> Bsdf) -> (EyePass, Vec<PhotonRay>) {
    let (w, h) = (140u32, 40u32);
    let mut glossy = Vec::new();
    let mut samples = Vec::new();
    for p in 0..w * h {
        for s in 0..2u64 {
            let mut r = Rng::new(hash(&[21, p as u64, s]), 0);
            let (x, y) = ((p % w) as f32 + r.next_f32(), (p / w) as f32 + r.next_f32());
            let n = Vec3::new(0.3 * (r.next_f32() - 0.5), 0.3 * (r.next_f32() - 0.5), 1.0).normalize();
            let g = if p % 3 == 0 {
                let wo = Vec3::new(r.next_f32() - 0.5, r.next_f32() - 0.5, 1.0).normalize();
                glossy.push(GlossySample { bsdf: bsdf_of(p).at(wo), frame: Frame::from_normal(n) });
                glossy.len() as u32 - 1
            } else {
                NO_GLOSSY
            };
            let weight = [0.5, 0.4 * r.next_f32(), 0.3];
            samples.push(EyeSample { p: [x * 0.02, y * 0.02, 0.005 * (x * 0.7).sin()], n: oct_encode(n), weight, pixel: p, glossy: g });
        }
    }
    let rays = (0..n_rays)
        .map(|i| {
            let mut r = Rng::new(hash(&[22, i as u64]), 0);
            let o = Vec3::new(r.next_f32() * 3.0 - 0.1, r.next_f32() * 1.0 - 0.1, 0.3 + r.next_f32());
            let d = Vec3::new(r.next_f32() - 0.5, r.next_f32() - 0.5, -1.0).normalize();
            let len = (o.z - 0.004) / -d.z;
            let mut ray = PhotonRay::new(o, d, len, Vec3::new(1.0, 0.5, 0.25) * r.next_f32(), -Vec3::Z, Vec3::Z);
            (ray.h0, ray.dh) = (0.01 + 0.03 * r.next_f32(), 0.02 * r.next_f32());
            ray
        })
        .collect();
    (EyePass::of_samples(w, h, samples, GlossyTable::from_samples(glossy)), rays)
}

/// Per pixel (radiance, kernel weight, Σ 1/t, count) and the pair count, by brute force.
fn brute_force(eye: &EyePass, rays: &[&[PhotonRay]]) -> (Vec<[f64; 6]>, u64) {
    let mut px = vec![[0.0f64; 6]; (eye.width * eye.height) as usize];
    let mut pairs = 0;
    for r in rays.iter().flat_map(|s| s.iter()) {
        let Some(fp) = Footprint::of(r) else { continue };
        let kernel = fp.kernel(r);
        for e in &eye.samples {
            let (p, n) = (e.pos(), e.normal());
            let Some((t, d2)) = fp.cone.test(p) else { continue };
            let Some((k, _)) = kernel.weight(p, n, t, d2) else { continue };
            let f = if e.glossy == NO_GLOSSY { Vec3::ONE } else { eye.glossy.sample(e.glossy as usize).eval(-fp.dir) };
            let c = e.weight() * f * r.flux() * (k * -n.dot(fp.dir));
            let a = &mut px[e.pixel as usize];
            for (j, v) in [c.x, c.y, c.z, k, 1.0 / t.max(1e-30), 1.0].into_iter().enumerate() {
                a[j] += v as f64;
            }
            pairs += 1;
        }
    }
    (px, pairs)
}

#[test]
fn splatting_gives_the_brute_force_sums_for_any_thread_count() {
    let (eye, rays) = setup(2 * 8192 + 321); // several tiles, rays in two classes
    let classes: [&[PhotonRay]; 2] = [&rays[..3000], &rays[3000..]];
    let (want, want_pairs) = brute_force(&eye, &classes);
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| splat(&eye, &classes))
    };
    let (a, b) = (run(1), run(2));
    assert!(want_pairs > 20_000, "too few pairs to mean anything: {want_pairs}");
    assert_eq!(a.pairs, want_pairs);
    assert!(a.tiles > 1);
    // thread count changes nothing, bit for bit
    assert_eq!(a.radiance, b.radiance);
    assert_eq!(a.kernel_weight, b.kernel_weight);
    assert_eq!(a.harmonic_distance, b.harmonic_distance);
    assert_eq!(a.pairs, b.pairs);
    let close = |got: f32, want: f64, scale: f64| (got as f64 - want).abs() <= 1e-5 * scale;
    let mut lit = 0;
    for (p, w) in want.iter().enumerate() {
        let scale = w[..3].iter().fold(1e-6f64, |m, v| m.max(v.abs()));
        let got = a.radiance[p];
        assert!(close(got.x, w[0], scale) && close(got.y, w[1], scale) && close(got.z, w[2], scale), "pixel {p}: {got} vs {w:?}");
        assert!(close(a.kernel_weight[p], w[3], w[3].max(1e-6)), "pixel {p}: kernel weight {} vs {}", a.kernel_weight[p], w[3]);
        let hd = if w[5] > 0.0 { w[5] / w[4] } else { 0.0 };
        assert!(close(a.harmonic_distance[p], hd, hd.max(1e-6)), "pixel {p}: harmonic distance {} vs {hd}", a.harmonic_distance[p]);
        lit += (w[5] > 0.0) as usize;
    }
    assert!(lit > want.len() / 2, "only {lit} pixels lit");
}

/// `GlossyMode::Auto` with a rough lobe (the Cornell box walls' coat) on some glossy pixels and a
/// sharp one on others: the sharp pixels get exactly the exact-BSDF image, the rough ones exactly
/// the SH map's, bit for bit, after the map's final integration.
#[test]
fn auto_maps_rough_lobes_and_evaluates_sharp_ones_exactly() {
    use crate::radiance_map::{resolve, SH_RESIDUAL_MAX};
    let sharp = Bsdf::from_preview_surface(&coat(0.3, Vec3::ONE, false));
    let rough = Bsdf::from_preview_surface(&coat(1.0, Vec3::ZERO, true));
    let is_sharp = |p: u32| (p / 3) % 2 == 0;
    let (eye, rays) = setup_with(6000, |p| if is_sharp(p) { sharp } else { rough });
    let classes: [&[PhotonRay]; 1] = [&rays];
    let image = |mode| {
        let mut img = splat_with_map(&eye, &classes, mode, &|| false).unwrap();
        let map = img.map.take();
        if let Some(m) = &map {
            resolve(&eye, m, 1, &mut img.radiance);
        }
        (img, map)
    };
    let (auto, map) = image(GlossyMode::Auto);
    let (exact, _) = image(GlossyMode::Exact);
    let (sh, _) = image(GlossyMode::Sh);
    let map = map.expect("the rough lobe is mapped");
    let tables = map.tables.as_ref().unwrap();
    let residuals: Vec<f32> = tables.tables.iter().map(|t| t.residual).collect();
    assert!(residuals.iter().any(|&r| r <= SH_RESIDUAL_MAX) && residuals.iter().any(|&r| r > SH_RESIDUAL_MAX), "{residuals:?}");
    let n_sharp = eye.samples.iter().filter(|e| e.is_glossy() && is_sharp(e.pixel)).count();
    assert!(n_sharp > 1000);
    assert_eq!(map.exact_samples, n_sharp);
    let (mut n_exact, mut n_sh) = (0, 0);
    for p in 0..(eye.width * eye.height) {
        if p % 3 != 0 || auto.kernel_weight[p as usize] == 0.0 {
            continue; // diffuse or unlit pixels: the same in every mode
        }
        let (got, want) = (auto.radiance[p as usize], if is_sharp(p) { exact.radiance[p as usize] } else { sh.radiance[p as usize] });
        assert_eq!(got, want, "pixel {p} (sharp: {})", is_sharp(p));
        *(if is_sharp(p) { &mut n_exact } else { &mut n_sh }) += 1;
    }
    assert!(n_exact > 300 && n_sh > 300, "{n_exact} exact, {n_sh} SH pixels lit");
    // the rough pixels' SH image differs from the exact one (the test tells the two apart)
    assert!((0..eye.width * eye.height).any(|p| p % 3 == 0 && !is_sharp(p) && sh.radiance[p as usize] != exact.radiance[p as usize]));
    // a view of sharp lobes only keeps the exact BSDF and says why
    let (eye, _) = setup_with(10, |_| sharp);
    let img = splat_with_map(&eye, &classes, GlossyMode::Auto, &|| false).unwrap();
    assert!(img.map.is_none() && img.auto_exact.is_some());
}

/// A sparse set of rays (all landing in the image's left quarter): with `only_reached` the map
/// holds the slots of the reached tiles only, and the resolved image is the same, bit for bit, in
/// every map mode.
#[test]
fn map_of_reached_tiles_gives_the_same_image() {
    use crate::radiance_map::resolve;
    let rough = Bsdf::from_preview_surface(&coat(1.0, Vec3::ZERO, true)); // a lobe auto maps
    let (eye, rays) = setup_with(3000, |_| rough);
    let few: Vec<PhotonRay> = rays.into_iter().filter(|r| r.end().x < 0.6).take(300).collect();
    assert!(few.len() > 100, "only {} rays land left", few.len());
    let classes: [&[PhotonRay]; 1] = [&few];
    for mode in [GlossyMode::Auto, GlossyMode::Sh, GlossyMode::Histogram] {
        let image = |only_reached| {
            let mut img = splat_with_tables(&eye, &classes, mode, None, only_reached, &|| false).unwrap();
            let map = img.map.take().expect("a mapped mode");
            resolve(&eye, &map, 1, &mut img.radiance);
            (img, map.slots())
        };
        let ((all, all_slots), (reached, reached_slots)) = (image(false), image(true));
        assert!(reached.pairs > 1000, "{mode}: too few pairs to mean anything: {}", reached.pairs);
        assert!(reached_slots * 2 < all_slots, "{mode}: {reached_slots} of {all_slots} slots");
        assert!(all.radiance == reached.radiance, "{mode}: the images differ");
    }
}
