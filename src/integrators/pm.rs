//! `--method pm`: direct visualisation of classic photon maps — a global map (indirect, plus direct
//! photons when asked for) and a caustic map — with k-nearest-neighbour density estimation at the
//! eye samples. Same eye pass, photons and kd-tree code as `rs`, so the comparison is fair.

use super::compose::{self, PhotonPass};
use super::settings::attribute;
use super::{Progress, RenderSettings, Stats};
use crate::error::{Error, Result};
use crate::eye::EyeSample;
use crate::image::Film;
use crate::kdtree::KnnHeap;
use crate::photon::PhotonMap;
use crate::prepare::PreparedScene;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// Eye samples per parallel work item (fixed: results do not depend on the thread count).
const CHUNK: usize = 1024;

/// Settings of `pm`.
#[derive(Clone, Debug, PartialEq)]
pub struct PmSettings {
    pub pass: PhotonPass,
    /// Neighbours per density estimate (global map; the caustic map uses half).
    pub knn: usize,
}

impl Default for PmSettings {
    fn default() -> Self {
        PmSettings { pass: PhotonPass::default(), knn: KNN }
    }
}

impl PmSettings {
    pub fn validate(&self) -> Result<()> {
        check_knn(self.knn)
    }

    pub(super) fn attributes(&self) -> Vec<(String, String)> {
        vec![attribute("knn", self.knn)]
    }
}

/// Default neighbours per density estimate of the photon maps (`pm`, and the gathering methods'
/// maps): about the mean splat radius of `rs` at its default bandwidth.
pub const KNN: usize = 100;

/// Check a neighbour count (`--knn`).
pub fn check_knn(knn: usize) -> Result<()> {
    if knn == 0 || knn > 100_000 {
        return Err(crate::error::Error::param("knn", format!("{knn} is out of range (1..=100000)")));
    }
    Ok(())
}

pub fn render(scene: &PreparedScene, s: &RenderSettings, m: &PmSettings, progress: &dyn Progress, stats: &mut Stats) -> Result<Film> {
    let (eye, photons) = compose::eye_and_light(scene, s, progress, stats)?;
    let t = Instant::now();
    let global = PhotonMap::build(
        &[&photons.rays[0], &photons.rays[1]],
        &[&photons.ends_diffuse[0], &photons.ends_diffuse[1]],
    )?;
    let caustic = PhotonMap::build(&[&photons.rays[2]], &[&photons.ends_diffuse[2]])?;
    stats.phase("build", t.elapsed().as_secs_f64());
    stats.enable("global photon map", global.bytes());
    if !caustic.is_empty() {
        stats.enable("caustic photon map", caustic.bytes());
    }
    let max_r = photons.bandwidth.h_max.max(1e-30) as f32 * 5.0;
    let (k_global, k_caustic) = (m.knn, (m.knn / 2).max(1));
    progress.begin("density estimation", eye.samples.len().div_ceil(CHUNK) as u64);
    let t = Instant::now();
    let per_sample: Vec<(Vec3, f32, u32)> = eye
        .samples
        .par_chunks(CHUNK)
        .flat_map_iter(|chunk| {
            if progress.cancelled() {
                return vec![(Vec3::ZERO, 0.0, 0); chunk.len()]; // discarded below
            }
            let mut heap = KnnHeap::with_capacity(k_global);
            let out: Vec<(Vec3, f32, u32)> = chunk
                .iter()
                .map(|e: &EyeSample| {
                    let (p, n) = (e.pos(), e.normal());
                    // the sample's BSDF with its per-`wo` work done once, for every photon found
                    let g = e.is_glossy().then(|| eye.glossy.sample(e.glossy as usize));
                    let f = |wi: Vec3| g.as_ref().map_or(Vec3::ONE, |g| g.eval(wi));
                    let (lg, rg, ng) = global.estimate(p, n, k_global, max_r, &mut heap, f);
                    let (lc, _, nc) = caustic.estimate(p, n, k_caustic, max_r, &mut heap, f);
                    (e.weight() * (lg + lc), rg, (ng + nc) as u32)
                })
                .collect();
            progress.advance(1);
            out
        })
        .collect();
    if progress.cancelled() {
        return Err(Error::Cancelled);
    }
    stats.phase("estimate", t.elapsed().as_secs_f64());
    progress.finish();
    let mut indirect = vec![Vec3::ZERO; (eye.width * eye.height) as usize];
    let (mut rsum, mut found) = (0.0f64, 0u64);
    for (e, (l, r, n)) in eye.samples.iter().zip(&per_sample) {
        indirect[e.pixel as usize] += *l;
        rsum += *r as f64;
        found += *n as u64;
    }
    stats.count("photons_found", found);
    if !eye.samples.is_empty() {
        stats.count("mean_bandwidth_um", (rsum / eye.samples.len() as f64 * 1e6) as u64);
    }
    compose::film(&eye, &indirect)
}
