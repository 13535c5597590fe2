//! Why `auto` chose what it chose: the rule that decided, with the figures it decided on
//! ([`AutoReason`]); front ends print its one-line form (`Display`) or read the fields.

use super::{Quality, Survey, TIMED_PT_SPP};
use crate::integrators::Method;
use std::fmt;

/// The rule that decided.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rule {
    /// Specular surfaces make caustics: the photon map.
    Caustics,
    /// At least [`super::STRONG_SECONDARY_SHARE`] of the survey's photons in high-energy voxels: ray
    /// splatting.
    StrongSecondaryLight,
    /// A closed room with small lights, a draft or a preview (or a time in which the path tracer
    /// would reach fewer than [`TIMED_PT_SPP`] samples per pixel): ray splatting with camera samples.
    BouncedLight,
    /// Under `--time`: `rs-rc`'s passes with the path tracer as their rival, the time after the
    /// first passes going where their measured figures predict the lowest error (more passes,
    /// direct-only camera samples, or the path tracer, blended: `integrators::allocation`).
    PredictedError,
    /// The path tracer, for this reason.
    PathTracer(KeepPt),
}

impl Rule {
    /// "caustics", "strong secondary light", "bounced light", or "path tracer: " and its reason.
    pub fn name(&self) -> String {
        match self {
            Rule::Caustics => "caustics".into(),
            Rule::StrongSecondaryLight => "strong secondary light".into(),
            Rule::BouncedLight => "bounced light".into(),
            Rule::PredictedError => "predicted error".into(),
            Rule::PathTracer(k) => format!("path tracer: {}", k.name()),
        }
    }
}

/// Why a scene without caustics or strong secondary light keeps the path tracer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KeepPt {
    /// Final quality: the path tracer keeps converging.
    Converges,
    /// A time budget in which the path tracer reaches at least [`TIMED_PT_SPP`] samples per pixel
    /// (this many).
    TimeForSamples(u64),
    /// Less than [`super::INDIRECT_SHARE`] of the light bounced.
    DirectLight,
    /// At least [`super::EMITTER_AREA_SHARE`] of the surface area emits.
    LargeEmitters,
    /// Fewer than [`super::MIN_PIXELS`] pixels.
    SmallImage,
    /// `--spp` without `--photons`.
    SamplesGiven,
    /// Under `--time`, the path tracer's noise is so mostly direct that photon passes could not
    /// repay their light pass and the passes that measure them (`super::photons_could_win`).
    DirectNoise,
    /// Under `--time`, no photon pass fits [`super::PILOT_PASSES`] times in the time left (or the
    /// scene has no light): the passes could not measure their figures.
    NoTimeForPasses,
}

impl KeepPt {
    pub fn name(self) -> &'static str {
        match self {
            KeepPt::Converges => "final quality",
            KeepPt::TimeForSamples(_) => "time for samples",
            KeepPt::DirectLight => "direct light",
            KeepPt::LargeEmitters => "large emitters",
            KeepPt::SmallImage => "small image",
            KeepPt::SamplesGiven => "samples given",
            KeepPt::NoTimeForPasses => "no time for passes",
            KeepPt::DirectNoise => "direct noise",
        }
    }
}

/// `auto`'s choice and the figures behind it.
#[derive(Clone, Debug, PartialEq)]
pub struct AutoReason {
    pub method: Method,
    pub rule: Rule,
    /// The preset asked for (preview unless given; under a time budget, the one the time stands for
    /// decides, see `timed_quality`).
    pub quality: Quality,
    /// The time budget asked for, in seconds.
    pub time: Option<f64>,
    /// The survey of the scene's light (`None` for a scene with specular surfaces, which takes the
    /// photon map without one).
    pub survey: Option<Survey>,
    /// Under a time budget: the path tracer's samples per pixel predicted for the time left.
    pub pt_spp_in_time: Option<f64>,
    /// Under a time budget: the time left after the survey, in seconds.
    pub time_left: Option<f64>,
    /// The image size.
    pub size: [u32; 2],
    /// The budget chosen: samples per pixel (a photon method's eye samples), camera samples per
    /// pixel and stored photons (photon methods).
    pub spp: u32,
    pub aa_spp: u32,
    pub photons: usize,
}

