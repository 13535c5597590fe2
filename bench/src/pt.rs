//! `raysplat-bench pt`: the path tracer's samples per second on USD stages at several sample
//! counts and, when a Mitsuba 3 is installed, Mitsuba's on the same stages in the same run
//! (through the workplace's `usd_to_mitsuba.py`, which reads USD as we do, driven by our
//! `scripts/mitsuba_filters.py`, which sets Mitsuba's pixel filter), with the ratio of the times
//! (ours / Mitsuba's; below 1: we are faster).
//!
//! Both renderers render each stage at the same size with the same pixel filter (`--filter`: box
//! and gaussian have Mitsuba counterparts of the same shape); our time is the render's `trace`
//! phase after a 1-spp warm-up (the BSDF tables fill on first use), Mitsuba's the `mi.render` calls
//! after warm-up renders of each pass size (the JIT compiles a kernel per size), as the script
//! reports them. With `--reference-spp`
//! each renderer also renders its own reference per stage and filter, and the tables give each
//! image's relative MSE against it and the two references' difference (see `pt_errors`).

use crate::pt_errors::{Between, Reference};
use raysplat::image::{FilterKind, PixelFilter};
use raysplat::integrators::{self, RenderSettings, SilentProgress};
use std::path::{Path, PathBuf};
use std::process::Command;

#[derive(clap::Args)]
pub struct PtArgs {
    /// USD stages with their image sizes, `STAGE@WIDTHxHEIGHT` (comma separated; without `@` the
    /// stage's own size).
    #[arg(required = true, num_args = 1.., value_delimiter = ',', value_name = "STAGES")]
    pub stages: Vec<String>,
    /// Samples per pixel (comma separated).
    #[arg(long, value_delimiter = ',', default_value = "16,64,256")]
    pub spp: Vec<u32>,
    /// Pixel filters at their default radii (comma separated, as `raysplat render --filter`);
    /// Mitsuba renders `box` and `gaussian` (its stddev 0.5, radius 2: our shape) and skips others.
    #[arg(long, value_delimiter = ',', default_value = "box")]
    pub filter: Vec<String>,
    /// Also render, per stage, filter and renderer, a reference of twice this many samples per
    /// pixel (two renders of other seeds), and print each image's relative MSE against its own
    /// renderer's reference and how far the two references are apart, net of their noise.
    #[arg(long)]
    pub reference_spp: Option<u32>,
    /// A Python with `mitsuba`, `usd-core` and `numpy` [default: $RAYSPLAT_MITSUBA_PYTHON; none:
    /// our figures only].
    #[arg(long)]
    pub mitsuba_python: Option<PathBuf>,
    /// The workplace's USD-to-Mitsuba converter [default: ../shared/peer/usd_to_mitsuba.py, from
    /// the workspace as the workplace lays it out].
    #[arg(long)]
    pub mitsuba_script: Option<PathBuf>,
    /// Mitsuba variant.
    #[arg(long, default_value = "llvm_ad_rgb")]
    pub mitsuba_variant: String,
}

/// Our driver of the converter, which sets Mitsuba's pixel filter.
const DRIVER: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../scripts/mitsuba_filters.py");
/// Filters the driver knows.
const MITSUBA_FILTERS: [FilterKind; 2] = [FilterKind::Box, FilterKind::Gaussian];
/// Seeds of the two reference renders (ours; Mitsuba's are these times 1000, apart by more than
/// its passes of 64 spp).
const REFERENCE_SEEDS: [u64; 2] = [1001, 2001];

/// One renderer's results on a stage with a filter: seconds per spp count, and with
/// `--reference-spp` each image's error against the renderer's reference.
struct Side {
    seconds: Vec<f64>,
    errors: Option<Vec<f64>>,
    reference: Option<Reference>,
}

/// One stage with one filter.
struct Row {
    name: String,
    size: [u32; 2],
    filter: FilterKind,
    ours: Side,
    theirs: Option<Side>,
    between: Option<Between>,
}

