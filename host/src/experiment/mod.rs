//! Leave-one-sequence-out experiments: for each arm (trajectory source) and each test sequence,
//! train on every other sequence, then score the float and the int8 model on the held-out one
//! beside the baselines and the paper's rows.

pub mod cache;
pub mod figures;
pub mod findings;
pub mod paper;
pub mod report;

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context as _;
use dynotraj_core::model::blob::Precision;
use dynotraj_core::model::Dims;
use dynotraj_core::predict::Baseline;

use std::collections::BTreeSet;

use crate::evaluate::{instance_keys, score_sequence, score_sequence_against, Forecaster, Reference};
use crate::model_file::ModelFile;
use crate::report::{forecast_table, ArmScores, Table};
use crate::scene::Scene;
use crate::sequence::SequenceTracks;
use crate::train::{train_fold_with, Event, Hyper, TrainConfig};
use crate::trajectory::{eligible_runs, EligibilityRule, EligibleRun, Source};
use cache::{fold_key, CachedFold, FoldCache};

/// What to run.
#[derive(Debug, Clone)]
pub struct ExperimentConfig {
    /// Arms (sources) to train and test.
    pub arms: Vec<Source>,
    /// Test sequences; each is held out in turn.
    pub test_sequences: Vec<String>,
    /// Model widths.
    pub dims: Dims,
    /// Optimisation and loss settings of every fold (`hyper.seed` seeds weights, shuffling
    /// and splits).
    pub hyper: Hyper,
    /// Share of each fold's training runs held out for early stopping.
    pub validation_fraction: f32,
    /// Validate on whole held-out training sequences.
    pub validate_on_sequences: bool,
    /// Train on reflected copies too ([`crate::train::Sample::mirrored`]).
    pub mirror: bool,
    /// Frame period, seconds.
    pub dt: f32,
    /// Eligibility.
    pub rule: EligibilityRule,
    /// Where to keep each fold's blobs (`<arm>-<seq>.blob` and `.blob.int8`), if anywhere.
    pub out: Option<PathBuf>,
    /// A fold cache folder ([`cache`]): folds found there are not trained again.
    pub cache: Option<PathBuf>,
}

/// What one fold took.
#[derive(Debug, Clone, PartialEq)]
pub struct FoldReport {
    /// Arm.
    pub arm: Source,
    /// Held-out sequence.
    pub sequence: String,
    /// Training instances.
    pub train_instances: usize,
    /// Best validation ADE, metres.
    pub val_ade: f32,
    /// Constant-velocity ADE on the same validation runs, metres.
    pub val_cv_ade: f32,
    /// The epoch kept (0: the untrained model, i.e. constant velocity along the fitted
    /// velocity, cv-fit).
    pub best_epoch: usize,
    /// The output shrink factor kept.
    pub shrink: f32,
    /// Seconds of training (when it was trained; a cached fold reports its original time).
    pub seconds: f32,
    /// Read from the fold cache instead of trained in this run.
    pub cached: bool,
}

/// The experiment's results.
#[derive(Debug, Clone)]
pub struct ExperimentResult {
    /// Table IV layout: learned f32 and int8 per arm, the baselines, the paper's rows.
    pub table: Table,
    /// The measured rows of the table (learned f32, int8, cv, ctra per arm), per sequence.
    pub arms: Vec<ArmScores>,
    /// The same forecasts scored against the simulator's truth on the instances every arm
    /// has (when an estimated arm brought the truth): the table and its rows.
    pub common: Option<(Table, Vec<ArmScores>)>,
    /// Per-fold training reports.
    pub folds: Vec<FoldReport>,
    /// Wall-clock seconds of the whole run.
    pub seconds: f64,
}

/// Scores `forecaster` on one sequence against the source's own future into `own` and, when
/// there is a common reference, against it into `common`.
fn score_both(runs: &[EligibleRun], scene: &Scene, forecaster: &mut dyn Forecaster, dt: f32, reference: Option<Reference<'_>>, own: &mut ArmScores, common: &mut ArmScores) {
    own.per_sequence.push(score_sequence(runs, scene, forecaster, dt).scores);
    if let Some(r) = reference {
        common.per_sequence.push(score_sequence_against(runs, scene, forecaster, dt, r).scores);
    }
}

