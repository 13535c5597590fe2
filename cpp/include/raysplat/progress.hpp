// raysplat C++ API: progress reporting.
//
// Derive from raysplat::ProgressCallback and pass it to raysplat::render. The renderer calls
// begin() when a stage starts, advance() as work completes and finish() at the end.
//
// Threading: the methods are called from the render's worker threads (not necessarily the thread
// that called render), but never concurrently for one render: raysplat serialises the calls, so an
// implementation needs no locking of its own unless it shares state with other threads. advance()
// calls may be coalesced: `done` is the cumulative number of work units of the current stage.
//
// Exceptions: an exception thrown by a callback stops the render, and render() then throws a
// rust::Error whose message contains the callback's what() (or "unknown exception").
//
// Keep callbacks cheap: they run between tiles of the render.
#pragma once

#include <cstdint>
#include <exception>
#include <stdexcept>
#include <string>

#include "rust/cxx.h"

namespace raysplat {

class ProgressCallback {
public:
  ProgressCallback() = default;
  ProgressCallback(const ProgressCallback &) = default;
  ProgressCallback &operator=(const ProgressCallback &) = default;
  virtual ~ProgressCallback() = default;

  // A stage (e.g. "path tracing") starts with `total` units of work.
  virtual void begin(rust::Str stage, std::uint64_t total) {
    (void)stage;
    (void)total;
  }
  // `done` of the current stage's `total` units are complete.
  virtual void advance(std::uint64_t done, std::uint64_t total) {
    (void)done;
    (void)total;
  }
  // The render ended (also called when it is cancelled).
  virtual void finish() {}
};

namespace detail {

// Called by the Rust side (src/ffi/bridge.rs): forward to the virtual methods and turn any
// exception into a std::exception that cxx converts into a Rust error.
[[noreturn]] inline void rethrow_as_std(const char *where) {
  try {
    throw;
  } catch (const std::exception &e) {
    throw std::runtime_error(std::string("progress callback ") + where + " threw: " + e.what());
  } catch (...) {
    throw std::runtime_error(std::string("progress callback ") + where + " threw an unknown exception");
  }
}

inline void progress_begin(ProgressCallback &callback, rust::Str stage, std::uint64_t total) {
  try {
    callback.begin(stage, total);
  } catch (...) {
    rethrow_as_std("begin");
  }
}

inline void progress_advance(ProgressCallback &callback, std::uint64_t done, std::uint64_t total) {
  try {
    callback.advance(done, total);
  } catch (...) {
    rethrow_as_std("advance");
  }
}

inline void progress_finish(ProgressCallback &callback) {
  try {
    callback.finish();
  } catch (...) {
    rethrow_as_std("finish");
  }
}

} // namespace detail
} // namespace raysplat