pub fn run(a: &PtArgs) -> anyhow::Result<()> {
    let filters = a.filter.iter().map(|f| PixelFilter::new(FilterKind::parse(f)?, None)).collect::<raysplat::Result<Vec<_>>>()?;
    let python = a.mitsuba_python.clone().or_else(|| std::env::var_os("RAYSPLAT_MITSUBA_PYTHON").map(PathBuf::from));
    let script = a.mitsuba_script.clone().unwrap_or_else(|| PathBuf::from("../shared/peer/usd_to_mitsuba.py"));
    let mitsuba = match &python {
        Some(p) if script.is_file() => Some(p.clone()),
        Some(_) => {
            println!("Mitsuba: skipped, no script at {}", script.display());
            None
        }
        None => {
            println!("Mitsuba: skipped (give --mitsuba-python or RAYSPLAT_MITSUBA_PYTHON: a Python with mitsuba, usd-core and numpy)");
            None
        }
    };
    let mut rows = Vec::new();
    for spec in &a.stages {
        let (stage, size) = match spec.split_once('@') {
            Some((s, wh)) => (PathBuf::from(s), Some(integrators::parse_size(wh)?)),
            None => (PathBuf::from(spec), None),
        };
        if !stage.is_file() {
            println!("{}: skipped, no such file", stage.display());
            continue;
        }
        let desc = raysplat::usd::load_scene(&stage)?;
        let size = size.unwrap_or(desc.resolution.unwrap_or([512, 512]));
        let name = stage.file_name().map_or(spec.clone(), |n| n.to_string_lossy().into_owned());
        for &filter in &filters {
            let render = |spp: u32, seed: u64| -> anyhow::Result<(f64, Vec<f32>)> {
                let s = RenderSettings { spp, resolution: Some(size), seed, filter, ..Default::default() };
                let out = integrators::render(desc.clone(), &s, &SilentProgress)?;
                let rgb = out.film.rgb("").ok_or_else(|| anyhow::anyhow!("the path tracer's image has no RGB"))?;
                Ok((out.stats.phase_seconds("trace").unwrap_or(out.stats.total_seconds), rgb))
            };
            render(1, 1)?;
            let (seconds, images): (Vec<f64>, Vec<Vec<f32>>) = a.spp.iter().map(|&n| render(n, 1)).collect::<anyhow::Result<Vec<_>>>()?.into_iter().unzip();
            let reference = match a.reference_spp {
                Some(n) => Some(Reference::new(render(n, REFERENCE_SEEDS[0])?.1, render(n, REFERENCE_SEEDS[1])?.1)),
                None => None,
            };
            let ours = Side::new(seconds, &images, reference);
            let theirs = match &mitsuba {
                Some(_) if !MITSUBA_FILTERS.contains(&filter.kind) => {
                    println!("Mitsuba on {name}: skipped for --filter {} (the driver has box and gaussian)", filter.kind.name());
                    None
                }
                Some(py) => mitsuba_side(py, &script, &a.mitsuba_variant, &stage, size, filter.kind, &a.spp, a.reference_spp)?,
                None => None,
            };
            let between = match (&ours.reference, theirs.as_ref().and_then(|t| t.reference.as_ref())) {
                (Some(o), Some(t)) => Some(Between::new(o, t)),
                _ => None,
            };
            rows.push(Row { name: name.clone(), size, filter: filter.kind, ours, theirs, between });
        }
    }
    print_times(&rows, &a.spp, &a.mitsuba_variant);
    if let Some(n) = a.reference_spp {
        print_errors(&rows, &a.spp, n);
    }
    Ok(())
}

impl Side {
    fn new(seconds: Vec<f64>, images: &[Vec<f32>], reference: Option<Reference>) -> Side {
        let errors = reference.as_ref().map(|r| images.iter().map(|i| r.error_of(i)).collect());
        Side { seconds, errors, reference }
    }
}

