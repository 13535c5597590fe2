//! `--method pm-fg | rpm-fg | rs-fg`: final gathering (`reverse-photon-mapping.md`, §8.4 of
//! `photon-ray-splatting.md`). Shared: the eye pass (direct light by light sampling), the light pass
//! (direct + indirect + caustic photons: the gather hits need all the light arriving there), the
//! caustics by direct visualisation at the primary eye samples, and the gather stage
//! (`crate::gather`) run task by task as the memory scheduler plans. The methods differ in how the
//! radiance along the gather rays is found:
//! - `pm-fg`: a search in the global photon map per gather hit (kNN, or `--gather-radius`);
//! - `rpm-fg`: a search in the kd-tree over the gather hits per photon (adaptive radius, or
//!   `--gather-radius`), batched, into the write-back array;
//! - `rs-fg`: the gather hits become the eye samples of photon ray splatting.

use super::compose::{self, PhotonPass};
use super::settings::{attribute, check_cache_error, or_none};
use super::{Method, Progress, RenderSettings, Stats};
use crate::error::{Error, Result};
use crate::eye::{EyePass, EyeSample};
use crate::gather::spill::Spill;
use crate::gather::{self, forward, rpm, schedule, FgSettings, Kernel, ReversePhoton};
use crate::image::Film;
use crate::kdtree::KnnHeap;
use crate::photon::{PhotonMap, PhotonSet};
use crate::prepare::PreparedScene;
use crate::splat;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// Eye samples per parallel work item of the caustic estimate.
const CHUNK: usize = 1024;

/// Per-method totals over the tasks.
#[derive(Default)]
struct Totals {
    gather_s: f64,
    /// CPU time of all threads while tracing gather rays (tasks in memory).
    gather_cpu_s: f64,
    build_s: f64,
    search_s: f64,
    complete_s: f64,
    rays: u64,
    hits: u64,
    found: u64,
    peak_a_r: u64,
    tree_bytes: u64,
}

/// Settings of `pm-fg`.
#[derive(Clone, Debug, PartialEq)]
pub struct PmFgSettings {
    pub pass: PhotonPass,
    /// Neighbours of the global map's estimate at a gather hit (kNN kernel; the caustic map uses half).
    pub knn: usize,
    /// Gather rays, fixed radius, memory budget, spill, density control.
    pub fg: FgSettings,
    /// Ward's irradiance cache: the gather runs per point at Lambertian eye samples
    /// ([`super::he_fg::gather_per_point`] with one global map and `fg.rays` stratified rays).
    pub irradiance_cache: bool,
    /// The irradiance cache's error ε.
    pub cache_error: f32,
}

impl Default for PmFgSettings {
    fn default() -> Self {
        PmFgSettings { pass: PhotonPass::default(), knn: super::pm::KNN, fg: FgSettings::default(), irradiance_cache: false, cache_error: super::he_fg::CACHE_ERROR }
    }
}

impl PmFgSettings {
    pub fn validate(&self) -> Result<()> {
        super::pm::check_knn(self.knn)?;
        self.fg.validate()?;
        check_cache_error(self.cache_error)?;
        if self.irradiance_cache && self.fg.gather_radius.is_some() {
            return Err(Error::param("irradiance-cache", "the cached gather uses k-NN estimates: drop --gather-radius".to_string()));
        }
        Ok(())
    }

    pub(super) fn attributes(&self) -> Vec<(String, String)> {
        let mut out = vec![attribute("knn", self.knn)];
        out.extend(fg_attributes(&self.fg));
        out.extend([attribute("irradiance_cache", self.irradiance_cache), attribute("cache_error", self.cache_error)]);
        out
    }
}

/// Settings of `rpm-fg`.
#[derive(Clone, Debug, PartialEq)]
pub struct RpmFgSettings {
    pub pass: PhotonPass,
    /// Photons per estimate the adaptive radius aims at (and the caustic map's kNN, half of it).
    pub knn: usize,
    pub fg: FgSettings,
}

