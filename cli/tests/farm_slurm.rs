//! `raysplat farm` on a real Slurm: munged, slurmctld and slurmd started on this machine in a
//! temporary folder (`scripts/slurm-cluster.sh`, one node of 2 CPUs), 4-task jobs of each split on
//! the repository's Cornell box at 32×32, each merged result checked against the one-machine
//! render, and a task killed mid-run then re-submitted. A cluster that cannot start fails the
//! test. Cost: 32-70 s on 2 loaded cores (the daemons start in under a second; ~20 small renders
//! and 6 conversions).

use raysplat::image::{read_exr, Film};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn repo(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(p)
}

/// The cluster, stopped when dropped (also when a check fails).
struct Cluster {
    dir: tempfile::TempDir,
    conf: String,
}

impl Cluster {
    fn start() -> Cluster {
        let dir = tempfile::tempdir().unwrap();
        // a port of this process's own, so that clusters of concurrent test runs do not meet
        let port = 20000 + (std::process::id() % 20000) * 2;
        let o = Command::new(repo("scripts/slurm-cluster.sh")).arg("start").arg(dir.path()).env("SLURM_TEST_PORT", port.to_string()).output().expect("run scripts/slurm-cluster.sh");
        assert!(o.status.success(), "could not start Slurm (munged, slurmctld, slurmd): {}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
        let conf = String::from_utf8_lossy(&o.stdout).trim().to_string();
        Cluster { dir, conf }
    }

    fn cmd(&self, program: &str) -> Command {
        let mut c = Command::new(program);
        c.env("SLURM_CONF", &self.conf).env("RAYSPLAT_CACHE_DIR", Path::new(env!("CARGO_TARGET_TMPDIR")).join("convert-cache"));
        c
    }

    fn raysplat(&self, args: &[&str]) -> Output {
        let o = self.cmd(env!("CARGO_BIN_EXE_raysplat")).args(args).output().expect("run raysplat");
        assert!(o.status.success(), "raysplat {args:?}: {}", String::from_utf8_lossy(&o.stderr));
        o
    }

    /// Plan a 4-task job of `split` with `flags` into `job` and submit it.
    fn submit(&self, job: &Path, split: &str, flags: &[&str]) {
        let scene = repo("scenes/cornell-box.usda");
        let mut args = vec!["farm", "plan", scene.to_str().unwrap(), "--split", split, "--tasks", "4", "-o", job.to_str().unwrap(), "--"];
        args.extend_from_slice(flags);
        self.raysplat(&args);
        self.raysplat(&["farm", "submit", job.to_str().unwrap()]);
    }

    /// `farm status --json` of `job`.
    fn status(&self, job: &Path) -> serde_json::Value {
        let o = self.raysplat(&["farm", "status", job.to_str().unwrap(), "--json"]);
        serde_json::from_slice(&o.stdout).expect("status JSON")
    }

    /// Wait until Slurm has no job left but those waiting on a dependency that can never be met.
    fn wait_idle(&self) {
        let t = Instant::now();
        loop {
            let o = self.cmd("squeue").args(["-h", "-o", "%T %r"]).output().unwrap();
            let text = String::from_utf8_lossy(&o.stdout).to_string();
            if text.lines().all(|l| l.contains("DependencyNeverSatisfied")) {
                return;
            }
            assert!(t.elapsed() < Duration::from_secs(300), "Slurm jobs still queued after 300 s:\n{text}");
            std::thread::sleep(Duration::from_millis(200));
        }
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new(repo("scripts/slurm-cluster.sh")).arg("stop").arg(self.dir.path()).status();
    }
}

const FLAGS: [&str; 6] = ["--resolution", "32x32", "--photons", "5000", "--seed", "5"];

/// The one-machine render of the Cornell box with `flags` (the stage read directly).
fn one_machine(c: &Cluster, flags: &[&str], out: &Path) -> Film {
    let scene = repo("scenes/cornell-box.usda");
    let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap()];
    args.extend_from_slice(flags);
    c.raysplat(&args);
    read_exr(out).unwrap()
}

fn identical(a: &Film, b: &Film) -> bool {
    (a.width, a.height) == (b.width, b.height) && a.layers.len() == b.layers.len() && a.layers.iter().zip(&b.layers).all(|(x, y)| x.name == y.name && x.data.iter().zip(&y.data).all(|(p, q)| p.to_bits() == q.to_bits()))
}