/// Mitsuba's side from the driver's JSON lines and images (`None`, with the reason printed, when
/// it fails).
#[allow(clippy::too_many_arguments)]
fn mitsuba_side(python: &Path, script: &Path, variant: &str, stage: &Path, [w, h]: [u32; 2], filter: FilterKind, spp: &[u32], reference_spp: Option<u32>) -> anyhow::Result<Option<Side>> {
    let out_dir = std::env::temp_dir().join(format!("raysplat-bench-pt-{}", std::process::id()));
    let mut jobs: Vec<String> = spp.iter().enumerate().map(|(i, n)| format!("t{i}:{n}:{}", 10_000 * (i + 1))).collect();
    if let Some(n) = reference_spp {
        jobs.extend(REFERENCE_SEEDS.iter().enumerate().map(|(i, s)| format!("r{i}:{n}:{}", s * 1000)));
    }
    let mut cmd = Command::new(python);
    cmd.arg(DRIVER).arg(script).arg(stage).arg(&out_dir).arg(variant).arg(w.to_string()).arg(h.to_string()).arg(filter.name()).args(&jobs);
    if std::env::var_os("DRJIT_LIBLLVM_PATH").is_none() {
        if let Some(llvm) = ["/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1", "/usr/lib/llvm-19/lib/libLLVM.so.1"].iter().find(|p| Path::new(p).is_file()) {
            cmd.env("DRJIT_LIBLLVM_PATH", llvm);
        }
    }
    let out = cmd.output().map_err(|e| raysplat::Error::io(python, e))?;
    let read = |name: &str| -> anyhow::Result<Vec<f32>> {
        let film = raysplat::image::read_exr(&out_dir.join(format!("{name}.exr")))?;
        film.rgb("").ok_or_else(|| anyhow::anyhow!("Mitsuba's {name}.exr has no R, G, B"))
    };
    let side = if out.status.success() {
        let mut seconds = vec![f64::NAN; spp.len()];
        for line in String::from_utf8_lossy(&out.stdout).lines() {
            let (Some(i), Some(s)) = (json_text(line, "name").and_then(|n| n.strip_prefix('t')?.parse::<usize>().ok()), json_number(line, "seconds")) else { continue };
            if i < seconds.len() {
                seconds[i] = s;
            }
        }
        let images = match reference_spp {
            Some(_) => (0..spp.len()).map(|i| read(&format!("t{i}"))).collect::<anyhow::Result<Vec<_>>>()?,
            None => Vec::new(),
        };
        let reference = match reference_spp {
            Some(_) => Some(Reference::new(read("r0")?, read("r1")?)),
            None => None,
        };
        Some(Side::new(seconds, &images, reference))
    } else {
        let err = String::from_utf8_lossy(&out.stderr);
        println!("Mitsuba on {}: failed ({}): {}", stage.display(), out.status, err.lines().last().unwrap_or(""));
        None
    };
    std::fs::remove_dir_all(&out_dir).ok();
    Ok(side)
}

/// The number after `"key": ` in a one-line JSON object (the script's flat records).
fn json_number(line: &str, key: &str) -> Option<f64> {
    let at = line.find(&format!("\"{key}\": "))? + key.len() + 4;
    let rest = &line[at..];
    let end = rest.find([',', '}']).unwrap_or(rest.len());
    rest[..end].trim().parse().ok()
}

/// The string after `"key": ` in a one-line JSON object (no escapes: the job names).
fn json_text<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    let at = line.find(&format!("\"{key}\": \""))? + key.len() + 5;
    let rest = &line[at..];
    Some(&rest[..rest.find('"')?])
}

/// The box row of row `k`'s stage rendered last before it (`--filter box,gaussian,box,gaussian`
/// pairs each Gaussian run with the box run just before it).
fn box_before(rows: &[Row], k: usize) -> Option<&Row> {
    let r = &rows[k];
    rows[..k].iter().rev().find(|b| b.name == r.name && b.size == r.size && b.filter == FilterKind::Box)
}

