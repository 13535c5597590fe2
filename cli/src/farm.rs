//! `raysplat farm plan|submit|status`: one render split into tasks for a render farm.
//!
//! `plan` writes into a job directory a farm-neutral description (`job.json`: the scene conversion
//! step, one command per task with the files it writes, the merge) and Slurm batch scripts
//! (`convert.sbatch`, an array job `tasks.sbatch`, `merge.sbatch`). `submit` hands them to
//! `sbatch` — the conversion, then the array after it (`--dependency=afterok`), then the merge
//! after the array — and, run again, queues only the tasks whose parts are missing. `status` counts
//! the parts written, asks `squeue`/`sacct` about the jobs submitted, and estimates the time left.
//!
//! Splits: `frames` (chunks of a `--frames` sequence), `tiles` (`--tile I/N`: bands of rows, every
//! task tracing the same photons) and `passes` (`--passes P --pass-range`: ranges of independent
//! passes, averaged by the merge). Every task reads the stage converted once, by the conversion
//! step, into the job directory: `scene.rss`, or for frames one `scenes/scene.####.rss` per frame.
//! Parts are written atomically, so a part that exists is complete.

use super::shell::quote;
use raysplat::Error;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::process::Command;

#[derive(clap::Subcommand)]
pub enum FarmCommand {
    /// Write the job description (job.json) and Slurm scripts into DIR.
    Plan(PlanArgs),
    /// Submit the job in DIR to Slurm (again: only the tasks whose parts are missing).
    Submit {
        dir: PathBuf,
        /// Print the sbatch commands instead of running them.
        #[arg(long)]
        dry_run: bool,
    },
    /// Parts done of N, what Slurm says of the jobs, the time left.
    Status {
        dir: PathBuf,
        /// Print the status as JSON.
        #[arg(long)]
        json: bool,
    },
}

#[derive(clap::Args)]
pub struct PlanArgs {
    /// The scene (USD stage or .rss).
    scene: PathBuf,
    /// How to split the render: frames, tiles or passes.
    #[arg(long, value_parser = ["frames", "tiles", "passes"])]
    split: String,
    /// Tasks of the array job.
    #[arg(long)]
    tasks: u32,
    /// The job directory (created; its job.json is replaced).
    #[arg(short, long)]
    output: PathBuf,
    /// CPUs per task (sbatch --cpus-per-task; each task renders with as many threads).
    #[arg(long, default_value_t = 1)]
    cpus_per_task: u32,
    /// Further sbatch options for every job (e.g. --sbatch=--partition=render), repeatable.
    #[arg(long = "sbatch", allow_hyphen_values = true)]
    sbatch: Vec<String>,
    /// The render's flags, after `--` (e.g. -- --method rs --spp 4 --passes 64; frames: --frames 1:24).
    #[arg(last = true)]
    render: Vec<String>,
}

/// A command and the files it writes.
#[derive(Serialize, Deserialize, Clone, Debug)]
pub struct Step {
    pub command: Vec<String>,
    pub outputs: Vec<PathBuf>,
}

/// The farm-neutral job description (`job.json`).
#[derive(Serialize, Deserialize, Clone, Debug)]
pub struct Job {
    pub version: u32,
    pub split: String,
    pub scene: PathBuf,
    pub dir: PathBuf,
    pub cpus_per_task: u32,
    pub sbatch: Vec<String>,
    /// Converts the USD stage to the .rss every task reads (frames: one per frame; none for an .rss
    /// scene).
    pub convert: Option<Step>,
    pub tasks: Vec<Step>,
    /// Merges the parts (none for frames: each frame is its own file).
    pub merge: Option<Step>,
}

/// Submissions so far (`submitted.json`): when, and the Slurm job ids.
#[derive(Serialize, Deserialize, Default, Debug)]
struct Submitted {
    first_unix: f64,
    jobs: Vec<String>,
    merge_job: Option<String>,
}

pub fn run(cmd: &FarmCommand) -> anyhow::Result<()> {
    match cmd {
        FarmCommand::Plan(a) => plan(a),
        FarmCommand::Submit { dir, dry_run } => submit(dir, *dry_run),
        FarmCommand::Status { dir, json } => status(dir, *json),
    }
}

fn abs(p: &Path) -> Result<PathBuf, Error> {
    std::path::absolute(p).map_err(|e| Error::io(p, e))
}

