//! The `experiment` command as one request: load the drives, check the objects the figures
//! draw, train and score the folds of the test sequences, and write the report folder.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use super::figures::{ObjectChoice, subjects};
use super::folds::TrainProgress;
use super::sections::{ReportFolder, RunSettings, write_report_folder};
use super::{ExperimentConfig, ExperimentResult, fold_specs, run_experiment};
use crate::loading::{DataRequest, LoadProgress};
use dynotraj_bag::record::RecordingEncoding;
use dynotraj_sources::sequence::SequenceTracks;

/// Where an experiment's report goes.
#[derive(Debug, Clone)]
pub struct ReportRequest<'a> {
    /// The report folder.
    pub dir: &'a Path,
    /// Where the test sequences' recordings go, if anywhere.
    pub record: Option<&'a Path>,
    /// The recordings' encoding.
    pub record_encoding: RecordingEncoding,
    /// The command line the report names.
    pub command: String,
}

/// One run of the paper's leave-one-sequence-out experiment.
#[derive(Debug)]
pub struct ExperimentRequest<'a> {
    /// Where the drives are and how to read them.
    pub data: DataRequest,
    /// The sequences loaded (all when empty).
    pub sequences: &'a [String],
    /// The test sequences, each held out in turn.
    pub tests: Vec<String>,
    /// The objects the per-object figures draw.
    pub objects: &'a [ObjectChoice],
    /// The run's settings; its folds are made from [`Self::tests`].
    pub config: ExperimentConfig,
    /// Where estimated tracks are kept.
    pub estimate_cache: Option<PathBuf>,
    /// The report folder, if one is written.
    pub report: Option<ReportRequest<'a>>,
    /// Called once the drives are loaded; the flag it returns stops the run between folds
    /// ([`ExperimentConfig::stop`]), so that a signal during the loading still ends the
    /// process at once.
    pub stop_from_now: Option<StopFromNow>,
}

/// Makes the flag that stops a run between folds from the moment it is called.
pub type StopFromNow = fn() -> anyhow::Result<Arc<AtomicBool>>;

/// What a run of the experiment has to show.
#[derive(Debug)]
pub struct ExperimentOutput {
    /// The tables and folds, timed over the whole run (loading included).
    pub result: ExperimentResult,
    /// One line per fold.
    pub summary: String,
    /// What is said of the report files written, or why they could not be.
    pub report: anyhow::Result<Vec<String>>,
    /// The sequences loaded.
    pub sequences: Vec<SequenceTracks>,
}

/// Runs the experiment ([`run_experiment`]) and writes its report folder.
///
/// # Errors
/// Loading or training errors, an object to draw that no loaded sequence has, named. A report
/// that cannot be written is in [`ExperimentOutput::report`], after the tables are made.
pub fn experiment<P: LoadProgress + TrainProgress>(
    request: &ExperimentRequest<'_>,
    progress: &P,
) -> anyhow::Result<ExperimentOutput> {
    let start = Instant::now();
    let sequences =
        request.data.load(request.sequences, &request.config.arms, request.estimate_cache.clone(), progress)?;
    // A bad object to draw fails before the folds are trained, not after.
    subjects(request.objects, &sequences, &request.data.rule)?;
    let stop = request.stop_from_now.map(|f| f()).transpose()?;
    let config = ExperimentConfig {
        folds: ExperimentConfig::one_sequence_folds(&request.tests),
        stop,
        ..request.config.clone()
    }
    .with_present_agents(&sequences);
    let loading_seconds = start.elapsed().as_secs_f64();
    progress.training(fold_specs(&config, &[config.hyper.seed]).len());
    let mut result = run_experiment(&sequences, &config, progress)?;
    result.seconds = start.elapsed().as_secs_f64();
    result.loading_seconds = loading_seconds;
    let summary = result.fold_summary();
    let report = match &request.report {
        None => Ok(Vec::new()),
        Some(report) => write_report(request, report, &config, &result, &sequences),
    };
    Ok(ExperimentOutput { result, summary, report, sequences })
}

fn write_report(
    request: &ExperimentRequest<'_>,
    report: &ReportRequest<'_>,
    config: &ExperimentConfig,
    result: &ExperimentResult,
    sequences: &[SequenceTracks],
) -> anyhow::Result<Vec<String>> {
    let run = RunSettings {
        arms: &config.arms,
        render_scale: request.data.estimate.render_scale,
        jobs: request.data.jobs,
        dt: request.data.dt,
        history_frames: config.prior.history_frames(),
    };
    let folder = ReportFolder {
        dir: report.dir,
        record: report.record,
        record_encoding: report.record_encoding,
        command: report.command.clone(),
        objects: request.objects,
        tests: &request.tests,
    };
    write_report_folder(&folder, &run, result, sequences, &request.data.rule)
}
