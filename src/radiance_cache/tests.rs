use super::*;
use crate::eye::{EyeSample, NO_GLOSSY};
use crate::sampling::oct_encode;

/// `n` photon rays (hash tag `tag`) falling onto the plane z = 0 from 0.3–1.3 above it, from
/// over `[−0.05, span[0] − 0.05] × [−0.05, span[1] − 0.05]`, ending 0.01 above it, with kernel radii
/// 0.03–0.08 growing by up to `dh_max` per unit length.
fn rays_onto_plane(tag: u64, n: usize, span: [f32; 2], dh_max: f32) -> Vec<PhotonRay> {
    use crate::sampling::{hash, Rng};
    (0..n)
        .map(|i| {
            let mut r = Rng::new(hash(&[tag, i as u64]), 0);
            let o = Vec3::new(r.next_f32() * span[0] - 0.05, r.next_f32() * span[1] - 0.05, 0.3 + r.next_f32());
            let d = Vec3::new(r.next_f32() - 0.5, r.next_f32() - 0.5, -1.0).normalize();
            let mut ray = PhotonRay::new(o, d, (o.z - 0.01) / -d.z, Vec3::new(1.0, 0.5, 0.2) * r.next_f32(), -Vec3::Z, Vec3::Z);
            (ray.h0, ray.dh) = (0.03 + 0.05 * r.next_f32(), dh_max * r.next_f32());
            ray
        })
        .collect()
}

/// Pixel 0 holds two eye samples on perpendicular surfaces (A faces +z, B faces +x, as at a
/// block's foot); pixel 1 holds a copy of A alone. One photon ray reaches A from behind B, so B
/// receives nothing from it. Pixel 0 must equal pixel 1: B may not integrate the coefficients of
/// its pixel's records, which describe A's surface (it received A's light before: 2× pixel 1).
#[test]
fn samples_off_their_pixels_surface_get_their_own_coefficients() {
    let sample = |p: Vec3, n: Vec3, pixel: u32| EyeSample { p: p.to_array(), n: oct_encode(n), weight: [1.0; 3], pixel, glossy: NO_GLOSSY };
    let (a, b) = (Vec3::ZERO, Vec3::new(0.002, 0.0, 0.002));
    let mut eye = EyePass::of_samples(2, 1, vec![sample(a, Vec3::Z, 0), sample(b, Vec3::X, 0), sample(a, Vec3::Z, 1)], Default::default());
    (eye.depth, eye.normal) = (vec![1.0; 2], vec![Vec3::Z; 2]);
    let wi = Vec3::new(-0.6, 0.0, 0.8); // toward the photon's origin: behind B
    let mut ray = PhotonRay::new(a + wi, -wi, 1.0, Vec3::splat(1e-3), -wi, Vec3::Z);
    (ray.h0, ray.dh) = (0.05, 0.0);
    let rays = [ray];
    let tables = crate::radiance_map::ShTables::build(&eye.glossy);
    let out = render(&eye, &[&rays], &[], &View { pixel_size: &|_| 1.0, raster: &|_| None }, &CacheParams::default(), &Integrated { tables: &tables, cached: &[] }, &|| false).unwrap();
    let (p0, p1) = (out.radiance[0].x, out.radiance[1].x);
    assert_eq!(out.off_surface_samples, 1);
    assert!(p1 > 0.0 && ((p0 - p1) / p1).abs() < 1e-4, "pixel with A and B {p0}, A alone {p1}");
}