/// Runs the experiment on `sequences` (every loaded sequence is a training candidate).
///
/// # Errors
/// A test sequence that is not loaded; a fold with no training data; I/O errors for --out.
pub fn run_experiment(sequences: &[SequenceTracks], config: &ExperimentConfig, progress: &mut dyn FnMut(&str, Event)) -> anyhow::Result<ExperimentResult> {
    let start = Instant::now();
    let tests: Vec<&SequenceTracks> = config
        .test_sequences
        .iter()
        .map(|id| sequences.iter().find(|s| &s.id == id).with_context(|| format!("test sequence {id} is not in the data folder")))
        .collect::<anyhow::Result<_>>()?;
    if let Some(dir) = &config.out {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let cache = config.cache.as_deref().map(FoldCache::open).transpose()?;
    for &source in &config.arms {
        if let Some(s) = sequences.iter().find(|s| !s.has(source)) {
            anyhow::bail!("arm {source}: the estimator's tracks of sequence {} were not loaded", s.id);
        }
    }
    let mut arms = Vec::new();
    let mut folds = Vec::new();
    // The common reference: the simulator's truth of each test sequence, and the instances
    // that every arm has; only when every test sequence has a truth (none from real images).
    let truths: Option<Vec<Scene>> =
        tests.iter().map(|s| s.estimated.as_ref().filter(|e| !e.truth.is_empty()).map(|e| Scene::new(&e.truth, Source::Gt, config.dt))).collect();
    // Per arm, per test sequence: the eligible runs of the arm's own tracks.
    let runs_by_arm: Vec<Vec<Vec<EligibleRun>>> =
        config.arms.iter().map(|&a| tests.iter().map(|s| eligible_runs(s.tracks_for(a), &config.rule)).collect()).collect();
    let common_keys: Vec<BTreeSet<(i32, u32)>> = (0..tests.len())
        .map(|i| {
            let mut sets = runs_by_arm.iter().filter_map(|per_test| per_test.get(i)).map(|r| instance_keys(r));
            let first = sets.next().unwrap_or_default();
            sets.fold(first, |acc, k| acc.intersection(&k).copied().collect())
        })
        .collect();
    let mut common_arms = Vec::new();
    for (&source, runs) in config.arms.iter().zip(&runs_by_arm) {
        let scenes: Vec<Scene> = tests.iter().map(|s| Scene::new(s.tracks_for(source), source, config.dt)).collect();
        let references: Vec<Option<Reference<'_>>> = (0..tests.len())
            .map(|i| {
                let world_yaw = tests[i].estimated.as_ref().filter(|_| source.is_estimated()).map(|e| &e.world_yaw);
                truths.as_ref().and_then(|t| t.get(i)).map(|truth| Reference::Common { truth, only: &common_keys[i], world_yaw })
            })
            .collect();
        let mut learned = [
            ArmScores { label: format!("learned f32 on {source}"), per_sequence: Vec::new() },
            ArmScores { label: format!("learned int8 on {source}"), per_sequence: Vec::new() },
        ];
        let mut learned_common = learned.clone();
        for (((test, seq_runs), scene), reference) in tests.iter().zip(runs).zip(&scenes).zip(&references) {
            let mut train = TrainConfig::new(sequences, vec![test.id.clone()], source);
            train.dt = config.dt;
            train.rule = config.rule.clone();
            train.dims = config.dims;
            train.hyper = config.hyper;
            train.validation_fraction = config.validation_fraction;
            train.mirror = config.mirror;
            train.validate_on_sequences = config.validate_on_sequences;
            let label = format!("{source} / {}", test.id);
            let name = format!("{source}-{}", test.id);
            let key = fold_key(&train);
            let template = FoldReport {
                arm: source,
                sequence: test.id.clone(),
                train_instances: 0,
                val_ade: f32::NAN,
                val_cv_ade: f32::NAN,
                best_epoch: 0,
                shrink: 1.0,
                seconds: 0.0,
                cached: true,
            };
            let fold = match cache.as_ref().and_then(|c| c.load(&name, key, &template)) {
                Some(fold) => {
                    log::info!("{label}: trained fold {key:016x} read from the cache");
                    fold
                }
                None => {
                    let model = train_fold_with(&train, &mut |e| progress(&label, e)).with_context(|| format!("training fold {label}"))?;
                    let r = &model.report;
                    let report = FoldReport {
                        train_instances: r.train_instances,
                        val_ade: r.best_val_ade,
                        val_cv_ade: r.val_cv_ade,
                        best_epoch: r.best_epoch,
                        shrink: r.shrink,
                        seconds: r.seconds,
                        cached: false,
                        ..template
                    };
                    let fold = CachedFold { f32_blob: model.blob(Precision::F32)?, int8_blob: model.blob(Precision::Int8)?, report };
                    if let Some(c) = &cache {
                        c.store(&name, key, &fold)?;
                    }
                    fold
                }
            };
            folds.push(fold.report.clone());
            let blobs = [(Precision::F32, fold.f32_blob), (Precision::Int8, fold.int8_blob)];
            for ((arm, common), (precision, bytes)) in learned.iter_mut().zip(learned_common.iter_mut()).zip(blobs) {
                if let Some(dir) = &config.out {
                    let ext = if precision == Precision::F32 { "blob" } else { "blob.int8" };
                    let path = dir.join(format!("{name}.{ext}"));
                    std::fs::write(&path, &bytes).with_context(|| format!("writing {}", path.display()))?;
                }
                let file = ModelFile::from_bytes(bytes, &label)?;
                score_both(seq_runs, scene, &mut file.predictor(), config.dt, *reference, arm, common);
            }
        }
        arms.extend(learned);
        if truths.is_some() {
            common_arms.extend(learned_common);
        }
        for mut baseline in Baseline::ALL {
            let mut own = ArmScores { label: format!("{} on {source}", baseline.name()), per_sequence: Vec::new() };
            let mut common = own.clone();
            for ((r, sc), rf) in runs.iter().zip(&scenes).zip(&references) {
                score_both(r, sc, &mut baseline, config.dt, *rf, &mut own, &mut common);
            }
            arms.push(own);
            if truths.is_some() {
                common_arms.push(common);
            }
        }
    }
    let names: Vec<&str> = config.arms.iter().map(Source::name).collect();
    let ids: Vec<String> = tests.iter().map(|s| s.id.clone()).collect();
    let table = forecast_table(&ids, &arms, &paper::reference_rows(&names, &ids));
    let common = truths.is_some().then(|| (forecast_table(&ids, &common_arms, &[]), common_arms));
    Ok(ExperimentResult { table, arms, common, folds, seconds: start.elapsed().as_secs_f64() })
}
