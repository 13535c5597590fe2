//! What a front end asks for, option by option: [`RenderRequest`]. The command line's flags and
//! the C++ API's `RenderOptions` map onto it field by field, and both turn it into validated
//! [`RenderSettings`] here ([`RenderRequest::resolve`]): the settings of the method asked for, or,
//! when none is (`auto`), of the method [`super::auto`] chooses for the scene, with its reason.

use super::auto::{self, AutoReason, Quality};
use super::compose::PhotonPass;
use super::settings::{check_size, MethodSettings};
use super::{he_fg, pm, rs_rc, HeFgSettings, Method, PmFgSettings, PmSettings, RenderSettings, RpmFgSettings, RsFgSettings, RsRcSettings, RsSettings};
use crate::error::{Error, Result};
use crate::gather::FgSettings;
use crate::photon::BandwidthParams;
use crate::radiance_map::GlossyMode;
use crate::scene::SceneDesc;
use crate::secondary::{Allocation, SplitSettings};
use std::path::PathBuf;

/// Parse a method as `--method` names it: "auto" (`None`) or one of [`Method::ALL`].
pub fn parse_method(s: &str) -> Result<Option<Method>> {
    if s == "auto" {
        return Ok(None);
    }
    s.parse().map(Some).map_err(|_| {
        let names: Vec<_> = std::iter::once("auto").chain(Method::ALL.iter().map(|m| m.name())).collect();
        Error::param("method", format!("unknown method {s:?} (available: {})", names.join(", ")))
    })
}

/// A render as a user asks for it. `None` means "not given": the method's default, or what `auto`
/// chooses. [`RenderRequest::DEFAULT`] is what a user who gives no option gets (the command line's
/// and the C++ API's defaults); each option applies to the methods that read it, and the others
/// ignore it.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderRequest {
    /// The method (`None`: `auto` chooses one from the scene).
    pub method: Option<Method>,
    /// `auto`'s preset (`None`: preview). An error with a method given, or with `time`.
    pub quality: Option<Quality>,
    /// Samples per pixel (`None`: 16 for the path tracer, 4 eye samples per pixel for the photon
    /// methods; the path tracer under `time`: until the time is spent).
    pub spp: Option<u32>,
    /// Wall-clock budget in seconds.
    pub time: Option<f64>,
    pub seed: u64,
    /// Worker threads (0: one per core).
    pub threads: usize,
    /// Image size (`None`: the scene's, else 512×512).
    pub resolution: Option<[u32; 2]>,
    pub max_depth: u32,
    /// Photon methods: stored photons (`None`: 200 000, or `auto`'s preset).
    pub photons: Option<usize>,
    /// Photon methods: smoothness C, sensitivity S and maximum bandwidth R of the splat bandwidth.
    pub smoothness: f32,
    pub sensitivity: f32,
    pub max_bandwidth: f32,
    /// Photon maps (pm, pm-fg, rpm-fg, he-fg): neighbours per estimate.
    pub knn: usize,
    pub direct_photons: bool,
    pub light_samples: u32,
    /// Camera samples per pixel (0: as many as `spp`; `auto`'s preset when not given).
    pub aa_spp: u32,
    /// rs, rs-rc: glossy transport.
    pub glossy: GlossyMode,
    /// rs: image-space radiance filter radius in pixels.
    pub filter_radius: u32,
    pub emission_guiding: bool,
    /// Final gathering: gather rays per eye sample (`None`: 64 for pm-fg, rpm-fg and rs-fg; he-fg's
    /// stratified rays, 48).
    pub fg_rays: Option<u32>,
    pub gather_radius: Option<f32>,
    /// Final gathering: memory budget of one task, in bytes.
    pub memory: Option<u64>,
    pub spill_dir: Option<PathBuf>,
    pub no_spill: bool,
    pub density_limit: Option<f32>,
    /// he-fg: explicit rays per gather point, their allocation, the split's E_max (or its
    /// multiplier of E_avg) and voxel resolution.
    pub explicit_rays: u32,
    pub explicit_allocation: Allocation,
    pub emax: Option<f32>,
    pub emax_multiplier: f32,
    pub voxel_resolution: Option<u32>,
    /// he-fg, pm-fg: Ward's irradiance cache (an error for the other methods).
    pub irradiance_cache: bool,
    /// Cache error ε (`None`: he-fg's and pm-fg's 0.2, rs-rc's 0.5).
    pub cache_error: Option<f32>,
    /// Open Image Denoise on the beauty (off by default).
    pub denoise: crate::denoise::Options,
    /// How textures are filtered over camera rays' footprints (anisotropic by default).
    pub texture_filter: crate::prepare::TextureFilter,
    /// Pixel reconstruction filter (`--filter`; box by default) and its radius in pixels
    /// (`--pixel-filter-radius`; `None`: the filter's default).
    pub filter: crate::image::FilterKind,
    pub pixel_filter_radius: Option<f32>,
}

