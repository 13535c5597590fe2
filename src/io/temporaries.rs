//! Temporary files and directories that must not outlive the command that made them: the atomic
//! writers' temporaries, the spill directories of final gathering, the converter's staging
//! directories, and the converter processes themselves.
//!
//! Every temporary is made through this module, which records it in a process-wide registry
//! until it is dropped (removed, or renamed into place). [`clean_up_all`] removes what the registry
//! holds and kills the registered converter process groups; a program calls it when it is asked to
//! stop (the CLI from its SIGINT/SIGTERM/SIGHUP handler thread). The library installs no signal
//! handler itself: a host program (the C++ API) keeps its own.
//!
//! Names carry the owner's process id and start time (`raysplat-PID-START-…`), so that the
//! temporaries of a process that died without cleaning up (SIGKILL, power loss) are recognised and
//! removed by the next command that writes into the same directory ([`remove_stale`]).

use crate::error::{Error, Result};
use std::ffi::OsStr;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, OnceLock};

/// What the registry holds: temporaries by id, converter process groups by id, and whether
/// [`clean_up_all`] has run (then nothing new may be made).
#[derive(Default)]
struct Registry {
    next: u64,
    paths: Vec<(u64, PathBuf)>,
    groups: Vec<(u64, u32)>,
    closed: bool,
}

fn registry() -> MutexGuard<'static, Registry> {
    static REGISTRY: Mutex<Registry> = Mutex::new(Registry { next: 0, paths: Vec::new(), groups: Vec::new(), closed: false });
    // a panic while holding the lock leaves the lists intact
    REGISTRY.lock().unwrap_or_else(|e| e.into_inner())
}

/// `PID-START`: this process's mark in the names of its temporaries, after `raysplat-` (START: its
/// start time in clock ticks after boot, so a later process reusing the PID is told apart).
pub fn owner_token() -> &'static str {
    static TOKEN: OnceLock<String> = OnceLock::new();
    TOKEN.get_or_init(|| {
        let pid = std::process::id();
        format!("{pid}-{}", start_time(pid).unwrap_or(0))
    })
}

/// Start time of process `pid` in clock ticks after boot (Linux `/proc/PID/stat`, field 22).
fn start_time(pid: u32) -> Option<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // fields after the command name, which is in parentheses and may hold spaces
    let rest = &stat[stat.rfind(')')? + 1..];
    rest.split_whitespace().nth(19)?.parse().ok()
}

/// The owner `(pid, start)` recorded in a temporary's name, if it is one of ours.
fn owner_of(name: &str) -> Option<(u32, u64)> {
    let at = name.rfind("raysplat-")? + "raysplat-".len();
    let mut parts = name[at..].trim_start_matches("spill-").splitn(3, '-');
    let pid = parts.next()?.parse().ok()?;
    let start = parts.next()?.parse().ok()?;
    parts.next()?;
    Some((pid, start))
}

/// Whether the process that made a temporary has ended. Unknown (no `/proc`) counts as running.
fn owner_is_gone((pid, start): (u32, u64)) -> bool {
    if !Path::new("/proc/self/stat").exists() {
        return false;
    }
    match start_time(pid) {
        Some(s) => s != start,
        None => !Path::new(&format!("/proc/{pid}")).exists(),
    }
}

/// Remove from `dir` the temporaries (files and directories) whose owner has ended. Best effort:
/// what cannot be removed stays. Returns how many were removed.
pub fn remove_stale(dir: &Path) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else { return 0 };
    let mut removed = 0;
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(name) = name.to_str() else { continue };
        let ours = (name.starts_with('.') && name.ends_with(".tmp")) || name.starts_with("raysplat-spill-");
        let Some(owner) = owner_of(name).filter(|_| ours) else { continue };
        if !owner_is_gone(owner) {
            continue;
        }
        let p = e.path();
        let gone = match e.file_type() {
            Ok(t) if t.is_dir() => std::fs::remove_dir_all(&p).is_ok(),
            Ok(_) => std::fs::remove_file(&p).is_ok(),
            Err(_) => false,
        };
        removed += gone as usize;
    }
    removed
}

/// Record `path` (just made, under the registry's lock) and return its id.
fn record(reg: &mut Registry, path: PathBuf) -> u64 {
    reg.next += 1;
    reg.paths.push((reg.next, path));
    reg.next
}

