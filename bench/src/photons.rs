//! `raysplat-bench photons`: the photon methods in the shape of Table 2 of the splatting paper
//! (`photon-ray-splatting.md` §9): per scene, the phase times of classic photon maps (`pm`) and photon
//! ray splatting (`rs`) at equal photon counts — T_E eye pass, T_L light pass, T_B photon-map build
//! (`pm` only; `rs` builds its per-tile eye-sample trees inside T_S), T_S density estimation (`pm`:
//! k-NN search and estimate; `rs`: splatting), ΣT total — plus their accuracy against a path-traced
//! reference rendered in the same run, and the cost of the cone-frustum search against a spherical
//! search of the same radius on the real eye samples and photon rays of the scene (§9: "approximately
//! 1.5 to 2 times slower").
//!
//! Accuracy: relative MSE (`image::compare`) of the beauty and of the `indirect` layer against the
//! mean of two path-traced halves (different seeds). The reference's own noise, `relMSE(A, B) / 4`,
//! is printed and subtracted, so the columns estimate the error against the truth.
//!
//! Cone against sphere: the eye samples are grouped into the splat's 32 × 32-pixel tiles, each tile
//! gets the kd-tree `splat` builds (with normals, sequential build), and every photon ray that
//! `splat` would query against that tile (the same cone: segment plus the extension beyond the hit,
//! radius `h0 + dh·t`, backface culling; the same capsule-box rejection) is timed with
//! [`crate::cone_timing::time_cone_vs_sphere_with`] against a ball of radius `h(t_max)` at the cone's end
//! (`SameRadiusAtHit`) and against a ball of the cone's volume; the bare segment with the paper's
//! half ball beyond the hit (§5, Fig. 4) against the same ball, whose points it holds 1.5 times on
//! planes lit by diffuse light (the floor of the ratio). Then whole splats, the comparison
//! the paper's figure is about (query, feasibility tests, kernel and accumulation): ray splatting
//! against photon splatting in a ball of radius `h` at the hit ([`crate::splat_timing`]). Single
//! threaded; the best of three runs, in the thread's CPU time where Linux gives it.

use raysplat::eye::{eye_pass, EyeSettings};
use raysplat::integrators::{self, Method, RenderRequest, RenderSettings, SilentProgress, Stats};
use crate::cone_timing::{time_cone_vs_sphere_with, ConeSphereTiming, SphereMatch};
use crate::splat_timing::{time_ray_vs_spherical_splats, SplatTiming};
use raysplat::kdtree::{BuildParams, Cone, KdTree};
use raysplat::photon::{trace_photons, BandwidthParams, PhotonSettings};
use raysplat::prepare::PreparedScene;
use raysplat::scene::SceneDesc;
use raysplat::photon::PhotonRay;
use raysplat::{image, splat, usd};
use glam::Vec3;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct PhotonTableArgs {
    /// Scenes (comma separated; default: the repository's cornell-box and bumpy-box).
    #[arg(num_args = 0.., value_delimiter = ',', value_name = "SCENES")]
    pub scenes: Vec<PathBuf>,
    /// Photon table: stored photons of both methods.
    #[arg(long, default_value_t = 200_000)]
    pub table_photons: usize,
    /// Photon table: image size WxH (the paper's Table 2 setting for CORNELL BOX I: 500x500, with
    /// 4 eye samples per pixel and M = 200 000; ray splatting gains on the photon map as eye samples
    /// per photon grow, so smaller images favour pm).
    #[arg(long, default_value = "500x500")]
    pub table_resolution: String,
    /// Photon table: eye samples per pixel.
    #[arg(long, default_value_t = 4)]
    pub table_spp: u32,
    /// Photon table: path-traced samples per pixel of the reference (two halves of half as many; its
    /// noise is measured and subtracted).
    #[arg(long, default_value_t = 512)]
    pub table_reference_spp: u32,
    /// Photon table: k nearest neighbours of the photon map (100 gives about the mean splat radius of
    /// rs with its default bandwidth).
    #[arg(long, default_value_t = 100)]
    pub table_knn: usize,
    /// Photon table: renders of each method, alternating (pm, rs, pm, rs, …); the phase times are
    /// those of each method's fastest render (the images, hence the errors, are the same every time).
    #[arg(long, default_value_t = 3)]
    pub table_repeat: usize,
}

