//! Render settings: what every method shares ([`RenderSettings`]) and one settings type per method
//! ([`MethodSettings`]), each defined beside its method with its defaults and checks.
//! [`RenderSettings::validate`] runs them all before anything is built. Front ends build settings
//! from their options through [`super::RenderRequest`].

use super::compose::PhotonPass;
use super::fg::{PmFgSettings, RpmFgSettings, RsFgSettings};
use super::he_fg::HeFgSettings;
use super::pm::PmSettings;
use super::rs::RsSettings;
use super::rs_rc::RsRcSettings;
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
    /// Does the method splat its photon rays onto the eye pass's samples (or cache records among
    /// them)? Its light pass then also keeps the rays that leave the scene past them
    /// (`PhotonSettings::reach`).
    pub fn splats_onto_eye_samples(self) -> bool {
        matches!(self, Method::Rs | Method::RsRc)
    }
    /// Does the method shoot final gather rays through the shared stage (`crate::gather`)? (`he-fg`
    /// gathers per point, in `crate::secondary`.)
    pub fn final_gathers(self) -> bool {
        matches!(self, Method::PmFg | Method::RpmFg | Method::RsFg)
    }
    /// Does the method's photon map hold direct photons whatever `--direct-photons` says? The
    /// gathering methods need all the light arriving at a gather hit.
    pub fn gathers_direct_light(self) -> bool {
        self.final_gathers() || self == Method::HeFg
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

/// The largest image side, in pixels.
pub const MAX_SIDE: u32 = 65536;
/// Eye samples per pixel a photon method may take at most.
pub const MAX_PHOTON_SPP: u32 = 4096;
/// The longest `--time` budget accepted, in seconds (a year).
pub const MAX_TIME_BUDGET: f64 = 365.0 * 24.0 * 3600.0;

/// Check an image size: `[w, h]` with both sides in 1..=[`MAX_SIDE`].
pub fn check_size([w, h]: [u32; 2]) -> Result<[u32; 2]> {
    if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
        return Err(Error::param("resolution", format!("{w}x{h} is out of range (1..={MAX_SIDE} per side)")));
    }
    Ok([w, h])
}

/// Parse an image size `WIDTHxHEIGHT` (as `--resolution`) and check it ([`check_size`]).
pub fn parse_size(s: &str) -> Result<[u32; 2]> {
    let bad = || Error::param("resolution", format!("{s:?} is not of the form WIDTHxHEIGHT"));
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    check_size([w, h])
}

/// Settings of one render: those every method shares, and the method's own.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// Samples per pixel (path tracer: paths per pixel; photon methods: eye samples per pixel for
    /// the density estimate, per pass).
    pub spp: u32,
    /// Wall-clock budget in seconds: render passes until it is spent (at least one pass). The path
    /// tracer adds samples per pixel; photon methods average independent passes of `spp` eye samples
    /// and their photons each (see `integrators::passes`).
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
    /// The method and its own settings.
    pub method: MethodSettings,
    /// Denoise the beauty with Open Image Denoise after rendering (`crate::denoise`; off by default).
    pub denoise: crate::denoise::Options,
    /// How textures are filtered over the footprints of camera rays' cones (`prepare::cone`).
    pub texture_filter: crate::prepare::TextureFilter,
    /// Render only this window `[x0, y0, x1, y1)` of the image, each of its pixels as the whole
    /// image's render has it (same rays, same photons): crops of one image stitch into it.
    pub crop: Option<[u32; 4]>,
    /// Render a range of a run of independent passes ([`Passes`]), or the whole run.
    pub passes: Option<Passes>,
    /// The pixel reconstruction filter (`image::filter`; the box over the pixel by default): the
    /// path tracer splats with it, the photon methods' eye pass samples it.
    pub filter: crate::image::PixelFilter,
    /// Under `time_budget`, a photon method's rival: the path tracer's figures (`auto` measured
    /// them), which the time left goes to when it is predicted to lower the error more than more
    /// passes (`integrators::allocation`). `None`: passes only.
    pub rival: Option<super::allocation::Rival>,
}

