//! The `log` facade on the MCU: records go to the semihosting console (QEMU's stdout) as one
//! terse line each, `L INSTRUCTIONS TARGET: MESSAGE`, e.g.
//! `I 1234560 edge: model accepted len=20480`: the level's letter (E, W, I, D, T), the
//! instructions executed since the clock started ([`crate::clock`]), the crate that logged
//! (`dynotraj_` left off) and the message.
//!
//! Which levels exist in the image is chosen at build time by the firmware's features
//! (`log-info`, the default; `log-debug`; `log-off`), through the `log` crate's
//! `release_max_level_*` features: records above that level are not compiled in at all.

use cortex_m_semihosting::hprintln;
use log::{Level, LevelFilter, Log, Metadata, Record};

use crate::clock;

/// The firmware's logger.
struct Semihosting;

static LOGGER: Semihosting = Semihosting;

impl Log for Semihosting {
    fn enabled(&self, metadata: &Metadata<'_>) -> bool {
        metadata.level() <= log::max_level()
    }

    fn log(&self, record: &Record<'_>) {
        if !self.enabled(record.metadata()) {
            return;
        }
        let letter = match record.level() {
            Level::Error => 'E',
            Level::Warn => 'W',
            Level::Info => 'I',
            Level::Debug => 'D',
            Level::Trace => 'T',
        };
        let target = record.target();
        let krate = target.split("::").next().unwrap_or(target);
        let krate = krate.strip_prefix("dynotraj_").unwrap_or(krate);
        hprintln!("{} {} {}: {}", letter, clock::ticks() * clock::INSTRUCTIONS_PER_TICK, krate, record.args());
    }

    fn flush(&self) {}
}

/// Installs the logger at every level the build kept. Call once the clock has started (its
/// timestamps count from there); a second call changes nothing.
pub fn init() {
    if log::set_logger(&LOGGER).is_ok() {
        log::set_max_level(log::STATIC_MAX_LEVEL);
    }
}

/// The most verbose level this build logs at.
#[must_use]
pub fn level() -> LevelFilter {
    log::STATIC_MAX_LEVEL
}
