//! Time spent inside Embree's ray queries, measured rather than estimated: when switched on, every
//! query of [`Scene`](super::Scene) adds the time-stamp-counter cycles of its Embree call (hit
//! filters such as alpha cut-outs run inside it and count) to a process-wide sum. `raysplat-bench
//! embree` switches it on for one single-threaded path-tracer render and divides by the render's
//! cycles.
//!
//! Built only with the feature `embree-timing` (which only the benchmarks enable); with it and the
//! counting off, a query pays one relaxed load of a flag.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};

static ON: AtomicBool = AtomicBool::new(false);
static CYCLES: AtomicU64 = AtomicU64::new(0);

/// The time-stamp counter (cycles at a constant rate; 0 where there is none).
#[inline]
pub fn cycles_now() -> u64 {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: `rdtsc` reads a counter; it has no preconditions on x86-64.
        #[allow(unused_unsafe)]
        unsafe {
            std::arch::x86_64::_rdtsc()
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        0
    }
}

/// Switch the counting on or off, and reset the sum.
pub fn set_counting(on: bool) {
    CYCLES.store(0, Relaxed);
    ON.store(on, Relaxed);
}

/// Cycles counted inside Embree since counting was switched on.
pub fn counted_cycles() -> u64 {
    CYCLES.load(Relaxed)
}

/// Run the Embree call `f`, counting its cycles when counting is on.
#[inline]
pub(super) fn timed<R>(f: impl FnOnce() -> R) -> R {
    if !ON.load(Relaxed) {
        return f();
    }
    let t0 = cycles_now();
    let r = f();
    CYCLES.fetch_add(cycles_now().wrapping_sub(t0), Relaxed);
    r
}
