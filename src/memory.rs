//! How much memory this process may still take, and allocations that report running out as an
//! error instead of aborting.
//!
//! The budget ([`available`]) is the smallest of: the machine's `MemAvailable` plus free swap; the
//! room left under the process's address-space and data-segment limits (`RLIMIT_AS`, `ulimit -v`,
//! against `VmSize`; `RLIMIT_DATA`, `ulimit -d`, against `VmData`), read from `/proc/self/limits`;
//! and the room left in its control group (cgroup v2 `memory.max` − `memory.current`, v1
//! `memory.limit_in_bytes` − `memory.usage_in_bytes`, reclaimable page cache counted as free), at
//! every level from its own group up to the root. Where nothing is known (no `/proc`), `None`.
//!
//! Large buffers (film, eye samples, photons, kd-trees, textures, files read whole) are allocated
//! through [`try_vec`] and friends: a failed allocation becomes [`Error::OutOfMemory`] naming what
//! was being allocated, so the CLI exits with status 2 and the C++ API throws.

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// One bound on the memory left, and what imposes it (for messages).
#[derive(Clone, Debug, PartialEq)]
pub struct Bound {
    pub bytes: u64,
    pub what: &'static str,
}

/// The memory this process may still allocate: the tightest [`bounds`], if any is known.
pub fn available() -> Option<Bound> {
    bounds().into_iter().min_by_key(|b| b.bytes)
}

/// Every bound known on this machine (see the module docs).
pub fn bounds() -> Vec<Bound> {
    let read = |p: &str| std::fs::read_to_string(p).ok();
    let mut out = Vec::new();
    if let Some(b) = read("/proc/meminfo").and_then(|m| machine_available(&m)) {
        out.push(Bound { bytes: b, what: "available on the machine" });
    }
    if let (Some(limits), Some(status)) = (read("/proc/self/limits"), read("/proc/self/status")) {
        out.extend(rlimit_bounds(&limits, &status));
    }
    if let Some(cg) = read("/proc/self/cgroup") {
        out.extend(cgroup_bounds(&cg, Path::new("/sys/fs/cgroup")));
    }
    out
}

/// The `kB` field `field` (e.g. `MemAvailable:`) of a `/proc` text, in bytes.
fn kb_field(text: &str, field: &str) -> Option<u64> {
    text.lines().find_map(|l| l.strip_prefix(field)?.split_whitespace().next()?.parse::<u64>().ok()).map(|kb| kb * 1024)
}

/// `MemAvailable` plus `SwapFree` of `/proc/meminfo`.
fn machine_available(meminfo: &str) -> Option<u64> {
    Some(kb_field(meminfo, "MemAvailable:")? + kb_field(meminfo, "SwapFree:").unwrap_or(0))
}

/// The soft limit of a row of `/proc/self/limits` (`None`: unlimited or absent).
fn soft_limit(limits: &str, row: &str) -> Option<u64> {
    let rest = limits.lines().find_map(|l| l.strip_prefix(row))?;
    rest.split_whitespace().next()?.parse().ok()
}

/// The room under `RLIMIT_AS` (against `VmSize`) and `RLIMIT_DATA` (against `VmData`).
fn rlimit_bounds(limits: &str, status: &str) -> Vec<Bound> {
    let mut out = Vec::new();
    for (row, used, what) in [
        ("Max address space", "VmSize:", "under the address-space limit (ulimit -v)"),
        ("Max data size", "VmData:", "under the data-segment limit (ulimit -d)"),
    ] {
        if let Some(limit) = soft_limit(limits, row) {
            let used = kb_field(status, used).unwrap_or(0);
            out.push(Bound { bytes: limit.saturating_sub(used), what });
        }
    }
    out
}

/// Values at or above this are "no limit" (cgroup v1 writes 2^63 rounded down to a page).
const UNLIMITED: u64 = 1 << 62;

