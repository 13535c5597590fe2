//! Pixel reconstruction filters through the path tracer: determinism across thread counts, the
//! noise a wide filter removes, the photon methods' filtered eye pass, the header attributes.

mod common;

use common::*;
use raysplat::image::{FilterKind, Film, PixelFilter};
use raysplat::integrators::{render, Method, MethodSettings, RenderSettings, SilentProgress};

fn pt(filter: PixelFilter, spp: u32, threads: usize, size: [u32; 2]) -> Film {
    let s = RenderSettings { spp, threads, seed: 5, resolution: Some(size), filter, ..Default::default() };
    render(furnace(0.7, 1.0), &s, &SilentProgress).expect("render").film
}

fn bits(f: &Film, layer: &str) -> Vec<u32> {
    f.layer(layer).unwrap().data.iter().map(|v| v.to_bits()).collect()
}

/// Every filter's image is the same bit for bit on 1, 2 and 3 threads (40×36: tiles of 16 pixels
/// leave borders inside the image in both directions).
#[test]
fn filtered_image_is_bit_identical_for_any_thread_count() {
    for kind in FilterKind::ALL {
        let f = PixelFilter::new(kind, Some(1.6)).unwrap();
        let one = pt(f, 2, 1, [40, 36]);
        for threads in [2, 3] {
            let other = pt(f, 2, threads, [40, 36]);
            for layer in ["", "direct", "indirect", "albedo"] {
                assert!(bits(&one, layer) == bits(&other, layer), "{} layer {layer:?}: 1 vs {threads} threads", f.describe());
            }
        }
    }
}

/// The furnace is constant in expectation, so a pixel's spread is its noise: a Gaussian of σ = ½
/// pixel averages about π pixels' worth of samples, so its variance is near a third of the box's.
/// Both keep the furnace's value in the mean.
#[test]
fn gaussian_has_a_fraction_of_the_box_noise_and_the_same_mean() {
    let spread = |f: &Film| {
        let rgb = f.rgb("").unwrap();
        let n = (rgb.len() / 3) as f64;
        let mean = rgb.chunks(3).map(|c| c[0] as f64).sum::<f64>() / n;
        let var = rgb.chunks(3).map(|c| (c[0] as f64 - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (mean, var)
    };
    let (box_mean, box_var) = spread(&pt(PixelFilter::BOX, 16, 0, [32, 32]));
    let (g_mean, g_var) = spread(&pt(PixelFilter::new(FilterKind::Gaussian, None).unwrap(), 16, 0, [32, 32]));
    let expected = 1.0 / (1.0 - 0.7);
    assert!((box_mean - expected).abs() < 0.02 * expected && (g_mean - expected).abs() < 0.02 * expected, "means {box_mean} {g_mean} vs {expected}");
    assert!(g_var < 0.5 * box_var, "gaussian variance {g_var} vs box {box_var}");
}

/// The photon methods sample the filter in their eye pass: the furnace keeps its value, and the
/// image is the same on 1 and 3 threads.
#[test]
fn photon_methods_take_the_filter() {
    let expected = 1.0 / (1.0 - 0.7);
    for method in [Method::Rs, Method::Pm] {
        for kind in [FilterKind::Gaussian, FilterKind::Mitchell] {
            let f = PixelFilter::new(kind, None).unwrap();
            let run = |threads| {
                let mut s = RenderSettings { spp: 4, threads, seed: 3, resolution: Some([20, 20]), filter: f, ..RenderSettings::of(method) };
                if let MethodSettings::Rs(r) = &mut s.method {
                    r.pass.photons = 20_000;
                }
                if let MethodSettings::Pm(p) = &mut s.method {
                    p.pass.photons = 20_000;
                }
                render(furnace(0.7, 1.0), &s, &SilentProgress).expect("render").film
            };
            let (one, three) = (run(1), run(3));
            assert!(bits(&one, "") == bits(&three, ""), "{method} {}: 1 vs 3 threads", f.describe());
            let mean = mean_rgb(&one).x as f64;
            assert!((mean - expected).abs() < 0.05 * expected, "{method} {}: mean {mean} vs {expected}", f.describe());
        }
    }
}

/// The header records the filter.
#[test]
fn filter_is_recorded() {
    let gaussian = PixelFilter::new(FilterKind::Gaussian, None).unwrap();
    let s = RenderSettings { filter: gaussian, method: MethodSettings::Pt, ..Default::default() };
    s.validate().unwrap();
    let attrs = s.attributes();
    assert!(attrs.contains(&("raysplat:pixel_filter".into(), "gaussian".into())), "{attrs:?}");
    assert!(attrs.contains(&("raysplat:pixel_filter_radius".into(), "2".into())), "{attrs:?}");
}