const DEFAULT_SCENES: [&str; 2] = ["scenes/cornell-box.usda", "scenes/bumpy-box.usda"];
const SEED: u64 = 1;
const REFERENCE_SEEDS: [u64; 2] = [1001, 1002];

/// One row of the table.
struct Row {
    label: String,
    stats: Stats,
    beauty: f64,
    indirect: f64,
}

pub fn run(a: &PhotonTableArgs) -> anyhow::Result<()> {
    let [w, h] = raysplat::integrators::parse_size(&a.table_resolution)?;
    if a.table_reference_spp < 2 {
        anyhow::bail!(raysplat::Error::param("table-reference-spp", "must be at least 2 (two halves)"));
    }
    let scenes: Vec<PathBuf> = if a.scenes.is_empty() { DEFAULT_SCENES.iter().map(PathBuf::from).collect() } else { a.scenes.clone() };
    let bw = BandwidthParams::default();
    let threads = rayon::current_num_threads();
    println!(
        "photon methods (splatting paper, Table 2): {w}x{h} x {} eye spp, M = {} stored photons, R = {}, {threads} threads",
        a.table_spp, a.table_photons, bw.max_bandwidth
    );
    println!(
        "reference: path tracer, {} spp (mean of two halves, seeds {:?}); errors are relative MSE against it minus its own noise;",
        a.table_reference_spp, REFERENCE_SEEDS
    );
    println!(
        "the beauty error is mostly the eye pass's direct light ({} spp x 4 light samples), the same for both methods; the indirect error is the density estimation",
        a.table_spp
    );
    println!(
        "T_E eye pass, T_L light pass, T_B photon-map build (pm), T_S density estimation (pm: k-NN search + estimate; rs: splatting incl. per-tile trees), ΣT total (incl. scene preparation); seconds, of each method's fastest of {} renders (alternating)",
        a.table_repeat.max(1)
    );
    for path in &scenes {
        let desc = usd::load_scene(path)?;
        let name = path.file_stem().map_or_else(|| path.display().to_string(), |s| s.to_string_lossy().into_owned());
        let base = RenderSettings { resolution: Some([w, h]), seed: SEED, ..Default::default() };

        // Reference: two halves.
        let reference = raysplat_cli::reference::Reference::render(&desc, &base, a.table_reference_spp, REFERENCE_SEEDS, &["", "indirect"])?;
        let layer = |f: &image::Film, l: &str| f.rgb(l).expect("layer");
        let (noise_beauty, noise_indirect) = (reference.noise(""), reference.noise("indirect"));

        // Each method's fastest of `table_repeat` renders, alternating, so that both see the same
        // moments of a shared machine; the errors are those of the first (every render is the same).
        let mut rows: Vec<Row> = Vec::new();
        for rep in 0..a.table_repeat.max(1) {
            for (m, method) in [Method::Pm, Method::Rs].into_iter().enumerate() {
                let s = RenderRequest {
                    method: Some(method),
                    spp: Some(a.table_spp),
                    photons: Some(a.table_photons),
                    knn: a.table_knn,
                    smoothness: bw.smoothness,
                    sensitivity: bw.sensitivity,
                    max_bandwidth: bw.max_bandwidth,
                    resolution: Some([w, h]),
                    seed: SEED,
                    ..Default::default()
                }
                .settings()?;
                let out = integrators::render(desc.clone(), &s, &SilentProgress)?;
                if rep == 0 {
                    let beauty = reference.error("", &layer(&out.film, ""));
                    let indirect = reference.error("indirect", &layer(&out.film, "indirect"));
                    let label = match method {
                        Method::Pm => format!("PM ({} k-NN)", a.table_knn),
                        _ => format!("RS (C = {}, S = {})", bw.smoothness, bw.sensitivity),
                    };
                    rows.push(Row { label, stats: out.stats, beauty, indirect });
                } else if out.stats.total_seconds < rows[m].stats.total_seconds {
                    rows[m].stats = out.stats;
                }
            }
        }
        let tris = rows[0].stats.scene.split(' ').next().unwrap_or("?").to_string();
        println!();
        println!(
            "{name} ({tris} triangles); reference {:.1}s, its noise (relative MSE): beauty {noise_beauty:.6}, indirect {noise_indirect:.6}",
            reference.seconds
        );
        println!(
            "  {:<22} {:>6} {:>6} {:>6} {:>7} {:>7} | {:>9} | {:>10} {:>10}",
            "method", "T_E", "T_L", "T_B", "T_S", "ΣT", "bandwidth", "rMSE beauty", "rMSE indir."
        );
        for r in &rows {
            let t = |p: &str| r.stats.phase_seconds(p);
            let ts = t("splat").or(t("estimate")).unwrap_or(0.0);
            println!(
                "  {:<22} {:>6.2} {:>6.2} {:>6} {:>7.2} {:>7.2} | {:>6.2} cm | {:>11.6} {:>11.6}",
                r.label,
                t("eye").unwrap_or(0.0),
                t("light").unwrap_or(0.0),
                t("build").map_or("-".to_string(), |b| format!("{b:.2}")),
                ts,
                r.stats.total_seconds,
                r.stats.counter("mean_bandwidth_um").unwrap_or(0) as f64 / 1e4,
                r.beauty,
                r.indirect
            );
        }
        println!(
            "  rs / pm: T_S {:.2}x, ΣT {:.2}x, indirect error {:.2}x, beauty error {:.2}x (goal: ΣT ≤ 1x at equal photons, with lower error)",
            rows[1].stats.phase_seconds("splat").unwrap_or(0.0) / rows[0].stats.phase_seconds("estimate").unwrap_or(f64::NAN),
            rows[1].stats.total_seconds / rows[0].stats.total_seconds,
            rows[1].indirect / rows[0].indirect,
            rows[1].beauty / rows[0].beauty
        );
        cone_vs_sphere(&desc, w, h, a, bw, rows[1].stats.counter("splat_pairs").unwrap_or(0))?;
    }
    Ok(())
}