fn read_u64(p: &Path) -> Option<u64> {
    std::fs::read_to_string(p).ok()?.trim().parse().ok()
}

/// A field of a cgroup `memory.stat` file.
fn stat_field(dir: &Path, field: &str) -> Option<u64> {
    let text = std::fs::read_to_string(dir.join("memory.stat")).ok()?;
    text.lines().find_map(|l| l.strip_prefix(field)?.strip_prefix(' ')?.trim().parse().ok())
}

/// The room left in the memory control groups of this process (`cgroup`: the text of
/// `/proc/self/cgroup`; `root`: where the hierarchy is mounted), each level from the process's
/// group up to the root. A group path not found under `root` (a container's own namespace) is
/// looked up from `root` itself.
fn cgroup_bounds(cgroup: &str, root: &Path) -> Vec<Bound> {
    let mut out = Vec::new();
    for line in cgroup.lines() {
        let mut parts = line.splitn(3, ':');
        let (Some(_), Some(controllers), Some(path)) = (parts.next(), parts.next(), parts.next()) else { continue };
        let v2 = controllers.is_empty();
        if !v2 && !controllers.split(',').any(|c| c == "memory") {
            continue;
        }
        let base = if v2 { root.to_path_buf() } else { root.join("memory") };
        let (limit_file, usage_file, cache_field, what) = if v2 {
            ("memory.max", "memory.current", "inactive_file", "left in the control group (cgroup v2 memory.max)")
        } else {
            ("memory.limit_in_bytes", "memory.usage_in_bytes", "total_inactive_file", "left in the control group (cgroup v1 memory.limit_in_bytes)")
        };
        let mut dir: PathBuf = base.join(path.trim_start_matches('/'));
        if !dir.is_dir() {
            dir = base.clone();
        }
        loop {
            if let (Some(limit), Some(usage)) = (read_u64(&dir.join(limit_file)), read_u64(&dir.join(usage_file))) {
                if limit < UNLIMITED {
                    let reclaimable = stat_field(&dir, cache_field).unwrap_or(0);
                    out.push(Bound { bytes: limit.saturating_sub(usage.saturating_sub(reclaimable)), what });
                }
            }
            if dir == base || !dir.pop() || !dir.starts_with(&base) {
                break;
            }
        }
    }
    out
}

/// Bytes as B, KiB, MiB or GiB, for messages.
pub fn human_bytes(b: u64) -> String {
    const K: f64 = 1024.0;
    let f = b as f64;
    if f >= K * K * K {
        format!("{:.2} GiB", f / (K * K * K))
    } else if f >= K * K {
        format!("{:.1} MiB", f / (K * K))
    } else if f >= K {
        format!("{:.1} KiB", f / K)
    } else {
        format!("{b} B")
    }
}

fn out_of_memory(what: String, bytes: u64) -> Error {
    let left = available().map_or(String::new(), |b| format!(" ({} {})", human_bytes(b.bytes), b.what));
    Error::OutOfMemory(format!("{what} needs {}, which could not be allocated{left}", human_bytes(bytes)))
}

/// An empty vector with room for `n` elements, or [`Error::OutOfMemory`] naming `what()`.
pub fn try_vec_with_capacity<T>(n: usize, what: impl FnOnce() -> String) -> Result<Vec<T>> {
    let mut v = Vec::new();
    try_reserve(&mut v, n, what)?;
    Ok(v)
}

/// `n` copies of `value`, or [`Error::OutOfMemory`] naming `what()`.
pub fn try_vec<T: Clone>(n: usize, value: T, what: impl FnOnce() -> String) -> Result<Vec<T>> {
    let mut v = try_vec_with_capacity(n, what)?;
    v.resize(n, value);
    Ok(v)
}

