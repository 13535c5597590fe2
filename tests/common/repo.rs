//! The repository's scenes (`scenes/*.usda`) and render helpers shared by the integration tests.

use raysplat::image::Film;
use raysplat::image::compare;
use raysplat::integrators::{render, RenderOutput, RenderSettings, SilentProgress};
use raysplat::scene::SceneDesc;
use std::path::Path;

/// The repository's root: the library package's folder, the parent of the CLI's (`cli/`), whose
/// tests include these helpers too.
pub fn root() -> std::path::PathBuf {
    let package = Path::new(env!("CARGO_MANIFEST_DIR"));
    if package.join("scenes").is_dir() { package.to_path_buf() } else { package.join("..") }
}

/// Load `scenes/<name>` (converted with the repository's Python converter, cached).
pub fn load(name: &str) -> SceneDesc {
    let p = root().join("scenes").join(name);
    raysplat::usd::load_scene(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Render and check that no value is NaN or infinite.
pub fn run(scene: SceneDesc, s: &RenderSettings) -> RenderOutput {
    let out = render(scene, s, &SilentProgress).expect("render");
    assert_eq!(out.film.nan_count(), 0, "{} rendered NaN/Inf values", s.method.method());
    out
}

/// The `indirect` layer's RGB values.
pub fn indirect(f: &Film) -> Vec<f32> {
    f.rgb("indirect").expect("indirect layer")
}

/// The RGB values of the pixels where `mask` is set.
pub fn masked(rgb: &[f32], mask: &[bool]) -> Vec<f32> {
    rgb.chunks(3).zip(mask).filter(|(_, &m)| m).flat_map(|(c, _)| c.iter().copied()).collect()
}

/// A path-traced reference of the `indirect` layer as the mean of two independent halves of `spp`
/// samples (seeds 1001 and 1002), with its own relative MSE against the converged image,
/// `relMSE(A, B) / 4`, to subtract from a test image's error. Returns `(reference, noise, halves)`.
#[allow(dead_code)]
pub fn indirect_reference(scene: &SceneDesc, resolution: [u32; 2], spp: u32) -> (Vec<f32>, f64, [Vec<f32>; 2]) {
    let half = |seed| {
        let s = RenderSettings { spp, seed, resolution: Some(resolution), ..Default::default() };
        indirect(&run(scene.clone(), &s).film)
    };
    let (a, b) = (half(1001), half(1002));
    let reference: Vec<f32> = a.iter().zip(&b).map(|(x, y)| 0.5 * (x + y)).collect();
    let noise = compare(&a, &b).rel_mse / 4.0;
    (reference, noise, [a, b])
}
