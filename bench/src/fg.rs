//! `raysplat-bench fg SCENES`: the reverse photon mapping paper's Table 1 on our scenes —
//! normal photon mapping with final gathering (`pm-fg`, kNN) against reverse photon mapping
//! (`rpm-fg`, adaptive radius, batched search), total times, the speedup, the average number of
//! photons found per gather ray, and the search alone (no density estimation) on the same gather
//! hits and photons: kNN in the photon map, against the adaptive-radius search in the reverse photon
//! map batched and unbatched (the table's estimators: different images), and — at identical images —
//! both searches with one fixed radius `r` (the median kNN radius over every 16th gather hit): a
//! radius search in the photon kd-tree per gather hit against the batched reverse search, both
//! counting the pairs the photon filter accepts (the same pairs: checked), each side the best of
//! `--fg-table-repeat` runs (default 3), alternating. The reverse search's time is the wall time of
//! its parallel blocks split by their CPU time (the blocks' kd-tree builds are not search), without
//! the Morton order of `A_r` (`rpm::ReverseStats::search_wall`).

use raysplat::eye::{eye_pass, EyeSettings};
use raysplat::gather::{self, forward, rpm, Kernel};
use raysplat::integrators::{self, Method, RenderRequest, SilentProgress};
use raysplat::photon::{trace_photons, PhotonMap, PhotonSettings};
use raysplat::prepare::PreparedScene;
use raysplat::usd;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct FgTableArgs {
    /// Scenes (comma separated; default: the repository's cornell-box, bumpy-box and
    /// concave-corners).
    #[arg(num_args = 0.., value_delimiter = ',', value_name = "SCENES")]
    pub scenes: Vec<PathBuf>,
    /// Final-gathering table: image sizes (comma separated).
    #[arg(long, value_delimiter = ',', default_value = "300x300,500x500")]
    pub fg_table_resolutions: Vec<String>,
    /// Final-gathering table: gather rays per eye sample (1 eye sample per pixel; the paper: 600).
    #[arg(long, default_value_t = 16)]
    pub fg_table_rays: u32,
    /// Final-gathering table: stored photons (the paper: 500 000 after density control).
    #[arg(long, default_value_t = 200_000)]
    pub fg_table_photons: usize,
    /// Final-gathering table: k of the kNN estimate, and the photons the adaptive radius aims at.
    #[arg(long, default_value_t = 50)]
    pub fg_table_knn: usize,
    /// Final-gathering table: runs of each side of the fixed-radius search comparison (Sr_NPM,
    /// Sr_RPM), alternating; the best of each is reported (1: one run each).
    #[arg(long, default_value_t = 3)]
    pub fg_table_repeat: usize,
}

const DEFAULT_SCENES: [&str; 3] = ["scenes/cornell-box.usda", "scenes/bumpy-box.usda", "scenes/concave-corners.usda"];
const SEED: u64 = 1;

