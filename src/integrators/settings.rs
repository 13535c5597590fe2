//! Render settings shared by the CLI and the C++ API, validated before anything is built.

use crate::error::{Error, Result};
use std::fmt;
use std::str::FromStr;

/// A rendering method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Unbiased path tracing: the reference every other method is measured against.
    Pt,
    /// Photon ray splatting (density estimation in ray space, cone traversal of an eye-sample kd-tree).
    Rs,
    /// Direct visualisation of classic photon maps with k-nearest-neighbour density estimation.
    Pm,
    /// Photon ray splatting with radiance caching in image space (§8.3).
    RsRc,
}

impl Method {
    pub const ALL: &'static [Method] = &[Method::Pt, Method::Rs, Method::Pm, Method::RsRc];
    pub fn name(self) -> &'static str {
        match self {
            Method::Pt => "pt",
            Method::Rs => "rs",
            Method::Pm => "pm",
            Method::RsRc => "rs-rc",
        }
    }
    /// Does the method trace photons?
    pub fn uses_photons(self) -> bool {
        matches!(self, Method::Rs | Method::Pm | Method::RsRc)
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Method {
    type Err = Error;
    fn from_str(s: &str) -> Result<Method> {
        Method::ALL.iter().copied().find(|m| m.name() == s).ok_or_else(|| {
            let names: Vec<_> = Method::ALL.iter().map(|m| m.name()).collect();
            Error::param("method", format!("unknown method {s:?} (available: {})", names.join(", ")))
        })
    }
}

/// Settings of one render.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub method: Method,
    /// Samples per pixel (path tracer: paths per pixel).
    pub spp: u32,
    /// Wall-clock budget in seconds: render passes until it is spent (at least one pass).
    pub time_budget: Option<f64>,
    pub seed: u64,
    /// Worker threads (0 = one per core). The image never depends on it.
    pub threads: usize,
    /// Overrides the scene's resolution.
    pub resolution: Option<[u32; 2]>,
    /// Hard cap on path length (Russian roulette ends paths long before in practice).
    pub max_depth: u32,
    /// Photon methods: stored photons in total (split over direct / indirect / caustic budgets).
    pub photons: usize,
    /// Photon ray splatting bandwidth: smoothness C, sensitivity S, maximum bandwidth R.
    pub bandwidth: crate::photon::BandwidthParams,
    /// Photon mapping: neighbours per density estimate (global map; the caustic map uses half).
    pub knn: usize,
    /// Direct light from photons instead of explicit light sampling.
    pub direct_photons: bool,
    /// Photon methods: light samples per eye sample for the direct light (ignored with
    /// `direct_photons`). Shadow rays are cheap next to density estimation, and the direct light
    /// of 4 eye samples per pixel with one light sample each sets the methods' error floor.
    pub light_samples: u32,
    /// Ray splatting: how glossy eye samples receive light (exact BSDF per photon, or a per-pixel
    /// SH / histogram radiance map, §8.1).
    pub glossy: crate::radiance_map::GlossyMode,
    /// Ray splatting: image-space radiance filter (§8.2), largest box radius in pixels (0: off).
    pub filter_radius: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            method: Method::Pt,
            spp: 16,
            time_budget: None,
            seed: 0,
            threads: 0,
            resolution: None,
            max_depth: 1024,
            photons: 200_000,
            bandwidth: crate::photon::BandwidthParams::default(),
            knn: 100,
            direct_photons: false,
            light_samples: 4,
            glossy: crate::radiance_map::GlossyMode::Exact,
            filter_radius: 0,
        }
    }
}

impl RenderSettings {
    pub fn validate(&self) -> Result<()> {
        if self.spp == 0 || self.spp > 1 << 24 {
            return Err(Error::param("spp", format!("{} is out of range (1..=16777216)", self.spp)));
        }
        if let Some(t) = self.time_budget {
            if !(t.is_finite() && t > 0.0) {
                return Err(Error::param("time", format!("{t} must be a positive number of seconds")));
            }
        }
        if self.threads > 4096 {
            return Err(Error::param("threads", format!("{} is absurd", self.threads)));
        }
        if self.max_depth == 0 || self.max_depth > 1 << 16 {
            return Err(Error::param("max-depth", format!("{} is out of range (1..=65536)", self.max_depth)));
        }
        if self.method.uses_photons() && self.time_budget.is_some() {
            return Err(Error::param("time", format!("a time budget is not supported by --method {} yet; give --spp and --photons", self.method)));
        }
        if self.method.uses_photons() && self.spp > 4096 {
            return Err(Error::param("spp", format!("{} eye samples per pixel is too many for --method {} (at most 4096)", self.spp, self.method)));
        }
        if self.photons > 1 << 28 {
            return Err(Error::param("photons", format!("{} is more than 268435456", self.photons)));
        }
        if self.light_samples == 0 || self.light_samples > 4096 {
            return Err(Error::param("light-samples", format!("{} is out of range (1..=4096)", self.light_samples)));
        }
        if self.knn == 0 || self.knn > 100_000 {
            return Err(Error::param("knn", format!("{} is out of range (1..=100000)", self.knn)));
        }
        if self.filter_radius > 64 {
            return Err(Error::param("filter-radius", format!("{} is out of range (0..=64 pixels)", self.filter_radius)));
        }
        self.bandwidth.validate()?;
        Ok(())
    }

    /// Settings as EXR header attributes.
    pub fn attributes(&self) -> Vec<(String, String)> {
        vec![
            ("raysplat:method".into(), self.method.to_string()),
            ("raysplat:spp".into(), self.spp.to_string()),
            ("raysplat:seed".into(), self.seed.to_string()),
            ("raysplat:max_depth".into(), self.max_depth.to_string()),
            ("raysplat:time_budget".into(), self.time_budget.map_or("none".into(), |t| t.to_string())),
            ("raysplat:photons".into(), self.photons.to_string()),
            ("raysplat:smoothness".into(), self.bandwidth.smoothness.to_string()),
            ("raysplat:sensitivity".into(), self.bandwidth.sensitivity.to_string()),
            ("raysplat:max_bandwidth".into(), self.bandwidth.max_bandwidth.to_string()),
            ("raysplat:knn".into(), self.knn.to_string()),
            ("raysplat:direct_photons".into(), self.direct_photons.to_string()),
            ("raysplat:light_samples".into(), self.light_samples.to_string()),
            ("raysplat:glossy".into(), self.glossy.to_string()),
            ("raysplat:filter_radius".into(), self.filter_radius.to_string()),
        ]
    }
}