impl AutoReason {
    /// Share of the survey's photons in high-energy voxels (0 without a survey).
    pub fn high_energy_share(&self) -> f64 {
        self.survey.as_ref().map_or(0.0, Survey::share)
    }
    /// Share of the light arriving at surfaces that has bounced (0 without a survey).
    pub fn indirect_share(&self) -> f64 {
        self.survey.as_ref().map_or(0.0, |s| s.indirect_share)
    }
    /// Share of the surface area that emits (0 without a survey).
    pub fn emitter_area_share(&self) -> f64 {
        self.survey.as_ref().map_or(0.0, |s| s.emitter_area_share)
    }
    /// Seconds the survey took (0 without a survey).
    pub fn survey_seconds(&self) -> f64 {
        self.survey.as_ref().map_or(0.0, |s| s.seconds)
    }

    fn quality_name(&self) -> String {
        format!("{:?}", self.quality).to_lowercase()
    }

    /// "preview quality" or "2 s".
    fn budget(&self) -> String {
        match self.time {
            Some(t) => format!("{t} s"),
            None => format!("{} quality", self.quality_name()),
        }
    }

    /// The photon budget: "N photons, E eye spp, C camera spp", as passes under a time budget.
    fn passes(&self) -> String {
        let what = format!("{} photons, {} eye spp, {} camera spp", self.photons, self.spp, self.aa_spp.max(self.spp));
        if self.time.is_some() {
            format!("passes of {what}")
        } else {
            what
        }
    }
}

