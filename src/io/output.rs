//! The output rule, one function for every file raysplat writes ([`check_output`]): a command
//! writes only to a new path or over an existing regular file. Through a symbolic link it writes
//! the link's target and keeps the link, as `cp` does. It refuses a directory, a device, a FIFO,
//! a socket or a dangling link; a path that is the same file (device and inode) as one of the
//! command's inputs or as another of its outputs; and a name whose extension says another format
//! (`-o x.png` for an OpenEXR file). Refusals are [`Error::Io`] naming the path as given, made
//! before anything is written.

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// What an output holds, for the check of its name's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Exr,
    Png,
    /// The scene format (`.rss`).
    Rss,
    Json,
    Csv,
    Markdown,
    /// A shell or batch script (the farm's `sbatch` files).
    Script,
}

impl Format {
    /// The extensions this format's files may carry (the first is the usual one).
    pub fn extensions(self) -> &'static [&'static str] {
        match self {
            Format::Exr => &["exr"],
            Format::Png => &["png"],
            Format::Rss => &["rss"],
            Format::Json => &["json"],
            Format::Csv => &["csv"],
            Format::Markdown => &["md"],
            Format::Script => &["sbatch", "sh"],
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Format::Exr => "OpenEXR",
            Format::Png => "PNG",
            Format::Rss => "a raysplat scene (.rss)",
            Format::Json => "JSON",
            Format::Csv => "CSV",
            Format::Markdown => "Markdown",
            Format::Script => "a batch script",
        }
    }
}

/// Extensions that name a format, and the format they name: an output named with one of these
/// must be of that format. Other extensions (or none) are free.
const NAMED: &[(&str, &str)] = &[
    ("exr", "OpenEXR"),
    ("png", "PNG"),
    ("jpg", "JPEG"),
    ("jpeg", "JPEG"),
    ("tif", "TIFF"),
    ("tiff", "TIFF"),
    ("hdr", "Radiance HDR"),
    ("bmp", "BMP"),
    ("tga", "TGA"),
    ("gif", "GIF"),
    ("webp", "WebP"),
    ("rss", "a raysplat scene"),
    ("usd", "USD"),
    ("usda", "USD"),
    ("usdc", "USD"),
    ("usdz", "USD"),
    ("json", "JSON"),
    ("csv", "CSV"),
    ("md", "Markdown"),
];

fn refuse(path: &Path, message: String) -> Error {
    Error::io(path, std::io::Error::other(message))
}

/// The identity of an existing file: (device, inode).
fn file_id(m: &std::fs::Metadata) -> (u64, u64) {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        (m.dev(), m.ino())
    }
    #[cfg(not(unix))]
    {
        let _ = m;
        (0, 0)
    }
}

/// What kind of file that is not a regular file `m` describes, for messages.
pub(crate) fn kind_of(m: &std::fs::Metadata) -> &'static str {
    let t = m.file_type();
    if t.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_block_device() || t.is_char_device() {
            return "a device";
        }
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    "not a regular file"
}

/// Check that `path` may be written as a file of `format` by a command that reads `inputs`, and
/// return the path to write: `path` itself, or the final target of a symbolic link. The target's
/// directory must exist.
pub fn check_output(path: &Path, format: Format, inputs: &[&Path]) -> Result<PathBuf> {
    if path.file_name().is_none() {
        return Err(refuse(path, "is not a file name to write".into()));
    }
    if let Some(ext) = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase) {
        if !format.extensions().contains(&ext.as_str()) {
            if let Some((_, named)) = NAMED.iter().find(|(e, _)| *e == ext) {
                return Err(refuse(
                    path,
                    format!("the name says {named}, but this output is {}: name it .{}", format.name(), format.extensions()[0]),
                ));
            }
        }
    }
    let target = match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => path.to_path_buf(),
        Err(e) => return Err(Error::io(path, e)),
        Ok(m) if m.file_type().is_symlink() => match std::fs::canonicalize(path) {
            Ok(t) => t,
            Err(_) => return Err(refuse(path, "is a symbolic link to a missing file (not written through)".into())),
        },
        Ok(_) => path.to_path_buf(),
    };
    let dir = match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(refuse(path, format!("output directory {} does not exist", dir.display())));
    }
    let Ok(m) = std::fs::metadata(&target) else { return Ok(target) };
    if !m.is_file() {
        return Err(refuse(path, format!("is {}, not a file to write", kind_of(&m))));
    }
    let id = file_id(&m);
    for input in inputs {
        if std::fs::metadata(input).is_ok_and(|i| file_id(&i) == id) {
            return Err(refuse(path, format!("is the same file as the input {}", input.display())));
        }
    }
    Ok(target)
}

