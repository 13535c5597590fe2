//! Denoising renders (`--denoise`, `raysplat denoise`): a noisy furnace room comes out closer to its
//! exact value, the raw layer is the render without denoising bit for bit, and a build without
//! Open Image Denoise says so instead of rendering something else. Every test checks whichever
//! configuration the build has; `make test-no-oidn` runs them without the library (the command
//! line's side: `cli/tests/denoise.rs`).

mod common;

use common::*;
use raysplat::denoise::{self, Mode, Options, Quality, RAW_LAYER};
use raysplat::integrators::{render, Method, MethodSettings, RenderSettings, SilentProgress};

/// The build links the library exactly when `OIDN_LIB_DIR` names it, and says so; without it every
/// entry point refuses with the reason and how to get the denoiser, and changes nothing.
#[test]
fn the_build_says_whether_it_has_the_denoiser() {
    let on = Options { mode: Mode::On, ..Default::default() };
    if !denoise::OIDN_LIB_DIR.is_empty() {
        let denoise::Status::Available(v) = denoise::status() else { panic!("linked from {} but unavailable: {:?}", denoise::OIDN_LIB_DIR, denoise::status()) };
        assert!(v.starts_with("2."), "version {v}");
        assert!(denoise::seconds_per_pixel(Quality::Fast, 0).is_some_and(|s| s > 0.0 && s.is_finite()));
        on.validate().unwrap();
        eprintln!("Open Image Denoise {v} from {}", denoise::OIDN_LIB_DIR);
        return;
    }
    let denoise::Status::Unavailable(why) = denoise::status() else { panic!("not linked, but reported available") };
    assert!(why.contains("make setup") && why.contains("RAYSPLAT_OIDN"), "{why}");
    assert!(!denoise::available());
    assert_eq!(denoise::seconds_per_pixel(Quality::High, 0), None);
    assert!(on.validate().unwrap_err().to_string().contains("the denoiser is unavailable"));
    let rgb = vec![1.0f32; 4 * 4 * 3];
    assert!(matches!(denoise::denoise_rgb(4, 4, &rgb, None, None, &on, 1), Err(raysplat::Error::Param { .. })));
    let mut film = render(furnace(0.5, 1.0), &settings(Method::Pt, 1, Mode::Off), &SilentProgress).unwrap().film;
    let before = film.clone();
    assert!(denoise::denoise_film(&mut film, &on, 1).is_err());
    assert_eq!(film, before, "a refused denoise leaves the film as it was");
    eprintln!("no denoiser in this build: {why}");
}

fn settings(method: Method, spp: u32, mode: Mode) -> RenderSettings {
    let mut s = RenderSettings {
        method: MethodSettings::of(method),
        spp,
        seed: 3,
        resolution: Some([48, 40]),
        denoise: Options { mode, quality: Quality::High, ..Default::default() },
        ..Default::default()
    };
    if let Some(pass) = s.method.photon_pass_mut() {
        pass.photons = 5000;
    }
    s
}

/// RMS distance of layer `layer`'s R, G, B from `value`.
fn rms_from(film: &raysplat::image::Film, layer: &str, value: f32) -> f32 {
    let rgb = film.rgb(layer).unwrap();
    (rgb.iter().map(|v| (v - value).powi(2)).sum::<f32>() / rgb.len() as f32).sqrt()
}

/// Furnace: every wall emits 1 and reflects 0.5, so every pixel is exactly 1 / (1 − 0.5) = 2.
#[test]
fn a_noisy_furnace_room_denoised_is_closer_to_its_exact_value() {
    let s = settings(Method::Pt, 2, Mode::On);
    if !denoise::available() {
        let e = render(furnace(0.5, 1.0), &s, &SilentProgress).err().expect("--denoise on without the denoiser is refused");
        assert!(e.to_string().contains("the denoiser is unavailable"), "{e}");
        eprintln!("no denoiser in this build ({:?}): checked that --denoise on is refused", denoise::status());
        return;
    }
    let out = render(furnace(0.5, 1.0), &s, &SilentProgress).unwrap();
    let (raw, denoised) = (rms_from(&out.film, RAW_LAYER, 2.0), rms_from(&out.film, "", 2.0));
    eprintln!("furnace at 2 spp: rms error {raw:.4} as rendered, {denoised:.4} denoised");
    assert!(raw > 0.05, "the render should be noisy (rms {raw})");
    assert!(denoised < 0.2 * raw, "denoised rms {denoised} vs raw {raw}");
    assert!(out.stats.phase_seconds("denoise").is_some());
    assert!(out.stats.notes.iter().any(|n| n.starts_with("denoised with Open Image Denoise")), "{:?}", out.stats.notes);
}

/// The raw layer is the image the same render gives without `--denoise`, for the path tracer and a
/// photon method; `auto` denoises exactly when the denoiser is there, and says so otherwise.
#[test]
fn the_raw_layer_is_the_render_without_denoising() {
    for method in [Method::Pt, Method::Rs] {
        let plain = render(furnace(0.5, 1.0), &settings(method, 2, Mode::Off), &SilentProgress).unwrap().film;
        assert!(plain.layer(RAW_LAYER).is_none());
        let auto = render(furnace(0.5, 1.0), &settings(method, 2, Mode::Auto), &SilentProgress).unwrap();
        if !denoise::available() {
            assert_eq!(auto.film, plain, "{method}: auto without the denoiser renders as off");
            assert!(auto.stats.notes.iter().any(|n| n.contains("not denoised") && n.contains("make setup")), "{:?}", auto.stats.notes);
            eprintln!("{method}: no denoiser in this build: checked --denoise auto");
            continue;
        }
        let raw = auto.film.layer(RAW_LAYER).expect("raw layer");
        let beauty = plain.layer("").unwrap();
        assert_eq!(raw.channels, beauty.channels);
        assert!(raw.data.iter().zip(&beauty.data).all(|(a, b)| a.to_bits() == b.to_bits()), "{method}: raw layer differs from the plain render");
        assert_ne!(auto.film.layer("").unwrap().data, beauty.data, "{method}: the beauty was denoised");
        for aov in ["albedo", "normal", "depth", "direct", "indirect"] {
            assert_eq!(auto.film.layer(aov), plain.layer(aov), "{method}: AOV {aov} changed");
        }
    }
}