fn print_times(rows: &[Row], spp: &[u32], variant: &str) {
    println!("path tracer (pt) against Mitsuba 3 ({variant}, path), same pixel filter: seconds of rendering, samples per second (millions), ratio of times");
    println!("{:<28} {:>10} {:>9} {:>6} {:>9} {:>8} {:>9} {:>8} {:>7}", "stage", "size", "filter", "spp", "ours s", "Ms/s", "Mitsuba s", "Ms/s", "ratio");
    for r in rows {
        let pixels = r.size[0] as f64 * r.size[1] as f64;
        for (i, &n) in spp.iter().enumerate() {
            let rate = |t: f64| pixels * n as f64 / t / 1e6;
            let ours = r.ours.seconds[i];
            let (theirs, their_rate, ratio) = match r.theirs.as_ref().map(|t| t.seconds[i]) {
                Some(t) if t.is_finite() => (format!("{t:.2}"), format!("{:.2}", rate(t)), format!("{:.2}×", ours / t)),
                _ => ("-".into(), "-".into(), "-".into()),
            };
            let size = format!("{}x{}", r.size[0], r.size[1]);
            println!("{:<28} {:>10} {:>9} {:>6} {:>9.2} {:>8.2} {:>9} {:>8} {:>7}", r.name, size, r.filter.name(), n, ours, rate(ours), theirs, their_rate, ratio);
        }
    }
    // each filter's time against the box's, per renderer (the cost of splatting)
    for (k, r) in rows.iter().enumerate().filter(|(_, r)| r.filter != FilterKind::Box) {
        let Some(b) = box_before(rows, k) else { continue };
        for (i, &n) in spp.iter().enumerate() {
            let theirs = match (&r.theirs, &b.theirs) {
                (Some(t), Some(tb)) => format!("{:.2}", t.seconds[i] / tb.seconds[i]),
                _ => "-".into(),
            };
            println!("{} {} spp: time with {} / with box: ours {:.2}, Mitsuba {theirs}", r.name, n, r.filter.name(), r.ours.seconds[i] / b.ours.seconds[i]);
        }
    }
}

fn print_errors(rows: &[Row], spp: &[u32], reference_spp: u32) {
    println!();
    println!("relative MSE against the renderer's own reference (2 x {reference_spp} spp, its noise subtracted), and the filter's over the box's at equal spp");
    println!("{:<28} {:>9} {:>6} {:>10} {:>10} {:>10} {:>10}", "stage", "filter", "spp", "ours", "Mitsuba", "ours/box", "Mitsuba/box");
    let fmt = |v: Option<f64>, p: usize| v.filter(|v| v.is_finite()).map_or("-".to_string(), |v| format!("{v:.p$e}"));
    for (k, r) in rows.iter().enumerate() {
        let b = if r.filter == FilterKind::Box { Some(r) } else { box_before(rows, k) };
        for (i, &n) in spp.iter().enumerate() {
            let ours = r.ours.errors.as_ref().map(|e| e[i]);
            let theirs = r.theirs.as_ref().and_then(|t| t.errors.as_ref()).map(|e| e[i]);
            let ours_box = b.and_then(|b| b.ours.errors.as_ref()).map(|e| e[i]);
            let theirs_box = b.and_then(|b| b.theirs.as_ref()?.errors.as_ref()).map(|e| e[i]);
            let ratio = |x: Option<f64>, y: Option<f64>| match (x, y) {
                (Some(x), Some(y)) => format!("{:.2}", x / y),
                _ => "-".into(),
            };
            println!("{:<28} {:>9} {:>6} {:>10} {:>10} {:>10} {:>10}", r.name, r.filter.name(), n, fmt(ours, 2), fmt(theirs, 2), ratio(ours, ours_box), ratio(theirs, theirs_box));
        }
    }
    println!();
    println!("our reference against Mitsuba's: relative MSE raw, the two references' noise, and net (the converged images' difference)");
    println!("{:<28} {:>9} {:>10} {:>10} {:>10}", "stage", "filter", "raw", "noise", "net");
    for r in rows {
        if let Some(b) = &r.between {
            println!("{:<28} {:>9} {:>10} {:>10} {:>10}", r.name, r.filter.name(), fmt(Some(b.raw), 2), fmt(Some(b.noise), 2), fmt(Some(b.net()), 2));
        }
    }
}
