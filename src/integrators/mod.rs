//! Rendering methods. Each method is a composition of shared stages over a `PreparedScene` and
//! returns a `Film` (beauty + AOVs) and `Stats` (phase times, counts, memory).
//!
//! - `pt`: the unbiased reference path tracer (next-event estimation + MIS, Russian roulette).
//! - `rs`: photon ray splatting.
//! - `pm`: classic photon maps visualised directly (the baseline for `rs`).

mod aov;
mod compose;
pub mod pm;
pub mod pt;
pub mod rs;
pub mod rs_rc;
mod settings;
mod stats;

pub use settings::{Method, RenderSettings};
pub use stats::{Progress, SilentProgress, Stats};

use crate::error::{Error, Result};
use crate::image::Film;
use crate::prepare::PreparedScene;
use crate::scene::SceneDesc;
use std::time::Instant;

/// The result of a render.
pub struct RenderOutput {
    pub film: Film,
    pub stats: Stats,
}

/// Render `scene` with `settings`. Progress is reported to `progress`, which can also cancel.
pub fn render(scene: SceneDesc, settings: &RenderSettings, progress: &dyn Progress) -> Result<RenderOutput> {
    settings.validate()?;
    let [w, h] = settings.resolution.or(scene.resolution).unwrap_or([512, 512]);
    if w == 0 || h == 0 || w > 65536 || h > 65536 {
        return Err(Error::param("resolution", format!("{w}x{h} is out of range (1..=65536 per side)")));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(settings.threads)
        .build()
        .map_err(|e| Error::param("threads", e.to_string()))?;
    pool.install(|| {
        let t0 = Instant::now();
        let mut stats = Stats::default();
        let prepared = PreparedScene::new(scene, w, h, settings.threads)?;
        stats.phase("prepare", t0.elapsed().as_secs_f64());
        stats.note_requirements(&prepared.requirements);
        let film = match settings.method {
            Method::Pt => pt::render(&prepared, settings, progress, &mut stats)?,
            Method::Rs => rs::render(&prepared, settings, progress, &mut stats)?,
            Method::Pm => pm::render(&prepared, settings, progress, &mut stats)?,
            Method::RsRc => rs_rc::render(&prepared, settings, progress, &mut stats)?,
        };
        stats.total_seconds = t0.elapsed().as_secs_f64();
        stats.warnings = prepared.warnings.len();
        Ok(RenderOutput { film, stats })
    })
}