impl Default for RpmFgSettings {
    fn default() -> Self {
        RpmFgSettings { pass: PhotonPass::default(), knn: super::pm::KNN, fg: FgSettings::default() }
    }
}

impl RpmFgSettings {
    pub fn validate(&self) -> Result<()> {
        super::pm::check_knn(self.knn)?;
        self.fg.validate()
    }

    pub(super) fn attributes(&self) -> Vec<(String, String)> {
        let mut out = vec![attribute("knn", self.knn)];
        out.extend(fg_attributes(&self.fg));
        out
    }
}

/// Settings of `rs-fg` (no photon map: the photons are splatted onto the gather hits).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RsFgSettings {
    pub pass: PhotonPass,
    pub fg: FgSettings,
}

impl RsFgSettings {
    pub fn validate(&self) -> Result<()> {
        self.fg.validate()
    }

    pub(super) fn attributes(&self) -> Vec<(String, String)> {
        fg_attributes(&self.fg)
    }
}

fn fg_attributes(fg: &FgSettings) -> Vec<(String, String)> {
    vec![
        attribute("fg_rays", fg.rays),
        attribute("gather_radius", or_none(fg.gather_radius)),
        attribute("memory", or_none(fg.memory)),
        attribute("density_limit", or_none(fg.density_limit)),
    ]
}

