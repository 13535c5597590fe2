//! The radiance map of §8.1 (`photon-ray-splatting.md`): per-pixel directional records of incoming
//! light for pixels whose eye samples are glossy, filled during splatting and integrated against
//! each glossy eye sample's BSDF at the end. Two representations:
//!
//! - **SH** (`--glossy sh`): 16 real spherical-harmonic coefficients per colour channel (bands 0–3)
//!   of the cosine-weighted incoming radiance; BSDFs come from [`ShTables`] ([`bsdf_table`]).
//! - **Histogram** (`--glossy histogram`): 20 dodecahedral strata with a directional filter
//!   ([`histogram`]), integrated by BSDF sampling.
//!
//! `--glossy exact` (the default) keeps evaluating each glossy eye sample's BSDF per splatted photon
//! — the reference for both maps. Diffuse pixels never get a map: their eye samples fold albedo/π
//! into the weight and the splat image's single RGB value per pixel is their one coefficient.
//!
//! A pixel's map holds the *sum* over its glossy eye samples of their cosine-weighted incoming
//! radiance (each eye sample's own normal gives its cosine); the final integration divides by the
//! pixel's number of glossy eye samples and applies each sample's weight and BSDF to that mean —
//! incoming light is shared by the pixel, the BSDF and view are per sample.
//!
//! Sharing is only valid among eye samples on one surface: light that reached one sample from below
//! another sample's horizon would be integrated by the other against the (even-extended) BSDF's
//! values below its surface. On `cornell-glossy.usda` (48², seed 4) a pixel at the glossy block's
//! foot, with eye samples on differently oriented surfaces, had a relative squared error of 107 with
//! the SH map and 37 with the histogram, against 2.6 with the exact BSDF (docs/glossy.md). So a
//! pixel holds one *slot* (set of records) per surface: a glossy sample joins the first slot of its
//! pixel whose first sample's normal is within [`SAME_SURFACE_COS`] of its own, or opens a new one
//! ([`RadianceMap::slot_of_glossy`]). Most pixels have one slot; pixels on edges and corners two
//! or three.

pub mod bsdf_table;
pub mod histogram;
#[cfg(test)]
mod tests;

use crate::error::{Error, Result};
use crate::eye::{EyePass, EyeSample};
use crate::sh;
use glam::Vec3;

pub use bsdf_table::{sh_residual, BsdfShTable, ShTables};
use histogram::{Strata, STRATA};
use rayon::prelude::*;
use std::fmt;
use std::str::FromStr;

/// How glossy eye samples receive splatted light.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum GlossyMode {
    /// Per material: the SH radiance map where bands 0–3 hold the BSDF's lobe (its relative
    /// residual at most [`SH_RESIDUAL_MAX`]), the exact BSDF per photon elsewhere.
    #[default]
    Auto,
    /// BSDF evaluated per splatted photon.
    Exact,
    /// Spherical-harmonics radiance map.
    Sh,
    /// 20-strata histogram radiance map.
    Histogram,
}

impl GlossyMode {
    pub const ALL: &'static [GlossyMode] = &[GlossyMode::Auto, GlossyMode::Exact, GlossyMode::Sh, GlossyMode::Histogram];
    pub fn name(self) -> &'static str {
        match self {
            GlossyMode::Auto => "auto",
            GlossyMode::Exact => "exact",
            GlossyMode::Sh => "sh",
            GlossyMode::Histogram => "histogram",
        }
    }
    /// Records per pixel and colour channel (0: no map).
    pub fn records(self) -> usize {
        match self {
            GlossyMode::Exact => 0,
            GlossyMode::Sh | GlossyMode::Auto => sh::N,
            GlossyMode::Histogram => STRATA,
        }
    }
}

impl fmt::Display for GlossyMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for GlossyMode {
    type Err = Error;
    fn from_str(s: &str) -> Result<GlossyMode> {
        GlossyMode::ALL.iter().copied().find(|m| m.name() == s).ok_or_else(|| {
            Error::param("glossy", format!("unknown glossy representation {s:?} (available: auto, exact, sh, histogram)"))
        })
    }
}

