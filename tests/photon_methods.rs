//! Photon ray splatting (`rs`) against classic photon maps (`pm`), both measured against the path
//! tracer (`pt`) on `scenes/cornell-box.usda` and `scenes/bumpy-box.usda`, the scale invariance
//! of `rs`, and the flux of `rs`'s caustic under the glass sphere of `scenes/cornell-glossy.usda`.
//!
//! Method:
//! - Everything is compared on the `indirect` layer: the direct light of `rs`/`pm` (explicit light
//!   sampling in the eye pass) and of `pt` differ only by noise; the indirect light is what the
//!   photon density estimation produces.
//! - The reference is rendered here: two path-traced images of `REF_SPP / 2` samples per pixel with
//!   different seeds, averaged. Its own noise, `relMSE(A, B) / 4` (the variance of the mean of two),
//!   is subtracted from every error (E[relMSE(test, ref)] = relMSE(test, truth) + noise(ref) for an
//!   independent reference); it is about 1/8 of the smallest error measured, and printed.
//! - `pm` and `rs` use the same photon count (200 000), seeds and eye pass; `pm` uses k = 100
//!   neighbours, which gives about the mean splat radius of `rs` with its default bandwidth
//!   (C = 0.3, S = 0.1): both about 2 cm (`mean_bandwidth_um`), checked by the tests.
//! - Errors and biases are averaged over three photon seeds: a photon set carries a global flux
//!   fluctuation of about ±1.5 % that every pixel shares, so single-seed ratios vary by ±0.08.
//! - Regions: the whole image; the edge mask (normal/depth discontinuities of the
//!   reference's AOVs, dilated 2 px), split into silhouettes (depth jumps) and creases (normal
//!   changes without a depth jump); on the bumpy box, the pixels that see only the bumpy floor, or
//!   only the sphere (camera rays traced against the scene).
//! - Images are 64 × 64 at 4 eye samples per pixel: the file takes about 45 s in the release
//!   profile on two cores. Every assertion message repeats the whole table.

mod common;
use common::repo::{load, run, indirect, masked};

use raysplat::image::{compare, Film};
use raysplat::integrators::{Method, RenderRequest, RenderSettings};
use raysplat::scene::SceneDesc;

const RES: [u32; 2] = [64, 64];
/// Path-traced samples per pixel of the reference (two halves with different seeds).
const REF_SPP: u32 = 4096;
const PHOTONS: usize = 200_000;
/// Photon seeds: errors and biases are averaged over them (each photon set carries a global flux
/// fluctuation of about ±1.5 % that all pixels share, so single-seed ratios vary by ±0.08).
const SEEDS: [u64; 3] = [1, 2, 3];





/// The path-traced reference: the average of two half renders, and their difference for the noise.
struct Reference {
    film: Film,
    indirect: Vec<f32>,
    halves: [Vec<f32>; 2],
}

impl Reference {
    fn render(scene: &SceneDesc) -> Reference {
        let half = |seed| {
            let s = RenderSettings { spp: REF_SPP / 2, seed, resolution: Some(RES), ..Default::default() };
            run(scene.clone(), &s).film
        };
        let (a, b) = (half(1001), half(1002));
        let halves = [indirect(&a), indirect(&b)];
        let indirect: Vec<f32> = halves[0].iter().zip(&halves[1]).map(|(x, y)| 0.5 * (x + y)).collect();
        // AOVs (normal, depth) of the first half are enough for the masks.
        Reference { film: a, indirect, halves }
    }

    /// Relative MSE of the reference's own noise over the pixels of `mask`.
    fn noise(&self, mask: &[bool]) -> f64 {
        compare(&masked(&self.halves[0], mask), &masked(&self.halves[1], mask)).rel_mse / 4.0
    }

    /// Relative MSE of `test` against the truth over `mask`: measured against the reference, minus
    /// the reference's noise.
    fn error(&self, test: &[f32], mask: &[bool]) -> f64 {
        compare(&masked(test, mask), &masked(&self.indirect, mask)).rel_mse - self.noise(mask)
    }

