//! Ctrl-C and SIGTERM. Commands that can stop part-way and keep what they did (stream, soak,
//! experiment, benchmark) take them as a request to stop ([`stop_flag`]): they finish what they
//! have and exit non-zero, and a second signal ends them at once. Every other command is ended at
//! once by the first, saying so ([`end_on_signal`]): it writes its outputs when they are
//! complete (or under a temporary name, or, for a tracks file, with a closing mark readers
//! check), so nothing it leaves looks complete.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::Context as _;

/// A flag that the first SIGINT or SIGTERM sets; the second ends the process with exit code 130.
///
/// # Errors
/// The handlers cannot be installed.
pub fn stop_flag() -> anyhow::Result<Arc<AtomicBool>> {
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        // Registered first, so it sees the flag before this signal sets it: only a repeat exits.
        signal_hook::flag::register_conditional_shutdown(signal, 130, Arc::clone(&stop))
            .context("installing a signal handler")?;
        signal_hook::flag::register(signal, Arc::clone(&stop)).context("installing a signal handler")?;
    }
    Ok(stop)
}

/// Ends the process on the first SIGINT or SIGTERM with exit code 130, saying on standard
/// error that `command` was interrupted and what that leaves.
///
/// # Errors
/// The handler cannot be installed.
pub fn end_on_signal(command: &'static str) -> anyhow::Result<()> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM]).context("installing a signal handler")?;
    std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || {
            if let Some(signal) = signals.forever().next() {
                let name = if signal == SIGINT { "SIGINT" } else { "SIGTERM" };
                let _ = std::io::Write::write_all(
                    &mut std::io::stderr(),
                    format!(
                        "error: dynotraj {command} interrupted by {name} before it finished: its outputs are incomplete \
                         (finished files and caches are kept)\n"
                    )
                    .as_bytes(),
                );
                std::process::exit(130);
            }
        })
        .context("starting the signal thread")?;
    Ok(())
}