impl RenderRequest {
    /// No option given.
    pub const DEFAULT: RenderRequest = RenderRequest {
        method: None,
        quality: None,
        spp: None,
        time: None,
        seed: 0,
        threads: 0,
        resolution: None,
        max_depth: 1024,
        photons: None,
        smoothness: 0.3,
        sensitivity: 0.1,
        max_bandwidth: 0.2,
        knn: pm::KNN,
        direct_photons: false,
        light_samples: 4,
        aa_spp: 0,
        glossy: GlossyMode::Auto,
        filter_radius: 0,
        emission_guiding: true,
        fg_rays: None,
        gather_radius: None,
        memory: None,
        spill_dir: None,
        no_spill: false,
        density_limit: None,
        explicit_rays: he_fg::EXPLICIT_RAYS,
        explicit_allocation: Allocation::PerVoxel,
        emax: None,
        emax_multiplier: crate::secondary::voxels::DEFAULT_MULTIPLIER,
        voxel_resolution: None,
        irradiance_cache: false,
        cache_error: None,
        denoise: crate::denoise::Options::DEFAULT,
        texture_filter: crate::prepare::TextureFilter::Anisotropic,
        filter: crate::image::FilterKind::Box,
        pixel_filter_radius: None,
    };

    /// Check what can be checked without the scene: every setting of the method asked for, or,
    /// for `auto`, the settings every method shares. Front ends call it before loading a scene.
    pub fn check(&self) -> Result<()> {
        match self.method {
            Some(_) => self.settings().map(|_| ()),
            None => {
                if self.quality.is_some() && self.time.is_some() {
                    return Err(Error::param("quality", "give --quality or --time, not both".to_string()));
                }
                self.settings_with(Method::Pt, &Budget::default()).map(|_| ())
            }
        }
    }

    /// The validated settings of the method asked for (an error for `auto`, which needs a scene:
    /// [`RenderRequest::resolve`]).
    pub fn settings(&self) -> Result<RenderSettings> {
        let Some(method) = self.method else {
            return Err(Error::param("method", "auto is chosen per scene".to_string()));
        };
        if self.quality.is_some() {
            return Err(Error::param("quality", "--quality applies to --method auto only".to_string()));
        }
        self.settings_with(method, &Budget::default())
    }

    /// The validated settings for `scene`: the method asked for, or `auto`'s choice and its reason.
    pub fn resolve(&self, scene: &SceneDesc) -> Result<Resolved> {
        match self.method {
            Some(_) => Ok(Resolved { settings: self.settings()?, auto: None }),
            None => {
                let (settings, reason) = auto::choose(scene, self)?;
                Ok(Resolved { settings, auto: Some(reason) })
            }
        }
    }

    /// The image size for `scene`: the request's, else the scene's, else 512×512.
    pub fn image_size(&self, scene: &SceneDesc) -> Result<[u32; 2]> {
        check_size(self.resolution.or(scene.resolution).unwrap_or([512, 512]))
    }