    /// Signed relative bias of `test` over `mask`: Σ test / Σ reference − 1.
    fn bias(&self, test: &[f32], mask: &[bool]) -> f64 {
        let sum = |v: &[f32]| masked(v, mask).iter().map(|&x| x as f64).sum::<f64>();
        sum(test) / sum(&self.indirect) - 1.0
    }
}

/// Pixels within `dilate` pixels of a discontinuity of the reference's `normal` or `depth` AOV:
/// neighbours whose normals differ by more than 37° (`cos < 0.8`), or whose depths differ by more
/// than 10 % (or one of which sees nothing). `kind` selects all of them, only the depth jumps
/// (silhouettes: convex edges, occlusion boundaries) or only normal changes without a depth jump
/// (creases: concave corners, and the convex vertical block edges seen from the front).
#[derive(Clone, Copy, PartialEq)]
enum Edges {
    All,
    Silhouettes,
    Creases,
}

fn edge_mask(r: &Film, kind: Edges, dilate: i32) -> Vec<bool> {
    let (w, h) = (r.width as i32, r.height as i32);
    let nl = r.layer("normal").expect("normal AOV");
    let dl = r.layer("depth").expect("depth AOV");
    let n = |x: i32, y: i32| {
        let p = nl.pixel((y * w + x) as usize);
        glam::Vec3::new(p[0], p[1], p[2]).normalize_or_zero()
    };
    let d = |x: i32, y: i32| dl.pixel((y * w + x) as usize)[0];
    let mut edge = vec![false; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            for (x2, y2) in [(x + 1, y), (x, y + 1)] {
                if x2 >= w || y2 >= h {
                    continue;
                }
                let (da, db) = (d(x, y), d(x2, y2));
                let depth_jump = (da <= 0.0) != (db <= 0.0) || (da - db).abs() > 0.1 * da.min(db);
                let normal_jump = n(x, y).dot(n(x2, y2)) < 0.8;
                let hit = match kind {
                    Edges::All => depth_jump || normal_jump,
                    Edges::Silhouettes => depth_jump,
                    Edges::Creases => normal_jump && !depth_jump,
                };
                if hit {
                    edge[(y * w + x) as usize] = true;
                    edge[(y2 * w + x2) as usize] = true;
                }
            }
        }
    }
    let mut out = vec![false; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            if edge[(y * w + x) as usize] {
                for yy in (y - dilate).max(0)..=(y + dilate).min(h - 1) {
                    for xx in (x - dilate).max(0)..=(x + dilate).min(w - 1) {
                        out[(yy * w + xx) as usize] = true;
                    }
                }
            }
        }
    }
    out
}

/// Pixels whose centre and four corners all see instances named in `names` (camera rays traced
/// against the prepared scene).
fn object_mask(desc: &SceneDesc, names: &[&str]) -> Vec<bool> {
    let scene = raysplat::prepare::PreparedScene::new(desc.clone(), RES[0], RES[1], 0).expect("prepare");
    let wanted: Vec<bool> = desc.instances.iter().map(|i| names.iter().any(|n| i.name.ends_with(n))).collect();
    let sees = |x: f32, y: f32| scene.intersect(&scene.camera.ray(x, y)).is_some_and(|h| wanted[h.instance as usize]);
    (0..RES[1])
        .flat_map(|y| (0..RES[0]).map(move |x| (x as f32, y as f32)))
        .map(|(x, y)| [(0.5, 0.5), (0.01, 0.01), (0.99, 0.01), (0.01, 0.99), (0.99, 0.99)].iter().all(|(dx, dy)| sees(x + dx, y + dy)))
        .collect()
}

/// One method at one photon count, rendered with every seed of [`SEEDS`].
struct Photon {
    name: String,
    /// Indirect layer per seed.
    images: Vec<Vec<f32>>,
    /// Mean bandwidth (`rs`: splat radius at the eye samples; `pm`: k-NN radius), cm, mean over seeds.
    bandwidth_cm: f64,
}

