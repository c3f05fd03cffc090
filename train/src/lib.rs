//! Host-side training of the trajectory predictor of `dynotraj_core::model::arch`, with candle.
//!
//! - [`prior_fit`]: the motion prior's settings, chosen on a fold's training sequences.
//! - [`dataset`]: samples (features by core's own code) from eligible runs through a source.
//! - [`batch`]: mini-batches as tensors.
//! - [`bootstrap`]: ratio intervals by resampling whole runs (epoch selection, reports).
//! - [`params`], [`cells`], [`fused`]: seeded parameters; LSTM/GRU cells and linear layers in
//!   PyTorch's naming and gate order; the GRU gates as one fused operation.
//! - [`dynamics`]: the unicycle rollout (as inference computes it) and covariance propagation.
//! - [`model`]: the network, its training-only future encoder and q(z|x,y), the unimodal
//!   forecast.
//! - [`loss`]: the CVAE objective and its documented departures from Trajectron++.
//! - [`fit`]: the optimisation loop with early stopping on the validation ADE.
//! - [`export`]: the model blob (f32 or int8) and the safetensors checkpoint (format there).
//!
//! [`train_fold`] runs one leave-sequences-out fold: the motion prior's settings chosen on every
//! sequence but the excluded ones, samples over that prior, a seeded split for validation,
//! training of the residual, and the best epoch's weights in a [`TrainedModel`].
//!
//! Speed: run with `RAYON_NUM_THREADS=1` in the environment (the `dynotraj` command sets it for
//! itself). The tensors are small; candle's kernels split over threads make training about
//! three times slower on 2 cores, and with the variable unset candle counts the cores from
//! /proc and /sys at every matrix product.

pub mod batch;
pub mod bootstrap;
pub mod cells;
pub mod dataset;
pub mod dynamics;
pub mod export;
pub mod fit;
pub mod fused;
pub mod loss;
pub mod model;
pub mod params;
pub mod prior_fit;
#[cfg(test)]
pub(crate) mod synthetic;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context as _;
use candle_nn::VarMap;
use dynotraj_core::limits::PAPER_FRAME_RATE_HZ;
use dynotraj_core::model::arch::Dims;
use dynotraj_core::model::blob::Precision;
use dynotraj_core::model::features::FeatureScales;
use dynotraj_core::predict::{Dynamics, PriorSettings};

pub use dataset::{Sample, Split, sample_at, sample_over, sequence_samples, split_by_run, split_by_sequence};
use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::{EligibilityRule, Source};
pub use fit::{DEFAULT_SHRINK, EpochReport, Event, Hyper};
pub use model::Network;
pub use prior_fit::PriorObjective;

/// Default share of a fold's training runs held out for early stopping and model selection
/// (chosen on the tuning folds: docs/decisions.md).
pub const DEFAULT_VALIDATION_FRACTION: f32 = 0.3;

/// Whether validation holds out whole training sequences (see
/// [`TrainConfig::validate_on_sequences`]).
pub const DEFAULT_VALIDATE_ON_SEQUENCES: bool = true;

/// Seed of the validation split by default ([`TrainConfig::split_seed`]).
pub const DEFAULT_SPLIT_SEED: u64 = 1;

/// Whether reflected copies of the training instances are trained on by default.
pub const DEFAULT_MIRROR: bool = true;

/// How a fold's motion prior is set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PriorChoice {
    /// Chosen on the fold's training sequences through its source ([`prior_fit::tune_prior`])
    /// under the default [`PriorObjective`]: the default.
    Tuned,
    /// Chosen the same way under another objective.
    TunedFor(PriorObjective),
    /// Given; [`PriorSettings::OFF`] is the paper's setting (seven states, no prior).
    Fixed(PriorSettings),
}

impl PriorChoice {
    /// Past frames a forecast reads at most: the network's history and the prior's windows
    /// (every window the tuning may choose when it is tuned).
    #[must_use]
    pub fn history_frames(&self) -> usize {
        let prior = match self {
            Self::Tuned | Self::TunedFor(_) => dynotraj_core::limits::PRIOR_STATES,
            Self::Fixed(s) => s.states(),
        };
        prior.max(dynotraj_core::model::arch::MAX_STEPS) - 1
    }
}