/// Time the splat's cone queries against spherical ones on the splat's per-tile trees.
fn cone_vs_sphere(desc: &SceneDesc, w: u32, h: u32, a: &PhotonTableArgs, bw: BandwidthParams, splat_pairs: u64) -> anyhow::Result<()> {
    let scene = PreparedScene::new(desc.clone(), w, h, 0)?;
    let eye = eye_pass(&scene, &EyeSettings { spp: a.table_spp, aa_spp: 0, seed: SEED, light_samples: 1 })?;
    let m = a.table_photons as f64;
    let budget = if scene.requirements.has_specular() { [0, (0.9 * m).round() as usize, (0.1 * m).round() as usize] } else { [0, a.table_photons, 0] };
    let photons = trace_photons(&scene, &PhotonSettings { budget, seed: SEED, max_depth: 256, bandwidth: bw, ..PhotonSettings::default() });
    // The cones of `splat` (the segment plus the extension beyond the hit, backface culling), and
    // the bare segment (its `t_max` is the photon hit, where the comparison's ball goes).
    let cones: Vec<(Cone, Cone, f32, &PhotonRay)> = photons
        .all()
        .filter_map(|r| splat::splat_cone(r).map(|(cone, rmax)| (cone, Cone { t_max: r.length, ..cone }, rmax, r)))
        .collect();
    // Tiles as in `splat`.
    let (tiles_x, tiles_y) = (w.div_ceil(splat::TILE), h.div_ceil(splat::TILE));
    let mut tiles: Vec<(Vec<Vec3>, Vec<Vec3>)> = vec![(Vec::new(), Vec::new()); (tiles_x * tiles_y) as usize];
    for e in &eye.samples {
        let t = ((e.pixel / w) / splat::TILE * tiles_x + (e.pixel % w) / splat::TILE) as usize;
        tiles[t].0.push(e.pos());
        tiles[t].1.push(e.normal());
    }
    let params = BuildParams { parallel_threshold: usize::MAX, empty_cut: splat::EMPTY_CUT, ..BuildParams::default() };
    // Per tile: the tree, the splat's cones that pass its rejection test, their bare segments, and
    // their photon rays (for the whole splats); plus the tile's points and normals.
    type TileWork<'a> = (KdTree, [Vec<Cone>; 3], Vec<&'a PhotonRay>, &'a [Vec3], &'a [Vec3]);
    let mut work: Vec<TileWork> = Vec::new();
    for (pts, nrm) in &tiles {
        if pts.is_empty() {
            continue;
        }
        let tree = KdTree::build_with_normals(pts, nrm, &params)?;
        let (lo, hi) = tree.bounds();
        let passing: Vec<&(Cone, Cone, f32, &PhotonRay)> = cones.iter().filter(|(c, _, r, _)| !splat::misses_box(c, *r, lo, hi)).collect();
        // the splat's cones, their bare segments, and the bare segments with the paper's
        // hemisphere beyond the hit (§5, Fig. 4), whose region lies inside the splat cone's (which
        // passes the rejection test)
        let splat_cones = passing.iter().map(|c| c.0).collect();
        let bare = passing.iter().map(|c| c.1).collect();
        let paper = passing.iter().map(|c| c.1.with_hemisphere_cap(true)).collect();
        let rays = passing.iter().map(|c| c.3).collect();
        work.push((tree, [splat_cones, bare, paper], rays, pts, nrm));
    }
    let queries: usize = work.iter().map(|w| w.1[0].len()).sum();
    println!(
        "  cone-frustum vs spherical search: {} eye samples in {} tiles of {}x{} px, {} photon rays, {} (tile, ray) queries; best of 3, 1 thread",
        eye.samples.len(),
        work.len(),
        splat::TILE,
        splat::TILE,
        cones.len(),
        queries
    );
    // (cone list, sphere match): the splat's cones against equal-volume balls; the bare segments,
    // and the paper's footprint, against balls of radius h at the photon hit (the paper's comparison;
    // `time_cone_vs_sphere_with` puts the ball at the cone's end, so the extended cones would put it
    // beyond the surface).
    // The thread's CPU time where Linux gives it (the machine may be shared: wall-clock time then
    // includes the time other jobs run), else wall-clock time.
    let start = std::time::Instant::now();
    let cpu = thread_cpu_seconds().is_some();
    let clock = || thread_cpu_seconds().unwrap_or_else(|| start.elapsed().as_secs_f64());
    let mut best = [(f64::INFINITY, f64::INFINITY, 0u64, 0u64); 3];
    for _ in 0..3 {
        for (k, how) in [SphereMatch::EqualVolume, SphereMatch::SameRadiusAtHit, SphereMatch::SameRadiusAtHit].into_iter().enumerate() {
            let mut sum = ConeSphereTiming::default();
            for (tree, cones, ..) in &work {
                let t = time_cone_vs_sphere_with(tree, &cones[k], how, &clock);
                sum.cone_seconds += t.cone_seconds;
                sum.sphere_seconds += t.sphere_seconds;
                sum.cone_found += t.cone_found;
                sum.sphere_found += t.sphere_found;
            }
            best[k] = (best[k].0.min(sum.cone_seconds), best[k].1.min(sum.sphere_seconds), sum.cone_found, sum.sphere_found);
        }
    }
    let [(splat_s, vol_s, splat_n, vol_n), (bare_s, ball_s, bare_n, ball_n), (paper_s, ball2_s, paper_n, _)] = best;
    let ball_s = ball_s.min(ball2_s);
    println!("    (seconds of {})", if cpu { "this thread's CPU time, /proc/thread-self/schedstat" } else { "wall-clock time" });
    println!(
        "    splat cones (segment + extension beyond the hit) {splat_s:.3}s, {splat_n} points (the rs render kept {splat_pairs} (eye sample, ray) pairs); bare segments {bare_s:.3}s, {bare_n} points"
    );
    println!(
        "    balls of radius h at the photon hit {ball_s:.3}s, {ball_n} points -> cone/sphere {:.2}x (paper §9: 1.5-2x; goal: ≤ 1.5x; bare segments {:.2}x)",
        splat_s / ball_s,
        bare_s / ball_s
    );
    println!("    balls of the splat cone's volume {vol_s:.3}s, {vol_n} points -> cone/sphere {:.2}x", splat_s / vol_s);
    // The paper's own footprint: the frustum, then a half ball of radius h beyond the hit. On a
    // plane, a photon arriving at θ from the normal finds in it the half ellipse (h, h/cos θ)
    // before the hit and a half disc after, (1 + 1/cos θ)/2 times the ball's disc; for photons
    // arriving cosine-distributed (diffuse interreflection), E[1/cos θ] = 2, so 1.5 times.
    println!(
        "    the paper's footprint (segment + hemisphere beyond the hit, §5 Fig. 4) {paper_s:.3}s, {paper_n} points = {:.2}x the ball's (planes lit by diffuse light: 1.5x) -> cone/sphere {:.2}x, per point found {:.2}x",
        paper_n as f64 / ball_n.max(1) as f64,
        paper_s / ball_s,
        (paper_s / paper_n.max(1) as f64) / (ball_s / ball_n.max(1) as f64)
    );
    // The cost per point found separates the traversal's efficiency from the size of the region
    // (the splat cone holds about twice the points of the ball at its hit).
    let ns = |s: f64, n: u64| s * 1e9 / n.max(1) as f64;
    println!(
        "    per point found: splat cones {:.1} ns, balls of radius h {:.1} ns -> {:.2}x",
        ns(splat_s, splat_n),
        ns(ball_s, ball_n),
        ns(splat_s, splat_n) / ns(ball_s, ball_n)
    );
    // Whole splats, the measurement behind the paper's "1.5 to 2 times": query, feasibility tests,
    // kernel and accumulation, ray splatting against photon splatting in a ball of the same radius.
    let mut best = SplatTiming { ray_seconds: f64::INFINITY, sphere_seconds: f64::INFINITY, ..SplatTiming::default() };
    for _ in 0..3 {
        let mut sum = SplatTiming::default();
        for (tree, _, rays, pts, nrm) in &work {
            let t = time_ray_vs_spherical_splats(tree, pts, nrm, rays, &clock);
            sum.ray_seconds += t.ray_seconds;
            sum.sphere_seconds += t.sphere_seconds;
            sum.ray_pairs += t.ray_pairs;
            sum.sphere_pairs += t.sphere_pairs;
        }
        best = SplatTiming { ray_seconds: best.ray_seconds.min(sum.ray_seconds), sphere_seconds: best.sphere_seconds.min(sum.sphere_seconds), ..sum };
    }
    println!(
        "    whole splats (query, feasibility, kernel, accumulation): ray splatting {:.3}s, {} pairs; spherical footprint of radius h at the hit {:.3}s, {} pairs -> {:.2}x (the paper's §9 comparison: 1.5-2x)",
        best.ray_seconds,
        best.ray_pairs,
        best.sphere_seconds,
        best.sphere_pairs,
        best.ray_seconds / best.sphere_seconds
    );
    Ok(())
}

/// This thread's CPU time in seconds (Linux: the first field of `/proc/thread-self/schedstat`, in
/// nanoseconds); `None` where that is not readable.
fn thread_cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: u64 = s.split_whitespace().next()?.parse().ok()?;
    Some(ns as f64 * 1e-9)
}
