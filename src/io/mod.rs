//! File and process helpers every other module may use, depending on none of them but [`crate::error`]:
//!
//! - [`output`]: the output rule every writer applies (a new path or an existing regular file of a
//!   fitting name; never an input, a device, a FIFO or a directory).
//! - [`atomic`]: atomic file output (a temporary file in the destination folder, then a rename).
//! - [`input`]: checks of input files (regular files, read with a bound on their size).
//! - [`temporaries`]: temporaries and spill folders that must not outlive the command (removed on
//!   exit and on SIGINT/SIGTERM/SIGHUP; stale ones of dead processes removed at the next start).
//! - [`exr_threads`]: OpenEXR's global thread pool, sized once per process before the first EXR
//!   file is read or written (the one call into OpenEXR's C API outside the `openexr` crate, so the
//!   one `unsafe` block outside `embree` and `ffi`).
//! - [`cache`]: the cache folder of converted scenes and decoded textures, and its size bound.
//! - [`parse_size`]: sizes written as bytes or with a K, M or G suffix (`--memory`,
//!   `RAYSPLAT_CACHE_LIMIT`).

pub mod atomic;
pub mod cache;
pub mod exr_threads;
pub mod input;
pub mod output;
pub mod temporaries;

pub use atomic::{write_atomically, write_file};
pub use output::{check_output, check_outputs, Format};

use crate::error::{Error, Result};

/// Parse a size in bytes, or with a K, M or G suffix (powers of 1024), e.g. `512M`.
pub fn parse_size(s: &str) -> Result<u64> {
    let t = s.trim();
    let (num, mul) = match t.chars().last().map(|c| c.to_ascii_uppercase()) {
        Some('K') => (&t[..t.len() - 1], 1u64 << 10),
        Some('M') => (&t[..t.len() - 1], 1 << 20),
        Some('G') => (&t[..t.len() - 1], 1 << 30),
        _ => (t, 1),
    };
    let v: f64 = num.trim().parse().map_err(|_| Error::param("memory", format!("{s:?} is not a size (e.g. 512M, 2G)")))?;
    if !(v.is_finite() && v > 0.0) {
        return Err(Error::param("memory", format!("{s:?} is not a positive size")));
    }
    Ok((v * mul as f64) as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_binary_suffixes() {
        assert_eq!(parse_size("512M").unwrap(), 512 << 20);
        assert_eq!(parse_size("2g").unwrap(), 2 << 30);
        assert_eq!(parse_size("4096").unwrap(), 4096);
        assert!(parse_size("lots").is_err());
        assert!(parse_size("-1M").is_err());
    }
}
