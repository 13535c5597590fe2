//! Running the `raysplat` binary as a hostile user would, with guards: a time limit (a hang guard,
//! not a speed assertion: the process group is killed after it), its peak memory (from
//! `/usr/bin/time` when installed), and digests of directories before and after, so a test sees
//! any file left, changed or removed.
#![allow(dead_code)]

use sha2::{Digest, Sha256};
use std::collections::BTreeMap;
use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// How one run ended.
#[derive(Debug)]
pub struct Outcome {
    /// Exit code, `None` when the process died of a signal (see `signal`).
    pub code: Option<i32>,
    pub signal: Option<i32>,
    pub stdout: String,
    pub stderr: String,
    /// Killed by the hang guard.
    pub timed_out: bool,
    pub seconds: f64,
    /// Peak resident memory of the largest process of the run (the binary or its converter), in
    /// KiB, when `/usr/bin/time` is installed.
    pub max_rss_kib: Option<u64>,
}

impl Outcome {
    /// The failures a hostile input must never cause: a panic, a signal death, a hang, a Python
    /// traceback, an abort message.
    pub fn misbehaviour(&self) -> Option<String> {
        if self.timed_out {
            return Some(format!("hang: killed after {:.0} s", self.seconds));
        }
        if let Some(s) = self.signal {
            return Some(format!("died of signal {s}"));
        }
        for bad in ["panicked", "Traceback", "memory allocation of", "RUST_BACKTRACE", "Segmentation", "core dumped"] {
            if self.stderr.contains(bad) || self.stdout.contains(bad) {
                return Some(format!("{bad:?} in the output"));
            }
        }
        None
    }
}

pub fn bin_path() -> &'static str {
    env!("CARGO_BIN_EXE_raysplat")
}

/// Whether `/usr/bin/time` can report the peak memory.
pub fn time_available() -> bool {
    Path::new("/usr/bin/time").exists()
}

/// Run `cmd` (in a process group of its own) for at most `limit`; the group is killed after it.
/// The run's peak memory is measured when `/usr/bin/time` exists (`measure`).
pub fn run(mut cmd: Command, limit: Duration, measure: bool) -> Outcome {
    let tmp = tempfile::tempdir().expect("a temporary directory for the run's output");
    let (out, err, rss) = (tmp.path().join("out"), tmp.path().join("err"), tmp.path().join("rss"));
    if measure && time_available() {
        let mut timed = Command::new("/usr/bin/time");
        timed.arg("-f").arg("%M").arg("-o").arg(&rss).arg(cmd.get_program()).args(cmd.get_args());
        for (k, v) in cmd.get_envs() {
            match v {
                Some(v) => timed.env(k, v),
                None => timed.env_remove(k),
            };
        }
        if let Some(d) = cmd.get_current_dir() {
            timed.current_dir(d);
        }
        cmd = timed;
    }
    cmd.stdin(Stdio::null())
        .stdout(std::fs::File::create(&out).unwrap())
        .stderr(std::fs::File::create(&err).unwrap())
        .process_group(0);
    let t0 = Instant::now();
    let mut child = cmd.spawn().expect("spawn");
    let mut timed_out = false;
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait") {
            break s;
        }
        if t0.elapsed() > limit {
            timed_out = true;
            kill_group(child.id(), "KILL");
            break child.wait().expect("wait");
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let read = |p: &Path| String::from_utf8_lossy(&std::fs::read(p).unwrap_or_default()).into_owned();
    let stderr = read(&err);
    // /usr/bin/time reports a signal death of its child as "Command terminated by signal N"
    let mut signal = status.signal();
    let mut code = status.code();
    if let Some(n) = stderr.lines().rev().find_map(|l| l.strip_prefix("Command terminated by signal ")) {
        signal = n.trim().parse().ok();
        code = None;
    }
    let max_rss_kib = read(&rss).lines().rev().find_map(|l| l.trim().parse().ok());
    Outcome { code, signal, stdout: read(&out), stderr, timed_out, seconds: t0.elapsed().as_secs_f64(), max_rss_kib }
}

/// Send `SIGNAME` to the process group `pgid` (the `kill` command: the tests hold no `unsafe`).
pub fn kill_group(pgid: u32, signal: &str) {
    let _ = Command::new("kill").arg(format!("-{signal}")).arg("--").arg(format!("-{pgid}")).status();
}

/// Send `SIGNAME` to the process `pid`.
pub fn kill(pid: u32, signal: &str) {
    let _ = Command::new("kill").arg(format!("-{signal}")).arg(pid.to_string()).status();
}

/// A directory's content: each entry (not following links) by relative path, with its kind and,
/// for files, a SHA-256 of the content.
pub type Listing = BTreeMap<PathBuf, String>;

pub fn digest(dir: &Path) -> Listing {
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

fn walk(root: &Path, dir: &Path, out: &mut Listing) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let p = e.path();
        let rel = p.strip_prefix(root).unwrap().to_path_buf();
        let Ok(m) = std::fs::symlink_metadata(&p) else { continue };
        let t = m.file_type();
        let what = if t.is_symlink() {
            format!("link -> {}", std::fs::read_link(&p).map(|l| l.display().to_string()).unwrap_or_default())
        } else if t.is_dir() {
            walk(root, &p, out);
            "dir".to_string()
        } else if t.is_file() {
            let bytes = std::fs::read(&p).unwrap_or_default();
            format!("file {:x}", Sha256::digest(&bytes))
        } else {
            use std::os::unix::fs::FileTypeExt;
            if t.is_fifo() { "fifo" } else if t.is_socket() { "socket" } else { "device" }.to_string()
        };
        out.insert(rel, what);
    }
}

/// What changed between two digests, one line per entry (empty: nothing).
pub fn changes(before: &Listing, after: &Listing) -> Vec<String> {
    let mut out = Vec::new();
    for (p, w) in after {
        match before.get(p) {
            None => out.push(format!("left behind: {}", p.display())),
            Some(b) if b != w => out.push(format!("changed: {} ({b} -> {w})", p.display())),
            _ => {}
        }
    }
    for p in before.keys().filter(|p| !after.contains_key(*p)) {
        out.push(format!("removed: {}", p.display()));
    }
    out
}

/// The processes whose parent is `pid` (Linux `/proc`).
pub fn children_of(pid: u32) -> Vec<u32> {
    let mut out = Vec::new();
    for e in std::fs::read_dir("/proc").into_iter().flatten().flatten() {
        let Some(p) = e.file_name().to_str().and_then(|s| s.parse::<u32>().ok()) else { continue };
        let Ok(stat) = std::fs::read_to_string(format!("/proc/{p}/stat")) else { continue };
        let Some(rest) = stat.rfind(')').map(|i| &stat[i + 1..]) else { continue };
        if rest.split_whitespace().nth(1).and_then(|s| s.parse::<u32>().ok()) == Some(pid) {
            out.push(p);
        }
    }
    out
}

/// Whether process `pid` still runs (a zombie counts as ended).
pub fn alive(pid: u32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Ok(stat) => stat.rfind(')').and_then(|i| stat[i + 1..].split_whitespace().next()) != Some("Z"),
        Err(_) => false,
    }
}

/// Poll `cond` every 5 ms for at most `limit`; whether it became true.
pub fn wait_for(limit: Duration, mut cond: impl FnMut() -> bool) -> bool {
    let t0 = Instant::now();
    while t0.elapsed() < limit {
        if cond() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    cond()
}