impl fmt::Display for AutoReason {
    /// One line: `auto: METHOD for BUDGET — why; budget (the survey's time)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let budget = self.budget();
        let (strong, indirect, emitters) = (self.high_energy_share(), self.indirect_share(), self.emitter_area_share());
        let no_caustics = match self.survey.map_or(0, |s| s.photons) {
            0 => "no caustics, no light pass traced".to_string(),
            _ => format!("no caustics, no strong secondary light ({:.1} % of the survey's photons in high-energy voxels)", 100.0 * strong),
        };
        let why = match self.rule {
            Rule::Caustics => format!("specular surfaces make caustics, which photons resolve faster than the path tracer; {}", self.passes()),
            Rule::StrongSecondaryLight => format!(
                "strong secondary light ({:.1} % of the survey's photons land in high-energy voxels), which the path tracer finds only by BSDF sampling; {}",
                100.0 * strong,
                self.passes()
            ),
            Rule::BouncedLight => {
                let what = match self.time {
                    Some(_) => format!("in {budget} the path tracer would reach about {:.0} spp (fewer than {TIMED_PT_SPP}):", self.pt_spp_in_time.unwrap_or(f64::INFINITY)),
                    None => format!("for a {}", self.quality_name()),
                };
                format!(
                    "{no_caustics}, {:.0} % of the light bounced, {:.1} % of the surface area emits: {what} ray splatting with camera samples reaches the path tracer's error sooner; {}",
                    100.0 * indirect,
                    100.0 * emitters,
                    self.passes()
                )
            }
            Rule::PredictedError => {
                let sv = self.survey.as_ref();
                let [vd, vi] = sv.and_then(|s| s.pt_variance).unwrap_or([0.0; 2]);
                let share = sv.and_then(|s| s.pt_relative_indirect_noise()).unwrap_or(f64::NAN);
                let left = self.time_left.unwrap_or(0.0);
                let pt = sv.and_then(|s| s.rival()).map_or(f64::INFINITY, |r| r.predicted(left));
                let pass = sv.and_then(|s| super::pass_seconds(s, self.photons, self.aa_spp.max(self.spp))).unwrap_or(f64::NAN);
                let fit = if pass > 0.0 { (left / pass).floor() } else { 0.0 };
                let single = (self.spp, self.aa_spp) == (super::SINGLE_PASS_SPP, super::SINGLE_PASS_CAMERA_SPP);
                let then = if !single {
                    "the first passes measure their variance and bias"
                } else {
                    "a single pass, its indirect light's error measured against the path tracer's first samples"
                };
                format!(
                    "{no_caustics}; the path tracer's probe: variance {vd:.2e} direct + {vi:.2e} indirect per sample ({:.0} % of the relative variance indirect), about {:.0} spp in the {left:.2} s left (predicted MSE {pt:.2e}); {} (about {pass:.2} s each, {fit} fit): {then}, then the time left goes where the predicted error is lowest — more passes, direct-only camera samples, or the path tracer, blended with the path tracer's samples",
                    100.0 * share,
                    self.pt_spp_in_time.unwrap_or(f64::INFINITY),
                    self.passes(),
                )
            }
            Rule::PathTracer(keep) => {
                let bounced = format!("{:.0} % of the light bounced", 100.0 * indirect);
                let [w, h] = self.size;
                let because = match keep {
                    KeepPt::Converges => "the path tracer converges where the photon methods' bias stops them".to_string(),
                    KeepPt::TimeForSamples(n) => format!("in {budget} the path tracer reaches about {n} spp, where it converges past the photon methods' bias"),
                    KeepPt::DirectLight => format!("{bounced}: mostly direct light, which the path tracer resolves best"),
                    KeepPt::LargeEmitters => format!("{bounced}, but {:.0} % of the surface area emits, which the path tracer's paths find by themselves", 100.0 * emitters),
                    KeepPt::SmallImage => format!("{bounced}, but the image has only {w}x{h} pixels, too few to repay a light pass"),
                    KeepPt::SamplesGiven => format!("{bounced}; --spp fixes the path tracer's samples (without it a {} would take ray splatting)", self.quality_name()),
                    KeepPt::DirectNoise => {
                        let f = self.survey.and_then(|s| s.pt_relative_indirect_noise()).unwrap_or(0.0);
                        format!(
                            "the path tracer's first samples put {:.0} % of its relative variance in the indirect light: photon passes, which lower that part, could not repay their light pass and the passes that measure them (even at best, their camera samples as efficient as its paths)",
                            100.0 * f
                        )
                    }
                    KeepPt::NoTimeForPasses => match self.survey.filter(|s| s.photons > 0).and_then(|s| super::pass_seconds(&s, super::PASS_PHOTONS[super::PASS_PHOTONS.len() - 1], super::SINGLE_PASS_CAMERA_SPP)) {
                        Some(t) => format!("a pass of the fewest photons takes about {t:.2} s, more than the {:.2} s left", self.time_left.unwrap_or(0.0)),
                        None => match self.survey.and_then(|s| s.pt_seconds_per_spp) {
                            Some(per_spp) => format!(
                                "a pass's camera samples alone (about {:.2} s) do not fit in the {:.2} s left, or the scene has no light: no light pass traced",
                                super::SINGLE_PASS_CAMERA_SPP as f64 * super::CAMERA_OVER_PATH * per_spp,
                                self.time_left.unwrap_or(0.0)
                            ),
                            None => "no light for photons".to_string(),
                        },
                    },
                };
                let how = if self.time.is_some() { "samples until the time is spent (the pilot's first samples among them)".to_string() } else { format!("{} spp", self.spp) };
                format!("{no_caustics}; {because}; {how}")
            }
        };
        let spent = self.survey_seconds();
        let note = match (self.time, &self.survey) {
            (Some(_), Some(sv)) if spent > 0.0 => format!(" (the survey took {spent:.2} s of the {budget}, its light pass of {} photons {:.2} s)", sv.photons, sv.light_seconds),
            _ => String::new(),
        };
        write!(f, "auto: {} for {budget} — {why}{note}", self.method)
    }
}
