//! The cache folder (`RAYSPLAT_CACHE_DIR`, else `~/.cache/raysplat`): converted scenes
//! ([`crate::usd`]) and decoded textures ([`crate::image`]), and its bound: files beyond a size
//! limit are removed, least recently used first, so that rendering a long frame sequence (a
//! conversion per frame), editing a stage many times or reading many images does not fill the
//! disk. A conversion or a decoded texture (`textures/*.rstx`) is "used" when it is written or
//! found.

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

/// The cache folder: `RAYSPLAT_CACHE_DIR`, else `$XDG_CACHE_HOME/raysplat`, else
/// `~/.cache/raysplat`, else `raysplat-cache` in the temporary directory.
pub fn dir() -> PathBuf {
    if let Some(d) = std::env::var_os("RAYSPLAT_CACHE_DIR") {
        return PathBuf::from(d);
    }
    if let Some(d) = std::env::var_os("XDG_CACHE_HOME") {
        return PathBuf::from(d).join("raysplat");
    }
    if let Some(h) = std::env::var_os("HOME") {
        return PathBuf::from(h).join(".cache/raysplat");
    }
    std::env::temp_dir().join("raysplat-cache")
}

/// Size the conversions may take together unless `RAYSPLAT_CACHE_LIMIT` says otherwise.
pub const DEFAULT_LIMIT: u64 = 4 << 30;
/// Conversions used this recently are never removed: another process sharing the cache may be
/// about to read the one it just wrote or found.
const GRACE: Duration = Duration::from_secs(60);

/// The limit: `RAYSPLAT_CACHE_LIMIT` (bytes, or with a K, M or G suffix), else [`DEFAULT_LIMIT`].
pub fn limit() -> Result<u64> {
    match std::env::var("RAYSPLAT_CACHE_LIMIT") {
        Ok(v) => super::parse_size(&v).map_err(|_| Error::param("RAYSPLAT_CACHE_LIMIT", format!("{v:?} is not a size (e.g. 500M, 4G)"))),
        Err(_) => Ok(DEFAULT_LIMIT),
    }
}

/// The cache directory to use: [`dir`] when it can be made and written, else a folder of this
/// user's under the temporary directory, with a note saying so (the cache is a speed-up; a
/// read-only home must not stop a render). The note is `(the configured folder, why)`.
pub fn usable_dir() -> (PathBuf, Option<(PathBuf, String)>) {
    let configured = dir();
    let writable = |d: &Path| std::fs::create_dir_all(d).and_then(|_| tempfile::tempfile_in(d).map(drop));
    let Err(e) = writable(&configured) else { return (configured, None) };
    let fallback = std::env::temp_dir().join(format!("raysplat-cache-{}", user_id()));
    let _ = std::fs::create_dir_all(&fallback);
    let why = format!("the cache directory cannot be written ({e}); using the temporary {} instead", fallback.display());
    (fallback, Some((configured, why)))
}

/// This process's user id (the owner of `/proc/self`; 0 where unknown).
fn user_id() -> u32 {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata("/proc/self").map_or(0, |m| m.uid())
}

/// Mark a conversion as just used (best effort: a read-only cache still works).
pub fn touch(rss: &Path) {
    if let Ok(f) = std::fs::File::options().append(true).open(rss) {
        let _ = f.set_modified(SystemTime::now());
    }
}

/// The files of one conversion: the scene file and the directory of textures extracted from a
/// `.usdz` beside it.
fn entry_files(rss: &Path) -> (u64, Option<PathBuf>) {
    let size = std::fs::metadata(rss).map(|m| m.len()).unwrap_or(0);
    let mut dir = rss.as_os_str().to_owned();
    dir.push(".textures");
    let dir = PathBuf::from(dir);
    if !dir.is_dir() {
        return (size, None);
    }
    let extracted: u64 = std::fs::read_dir(&dir).map_or(0, |d| d.flatten().filter_map(|e| e.metadata().ok()).map(|m| m.len()).sum());
    (size + extracted, Some(dir))
}

