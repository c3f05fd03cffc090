//! Progress of a long command: a bar on a terminal; anywhere else (a pipe, a CI log) a line
//! per step with the elapsed time, at most one every [`LINE_EVERY`] plus the last, so a log
//! shows where a long run is without a line per frame.

use std::io::IsTerminal as _;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

use dynotraj_eval::loading::LoadProgress;
use dynotraj_sources::on_step::OnStep;

/// Least time between two plain lines (the last step always gets one).
pub const LINE_EVERY: Duration = Duration::from_secs(10);

/// Set by `--quiet`: no bars and no lines.
static QUIET: AtomicBool = AtomicBool::new(false);

/// Silences every progress made from now on (`--quiet`).
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

/// A bar on a terminal, paced lines elsewhere. Shared by reference across worker threads.
#[derive(Debug)]
pub struct Progress {
    bar: ProgressBar,
    what: String,
    start: Instant,
    /// When the last plain line was printed; `None` on a terminal (the bar shows everything).
    last_line: Option<Mutex<Option<Instant>>>,
}

impl Progress {
    /// Progress over `len` steps of `what` (0: the length is set later).
    #[must_use]
    pub fn new(len: u64, what: &str) -> Self {
        if QUIET.load(Ordering::Relaxed) {
            return Self::silent(len, what);
        }
        Self::with_terminal(len, what, std::io::stderr().is_terminal())
    }

    /// Progress that shows nothing.
    fn silent(len: u64, what: &str) -> Self {
        let bar = ProgressBar::hidden();
        bar.set_length(len);
        Self { bar, what: what.to_string(), start: Instant::now(), last_line: None }
    }

    fn with_terminal(len: u64, what: &str, terminal: bool) -> Self {
        let bar = if terminal { ProgressBar::new(len) } else { ProgressBar::hidden() };
        bar.set_length(len);
        bar.set_style(
            ProgressStyle::with_template(&format!("{what} {{bar:30}} {{pos}}/{{len}} {{msg}} [{{elapsed}}]"))
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        Self { bar, what: what.to_string(), start: Instant::now(), last_line: (!terminal).then(|| Mutex::new(None)) }
    }

    /// Says what is being worked on now.
    pub fn set_message(&self, msg: impl Into<std::borrow::Cow<'static, str>>) {
        self.bar.set_message(msg);
    }

    /// `n` more steps done.
    pub fn inc(&self, n: u64) {
        self.bar.inc(n);
        self.line();
    }

    /// The total number of steps.
    pub fn set_length(&self, len: u64) {
        self.bar.set_length(len);
    }

    /// Steps done, set outright.
    pub fn set_position(&self, pos: u64) {
        self.bar.set_position(pos);
        self.line();
    }

    /// Steps done.
    #[must_use]
    pub fn position(&self) -> u64 {
        self.bar.position()
    }

    /// Removes the bar; off a terminal, says how long the whole took.
    pub fn finish_and_clear(&self) {
        // Read first: finishing sets the bar's position to its length.
        let done = self.position();
        self.bar.finish_and_clear();
        if self.last_line.is_some() {
            eprintln!("[{:>6.0} s] {} done: {done} steps", self.start.elapsed().as_secs_f64(), self.what);
        }
    }

    /// Off a terminal: a line now if the last was [`LINE_EVERY`] ago or this is the last step.
    fn line(&self) {
        let Some(last) = &self.last_line else { return };
        let Ok(mut last) = last.lock() else { return };
        let (pos, len) = (self.bar.position(), self.bar.length().unwrap_or(0));
        let now = Instant::now();
        let due = last.is_none_or(|t| now.duration_since(t) >= LINE_EVERY) || (len > 0 && pos >= len);
        if due {
            *last = Some(now);
            let msg = self.bar.message();
            let sep = if msg.is_empty() { "" } else { " " };
            // A length of 0 is not known yet: the count alone.
            let of = if len > 0 { format!("/{len}") } else { String::new() };
            eprintln!("[{:>6.0} s] {} {pos}{of}{sep}{msg}", self.start.elapsed().as_secs_f64(), self.what);
        }
    }

    /// A hook for a library loop that sets this progress to the steps it reports done.
    #[must_use]
    pub fn hook(self: &Arc<Self>) -> OnStep {
        let me = Arc::clone(self);
        OnStep::new(move |done| me.set_position(done))
    }

    /// Whether plain lines are printed (not a terminal).
    #[must_use]
    pub const fn is_plain(&self) -> bool {
        self.last_line.is_some()
    }
}

/// Progress on stderr: a bar on a terminal, paced lines with the elapsed time elsewhere.
#[must_use]
pub fn progress(len: u64, what: &str) -> Progress {
    Progress::new(len, what)
}

/// The bar of a command's loading ([`LoadProgress`]), made when the loading starts.
#[derive(Debug, Default)]
pub struct LoadBar(OnceLock<Progress>);

impl LoadProgress for LoadBar {
    fn loading(&self, drives: usize, estimating: bool) {
        let _ = self.0.set(progress(drives as u64, if estimating { "loading and estimating" } else { "loading" }));
    }

    fn loaded(&self, name: &str, ok: bool) {
        if let Some(bar) = self.0.get() {
            bar.set_message(format!("sequence {name} {}", if ok { "loaded" } else { "failed" }));
            bar.inc(1);
        }
    }

    fn finished(&self) {
        if let Some(bar) = self.0.get() {
            bar.finish_and_clear();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn off_a_terminal_the_first_and_last_steps_are_due_and_the_rest_paced() {
        let p = Progress::with_terminal(1000, "frames", false);
        assert!(p.is_plain());
        p.inc(1);
        let first = p.last_line.as_ref().and_then(|m| *m.lock().unwrap());
        assert!(first.is_some(), "the first step prints");
        for _ in 0..998 {
            p.inc(1);
        }
        assert_eq!(p.last_line.as_ref().and_then(|m| *m.lock().unwrap()), first, "no line within LINE_EVERY");
        p.inc(1);
        assert_ne!(p.last_line.as_ref().and_then(|m| *m.lock().unwrap()), first, "the last step prints");
        assert_eq!(p.position(), 1000);
        assert!(!Progress::with_terminal(3, "x", true).is_plain());
    }
}
