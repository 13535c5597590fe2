//! `raysplat bench`: what this machine does per second on a scene, measured in one run so the
//! figures compare as ratios — bare Embree (coherent primary rays, incoherent random rays, batched
//! and one at a time) and the path tracer's samples and rays per second, whose rays per second over
//! the bare single-ray rate estimate the share of its time spent inside Embree. The papers' tables
//! are `raysplat-bench` (`make bench`).

use raysplat::embree::Ray;
use raysplat::integrators::{self, RenderSettings, SilentProgress};
use raysplat::prepare::PreparedScene;
use raysplat::sampling::{hash, square_to_uniform_sphere, Rng};
use raysplat::scene::SceneDesc;
use raysplat::usd;
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args, Clone)]
pub struct BenchArgs {
    /// Scene to measure.
    #[arg(default_value = "scenes/cornell-box.usda")]
    pub scene: PathBuf,
    /// Image size for the primary-ray and path-tracing measurements.
    #[arg(long, default_value = "256x256")]
    pub resolution: String,
    /// Samples per pixel for the path tracer.
    #[arg(long, default_value_t = 16)]
    pub spp: u32,
}

/// The scene measured and what was measured on it.
pub struct Throughput {
    pub desc: SceneDesc,
    pub resolution: [u32; 2],
    /// Rays per second: coherent camera rays (batched), incoherent random rays (batched), the same
    /// one at a time.
    pub coherent: f64,
    pub incoherent: f64,
    pub single: f64,
    /// The path tracer's render: seconds of its trace phase, samples and rays traced.
    pub pt_seconds: f64,
    pub pt_samples: f64,
    pub pt_rays: f64,
}

const BATCH: usize = 256;

pub fn run(a: &BenchArgs) -> anyhow::Result<()> {
    measure(a)?;
    Ok(())
}

/// Measure and print the throughput figures of `a`.
pub fn measure(a: &BenchArgs) -> anyhow::Result<Throughput> {
    let [w, h] = raysplat::integrators::parse_size(&a.resolution)?;
    let desc = usd::load_scene(&a.scene)?;
    let scene = PreparedScene::new(desc.clone(), w, h, 0)?;
    println!("scene {} ({} triangles), {}x{}, {} threads", a.scene.display(), scene.requirements.triangles, w, h, rayon::current_num_threads());

    // Coherent: camera rays in batches of image rows.
    let cam = &scene.camera;
    let primary: Vec<Ray> = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| cam.ray(x as f32 + 0.5, y as f32 + 0.5)).collect();
    let coherent = rays_per_second(&primary, |rays, hits| scene.embree.intersect_batch(rays, hits, true));
    // Incoherent: random origins inside the bounds, random directions.
    let (lo, hi) = scene.bounds;
    let random: Vec<Ray> = (0..primary.len().max(1 << 18))
        .map(|i| {
            let mut rng = Rng::new(hash(&[7, i as u64]), 0);
            let o = lo + (hi - lo) * glam::Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            Ray::new(o, square_to_uniform_sphere(rng.next_2d()))
        })
        .collect();
    let incoherent = rays_per_second(&random, |rays, hits| scene.embree.intersect_batch(rays, hits, false));
    let single = rays_per_second(&random, |rays, hits| {
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
    println!("path tracer                    {:8.3} Msamples/s, {:.2} Mrays/s ({} spp in {:.2}s)", samples / secs / 1e6, rays / secs / 1e6, a.spp, secs);
    println!(
        "estimated share of path-tracer time inside Embree: {:.0}% (its rays at the bare single-ray rate take {:.2}s of {:.2}s)",
        100.0 * (rays / single / secs).min(1.0),
        rays / single,
        secs
    );
    Ok(Throughput { desc, resolution: [w, h], coherent, incoherent, single, pt_seconds: secs, pt_samples: samples, pt_rays: rays })
}

/// Rays per second of `f` over `rays`, in parallel batches, repeated until ~1 s has passed.
fn rays_per_second(rays: &[Ray], f: impl Fn(&[Ray], &mut [Option<raysplat::embree::Hit>]) + Sync) -> f64 {
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
