//! OpenEXR's global thread pool: the one call the safe `openexr` crate does not wrap.
//!
//! OpenEXR compresses the line blocks of a file on its global pool (IlmThread). The crate leaves the
//! pool at 0 threads, so ZIP compression ran on one thread: writing a 1920×1080 image with its AOV
//! layers spent several seconds in zlib after the render. Compression of separate line blocks is
//! independent and the blocks are written in order, so the file is the same for any thread count.

use std::sync::atomic::{AtomicI32, Ordering};

/// The count last given to OpenEXR (−1: never set).
static CURRENT: AtomicI32 = AtomicI32::new(-1);

/// Give OpenEXR's global thread pool `threads` worker threads (0: compress on the calling thread),
/// unless it already has that many. Errors are OpenEXR's message.
pub fn set_exr_threads(threads: usize) -> Result<(), String> {
    let n = threads.min(256) as i32;
    if CURRENT.load(Ordering::Relaxed) == n {
        return Ok(());
    }
    // SAFETY: `Imf_setGlobalThreadCount` takes a plain integer and reports failure through its
    // return value (C++ exceptions are caught inside openexr-sys's C wrapper); it may be called from
    // any thread, and OpenEXR serialises changes of the pool with its own lock.
    let status = unsafe { openexr_sys::Imf_setGlobalThreadCount(n) };
    status.into_result().map_err(|e| format!("{e:?}"))?;
    CURRENT.store(n, Ordering::Relaxed);
    Ok(())
}
