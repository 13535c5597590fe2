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
    /// Photon mapping with final gathering (the baseline of reverse photon mapping).
    PmFg,
    /// Reverse photon mapping: final gathering with the density estimation done from the photons.
    RpmFg,
    /// Ray-splatting final gathering: gather hits are the eye samples of photon ray splatting.
    RsFg,
    /// Final gathering with strong secondary lights: stratified gather rays into a low-energy photon
    /// map plus explicit rays toward the high-energy voxels (`secondary`).
    HeFg,
    /// Photon ray splatting with radiance caching in image space (§8.3).
    RsRc,
}

impl Method {
    pub const ALL: &'static [Method] =
        &[Method::Pt, Method::Rs, Method::Pm, Method::PmFg, Method::RpmFg, Method::RsFg, Method::HeFg, Method::RsRc];
    pub fn name(self) -> &'static str {
        match self {
            Method::Pt => "pt",
            Method::Rs => "rs",
            Method::Pm => "pm",
            Method::PmFg => "pm-fg",
            Method::RpmFg => "rpm-fg",
            Method::RsFg => "rs-fg",
            Method::HeFg => "he-fg",
            Method::RsRc => "rs-rc",
        }
    }
    /// Does the method trace photons?
    pub fn uses_photons(self) -> bool {
        matches!(self, Method::Rs | Method::Pm | Method::HeFg | Method::RsRc) || self.final_gathers()
    }
    /// Does the method shoot final gather rays through the shared stage (`crate::gather`)? (`he-fg`
    /// gathers per point, in `crate::secondary`.)
    pub fn final_gathers(self) -> bool {
        matches!(self, Method::PmFg | Method::RpmFg | Method::RsFg)
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

/// Default cache error ε of the irradiance cache (`he-fg --irradiance-cache`, Ward's ε).
pub const CACHE_ERROR_HE_FG: f32 = 0.2;
/// Default cache error ε of the radiance cache of `rs-rc` (record radius = ε × harmonic mean
/// distance; the splatting paper's Table 2 uses 0.4–0.9).
pub const CACHE_ERROR_RS_RC: f32 = 0.5;
/// `rs-rc` traces its photons with these fractions of the smoothness C (`--smoothness`) that the
/// other photon methods use, per photon class (direct, indirect, caustic): its records are
/// extrapolated by the cache, a filter of their own, so narrower photon kernels lower the blur at
/// little noise. The splatting paper's Table 2 gives RC 0.5–0.6 of RS's C. Measured on
/// cornell-glossy at 500² × 4 spp, 200 000 photons (indirect relative MSE against 512-spp path
/// tracing), every class at once: rs-rc at C = 0.3 → 0.0236, 0.2 → 0.0201, 0.15 → 0.0179,
/// 0.1 → 0.0166; rs at 0.15 → 0.0311, 0.3 → 0.0292 (its default), 0.5 → 0.0327. That gain is the
/// caustic photons' (splatted onto eye samples or image grids, not cached): the cached photons'
/// factor alone at 0.5, 0.75, 1 gave, over six photon seeds (against two 256-spp references,
/// noise subtracted), cornell-glossy 0.01385, 0.01435, 0.01468 and Crytek Sponza at 400²
/// 0.00205, 0.00187, 0.00188 (docs/glossy.md, stop 25).
pub const RS_RC_SMOOTHNESS: [f32; 3] = [0.75, 0.75, 0.5];
/// The longest `--time` budget accepted, in seconds (a year).
pub const MAX_TIME_BUDGET: f64 = 365.0 * 24.0 * 3600.0;

/// Settings of one render.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub method: Method,
    /// Samples per pixel (path tracer: paths per pixel).
    pub spp: u32,
    /// Wall-clock budget in seconds: render passes until it is spent (at least one pass). The path
    /// tracer adds samples per pixel; photon methods average independent passes of `spp` eye samples
    /// and `photons` photons each (see `integrators::passes`).
    pub time_budget: Option<f64>,
    pub seed: u64,
    /// Worker threads (0 = one per core). The image never depends on it.
    pub threads: usize,
    /// Overrides the scene's resolution.
    pub resolution: Option<[u32; 2]>,
    /// Hard cap on path length. Russian roulette ends most paths long before it, but not in
    /// near-white closed scenes: at albedo 0.999 the mean path has 1000 bounces, and a cap of 1024
    /// keeps 1 − 0.999¹⁰²⁴ ≈ 64 % of the light. Photon paths are capped at min(this, 256).
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
    /// Photon methods: camera samples per pixel for anti-aliasing, emission seen directly, direct
    /// light and the AOVs (0: the same as `spp`). The first `spp` of them are also eye samples for
    /// the density estimate, so the costly indirect estimate stays at `spp` while the edges and
    /// the direct light get `aa_spp` stratified positions.
    pub aa_spp: u32,
    /// Ray splatting: how glossy eye samples receive light (exact BSDF per photon, or a per-pixel
    /// SH / histogram radiance map, §8.1; `Auto`: SH for the lobes SH bands 0–3 hold, exact for
    /// the others).
    pub glossy: crate::radiance_map::GlossyMode,
    /// Final gathering (`pm-fg`, `rpm-fg`, `rs-fg`): gather rays, gather radius, memory budget.
    pub fg: crate::gather::FgSettings,
    /// he-fg: stratified final-gather rays into the low-energy photon map per gather point (the
    /// CLI's `--fg-rays` sets this for he-fg, default 48, and `fg.rays` for the other gathering
    /// methods, default 64).
    pub fg_rays: u32,
    /// he-fg: explicit rays toward the high-energy voxels per gather point (0: no split, one map).
    pub explicit_rays: u32,
    /// he-fg: how explicit rays are shared between high-energy voxels.
    pub explicit_allocation: crate::secondary::Allocation,
    /// he-fg: the low/high-energy split (E_max or its multiplier of E_avg, voxel resolution).
    pub split: crate::secondary::SplitSettings,
    /// he-fg: Ward's irradiance cache for the gather at Lambertian eye samples.
    pub irradiance_cache: bool,
    /// Cache error ε (`None`: the method's default, [`CACHE_ERROR_HE_FG`] or [`CACHE_ERROR_RS_RC`]).
    pub cache_error: Option<f32>,
    /// Ray splatting: image-space radiance filter (§8.2), largest box radius in pixels (0: off).
    pub filter_radius: u32,
    /// Photon methods: guided emission (each emitter's position sample drawn from where paths that
    /// store photons start, learned during the light pass; see `photon::guide`).
    pub emission_guiding: bool,
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
            aa_spp: 0,
            glossy: crate::radiance_map::GlossyMode::Auto,
            fg: crate::gather::FgSettings::default(),
            fg_rays: 48,
            explicit_rays: 230,
            explicit_allocation: crate::secondary::Allocation::PerVoxel,
            split: crate::secondary::SplitSettings::default(),
            irradiance_cache: false,
            cache_error: None,
            filter_radius: 0,
            emission_guiding: true,
        }
    }
}

