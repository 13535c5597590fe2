//! Open Image Denoise's behaviour on images whose answer is known, when this build links it
//! (`cfg(raysplat_oidn)`), and what holds in any build. (What a build without it reports is
//! checked in `tests/denoise.rs`, which `make test-no-oidn` runs in that configuration.)

use super::*;

/// A `w × h` RGB image with every pixel `v`.
fn constant(w: u32, h: u32, v: [f32; 3]) -> Vec<f32> {
    (0..w * h).flat_map(|_| v).collect()
}

fn on(quality: Quality) -> Options {
    Options { mode: Mode::On, quality, ..Default::default() }
}

#[test]
fn modes_and_qualities_parse_and_print() {
    for m in [Mode::Off, Mode::Auto, Mode::On] {
        assert_eq!(m.name().parse::<Mode>().unwrap(), m);
    }
    for q in Quality::ALL {
        assert_eq!(q.to_string().parse::<Quality>().unwrap(), q);
    }
    assert!(matches!("yes".parse::<Mode>(), Err(Error::Param { .. })));
    assert!(matches!("best".parse::<Quality>(), Err(Error::Param { .. })));
    assert_eq!(Options::default().mode, Mode::Off);
    // off and auto never refuse a render, whatever the build
    for mode in [Mode::Off, Mode::Auto] {
        Options { mode, ..Default::default() }.validate().unwrap();
    }
}

#[test]
fn buffers_of_the_wrong_size_are_refused() {
    let c = constant(4, 4, [1.0; 3]);
    let short = vec![0.5f32; 3 * 15];
    let e = denoise_rgb(4, 4, &c, Some(&short), None, &on(Quality::Fast), 1).unwrap_err();
    assert!(matches!(&e, Error::Param { message, .. } if message.contains("albedo image has 45 values")), "{e}");
    let e = denoise_rgb(4, 4, &short, None, None, &on(Quality::Fast), 1).unwrap_err();
    assert!(matches!(&e, Error::Param { message, .. } if message.contains("colour image")), "{e}");
}

#[cfg(raysplat_oidn)]
mod with_oidn {
    use super::*;

