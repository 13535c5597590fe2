//! A path-traced reference rendered as two independent halves, with its noise measured, for the
//! benchmarks that report errors against the converged image.
//!
//! A and B are the halves (R/2 spp each) and `ref` their mean. `mean((A − B)² / 4 / (ref² + 0.01))`
//! over pixels and RGB estimates the reference's own relative MSE against the converged image (the
//! variance of an R-spp estimate). A test image independent of the reference has `rel MSE(test, ref) = error(test) +
//! noise` in expectation, so its error against the converged image is the difference. The path
//! tracer is unbiased with a fixed cost per sample: its relative MSE at N spp is `noise · R / N`, so
//! it needs `t_ref · noise / e` seconds for a target `e`.

use raysplat::image;
use raysplat::integrators::{self, Method, RenderSettings, SilentProgress};
use raysplat::scene::SceneDesc;

/// One layer of the reference: its pixels and their noise.
struct Layer {
    name: String,
    rgb: Vec<f32>,
    noise: f64,
}

pub struct Reference {
    layers: Vec<Layer>,
    /// Samples per pixel of both halves together.
    pub spp: u32,
    /// Seconds of both halves.
    pub seconds: f64,
}

impl Reference {
    /// Render the halves of `spp / 2` samples with `seeds` and keep `layers` ("" = beauty).
    pub fn render(desc: &SceneDesc, base: &RenderSettings, spp: u32, seeds: [u64; 2], layers: &[&str]) -> anyhow::Result<Reference> {
        let half = |seed| integrators::render(desc.clone(), &RenderSettings { method: Method::Pt, spp: (spp / 2).max(1), seed, ..base.clone() }, &SilentProgress);
        let (a, b) = (half(seeds[0])?, half(seeds[1])?);
        let layers = layers
            .iter()
            .map(|&l| {
                let get = |f: &image::Film| f.rgb(l).ok_or_else(|| anyhow::anyhow!("the reference has no layer {l:?}"));
                let (ra, rb) = (get(&a.film)?, get(&b.film)?);
                let rgb: Vec<f32> = ra.iter().zip(&rb).map(|(x, y)| 0.5 * (x + y)).collect();
                // (A − B)²/4 over the reference's own denominator: `rel MSE(A, B) / 4` (B² in the
                // denominator) overestimates the noise at low sample counts, where B is often small.
                let sum: f64 = ra.iter().zip(&rb).zip(&rgb).map(|((x, y), r)| ((x - y) as f64).powi(2) / 4.0 / ((*r as f64).powi(2) + 0.01)).filter(|v| v.is_finite()).sum();
                let noise = sum / rgb.len().max(1) as f64;
                Ok(Layer { name: l.to_string(), rgb, noise })
            })
            .collect::<anyhow::Result<_>>()?;
        Ok(Reference { layers, spp: 2 * (spp / 2).max(1), seconds: a.stats.total_seconds + b.stats.total_seconds })
    }

    fn layer(&self, name: &str) -> &Layer {
        self.layers.iter().find(|l| l.name == name).unwrap_or_else(|| panic!("layer {name:?} was not kept"))
    }

    /// Relative MSE of the reference's `layer` itself against the converged image.
    pub fn noise(&self, layer: &str) -> f64 {
        self.layer(layer).noise
    }

    /// The relative MSE of `test` (pixels of `layer`) against the converged image: against this
    /// reference, less its noise.
    pub fn error(&self, layer: &str, test: &[f32]) -> f64 {
        let l = self.layer(layer);
        image::compare(test, &l.rgb).rel_mse - l.noise
    }

    /// Seconds the path tracer needs for a relative MSE of `target` in the beauty image.
    pub fn pt_seconds_for(&self, target: f64) -> f64 {
        self.seconds * self.noise("") / target
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use raysplat::usd;

    /// The reference's measured noise predicts the error of an independent path-traced image of the
    /// same samples per pixel (both are the variance of an R-spp estimate), and what `error` takes out.
    #[test]
    fn reference_noise_predicts_the_error_of_an_independent_render() {
        let desc = usd::load_scene(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.usda"))).unwrap();
        let base = RenderSettings { resolution: Some([24, 24]), ..Default::default() };
        let reference = Reference::render(&desc, &base, 64, [1000, 1001], &[""]).unwrap();
        let mut ratios = Vec::new();
        for seed in [7, 8, 9] {
            let out = integrators::render(desc.clone(), &RenderSettings { spp: 64, seed, ..base.clone() }, &SilentProgress).unwrap();
            // error against the converged image = the test's own variance = the reference's noise
            ratios.push(reference.error("", &out.film.rgb("").unwrap()) / reference.noise(""));
        }
        let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
        assert!(reference.noise("") > 0.0 && (0.6..1.6).contains(&mean), "error / noise {ratios:?}");
        assert!((reference.pt_seconds_for(reference.noise("")) - reference.seconds).abs() < 1e-9);
    }
}
