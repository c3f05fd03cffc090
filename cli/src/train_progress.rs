//! Progress of a run of folds: the loading's bar, then, for the training stage with folds on
//! several threads, one bar for the folds done and one per fold in training (on a terminal); on
//! anything else, one line per finished fold with the elapsed time, so a log shows where a long
//! run is.

use std::collections::BTreeMap;
use std::io::IsTerminal as _;
use std::sync::{Mutex, OnceLock};
use std::time::Instant;

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

use super::progress::LoadBar;
use dynotraj_eval::experiment::FoldReport;
use dynotraj_eval::experiment::folds::TrainProgress;
use dynotraj_eval::loading::LoadProgress;
use dynotraj_train::Event;

/// The bars of one run: its loading, then its training stage.
#[derive(Default)]
pub struct TrainBars {
    loading: LoadBar,
    training: OnceLock<Stage>,
}

/// The bars of the training stage, made when it starts.
struct Stage {
    multi: MultiProgress,
    overall: ProgressBar,
    running: Mutex<BTreeMap<String, ProgressBar>>,
    start: Instant,
    terminal: bool,
}

impl Stage {
    fn new(folds: usize) -> Self {
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
}

impl TrainBars {
    /// Removes the bars.
    pub fn finish(&self) {
        self.loading.finished();
        if let Some(stage) = self.training.get() {
            stage.overall.finish_and_clear();
            let _ = stage.multi.clear();
        }
    }
}

impl LoadProgress for TrainBars {
    fn loading(&self, drives: usize, estimating: bool) {
        self.loading.loading(drives, estimating);
    }

    fn loaded(&self, name: &str, ok: bool) {
        self.loading.loaded(name, ok);
    }

    fn finished(&self) {
        self.loading.finished();
    }
}

impl TrainProgress for TrainBars {
    fn training(&self, folds: usize) {
        let _ = self.training.set(Stage::new(folds));
    }

    fn event(&self, label: &str, event: Event) {
        let Event::Step { step, total, loss } = event else { return };
        let Some(stage) = self.training.get() else { return };
        let Ok(mut running) = stage.running.lock() else { return };
        let bar = running.entry(label.to_string()).or_insert_with(|| {
            let b = stage.multi.add(ProgressBar::new(total as u64));
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
        let Some(stage) = self.training.get() else { return };
        if let Ok(mut running) = stage.running.lock()
            && let Some(b) = running.remove(label)
        {
            b.finish_and_clear();
            stage.multi.remove(&b);
        }
        stage.overall.inc(1);
        let line = format!(
            "{label}: epoch {}, val ADE {:.3} m (cv {:.3} m), {:.0} s{}",
            r.best_epoch,
            r.val_ade,
            r.val_cv_ade,
            r.seconds,
            if r.cached { " (cached)" } else { "" }
        );
        if stage.terminal {
            stage.overall.set_message(line);
        } else {
            eprintln!(
                "[{:>6.0} s] fold {}/{} {line}",
                stage.start.elapsed().as_secs_f64(),
                stage.overall.position(),
                stage.overall.length().unwrap_or(0)
            );
        }
    }
}
