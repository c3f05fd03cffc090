//! The `benchmark` command as one request: load the drives, deal them into folds, train every
//! fold with every seed (or one shard of the trainings) and write the report folder.

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::benchmark::{Shard, run_benchmark, sequence_groups, train_shard};
use super::benchmark_report::{benchmark_report, benchmark_sections};
use super::folds::TrainProgress;
use super::report::{Section, write_report};
use super::request::StopFromNow;
use super::{ExperimentConfig, fold_specs};
use crate::loading::{DataRequest, LoadProgress};

/// One run of the generalisation benchmark.
#[derive(Debug)]
pub struct BenchmarkRequest<'a> {
    /// Where the drives are and how to read them.
    pub data: DataRequest,
    /// The sequences loaded (all when empty); each is held out once.
    pub sequences: &'a [String],
    /// Folds the sorted sequences are dealt into ([`sequence_groups`]).
    pub groups: usize,
    /// Seeds each fold is trained with.
    pub seeds: &'a [u64],
    /// Only this part of the trainings, into the fold cache; no report.
    pub shard: Option<Shard>,
    /// The run's settings; its folds are made from the loaded sequences.
    pub config: ExperimentConfig,
    /// Where estimated tracks are kept.
    pub estimate_cache: Option<PathBuf>,
    /// The report folder and the command line it names, if one is written.
    pub report: Option<(&'a Path, String)>,
    /// Called once the drives are loaded ([`super::request::ExperimentRequest::stop_from_now`]).
    pub stop_from_now: Option<StopFromNow>,
}

/// What a run of the benchmark has to show.
#[derive(Debug)]
pub enum BenchmarkOutput {
    /// One shard's trainings are in the fold cache.
    Shard {
        /// The shard run.
        shard: Shard,
        /// Trainings this shard holds.
        mine: usize,
        /// Trainings of every shard.
        all: usize,
    },
    /// The whole benchmark.
    Report {
        /// The report's tables ([`benchmark_sections`]); the first two are its summary.
        sections: Vec<Section>,
        /// Loading and estimating, seconds.
        loading_seconds: f64,
        /// Training and scoring, seconds.
        training_seconds: f64,
        /// The whole run, seconds.
        seconds: f64,
        /// The report written, or why it could not be.
        report: Option<anyhow::Result<PathBuf>>,
    },
}

/// Runs the benchmark ([`run_benchmark`], or [`train_shard`] for a shard) and writes its
/// report.
///
/// # Errors
/// A shard without a fold cache (before any loading), loading or training errors, fewer than
/// two folds, named. A report that cannot be written is in [`BenchmarkOutput::Report`].
pub fn benchmark<P: LoadProgress + TrainProgress>(
    request: &BenchmarkRequest<'_>,
    progress: &P,
) -> anyhow::Result<BenchmarkOutput> {
    anyhow::ensure!(
        request.shard.is_none() || request.config.cache.is_some(),
        "--shard: needs a fold cache (--out DIR, without --no-cache): it is where the shards' folds meet"
    );
    let start = Instant::now();
    let sequences =
        request.data.load(request.sequences, &request.config.arms, request.estimate_cache.clone(), progress)?;
    let loading_seconds = start.elapsed().as_secs_f64();
    let ids: Vec<String> = sequences.iter().map(|s| s.id.clone()).collect();
    let folds = sequence_groups(&ids, request.groups);
    anyhow::ensure!(
        folds.len() >= 2,
        "--folds: the benchmark needs at least two folds, found {} sequence(s) for {} fold(s)",
        ids.len(),
        request.groups
    );
    let stop = request.stop_from_now.map(|f| f()).transpose()?;
    let config = ExperimentConfig { folds, stop, ..request.config.clone() }.with_present_agents(&sequences);
    let trainings = fold_specs(&config, request.seeds).len();
    if let Some(shard) = request.shard {
        progress.training(trainings.div_ceil(shard.count));
        let (mine, all) = train_shard(&sequences, &config, request.seeds, shard, progress)?;
        return Ok(BenchmarkOutput::Shard { shard, mine, all });
    }
    progress.training(trainings);
    let result = run_benchmark(&sequences, &config, request.seeds, progress)?;
    let seconds = start.elapsed().as_secs_f64();
    let sections = benchmark_sections(&result, &config, &sequences, (&request.data.rule, request.seeds))?;
    let report = request.report.as_ref().map(|(dir, command)| {
        let times = (command.clone(), loading_seconds, seconds);
        let report = benchmark_report(dir, sections.clone(), &result, &config, &sequences, times)?;
        write_report(dir, &report)
    });
    Ok(BenchmarkOutput::Report { sections, loading_seconds, training_seconds: result.seconds, seconds, report })
}