/// An edge pixel's sample on the other surface takes the coefficients of the neighbouring
/// pixel whose first sample is on that surface: pixel 0 sees surface B (facing +x), pixel 1
/// sees A (facing about +z) first and then B, pixel 2 sees A. One photon ray lights B only.
/// Pixel 1 must receive exactly pixel 0's light (splatted at its own position, its kernel
/// weight would differ by 2e-4), pixel 2 none.
#[test]
fn edge_samples_take_the_neighbouring_pixel_on_their_surface() {
    let sample = |p: [f32; 3], n: Vec3, pixel: u32| EyeSample { p, n: oct_encode(n), weight: [1.0; 3], pixel, glossy: NO_GLOSSY };
    // A leans away from the photon a little (exactly +z could decode to a front-facing normal)
    let a = Vec3::new(-0.1, 0.0, 1.0).normalize();
    let samples = vec![
        sample([-0.001, 0.0, 0.003], Vec3::X, 0),
        sample([0.0, 0.0, 0.0], a, 1),
        sample([-0.001, 0.0, 0.002], Vec3::X, 1),
        sample([0.002, 0.0, 0.0002], a, 2),
    ];
    let mut eye = EyePass::of_samples(3, 1, samples, Default::default());
    (eye.depth, eye.normal) = (vec![1.0; 3], vec![Vec3::X, a, a]);
    let dir = -Vec3::X;
    let mut ray = PhotonRay::new(Vec3::new(0.999, 0.0, 0.0028), dir, 1.0, Vec3::splat(1e-3), dir, Vec3::X);
    (ray.h0, ray.dh) = (0.05, 0.0);
    let rays = [ray];
    let tables = crate::radiance_map::ShTables::build(&eye.glossy);
    let out = render(&eye, &[&rays], &[], &View { pixel_size: &|_| 1.0, raster: &|_| None }, &CacheParams::default(), &Integrated { tables: &tables, cached: &[] }, &|| false).unwrap();
    assert_eq!((out.neighbour_samples, out.off_surface_samples), (1, 0));
    let (p0, p1, p2) = (out.radiance[0].x, out.radiance[1].x, out.radiance[2].x);
    assert!(p0 > 0.0 && ((p1 - p0) / p0).abs() < 1e-6, "pixel 0 {p0}, pixel 1 {p1}");
    assert_eq!(p2, 0.0);
}

/// A sample seen through a lens (a second sample of pixel 0 that lands where pixel 9 sees the
/// plane directly, far from pixel 0 and its neighbours) takes the coefficients of the pixel where
/// its point is seen directly, found by projecting it into the image: pixel 0 then gains exactly
/// pixel 9's light. Without a projection it is splatted at its own position.
#[test]
fn samples_seen_through_a_lens_take_the_pixel_where_their_point_is_seen() {
    const PITCH: f32 = 0.05;
    let (w, h) = (12u32, 3u32);
    let first = |p: u32| EyeSample { p: [(p % w) as f32 * PITCH, (p / w) as f32 * PITCH, 0.0], n: oct_encode(Vec3::Z), weight: [1.0; 3], pixel: p, glossy: NO_GLOSSY };
    let mut lens = first(9);
    (lens.p[0], lens.pixel) = (lens.p[0] + 0.1 * PITCH, 0);
    let image = |with_lens: bool| {
        let mut samples: Vec<EyeSample> = (0..w * h).map(first).collect();
        if with_lens {
            samples.insert(1, lens);
        }
        let mut eye = EyePass::of_samples(w, h, samples, Default::default());
        (eye.depth, eye.normal) = (vec![1.0; (w * h) as usize], vec![Vec3::Z; (w * h) as usize]);
        eye
    };
    let rays = rays_onto_plane(23, 2000, [0.7, 0.2], 0.0);
    let raster = |p: Vec3| Some(glam::Vec2::new(p.x / PITCH + 0.5, p.y / PITCH + 0.5));
    let run = |eye: &EyePass, raster: &(dyn Fn(Vec3) -> Option<glam::Vec2> + Sync)| {
        let tables = crate::radiance_map::ShTables::build(&eye.glossy);
        render(eye, &[&rays], &[], &View { pixel_size: &|_| PITCH, raster }, &CacheParams::default(), &Integrated { tables: &tables, cached: &[] }, &|| false).unwrap()
    };
    let (with, without) = (run(&image(true), &raster), run(&image(false), &raster));
    assert_eq!((with.neighbour_samples, with.off_surface_samples), (1, 0));
    let (gain, p9) = (with.radiance[0] - without.radiance[0], with.radiance[9]);
    assert!(p9.x > 0.0 && ((gain - p9).abs() / p9).max_element() < 1e-5, "pixel 0 gained {gain}, pixel 9 holds {p9}");
    assert_eq!(with.radiance[9], without.radiance[9]);
    let blind = run(&image(true), &|_| None);
    assert_eq!((blind.neighbour_samples, blind.off_surface_samples), (0, 1));
}