impl RenderSettings {
    /// The photon bandwidth parameters in effect for this method ([`RS_RC_SMOOTHNESS`]).
    pub fn bandwidth_in_effect(&self) -> crate::photon::BandwidthParams {
        let mut b = self.bandwidth;
        if self.method == Method::RsRc {
            b.class_smoothness = RS_RC_SMOOTHNESS;
        }
        b
    }

    /// The cache error ε in effect for this method.
    pub fn cache_error(&self) -> f32 {
        self.cache_error.unwrap_or(if self.method == Method::RsRc { CACHE_ERROR_RS_RC } else { CACHE_ERROR_HE_FG })
    }

    pub fn validate(&self) -> Result<()> {
        if self.spp == 0 || self.spp > 1 << 24 {
            return Err(Error::param("spp", format!("{} is out of range (1..=16777216)", self.spp)));
        }
        if let Some(t) = self.time_budget {
            if !(t.is_finite() && t > 0.0) {
                return Err(Error::param("time", format!("{t} must be a positive number of seconds")));
            }
            // a budget beyond a year is a mistake that would hold a machine until killed
            if t > MAX_TIME_BUDGET {
                return Err(Error::param("time", format!("{t} seconds is more than a year ({MAX_TIME_BUDGET} s)")));
            }
        }
        if self.threads > 4096 {
            return Err(Error::param("threads", format!("{} is absurd", self.threads)));
        }
        if self.max_depth == 0 || self.max_depth > 1 << 16 {
            return Err(Error::param("max-depth", format!("{} is out of range (1..=65536)", self.max_depth)));
        }
        if self.method.uses_photons() && self.spp > 4096 {
            return Err(Error::param("spp", format!("{} eye samples per pixel is too many for --method {} (at most 4096)", self.spp, self.method)));
        }
        if self.photons > 1 << 28 {
            return Err(Error::param("photons", format!("{} is more than 268435456", self.photons)));
        }
        if self.aa_spp != 0 && (self.aa_spp < self.spp || self.aa_spp > 4096) {
            return Err(Error::param("aa-spp", format!("{} is out of range (--spp {} ..= 4096, or 0 for the same as --spp)", self.aa_spp, self.spp)));
        }
        if self.light_samples == 0 || self.light_samples > 4096 {
            return Err(Error::param("light-samples", format!("{} is out of range (1..=4096)", self.light_samples)));
        }
        if self.knn == 0 || self.knn > 100_000 {
            return Err(Error::param("knn", format!("{} is out of range (1..=100000)", self.knn)));
        }
        if let Some(e) = self.cache_error {
            if !(e > 0.0 && e <= 10.0) {
                return Err(Error::param("cache-error", format!("{e} is out of range (0, 10]")));
            }
        }
        if self.filter_radius > 64 {
            return Err(Error::param("filter-radius", format!("{} is out of range (0..=64 pixels)", self.filter_radius)));
        }
        self.bandwidth.validate()?;
        self.fg.validate()?;
        if self.fg_rays > 65536 || self.explicit_rays > 65536 {
            return Err(Error::param("fg-rays", format!("{} gather + {} explicit rays per point is out of range (0..=65536 each)", self.fg_rays, self.explicit_rays)));
        }
        if self.method == Method::HeFg && self.fg_rays == 0 && self.explicit_rays == 0 {
            return Err(Error::param("fg-rays", "--fg-rays and --explicit-rays are both 0"));
        }
        self.split.validate()?;
        if self.irradiance_cache && !matches!(self.method, Method::HeFg | Method::PmFg) {
            return Err(Error::param("irradiance-cache", format!("applies to --method he-fg and pm-fg, not {}", self.method)));
        }
        if self.irradiance_cache && self.fg.gather_radius.is_some() {
            return Err(Error::param("irradiance-cache", "the cached gather uses k-NN estimates: drop --gather-radius".to_string()));
        }
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
            ("raysplat:smoothness".into(), self.bandwidth_in_effect().smoothness.to_string()),
            ("raysplat:class_smoothness".into(), self.bandwidth_in_effect().class_smoothness.map(|f| f.to_string()).join(" ")),
            ("raysplat:sensitivity".into(), self.bandwidth.sensitivity.to_string()),
            ("raysplat:max_bandwidth".into(), self.bandwidth.max_bandwidth.to_string()),
            ("raysplat:knn".into(), self.knn.to_string()),
            ("raysplat:direct_photons".into(), self.direct_photons.to_string()),
            ("raysplat:light_samples".into(), self.light_samples.to_string()),
            ("raysplat:aa_spp".into(), self.aa_spp.max(self.spp).to_string()),
            ("raysplat:glossy".into(), self.glossy.to_string()),
            ("raysplat:fg_rays".into(), self.fg.rays.to_string()),
            ("raysplat:gather_radius".into(), self.fg.gather_radius.map_or("none".into(), |r| r.to_string())),
            ("raysplat:memory".into(), self.fg.memory.map_or("none".into(), |m| m.to_string())),
            ("raysplat:density_limit".into(), self.fg.density_limit.map_or("none".into(), |d| d.to_string())),
            ("raysplat:stratified_rays".into(), self.fg_rays.to_string()),
            ("raysplat:explicit_rays".into(), self.explicit_rays.to_string()),
            ("raysplat:explicit_allocation".into(), self.explicit_allocation.name().into()),
            ("raysplat:emax".into(), self.split.e_max.map_or("auto".into(), |e| e.to_string())),
            ("raysplat:emax_multiplier".into(), self.split.multiplier.to_string()),
            ("raysplat:voxel_resolution".into(), self.split.resolution.map_or("auto".into(), |r| r.to_string())),
            ("raysplat:irradiance_cache".into(), self.irradiance_cache.to_string()),
            ("raysplat:cache_error".into(), self.cache_error().to_string()),
            ("raysplat:filter_radius".into(), self.filter_radius.to_string()),
            ("raysplat:emission_guiding".into(), self.emission_guiding.to_string()),
        ]
    }
}
