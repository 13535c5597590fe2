//! `raysplat-bench embree`: the throughput figures of `raysplat bench`, then the share of the path
//! tracer's time inside Embree measured rather than estimated: a single-threaded render with its
//! Embree calls timed by the time-stamp counter (`raysplat::embree::timing`, built only with the
//! feature `embree-timing`, which `make bench` turns on).
//!
//! With `--compare <raysplat-bench>` (a build with the other Embree: `make bench-embree` builds
//! the Embree 4 one in target/embree4), the other build then measures the same scene with the same
//! settings, after this one has finished, and one table puts the two side by side. Two Embree
//! libraries cannot share a process (their functions have the same names), hence two programs.

use std::path::PathBuf;
use std::process::Command;

use anyhow::{bail, Context};
use raysplat_cli::bench::{BenchArgs, Throughput};

#[derive(clap::Args)]
pub struct EmbreeArgs {
    #[command(flatten)]
    pub throughput: BenchArgs,
    /// A `raysplat-bench` built with the other Embree (e.g. target/embree4/release/raysplat-bench):
    /// run its measurement after this one and print both side by side.
    #[arg(long)]
    pub compare: Option<PathBuf>,
    /// End with the figures on one machine-readable line (what `--compare` reads).
    #[arg(long, hide = true)]
    pub figures_line: bool,
}

/// The start of the machine-readable line.
const FIGURES: &str = "embree-figures:";

/// One build's figures: its Embree version and rates per second.
struct Figures {
    version: String,
    coherent: f64,
    incoherent: f64,
    single: f64,
    pt_samples: f64,
    pt_rays: f64,
}

impl Figures {
    fn of(t: &Throughput) -> anyhow::Result<Figures> {
        Ok(Figures {
            version: raysplat::embree::Device::new(0)?.version(),
            coherent: t.coherent,
            incoherent: t.incoherent,
            single: t.single,
            pt_samples: t.pt_samples / t.pt_seconds,
            pt_rays: t.pt_rays / t.pt_seconds,
        })
    }

    fn line(&self) -> String {
        format!(
            "{FIGURES} version={} coherent={} incoherent={} single={} pt_samples={} pt_rays={}",
            self.version, self.coherent, self.incoherent, self.single, self.pt_samples, self.pt_rays
        )
    }

    fn parse(line: &str) -> anyhow::Result<Figures> {
        let fields: std::collections::HashMap<&str, &str> =
            line.split_whitespace().skip(1).filter_map(|kv| kv.split_once('=')).collect();
        let get = |k: &str| fields.get(k).copied().with_context(|| format!("no {k} in \"{line}\""));
        let num = |k: &str| -> anyhow::Result<f64> { Ok(get(k)?.parse()?) };
        Ok(Figures {
            version: get("version")?.to_string(),
            coherent: num("coherent")?,
            incoherent: num("incoherent")?,
            single: num("single")?,
            pt_samples: num("pt_samples")?,
            pt_rays: num("pt_rays")?,
        })
    }
}

pub fn run(a: &EmbreeArgs) -> anyhow::Result<()> {
    let t = raysplat_cli::bench::measure(&a.throughput)?;
    measured_share(&t, a.throughput.spp)?;
    let ours = Figures::of(&t)?;
    if a.figures_line {
        println!("{}", ours.line());
    }
    if let Some(other) = &a.compare {
        let theirs = run_other(other, &a.throughput)?;
        print_table(&a.throughput, &ours, &theirs);
    }
    Ok(())
}

/// Run `raysplat-bench embree` of the other build on the same scene and settings; its output is
/// shown, its figures returned.
fn run_other(program: &std::path::Path, b: &BenchArgs) -> anyhow::Result<Figures> {
    println!("\n{} (the other build):", program.display());
    let out = Command::new(program)
        .arg("embree")
        .arg(&b.scene)
        .args(["--resolution", &b.resolution, "--spp", &b.spp.to_string(), "--figures-line"])
        .output()
        .with_context(|| format!("cannot run {}", program.display()))?;
    let text = String::from_utf8_lossy(&out.stdout);
    print!("{}", text.lines().filter(|l| !l.starts_with(FIGURES)).map(|l| format!("{l}\n")).collect::<String>());
    if !out.status.success() {
        bail!("{} failed ({}): {}", program.display(), out.status, String::from_utf8_lossy(&out.stderr).trim());
    }
    match text.lines().find(|l| l.starts_with(FIGURES)) {
        Some(line) => Figures::parse(line),
        None => bail!("{} printed no figures (is it a raysplat-bench?)", program.display()),
    }
}

fn print_table(b: &BenchArgs, a: &Figures, o: &Figures) {
    println!(
        "\nEmbree {} and Embree {} on {} ({}, pt at {} spp, {} threads; measured one after the other):\n",
        a.version,
        o.version,
        b.scene.display(),
        b.resolution,
        b.spp,
        rayon::current_num_threads()
    );
    println!("| | Embree {} | Embree {} | ratio |", a.version, o.version);
    println!("|---|---:|---:|---:|");
    let rows = [
        ("coherent primary rays, batched (Mrays/s)", a.coherent, o.coherent),
        ("incoherent random rays, batched (Mrays/s)", a.incoherent, o.incoherent),
        ("incoherent random rays, one at a time (Mrays/s)", a.single, o.single),
        ("path tracer (Msamples/s)", a.pt_samples, o.pt_samples),
        ("path tracer (Mrays/s)", a.pt_rays, o.pt_rays),
    ];
    for (what, x, y) in rows {
        println!("| {what} | {:.2} | {:.2} | {:.2} |", x / 1e6, y / 1e6, y / x);
    }
}

#[cfg(feature = "embree-timing")]
fn measured_share(t: &Throughput, spp: u32) -> anyhow::Result<()> {
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
fn measured_share(_: &Throughput, _: u32) -> anyhow::Result<()> {
    println!("measured share inside Embree: not built in (`cargo build --release -p raysplat-bench --features embree-timing`, as `make bench` does)");
    Ok(())
}