    /// Deterministic noise in [0, 2): a mean of 1 with the spread of a few-sample render.
    fn noise(n: usize, seed: u32) -> Vec<f32> {
        let mut s = seed.wrapping_mul(0x9e37_79b9) | 1;
        (0..n)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 17;
                s ^= s << 5;
                2.0 * (s >> 8) as f32 / (1u32 << 24) as f32
            })
            .collect()
    }

    /// A film of `w × h` with the beauty (RGBA), albedo and normal layers a render writes.
    fn film(w: u32, h: u32, beauty: &[f32], albedo: [f32; 3], normal: [f32; 3]) -> Film {
        let mut f = Film::new(w, h);
        f.add_layer("", &["R", "G", "B", "A"]);
        for (px, rgb) in f.layer_mut("").unwrap().data.chunks_exact_mut(4).zip(beauty.chunks_exact(3)) {
            px.copy_from_slice(&[rgb[0], rgb[1], rgb[2], 1.0]);
        }
        f.add_layer("albedo", &["R", "G", "B"]);
        f.layer_mut("albedo").unwrap().data = constant(w, h, albedo);
        f.add_layer("normal", &["X", "Y", "Z"]);
        f.layer_mut("normal").unwrap().data = constant(w, h, normal);
        f
    }

    /// A constant image with constant albedo and normal has nothing to remove: every pixel at
    /// least 8 pixels from the border stays at its value within 1.5 % of its brightest channel
    /// (OIDN's precision there, measured: 0.37 % at high quality, 0.59 % at fast, 0.98 % at
    /// balanced for a strongly coloured pixel, with the noisy-aux models; 0.16–0.77 % with the
    /// clean-aux ones). The pixels near the border move more — 13–55 % at the outermost — which
    /// OIDN's own `oidnDenoise` does to the same input too (docs/denoise.md); they are printed,
    /// not asserted.
    #[test]
    fn a_constant_image_stays_constant() {
        let (w, h) = (64, 48);
        for clean_aux in [false, true] {
            for (v, quality) in [([0.3f32, 0.5, 0.7], Quality::High), ([2.0, 2.0, 2.0], Quality::Fast), ([40.0, 5.0, 0.25], Quality::Balanced)] {
                let options = Options { clean_aux, ..on(quality) };
                let out = denoise_rgb(w, h, &constant(w, h, v), Some(&constant(w, h, [0.5; 3])), Some(&constant(w, h, [0.0, 0.0, 1.0])), &options, 0).unwrap();
                let scale = v.iter().fold(0.0f32, |m, &c| m.max(c));
                let (mut inner, mut border) = (0.0f32, 0.0f32);
                for (i, p) in out.chunks_exact(3).enumerate() {
                    let (x, y) = (i as u32 % w, i as u32 / w);
                    let d = (0..3).map(|c| (p[c] - v[c]).abs() / scale).fold(0.0f32, f32::max);
                    if x.min(y).min(w - 1 - x).min(h - 1 - y) >= 8 {
                        inner = inner.max(d);
                    } else {
                        border = border.max(d);
                    }
                }
                eprintln!("constant {v:?}, {quality}, clean aux {clean_aux}: largest deviation {inner:.2e} inside, {border:.2e} within 8 px of the border (of the brightest channel)");
                assert!(inner < 0.015, "constant {v:?} at {quality}, clean aux {clean_aux}: a pixel moved by {inner} of its brightest channel");
            }
        }
    }

    /// Noise around a constant is pulled toward it.
    #[test]
    fn noise_around_a_constant_shrinks() {
        let (w, h) = (64, 64);
        let n = (w * h * 3) as usize;
        let grey: Vec<f32> = noise(n / 3, 7).into_iter().flat_map(|v| [v; 3]).collect();
        let rms = |img: &[f32]| (img.iter().map(|v| (v - 1.0).powi(2)).sum::<f32>() / img.len() as f32).sqrt();
        let out = denoise_rgb(w, h, &grey, Some(&constant(w, h, [0.8; 3])), Some(&constant(w, h, [0.0, 1.0, 0.0])), &on(Quality::High), 0).unwrap();
        let (before, after) = (rms(&grey), rms(&out));
        eprintln!("noise around 1: rms {before:.4} -> {after:.4}");
        assert!(after < 0.25 * before, "rms {before} -> {after}");
    }

    #[test]
    fn the_image_does_not_depend_on_the_thread_count() {
        let (w, h) = (40, 32);
        let n = (w * h * 3) as usize;
        let color = noise(n, 3);
        let albedo: Vec<f32> = noise(n, 4).iter().map(|v| v * 0.5).collect();
        let normal = constant(w, h, [0.0, 0.0, 1.0]);
        let one = denoise_rgb(w, h, &color, Some(&albedo), Some(&normal), &on(Quality::High), 1).unwrap();
        let two = denoise_rgb(w, h, &color, Some(&albedo), Some(&normal), &on(Quality::High), 2).unwrap();
        assert!(one.iter().zip(&two).all(|(a, b)| a.to_bits() == b.to_bits()), "1 and 2 threads differ");
    }

    #[test]
    fn the_raw_beauty_is_kept_and_a_second_denoise_starts_from_it() {
        let (w, h) = (32, 24);
        let color = noise((w * h * 3) as usize, 11);
        let mut f = film(w, h, &color, [0.6, 0.5, 0.4], [0.0, 0.0, 1.0]);
        f.layer_mut("").unwrap().data.chunks_exact_mut(4).for_each(|p| p[3] = 0.75);
        let before = f.layer("").unwrap().clone();
        let report = denoise_film(&mut f, &on(Quality::Fast), 0).unwrap();
        assert_eq!((report.aux, report.from_raw), ("albedo + normal", false));
        let raw = f.layer(RAW_LAYER).unwrap();
        assert_eq!((&raw.channels, &raw.data), (&before.channels, &before.data), "raw layer = the beauty as rendered");
        let first = f.layer("").unwrap().clone();
        assert!(first.data.chunks_exact(4).all(|p| p[3] == 0.75), "alpha is kept");
        assert_ne!(first.data, before.data);
        let again = denoise_film(&mut f, &on(Quality::Fast), 0).unwrap();
        assert!(again.from_raw);
        assert_eq!(f.layer("").unwrap().data, first.data, "denoising twice = denoising the raw beauty once");
        assert_eq!(f.layers.iter().filter(|l| l.name == RAW_LAYER).count(), 1);
    }

    /// Non-finite and negative colours would spread through the filter's convolutions: they go in as 0.
    #[test]
    fn non_finite_inputs_give_a_finite_image() {
        let (w, h) = (16, 16);
        let mut color = constant(w, h, [1.0; 3]);
        color[30] = f32::NAN;
        color[31] = f32::INFINITY;
        color[90] = -5.0;
        let out = denoise_rgb(w, h, &color, None, None, &on(Quality::Fast), 0).unwrap();
        assert!(out.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn a_film_without_aux_layers_is_denoised_on_colour_alone() {
        let (w, h) = (16, 16);
        let mut f = Film::new(w, h);
        f.add_layer("", &["R", "G", "B", "A"]);
        f.layer_mut("").unwrap().data = (0..w * h).flat_map(|_| [1.0, 1.0, 1.0, 1.0]).collect();
        assert_eq!(denoise_film(&mut f, &on(Quality::Fast), 0).unwrap().aux, "none");
        let mut bad = Film::new(w, h);
        bad.add_layer("depth", &["Z"]);
        assert!(matches!(denoise_film(&mut bad, &on(Quality::Fast), 0), Err(Error::Image { .. })));
    }
}
