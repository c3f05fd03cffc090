//! The `dynotraj` command.

use clap::Parser as _;
use dynotraj_host::cli::{Cli, run};

fn main() -> std::process::ExitCode {
    dynotraj_host::jobs::one_thread_per_job();
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    match run(Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