impl Photon {
    fn render(scene: &SceneDesc, method: Method, photons: usize) -> Photon {
        let mut images = Vec::new();
        let mut bw = 0.0;
        for seed in SEEDS {
            let s = RenderRequest { method: Some(method), photons: Some(photons), spp: Some(4), seed, resolution: Some(RES), knn: 100, ..Default::default() }.settings().unwrap();
            let out = run(scene.clone(), &s);
            bw += out.stats.counter("mean_bandwidth_um").expect("mean_bandwidth_um") as f64 / 1e4 / SEEDS.len() as f64;
            images.push(indirect(&out.film));
        }
        Photon { name: format!("{method} {}k", photons / 1000), images, bandwidth_cm: bw }
    }
}

/// Everything the accuracy tests look at, for one scene.
struct Accuracy {
    file: &'static str,
    reference: Reference,
    pm: Photon,
    rs: Photon,
    /// `rs` with four times the photons.
    rs4: Photon,
    /// (name, mask) of the regions measured.
    regions: Vec<(&'static str, Vec<bool>)>,
}

impl Accuracy {
    fn measure(file: &'static str, extra: impl FnOnce(&SceneDesc) -> Vec<(&'static str, Vec<bool>)>) -> Accuracy {
        let scene = load(file);
        let reference = Reference::render(&scene);
        let pm = Photon::render(&scene, Method::Pm, PHOTONS);
        let rs = Photon::render(&scene, Method::Rs, PHOTONS);
        let rs4 = Photon::render(&scene, Method::Rs, 4 * PHOTONS);
        let mut regions = vec![
            ("image", vec![true; (RES[0] * RES[1]) as usize]),
            ("edges", edge_mask(&reference.film, Edges::All, 2)),
            ("silhouettes", edge_mask(&reference.film, Edges::Silhouettes, 1)),
            ("creases", edge_mask(&reference.film, Edges::Creases, 1)),
        ];
        regions.extend(extra(&scene));
        let a = Accuracy { file, reference, pm, rs, rs4, regions };
        eprintln!("{}", a.table());
        a
    }

    fn mask(&self, region: &str) -> &[bool] {
        &self.regions.iter().find(|(n, _)| *n == region).expect("region").1
    }

    /// Relative MSE against the truth (see [`Reference::error`]), mean over the seeds.
    fn error(&self, p: &Photon, region: &str) -> f64 {
        p.images.iter().map(|i| self.reference.error(i, self.mask(region))).sum::<f64>() / p.images.len() as f64
    }

    /// Signed relative bias, mean over the seeds.
    fn bias(&self, p: &Photon, region: &str) -> f64 {
        p.images.iter().map(|i| self.reference.bias(i, self.mask(region))).sum::<f64>() / p.images.len() as f64
    }

    /// The measurements as a table (printed by the tests and repeated in every assertion message).
    fn table(&self) -> String {
        let mut s = format!(
            "{}: {}x{}, 4 eye spp, indirect layer; error = relative MSE minus the reference's own noise \
             (path tracer, {} spp), bias = Σtest/Σref − 1, both averaged over photon seeds {:?}\n",
            self.file, RES[0], RES[1], REF_SPP, SEEDS
        );
        s += &format!("  {:<12} {:>6} {:>9}", "region", "pixels", "ref noise");
        for p in [&self.pm, &self.rs, &self.rs4] {
            s += &format!(" | {:>8} ({:.2} cm) bias  ", p.name, p.bandwidth_cm);
        }
        s += &format!(" | {:>6} {:>6}\n", "rs/pm", "rs4/rs");
        for (name, mask) in &self.regions {
            s += &format!("  {:<12} {:>6} {:>9.6}", name, mask.iter().filter(|&&m| m).count(), self.reference.noise(mask));
            for p in [&self.pm, &self.rs, &self.rs4] {
                s += &format!(" | {:>17.6} {:>+6.3}", self.error(p, name), self.bias(p, name));
            }
            s += &format!(
                " | {:>6.3} {:>6.3}\n",
                self.error(&self.rs, name) / self.error(&self.pm, name),
                self.error(&self.rs4, name) / self.error(&self.rs, name)
            );
        }
        s
    }

