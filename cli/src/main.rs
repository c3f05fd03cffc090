//! The `dynotraj` command.

use std::io::Write as _;

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

/// The exit code of a command whose reader closed its standard output early (`| head`): what a
/// process killed by SIGPIPE reports, 128 + 13.
const CLOSED_PIPE_EXIT: u8 = 141;

/// Whether `e` comes of a reader that closed the output pipe.
fn closed_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| c.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe))
}

/// Makes a failed write to standard output or error an exit, not a panic: Rust's `print!`
/// family panics when the write fails, wherever it is called. A reader that closed the pipe
/// ends the command quietly with [`CLOSED_PIPE_EXIT`]; any other failure (a full disk) is
/// said on standard error, if that still works, and exits 1.
fn exit_on_output_errors() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let message = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or_default();
        if message.starts_with("failed printing to std") {
            if message.contains("Broken pipe") {
                std::process::exit(i32::from(CLOSED_PIPE_EXIT));
            }
            let what = message.trim_start_matches("failed printing to ");
            let _ = writeln!(std::io::stderr(), "error: writing to {what}");
            std::process::exit(1);
        }
        default(info);
    }));
}

/// Prints what clap has to say instead of running (help, version, a usage error) through the
/// same checks as every other write: clap's own printing ignores a failed write and exits 0.
fn clap_exit(e: &clap::Error) -> std::process::ExitCode {
    use std::io::IsTerminal as _;
    let (written, what) = if e.use_stderr() {
        let text = if std::io::stderr().is_terminal() { e.render().ansi().to_string() } else { e.render().to_string() };
        (std::io::stderr().write_all(text.as_bytes()), "stderr")
    } else {
        let text = if std::io::stdout().is_terminal() { e.render().ansi().to_string() } else { e.render().to_string() };
        (std::io::stdout().write_all(text.as_bytes()).and_then(|()| std::io::stdout().flush()), "stdout")
    };
    match written {
        Ok(()) => std::process::ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(1)),
        Err(io) if io.kind() == std::io::ErrorKind::BrokenPipe => std::process::ExitCode::from(CLOSED_PIPE_EXIT),
        Err(io) => {
            let _ = writeln!(std::io::stderr(), "error: writing to {what}: {io}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn main() -> std::process::ExitCode {
    one_compute_thread();
    exit_on_output_errors();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return clap_exit(&e),
    };
    let mut logger = env_logger::Builder::new();
    logger.filter_level(cli.log_level());
    if let Ok(filters) = std::env::var("RUST_LOG") {
        logger.parse_filters(&filters);
    }
    logger.init();
    if !cli.command.stops_on_signal()
        && let Err(e) = dynotraj_cli::interrupt::end_on_signal(cli.command.name())
    {
        eprintln!("error: {e:#}");
        return std::process::ExitCode::FAILURE;
    }
    match run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) if closed_pipe(&e) => std::process::ExitCode::from(CLOSED_PIPE_EXIT),
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