/// One fold's training set-up.
#[derive(Debug, Clone)]
pub struct TrainConfig<'a> {
    /// Loaded sequences; every one not in `exclude` is trained on.
    pub sequences: &'a [SequenceTracks],
    /// Sequence ids held out (the fold's test sequences).
    pub exclude: Vec<String>,
    /// The trajectory source trained on (inputs and targets).
    pub source: Source,
    /// Frame period, seconds (the paper's 1/20).
    pub dt: f32,
    /// Which runs are eligible.
    pub rule: EligibilityRule,
    /// Network widths.
    pub dims: Dims,
    /// Optimisation settings; `hyper.seed` also seeds the initial weights and the split.
    pub hyper: Hyper,
    /// Share of the runs held out for early stopping.
    pub validation_fraction: f32,
    /// Hold out whole sequences for validation instead of runs drawn from every sequence.
    pub validate_on_sequences: bool,
    /// Seed of the validation split, apart from `hyper.seed`: the seed of a model is its
    /// weights and shuffling, the split is part of the fold (the same sequences judge every
    /// seed).
    pub split_seed: u64,
    /// Add every training sample's reflection ([`Sample::mirrored`]) to the training set (never
    /// to validation).
    pub mirror: bool,
    /// The motion prior the network's residual is added to.
    pub prior: PriorChoice,
    /// How the network's outputs move the forecast (vehicles: the unicycle), and so the agents
    /// trained on: the classes of `rule` that this dynamics forecasts
    /// ([`EligibilityRule::for_agents`]).
    pub dynamics: Dynamics,
    /// With no training instance at all, ship the untrained model (the prior alone, at the
    /// settings chosen on no data: [`PriorSettings::OFF`]) instead of failing. For agent types
    /// that some folds' training sequences do not hold (KITTI's few moving pedestrians).
    pub empty_ships_prior: bool,
}

impl<'a> TrainConfig<'a> {
    /// The defaults: the paper's 20 Hz, the default eligibility, the ECU widths,
    /// [`Hyper::default`], [`DEFAULT_VALIDATION_FRACTION`] and [`DEFAULT_MIRROR`].
    #[must_use]
    pub fn new(sequences: &'a [SequenceTracks], exclude: Vec<String>, source: Source) -> Self {
        Self {
            sequences,
            exclude,
            source,
            dt: 1.0 / PAPER_FRAME_RATE_HZ,
            rule: EligibilityRule::default(),
            dims: Dims::DEFAULT,
            hyper: Hyper::default(),
            validation_fraction: DEFAULT_VALIDATION_FRACTION,
            mirror: DEFAULT_MIRROR,
            validate_on_sequences: DEFAULT_VALIDATE_ON_SEQUENCES,
            split_seed: DEFAULT_SPLIT_SEED,
            prior: PriorChoice::Tuned,
            dynamics: Dynamics::Unicycle,
            empty_ships_prior: false,
        }
    }

    /// The eligibility of the agents trained: `rule`'s classes of `dynamics`.
    #[must_use]
    pub fn agent_rule(&self) -> EligibilityRule {
        self.rule.for_agents(self.dynamics)
    }

