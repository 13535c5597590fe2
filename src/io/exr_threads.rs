//! OpenEXR's global thread pool: the one call the safe `openexr` crate does not wrap.
//!
//! OpenEXR compresses and decompresses the line blocks of a file on its global pool (IlmThread).
//! The crate leaves the pool at 0 threads, so ZIP compression ran on one thread: writing a
//! 1920×1080 image with its AOV layers spent several seconds in zlib after the render. Compression
//! of separate line blocks is independent and the blocks are written in order, so the file is the
//! same for any thread count.
//!
//! The pool is sized **once per process**, before the first EXR file is read or written, and never
//! resized. OpenEXR 3.0's pool cannot be resized safely while another thread reads or writes a
//! file: shrinking it stops the workers and clears the task queue, so a task queued meanwhile by
//! another thread's writer is dropped and that writer waits for it forever (a test process that
//! wrote files from pools of 1, 2 and 3 threads at once hung this way). Every EXR reader and writer
//! of this crate calls [`size_pool_once`] first; the first call decides the count for the process.

use std::sync::OnceLock;

/// The pool's size for this process, or OpenEXR's message if sizing it failed (it then stays at
/// 0 threads: files are compressed on the calling thread).
static POOL: OnceLock<Result<usize, String>> = OnceLock::new();

/// Largest pool asked of OpenEXR.
const MAX_THREADS: usize = 256;

/// Give OpenEXR's global pool `threads` worker threads (0: work on the calling thread) if this is
/// the first call in the process; later calls change nothing. Returns the pool's size for the
/// process. Concurrent first calls wait for the one that sizes the pool, so no file is read or
/// written while it changes.
///
/// # Errors
/// OpenEXR's message if it refused the size (the pool then has 0 threads for the process).
pub fn size_pool_once(threads: usize) -> Result<usize, String> {
    POOL.get_or_init(|| {
        let n = threads.min(MAX_THREADS);
        // SAFETY: `Imf_setGlobalThreadCount` takes a plain integer and reports failure through its
        // return value (C++ exceptions are caught inside openexr-sys's C wrapper). It runs once per
        // process, inside `OnceLock::get_or_init`, before any file of this crate is opened: every
        // reader and writer calls this function first and blocks until the pool is sized.
        let status = unsafe { openexr_sys::Imf_setGlobalThreadCount(n as i32) };
        status.into_result().map(|()| n).map_err(|e| format!("{e:?}"))
    })
    .clone()
}

/// [`size_pool_once`] with as many threads as the calling thread's rayon pool (the first call of
/// the process decides): what every EXR reader and writer calls before touching a file.
pub fn size_pool_for_caller() -> Result<usize, String> {
    size_pool_once(rayon::current_num_threads())
}
