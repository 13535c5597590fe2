//! `raysplat-bench embree`: the throughput figures of `raysplat bench`, then the share of the path
//! tracer's time inside Embree measured rather than estimated: a single-threaded render with its
//! Embree calls timed by the time-stamp counter (`raysplat::embree::timing`, built only with the
//! feature `embree-timing`, which `make bench` turns on).

use raysplat_cli::bench::BenchArgs;

#[derive(clap::Args)]
pub struct EmbreeArgs {
    #[command(flatten)]
    pub throughput: BenchArgs,
}

pub fn run(a: &EmbreeArgs) -> anyhow::Result<()> {
    let t = raysplat_cli::bench::measure(&a.throughput)?;
    measured_share(&t, a.throughput.spp)
}

#[cfg(feature = "embree-timing")]
fn measured_share(t: &raysplat_cli::bench::Throughput, spp: u32) -> anyhow::Result<()> {
    use raysplat::embree::timing;
    use raysplat::integrators::{self, RenderSettings, SilentProgress};
    use std::time::Instant;

    let one = RenderSettings { spp, resolution: Some(t.resolution), threads: 1, ..Default::default() };
    let (c0, t0) = (timing::cycles_now(), Instant::now());
    timing::set_counting(true);
    let out = integrators::render(t.desc.clone(), &one, &SilentProgress);
    let inside = timing::counted_cycles();
    timing::set_counting(false);
    let (cycles, wall) = (timing::cycles_now().wrapping_sub(c0), t0.elapsed().as_secs_f64());
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
    } else {
        println!("measured share inside Embree: no time-stamp counter on this machine");
    }
    Ok(())
}

#[cfg(not(feature = "embree-timing"))]
fn measured_share(_: &raysplat_cli::bench::Throughput, _: u32) -> anyhow::Result<()> {
    println!("measured share inside Embree: not built in (`cargo build --release -p raysplat-bench --features embree-timing`, as `make bench` does)");
    Ok(())
}