/// Glossy eye samples of one pixel share a slot only if their normal and the slot's first sample's
/// have at least this cosine (the normal test of the image-space filter's discontinuity buffer,
/// [`crate::radiance_filter::FilterParams`]).
pub const SAME_SURFACE_COS: f32 = 0.8;

/// Per-pixel directional records, only for pixels with glossy eye samples: one slot per surface
/// the pixel's glossy samples lie on. Slots are numbered in pixel order, a pixel's slots
/// contiguously from `slot_of[pixel]`.
pub struct RadianceMap {
    pub mode: GlossyMode,
    /// Records per slot (16 or 20).
    pub k: usize,
    /// First slot per pixel (`u32::MAX`: no glossy eye sample, no map).
    pub slot_of: Vec<u32>,
    /// Slots per pixel (0 without a glossy eye sample).
    pub pixel_slots: Vec<u32>,
    /// Slot per glossy eye sample (index into `EyePass::glossy`).
    pub slot_of_glossy: Vec<u32>,
    /// Glossy eye samples per slot.
    pub glossy_count: Vec<u32>,
    /// `slots × k` RGB records.
    pub records: Vec<Vec3>,
    /// The SH BSDF tables, when built before splatting (`GlossyMode::Auto` decides with them).
    pub tables: Option<ShTables>,
    /// Glossy eye samples outside the map, whose BSDF is evaluated per photon (`Auto` only).
    pub exact_samples: usize,
}

/// `GlossyMode::Auto` puts a material's glossy eye samples in the SH map when bands 0–3 misplace
/// at most this share of its reflected light ([`sh_residual`], at its darkest diffuse factor):
/// rough lobes (0.086) integrate from SH with the exact BSDF's error, sharper ones (above 1.5)
/// with more (docs/glossy.md).
pub const SH_RESIDUAL_MAX: f32 = 0.15;

/// `Auto` builds no more SH tables than this before splatting (textured roughness makes one per
/// distinct texel value): glossy samples with more distinct lobes all keep the exact BSDF.
pub const AUTO_MAX_TABLES: usize = 256;

impl RadianceMap {
    /// An empty map for the glossy pixels of `eye` (slots in pixel order; `eye.samples` are in
    /// pixel order).
    pub fn new(mode: GlossyMode, eye: &EyePass) -> RadianceMap {
        Self::new_for(mode, eye, |_| true)
    }