/// A run of `total` independent passes, of which passes `first .. end` are rendered (and
/// averaged). The path tracer's pass `k` is its samples `k·spp .. (k+1)·spp` of `total·spp`
/// per pixel; a photon method's pass `k` is a progressive pass (`integrators::passes`): new eye
/// samples and photons (seed `hash(seed, k)`) and a bandwidth that shrinks with `k`. A pass
/// depends only on the seed and its index, so any machine can render any range of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Passes {
    pub total: u32,
    pub first: u32,
    pub end: u32,
    /// Photon methods: keep every pass's bandwidth at the first pass's (averaging lowers the noise
    /// but not the bias: the fixed-bandwidth floor progressive passes go below).
    pub fixed_bandwidth: bool,
}

impl Passes {
    /// The whole run of `total` passes.
    pub fn all(total: u32) -> Passes {
        Passes { total, first: 0, end: total, fixed_bandwidth: false }
    }
    /// Passes rendered.
    pub fn count(&self) -> u32 {
        self.end - self.first
    }
    pub fn validate(&self) -> Result<()> {
        if self.total == 0 || self.total > 1 << 20 {
            return Err(Error::param("passes", format!("{} is out of range (1..=1048576)", self.total)));
        }
        if self.first >= self.end || self.end > self.total {
            return Err(Error::param("pass-range", format!("{}:{} is not a non-empty range of the {} passes (FIRST:END, 0 <= FIRST < END <= {})", self.first, self.end, self.total, self.total)));
        }
        Ok(())
    }
}

/// Check a crop window `[x0, y0, x1, y1)` against the image size `[w, h]`.
pub fn check_crop([x0, y0, x1, y1]: [u32; 4], [w, h]: [u32; 2]) -> Result<()> {
    if !(x0 < x1 && y0 < y1 && x1 <= w && y1 <= h) {
        return Err(Error::param("crop", format!("{x0},{y0},{x1},{y1} is not a non-empty window of the {w}x{h} image (X0,Y0,X1,Y1 with 0 <= X0 < X1 <= {w}, 0 <= Y0 < Y1 <= {h})")));
    }
    Ok(())
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            spp: 16,
            time_budget: None,
            seed: 0,
            threads: 0,
            resolution: None,
            max_depth: 1024,
            method: MethodSettings::Pt,
            denoise: crate::denoise::Options::default(),
            texture_filter: crate::prepare::TextureFilter::Anisotropic,
            crop: None,
            passes: None,
            filter: crate::image::PixelFilter::BOX,
            rival: None,
        }
    }
}

/// A method with its own settings.
#[derive(Clone, Debug)]
pub enum MethodSettings {
    /// The path tracer has no settings of its own.
    Pt,
    Rs(RsSettings),
    Pm(PmSettings),
    PmFg(PmFgSettings),
    RpmFg(RpmFgSettings),
    RsFg(RsFgSettings),
    HeFg(HeFgSettings),
    RsRc(RsRcSettings),
}

impl MethodSettings {
    /// `method` with its default settings.
    pub fn of(method: Method) -> MethodSettings {
        match method {
            Method::Pt => MethodSettings::Pt,
            Method::Rs => MethodSettings::Rs(Default::default()),
            Method::Pm => MethodSettings::Pm(Default::default()),
            Method::PmFg => MethodSettings::PmFg(Default::default()),
            Method::RpmFg => MethodSettings::RpmFg(Default::default()),
            Method::RsFg => MethodSettings::RsFg(Default::default()),
            Method::HeFg => MethodSettings::HeFg(Default::default()),
            Method::RsRc => MethodSettings::RsRc(Default::default()),
        }
    }

    pub fn method(&self) -> Method {
        match self {
            MethodSettings::Pt => Method::Pt,
            MethodSettings::Rs(_) => Method::Rs,
            MethodSettings::Pm(_) => Method::Pm,
            MethodSettings::PmFg(_) => Method::PmFg,
            MethodSettings::RpmFg(_) => Method::RpmFg,
            MethodSettings::RsFg(_) => Method::RsFg,
            MethodSettings::HeFg(_) => Method::HeFg,
            MethodSettings::RsRc(_) => Method::RsRc,
        }
    }