/// One of the three final gathers, with its settings.
#[derive(Clone, Copy)]
pub enum FinalGather<'a> {
    Pm(&'a PmFgSettings),
    Rpm(&'a RpmFgSettings),
    Rs(&'a RsFgSettings),
}

impl FinalGather<'_> {
    fn method(self) -> Method {
        match self {
            FinalGather::Pm(_) => Method::PmFg,
            FinalGather::Rpm(_) => Method::RpmFg,
            FinalGather::Rs(_) => Method::RsFg,
        }
    }

    fn fg(&self) -> &FgSettings {
        match self {
            FinalGather::Pm(m) => &m.fg,
            FinalGather::Rpm(m) => &m.fg,
            FinalGather::Rs(m) => &m.fg,
        }
    }

    /// Neighbours of the photon maps' estimates (`None`: no photon map, `rs-fg`).
    fn knn(self) -> Option<usize> {
        match self {
            FinalGather::Pm(m) => Some(m.knn),
            FinalGather::Rpm(m) => Some(m.knn),
            FinalGather::Rs(_) => None,
        }
    }
}

pub fn render(scene: &PreparedScene, s: &RenderSettings, g: FinalGather, progress: &dyn Progress, stats: &mut Stats) -> Result<Film> {
    let (method, fg, knn) = (g.method(), g.fg(), g.knn());
    let (eye, photons) = compose::eye_and_light(scene, s, progress, stats)?;
    let max_r = photons.bandwidth.h_max.max(1e-30) as f32 * 5.0;
    let mut indirect = vec![Vec3::ZERO; (eye.width * eye.height) as usize];

    // Maps (pm-fg, rpm-fg): the global map over all photons, the caustic map over caustic photons.
    let t = Instant::now();
    let mut density_s = 0.0;
    let maps = if knn.is_none() {
        None
    } else {
        let global = PhotonMap::build(
            &[&photons.rays[0], &photons.rays[1], &photons.rays[2]],
            &[&photons.ends_diffuse[0], &photons.ends_diffuse[1], &photons.ends_diffuse[2]],
        )?;
        let caustic = PhotonMap::build(&[&photons.rays[2]], &[&photons.ends_diffuse[2]])?;
        stats.enable("global photon map (direct + indirect + caustic)", global.bytes());
        let global = match fg.density_limit {
            None => global,
            Some(limit) => {
                let td = Instant::now();
                let (thin, st) = gather::density_control::control(&global, limit, max_r, s.seed)?;
                density_s = td.elapsed().as_secs_f64();
                stats.phase("density control", density_s);
                stats.count("density_control_photons_before", st.before as u64);
                stats.count("density_control_photons_after", st.after as u64);
                stats.enable(&format!("density-controlled global map (≤ {limit} photons/m²)"), thin.bytes());
                thin
            }
        };
        if !caustic.is_empty() {
            stats.enable("caustic photon map", caustic.bytes());
        }
        Some((global, caustic))
    };
    stats.phase("photon map build", t.elapsed().as_secs_f64() - density_s);

    // Caustics at the primary eye samples.
    let t = Instant::now();
    caustics(&eye, &photons, maps.as_ref().map(|m| &m.1).zip(knn), max_r, &mut indirect, progress)?;
    stats.phase("caustics", t.elapsed().as_secs_f64());

    // Kernels and the photon queries of rpm (built once, reused by every task).
    let kernel = knn.map(|k| match (method, fg.gather_radius) {
        (_, Some(r)) => Kernel::Fixed(r),
        (Method::RpmFg, None) => Kernel::Adaptive { k, max_radius: max_r },
        _ => Kernel::Knn { k, max_radius: max_r },
    });
    let t = Instant::now();
    let queries = match (&maps, method, kernel) {
        (Some((global, _)), Method::RpmFg, Some(kernel)) => Some(rpm::Queries::new(global, kernel)),
        _ => None,
    };
    if let Some(q) = &queries {
        stats.phase("photon queries (photon kd-tree order)", t.elapsed().as_secs_f64());
        stats.enable("photon queries (ball, direction, photon normal, scaled flux; four-query lanes; batch boxes)", q.bytes() as u64);
    }

    let plan = schedule::plan(eye.samples.len(), fg.rays, fg.memory)?;
    let tasks = plan.tasks;
    // Resident memory when the gather stage starts: its peak minus this is what the stage used.
    stats.count("rss_before_gather_bytes", super::stats::current_rss());
    stats.count("fg_tasks", tasks.len() as u64);
    progress.begin("final gathering (tasks)", tasks.len() as u64);
    let mut tot = Totals::default();
    let ctx = Ctx { method, fg, seed: s.seed, eye: &eye, photons: &photons, maps: maps.as_ref(), queries: queries.as_ref(), kernel, block: plan.block, flight: plan.flight, window: plan.window };
    let spill = choose_spill(scene, &ctx, tasks.len(), stats)?;
    stats.count("fg_spilled", spill.is_some() as u64);
    if let Some(spill) = spill {
        spilled(scene, &ctx, &tasks, spill, &mut tot, &mut indirect, progress, stats)?;
    } else {
        for task in &tasks {
            if progress.cancelled() {
                return Err(Error::Cancelled);
            }
            let (t, cpu) = (Instant::now(), super::stats::process_cpu_seconds());
            let mut a_r = Vec::with_capacity(task.samples.len() * task.rays.len());
            let counts = gather::rays::trace_gather_each(scene, &eye, task.samples.clone(), task.rays.clone(), fg.rays, s.seed, plan.window, |w| a_r.extend_from_slice(w));
            tot.gather_s += t.elapsed().as_secs_f64();
            tot.gather_cpu_s += super::stats::process_cpu_seconds() - cpu;
            tot.rays += counts.rays;
            tot.hits += counts.hits;
            tot.peak_a_r = tot.peak_a_r.max(a_r.len() as u64);
            radiance(&ctx, &mut a_r, &mut tot, &mut indirect, progress)?;
            progress.advance(1);
        }
    }
    progress.finish();
    stats.phase("gather rays (sampling + tracing)", tot.gather_s);
    match method {
        Method::PmFg => stats.phase("search + density estimation (photon map)", tot.search_s),
        Method::RpmFg => {
            stats.phase("reverse photon map build", tot.build_s);
            stats.phase("search + density estimation (reverse)", tot.search_s);
        }
        _ => stats.phase("splatting onto gather hits", tot.search_s),
    }
    stats.phase("completion", tot.complete_s);
    if tot.gather_cpu_s > 0.0 {
        stats.count("gather_rays_cpu_ms", (tot.gather_cpu_s * 1000.0).round() as u64);
    }
    stats.count("gather_rays", tot.rays);
    stats.count("gather_hits", tot.hits);
    stats.count("photons_found", tot.found);
    if tot.hits > 0 {
        stats.count("photons_per_gather_hit_x100", tot.found * 100 / tot.hits);
    }
    let peak = tot.peak_a_r * schedule::BYTES_PER_GATHER_RAY;
    let unit = if stats.counter("fg_spilled") == Some(1) { "spilled chunks" } else { "tasks" };
    stats.enable(&format!("A_r + A_w (largest of the {unit}, {} B per gather hit)", schedule::BYTES_PER_GATHER_RAY), peak);
    if tot.tree_bytes > 0 {
        stats.enable(&format!("gather-hit kd-tree (largest block or tile; {} reverse photons per block)", plan.block), tot.tree_bytes);
    }
    compose::film(&eye, &indirect)
}

/// What the gather stage of one render shares between its tasks or spilled chunks.
struct Ctx<'a> {
    method: Method,
    fg: &'a FgSettings,
    seed: u64,
    eye: &'a EyePass,
    photons: &'a PhotonSet,
    maps: Option<&'a (PhotonMap, PhotonMap)>,
    queries: Option<&'a rpm::Queries>,
    /// The photon-map search kernel (`None` for `rs-fg`, which splats).
    kernel: Option<Kernel>,
    block: usize,
    /// Blocks searched at once at most.
    flight: usize,
    /// Eye samples per window of the ray shooting cache.
    window: usize,
}

