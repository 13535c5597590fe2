//! Atomic file output: write to a temporary file next to the destination, then rename.

use std::fs::File;
use std::path::Path;

use crate::{Error, Result};

/// The display form of `path` used in error messages.
pub fn shown(path: &Path) -> String {
    path.display().to_string()
}

/// Write `path` atomically: `write` fills a fresh temporary file in the destination directory
/// (it gets the temporary file's path and an open handle to it); after it succeeds the data is
/// flushed to disk and the file renamed to `path`, replacing any existing file. On any error the
/// temporary file is removed and `path` is left untouched.
///
/// A missing destination directory is reported as such instead of as a bare "No such file".
pub fn write_atomically<F>(path: &Path, write: F) -> Result<()>
where
    F: FnOnce(&Path, &mut File) -> Result<()>,
{
    let Some(file_name) = path.file_name() else {
        return Err(Error::image(shown(path), "not a file path"));
    };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(Error::image(shown(path), format!("output directory {} does not exist", dir.display())));
    }

    let prefix = format!(".{}.", file_name.to_string_lossy());
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    #[cfg(unix)]
    {
        // tempfile's default is 0600; final images should get the usual 0666 & !umask.
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut tmp = builder.tempfile_in(dir).map_err(|e| Error::io(dir, e))?;

    let tmp_path = tmp.path().to_path_buf();
    write(&tmp_path, tmp.as_file_mut())?;
    tmp.as_file().sync_all().map_err(|e| Error::io(&tmp_path, e))?;
    tmp.persist(path).map_err(|e| Error::io(path, e.error))?;
    Ok(())
}

/// Write `bytes` to `path` atomically ([`write_atomically`]).
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    use std::io::Write;
    write_atomically(path, |tmp, f| f.write_all(bytes).map_err(|e| Error::io(tmp, e)))
}