    /// The sequences trained on (every one not excluded).
    fn training_sequences(&self) -> Vec<&'a SequenceTracks> {
        self.sequences.iter().filter(|s| !self.exclude.contains(&s.id)).collect()
    }

    /// The fold's motion prior: given, or chosen on its training sequences.
    #[must_use]
    pub fn prior_settings(&self) -> PriorSettings {
        match self.prior {
            PriorChoice::Fixed(p) => p,
            PriorChoice::Tuned => self.tuned_prior(PriorObjective::default()),
            PriorChoice::TunedFor(objective) => self.tuned_prior(objective),
        }
    }

    fn tuned_prior(&self, objective: PriorObjective) -> PriorSettings {
        prior_fit::tune_prior(
            &prior_fit::prior_instances(&self.training_sequences(), self.source, self.dt, &self.agent_rule()),
            self.dt,
            objective,
        )
    }

    /// The fold's samples over motion prior `prior`, split by run (or by sequence, with
    /// `validate_on_sequences`), and the ids of the sequences they come from.
    #[must_use]
    pub fn samples(&self, prior: &PriorSettings) -> (Split, Vec<String>) {
        let mut per_sequence = Vec::new();
        let mut groups = 0;
        let mut used = Vec::new();
        let (rule, scales) = (self.agent_rule(), FeatureScales::of(self.dynamics));
        for seq in self.training_sequences() {
            let (samples, runs) = sequence_samples(seq, self.source, self.dt, &rule, groups, (prior, &scales));
            groups += runs;
            per_sequence.push(samples);
            used.push(seq.id.clone());
        }
        if self.validate_on_sequences {
            return (split_by_sequence(per_sequence, self.validation_fraction, self.split_seed), used);
        }
        (
            split_by_run(
                per_sequence.into_iter().flatten().collect(),
                groups,
                self.validation_fraction,
                self.split_seed,
            ),
            used,
        )
    }
}

/// What a fold's training did.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainReport {
    /// The seed of the restart kept ([`restart_seed`]).
    pub kept_seed: u64,
    /// Sequences trained on.
    pub sequences: Vec<String>,
    /// Training instances.
    pub train_instances: usize,
    /// Validation instances.
    pub val_instances: usize,
    /// Epochs run (early stopping may end before the maximum).
    pub epochs: usize,
    /// The epoch whose weights were kept.
    pub best_epoch: usize,
    /// Its validation ADE of the unimodal forecast, metres (after shrinking).
    pub best_val_ade: f32,
    /// The output shrink factor kept (1: none).
    pub shrink: f32,
    /// The best trained epoch's validation ADE over the prior's, with its run-bootstrap
    /// interval (when an epoch beat the prior and the gain was judged): the epoch is kept only
    /// when the interval's upper end is below 1.
    pub gain: Option<bootstrap::RatioInterval>,
    /// Validation ADE of the constant-velocity forecast, metres (the reference to beat).
    pub val_cv_ade: f32,
    /// Validation ADE of the motion prior alone (the untrained model), metres.
    pub val_prior_ade: f32,
    /// The motion prior's settings.
    pub prior: PriorSettings,
    /// Optimiser steps run.
    pub steps: usize,
    /// Wall-clock seconds of sample building and training.
    pub seconds: f32,
    /// Every epoch.
    pub history: Vec<EpochReport>,
}

/// A trained network with its variables.
pub struct TrainedModel {
    /// The network (its tensors are the variables in `vars`).
    pub network: Network,
    /// Every variable, by name.
    pub vars: VarMap,
    /// Frame period it was trained at, seconds.
    pub dt: f32,
    /// The motion prior its output is added to.
    pub prior: PriorSettings,
    /// What training did.
    pub report: TrainReport,
}

impl std::fmt::Debug for TrainedModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TrainedModel")
            .field("dims", &self.network.dims)
            .field("dt", &self.dt)
            .field("report", &self.report)
            .finish_non_exhaustive()
    }
}

/// The files [`TrainedModel::save`] wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SavedFiles {
    /// The f32 blob.
    pub f32_blob: PathBuf,
    /// The int8 blob.
    pub int8_blob: PathBuf,
    /// The checkpoint.
    pub checkpoint: PathBuf,
}

impl SavedFiles {
    /// The CRC-64 (ECMA-182) of the f32 and of the int8 blob's files: the same data, settings
    /// and seed give the same bytes, so these identify the model. (Not CRC-32: a blob ends in
    /// its own CRC-32, and the CRC-32 of any such file is one constant.)
    ///
    /// # Errors
    /// A file that cannot be read, named.
    pub fn crc64(&self) -> anyhow::Result<[u64; 2]> {
        let crc64 = crc::Crc::<u64>::new(&crc::CRC_64_ECMA_182);
        let crc =
            |p: &Path| std::fs::read(p).map(|b| crc64.checksum(&b)).with_context(|| format!("reading {}", p.display()));
        Ok([crc(&self.f32_blob)?, crc(&self.int8_blob)?])
    }
}

