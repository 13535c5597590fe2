//! Input files: only regular files are read (a device such as `/dev/zero`, a FIFO or a directory
//! is refused before anything is read), and a whole-file read takes at most the size the file had
//! when opened, allocated fallibly.

use crate::error::{Error, Result};
use std::fs::File;
use std::io::Read;
use std::path::Path;

/// Check that `path` (through links) is a regular file; the error names the path as given.
pub fn check_input(path: &Path) -> Result<std::fs::Metadata> {
    let m = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if !m.is_file() {
        return Err(Error::io(path, std::io::Error::other(format!("is {}, not a file to read", super::output::kind_of(&m)))));
    }
    Ok(m)
}

/// Open a regular file for reading (checked on the open handle as well, so a path swapped for a
/// device in between is still refused).
pub fn open_input(path: &Path) -> Result<(File, u64)> {
    check_input(path)?;
    let f = File::open(path).map_err(|e| Error::io(path, e))?;
    let m = f.metadata().map_err(|e| Error::io(path, e))?;
    if !m.is_file() {
        return Err(Error::io(path, std::io::Error::other(format!("is {}, not a file to read", super::output::kind_of(&m)))));
    }
    Ok((f, m.len()))
}

/// Read a whole regular file: its size when opened, at most, into a buffer allocated fallibly.
pub fn read_input(path: &Path) -> Result<Vec<u8>> {
    let (f, len) = open_input(path)?;
    let mut bytes = crate::memory::try_vec_with_capacity::<u8>(len as usize, || format!("reading {}", path.display()))?;
    f.take(len).read_to_end(&mut bytes).map_err(|e| Error::io(path, e))?;
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_regular_files_are_read() {
        let d = tempfile::tempdir().unwrap();
        let f = d.path().join("f");
        std::fs::write(&f, b"abc").unwrap();
        assert_eq!(read_input(&f).unwrap(), b"abc");
        for (p, what) in [(Path::new("/dev/zero"), "a device"), (d.path(), "a directory")] {
            let e = read_input(p).unwrap_err().to_string();
            assert!(e.contains(&p.display().to_string()) && e.contains(what), "{e}");
        }
        let missing = d.path().join("missing");
        assert!(read_input(&missing).unwrap_err().to_string().contains("missing"));
    }
}
