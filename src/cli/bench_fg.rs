//! `raysplat bench --fg-table SCENES`: the reverse photon mapping paper's Table 1 on our scenes —
//! normal photon mapping with final gathering (`pm-fg`, kNN) against reverse photon mapping
//! (`rpm-fg`, adaptive radius, batched search), total times, the speedup, the average number of
//! photons found per gather ray, and the search alone (no density estimation) on the same gather
//! hits and photons: kNN in the photon map, against fixed-radius search in the reverse photon map
//! batched and unbatched.

use raysplat::eye::{eye_pass, EyeSettings};
use raysplat::gather::{self, forward, rpm, FgSettings, Kernel};
use raysplat::integrators::{self, Method, RenderSettings, SilentProgress};
use raysplat::photon::{trace_photons, PhotonMap, PhotonSettings};
use raysplat::prepare::PreparedScene;
use raysplat::usd;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct FgTableArgs {
    /// Print the final-gathering table (reverse photon mapping paper, Table 1) for these scenes
    /// (comma separated; default: the repository's cornell-box, bumpy-box and concave-corners).
    #[arg(long, num_args = 0.., value_delimiter = ',', value_name = "SCENES")]
    pub fg_table: Option<Vec<PathBuf>>,
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
}

const DEFAULT_SCENES: [&str; 3] = ["scenes/cornell-box.usda", "scenes/bumpy-box.usda", "scenes/concave-corners.usda"];
const SEED: u64 = 1;

pub fn run(a: &FgTableArgs, scenes: &[PathBuf]) -> anyhow::Result<()> {
    let scenes: Vec<PathBuf> = if scenes.is_empty() { DEFAULT_SCENES.iter().map(PathBuf::from).collect() } else { scenes.to_vec() };
    println!(
        "final gathering (reverse photon mapping paper, Table 1): 1 eye sample per pixel x {} gather rays, {} photons, k = {}, {} threads",
        a.fg_table_rays,
        a.fg_table_photons,
        a.fg_table_knn,
        rayon::current_num_threads()
    );
    println!("T_NPM: pm-fg (kNN), T_RPM: rpm-fg (adaptive radius, batched); K~: photons found per gather hit; S_*: search alone on the same gather hits (seconds)");
    println!(
        "{:<14} {:>9} {:>6} {:>6} {:>6} {:>8} {:>8} {:>7} {:>8} {:>9} {:>9} {:>8} {:>8}",
        "scene", "res", "FGR/px", "K~npm", "K~rpm", "T_NPM", "T_RPM", "speedup", "S_NPM", "S_RPM", "S_RPM1", "S_spdup", "S_spdup1"
    );
    for path in &scenes {
        let desc = usd::load_scene(path)?;
        let name = path.file_stem().map_or_else(|| path.display().to_string(), |s| s.to_string_lossy().into_owned());
        for res in &a.fg_table_resolutions {
            let [w, h] = super::parse_resolution(res)?;
            let base = RenderSettings {
                spp: 1,
                seed: SEED,
                resolution: Some([w, h]),
                photons: a.fg_table_photons,
                knn: a.fg_table_knn,
                fg: FgSettings { rays: a.fg_table_rays, ..Default::default() },
                ..Default::default()
            };
            let npm = integrators::render(desc.clone(), &RenderSettings { method: Method::PmFg, ..base.clone() }, &SilentProgress)?;
            let rpm_out = integrators::render(desc.clone(), &RenderSettings { method: Method::RpmFg, ..base.clone() }, &SilentProgress)?;
            let k = |o: &integrators::RenderOutput| o.stats.counter("photons_found").unwrap_or(0) as f64 / o.stats.counter("gather_hits").unwrap_or(1).max(1) as f64;

            // The search alone, on the same photons and gather hits as the renders.
            let scene = PreparedScene::new(desc.clone(), w, h, 0)?;
            let eye = eye_pass(&scene, &EyeSettings { spp: 1, seed: SEED, light_samples: 1 });
            let budget = integrators_budget(&base, &scene);
            let photons = trace_photons(&scene, &PhotonSettings { budget, seed: SEED, max_depth: 256, bandwidth: base.bandwidth, ..PhotonSettings::default() });
            let max_r = photons.bandwidth.h_max.max(1e-30) as f32 * 5.0;
            let map = PhotonMap::build(
                &[&photons.rays[0], &photons.rays[1], &photons.rays[2]],
                &[&photons.ends_diffuse[0], &photons.ends_diffuse[1], &photons.ends_diffuse[2]],
            )?;
            let (mut a_r, _) = gather::trace_gather(&scene, &eye, 0..eye.samples.len(), 0..a.fg_table_rays, a.fg_table_rays, SEED);
            let t = Instant::now();
            forward::search_only(&map, &a_r, Kernel::Knn { k: a.fg_table_knn, max_radius: max_r });
            let s_npm = t.elapsed().as_secs_f64();
            let q = rpm::Queries::new(&map, Kernel::Adaptive { k: a.fg_table_knn, max_radius: max_r });
            let t = Instant::now();
            let batched = rpm::search_only(&map, &q, &mut a_r, true);
            let s_rpm = t.elapsed().as_secs_f64() * batched.process_cpu / (batched.process_cpu + batched.build_cpu).max(1e-12);
            let t = Instant::now();
            let single = rpm::search_only(&map, &q, &mut a_r, false);
            let s_rpm1 = t.elapsed().as_secs_f64() * single.process_cpu / (single.process_cpu + single.build_cpu).max(1e-12);
            println!(
                "{:<14} {:>9} {:>6} {:>6.1} {:>6.1} {:>8.2} {:>8.2} {:>7.2} {:>8.3} {:>9.3} {:>9.3} {:>8.2} {:>8.2}",
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
                s_npm / s_rpm1
            );
            let phases = |o: &integrators::RenderOutput| o.stats.phases.iter().map(|(n, s)| format!("{n} {s:.2}")).collect::<Vec<_>>().join(", ");
            println!("    pm-fg  phases: {}", phases(&npm));
            println!("    rpm-fg phases: {}", phases(&rpm_out));
        }
    }
    Ok(())
}

/// The photon budget of the final-gathering methods (direct + indirect + caustic).
fn integrators_budget(s: &RenderSettings, scene: &PreparedScene) -> [usize; 3] {
    let m = s.photons as f64;
    let f = |x: f64| (m * x).round() as usize;
    if scene.requirements.has_specular() {
        [f(0.3), f(0.6), f(0.1)]
    } else {
        [f(0.3), f(0.7), 0]
    }
}