/// The radiance along the gather rays of `a_r` (one task, or one chunk read back from the spill
/// file), completed into the pixels of `indirect`. `rpm-fg` reorders `a_r`.
fn radiance(ctx: &Ctx, a_r: &mut [ReversePhoton], tot: &mut Totals, indirect: &mut [Vec3], progress: &dyn Progress) -> Result<()> {
    match ctx.method {
        Method::PmFg => {
            let global = &ctx.maps.expect("maps").0;
            let t = Instant::now();
            let (l, found) = forward::estimate(global, a_r, ctx.kernel.expect("a photon-map kernel"));
            tot.search_s += t.elapsed().as_secs_f64();
            tot.found += found;
            let t = Instant::now();
            gather::complete(a_r, &l, indirect);
            tot.complete_s += t.elapsed().as_secs_f64();
        }
        Method::RpmFg => {
            let t = Instant::now();
            let (a_w, st) = rpm::estimate(ctx.queries.expect("queries"), a_r, ctx.fg.batched, ctx.block, ctx.flight);
            let wall = t.elapsed().as_secs_f64();
            // The parallel blocks' wall time split by their CPU time; the Morton order is build.
            let search = st.search_wall().min(wall);
            tot.build_s += wall - search;
            tot.search_s += search;
            tot.found += st.pairs;
            tot.tree_bytes = tot.tree_bytes.max(st.tree_bytes);
            let t = Instant::now();
            gather::complete(a_r, &a_w, indirect);
            tot.complete_s += t.elapsed().as_secs_f64();
        }
        Method::RsFg => {
            let t = Instant::now();
            let img = splat_gather_hits(ctx.eye, a_r, ctx.photons, progress)?;
            tot.search_s += t.elapsed().as_secs_f64();
            tot.found += img.pairs;
            tot.tree_bytes = tot.tree_bytes.max(img.tree_bytes);
            let t = Instant::now();
            for (p, l) in indirect.iter_mut().zip(&img.radiance) {
                *p += *l;
            }
            tot.complete_s += t.elapsed().as_secs_f64();
        }
        _ => unreachable!("not a final-gathering method"),
    }
    Ok(())
}