    /// `GlossyMode::Auto`'s map: SH slots for the glossy eye samples whose material's lobe SH
    /// bands 0–3 hold ([`SH_RESIDUAL_MAX`]), the tables built here and kept for the resolve.
    /// `Err(why)` when no glossy sample qualifies (every glossy sample then takes the exact BSDF).
    pub fn auto(eye: &EyePass) -> std::result::Result<RadianceMap, &'static str> {
        Self::auto_with(eye, Self::auto_tables(eye)?)
    }

    /// The SH tables [`auto`](Self::auto) builds: the lobes SH holds projected, at most
    /// [`AUTO_MAX_TABLES`].
    pub fn auto_tables(eye: &EyePass) -> std::result::Result<ShTables, &'static str> {
        ShTables::build_where(&eye.glossy, AUTO_MAX_TABLES, |r| r <= SH_RESIDUAL_MAX).ok_or("more distinct glossy lobes than auto projects")
    }

    /// [`auto`](Self::auto) with the SH tables of `eye`'s glossy samples already built (by
    /// [`ShTables::build`] or `build_where`; the lobes SH does not hold need no projection).
    pub fn auto_with(eye: &EyePass, tables: ShTables) -> std::result::Result<RadianceMap, &'static str> {
        Self::auto_within(eye, tables, |_| true)
    }

    /// [`auto_with`](Self::auto_with) for the eye samples `within` accepts only (the others get no
    /// slot, as if exact, and must receive no photon: e.g. the samples of image tiles a sparse set
    /// of photon rays does not reach).
    pub fn auto_within(eye: &EyePass, tables: ShTables, within: impl Fn(&EyeSample) -> bool) -> std::result::Result<RadianceMap, &'static str> {
        if tables.tables.len() > AUTO_MAX_TABLES {
            return Err("more distinct glossy lobes than auto projects");
        }
        let fits: Vec<bool> = tables.tables.iter().map(|t| t.residual <= SH_RESIDUAL_MAX).collect();
        if !fits.iter().any(|&f| f) {
            return Err("no glossy lobe within SH bands 0–3");
        }
        let mut map = Self::new_for(GlossyMode::Auto, eye, |e| fits[tables.table_of[e.glossy as usize] as usize] && within(e));
        map.exact_samples = tables.table_of.iter().filter(|&&t| !fits[t as usize]).count();
        map.tables = Some(tables);
        Ok(map)
    }

    /// A map over the glossy eye samples `keep` accepts; the others get no slot
    /// (`slot_of_glossy` = `u32::MAX`).
    pub fn new_for(mode: GlossyMode, eye: &EyePass, keep: impl Fn(&EyeSample) -> bool) -> RadianceMap {
        let k = mode.records();
        let n = (eye.width * eye.height) as usize;
        let mut slot_of = vec![u32::MAX; n];
        let mut pixel_slots = vec![0u32; n];
        let mut slot_of_glossy = vec![u32::MAX; eye.glossy.len()];
        let mut glossy_count = Vec::new();
        // the current pixel's slots: (slot, normal of its first sample)
        let mut open: Vec<(u32, Vec3)> = Vec::new();
        let mut pixel = u32::MAX;
        for e in eye.samples.iter().filter(|e| e.is_glossy() && keep(e)) {
            if e.pixel != pixel {
                debug_assert!(pixel == u32::MAX || e.pixel > pixel, "eye samples must be in pixel order");
                pixel = e.pixel;
                open.clear();
            }
            let nrm = e.normal();
            let slot = match open.iter().find(|(_, n0)| nrm.dot(*n0) >= SAME_SURFACE_COS) {
                Some(&(s, _)) => s,
                None => {
                    let s = glossy_count.len() as u32;
                    glossy_count.push(0);
                    open.push((s, nrm));
                    if slot_of[pixel as usize] == u32::MAX {
                        slot_of[pixel as usize] = s;
                    }
                    pixel_slots[pixel as usize] += 1;
                    s
                }
            };
            glossy_count[slot as usize] += 1;
            slot_of_glossy[e.glossy as usize] = slot;
        }
        // zeroed pages: a slot no photon reaches is read from the shared zero page, never written
        let records = bytemuck::zeroed_vec(glossy_count.len() * k);
        RadianceMap { mode, k, slot_of, pixel_slots, slot_of_glossy, glossy_count, records, tables: None, exact_samples: 0 }
    }

    pub fn slots(&self) -> usize {
        self.glossy_count.len()
    }

    /// Memory of the map: the records plus the slot indices.
    pub fn bytes(&self) -> u64 {
        (self.records.len() * 12 + (self.slot_of.len() + self.pixel_slots.len() + self.slot_of_glossy.len() + self.glossy_count.len()) * 4) as u64
    }

    /// Slots beyond the first of their pixel (pixels whose glossy samples lie on several surfaces).
    pub fn extra_slots(&self) -> usize {
        self.slots() - self.slot_of.iter().filter(|&&s| s != u32::MAX).count()
    }
}