/// Photon rays on a grid of spacing 1 reach one record per pixel, at its first eye sample, and
/// are not extrapolated: with one Lambertian eye sample per pixel (and no cached rays), every
/// pixel receives what the tiled splatting of `rs` gives it.
#[test]
fn pixel_records_receive_what_rs_gives_each_pixel() {
    let (w, h) = (16u32, 12u32);
    let samples = (0..w * h)
        .map(|p| {
            let (x, y) = ((p % w) as f32 * 0.05, (p / w) as f32 * 0.05);
            EyeSample { p: [x, y, 0.004 * (x * 40.0).sin()], n: oct_encode(Vec3::Z), weight: [1.0; 3], pixel: p, glossy: NO_GLOSSY }
        })
        .collect();
    let mut eye = EyePass::of_samples(w, h, samples, Default::default());
    (eye.depth, eye.normal) = (vec![1.0; (w * h) as usize], vec![Vec3::Z; (w * h) as usize]);
    let rays = rays_onto_plane(21, 3000, [0.9, 0.7], 0.01);
    let tables = crate::radiance_map::ShTables::build(&eye.glossy);
    let out = render(&eye, &[], &[(&rays, 1)], &View { pixel_size: &|_| 0.05, raster: &|_| None }, &CacheParams::default(), &Integrated { tables: &tables, cached: &[] }, &|| false).unwrap();
    let tiled = crate::splat::splat(&eye, &[&rays]);
    assert_eq!(out.grid_records, (w * h) as usize);
    assert_eq!(out.pairs, tiled.pairs);
    assert!(tiled.pairs > 5000, "too few pairs to mean anything: {}", tiled.pairs);
    for (p, (a, b)) in out.radiance.iter().zip(&tiled.radiance).enumerate() {
        assert!((*a - *b).abs().max_element() <= 1e-4 * (1.0 + b.max_element()), "pixel {p}: {a} vs {b}");
    }
}

/// Splatting the later passes' candidates in one traversal places the same records with the
/// same sums as a traversal per pass: two planes at different depths (a discontinuity along
/// which the first pass leaves pixels under-covered), photons onto both.
#[test]
fn later_passes_splatted_together_give_the_same_records() {
    use crate::sampling::{hash, Rng};
    let (w, h) = (48u32, 32u32);
    let z = |p: u32| if (p % w) * 3 < w + (p / w) { -0.4 } else { 0.0 };
    let samples = (0..w * h).map(|p| EyeSample { p: [(p % w) as f32 * 0.02, (p / w) as f32 * 0.02, z(p)], n: oct_encode(Vec3::Z), weight: [1.0; 3], pixel: p, glossy: NO_GLOSSY }).collect();
    let mut eye = EyePass::of_samples(w, h, samples, Default::default());
    eye.depth = (0..w * h).map(|p| 1.0 - z(p)).collect();
    eye.normal = vec![Vec3::Z; (w * h) as usize];
    let rays: Vec<PhotonRay> = (0..4000)
        .map(|i| {
            let mut r = Rng::new(hash(&[23, i as u64]), 0);
            let target = Vec3::new(r.next_f32() * 0.96, r.next_f32() * 0.64, if r.next_f32() < 0.5 { -0.4 } else { 0.0 });
            let d = Vec3::new(r.next_f32() - 0.5, r.next_f32() - 0.5, -1.0).normalize();
            let mut ray = PhotonRay::new(target - d * 0.3, d, 0.3, Vec3::splat(r.next_f32()), -Vec3::Z, Vec3::Z);
            (ray.h0, ray.dh) = (0.03 + 0.03 * r.next_f32(), 0.0);
            ray
        })
        .collect();
    let tables = crate::radiance_map::ShTables::build(&eye.glossy);
    let run = |together| {
        let p = CacheParams { error: 0.3, refine_together_max: together, ..CacheParams::default() };
        render(&eye, &[&rays], &[], &View { pixel_size: &|_| 0.02, raster: &|_| None }, &p, &Integrated { tables: &tables, cached: &[] }, &|| false).unwrap()
    };
    let (apart, joint) = (run(0), run(usize::MAX));
    assert!(apart.passes >= 3, "only {} passes placed records", apart.passes);
    assert_eq!((joint.records, joint.passes), (apart.records, apart.passes));
    assert!(joint.radiance == apart.radiance, "the images differ");
}

