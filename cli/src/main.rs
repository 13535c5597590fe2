//! The `raysplat` command line ([`raysplat_cli`]).

fn main() {
    quiet_on_broken_pipe();
    std::process::exit(raysplat_cli::run());
}

/// `raysplat compare … | head` closes stdout early: `println!` then panics with "failed printing to
/// stdout: Broken pipe". Exit quietly with the shell's SIGPIPE status instead, as C tools do; every
/// other panic reaches the default hook.
fn quiet_on_broken_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let msg = info.payload().downcast_ref::<String>().map(String::as_str).or_else(|| info.payload().downcast_ref::<&str>().copied()).unwrap_or("");
        if msg.contains("failed printing to stdout") && msg.contains("Broken pipe") {
            std::process::exit(141);
        }
        default(info)
    }));
}