fn forget(id: u64) {
    registry().paths.retain(|(i, _)| *i != id);
}

/// A temporary file in the registry: removed when dropped unless [`TempFile::persist`]ed.
pub struct TempFile {
    id: u64,
    file: Option<tempfile::NamedTempFile>,
}

impl TempFile {
    pub fn path(&self) -> &Path {
        self.file.as_ref().expect("present until persisted").path()
    }

    pub fn as_file_mut(&mut self) -> &mut File {
        self.file.as_mut().expect("present until persisted").as_file_mut()
    }

    /// Rename the file to `target` (replacing a file there) and take it out of the registry.
    pub fn persist(mut self, target: &Path) -> Result<()> {
        let f = self.file.take().expect("present until persisted");
        let r = f.persist(target).map(|_| ()).map_err(|e| Error::io(target, e.error));
        forget(self.id);
        r
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if self.file.take().is_some() {
            // NamedTempFile's drop has removed it
            forget(self.id);
        }
    }
}

/// A new, empty temporary file `.NAME.raysplat-PID-START-XXXXXX.tmp` in `dir` (for `name`, the file
/// it will become), with the usual `0666 & !umask` permissions. Stale temporaries of ended
/// processes in `dir` are removed first.
pub fn create_file(dir: &Path, name: &OsStr) -> Result<TempFile> {
    remove_stale(dir);
    let prefix = format!(".{}.raysplat-{}-", name.to_string_lossy(), owner_token());
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    #[cfg(unix)]
    {
        // tempfile's default is 0600; outputs should get the usual 0666 & !umask.
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut reg = registry();
    if reg.closed {
        return Err(Error::Cancelled);
    }
    let file = builder.tempfile_in(dir).map_err(|e| Error::io(dir, e))?;
    let id = record(&mut reg, file.path().to_path_buf());
    Ok(TempFile { id, file: Some(file) })
}

/// A temporary directory in the registry: removed with its content when dropped.
pub struct TempDir {
    id: u64,
    dir: Option<tempfile::TempDir>,
}

impl TempDir {
    pub fn path(&self) -> &Path {
        self.dir.as_ref().expect("present until dropped").path()
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        drop(self.dir.take());
        forget(self.id);
    }
}

/// A new temporary directory in `dir` named `PREFIX` + `PID-START-XXXXXX` + `suffix`, where
/// `PREFIX` ends in `raysplat-` (`raysplat-spill-…`, or `.out.rss.raysplat-…` with suffix `.tmp`).
/// Stale temporaries of ended processes in `dir` are removed first.
pub fn create_dir(dir: &Path, prefix: &str, suffix: &str) -> Result<TempDir> {
    debug_assert!(prefix.ends_with("raysplat-") || prefix.ends_with("raysplat-spill-"));
    remove_stale(dir);
    let full = format!("{prefix}{}-", owner_token());
    let mut reg = registry();
    if reg.closed {
        return Err(Error::Cancelled);
    }
    let made = tempfile::Builder::new().prefix(&full).suffix(suffix).tempdir_in(dir).map_err(|e| Error::io(dir, e))?;
    let id = record(&mut reg, made.path().to_path_buf());
    Ok(TempDir { id, dir: Some(made) })
}

/// A path made by someone else (the converter's extracted textures) to remove on
/// [`clean_up_all`]; dropping the guard only takes it out of the registry.
pub struct Registered {
    id: u64,
}

impl Drop for Registered {
    fn drop(&mut self) {
        forget(self.id);
    }
}

/// Record `path` for removal by [`clean_up_all`] until the guard is dropped.
pub fn register(path: &Path) -> Result<Registered> {
    let mut reg = registry();
    if reg.closed {
        return Err(Error::Cancelled);
    }
    Ok(Registered { id: record(&mut reg, path.to_path_buf()) })
}

/// A child process group (a converter started with its own group) to kill on [`clean_up_all`];
/// dropping the guard takes it out of the registry.
pub struct ChildGroup {
    id: u64,
}

impl Drop for ChildGroup {
    fn drop(&mut self) {
        registry().groups.retain(|(i, _)| *i != self.id);
    }
}

/// Record the process group `pgid` for [`clean_up_all`]. When cleanup has already run, the group
/// is killed at once and the result is [`Error::Cancelled`].
pub fn register_child_group(pgid: u32) -> Result<ChildGroup> {
    let mut reg = registry();
    if reg.closed {
        kill_group(pgid);
        return Err(Error::Cancelled);
    }
    reg.next += 1;
    let id = reg.next;
    reg.groups.push((id, pgid));
    Ok(ChildGroup { id })
}

fn kill_group(pgid: u32) {
    if let Some(pid) = rustix::process::Pid::from_raw(pgid as i32) {
        let _ = rustix::process::kill_process_group(pid, rustix::process::Signal::KILL);
    }
}

/// Kill the registered converter process groups and remove every registered temporary, then
/// refuse new ones ([`Error::Cancelled`]) and hold the registry's lock until the process ends: a
/// program calls this just before it exits on a signal, and no temporary can be made between
/// this cleanup and the exit. Returns how many paths were removed.
pub fn clean_up_all() -> usize {
    let mut reg = registry();
    reg.closed = true;
    for &(_, pgid) in &reg.groups {
        kill_group(pgid);
    }
    let mut removed = 0;
    // newest first: a file made inside a registered directory goes before the directory
    for (_, p) in reg.paths.iter().rev() {
        let gone = match std::fs::symlink_metadata(p) {
            Ok(m) if m.is_dir() => std::fs::remove_dir_all(p).is_ok(),
            Ok(_) => std::fs::remove_file(p).is_ok(),
            Err(_) => false,
        };
        removed += gone as usize;
    }
    reg.paths.clear();
    // the lock stays held: this process is about to exit
    std::mem::forget(reg);
    removed
}

/// The registered temporaries (for tests).
pub fn registered() -> Vec<PathBuf> {
    registry().paths.iter().map(|(_, p)| p.clone()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_carry_the_owner_and_a_dead_owners_temporaries_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        let t = create_file(dir.path(), OsStr::new("x.exr")).unwrap();
        let name = t.path().file_name().unwrap().to_str().unwrap().to_string();
        assert!(name.starts_with(".x.exr.raysplat-") && name.ends_with(".tmp"), "{name}");
        assert_eq!(owner_of(&name), Some((std::process::id(), start_time(std::process::id()).unwrap())));
        assert!(registered().contains(&t.path().to_path_buf()));
        // ours is alive: kept; a dead owner's file and directory go; other files stay
        let stale_file = dir.path().join(format!(".y.exr.raysplat-{}-{}-abc.tmp", u32::MAX - 7, 12345));
        let stale_dir = dir.path().join(format!("raysplat-spill-{}-{}-xyz", u32::MAX - 7, 12345));
        std::fs::write(&stale_file, b"x").unwrap();
        std::fs::create_dir(&stale_dir).unwrap();
        std::fs::write(stale_dir.join("a_r.bin"), b"x").unwrap();
        // the same pid with another start time is another (ended) process
        let reused = dir.path().join(format!(".z.exr.raysplat-{}-{}-q.tmp", std::process::id(), 1));
        std::fs::write(&reused, b"x").unwrap();
        let unrelated = [dir.path().join("keep.tmp"), dir.path().join(".keep.raysplat-notanumber-1-a.tmp")];
        for u in &unrelated {
            std::fs::write(u, b"x").unwrap();
        }
        assert_eq!(remove_stale(dir.path()), 3);
        assert!(!stale_file.exists() && !stale_dir.exists() && !reused.exists());
        assert!(t.path().exists() && unrelated.iter().all(|u| u.exists()));
        let p = t.path().to_path_buf();
        drop(t);
        assert!(!p.exists() && !registered().contains(&p));
    }

    #[test]
    fn directories_are_registered_until_dropped() {
        let parent = tempfile::tempdir().unwrap();
        let d = create_dir(parent.path(), "raysplat-spill-", "").unwrap();
        let name = d.path().file_name().unwrap().to_str().unwrap().to_string();
        assert!(name.starts_with(&format!("raysplat-spill-{}-", std::process::id())), "{name}");
        assert!(owner_of(&name).is_some());
        let p = d.path().to_path_buf();
        assert!(registered().contains(&p));
        drop(d);
        assert!(!p.exists() && !registered().contains(&p));
    }
}