/// Spreads one photon's contribution over a map's records.
#[derive(Clone, Copy)]
pub enum Encoder {
    Sh,
    Histogram(&'static Strata),
}

impl Encoder {
    pub fn new(mode: GlossyMode) -> Option<Encoder> {
        match mode {
            GlossyMode::Exact => None,
            GlossyMode::Sh | GlossyMode::Auto => Some(Encoder::Sh),
            GlossyMode::Histogram => Some(Encoder::Histogram(Strata::get())),
        }
    }
    pub fn records(self) -> usize {
        match self {
            Encoder::Sh => sh::N,
            Encoder::Histogram(_) => STRATA,
        }
    }
    /// One photon's flux `flux` arriving from world direction `wi` (pointing away from the
    /// surface), spread over the records once per photon ray: every (eye sample, photon ray) pair
    /// then only scales it ([`PhotonCode::add`]).
    #[inline]
    pub fn encode(self, wi: Vec3, flux: Vec3) -> PhotonCode {
        match self {
            Encoder::Sh => {
                let y = sh::eval(wi);
                PhotonCode::Sh(std::array::from_fn(|j| flux * y[j]))
            }
            Encoder::Histogram(s) => PhotonCode::Histogram(s.weights(wi), flux),
        }
    }
}

/// A photon's flux spread over a map's records ([`Encoder::encode`]).
pub enum PhotonCode {
    /// The flux times each SH basis function at the photon's direction.
    Sh([Vec3; sh::N]),
    /// The strata and filter weights of the photon's direction, and its flux.
    Histogram(&'static [(u8, f32); histogram::SPREAD], Vec3),
}

impl PhotonCode {
    /// Add `s` times this photon's records to `out` (`s`: the pair's kernel weight times cosine).
    #[inline(always)]
    pub fn add(&self, s: f32, out: &mut [Vec3]) {
        match self {
            PhotonCode::Sh(c) => {
                // 48 floats, contiguous on both sides: one vectorisable loop
                let out: &mut [f32] = bytemuck::cast_slice_mut(&mut out[..sh::N]);
                let c: &[f32] = bytemuck::cast_slice(c.as_slice());
                for (o, c) in out.iter_mut().zip(c) {
                    *o += c * s;
                }
            }
            PhotonCode::Histogram(w, flux) => {
                let v = *flux * s;
                for &(k, w) in w.iter() {
                    out[k as usize] += v * w;
                }
            }
        }
    }
}

/// BSDF samples per glossy eye sample for the histogram's final integration (`n²`, stratified).
pub const HISTOGRAM_BSDF_SAMPLES: u32 = 8;

/// Final integration: the reflected radiance of every glossy eye sample from its pixel's map,
/// weighted by the eye sample's weight, summed per pixel into `radiance`. Returns the memory of the
/// BSDF tables built (SH) — deterministic: per-sample values are computed in parallel and summed in
/// sample order.
pub fn resolve(eye: &EyePass, map: &RadianceMap, seed: u64, radiance: &mut [Vec3]) -> (u64, usize) {
    let tables = match map.mode {
        GlossyMode::Sh if map.tables.is_none() => Some(ShTables::build(&eye.glossy)),
        _ => None,
    };
    let tables = map.tables.as_ref().or(tables.as_ref());
    let strata = Strata::get();
    let values: Vec<(u32, Vec3)> = eye
        .samples
        .par_iter()
        // glossy samples outside the map (`Auto`'s exact ones) already have their light
        .filter(|e| e.is_glossy() && map.slot_of_glossy[e.glossy as usize] != u32::MAX)
        .filter_map(|e| {
            let slot = map.slot_of_glossy[e.glossy as usize] as usize;
            let inv = 1.0 / map.glossy_count[slot] as f32;
            let rec = &map.records[slot * map.k..(slot + 1) * map.k];
            // a slot no photon reached integrates to zero: skip it (unlit pixels; much of
            // rs-rc's caustic map)
            if rec.iter().all(|v| *v == Vec3::ZERO) {
                return None;
            }
            let g = &eye.glossy.lobe(e.glossy as usize);
            let l = match (map.mode, tables) {
                (GlossyMode::Sh | GlossyMode::Auto, Some(t)) => {
                    let c: [Vec3; sh::N] = std::array::from_fn(|i| rec[i] * inv);
                    t.integrate(e.glossy as usize, g, &c)
                }
                (GlossyMode::Histogram, _) => {
                    let h: [Vec3; STRATA] = std::array::from_fn(|i| rec[i] * inv);
                    strata.integrate(g, &h, HISTOGRAM_BSDF_SAMPLES, histogram::seed_of(seed, e.glossy as usize))
                }
                _ => Vec3::ZERO,
            };
            Some((e.pixel, e.weight() * l.max(Vec3::ZERO)))
        })
        .collect();
    for (p, v) in values {
        radiance[p as usize] += v;
    }
    tables.map_or((0, 0), |t| (t.bytes(), t.tables.len()))
}