/// The task ranges of `n` items over `tasks` tasks: task `i` gets `⌊i·n/tasks⌋ .. ⌊(i+1)·n/tasks⌋`.
pub fn ranges(n: u64, tasks: u32) -> Vec<(u64, u64)> {
    (0..tasks as u64).map(|i| (i * n / tasks as u64, (i + 1) * n / tasks as u64)).collect()
}

/// The value of `--flag V` or `--flag=V` in `args`, and `args` without it.
fn take_flag(args: &[String], flag: &str) -> (Option<String>, Vec<String>) {
    let mut rest = Vec::new();
    let mut value = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        if a == flag {
            value = it.next().cloned();
        } else if let Some(v) = a.strip_prefix(&format!("{flag}=")) {
            value = Some(v.to_string());
        } else {
            rest.push(a.clone());
        }
    }
    (value, rest)
}

fn plan(a: &PlanArgs) -> anyhow::Result<()> {
    if a.tasks == 0 || a.tasks > 100_000 {
        return Err(Error::param("tasks", format!("{} is out of range (1..=100000)", a.tasks)).into());
    }
    if !a.scene.exists() {
        return Err(Error::io(&a.scene, std::io::Error::new(std::io::ErrorKind::NotFound, "no such file")).into());
    }
    for f in ["--tile", "--crop", "--pass-range", "-o", "--output", "--threads"] {
        if a.render.iter().any(|x| x == f || x.starts_with(&format!("{f}="))) {
            return Err(Error::param("farm", format!("{f} is the farm's to set: give the render's other flags")).into());
        }
    }
    let dir = abs(&a.output)?;
    std::fs::create_dir_all(dir.join("parts")).map_err(|e| Error::io(&dir, e))?;
    std::fs::create_dir_all(dir.join("logs")).map_err(|e| Error::io(&dir, e))?;
    let exe = std::env::current_exe().map_err(|e| Error::io(Path::new("raysplat"), e))?.display().to_string();
    let scene = abs(&a.scene)?;
    let usd = raysplat::usd::is_usd(&scene);
    let threads = ["--threads".to_string(), a.cpus_per_task.to_string()];
    let render = |scene: &Path, extra: &[String], out: &Path| -> Vec<String> {
        let mut c = vec![exe.clone(), "render".into(), scene.display().to_string()];
        c.extend(extra.iter().cloned());
        c.extend(threads.iter().cloned());
        c.extend(["-o".into(), out.display().to_string()]);
        c
    };
    // the stage's view (camera, time code) is the conversion's; subdivision applies when rendering
    let mut stage_args = Vec::new();
    let mut flags = a.render.clone();
    for f in ["--camera", "--frame"] {
        let (v, rest) = take_flag(&flags, f);
        if let Some(v) = v {
            stage_args.extend([f.to_string(), v]);
        }
        flags = rest;
    }
    // frames: the sequence's time codes, each converted by the conversion step to a file of its own
    let (frame_spec, flags) = if a.split == "frames" { take_flag(&flags, "--frames") } else { (None, flags) };
    let frame_list = match &frame_spec {
        Some(spec) => super::frames::parse(spec)?,
        None if a.split == "frames" => return Err(Error::param("split", "--split frames needs the render's --frames FIRST:LAST[:STEP]").into()),
        None => Vec::new(),
    };
    let rss = if a.split == "frames" { dir.join("scenes").join("scene.####.rss") } else { dir.join("scene.rss") };
    let convert = usd.then(|| {
        let mut c = vec![exe.clone(), "convert".into(), scene.display().to_string(), rss.display().to_string()];
        c.extend(stage_args.iter().cloned());
        let outputs = match &frame_spec {
            Some(spec) => {
                c.extend(["--frames".into(), spec.clone()]);
                frame_list.iter().map(|&f| super::frames::name(&rss, f).expect("a # in the name")).collect()
            }
            None => vec![rss.clone()],
        };
        Step { command: c, outputs }
    });
    if convert.is_some() && frame_spec.is_some() {
        std::fs::create_dir_all(dir.join("scenes")).map_err(|e| Error::io(&dir, e))?;
    }
    if !usd && frame_spec.is_some() && super::frames::name(&scene, 0).is_none() {
        return Err(Error::param("split", format!("{}: --split frames reads a USD stage (or .rss files named with a # for the frame number)", scene.display())).into());
    }
    let task_scene = if convert.is_some() { rss.clone() } else { scene.clone() };
    let part = |i: usize| dir.join("parts").join(format!("part-{i:04}.exr"));
    let (tasks, merge) = match a.split.as_str() {
        "tiles" => {
            let tasks: Vec<Step> = (0..a.tasks as usize)
                .map(|i| Step { command: render(&task_scene, &[flags.clone(), vec!["--tile".into(), format!("{i}/{}", a.tasks)]].concat(), &part(i)), outputs: vec![part(i)] })
                .collect();
            (tasks, true)
        }
        "passes" => {
            let (p, rest) = take_flag(&flags, "--passes");
            let total: u32 = match p {
                Some(p) => p.parse().map_err(|_| Error::param("passes", format!("{p:?} is not a whole number")))?,
                None => a.tasks,
            };
            if total < a.tasks {
                return Err(Error::param("tasks", format!("{} tasks for {total} passes: at most one task per pass", a.tasks)).into());
            }
            let tasks = ranges(total as u64, a.tasks)
                .into_iter()
                .enumerate()
                .map(|(i, (f, e))| {
                    let extra = [rest.clone(), vec!["--passes".into(), total.to_string(), "--pass-range".into(), format!("{f}:{e}")]].concat();
                    Step { command: render(&task_scene, &extra, &part(i)), outputs: vec![part(i)] }
                })
                .collect();
            (tasks, true)
        }
        _ => {
            let list = frame_list;
            let step = if list.len() > 1 { list[1] - list[0] } else { 1 };
            if (list.len() as u64) < a.tasks as u64 {
                return Err(Error::param("tasks", format!("{} tasks for {} frames: at most one task per frame", a.tasks, list.len())).into());
            }
            let pattern = dir.join("frames").join("frame.####.exr");
            std::fs::create_dir_all(dir.join("frames")).map_err(|e| Error::io(&dir, e))?;
            let tasks = ranges(list.len() as u64, a.tasks)
                .into_iter()
                .map(|(f, e)| {
                    let mine = &list[f as usize..e as usize];
                    let extra = [flags.clone(), vec!["--frames".into(), format!("{}:{}:{step}", mine[0], mine[mine.len() - 1])]].concat();
                    let outputs = mine.iter().map(|&k| super::frames::name(&pattern, k).expect("a # in the name")).collect();
                    Step { command: render(&task_scene, &extra, &pattern), outputs }
                })
                .collect();
            (tasks, false)
        }
    };
    let merged = dir.join("out.exr");
    let merge = merge.then(|| {
        let mut c = vec![exe.clone(), "merge".into()];
        c.extend(tasks.iter().flat_map(|t: &Step| t.outputs.iter().map(|p| p.display().to_string())));
        c.extend(["-o".into(), merged.display().to_string()]);
        Step { command: c, outputs: vec![merged.clone()] }
    });
    // check the render flags now, on the first task's command, rather than on the farm
    super::check_render_flags(&tasks[0].command[1..])?;
    let job = Job { version: 1, split: a.split.clone(), scene, dir: dir.clone(), cpus_per_task: a.cpus_per_task, sbatch: a.sbatch.clone(), convert, tasks, merge };
    write_scripts(&job)?;
    raysplat::io::write_file(&dir.join("job.json"), raysplat::io::Format::Json, serde_json::to_string_pretty(&job)?.as_bytes())?;
    eprintln!(
        "planned {} tasks ({} split) in {}: job.json, {}tasks.sbatch{}; submit with `raysplat farm submit {}`",
        job.tasks.len(),
        job.split,
        dir.display(),
        if job.convert.is_some() { "convert.sbatch, " } else { "" },
        if job.merge.is_some() { ", merge.sbatch" } else { "" },
        dir.display()
    );
    Ok(())
}

