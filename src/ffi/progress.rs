//! `integrators::Progress` over a C++ `raysplat::ProgressCallback` and a `CancelToken`.
//!
//! The renderer calls `Progress` from its worker threads, concurrently. The C++ callback is only
//! ever called with `state` locked, so C++ sees one call at a time; `advance` counts are summed in
//! an atomic and delivered by whichever thread gets the lock (`try_lock`: a worker never waits for
//! a slow callback), the remainder at `finish`. A C++ exception stops the render (through
//! `cancelled()`) and is reported instead of "render cancelled".

use super::bridge::ffi;
use crate::integrators::Progress;
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard, TryLockError};

/// A cancellation flag shared by the C++ threads that render and the ones that cancel.
#[derive(Debug, Default)]
pub struct CancelToken {
    flag: AtomicBool,
}

impl CancelToken {
    pub fn new() -> CancelToken {
        CancelToken::default()
    }
    pub fn set(&self) {
        self.flag.store(true, Ordering::SeqCst);
    }
    pub fn clear(&self) {
        self.flag.store(false, Ordering::SeqCst);
    }
    pub fn get(&self) -> bool {
        self.flag.load(Ordering::SeqCst)
    }
}

/// The C++ callback object, borrowed for the duration of one `render` call.
struct Callback<'a>(Pin<&'a mut ffi::ProgressCallback>);

// SAFETY: `Callback` is only reachable through `CppProgress::state`'s mutex, so the C++ object is
// never used by two threads at once; moving the exclusive borrow to another thread is then sound as
// long as the C++ object is not tied to the thread that created it, which `progress.hpp` and
// docs/cpp.md state as the contract of `ProgressCallback` ("called from the render's worker
// threads, one call at a time"). The borrow cannot outlive the `render` call that received it.
unsafe impl Send for Callback<'_> {}

struct State<'a> {
    callback: Callback<'a>,
    /// The cumulative `done` last given to C++ for the current stage.
    delivered: u64,
    /// A stage began and its `finish` has not been delivered.
    open: bool,
}

pub struct CppProgress<'a> {
    state: Mutex<State<'a>>,
    done: AtomicU64,
    total: AtomicU64,
    cancel: &'a CancelToken,
    /// Set when a callback threw: no further calls to C++, and the render stops.
    failed: AtomicBool,
    error: Mutex<Option<String>>,
}

impl<'a> CppProgress<'a> {
    pub fn new(callback: Pin<&'a mut ffi::ProgressCallback>, cancel: &'a CancelToken) -> CppProgress<'a> {
        CppProgress {
            state: Mutex::new(State { callback: Callback(callback), delivered: 0, open: false }),
            done: AtomicU64::new(0),
            total: AtomicU64::new(0),
            cancel,
            failed: AtomicBool::new(false),
            error: Mutex::new(None),
        }
    }

    fn lock(&self) -> MutexGuard<'_, State<'a>> {
        // A poisoned lock only means a panic elsewhere; the state itself is always consistent.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Run one C++ call unless an earlier one failed; record the first failure.
    fn call(&self, f: impl FnOnce() -> Result<(), cxx::Exception>) {
        if self.failed.load(Ordering::SeqCst) {
            return;
        }
        if let Err(e) = f() {
            self.failed.store(true, Ordering::SeqCst);
            let mut slot = self.error.lock().unwrap_or_else(|e| e.into_inner());
            slot.get_or_insert_with(|| e.what().to_string());
        }
    }

    fn deliver(&self, state: &mut State<'a>) {
        let done = self.done.load(Ordering::SeqCst);
        if done > state.delivered {
            state.delivered = done;
            let total = self.total.load(Ordering::SeqCst);
            self.call(|| ffi::progress_advance(state.callback.0.as_mut(), done, total));
        }
    }

    /// Deliver what is pending and `finish` if a stage is still open (the render ended, possibly
    /// with an error, without finishing). Returns the callback's error, if one threw.
    pub fn close(&self) -> Option<String> {
        let mut state = self.lock();
        if state.open {
            self.deliver(&mut state);
            state.open = false;
            self.call(|| ffi::progress_finish(state.callback.0.as_mut()));
        }
        drop(state);
        self.error.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }
}

impl Progress for CppProgress<'_> {
    fn begin(&self, stage: &str, total: u64) {
        let mut state = self.lock();
        self.done.store(0, Ordering::SeqCst);
        self.total.store(total, Ordering::SeqCst);
        state.delivered = 0;
        state.open = true;
        self.call(|| ffi::progress_begin(state.callback.0.as_mut(), stage, total));
    }

    fn advance(&self, n: u64) {
        self.done.fetch_add(n, Ordering::SeqCst);
        let mut state = match self.state.try_lock() {
            Ok(s) => s,
            Err(TryLockError::Poisoned(e)) => e.into_inner(),
            Err(TryLockError::WouldBlock) => return, // the holder or a later call delivers it
        };
        self.deliver(&mut state);
    }

    fn cancelled(&self) -> bool {
        self.cancel.get() || self.failed.load(Ordering::Relaxed)
    }

    fn finish(&self) {
        let mut state = self.lock();
        self.deliver(&mut state);
        if state.open {
            state.open = false;
            self.call(|| ffi::progress_finish(state.callback.0.as_mut()));
        }
    }
}
