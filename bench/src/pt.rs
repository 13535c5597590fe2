//! `raysplat-bench pt`: the path tracer's samples per second on USD stages at several sample
//! counts and, when a Mitsuba 3 is installed, Mitsuba's on the same stages in the same run
//! (through the workplace's `usd_to_mitsuba.py`, which reads USD as we do), with the ratio of the
//! times (ours / Mitsuba's; below 1: we are faster).
//!
//! Both renderers render each stage at the same size with a box pixel filter; our time is the
//! render's `trace` phase after a 1-spp warm-up (the BSDF tables fill on first use), Mitsuba's the
//! `mi.render` calls after its 1-spp warm-up (the JIT compile), as the script reports them.

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
    /// A Python with `mitsuba`, `usd-core` and `numpy` [default: $RAYSPLAT_MITSUBA_PYTHON; none:
    /// our figures only].
    #[arg(long)]
    pub mitsuba_python: Option<PathBuf>,
    /// The converter and render script [default: ../shared/peer/usd_to_mitsuba.py, from the
    /// workspace as the workplace lays it out].
    #[arg(long)]
    pub mitsuba_script: Option<PathBuf>,
    /// Mitsuba variant.
    #[arg(long, default_value = "llvm_ad_rgb")]
    pub mitsuba_variant: String,
}

/// One stage's row: our seconds per spp count, and Mitsuba's when it ran.
struct Row {
    name: String,
    size: [u32; 2],
    ours: Vec<f64>,
    theirs: Option<Vec<f64>>,
}

pub fn run(a: &PtArgs) -> anyhow::Result<()> {
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
        let render = |spp: u32| -> anyhow::Result<f64> {
            let s = RenderSettings { spp, resolution: Some(size), seed: 1, ..Default::default() };
            let out = integrators::render(desc.clone(), &s, &SilentProgress)?;
            Ok(out.stats.phase_seconds("trace").unwrap_or(out.stats.total_seconds))
        };
        render(1)?;
        let ours = a.spp.iter().map(|&n| render(n)).collect::<anyhow::Result<Vec<f64>>>()?;
        let theirs = match &mitsuba {
            Some(py) => mitsuba_times(py, &script, &a.mitsuba_variant, &stage, size, &a.spp)?,
            None => None,
        };
        let name = stage.file_name().map_or(spec.clone(), |n| n.to_string_lossy().into_owned());
        rows.push(Row { name, size, ours, theirs });
    }
    print_table(&rows, &a.spp, &a.mitsuba_variant);
    Ok(())
}

/// Mitsuba's seconds per spp count, from the script's JSON lines (`None`, with the reason
/// printed, when it fails).
fn mitsuba_times(python: &Path, script: &Path, variant: &str, stage: &Path, [w, h]: [u32; 2], spp: &[u32]) -> anyhow::Result<Option<Vec<f64>>> {
    let out_dir = std::env::temp_dir().join(format!("raysplat-bench-pt-{}", std::process::id()));
    let mut cmd = Command::new(python);
    cmd.arg(script).arg(stage).arg(&out_dir).arg(variant).arg(w.to_string());
    cmd.args(spp.iter().map(|n| n.to_string())).arg("--height").arg(h.to_string());
    if std::env::var_os("DRJIT_LIBLLVM_PATH").is_none() {
        if let Some(llvm) = ["/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1", "/usr/lib/llvm-19/lib/libLLVM.so.1"].iter().find(|p| Path::new(p).is_file()) {
            cmd.env("DRJIT_LIBLLVM_PATH", llvm);
        }
    }
    let out = cmd.output().map_err(|e| raysplat::Error::io(python, e))?;
    std::fs::remove_dir_all(&out_dir).ok();
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        println!("Mitsuba on {}: failed ({}): {}", stage.display(), out.status, err.lines().last().unwrap_or(""));
        return Ok(None);
    }
    let mut times = vec![f64::NAN; spp.len()];
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let (Some(n), Some(s)) = (json_number(line, "spp"), json_number(line, "seconds")) else { continue };
        if let Some(i) = spp.iter().position(|&k| k as f64 == n) {
            times[i] = s;
        }
    }
    Ok(Some(times))
}

/// The number after `"key": ` in a one-line JSON object (the script's flat records).
fn json_number(line: &str, key: &str) -> Option<f64> {
    let at = line.find(&format!("\"{key}\": "))? + key.len() + 4;
    let rest = &line[at..];
    let end = rest.find([',', '}']).unwrap_or(rest.len());
    rest[..end].trim().parse().ok()
}

fn print_table(rows: &[Row], spp: &[u32], variant: &str) {
    println!("path tracer (pt, box filter) against Mitsuba 3 ({variant}, path): seconds of rendering, samples per second (millions), ratio of times");
    println!("{:<28} {:>10} {:>6} {:>9} {:>8} {:>9} {:>8} {:>7}", "stage", "size", "spp", "ours s", "Ms/s", "Mitsuba s", "Ms/s", "ratio");
    for r in rows {
        let pixels = r.size[0] as f64 * r.size[1] as f64;
        for (i, &n) in spp.iter().enumerate() {
            let rate = |t: f64| pixels * n as f64 / t / 1e6;
            let ours = r.ours[i];
            let (theirs, their_rate, ratio) = match r.theirs.as_ref().map(|t| t[i]) {
                Some(t) if t.is_finite() => (format!("{t:.2}"), format!("{:.2}", rate(t)), format!("{:.2}×", ours / t)),
                _ => ("-".into(), "-".into(), "-".into()),
            };
            println!(
                "{:<28} {:>10} {:>6} {:>9.2} {:>8.2} {:>9} {:>8} {:>7}",
                r.name,
                format!("{}x{}", r.size[0], r.size[1]),
                n,
                ours,
                rate(ours),
                theirs,
                their_rate,
                ratio
            );
        }
    }
}