/// A plane lit on its left half only (a shadow line at x = 24 px; photons from far away, so
/// the records' harmonic distance gives them the largest radius): the lit records disagree
/// with the dark ones and stop at them, so the shadow stays dark beyond a record spacing from
/// the line. Without the limit the lit records reach 24 px into it.
#[test]
fn records_do_not_carry_light_across_a_shadow_line() {
    use crate::sampling::{hash, Rng};
    let (w, h) = (64u32, 32u32);
    let samples = (0..w * h).map(|p| EyeSample { p: [(p % w) as f32 * 0.02, (p / w) as f32 * 0.02, 0.0], n: oct_encode(Vec3::Z), weight: [1.0; 3], pixel: p, glossy: NO_GLOSSY }).collect();
    let mut eye = EyePass::of_samples(w, h, samples, Default::default());
    (eye.depth, eye.normal) = (vec![1.0; (w * h) as usize], vec![Vec3::Z; (w * h) as usize]);
    let rays: Vec<PhotonRay> = (0..20000)
        .map(|i| {
            let mut r = Rng::new(hash(&[29, i as u64]), 0);
            let target = Vec3::new(r.next_f32() * 0.47, r.next_f32() * 0.64, 0.0);
            let d = Vec3::new(0.2 * (r.next_f32() - 0.5), 0.2 * (r.next_f32() - 0.5), -1.0).normalize();
            let mut ray = PhotonRay::new(target - d * 20.0, d, 20.0, Vec3::splat(1e-3), -Vec3::Z, Vec3::Z);
            (ray.h0, ray.dh) = (0.02, 0.0);
            ray
        })
        .collect();
    let tables = crate::radiance_map::ShTables::build(&eye.glossy);
    let out = render(&eye, &[&rays], &[], &View { pixel_size: &|_| 0.02, raster: &|_| None }, &CacheParams::default(), &Integrated { tables: &tables, cached: &[] }, &|| false).unwrap();
    let mean = |x0: u32, x1: u32| {
        let px: Vec<usize> = (0..w * h).filter(|p| (x0..x1).contains(&(p % w))).map(|p| p as usize).collect();
        px.iter().map(|&p| out.radiance[p].x).sum::<f32>() / px.len() as f32
    };
    let (lit, shadow) = (mean(0, 20), mean(34, 64));
    assert!(lit > 0.0);
    assert!(shadow < 1e-3 * lit, "the shadow 10+ px from the line receives {shadow}, the lit side {lit}");
}

