//! The `dynotraj` command.

use clap::Parser as _;
use dynotraj_cli::{Cli, run};

/// Sets `RAYON_NUM_THREADS=1` for this process when it is unset. candle sizes its kernels'
/// threads from that variable, read from the environment at every matrix product; unset, each
/// product also reads /proc and /sys to count cores. One thread per training is fastest for this
/// small network (measured with the command in docs/decisions.md: 1.8x the time unset, about 3x
/// with candle's own pool), and `--jobs` spreads folds over the cores instead.
fn one_compute_thread() {
    if std::env::var_os("RAYON_NUM_THREADS").is_none() {
        // SAFETY: the first thing main does, before this process has any other thread, so
        // nothing reads or writes the environment at the same time.
        unsafe { std::env::set_var("RAYON_NUM_THREADS", "1") };
    }
}

fn main() -> std::process::ExitCode {
    one_compute_thread();
    let cli = Cli::parse();
    let mut logger = env_logger::Builder::new();
    logger.filter_level(cli.log_level());
    if let Ok(filters) = std::env::var("RUST_LOG") {
        logger.parse_filters(&filters);
    }
    logger.init();
    match run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