#[test]
fn farm_jobs_on_slurm_merge_into_the_one_machine_render() {
    let c = Cluster::start();
    let work = tempfile::tempdir().unwrap();
    let w = |n: &str| work.path().join(n);
    let flags = |extra: &[&'static str]| -> Vec<&'static str> { FLAGS.iter().copied().chain(extra.iter().copied()).collect() };

    // tiles (pm: same photons on every task) and passes (pt: sample ranges) and frames, queued together
    let tiles = flags(&["--method", "pm", "--spp", "2"]);
    let passes = flags(&["--method", "pt", "--spp", "2", "--passes", "4"]);
    let frames = flags(&["--method", "pt", "--spp", "2", "--frames", "1:4"]);
    c.submit(&w("tiles"), "tiles", &tiles);
    c.submit(&w("passes"), "passes", &passes);
    c.submit(&w("frames"), "frames", &frames);
    c.wait_idle();
    for job in ["tiles", "passes", "frames"] {
        let s = c.status(&w(job));
        assert_eq!((s["parts_done"].as_u64(), s["parts"].as_u64()), (Some(4), Some(4)), "{job}: {s}");
    }
    let whole = one_machine(&c, &tiles, &w("tiles.exr"));
    assert!(identical(&read_exr(&w("tiles/out.exr")).unwrap(), &whole), "tiles merged differ from the one-machine render");

    // the path tracer's 4 passes of 2 samples = 8 samples per pixel, to float rounding (the
    // parts hold means; the normal layer averages unit normals)
    let mut merged = read_exr(&w("passes/out.exr")).unwrap();
    let mut eight = one_machine(&c, &flags(&["--method", "pt", "--spp", "8"]), &w("eight.exr"));
    merged.layers.retain(|l| l.name != "normal");
    eight.layers.retain(|l| l.name != "normal");
    for (a, b) in merged.layers.iter().zip(&eight.layers) {
        for (x, y) in a.data.iter().zip(&b.data) {
            assert!((x - y).abs() <= 1e-5 * x.abs().max(y.abs()).max(1e-3), "layer {:?}: {x} vs {y}", a.name);
        }
    }

    // frames: the files of the one-machine --frames render
    let scene = repo("scenes/cornell-box.usda");
    let seq = w("seq.####.exr");
    let mut args = vec!["render", scene.to_str().unwrap(), "-o", seq.to_str().unwrap()];
    args.extend_from_slice(&frames);
    c.raysplat(&args);
    for f in 1..=4 {
        let (a, b) = (read_exr(&w(&format!("frames/frames/frame.{f:04}.exr"))).unwrap(), read_exr(&w(&format!("seq.{f:04}.exr"))).unwrap());
        assert!(identical(&a, &b), "frame {f} differs");
    }
    // the stage was converted once, by the first step, to a file per frame that the tasks read
    let job: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(w("frames/job.json")).unwrap()).unwrap();
    let rss: Vec<PathBuf> = (1..=4).map(|f| w(&format!("frames/scenes/scene.{f:04}.rss"))).collect();
    let outputs: Vec<PathBuf> = job["convert"]["outputs"].as_array().expect("a conversion step").iter().map(|o| PathBuf::from(o.as_str().unwrap())).collect();
    assert_eq!(outputs, rss);
    assert!(rss.iter().all(|p| p.exists()), "the per-frame scenes are there");
    assert_eq!(std::fs::read_to_string(w("frames/logs/convert.log")).unwrap().matches("converted ").count(), 4, "one conversion step converts the 4 frames");
    for t in job["tasks"].as_array().unwrap() {
        assert_eq!(t["command"][2].as_str(), w("frames/scenes/scene.####.rss").to_str(), "a task reads the converted frames: {t}");
    }

    // a task killed mid-run (4096 samples per pixel keep each task running for a second or more,
    // time to see it running and kill it): its part is not written (parts are written atomically), the merge
    // waits forever on it; submitted again, only that task runs, and the merge is the same image.
    // The kill races the task's end on a loaded machine: when the victim's part is there all the
    // same, the kill came after its last write and shows nothing, so the job is planned again.
    let slow = flags(&["--method", "pt", "--spp", "4096"]);
    let killed = (0..3)
        .find_map(|attempt| {
            let dir = w(&format!("killed-{attempt}"));
            c.submit(&dir, "tiles", &slow);
            let sub: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join("submitted.json")).unwrap()).unwrap();
            let array = sub["jobs"][1].as_str().unwrap().to_string();
            let t = Instant::now();
            let victim = loop {
                let o = c.cmd("squeue").args(["-h", "-r", "-t", "RUNNING", "-o", "%i", "-j", &array]).output().unwrap();
                if let Some(id) = String::from_utf8_lossy(&o.stdout).lines().next().map(str::to_string) {
                    break id;
                }
                assert!(t.elapsed() < Duration::from_secs(120), "no task of job {array} ran within 120 s");
                std::thread::sleep(Duration::from_millis(20));
            };
            // scancel fails on a task that has ended, which the part below tells apart
            let o = c.cmd("scancel").args(["-s", "KILL", &victim]).output().unwrap();
            c.wait_idle();
            let job: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join("job.json")).unwrap()).unwrap();
            let index: usize = victim.rsplit('_').next().unwrap().parse().unwrap();
            let part = PathBuf::from(job["tasks"][index]["outputs"][0].as_str().unwrap());
            if part.exists() {
                eprintln!("attempt {attempt}: {victim} wrote {} before the kill reached it; planning again", part.display());
                return None;
            }
            assert!(o.status.success(), "scancel {victim}: {}", String::from_utf8_lossy(&o.stderr));
            let s = c.status(&dir);
            assert_eq!(s["parts_done"].as_u64(), Some(3), "{victim} was killed: {s}");
            assert_eq!(s["merged"].as_bool(), Some(false));
            Some(dir)
        })
        .expect("in 3 attempts the kill never reached a task before it wrote its part");
    c.raysplat(&["farm", "submit", killed.to_str().unwrap()]);
    c.wait_idle();
    let s = c.status(&killed);
    assert_eq!((s["parts_done"].as_u64(), s["merged"].as_bool()), (Some(4), Some(true)), "{s}");
    let whole = one_machine(&c, &slow, &w("slow.exr"));
    assert!(identical(&read_exr(&killed.join("out.exr")).unwrap(), &whole), "the re-submitted job's merge differs from the one-machine render");
}
