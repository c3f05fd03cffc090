//! The log level that a program's `-q` and `-v` flags ask for, one mapping for every program of
//! the project (the `dynotraj` command and the host build of the edge).

/// `quiet`: errors only; otherwise warnings, and each `verbose` step one level more (info,
/// debug, trace).
#[must_use]
pub const fn from_flags(quiet: bool, verbose: u8) -> log::LevelFilter {
    match (quiet, verbose) {
        (true, _) => log::LevelFilter::Error,
        (false, 0) => log::LevelFilter::Warn,
        (false, 1) => log::LevelFilter::Info,
        (false, 2) => log::LevelFilter::Debug,
        (false, _) => log::LevelFilter::Trace,
    }
}
