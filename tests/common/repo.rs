//! The repository's scenes (`scenes/*.usda`) and render helpers shared by the integration tests.

use raysplat::image::Film;
use raysplat::integrators::{render, RenderOutput, RenderSettings, SilentProgress};
use raysplat::scene::SceneDesc;
use std::path::Path;

/// Load `scenes/<name>` (converted with the repository's Python converter, cached).
pub fn load(name: &str) -> SceneDesc {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name);
    raysplat::usd::load_scene(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Render and check that no value is NaN or infinite.
pub fn run(scene: SceneDesc, s: &RenderSettings) -> RenderOutput {
    let out = render(scene, s, &SilentProgress).expect("render");
    assert_eq!(out.film.nan_count(), 0, "{} rendered NaN/Inf values", s.method);
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