/// [`check_output`] for every output of one command, and that no two of them are the same file
/// (or, when new, the same path). Returns the paths to write, in order.
pub fn check_outputs(outputs: &[(&Path, Format)], inputs: &[&Path]) -> Result<Vec<PathBuf>> {
    let mut targets: Vec<PathBuf> = Vec::with_capacity(outputs.len());
    for (k, &(path, format)) in outputs.iter().enumerate() {
        let t = check_output(path, format, inputs)?;
        let key = same_file_key(&t);
        for (j, earlier) in targets.iter().enumerate() {
            if same_file_key(earlier) == key {
                return Err(refuse(path, format!("is the same file as the other output {}", outputs[j].0.display())));
            }
        }
        debug_assert_eq!(k, targets.len());
        targets.push(t);
    }
    Ok(targets)
}

/// Two outputs are one file when their (device, inode) agree, or, not existing yet, their
/// directories' canonical paths and their names do.
fn same_file_key(target: &Path) -> (Option<(u64, u64)>, Option<PathBuf>) {
    if let Ok(m) = std::fs::metadata(target) {
        return (Some(file_id(&m)), None);
    }
    let dir = match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let name = target.file_name().map(PathBuf::from).unwrap_or_default();
    (None, Some(std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf()).join(name)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(r: Result<PathBuf>) -> String {
        r.expect_err("refused").to_string()
    }

    #[test]
    fn new_paths_and_regular_files_are_written_and_others_refused() {
        let d = tempfile::tempdir().unwrap();
        let p = |n: &str| d.path().join(n);
        assert_eq!(check_output(&p("new.exr"), Format::Exr, &[]).unwrap(), p("new.exr"));
        assert_eq!(check_output(&p("no-extension"), Format::Exr, &[]).unwrap(), p("no-extension"));
        std::fs::write(p("old.exr"), b"x").unwrap();
        assert_eq!(check_output(&p("old.exr"), Format::Exr, &[]).unwrap(), p("old.exr"));
        // another format's name
        let e = err(check_output(&p("x.png"), Format::Exr, &[]));
        assert!(e.contains("x.png") && e.contains("PNG") && e.contains("OpenEXR") && e.contains(".exr"), "{e}");
        assert!(err(check_output(&p("x.EXR"), Format::Png, &[])).contains("OpenEXR"));
        assert!(err(check_output(&p("s.usda"), Format::Rss, &[])).contains("USD"));
        // not a regular file
        assert!(err(check_output(d.path(), Format::Exr, &[])).contains("is a directory"));
        std::fs::create_dir(p("dir.exr")).unwrap();
        assert!(err(check_output(&p("dir.exr"), Format::Exr, &[])).contains("a directory"));
        let sock = std::os::unix::net::UnixListener::bind(p("sock")).unwrap();
        assert!(err(check_output(&p("sock"), Format::Exr, &[])).contains("a socket"));
        drop(sock);
        assert!(err(check_output(&p("missing/x.exr"), Format::Exr, &[])).contains("does not exist"));
        // through a symbolic link: its target (relative links resolve from the link's directory)
        std::os::unix::fs::symlink("old.exr", p("link.exr")).unwrap();
        assert_eq!(check_output(&p("link.exr"), Format::Exr, &[]).unwrap(), std::fs::canonicalize(p("old.exr")).unwrap());
        std::os::unix::fs::symlink("nowhere.exr", p("dangling.exr")).unwrap();
        assert!(err(check_output(&p("dangling.exr"), Format::Exr, &[])).contains("missing file"));
        std::os::unix::fs::symlink(d.path(), p("dirlink")).unwrap();
        assert!(err(check_output(&p("dirlink"), Format::Exr, &[])).contains("a directory"));
    }

    #[test]
    fn an_input_or_another_output_is_never_an_output() {
        let d = tempfile::tempdir().unwrap();
        let p = |n: &str| d.path().join(n);
        std::fs::write(p("scene"), b"x").unwrap();
        std::fs::hard_link(p("scene"), p("hard")).unwrap();
        std::os::unix::fs::symlink(p("scene"), p("soft")).unwrap();
        for name in ["scene", "hard", "soft"] {
            let e = err(check_output(&p(name), Format::Exr, &[&p("scene")]));
            assert!(e.contains(name) && e.contains("same file as the input"), "{e}");
        }
        // two outputs: new or existing, through a link or by another spelling of the directory
        let a = p("a");
        let a2 = d.path().join(".").join("a");
        let e = check_outputs(&[(&a, Format::Exr), (&a2, Format::Png)], &[]).unwrap_err().to_string();
        assert!(e.contains("same file as the other output"), "{e}");
        std::fs::write(p("b"), b"x").unwrap();
        let e = check_outputs(&[(&p("b"), Format::Exr), (&p("hard"), Format::Png), (&p("soft"), Format::Png)], &[]).unwrap_err().to_string();
        assert!(e.contains("soft") && e.contains("other output") && e.contains("hard"), "{e}");
        assert_eq!(check_outputs(&[(&p("b"), Format::Exr), (&p("c"), Format::Png)], &[&p("scene")]).unwrap().len(), 2);
    }
}