    /// The eye and light passes of a photon method (`None` for the path tracer).
    pub fn photon_pass(&self) -> Option<&PhotonPass> {
        match self {
            MethodSettings::Pt => None,
            MethodSettings::Rs(m) => Some(&m.pass),
            MethodSettings::Pm(m) => Some(&m.pass),
            MethodSettings::PmFg(m) => Some(&m.pass),
            MethodSettings::RpmFg(m) => Some(&m.pass),
            MethodSettings::RsFg(m) => Some(&m.pass),
            MethodSettings::HeFg(m) => Some(&m.pass),
            MethodSettings::RsRc(m) => Some(&m.pass),
        }
    }

    /// [`MethodSettings::photon_pass`], to change it.
    pub fn photon_pass_mut(&mut self) -> Option<&mut PhotonPass> {
        match self {
            MethodSettings::Pt => None,
            MethodSettings::Rs(m) => Some(&mut m.pass),
            MethodSettings::Pm(m) => Some(&mut m.pass),
            MethodSettings::PmFg(m) => Some(&mut m.pass),
            MethodSettings::RpmFg(m) => Some(&mut m.pass),
            MethodSettings::RsFg(m) => Some(&mut m.pass),
            MethodSettings::HeFg(m) => Some(&mut m.pass),
            MethodSettings::RsRc(m) => Some(&mut m.pass),
        }
    }

    /// The photon bandwidth the light pass traces with: the pass's, with `rs-rc`'s narrower
    /// kernels per photon class ([`super::rs_rc::SMOOTHNESS`]). `None` for the path tracer.
    pub fn bandwidth_in_effect(&self) -> Option<crate::photon::BandwidthParams> {
        let mut b = self.photon_pass()?.bandwidth;
        if let MethodSettings::RsRc(_) = self {
            b.class_smoothness = super::rs_rc::SMOOTHNESS;
        }
        Some(b)
    }

    fn validate(&self, spp: u32) -> Result<()> {
        let method = self.method();
        if let Some(pass) = self.photon_pass() {
            if spp > MAX_PHOTON_SPP {
                return Err(Error::param("spp", format!("{spp} eye samples per pixel is too many for --method {method} (at most {MAX_PHOTON_SPP})")));
            }
            pass.validate(spp)?;
        }
        match self {
            MethodSettings::Pt => Ok(()),
            MethodSettings::Rs(m) => m.validate(),
            MethodSettings::Pm(m) => m.validate(),
            MethodSettings::PmFg(m) => m.validate(),
            MethodSettings::RpmFg(m) => m.validate(),
            MethodSettings::RsFg(m) => m.validate(),
            MethodSettings::HeFg(m) => m.validate(),
            MethodSettings::RsRc(m) => m.validate(),
        }
    }

    fn attributes(&self, spp: u32) -> Vec<(String, String)> {
        let mut out = match self.photon_pass() {
            Some(pass) => pass.attributes(spp, self.bandwidth_in_effect().unwrap_or(pass.bandwidth)),
            None => Vec::new(),
        };
        out.extend(match self {
            MethodSettings::Pt => Vec::new(),
            MethodSettings::Rs(m) => m.attributes(),
            MethodSettings::Pm(m) => m.attributes(),
            MethodSettings::PmFg(m) => m.attributes(),
            MethodSettings::RpmFg(m) => m.attributes(),
            MethodSettings::RsFg(m) => m.attributes(),
            MethodSettings::HeFg(m) => m.attributes(),
            MethodSettings::RsRc(m) => m.attributes(),
        });
        out
    }
}

impl RenderSettings {
    /// `method`'s default settings, with the others at their defaults.
    pub fn of(method: Method) -> RenderSettings {
        RenderSettings { method: MethodSettings::of(method), ..Default::default() }
    }