pub fn run(a: &FgTableArgs) -> anyhow::Result<()> {
    let scenes: Vec<PathBuf> = if a.scenes.is_empty() { DEFAULT_SCENES.iter().map(PathBuf::from).collect() } else { a.scenes.clone() };
    println!(
        "final gathering (reverse photon mapping paper, Table 1): 1 eye sample per pixel x {} gather rays, {} photons, k = {}, {} threads",
        a.fg_table_rays,
        a.fg_table_photons,
        a.fg_table_knn,
        rayon::current_num_threads()
    );
    println!("T_NPM: pm-fg (kNN), T_RPM: rpm-fg (adaptive radius, batched); K~: photons found per gather hit; S_*: search alone on the same gather hits (seconds)");
    println!("S_NPM: kNN; S_RPM / S_RPM1: adaptive radius batched / unbatched; r: fixed radius (median kNN radius), K~r: pairs per gather hit at r, Sr_NPM / Sr_RPM: both searches at r (identical pairs, identical images), each the best of {} runs, alternating", a.fg_table_repeat.max(1));
    println!("S_RPM*, Sr_RPM: the wall time of the reverse map's parallel blocks split by their CPU time (kd-tree builds excluded), without the Morton order of A_r (build)");
    println!(
        "{:<14} {:>9} {:>6} {:>6} {:>6} {:>8} {:>8} {:>7} {:>8} {:>9} {:>9} {:>8} {:>8} {:>8} {:>6} {:>8} {:>8} {:>8}",
        "scene", "res", "FGR/px", "K~npm", "K~rpm", "T_NPM", "T_RPM", "speedup", "S_NPM", "S_RPM", "S_RPM1", "S_spdup", "S_spdup1", "r", "K~r", "Sr_NPM", "Sr_RPM", "Sr_spdup"
    );
    for path in &scenes {
        let desc = usd::load_scene(path)?;
        let name = path.file_stem().map_or_else(|| path.display().to_string(), |s| s.to_string_lossy().into_owned());
        for res in &a.fg_table_resolutions {
            let [w, h] = raysplat::integrators::parse_size(res)?;
            let request = RenderRequest {
                spp: Some(1),
                seed: SEED,
                resolution: Some([w, h]),
                photons: Some(a.fg_table_photons),
                knn: a.fg_table_knn,
                fg_rays: Some(a.fg_table_rays),
                ..Default::default()
            };
            let settings = |m: Method| RenderRequest { method: Some(m), ..request.clone() }.settings();
            let npm = integrators::render(desc.clone(), &settings(Method::PmFg)?, &SilentProgress)?;
            let rpm_out = integrators::render(desc.clone(), &settings(Method::RpmFg)?, &SilentProgress)?;
            let k = |o: &integrators::RenderOutput| o.stats.counter("photons_found").unwrap_or(0) as f64 / o.stats.counter("gather_hits").unwrap_or(1).max(1) as f64;

            // The search alone, on the same photons and gather hits as the renders.
            let scene = PreparedScene::new(desc.clone(), w, h, 0)?;
            let eye = eye_pass(&scene, &EyeSettings { spp: 1, aa_spp: 0, seed: SEED, light_samples: 1 })?;
            let budget = integrators_budget(a.fg_table_photons, &scene);
            let photons = trace_photons(&scene, &PhotonSettings { budget, seed: SEED, max_depth: 256, ..PhotonSettings::default() });
            let max_r = photons.bandwidth.h_max.max(1e-30) as f32 * 5.0;
            let map = PhotonMap::build(
                &[&photons.rays[0], &photons.rays[1], &photons.rays[2]],
                &[&photons.ends_diffuse[0], &photons.ends_diffuse[1], &photons.ends_diffuse[2]],
            )?;
            let (mut a_r, _) = gather::trace_gather(&scene, &eye, 0..eye.samples.len(), 0..a.fg_table_rays, a.fg_table_rays, SEED);
            let t = Instant::now();
            forward::search_only(&map, &a_r, Kernel::Knn { k: a.fg_table_knn, max_radius: max_r });
            let s_npm = t.elapsed().as_secs_f64();
            // Identical images: both searches with one fixed radius, the median kNN radius (the
            // forward one here, on the gather hits in the order pm-fg searches them).
            let r = median_knn_radius(&map, &a_r, a.fg_table_knn, max_r);
            let gather_order = a_r.clone();
            let q = rpm::Queries::new(&map, Kernel::Adaptive { k: a.fg_table_knn, max_radius: max_r });
            let batched = rpm::search_only(&q, &mut a_r, true);
            let s_rpm = batched.search_wall();
            let single = rpm::search_only(&q, &mut a_r, false);
            let s_rpm1 = single.search_wall();

            // Identical images: the reverse search with the fixed radius of the forward one; both
            // sides best of `fg_table_repeat`, alternating.
            let qr = rpm::Queries::new(&map, Kernel::Fixed(r));
            let (mut sr_npm, mut sr_rpm, mut npm_pairs, mut fixed) = (f64::INFINITY, f64::INFINITY, 0, rpm::ReverseStats::default());
            for _ in 0..a.fg_table_repeat.max(1) {
                let t = Instant::now();
                npm_pairs = forward::search_only(&map, &gather_order, Kernel::Fixed(r));
                sr_npm = sr_npm.min(t.elapsed().as_secs_f64());
                fixed = rpm::search_only(&qr, &mut a_r, true);
                sr_rpm = sr_rpm.min(fixed.search_wall());
            }
            anyhow::ensure!(fixed.pairs == npm_pairs, "{name} {res}: fixed radius {r}: rpm found {} pairs, npm {npm_pairs}", fixed.pairs);
            println!(
                "{:<14} {:>9} {:>6} {:>6.1} {:>6.1} {:>8.2} {:>8.2} {:>7.2} {:>8.3} {:>9.3} {:>9.3} {:>8.2} {:>8.2} {:>8.4} {:>6.1} {:>8.3} {:>8.3} {:>8.2}",
                name,
                res,
                a.fg_table_rays,
                k(&npm),
                k(&rpm_out),
                npm.stats.total_seconds,
                rpm_out.stats.total_seconds,
                npm.stats.total_seconds / rpm_out.stats.total_seconds,
                s_npm,
                s_rpm,
                s_rpm1,
                s_npm / s_rpm,
                s_npm / s_rpm1,
                r,
                npm_pairs as f64 / a_r.len().max(1) as f64,
                sr_npm,
                sr_rpm,
                sr_npm / sr_rpm
            );
            let phases = |o: &integrators::RenderOutput| o.stats.phases.iter().map(|(n, s)| format!("{n} {s:.2}")).collect::<Vec<_>>().join(", ");
            println!("    pm-fg  phases: {}", phases(&npm));
            println!("    rpm-fg phases: {}", phases(&rpm_out));
        }
    }
    Ok(())
}

/// The median kNN radius (k neighbours within `max_r`) over every 16th gather hit: a fixed radius at
/// which a gather hit finds about `k` photons before the photon filter.
fn median_knn_radius(map: &PhotonMap, a_r: &[gather::ReversePhoton], k: usize, max_r: f32) -> f32 {
    let mut heap = raysplat::kdtree::KnnHeap::with_capacity(k);
    let mut r: Vec<f32> = a_r.iter().step_by(16).map(|rp| map.tree.knn(rp.pos(), k, max_r, &mut heap).sqrt()).collect();
    if r.is_empty() {
        return max_r;
    }
    let mid = r.len() / 2;
    *r.select_nth_unstable_by(mid, f32::total_cmp).1
}

/// The photon budget of the final-gathering methods (direct + indirect + caustic).
fn integrators_budget(photons: usize, scene: &PreparedScene) -> [usize; 3] {
    let m = photons as f64;
    let f = |x: f64| (m * x).round() as usize;
    if scene.requirements.has_specular() {
        [f(0.3), f(0.6), f(0.1)]
    } else {
        [f(0.3), f(0.7), 0]
    }
}
