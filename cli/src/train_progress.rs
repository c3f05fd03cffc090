//! Progress of a training stage with folds on several threads: one bar for the folds done and
//! one per fold in training (on a terminal); on anything else, one line per finished fold with
//! the elapsed time, so a log shows where a long run is.

use std::collections::BTreeMap;
use std::io::IsTerminal as _;
use std::sync::Mutex;
use std::time::Instant;

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

use dynotraj_eval::experiment::FoldReport;
use dynotraj_eval::experiment::folds::TrainProgress;
use dynotraj_train::Event;

/// The bars of one training stage.
pub struct TrainBars {
    multi: MultiProgress,
    overall: ProgressBar,
    running: Mutex<BTreeMap<String, ProgressBar>>,
    start: Instant,
    terminal: bool,
}

impl TrainBars {
    /// Bars for `folds` folds.
    #[must_use]
    pub fn new(folds: usize) -> Self {
        let terminal = std::io::stderr().is_terminal();
        let multi = MultiProgress::with_draw_target(if terminal {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        });
        let overall = multi.add(ProgressBar::new(folds as u64));
        overall.set_style(
            ProgressStyle::with_template("folds {bar:30} {pos}/{len} [{elapsed}] {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        Self { multi, overall, running: Mutex::new(BTreeMap::new()), start: Instant::now(), terminal }
    }

    /// Removes the bars.
    pub fn finish(&self) {
        self.overall.finish_and_clear();
        let _ = self.multi.clear();
    }
}

impl TrainProgress for TrainBars {
    fn event(&self, label: &str, event: Event) {
        let Event::Step { step, total, loss } = event else { return };
        let Ok(mut running) = self.running.lock() else { return };
        let bar = running.entry(label.to_string()).or_insert_with(|| {
            let b = self.multi.add(ProgressBar::new(total as u64));
            b.set_style(
                ProgressStyle::with_template("  {msg:32} {bar:30} {pos}/{len}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            b
        });
        bar.set_length(total as u64);
        bar.set_position(step as u64);
        bar.set_message(format!("{label} loss {loss:.2}"));
    }

    fn done(&self, label: &str, r: &FoldReport) {
        if let Ok(mut running) = self.running.lock()
            && let Some(b) = running.remove(label)
        {
            b.finish_and_clear();
            self.multi.remove(&b);
        }
        self.overall.inc(1);
        let line = format!(
            "{label}: epoch {}, val ADE {:.3} m (cv {:.3} m), {:.0} s{}",
            r.best_epoch,
            r.val_ade,
            r.val_cv_ade,
            r.seconds,
            if r.cached { " (cached)" } else { "" }
        );
        if self.terminal {
            self.overall.set_message(line);
        } else {
            eprintln!(
                "[{:>6.0} s] fold {}/{} {line}",
                self.start.elapsed().as_secs_f64(),
                self.overall.position(),
                self.overall.length().unwrap_or(0)
            );
        }
    }
}