fn header(job: &Job, name: &str, log: &str, cpus: u32) -> String {
    let mut s = format!("#!/bin/bash\n#SBATCH --job-name=raysplat-{name}\n#SBATCH --output={}\n#SBATCH --cpus-per-task={cpus}\n", job.dir.join("logs").join(log).display());
    for o in &job.sbatch {
        s.push_str(&format!("#SBATCH {o}\n"));
    }
    s.push_str("set -euo pipefail\n");
    s
}

fn write_scripts(job: &Job) -> Result<(), Error> {
    let line = |c: &[String]| c.iter().map(|a| quote(a)).collect::<Vec<_>>().join(" ");
    if let Some(c) = &job.convert {
        let s = format!("{}exec {}\n", header(job, "convert", "convert.log", 1), line(&c.command));
        raysplat::io::write_file(&job.dir.join("convert.sbatch"), raysplat::io::Format::Script, s.as_bytes())?;
    }
    let mut s = header(job, "task", "task-%a.log", job.cpus_per_task);
    s.push_str("case \"$SLURM_ARRAY_TASK_ID\" in\n");
    for (i, t) in job.tasks.iter().enumerate() {
        s.push_str(&format!("  {i}) exec {} ;;\n", line(&t.command)));
    }
    s.push_str("  *) echo \"no task $SLURM_ARRAY_TASK_ID\" >&2; exit 2 ;;\nesac\n");
    raysplat::io::write_file(&job.dir.join("tasks.sbatch"), raysplat::io::Format::Script, s.as_bytes())?;
    if let Some(m) = &job.merge {
        let s = format!("{}exec {}\n", header(job, "merge", "merge.log", 1), line(&m.command));
        raysplat::io::write_file(&job.dir.join("merge.sbatch"), raysplat::io::Format::Script, s.as_bytes())?;
    }
    Ok(())
}

