//! An interrupted run leaves nothing behind: on SIGINT (Ctrl-C), SIGTERM or SIGHUP, a
//! thread of its own removes the run's staging folder and temporary files
//! (`ptsa_host_sim::output::fs::abandon`) and exits with 128 + the signal's number, as a
//! shell reports a process killed by it. What the run was replacing (an earlier report, a
//! file) is left as it was.

/// Install the handler (once, at start). Where signals cannot be caught, nothing happens.
#[cfg(unix)]
pub fn clean_up_on_signals() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
        return;
    };
    std::thread::spawn(move || {
        if let Some(sig) = signals.forever().next() {
            // Held until the process exits: nothing is renamed into place after this.
            let _held = ptsa_host_sim::output::fs::abandon();
            let name = match sig {
                SIGINT => "SIGINT",
                SIGTERM => "SIGTERM",
                _ => "SIGHUP",
            };
            eprintln!(
                "\ninterrupted by {name}: the unfinished outputs were removed; what they were to replace is as it was"
            );
            std::process::exit(128 + sig);
        }
    });
}

/// Install the handler: not on this platform.
#[cfg(not(unix))]
pub fn clean_up_on_signals() {}
