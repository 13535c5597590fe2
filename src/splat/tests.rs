//! [`super::splat`] against brute force: every (eye sample, photon ray) pair evaluated directly
//! with the footprint's membership and kernel tests, no kd-tree, no tiles, sums in f64.

use super::footprint::Footprint;
use super::*;
use crate::bsdf::{Bsdf, SurfaceParams};
use crate::eye::{EyeSample, GlossySample};
use crate::sampling::{hash, oct_encode, Frame, Rng};

/// Eye samples on a bumpy floor (two per pixel, every third pixel's glossy) over several tiles,
/// and photon rays falling onto it from above, in two classes.
fn setup(n_rays: usize) -> (EyePass, Vec<PhotonRay>) {
    let (w, h) = (140u32, 40u32);
    let params = SurfaceParams {
        diffuse: Vec3::new(0.5, 0.3, 0.2),
        specular: Vec3::ONE,
        use_specular_workflow: false,
        metallic: 0.0,
        roughness: 0.3,
        clearcoat: 0.0,
        clearcoat_roughness: 0.01,
        opacity: 1.0,
        ior: 1.5,
    };
    let bsdf = Bsdf::from_preview_surface(&params);
    let mut glossy = Vec::new();
    let mut samples = Vec::new();
    for p in 0..w * h {
        for s in 0..2u64 {
            let mut r = Rng::new(hash(&[21, p as u64, s]), 0);
            let (x, y) = ((p % w) as f32 + r.next_f32(), (p / w) as f32 + r.next_f32());
            let n = Vec3::new(0.3 * (r.next_f32() - 0.5), 0.3 * (r.next_f32() - 0.5), 1.0).normalize();
            let g = if p % 3 == 0 {
                let wo = Vec3::new(r.next_f32() - 0.5, r.next_f32() - 0.5, 1.0).normalize();
                glossy.push(GlossySample { bsdf: bsdf.at(wo), frame: Frame::from_normal(n) });
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
    (EyePass::of_samples(w, h, samples, glossy), rays)
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
            let f = if e.glossy == NO_GLOSSY { Vec3::ONE } else { eye.glossy[e.glossy as usize].eval(-fp.dir) };
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