/// Reverse photons per chunk read back from a spill: [`schedule::BLOCKS_IN_FLIGHT`] blocks,
/// within half the budget. Never from the thread count: the chunks decide the order of each
/// pixel's sum, so the image would.
fn spill_chunk(ctx: &Ctx) -> usize {
    let chunk = schedule::BLOCKS_IN_FLIGHT as usize * ctx.block;
    match ctx.fg.memory {
        Some(m) => chunk.min((m / 2 / schedule::BYTES_PER_GATHER_RAY) as usize).max(1),
        None => chunk,
    }
}

/// Spill `A_r` (§6.5) or run `n_tasks` tasks in memory (§5.1)? With `--spill-dir`: spill there.
/// With a budget that needs more than [`schedule::AUTO_SPILL_TASKS`] tasks and no `--no-spill`:
/// spill into a new directory under `std::env::temp_dir()` (`TMPDIR`), or fall back to the tasks with
/// a warning when it cannot be created. The choice and its reason go to the stats' notes.
fn choose_spill(scene: &PreparedScene, ctx: &Ctx, n_tasks: usize, stats: &mut Stats) -> Result<Option<Spill>> {
    let fg = ctx.fg;
    let expected = ctx.eye.samples.len() as u64 * fg.rays as u64;
    let open = |dir: &std::path::Path| {
        let buffer_bytes = fg.memory.map_or(16 << 20, |m| m / 8);
        Spill::new(dir, scene.bounds, expected, spill_chunk(ctx), buffer_bytes)
    };
    if let Some(dir) = &fg.spill_dir {
        let spill = open(dir)?;
        stats.note(format!("A_r spilled to {} (--spill-dir)", spill.dir().display()));
        return Ok(Some(spill));
    }
    let Some(budget) = fg.memory else { return Ok(None) };
    if n_tasks <= 1 {
        return Ok(None);
    }
    let hb = super::stats::human_bytes;
    let need = format!("A_r + A_w up to {} > {} (half of --memory {})", hb(expected * schedule::BYTES_PER_GATHER_RAY), hb(budget / 2), hb(budget));
    if fg.no_spill {
        stats.note(format!("{need}: {n_tasks} tasks in memory (--no-spill)"));
        return Ok(None);
    }
    if n_tasks <= schedule::AUTO_SPILL_TASKS {
        stats.note(format!("{need}: {n_tasks} tasks in memory (up to {} tasks cost no more than a spill)", schedule::AUTO_SPILL_TASKS));
        return Ok(None);
    }
    let tmp = std::env::temp_dir();
    match open(&tmp) {
        Ok(spill) => {
            stats.note(format!("{need}: spilled to {} ({n_tasks} tasks would cost more search)", spill.dir().display()));
            Ok(Some(spill))
        }
        Err(e) => {
            stats.note(format!("warning: could not spill ({e}): {n_tasks} tasks in memory instead"));
            Ok(None)
        }
    }
}

/// Spilling (§6.5): every task's reverse photons go to the spill file in spatial buckets, then
/// come back in chunks (`threads` blocks at a time, within half the budget) whose radiance is found
/// and completed chunk by chunk. The spill's directory is removed when `spill` is dropped, on
/// success, error or cancellation alike.
#[allow(clippy::too_many_arguments)]
fn spilled(scene: &PreparedScene, ctx: &Ctx, tasks: &[schedule::Task], mut spill: Spill, tot: &mut Totals, indirect: &mut [Vec3], progress: &dyn Progress, stats: &mut Stats) -> Result<()> {
    let chunk = spill_chunk(ctx);
    let t = Instant::now();
    let mut failed = None;
    for task in tasks {
        if progress.cancelled() {
            return Err(Error::Cancelled);
        }
        let counts = gather::rays::trace_gather_each(scene, ctx.eye, task.samples.clone(), task.rays.clone(), ctx.fg.rays, ctx.seed, ctx.window, |g| {
            if failed.is_none() {
                failed = spill.push(g).err();
            }
        });
        if let Some(e) = failed.take() {
            return Err(e);
        }
        tot.rays += counts.rays;
        tot.hits += counts.hits;
        progress.advance(1);
    }
    spill.finish()?;
    tot.gather_s += t.elapsed().as_secs_f64();
    stats.enable(&format!("A_r spilled to disk ({} buckets, pages of {} reverse photons)", spill.buckets(), spill.page()), spill.file_bytes());
    stats.enable("spill page buffers", spill.buffer_bytes());
    let t = Instant::now();
    let (mut process, mut chunks) = (0.0, 0u64);
    spill.for_each_chunk(chunk, |a_r| {
        if progress.cancelled() {
            return Err(Error::Cancelled);
        }
        let tp = Instant::now();
        tot.peak_a_r = tot.peak_a_r.max(a_r.len() as u64);
        radiance(ctx, a_r, tot, indirect, progress)?;
        process += tp.elapsed().as_secs_f64();
        chunks += 1;
        Ok(())
    })?;
    stats.phase("spill read", t.elapsed().as_secs_f64() - process);
    stats.count("spill_chunks", chunks);
    Ok(())
}

