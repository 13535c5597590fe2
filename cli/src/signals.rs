//! SIGINT, SIGTERM and SIGHUP end the command cleanly: a thread waiting for them removes every
//! temporary the library registered (the EXR being written, spill directories, the converter's
//! staging files) and kills the converter, then exits with status 128 + the signal's number
//! (130 for Ctrl-C). The handler lives here, in the program: the library installs none. At start,
//! the temporaries that ended processes left in the temporary directory are removed.

use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
use signal_hook::iterator::Signals;

/// Install the handler thread, and remove what processes that could not clean up (SIGKILL) left
/// in the temporary directory (their spill directories).
pub(super) fn install() {
    raysplat::io::temporaries::remove_stale(&std::env::temp_dir());
    let Ok(mut signals) = Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
        eprintln!("warning: cannot handle SIGINT/SIGTERM/SIGHUP; an interrupted command may leave temporary files");
        return;
    };
    std::thread::spawn(move || {
        if let Some(sig) = signals.forever().next() {
            raysplat::io::temporaries::clean_up_all();
            // _exit: no destructors or atexit handlers run while other threads are mid-work
            signal_hook::low_level::exit(128 + sig);
        }
    });
}