    /// The claims both scenes share. Margins: the ratios were measured on three disjoint seed
    /// triples ({1,2,3}, {4,5,6}, {7,8,9}); the bounds sit at least 0.08 above the worst of them.
    fn check_common(&self) {
        let t = self.table();
        let noise = self.reference.noise(self.mask("image"));
        // The reference is good enough: its noise is small next to the smallest error measured.
        let smallest = self.error(&self.rs4, "image");
        assert!(noise < 0.2 * smallest, "reference noise {noise:.6} is not well below the smallest error {smallest:.6}\n{t}");
        // Comparable bandwidths (k = 100 was chosen for this), so the comparison is fair.
        let ratio = self.rs.bandwidth_cm / self.pm.bandwidth_cm;
        assert!((0.85..1.15).contains(&ratio), "mean bandwidths not comparable: rs {:.2} cm, pm {:.2} cm\n{t}", self.rs.bandwidth_cm, self.pm.bandwidth_cm);
        // Neither method loses or gains light overall (flux normalisation, kernel normalisation).
        for p in [&self.pm, &self.rs, &self.rs4] {
            let b = self.bias(p, "image");
            assert!(b.abs() < 0.05, "{} indirect light is off by {b:+.3} over the image\n{t}", p.name);
        }
        // At equal photons and comparable bandwidth, rs is more accurate over the image (measured
        // 0.70-0.71 on the Cornell box, 0.75-0.77 on the bumpy box before the light-leak test, 0.80 with it).
        let (rs, pm) = (self.error(&self.rs, "image"), self.error(&self.pm, "image"));
        assert!(rs < 0.85 * pm, "rs indirect error {rs:.6} is not below 0.85 x pm's {pm:.6}\n{t}");
        // And near edges and corners: the mask (normal/depth discontinuities of the reference
        // AOVs, dilated 2 px; measured 0.68-0.70 and 0.74-0.76). Most of it is pm's boundary bias at
        // creases (it averages over a disc that the corner cuts: about -7 % there, rs -4.5 %).
        let (rs_e, pm_e) = (self.error(&self.rs, "edges"), self.error(&self.pm, "edges"));
        assert!(rs_e < 0.85 * pm_e, "rs error near edges {rs_e:.6} is not below 0.85 x pm's {pm_e:.6}\n{t}");
        // Four times the photons lower the rs error (measured 0.51-0.56 over the image).
        let rs4 = self.error(&self.rs4, "image");
        assert!(rs4 < 0.7 * rs, "rs with 4x photons: error {rs4:.6}, not below 0.7 x {rs:.6}\n{t}");
    }
}

#[test]
fn cornell_box_rs_is_more_accurate_than_pm_against_the_path_tracer() {
    let a = Accuracy::measure("cornell-box.usda", |_| vec![]);
    a.check_common();
}