/// Caustics by direct visualisation at the primary eye samples: the caustic photon map (k/2
/// neighbours) for pm-fg and rpm-fg, splatting of the caustic photon rays for rs-fg.
fn caustics(eye: &EyePass, photons: &PhotonSet, caustic: Option<(&PhotonMap, usize)>, max_r: f32, indirect: &mut [Vec3], progress: &dyn Progress) -> Result<()> {
    if photons.rays[2].is_empty() {
        return Ok(());
    }
    match caustic {
        None => {
            let img = splat::splat_cancellable(eye, &[&photons.rays[2]], &|| progress.cancelled()).ok_or(Error::Cancelled)?;
            for (p, l) in indirect.iter_mut().zip(&img.radiance) {
                *p += *l;
            }
        }
        Some((map, knn)) => {
            let k = (knn / 2).max(1);
            let per_sample: Vec<Vec3> = eye
                .samples
                .par_chunks(CHUNK)
                .flat_map_iter(|chunk| {
                    let mut heap = KnnHeap::with_capacity(k);
                    chunk
                        .iter()
                        .map(|e: &EyeSample| {
                            // the sample's BSDF with its per-`wo` work done once, for every photon found
                            let g = e.is_glossy().then(|| eye.glossy.sample(e.glossy as usize));
                            let f = |wi: Vec3| g.as_ref().map_or(Vec3::ONE, |g| g.eval(wi));
                            e.weight() * map.estimate(e.pos(), e.normal(), k, max_r, &mut heap, f).0
                        })
                        .collect::<Vec<_>>()
                })
                .collect();
            for (e, l) in eye.samples.iter().zip(per_sample) {
                indirect[e.pixel as usize] += l;
            }
        }
    }
    Ok(())
}

/// `rs-fg` (§8.4): the gather hits of one task become Lambertian eye samples (their weight already
/// holds the gather ray's contribution and `albedo/π` at the hit) and every photon ray is splatted
/// onto them, tile by tile.
fn splat_gather_hits(eye: &EyePass, a_r: &[ReversePhoton], photons: &PhotonSet, progress: &dyn Progress) -> Result<splat::SplatImage> {
    let mut hits: Vec<EyeSample> = a_r
        .iter()
        .map(|rp| EyeSample {
            p: rp.p,
            n: crate::sampling::oct_encode(rp.normal()),
            weight: rp.weight,
            pixel: rp.pixel,
            glossy: u32::MAX,
        })
        .collect();
    hits.sort_by_key(|e| e.pixel); // splatting groups eye samples by tile (stable: deterministic)
    let pass = EyePass::of_samples(eye.width, eye.height, hits, Default::default());
    let classes: Vec<&[crate::photon::PhotonRay]> = photons.rays.iter().map(|v| v.as_slice()).collect();
    splat::splat_cancellable(&pass, &classes, &|| progress.cancelled()).ok_or(Error::Cancelled)
}