    /// Check every setting, the method's included: the one validation of a render's settings.
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
        if self.crop.is_some() && !self.filter.is_pixel_box() && matches!(self.method, MethodSettings::Pt) {
            // the path tracer's filter spreads samples across the window's edge: a crop would
            // lose its neighbours' share and no longer stitch into the whole image
            return Err(Error::param("filter", "a crop or tile of pt needs --filter box (a wider filter spreads samples across the window's edge)".to_string()));
        }
        if self.threads > 4096 {
            return Err(Error::param("threads", format!("{} is absurd", self.threads)));
        }
        if let Some(size) = self.resolution {
            check_size(size)?;
        }
        if self.max_depth == 0 || self.max_depth > 1 << 16 {
            return Err(Error::param("max-depth", format!("{} is out of range (1..=65536)", self.max_depth)));
        }
        self.denoise.validate()?;
        if let Some(p) = &self.passes {
            p.validate()?;
            if self.time_budget.is_some() {
                return Err(Error::param("passes", "--passes and --time are two ways to count passes: give one"));
            }
            if self.method.method() == Method::Pt && (p.total as u64) * self.spp as u64 > 1 << 24 {
                return Err(Error::param("passes", format!("{} passes of --spp {} is more than 16777216 samples per pixel", p.total, self.spp)));
            }
        }
        self.method.validate(self.spp)
    }

    /// Settings as EXR header attributes: the shared ones, then the method's.
    pub fn attributes(&self) -> Vec<(String, String)> {
        let mut out = vec![
            ("raysplat:method".into(), self.method.method().to_string()),
            ("raysplat:spp".into(), self.spp.to_string()),
            ("raysplat:seed".into(), self.seed.to_string()),
            ("raysplat:max_depth".into(), self.max_depth.to_string()),
            ("raysplat:time_budget".into(), self.time_budget.map_or("none".into(), |t| t.to_string())),
            ("raysplat:denoise".into(), self.denoise.mode.to_string()),
            ("raysplat:denoise_quality".into(), self.denoise.quality.to_string()),
            ("raysplat:texture_filter".into(), self.texture_filter.name().into()),
            ("raysplat:pixel_filter".into(), self.filter.kind.name().into()),
            ("raysplat:pixel_filter_radius".into(), self.filter.radius.to_string()),
        ];
        if let Some(p) = &self.passes {
            out.push(("raysplat:passes".into(), p.total.to_string()));
            out.push(("raysplat:pass_range".into(), format!("{}:{}", p.first, p.end)));
            if p.fixed_bandwidth {
                out.push(("raysplat:fixed_bandwidth".into(), "true".into()));
            }
        }
        out.extend(self.method.attributes(self.spp));
        out
    }
}

/// Check a cache error ε (`--cache-error`): in (0, 10].
pub fn check_cache_error(e: f32) -> Result<()> {
    if !(e > 0.0 && e <= 10.0) {
        return Err(Error::param("cache-error", format!("{e} is out of range (0, 10]")));
    }
    Ok(())
}

/// `("raysplat:<name>", value)`, for the settings' [`RenderSettings::attributes`].
pub(super) fn attribute(name: &str, value: impl ToString) -> (String, String) {
    (format!("raysplat:{name}"), value.to_string())
}

/// An optional value as an attribute: the value, or `none`.
pub(super) fn or_none<T: ToString>(v: Option<T>) -> String {
    v.map_or("none".into(), |v| v.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every method's header attributes have distinct names: `merge` and `denoise` read them back
    /// by name, and a name given twice (a pixel filter's radius and `rs`'s image-space filter's)
    /// made equal parts look different.
    #[test]
    fn header_attribute_names_are_distinct() {
        for &m in Method::ALL {
            let s = RenderSettings { passes: Some(Passes::all(4)), crop: Some([0, 0, 1, 1]), ..RenderSettings::of(m) };
            let mut names: Vec<String> = s.attributes().into_iter().map(|(k, _)| k).collect();
            let n = names.len();
            names.sort();
            names.dedup();
            assert_eq!(names.len(), n, "{m}: a header attribute is named twice");
        }
    }
}