#[test]
fn bumpy_box_rs_is_more_accurate_than_pm_against_the_path_tracer() {
    let a = Accuracy::measure("bumpy-box.usda", |scene| {
        vec![("bumps", object_mask(scene, &["/BumpyFloor"])), ("sphere", object_mask(scene, &["/Sphere"]))]
    });
    a.check_common();
    let t = a.table();
    // The scene exercises topological bias: pm overestimates the bumpy floor relative to the rest
    // of the image (its k-NN disc of area πr² holds photons from a larger, folded surface; measured
    // +5.1 to +5.8 %).
    let pm_topo = a.bias(&a.pm, "bumps") - a.bias(&a.pm, "image");
    assert!(pm_topo > 0.025, "pm does not overestimate the bumps ({pm_topo:+.3}): the scene does not test topological bias\n{t}");
    // rs does not remove it: it underestimates the bumps instead, and its error there is 1.2-1.9 x
    // pm's. Every trough is a small concave corner: lines near an eye sample that would have to
    // cross the bumps upstream carry no photons, yet the kernel is normalised over the full disc;
    // on the crests the feasibility test against light leaks (the ray's closest point before its
    // hit on the eye sample's side of its surface) drops rays passing just beside a convex bump.
    // Measured -6.6 to -7.4 % without that test, -13.2 % (200k) and -12.8 % (800k photons) with it,
    // so it does not shrink with the bandwidth. The test is kept: it stops 99.9 % of the light
    // leaking through zero-thickness walls (tests/extremes.rs). Guard against it getting worse.
    for p in [&a.rs, &a.rs4] {
        let b = a.bias(p, "bumps");
        assert!(b.abs() < 0.16, "{} bias on the bumpy floor {b:+.3}\n{t}", p.name);
    }
}

/// The same scene scaled by 1e-4 and 1e4 gives the same `rs` image: bandwidths are computed in units
/// of the scene radius (path densities, the minimum distance D̃, the pilot's mean segment length) and
/// every epsilon is relative, so the only differences come from the float rounding of the scaled
/// geometry (relative 6e-8 per coordinate), which moves hit points and splat distances by as much.
/// Near the edge of a footprint the Epanechnikov kernel goes to 0 continuously, so an eye sample that
/// flips in or out changes nothing measurable. Measured: relative MSE 1e-12 (beauty) and 2e-12
/// (indirect), mean relative error 1e-6, worst pixel 3e-5, identical photon paths, splat pairs within
/// 5 of 1.17 M. Bounds: relative MSE < 1e-6, mean relative error < 1e-4, every pixel within 5 % —
/// three orders of magnitude below the methods' errors (relative MSE ~1e-3), so any length that does
/// not scale with the scene would show, while a handful of photon paths diverging through a rounding
/// flip of a Russian-roulette or hit/miss decision (one path moves ~20 pixels by ~1 %, relative MSE
/// ~5e-7) would not fail the test.
#[test]
fn rs_is_scale_invariant() {
    let scene = load("cornell-box.usda");
    let s = RenderRequest { method: Some(Method::Rs), photons: Some(50_000), spp: Some(4), seed: 1, resolution: Some(RES), ..Default::default() }.settings().unwrap();
    let base = run(scene.clone(), &s);
    for k in [1e-4f32, 1e4] {
        let out = run(scene.scaled(k), &s);
        for layer in ["", "indirect"] {
            let (t, r) = (out.film.rgb(layer).unwrap(), base.film.rgb(layer).unwrap());
            let m = compare(&t, &r);
            let worst = t.chunks(3).zip(r.chunks(3)).map(|(a, b)| raysplat::image::pixel_relative_error([a[0], a[1], a[2]], [b[0], b[1], b[2]])).fold(0.0, f64::max);
            let what = format!(
                "scale {k:e}, layer {layer:?}: relative MSE {:.2e}, mean relative error {:.2e}, worst pixel {worst:.2e}",
                m.rel_mse, m.mean_rel_error
            );
            eprintln!("{what}");
            assert!(m.rel_mse < 1e-6 && m.mean_rel_error < 1e-4 && worst < 0.05, "{what}");
        }
        // The mean splat radius scales with the scene (the counter is in whole µm: compare at 1e4).
        if k > 1.0 {
            let (a, b) = (out.stats.counter("mean_bandwidth_um").unwrap() as f64 / k as f64, base.stats.counter("mean_bandwidth_um").unwrap() as f64);
            assert!((a / b - 1.0).abs() < 1e-3, "mean bandwidth {a} µm (rescaled) vs {b} µm");
        }
    }
}