/// The items of an exact-size iterator in a vector allocated fallibly, or [`Error::OutOfMemory`]
/// naming `what()`.
pub fn try_collect<T>(items: impl ExactSizeIterator<Item = T>, what: impl FnOnce() -> String) -> Result<Vec<T>> {
    let mut v = try_vec_with_capacity(items.len(), what)?;
    v.extend(items);
    Ok(v)
}

/// Room for `additional` more elements in `v`, or [`Error::OutOfMemory`] naming `what()`.
pub fn try_reserve<T>(v: &mut Vec<T>, additional: usize, what: impl FnOnce() -> String) -> Result<()> {
    v.try_reserve_exact(additional).map_err(|_| {
        let bytes = (additional as u128 * std::mem::size_of::<T>() as u128).min(u64::MAX as u128) as u64;
        out_of_memory(what(), bytes)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIMITS: &str = "Limit                     Soft Limit           Hard Limit           Units     \n\
        Max cpu time              unlimited            unlimited            seconds   \n\
        Max data size             unlimited            unlimited            bytes     \n\
        Max address space         3072000000           unlimited            bytes     \n";

    #[test]
    fn process_limits_bound_the_budget() {
        let status = "Name:\traysplat\nVmSize:\t  100000 kB\nVmData:\t   50000 kB\n";
        assert_eq!(rlimit_bounds(LIMITS, status), vec![Bound { bytes: 3_072_000_000 - 102_400_000, what: "under the address-space limit (ulimit -v)" }]);
        let both = LIMITS.replace("Max data size             unlimited", "Max data size             1000000000");
        let b = rlimit_bounds(&both, status);
        assert_eq!(b.len(), 2);
        assert_eq!(b[1].bytes, 1_000_000_000 - 51_200_000);
        assert_eq!(machine_available("MemTotal: 9 kB\nMemAvailable:   2000 kB\nSwapFree: 1000 kB\n"), Some(3000 * 1024));
    }

    #[test]
    fn control_groups_bound_the_budget_at_every_level() {
        let root = tempfile::tempdir().unwrap();
        let write = |p: &str, s: &str| {
            let p = root.path().join(p);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, s).unwrap();
        };
        // v2: the process's group is unlimited, its parent limited to 1 GB with 300 MB used of
        // which 100 MB is reclaimable page cache
        write("a/b/memory.max", "max\n");
        write("a/b/memory.current", "5000\n");
        write("a/memory.max", "1000000000\n");
        write("a/memory.current", "300000000\n");
        write("a/memory.stat", "anon 1\ninactive_file 100000000\n");
        let b = cgroup_bounds("0::/a/b\n", root.path());
        assert_eq!(b.iter().map(|b| b.bytes).collect::<Vec<_>>(), vec![800_000_000]);
        // a path not under the mount (a container's namespace): the mount's own files
        write("memory.max", "2000\n");
        write("memory.current", "500\n");
        assert_eq!(cgroup_bounds("0::/elsewhere\n", root.path())[0].bytes, 1500);
        // v1, memory controller with others; unlimited is ignored
        write("memory/x/memory.limit_in_bytes", "4096\n");
        write("memory/x/memory.usage_in_bytes", "1024\n");
        write("memory/memory.limit_in_bytes", "9223372036854771712\n");
        write("memory/memory.usage_in_bytes", "1\n");
        let b = cgroup_bounds("12:cpu,cpuacct:/x\n7:memory:/x\n", root.path());
        assert_eq!(b.iter().map(|b| b.bytes).collect::<Vec<_>>(), vec![3072]);
    }

    #[test]
    fn an_impossible_allocation_is_an_error() {
        let e = try_vec::<u64>(usize::MAX / 16, 0, || "the test's buffer".into()).unwrap_err();
        assert!(matches!(e, Error::OutOfMemory(_)), "{e:?}");
        assert!(e.to_string().contains("the test's buffer"), "{e}");
        assert_eq!(try_vec(3, 7u8, || unreachable!()).unwrap(), vec![7, 7, 7]);
    }
}
