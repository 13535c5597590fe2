//! Atomic file output: write to a temporary file next to the destination, then rename. Every
//! writer goes through [`write_atomically`], which applies the output rule
//! ([`crate::io::output`]) first and keeps the temporary in the cleanup registry
//! ([`crate::io::temporaries`]) while it exists.

use std::fs::File;
use std::path::Path;

use crate::io::{output, temporaries, Format};
use crate::{Error, Result};

/// The display form of `path` used in error messages.
pub fn shown(path: &Path) -> String {
    path.display().to_string()
}

/// Write `path` atomically as a file of `format`: the output rule is checked ([`output::check_output`]:
/// a new path or an existing regular file of a fitting name; through a symbolic link its target);
/// `write` fills a fresh temporary file in the destination directory (it gets the temporary
/// file's path and an open handle to it; it may also replace that path with a file of its own);
/// after it succeeds the data is flushed to disk and the file renamed over the destination. On
/// any error the temporary file is removed and the destination is left untouched.
pub fn write_atomically<F>(path: &Path, format: Format, write: F) -> Result<()>
where
    F: FnOnce(&Path, &mut File) -> Result<()>,
{
    let target = output::check_output(path, format, &[])?;
    let dir = match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => Path::new(".").to_path_buf(),
    };
    let name = target.file_name().ok_or_else(|| Error::image(shown(path), "not a file path"))?;
    let mut tmp = temporaries::create_file(&dir, name)?;
    let tmp_path = tmp.path().to_path_buf();
    write(&tmp_path, tmp.as_file_mut())?;
    // (`write` may have renamed a file of its own over the temporary: flush what the path holds)
    File::open(&tmp_path).and_then(|f| f.sync_all()).map_err(|e| Error::io(&tmp_path, e))?;
    // the destination may have changed while `write` ran (a FIFO made in its place)
    if output::check_output(path, format, &[])? != target {
        return Err(Error::io(path, std::io::Error::other("changed while it was being written")));
    }
    tmp.persist(&target)
}

/// Write `bytes` to `path` atomically as a file of `format` ([`write_atomically`]).
pub fn write_file(path: &Path, format: Format, bytes: &[u8]) -> Result<()> {
    use std::io::Write;
    write_atomically(path, format, |tmp, f| f.write_all(bytes).map_err(|e| Error::io(tmp, e)))
}