fn load(dir: &Path) -> Result<Job, Error> {
    let p = dir.join("job.json");
    let text = std::fs::read_to_string(&p).map_err(|e| Error::io(&p, e))?;
    serde_json::from_str(&text).map_err(|e| Error::param("farm", format!("{}: not a job description: {e}", p.display())))
}

/// Task indices whose outputs are not all there.
fn missing(job: &Job) -> Vec<usize> {
    job.tasks.iter().enumerate().filter(|(_, t)| !t.outputs.iter().all(|o| o.exists())).map(|(i, _)| i).collect()
}

/// Run `sbatch --parsable ARGS`, returning the job id (or print it under `dry_run`).
fn sbatch(args: &[String], dry_run: bool) -> Result<String, Error> {
    if dry_run {
        println!("sbatch --parsable {}", args.join(" "));
        return Ok(format!("DRYRUN{}", args.len()));
    }
    let out = Command::new("sbatch").arg("--parsable").args(args).output().map_err(|e| Error::io(Path::new("sbatch"), e))?;
    if !out.status.success() {
        return Err(Error::param("farm", format!("sbatch {}: {}", args.join(" "), String::from_utf8_lossy(&out.stderr).trim())));
    }
    let id = String::from_utf8_lossy(&out.stdout).trim().split(';').next().unwrap_or("").to_string();
    if id.is_empty() {
        return Err(Error::param("farm", "sbatch printed no job id".to_string()));
    }
    Ok(id)
}

fn submit(dir: &Path, dry_run: bool) -> anyhow::Result<()> {
    let job = load(dir)?;
    let todo = missing(&job);
    let merged = job.merge.as_ref().is_some_and(|m| m.outputs.iter().all(|o| o.exists()));
    let sub_path = job.dir.join("submitted.json");
    let mut sub: Submitted = std::fs::read_to_string(&sub_path).ok().and_then(|t| serde_json::from_str(&t).ok()).unwrap_or_default();
    if todo.is_empty() && (merged || job.merge.is_none()) {
        eprintln!("nothing to submit: all {} parts{} are there", job.tasks.len(), if job.merge.is_some() { " and the merge" } else { "" });
        return Ok(());
    }
    // a merge queued by an earlier submission waits on tasks that failed: it is replaced
    if let Some(old) = sub.merge_job.take() {
        if !dry_run {
            let _ = Command::new("scancel").arg(&old).status();
        }
    }
    let dep = |id: &str| format!("--dependency=afterok:{id}");
    let script = |n: &str| job.dir.join(n).display().to_string();
    let mut after = None;
    if let Some(c) = &job.convert {
        if !c.outputs.iter().all(|o| o.exists()) && !todo.is_empty() {
            let id = sbatch(&[script("convert.sbatch")], dry_run)?;
            sub.jobs.push(id.clone());
            after = Some(id);
        }
    }
    if !todo.is_empty() {
        let list = todo.iter().map(|i| i.to_string()).collect::<Vec<_>>().join(",");
        let mut args = vec![format!("--array={list}")];
        args.extend(after.as_deref().map(dep));
        args.push(script("tasks.sbatch"));
        let id = sbatch(&args, dry_run)?;
        sub.jobs.push(id.clone());
        after = Some(id);
    }
    if job.merge.is_some() {
        let mut args: Vec<String> = after.as_deref().map(dep).into_iter().collect();
        args.push(script("merge.sbatch"));
        let id = sbatch(&args, dry_run)?;
        sub.jobs.push(id.clone());
        sub.merge_job = Some(id);
    }
    if sub.first_unix == 0.0 {
        sub.first_unix = now();
    }
    if !dry_run {
        raysplat::io::write_file(&sub_path, raysplat::io::Format::Json, serde_json::to_string_pretty(&sub)?.as_bytes())?;
    }
    eprintln!("submitted {} of {} tasks{}: jobs {}", todo.len(), job.tasks.len(), if job.merge.is_some() { " and the merge" } else { "" }, sub.jobs.join(", "));
    Ok(())
}