/// A half cylinder seen from above (its axis along the image's rows; the columns' normals turn
/// from −75° to 75° about +z), lit by parallel photons falling along −z from far away (so every
/// record has the largest radius, 24 px, i.e. 37° of the cylinder): its irradiance is
/// `ρ Φ cos θ` exactly, ρ the photons per unit area across their direction. Records that
/// reached every pixel of their radius carried the top's light towards the rim; the normal
/// term keeps the columns' means closer to the cosine law. (The rim beyond the last column of
/// records is extrapolated from one side, and the radius limit already cuts the records
/// where they differ by a quarter: the gain is a quarter of the error, not all of it.)
#[test]
fn records_reach_less_where_the_normal_turns() {
    use crate::sampling::{hash, Rng};
    let (w, h) = (96u32, 16u32);
    let theta = |x: u32| ((x as f32 + 0.5) / w as f32 * 150.0 - 75.0).to_radians();
    let step = 150f32.to_radians() / w as f32; // arc length per column on the unit cylinder
    let samples = (0..w * h)
        .map(|p| {
            let (t, y) = (theta(p % w), (p / w) as f32 * step);
            EyeSample { p: [t.sin(), y, t.cos()], n: oct_encode(Vec3::new(t.sin(), 0.0, t.cos())), weight: [1.0; 3], pixel: p, glossy: NO_GLOSSY }
        })
        .collect();
    let mut eye = EyePass::of_samples(w, h, samples, Default::default());
    eye.depth = vec![1.0; (w * h) as usize];
    eye.normal = (0..w * h).map(|p| Vec3::new(theta(p % w).sin(), 0.0, theta(p % w).cos())).collect();
    // rays over x ∈ [−1, 1] and beyond the image's rows by 4 kernel radii: no pixel's kernel
    // is cut by the edge of the photons
    let (n_rays, kernel, flux) = (160_000usize, 0.05f32, 1e-3f32);
    let (y0, y1) = (-4.0 * kernel, (h - 1) as f32 * step + 4.0 * kernel);
    let rays: Vec<PhotonRay> = (0..n_rays)
        .map(|i| {
            let mut r = Rng::new(hash(&[31, i as u64]), 0);
            let (x, y) = (2.0 * r.next_f32() - 1.0, y0 + (y1 - y0) * r.next_f32());
            let z = (1.0 - x * x).max(0.0).sqrt();
            let mut ray = PhotonRay::new(Vec3::new(x, y, 20.0), -Vec3::Z, 20.0 - z, Vec3::splat(flux), -Vec3::Z, Vec3::new(x, 0.0, z));
            (ray.h0, ray.dh) = (kernel, 0.0);
            ray
        })
        .collect();
    let density = n_rays as f32 / (2.0 * (y1 - y0));
    let tables = crate::radiance_map::ShTables::build(&eye.glossy);
    let column_errors = |normal_weight: f32| {
        let p = CacheParams { normal_weight, ..CacheParams::default() };
        let out = render(&eye, &[&rays], &[], &View { pixel_size: &|_| step, raster: &|_| None }, &p, &Integrated { tables: &tables, cached: &[] }, &|| false).unwrap();
        (0..w)
            .map(|x| {
                let mean = (0..h).map(|y| out.radiance[(y * w + x) as usize].x).sum::<f32>() / h as f32;
                let exact = density * flux * theta(x).cos();
                (mean - exact) / exact
            })
            .collect::<Vec<f32>>()
    };
    let worst = |e: &[f32]| e.iter().fold(0.0f32, |m, e| m.max(e.abs()));
    let mean = |e: &[f32]| e.iter().map(|e| e.abs()).sum::<f32>() / e.len() as f32;
    let (with, without) = (column_errors(NORMAL_WEIGHT), column_errors(0.0));
    // the columns' mean and worst relative errors (measured: 0.032 and 0.31 with the normal
    // term, 0.042 and 0.43 without; 160 000 photons leave ~1 % of noise in a column's mean)
    assert!(mean(&with) < 0.04, "mean column error {} with the normal term", mean(&with));
    assert!(mean(&with) < 0.85 * mean(&without), "mean column error {} with the normal term, {} without", mean(&with), mean(&without));
    assert!(worst(&with) < 0.85 * worst(&without), "worst column error {} with the normal term, {} without", worst(&with), worst(&without));
}

