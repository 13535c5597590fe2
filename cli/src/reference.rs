//! A path-traced reference rendered as two independent halves, with its noise measured, for the
//! benchmarks that report errors against the converged image.
//!
//! A and B are the halves (R/2 spp each) and `ref` their mean. `mean((A − B)² / 4 / (ref² + 0.01))`
//! over pixels and RGB estimates the reference's own relative MSE against the converged image (the
//! variance of the mean of two independent R/2-spp renders). A test image independent of the
//! reference has `rel MSE(test, ref) = error(test) + noise` in expectation, so its error against the
//! converged image is the difference.
//!
//! The path tracer's own time to a target error is measured, not extrapolated
//! ([`Reference::pt_time_to`]): its pixel positions are stratified (`sampling::PixelSampler`), so one
//! N-spp render has less variance than two independent N/2-spp halves, and its error falls faster
//! than 1/N where anti-aliasing matters.

use raysplat::image;
use raysplat::integrators::{self, MethodSettings, Progress, RenderSettings, SilentProgress};
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
    /// The mean of the two halves, every layer.
    pub film: image::Film,
}

impl Reference {
    /// Render the halves of `spp / 2` samples with `seeds` and keep `layers` ("" = beauty).
    pub fn render(desc: &SceneDesc, base: &RenderSettings, spp: u32, seeds: [u64; 2], layers: &[&str]) -> anyhow::Result<Reference> {
        Self::render_with_progress(desc, base, spp, seeds, layers, &SilentProgress)
    }

    /// [`render`](Self::render), reporting each half's progress to `progress`.
    pub fn render_with_progress(
        desc: &SceneDesc,
        base: &RenderSettings,
        spp: u32,
        seeds: [u64; 2],
        layers: &[&str],
        progress: &dyn Progress,
    ) -> anyhow::Result<Reference> {
        let half = |seed| integrators::render(desc.clone(), &RenderSettings { method: MethodSettings::Pt, spp: (spp / 2).max(1), seed, ..base.clone() }, progress);
        let (a, b) = (half(seeds[0])?, half(seeds[1])?);
        let layers: Vec<Layer> = layers
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
        let mut film = a.film;
        for (la, lb) in film.layers.iter_mut().zip(&b.film.layers) {
            for (x, y) in la.data.iter_mut().zip(&lb.data) {
                *x = 0.5 * (*x + y);
            }
        }
        Ok(Reference { layers, spp: 2 * (spp / 2).max(1), seconds: a.stats.total_seconds + b.stats.total_seconds, film })
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

    /// The path tracer's time to a relative MSE of `target` in the beauty image against the
    /// converged image, measured: renders of 4, 8, 16, … spp (seed `seed`, independent of the
    /// reference's) up to `max_spp`, the spp interpolated log-log between the two renders that
    /// bracket the target and the seconds linearly between theirs. Beyond `max_spp` it is
    /// extrapolated from the last render with error ∝ 1/spp, the path tracer's rate once path noise
    /// dominates (stratified pixel positions only lower the anti-aliasing part faster);
    /// `extrapolated` says so.
    pub fn pt_time_to(&self, desc: &SceneDesc, base: &RenderSettings, target: f64, max_spp: u32, seed: u64) -> anyhow::Result<PtTime> {
        let mut prev: Option<(f64, f64, u32)> = None; // (seconds, error, spp)
        let mut spp = 4u32;
        loop {
            let out = integrators::render(desc.clone(), &RenderSettings { method: MethodSettings::Pt, spp, seed, ..base.clone() }, &SilentProgress)?;
            let (t, e) = (out.stats.total_seconds, self.error("", &out.film.rgb("").expect("beauty")).max(1e-12));
            if e <= target {
                let seconds = match prev {
                    // log-log interpolation of error against spp; time linear in spp between the
                    // two renders (a fixed start-up cost plus a cost per sample)
                    Some((pt, pe, ps)) if pe > target => {
                        let f = (pe.ln() - target.ln()) / (pe.ln() - e.ln());
                        let s = ((ps as f64).ln() + f * ((spp as f64).ln() - (ps as f64).ln())).exp();
                        pt + (t - pt) * (s - ps as f64) / (spp - ps) as f64
                    }
                    // the first render is already below the target: 1/spp from it (at most its time)
                    _ => t * e / target,
                };
                return Ok(PtTime { seconds, spp_error: (spp, e), extrapolated: false });
            }
            if spp >= max_spp {
                return Ok(PtTime { seconds: t * e / target, spp_error: (spp, e), extrapolated: true });
            }
            prev = Some((t, e, spp));
            spp = (spp * 2).min(max_spp);
        }
    }
}

/// The path tracer's measured time to a target error ([`Reference::pt_time_to`]).
pub struct PtTime {
    pub seconds: f64,
    /// The last render: its spp and error against the converged image.
    pub spp_error: (u32, f64),
    /// The target was beyond the last render; the time is extrapolated with error ∝ 1/spp.
    pub extrapolated: bool,
}

#[cfg(test)]
mod tests {
    use super::*;
    use raysplat::usd;

    /// The reference's measured noise predicts the error of an independent image made the same way
    /// (the mean of two independent path-traced halves: the same variance), and what `error` takes
    /// out. A single 64-spp render has less: its pixel positions are stratified over all 64 samples.
    #[test]
    fn reference_noise_predicts_the_error_of_an_independent_render() {
        let desc = usd::load_scene(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/cornell-box.usda"))).unwrap();
        let base = RenderSettings { resolution: Some([24, 24]), ..Default::default() };
        let reference = Reference::render(&desc, &base, 64, [1000, 1001], &[""]).unwrap();
        let pt = |spp, seed| integrators::render(desc.clone(), &RenderSettings { spp, seed, ..base.clone() }, &SilentProgress).unwrap().film.rgb("").unwrap();
        let (mut ratios, mut single) = (Vec::new(), Vec::new());
        for seed in [7, 9, 11] {
            let (a, b) = (pt(32, seed), pt(32, seed + 1));
            let mean: Vec<f32> = a.iter().zip(&b).map(|(x, y)| 0.5 * (x + y)).collect();
            // error against the converged image = the test's own variance = the reference's noise
            ratios.push(reference.error("", &mean) / reference.noise(""));
            single.push(reference.error("", &pt(64, seed)) / reference.noise(""));
        }
        let avg = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        assert!(reference.noise("") > 0.0 && (0.6..1.6).contains(&avg(&ratios)), "error / noise {ratios:?}");
        assert!(avg(&single) < avg(&ratios), "one stratified 64-spp render {single:?} vs two halves {ratios:?}");
    }

    /// The measured time to the reference's own noise is about the time of a render of that many
    /// samples, and a target the ladder cannot reach is extrapolated.
    #[test]
    fn pt_time_to_a_target_is_measured() {
        let desc = usd::load_scene(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/cornell-box.usda"))).unwrap();
        let base = RenderSettings { resolution: Some([16, 16]), ..Default::default() };
        let reference = Reference::render(&desc, &base, 256, [1000, 1001], &[""]).unwrap();
        let easy = reference.pt_time_to(&desc, &base, 0.5, 64, 5).unwrap();
        assert!(!easy.extrapolated && easy.spp_error.1 <= 0.5 && easy.seconds > 0.0);
        let hard = reference.pt_time_to(&desc, &base, 1e-6, 8, 5).unwrap();
        assert!(hard.extrapolated && hard.spp_error.0 == 8 && hard.seconds > easy.seconds);
    }
}