    /// The validated settings of `method` from this request, with `budget`'s values where it has
    /// them (what `auto` chose).
    pub(super) fn settings_with(&self, method: Method, budget: &Budget) -> Result<RenderSettings> {
        if self.irradiance_cache && !matches!(method, Method::HeFg | Method::PmFg) {
            return Err(Error::param("irradiance-cache", format!("applies to --method he-fg and pm-fg, not {method}")));
        }
        let spp = match (budget.spp.or(self.spp), self.time) {
            (Some(n), _) => n,
            (None, _) if method.uses_photons() => 4,
            (None, Some(_)) => 1 << 24,
            (None, None) => RenderSettings::default().spp,
        };
        let pass = PhotonPass {
            photons: budget.photons.or(self.photons).unwrap_or(PhotonPass::default().photons),
            bandwidth: BandwidthParams { smoothness: self.smoothness, sensitivity: self.sensitivity, max_bandwidth: self.max_bandwidth, ..Default::default() },
            direct_photons: self.direct_photons,
            light_samples: self.light_samples,
            aa_spp: budget.aa_spp.unwrap_or(self.aa_spp),
            emission_guiding: self.emission_guiding,
        };
        if !method.uses_photons() {
            // the photon pass's options are range-checked with any method: a value out of range
            // is a mistake, whichever method it was given with
            pass.validate(1)?;
        }
        let fg = FgSettings {
            rays: self.fg_rays.unwrap_or(FgSettings::default().rays),
            gather_radius: self.gather_radius,
            memory: self.memory,
            spill_dir: self.spill_dir.clone(),
            no_spill: self.no_spill,
            density_limit: self.density_limit,
            ..Default::default()
        };
        let (knn, glossy) = (self.knn, self.glossy);
        let method_settings = match method {
            Method::Pt => MethodSettings::Pt,
            Method::Rs => MethodSettings::Rs(RsSettings { pass, glossy, filter_radius: self.filter_radius }),
            Method::Pm => MethodSettings::Pm(PmSettings { pass, knn }),
            Method::PmFg => MethodSettings::PmFg(PmFgSettings {
                pass,
                knn,
                fg,
                irradiance_cache: self.irradiance_cache,
                cache_error: self.cache_error.unwrap_or(he_fg::CACHE_ERROR),
            }),
            Method::RpmFg => MethodSettings::RpmFg(RpmFgSettings { pass, knn, fg }),
            Method::RsFg => MethodSettings::RsFg(RsFgSettings { pass, fg }),
            Method::HeFg => MethodSettings::HeFg(HeFgSettings {
                pass,
                knn,
                stratified_rays: self.fg_rays.unwrap_or(he_fg::STRATIFIED_RAYS),
                explicit_rays: self.explicit_rays,
                explicit_allocation: self.explicit_allocation,
                split: SplitSettings { multiplier: self.emax_multiplier, e_max: self.emax, resolution: self.voxel_resolution },
                irradiance_cache: self.irradiance_cache,
                cache_error: self.cache_error.unwrap_or(he_fg::CACHE_ERROR),
            }),
            Method::RsRc => MethodSettings::RsRc(RsRcSettings { pass, glossy, cache_error: self.cache_error.unwrap_or(rs_rc::CACHE_ERROR) }),
        };
        let s = RenderSettings {
            spp,
            time_budget: budget.time.or(self.time),
            seed: self.seed,
            threads: self.threads,
            resolution: self.resolution,
            max_depth: self.max_depth,
            method: method_settings,
            denoise: self.denoise,
            texture_filter: self.texture_filter,
            crop: None,
            passes: None,
            filter: crate::image::PixelFilter::new(self.filter, self.pixel_filter_radius)?,
            rival: None,
        };
        s.validate()?;
        Ok(s)
    }
}

impl Default for RenderRequest {
    fn default() -> Self {
        RenderRequest::DEFAULT
    }
}

/// What `auto` chose of a render's budget; the request's own values fill what it leaves `None`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Budget {
    pub spp: Option<u32>,
    pub aa_spp: Option<u32>,
    pub photons: Option<usize>,
    /// The time left after `auto`'s survey.
    pub time: Option<f64>,
}

/// The settings of a request for a scene, and `auto`'s reason when it chose them.
#[derive(Clone, Debug)]
pub struct Resolved {
    pub settings: RenderSettings,
    pub auto: Option<AutoReason>,
}

impl Resolved {
    /// The settings as EXR header attributes, with `auto`'s reason (`raysplat:auto`) when it chose.
    pub fn attributes(&self) -> Vec<(String, String)> {
        let mut out = self.settings.attributes();
        if let Some(r) = &self.auto {
            out.push(("raysplat:auto".into(), r.to_string()));
        }
        out
    }
}