impl TrainedModel {
    /// The model blob in `precision`.
    ///
    /// # Errors
    /// See [`export::to_blob`].
    pub fn blob(&self, precision: Precision) -> anyhow::Result<Vec<u8>> {
        Ok(export::to_blob(&self.network, &self.network.dims, precision, self.dt, &self.prior)?)
    }

    /// Writes `path` (f32 blob), `path.int8` (int8 blob) and `path.safetensors` (checkpoint).
    ///
    /// # Errors
    /// I/O errors, named.
    pub fn save(&self, path: &Path) -> anyhow::Result<SavedFiles> {
        let with = |ext: &str| {
            let mut p = path.as_os_str().to_owned();
            p.push(ext);
            PathBuf::from(p)
        };
        let files =
            SavedFiles { f32_blob: path.to_path_buf(), int8_blob: with(".int8"), checkpoint: with(".safetensors") };
        // Each file under a temporary name, renamed when whole: an interrupted save leaves no
        // blob that looks complete.
        dynotraj_formats::atomic::write_file(&files.f32_blob, self.blob(Precision::F32)?)
            .with_context(|| format!("writing {}", files.f32_blob.display()))?;
        dynotraj_formats::atomic::write_file(&files.int8_blob, self.blob(Precision::Int8)?)
            .with_context(|| format!("writing {}", files.int8_blob.display()))?;
        let partial = dynotraj_formats::atomic::partial_path(&files.checkpoint);
        export::save_checkpoint(&self.network, &self.vars, self.dt, &self.prior, &partial)
            .with_context(|| format!("writing {}", partial.display()))?;
        std::fs::rename(&partial, &files.checkpoint)
            .with_context(|| format!("renaming {} to {}", partial.display(), files.checkpoint.display()))?;
        Ok(files)
    }

    /// As [`TrainedModel::save`], with the blob at `path` itself in `precision` (`path.int8`
    /// stays the int8 blob).
    ///
    /// # Errors
    /// I/O errors, named.
    pub fn save_as(&self, path: &Path, precision: Precision) -> anyhow::Result<SavedFiles> {
        let files = self.save(path)?;
        if precision != Precision::F32 {
            dynotraj_formats::atomic::write_file(&files.f32_blob, self.blob(precision)?)
                .with_context(|| format!("writing {}", files.f32_blob.display()))?;
        }
        Ok(files)
    }
}

/// The untrained model of `config` (zero residual: the motion prior `prior` alone), for a fold
/// without training instances ([`TrainConfig::empty_ships_prior`]).
fn untrained(
    sequences: Vec<String>,
    prior: PriorSettings,
    config: &TrainConfig<'_>,
    start: Instant,
) -> anyhow::Result<TrainedModel> {
    let (mut network, vars) = Network::new(config.dims, config.hyper.seed)?;
    network.dynamics = config.dynamics;
    log::info!("no training instances of {} in {sequences:?}: the fold ships the prior", config.dynamics.agents());
    let report = TrainReport {
        kept_seed: config.hyper.seed,
        sequences,
        train_instances: 0,
        val_instances: 0,
        epochs: 0,
        best_epoch: 0,
        best_val_ade: f32::NAN,
        shrink: 1.0,
        gain: None,
        val_cv_ade: f32::NAN,
        val_prior_ade: f32::NAN,
        prior,
        steps: 0,
        seconds: start.elapsed().as_secs_f32(),
        history: Vec::new(),
    };
    Ok(TrainedModel { network, vars, dt: config.dt, prior, report })
}

/// The seed of restart `restart` of a fold trained with `seed`: the seed itself for restart 0,
/// else a value no small seed takes.
#[must_use]
pub fn restart_seed(seed: u64, restart: usize) -> u64 {
    if restart == 0 { seed } else { seed.wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(restart as u64) }
}