/// The row-parallel scatter of records gives each pixel what a gather over its neighbourhood
/// gives (the same records, summed in the same order: bit for bit), for any thread count.
#[test]
fn extrapolation_equals_a_gather_over_each_pixels_neighbourhood() {
    use crate::sampling::{hash, Rng};
    let (w, h) = (37usize, 23usize);
    let mut r = Rng::new(hash(&[5, 7]), 0);
    // two segments split by a diagonal, a few pixels without a surface
    let label: Vec<u32> = (0..w * h).map(|q| if q % 53 == 0 { u32::MAX } else { ((q % w) * 2 > q / w * 3) as u32 }).collect();
    let first: Vec<u32> = (0..w * h).map(|q| if q % 41 == 0 { u32::MAX } else { q as u32 }).collect();
    // normals within ~70° of +z, so the normal term removes some records from some pixels
    let normal: Vec<Vec3> = (0..w * h).map(|_| Vec3::new(2.0 * r.next_f32() - 1.0, 2.0 * r.next_f32() - 1.0, 1.0).normalize()).collect();
    let mut rec_pixel: Vec<u32> = (0..w * h as usize).filter(|_| r.next_f32() < 0.08).map(|q| q as u32).collect();
    rec_pixel.reverse(); // records need not come in pixel order
    let rec_radius: Vec<f32> = rec_pixel.iter().map(|_| 1.0 + 9.0 * r.next_f32()).collect();
    let rec_coeffs: Vec<[Vec3; sh::N]> = rec_pixel.iter().map(|_| std::array::from_fn(|_| Vec3::new(r.next_f32(), r.next_f32(), r.next_f32()))).collect();
    let mut rec_at = vec![u32::MAX; w * h];
    for (k, &px) in rec_pixel.iter().enumerate() {
        rec_at[px as usize] = k as u32;
    }
    let gather = |q: usize| {
        let mut acc = [Vec3::ZERO; sh::N];
        if first[q] == u32::MAX || label[q] == u32::MAX {
            return (acc, 0);
        }
        let (x0, y0, mut wsum) = (q % w, q / w, 0.0f32);
        let mut turned = 0usize;
        for y in 0..h {
            for x in 0..w {
                let k = rec_at[y * w + x];
                if k == u32::MAX || label[y * w + x] != label[q] {
                    continue;
                }
                let d = ((x as f32 - x0 as f32).powi(2) + (y as f32 - y0 as f32).powi(2)).sqrt();
                let rad = rec_radius[k as usize];
                let wt = reach(d, rad, normal[q].dot(normal[y * w + x]), NORMAL_WEIGHT);
                if d < rad && wt > 0.0 {
                    wsum += wt;
                    for (a, c) in acc.iter_mut().zip(&rec_coeffs[k as usize]) {
                        *a += *c * wt;
                    }
                } else if d < rad {
                    turned += 1;
                }
            }
        }
        if wsum > 0.0 {
            acc.iter_mut().for_each(|a| *a /= wsum);
        }
        (acc, turned)
    };
    let (expected, turned): (Vec<[Vec3; sh::N]>, Vec<usize>) = (0..w * h).map(gather).unzip();
    assert!(expected.iter().filter(|c| c[0] != Vec3::ZERO).count() > w * h / 2, "too few covered pixels to mean anything");
    assert!(turned.iter().sum::<usize>() > w * h / 4, "too few records turned away by their normals to mean anything");
    for threads in [1, 3] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let eye = EyePass::of_samples(w as u32, h as u32, Vec::new(), Default::default());
        let surface = grid::ImageSurface { eye: &eye, first: &first, label: &label, normal: &normal, pixel_size: &|_| 1.0 };
        let ex = Extrapolation::new(&surface, NORMAL_WEIGHT, &rec_pixel, &rec_radius, &rec_coeffs);
        let mut got = vec![[Vec3::ZERO; sh::N]; w * h];
        pool.install(|| got.par_chunks_mut(w).enumerate().for_each(|(y, row)| ex.row(y, row, &mut vec![0.0; w])));
        assert!(got == expected, "{threads} threads");
    }
}
