//! The `dynotraj` command.

use clap::Parser as _;
use dynotraj_host::cli::{Cli, run};

/// candle's CPU kernels run this small network fastest on one thread (measured: a training
/// fold is about 3x slower with the default pool on 2 cores), and its pools read
/// RAYON_NUM_THREADS only from the environment, which safe code cannot set for the running
/// process. So when it is unset, the command runs itself again with it set to 1.
fn with_one_compute_thread() -> Option<std::process::ExitCode> {
    if std::env::var_os("RAYON_NUM_THREADS").is_some() {
        return None;
    }
    let exe = std::env::current_exe().ok()?;
    let status = std::process::Command::new(exe)
        .args(std::env::args_os().skip(1))
        .env("RAYON_NUM_THREADS", "1")
        .status()
        .ok()?;
    Some(std::process::ExitCode::from(u8::try_from(status.code().unwrap_or(1)).unwrap_or(1)))
}

fn main() -> std::process::ExitCode {
    if let Some(code) = with_one_compute_thread() {
        return code;
    }
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    match run(Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