/// The caustic under `cornell-glossy`'s glass sphere as `rs` splats it: onto eye samples on a 2 mm
/// grid of the (bumpy) floor around the sphere, the caustic photon rays deposit the flux of the
/// caustic photons that land there — the splat kernel integrates to 1 over a surface, so
/// Σ irradiance × area over the grid is that flux (up to the photons near the window's edge, whose
/// footprints reach across it both ways). Photon rays that end on the sphere must splat nothing:
/// their light is refracted on along the next segment, and their footprints, reaching the floor
/// the sphere stands on, would put the light inside the glass there a second time (2.05 × the
/// landing flux). Measured 0.96 for both seeds (the bumpy floor loses a little of the kernel, see
/// the bumpy-box test); bound ±8 %. About 1.5 s.
#[test]
fn caustic_splats_carry_the_flux_that_lands_under_the_glass_sphere() {
    use glam::Vec3;
    use raysplat::eye::{EyePass, EyeSample, GlossyTable, NO_GLOSSY};
    use raysplat::photon::{trace_photons, PhotonClass, PhotonSettings};
    use raysplat::prepare::PreparedScene;
    use raysplat::sampling::oct_encode;
    let scene = PreparedScene::new(load("cornell-glossy.usda"), 16, 16, 0).expect("prepare");
    // the window: 24 cm square around the sphere's contact with the floor at (0.4, 0, 0.12)
    let (x0, z0, n, cell) = (0.28f32, 0.0f32, 120u32, 0.002f32);
    let inside = |p: Vec3| p.x >= x0 && p.x < x0 + n as f32 * cell && p.z >= z0 && p.z < z0 + n as f32 * cell && p.y.abs() < 0.01;
    // eye samples where vertical rays from below meet the floor, weight 1 (their "radiance" is the
    // irradiance), and the area of floor each one stands for (the cell over the facet's slope)
    let mut samples = Vec::new();
    let mut area = Vec::new();
    for pixel in 0..n * n {
        let (i, j) = (pixel % n, pixel / n);
        let at = Vec3::new(x0 + (i as f32 + 0.5) * cell, -0.02, z0 + (j as f32 + 0.5) * cell);
        let hit = scene.intersect(&raysplat::embree::Ray::new(at, Vec3::Y)).expect("the floor above");
        assert!(hit.p.y.abs() < 0.01, "the ray from below met something else than the floor at {}", hit.p);
        let up = if hit.ng.y >= 0.0 { hit.ng } else { -hit.ng }.normalize();
        samples.push(EyeSample { p: hit.p.to_array(), n: oct_encode(up), weight: [1.0; 3], pixel, glossy: NO_GLOSSY });
        area.push((cell * cell / up.y) as f64);
    }
    let eye = EyePass::of_samples(n, n, samples, GlossyTable::default());
    let k = PhotonClass::Caustic as usize;
    for seed in [1, 2] {
        let set = trace_photons(&scene, &PhotonSettings { budget: [0, 0, 40_000], seed, ..PhotonSettings::default() });
        let landed: f64 = set.rays[k].iter().zip(&set.ends_diffuse[k]).filter(|(r, &d)| d && inside(r.end())).map(|(r, _)| r.flux().element_sum() as f64).sum();
        let on_glass = set.ends_diffuse[k].iter().filter(|&&d| !d).count();
        let img = raysplat::splat::splat(&eye, &[&set.rays[k]]);
        let splatted: f64 = img.radiance.iter().zip(&area).map(|(e, a)| e.element_sum() as f64 * a).sum();
        let ratio = splatted / landed;
        eprintln!("seed {seed}: caustic flux splatted onto the floor {splatted:.5} W, landed {landed:.5} W, ratio {ratio:.3} ({on_glass} of {} caustic photon rays end on the glass)", set.rays[k].len());
        assert!(on_glass > 10_000, "only {on_glass} caustic photon rays end on the glass: the test tests nothing");
        assert!((ratio - 1.0).abs() < 0.08, "seed {seed}: the caustic splat deposits {ratio:.3} × the flux that lands under the sphere");
    }
}