fn now() -> f64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_secs_f64()).unwrap_or(0.0)
}

#[derive(Serialize)]
struct Status {
    parts_done: usize,
    parts: usize,
    merged: Option<bool>,
    /// Seconds left at the rate parts have been written since the first submission.
    eta_seconds: Option<f64>,
    /// Slurm's word on the jobs submitted: `job id → state`.
    slurm: Vec<(String, String)>,
}

fn status(dir: &Path, json: bool) -> anyhow::Result<()> {
    let job = load(dir)?;
    let parts = job.tasks.len();
    let done = parts - missing(&job).len();
    let merged = job.merge.as_ref().map(|m| m.outputs.iter().all(|o| o.exists()));
    let sub: Submitted = std::fs::read_to_string(job.dir.join("submitted.json")).ok().and_then(|t| serde_json::from_str(&t).ok()).unwrap_or_default();
    let elapsed = now() - sub.first_unix;
    let eta_seconds = (sub.first_unix > 0.0 && done > 0 && done < parts).then(|| elapsed / done as f64 * (parts - done) as f64);
    let slurm = if sub.jobs.is_empty() { Vec::new() } else { slurm_states(&sub.jobs) };
    let st = Status { parts_done: done, parts, merged, eta_seconds, slurm };
    if json {
        println!("{}", serde_json::to_string(&st)?);
        return Ok(());
    }
    println!(
        "parts {done} of {parts} done{}{}",
        match merged {
            Some(true) => ", merged",
            Some(false) => ", not merged yet",
            None => "",
        },
        st.eta_seconds.map_or(String::new(), |e| format!(", about {e:.0} s left at the rate so far"))
    );
    for (id, state) in &st.slurm {
        println!("  job {id}: {state}");
    }
    Ok(())
}

/// States of `jobs` (and their array tasks) from `sacct`, else `squeue`; empty when neither answers.
fn slurm_states(jobs: &[String]) -> Vec<(String, String)> {
    let list = jobs.join(",");
    let parse = |out: std::process::Output| -> Vec<(String, String)> {
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter_map(|l| l.split_once('|').map(|(a, b)| (a.trim().to_string(), b.trim().to_string())))
            .filter(|(a, _)| !a.contains('.'))
            .collect()
    };
    if let Ok(out) = Command::new("sacct").args(["-n", "-P", "-X", "-o", "JobID,State", "-j", &list]).output() {
        let v = parse(out);
        if !v.is_empty() {
            return v;
        }
    }
    match Command::new("squeue").args(["-h", "-r", "-o", "%i|%T", "-j", &list]).output() {
        Ok(out) => parse(out),
        Err(_) => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_split_evenly_and_cover() {
        assert_eq!(ranges(10, 4), vec![(0, 2), (2, 5), (5, 7), (7, 10)]);
        assert_eq!(ranges(4, 4), vec![(0, 1), (1, 2), (2, 3), (3, 4)]);
    }

    #[test]
    fn take_flag_takes_both_forms() {
        let a: Vec<String> = ["--spp", "4", "--passes=8", "--method", "rs"].iter().map(|s| s.to_string()).collect();
        let (v, rest) = take_flag(&a, "--passes");
        assert_eq!(v.as_deref(), Some("8"));
        assert_eq!(rest, ["--spp", "4", "--method", "rs"]);
    }
}
