//! Render statistics (phase times, counts, what was enabled) and progress reporting.

use crate::prepare::Requirements;
use serde::Serialize;
use std::fmt::Write;

/// Receives progress and may cancel. Implementations must be cheap: `advance` is called per tile.
pub trait Progress: Sync {
    /// A stage starts with `total` units of work.
    fn begin(&self, stage: &str, total: u64);
    fn advance(&self, n: u64);
    /// Polled between tiles: returning true stops the render with `Error::Cancelled`.
    fn cancelled(&self) -> bool {
        false
    }
    fn finish(&self) {}
}

/// Progress that reports nothing and never cancels.
pub struct SilentProgress;

impl Progress for SilentProgress {
    fn begin(&self, _: &str, _: u64) {}
    fn advance(&self, _: u64) {}
}

/// Statistics of one render.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Stats {
    /// (phase, seconds) in execution order.
    pub phases: Vec<(String, f64)>,
    /// (counter, value): rays, samples, photons, …
    pub counters: Vec<(String, u64)>,
    /// What was built for this scene and method, with its memory in bytes.
    pub enabled: Vec<(String, u64)>,
    /// Decisions the method took by itself and why, and warnings about them (one line each).
    pub notes: Vec<String>,
    pub total_seconds: f64,
    /// Warnings of the scene, the loader's and the preparation's (all counted).
    pub warnings: usize,
    /// The warnings the preparation added to the loader's (textures, lights, materials), as
    /// `prim: message`: the render reports them, since nothing else has.
    pub prepare_warnings: Vec<String>,
    pub scene: String,
    /// Peak resident set size of the process when the render ended (Linux `VmHWM`; 0 elsewhere).
    pub peak_rss_bytes: u64,
}

/// The `kB` field `field` (e.g. `VmHWM:`) of a `/proc` text such as `/proc/self/status` or
/// `/proc/meminfo`, in bytes.
fn proc_kb_field(text: &str, field: &str) -> Option<u64> {
    text.lines().find_map(|l| l.strip_prefix(field)?.split_whitespace().next()?.parse::<u64>().ok()).map(|kb| kb * 1024)
}

/// A `kB` field of `/proc/self/status` in bytes (0 where unknown).
fn proc_status_bytes(field: &str) -> u64 {
    std::fs::read_to_string("/proc/self/status").ok().and_then(|s| proc_kb_field(&s, field)).unwrap_or(0)
}

/// Peak resident set size of this process (since start or the last [`reset_peak_rss`]), in bytes.
pub fn peak_rss() -> u64 {
    proc_status_bytes("VmHWM:")
}

/// Current resident set size of this process, in bytes.
pub fn current_rss() -> u64 {
    proc_status_bytes("VmRSS:")
}

/// CPU time (user + system) of this process so far, all threads, in seconds (Linux
/// `/proc/self/stat`, clock ticks of 1/100 s; 0 elsewhere). Unlike wall time, it does not grow when
/// other processes take the cores.
pub fn process_cpu_seconds() -> f64 {
    std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| {
            // Fields after the command name (which is in parentheses and may hold spaces).
            let rest = &s[s.rfind(')')? + 1..];
            let f: Vec<&str> = rest.split_whitespace().collect();
            // utime and stime are fields 14 and 15 of the whole line: 12 and 13 after the name.
            Some((f.get(11)?.parse::<u64>().ok()? + f.get(12)?.parse::<u64>().ok()?) as f64 / 100.0)
        })
        .unwrap_or(0.0)
}

/// Reset the peak resident set size to the current one (Linux ≥ 4.0; ignored elsewhere).
pub fn reset_peak_rss() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

impl Stats {
    pub fn phase(&mut self, name: &str, seconds: f64) {
        self.phases.push((name.to_string(), seconds));
    }
    pub fn count(&mut self, name: &str, value: u64) {
        self.counters.push((name.to_string(), value));
    }
    pub fn enable(&mut self, what: &str, bytes: u64) {
        self.enabled.push((what.to_string(), bytes));
    }
    /// A decision taken by the method and why (printed as `note: …`).
    pub fn note(&mut self, line: String) {
        self.notes.push(line);
    }

    pub(crate) fn note_requirements(&mut self, r: &Requirements) {
        let mut s = String::new();
        let _ = write!(
            s,
            "{} triangles{} in {} instances, {} lights + {} emissive triangles; surfaces:{}{}{}{}",
            r.triangles,
            if r.subdivision_faces > 0 { format!(" + {} subdivision faces (~{:.0} quads)", r.subdivision_faces, r.subdivision_quads) } else { String::new() },
            r.instances,
            r.lights,
            r.emissive_triangles,
            if r.has_diffuse() { " diffuse" } else { "" },
            if r.has_glossy() { " glossy" } else { "" },
            if r.has_specular() { " specular" } else { "" },
            if r.cutouts { " (cut-outs)" } else { "" },
        );
        self.scene = s;
    }

    /// Human-readable summary (several lines).
    pub fn summary(&self) -> String {
        let mut s = String::new();
        if !self.scene.is_empty() {
            let _ = writeln!(s, "scene: {}", self.scene);
        }
        for w in &self.prepare_warnings {
            let _ = writeln!(s, "warning: {w}");
        }
        if !self.enabled.is_empty() {
            let parts: Vec<String> =
                self.enabled.iter().map(|(n, b)| format!("{n} ({})", human_bytes(*b))).collect();
            let _ = writeln!(s, "enabled: {}", parts.join(", "));
        }
        for n in &self.notes {
            let _ = writeln!(s, "note: {n}");
        }
        let phases: Vec<String> = self.phases.iter().map(|(n, t)| format!("{n} {t:.3}s")).collect();
        let _ = writeln!(s, "time: {:.3}s total ({})", self.total_seconds, phases.join(", "));
        if self.peak_rss_bytes > 0 {
            let _ = writeln!(s, "peak resident memory: {}", human_bytes(self.peak_rss_bytes));
        }
        if !self.counters.is_empty() {
            let c: Vec<String> = self.counters.iter().map(|(n, v)| format!("{n} {v}")).collect();
            let _ = writeln!(s, "counts: {}", c.join(", "));
        }
        s
    }

    pub fn counter(&self, name: &str) -> Option<u64> {
        self.counters.iter().find(|(n, _)| n == name).map(|(_, v)| *v)
    }
    pub fn phase_seconds(&self, name: &str) -> Option<f64> {
        self.phases.iter().find(|(n, _)| n == name).map(|(_, v)| *v)
    }
}

pub use crate::memory::human_bytes;