/// Mean constant-velocity ADE of `samples` (NaN when empty).
fn mean_cv_ade(samples: &[Sample]) -> f32 {
    samples.iter().map(Sample::constant_velocity_ade).sum::<f32>() / samples.len() as f32
}

/// Trains one fold (see [`TrainConfig`]).
///
/// # Errors
/// No training samples; unsupported widths; a non-finite loss.
pub fn train_fold(config: &TrainConfig<'_>) -> anyhow::Result<TrainedModel> {
    train_fold_with(config, &mut |_| {})
}

/// [`train_fold`], reporting progress to `observer`.
///
/// # Errors
/// See [`train_fold`].
pub fn train_fold_with(config: &TrainConfig<'_>, observer: &mut dyn FnMut(Event)) -> anyhow::Result<TrainedModel> {
    let start = Instant::now();
    anyhow::ensure!(config.dt.is_finite() && config.dt > 0.0, "frame period must be positive, found {}", config.dt);
    let prior = config.prior_settings();
    let (split, sequences) = config.samples(&prior);
    train_split(split, sequences, prior, config, start, observer)
}

/// Trains on samples built elsewhere (over motion prior `prior`, named by the data sets in
/// `sequences`): `config`'s widths, optimisation, frame period and mirroring; its sequences,
/// source, rule and split are not read. `start` is when the fold's work began (its report's
/// seconds).
///
/// # Errors
/// See [`train_fold`].
pub fn train_split(
    mut split: Split,
    sequences: Vec<String>,
    prior: PriorSettings,
    config: &TrainConfig<'_>,
    start: Instant,
    observer: &mut dyn FnMut(Event),
) -> anyhow::Result<TrainedModel> {
    anyhow::ensure!(config.dt.is_finite() && config.dt > 0.0, "frame period must be positive, found {}", config.dt);
    if config.mirror {
        let reflected: Vec<Sample> = split.train.iter().map(Sample::mirrored).collect();
        split.train.extend(reflected);
    }
    if split.train.is_empty() && config.empty_ships_prior {
        return untrained(sequences, prior, config, start);
    }
    anyhow::ensure!(
        !split.train.is_empty(),
        "no training instances of {} in {sequences:?} (source {})",
        config.dynamics.agents(),
        config.source
    );
    // Restarts: independent trainings from other seeds, the one with the best validation ADE
    // kept (restart 0 is the seed itself, so one restart is plain training).
    let mut best: Option<(Network, VarMap, fit::FitOutcome, u64)> = None;
    for restart in 0..config.hyper.restarts.max(1) {
        let seed = restart_seed(config.hyper.seed, restart);
        let (mut network, vars) = Network::new(config.dims, seed)?;
        network.dynamics = config.dynamics;
        let hyper = Hyper { seed, ..config.hyper };
        let outcome = fit::fit(&network, &vars, &split.train, &split.validation, config.dt, &hyper, observer)?;
        if best.as_ref().is_none_or(|b| outcome.best_val_ade < b.2.best_val_ade) {
            best = Some((network, vars, outcome, seed));
        }
    }
    let Some((network, vars, outcome, kept_seed)) = best else { anyhow::bail!("no restart ran") };
    let report = TrainReport {
        kept_seed,
        sequences,
        train_instances: split.train.len(),
        val_instances: split.validation.len(),
        epochs: outcome.history.len(),
        best_epoch: outcome.best_epoch,
        best_val_ade: outcome.best_val_ade,
        shrink: outcome.shrink,
        gain: outcome.gain,
        val_cv_ade: mean_cv_ade(if split.validation.is_empty() { &split.train } else { &split.validation }),
        val_prior_ade: {
            let v = if split.validation.is_empty() { &split.train } else { &split.validation };
            v.iter().map(|s| s.prior_ade(config.dt)).sum::<f32>() / v.len() as f32
        },
        prior,
        steps: outcome.steps,
        seconds: start.elapsed().as_secs_f32(),
        history: outcome.history,
    };
    Ok(TrainedModel { network, vars, dt: config.dt, prior, report })
}
