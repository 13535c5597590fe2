//! `raysplat bench`: throughput figures measured in one run, so they compare as ratios on a noisy
//! machine. Bare Embree (coherent primary rays, incoherent random rays) versus the path tracer, whose
//! rays per second over the bare incoherent rate estimate the share of its time spent inside Embree;
//! a single-threaded render with its Embree calls timed (`embree::timing`) measures it.

use raysplat::embree::Ray;
use raysplat::integrators::{self, RenderSettings, SilentProgress};
use raysplat::prepare::PreparedScene;
use raysplat::sampling::{hash, square_to_uniform_sphere, Rng};
use raysplat::usd;
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct BenchArgs {
    /// Scene to measure.
    #[arg(default_value = "scenes/cornell-box.usda")]
    scene: PathBuf,
    /// Image size for the primary-ray and path-tracing measurements.
    #[arg(long, default_value = "256x256")]
    resolution: String,
    /// Samples per pixel for the path tracer.
    #[arg(long, default_value_t = 16)]
    spp: u32,
    #[command(flatten)]
    photons: super::bench_photons::PhotonTableArgs,
    #[command(flatten)]
    auto: super::bench_auto::AutoTableArgs,
    #[command(flatten)]
    fg: super::bench_fg::FgTableArgs,
    #[command(flatten)]
    secondary: super::bench_secondary::SecondaryTableArgs,
    #[command(flatten)]
    target: super::bench_target::TargetTableArgs,
    #[command(flatten)]
    cache: super::bench_cache::CacheTableArgs,
}

const BATCH: usize = 256;

pub fn run(a: &BenchArgs) -> anyhow::Result<()> {
    if let Some(scenes) = &a.auto.auto_table {
        return super::bench_auto::run(&a.auto, scenes);
    }
    if let Some(scene) = &a.secondary.secondary_table {
        return super::bench_secondary::run(&a.secondary, scene);
    }
    if let Some(scenes) = &a.photons.photon_table {
        return super::bench_photons::run(&a.photons, scenes);
    }
    if let Some(scenes) = &a.fg.fg_table {
        return super::bench_fg::run(&a.fg, scenes);
    }
    if let Some(scenes) = &a.target.target_table {
        return super::bench_target::run(&a.target, scenes);
    }
    if let Some(scenes) = &a.cache.cache_table {
        return super::bench_cache::run(&a.cache, scenes);
    }
    let [w, h] = super::parse_resolution(&a.resolution)?;
    let desc = usd::load_scene(&a.scene)?;
    let scene = PreparedScene::new(desc.clone(), w, h, 0)?;
    println!("scene {} ({} triangles), {}x{}, {} threads", a.scene.display(), scene.requirements.triangles, w, h, rayon::current_num_threads());

    // Coherent: camera rays in batches of image rows.
    let cam = &scene.camera;
    let primary: Vec<Ray> = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| cam.ray(x as f32 + 0.5, y as f32 + 0.5)).collect();
    let coherent = measure(&primary, |rays, hits| scene.embree.intersect_batch(rays, hits, true));
    // Incoherent: random origins inside the bounds, random directions.
    let (lo, hi) = scene.bounds;
    let random: Vec<Ray> = (0..primary.len().max(1 << 18))
        .map(|i| {
            let mut rng = Rng::new(hash(&[7, i as u64]), 0);
            let o = lo + (hi - lo) * glam::Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            Ray::new(o, square_to_uniform_sphere(rng.next_2d()))
        })
        .collect();
    let incoherent = measure(&random, |rays, hits| scene.embree.intersect_batch(rays, hits, false));
    let single = measure(&random, |rays, hits| {
        for (r, hh) in rays.iter().zip(hits.iter_mut()) {
            *hh = scene.embree.intersect(r);
        }
    });
    println!("embree coherent primary rays   {:8.2} Mrays/s (batched)", coherent / 1e6);
    println!("embree incoherent random rays  {:8.2} Mrays/s (batched), {:.2} Mrays/s (single)", incoherent / 1e6, single / 1e6);

    let settings = RenderSettings { spp: a.spp, resolution: Some([w, h]), ..Default::default() };
    let out = integrators::render(desc.clone(), &settings, &SilentProgress)?;
    let secs = out.stats.phase_seconds("trace").unwrap_or(out.stats.total_seconds);
    let samples = (w * h) as f64 * out.stats.counter("spp").unwrap_or(0) as f64;
    let rays = out.stats.counter("rays").unwrap_or(0) as f64;
    let pt_rate = rays / secs;
    println!("path tracer                    {:8.3} Msamples/s, {:.2} Mrays/s ({} spp in {:.2}s)", samples / secs / 1e6, pt_rate / 1e6, a.spp, secs);
    println!(
        "estimated share of path-tracer time inside Embree: {:.0}% (its rays at the bare single-ray rate take {:.2}s of {:.2}s)",
        100.0 * (rays / single / secs).min(1.0),
        rays / single,
        secs
    );
    // Measured: the Embree calls of a single-threaded render timed with the time-stamp counter.
    let one = RenderSettings { threads: 1, ..settings };
    let (c0, t0) = (raysplat::embree::timing::cycles_now(), Instant::now());
    raysplat::embree::timing::set_counting(true);
    let out = integrators::render(desc, &one, &SilentProgress);
    let inside = raysplat::embree::timing::counted_cycles();
    raysplat::embree::timing::set_counting(false);
    let (cycles, wall) = (raysplat::embree::timing::cycles_now().wrapping_sub(c0), t0.elapsed().as_secs_f64());
    let out = out?;
    let trace = out.stats.phase_seconds("trace").unwrap_or(out.stats.total_seconds);
    if cycles > 0 && wall > 0.0 {
        let per_second = cycles as f64 / wall;
        println!(
            "measured share inside Embree (1 thread, its calls timed by the time-stamp counter): {:.0}% ({:.2}s of the {:.2}s trace phase)",
            100.0 * inside as f64 / (trace * per_second),
            inside as f64 / per_second,
            trace
        );
    }
    Ok(())
}

/// Rays per second of `f` over `rays`, in parallel batches, repeated until ~1 s has passed.
fn measure(rays: &[Ray], f: impl Fn(&[Ray], &mut [Option<raysplat::embree::Hit>]) + Sync) -> f64 {
    let t0 = Instant::now();
    let mut n = 0usize;
    while t0.elapsed().as_secs_f64() < 1.0 {
        rays.par_chunks(BATCH).for_each(|chunk| {
            raysplat::embree::set_flush_denormals();
            let mut hits = [None; BATCH];
            f(chunk, &mut hits[..chunk.len()]);
            std::hint::black_box(&hits);
        });
        n += rays.len();
    }
    n as f64 / t0.elapsed().as_secs_f64()
}