/// Remove the least recently used conversions in `dir` and decoded textures in `dir/textures`
/// until they take at most `limit` bytes together, never `keep` (the file being used) nor any used
/// within [`GRACE`]. Returns the bytes removed. Errors (a file another process removed first, a
/// read-only directory) leave the files as they are.
pub fn prune(dir: &Path, keep: &Path, limit: u64) -> u64 {
    let listing = |d: &Path, ext: &'static str| {
        std::fs::read_dir(d).into_iter().flatten().flatten().map(|e| e.path()).filter(move |p| p.extension().is_some_and(|x| x == ext) && p.is_file())
    };
    let used = |p: &Path| std::fs::metadata(p).and_then(|m| m.modified()).unwrap_or(SystemTime::UNIX_EPOCH);
    let mut entries: Vec<(SystemTime, u64, PathBuf, Option<PathBuf>)> = listing(dir, "rss")
        .map(|p| {
            let (size, textures) = entry_files(&p);
            (used(&p), size, p, textures)
        })
        .chain(listing(&dir.join("textures"), "rstx").map(|p| (used(&p), std::fs::metadata(&p).map_or(0, |m| m.len()), p, None)))
        .collect();
    let mut total: u64 = entries.iter().map(|e| e.1).sum();
    entries.sort_by(|a, b| a.0.cmp(&b.0).then_with(|| a.2.cmp(&b.2)));
    let mut removed = 0;
    let recent = SystemTime::now().checked_sub(GRACE).unwrap_or(SystemTime::UNIX_EPOCH);
    // (`file`: a conversion, with its extracted `textures`, or a decoded texture)
    for (used, size, file, textures) in entries {
        if total <= limit || used > recent {
            break; // (the rest were used later still)
        }
        if file == keep || std::fs::remove_file(&file).is_err() {
            continue;
        }
        if let Some(t) = textures {
            let _ = std::fs::remove_dir_all(t);
        }
        total -= size;
        removed += size;
    }
    removed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn least_recently_used_conversions_go_first_and_the_one_in_use_stays() {
        let dir = tempfile::tempdir().unwrap();
        let t0 = SystemTime::now() - Duration::from_secs(1000);
        let make = |name: &str, size: usize, age: u64| {
            let p = dir.path().join(name);
            std::fs::write(&p, vec![0u8; size]).unwrap();
            std::fs::File::options().append(true).open(&p).unwrap().set_modified(t0 + Duration::from_secs(age)).unwrap();
            p
        };
        let oldest = make("a.rss", 100, 0);
        let old = make("b.rss", 100, 10);
        let used = make("c.rss", 100, 20);
        let newest = make("d.rss", 100, 30);
        // the oldest has extracted textures, removed with it; other files are not conversions
        let tex = dir.path().join("a.rss.textures");
        std::fs::create_dir(&tex).unwrap();
        std::fs::write(tex.join("t.png"), vec![0u8; 50]).unwrap();
        std::fs::write(dir.path().join("notes.txt"), vec![0u8; 1000]).unwrap();
        // decoded textures count too: the older goes before b, the newer stays
        std::fs::create_dir(dir.path().join("textures")).unwrap();
        let old_texture = make("textures/x.rstx", 40, 5);
        let new_texture = make("textures/y.rstx", 40, 25);
        touch(&used); // found again: now the most recent
        // 530 bytes, limit 290: a (150 with its textures), the older texture and b go
        assert_eq!(prune(dir.path(), &newest, 290), 290);
        assert!(!oldest.exists() && !tex.exists() && !old.exists() && !old_texture.exists());
        assert!(new_texture.exists());
        std::fs::remove_file(&new_texture).unwrap();
        assert!(used.exists() && newest.exists() && dir.path().join("notes.txt").exists());
        // the one in use stays even when it alone is over the limit, and so does one used within
        // the last minute (another process may be about to read it)
        let later = make("e.rss", 100, 40);
        assert_eq!(prune(dir.path(), &newest, 50), 100);
        assert!(newest.exists() && used.exists() && !later.exists());
        assert_eq!(prune(dir.path(), &newest, 1000), 0);
    }
}
