//! Experiments over folds of held-out sequences: for each arm (trajectory source) and each fold,
//! train on every other sequence, then score the float and the int8 model on the held-out ones
//! beside the baselines and the paper's rows. The paper's experiment holds one sequence out
//! per fold; [`benchmark`] holds out groups of sequences, with several seeds.
//!
//! Two stages: [`folds::train_folds`] trains every (arm, fold, seed) on `--jobs` threads;
//! [`score_seed`] scores one seed's models, sequence by sequence; [`sections`] turns a run into
//! its report's tables and notes ([`report`] writes them).

pub mod benchmark;
pub mod benchmark_report;
pub mod benchmark_request;
pub mod budget;
pub mod cache;
pub mod figures;
pub mod findings;
pub mod folds;
pub mod paper;
pub mod report;
pub mod request;
pub mod sections;

use std::collections::BTreeSet;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context as _;
use dynotraj_core::model::Dims;
use dynotraj_core::predict::{Baseline, Dynamics, MotionPrior};

use crate::forecast_eval::{Reference, instance_keys, score_sequence, score_sequence_against};
use crate::report::{ArmScores, Table, forecast_table};
use cache::CachedFold;
use dynotraj_core::predict::Predictor;
use dynotraj_formats::model_file::ModelFile;
use dynotraj_sources::scene::Scene;
use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::{EligibilityRule, EligibleRun, Source, eligible_runs};
use dynotraj_train::Hyper;
use folds::{FoldSpec, TrainProgress, train_folds};

/// What to run.
#[derive(Debug, Clone)]
pub struct ExperimentConfig {
    /// Arms (sources) to train and test.
    pub arms: Vec<Source>,
    /// Folds: the test sequences each one holds out together (the paper's experiment: one
    /// sequence a fold). Every loaded sequence outside a fold trains it.
    pub folds: Vec<Vec<String>>,
    /// Model widths.
    pub dims: Dims,
    /// Optimisation and loss settings of every fold (`hyper.seed` seeds weights, shuffling
    /// and splits).
    pub hyper: Hyper,
    /// Share of each fold's training runs held out for early stopping.
    pub validation_fraction: f32,
    /// Validate on whole held-out training sequences.
    pub validate_on_sequences: bool,
    /// Train on reflected copies too ([`dynotraj_train::Sample::mirrored`]).
    pub mirror: bool,
    /// The motion prior of every fold ([`dynotraj_train::PriorChoice`]).
    pub prior: dynotraj_train::PriorChoice,
    /// Frame period, seconds.
    pub dt: f32,
    /// Eligibility.
    pub rule: EligibilityRule,
    /// Where to keep each fold's blobs (`<arm>-<seq>.blob` and `.blob.int8`), if anywhere.
    pub out: Option<PathBuf>,
    /// A fold cache folder ([`cache`]): folds found there are not trained again.
    pub cache: Option<PathBuf>,
    /// Folds trained at the same time ([`crate::jobs`]).
    pub jobs: usize,
    /// Set (by a signal) to stop: folds not started by then are not trained, and the run ends
    /// with [`folds::Interrupted`].
    pub stop: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
}

impl ExperimentConfig {
    /// Every test sequence, fold by fold.
    #[must_use]
    pub fn test_sequences(&self) -> Vec<String> {
        self.folds.iter().flatten().cloned().collect()
    }

    /// The folds of the paper's protocol: each of `tests` held out alone.
    #[must_use]
    pub fn one_sequence_folds(tests: &[String]) -> Vec<Vec<String>> {
        tests.iter().map(|t| vec![t.clone()]).collect()
    }

    /// This configuration without the agent types (after the first) that no loaded sequence
    /// holds an eligible run of in any arm: they would train folds on nothing and score nothing.
    #[must_use]
    pub fn with_present_agents(&self, sequences: &[SequenceTracks]) -> Self {
        let kept: Vec<Dynamics> = self
            .rule
            .agent_types()
            .into_iter()
            .enumerate()
            .filter(|&(k, d)| k == 0 || self.for_agents(d).holds_runs(sequences.iter()))
            .map(|(_, d)| d)
            .collect();
        let mut rule = self.rule.clone();
        rule.classes.retain(|&c| kept.contains(&Dynamics::of_class(c)));
        Self { rule, ..self.clone() }
    }

    /// Whether any of `sequences` holds an eligible run under this rule, in any arm.
    fn holds_runs<'s>(&self, mut sequences: impl Iterator<Item = &'s SequenceTracks>) -> bool {
        sequences.any(|s| self.arms.iter().any(|&a| !eligible_runs(s.tracks_for(a), &self.rule).is_empty()))
    }

    /// This configuration for the agents of `dynamics` alone (its rule's classes of them).
    #[must_use]
    pub fn for_agents(&self, dynamics: Dynamics) -> Self {
        Self { rule: self.rule.for_agents(dynamics), ..self.clone() }
    }

    /// The index of the fold holding out `id`.
    #[must_use]
    pub fn fold_of(&self, id: &str) -> Option<usize> {
        self.folds.iter().position(|f| f.iter().any(|s| s == id))
    }
}

/// What one fold took.
#[derive(Debug, Clone, PartialEq)]
pub struct FoldReport {
    /// Arm.
    pub arm: Source,
    /// The agent type trained (its dynamics).
    pub agents: Dynamics,
    /// Held-out sequences, joined by `+`.
    pub sequence: String,
    /// The seed it was trained with.
    pub seed: u64,
    /// Training instances.
    pub train_instances: usize,
    /// Best validation ADE, metres.
    pub val_ade: f32,
    /// Constant-velocity ADE on the same validation runs, metres.
    pub val_cv_ade: f32,
    /// The motion prior's ADE on the same validation runs, metres.
    pub val_prior_ade: f32,
    /// The motion prior's settings, chosen on the fold's training sequences.
    pub prior: dynotraj_core::predict::PriorSettings,
    /// The epoch kept (0: the untrained model, i.e. the motion prior alone).
    pub best_epoch: usize,
    /// The output shrink factor kept.
    pub shrink: f32,
    /// Seconds of training (when it was trained; a cached fold reports its original time).
    pub seconds: f32,
    /// Read from the fold cache instead of trained in this run.
    pub cached: bool,
}

/// The experiment's results for one agent type (the first of the rule's, normally vehicles),
/// with those of the others beside it.
#[derive(Debug, Clone)]
pub struct ExperimentResult {
    /// The agent type scored here: the rule's classes of this dynamics, each forecast by the
    /// models trained on them.
    pub agents: Dynamics,
    /// The same experiment for the rule's other agent types (pedestrians), with their own
    /// models; their folds are in this result's `folds`.
    pub other_agents: Vec<ExperimentResult>,
    /// Table IV layout: learned f32 and int8 per arm, the baselines, the paper's rows.
    pub table: Table,
    /// The measured rows of the table (learned f32, int8, cv, ctra per arm), per sequence.
    pub arms: Vec<ArmScores>,
    /// The same forecasts scored against the simulator's truth on the instances every arm
    /// has (when an estimated arm brought the truth): the table and its rows.
    pub common: Option<(Table, Vec<ArmScores>)>,
    /// The deployment comparison (when an estimated arm brought the truth): every arm's models
    /// and the baselines run on the estimated arm's inputs, all scored against the simulator's
    /// truth on the instances every arm has: the table and its rows.
    pub deployment: Option<(Table, Vec<ArmScores>)>,
    /// Per-fold training reports.
    pub folds: Vec<FoldReport>,
    /// Wall-clock seconds of the whole run.
    pub seconds: f64,
    /// Of those, seconds of loading and estimating the sequences (set by the command that
    /// loaded them; 0 when not measured).
    pub loading_seconds: f64,
}

impl ExperimentResult {
    /// The folds in a few lines: arm and held-out sequence, training instances, the epoch kept,
    /// the output shrink, validation ADE against cv's, seconds (cached or trained), and the
    /// whole command's seconds.
    #[must_use]
    pub fn fold_summary(&self) -> String {
        use std::fmt::Write as _;
        let mut summary = String::from(
            "folds (arm / held-out sequence: training instances, epoch kept, output shrink, validation ADE vs cv, \
                seconds):\n",
        );
        for f in &self.folds {
            let _ = writeln!(
                summary,
                "  {} / {}: {} instances, epoch {}, shrink {}, val ADE {:.3} m (cv {:.3} m), {:.1} s{}",
                f.arm,
                f.sequence,
                f.train_instances,
                f.best_epoch,
                f.shrink,
                f.val_ade,
                f.val_cv_ade,
                f.seconds,
                if f.cached { " (cached)" } else { "" }
            );
        }
        let _ = writeln!(summary, "total: {:.1} s", self.seconds);
        summary
    }
}

/// Scores `forecaster` on one sequence against the source's own future into `own` and, when
/// there is a common reference, against it into `common`.
fn score_both(
    runs: &[EligibleRun],
    scene: &Scene,
    forecaster: &mut dyn Predictor,
    dt: f32,
    reference: Option<Reference<'_>>,
    own: &mut ArmScores,
    common: &mut ArmScores,
) {
    own.push_sequence(&score_sequence(runs, scene, forecaster, dt));
    if let Some(r) = reference {
        common.push_sequence(&score_sequence_against(runs, scene, forecaster, dt, r));
    }
}

/// Runs the experiment on `sequences` (every loaded sequence is a training candidate) with
/// the seed of `config.hyper`.
///
/// # Errors
/// A test sequence that is not loaded; a fold with no training data; I/O errors for --out.
pub fn run_experiment(
    sequences: &[SequenceTracks],
    config: &ExperimentConfig,
    progress: &dyn TrainProgress,
) -> anyhow::Result<ExperimentResult> {
    let start = Instant::now();
    check_inputs(sequences, config)?;
    let config = &config.with_present_agents(sequences);
    let specs = fold_specs(config, &[config.hyper.seed]);
    let trained = train_folds(sequences, config, &specs, progress)?;
    let mut result = score_seed(sequences, config, &specs, &trained, config.hyper.seed)?;
    result.seconds = start.elapsed().as_secs_f64();
    Ok(result)
}

/// Every (agent type, arm, fold, seed) of `config` for `seeds`: agent type by agent type (in
/// [`Dynamics::ALL`] order), arm by arm, seed by seed, fold by fold.
#[must_use]
pub fn fold_specs(config: &ExperimentConfig, seeds: &[u64]) -> Vec<FoldSpec> {
    let mut out = Vec::new();
    for agents in config.rule.agent_types() {
        for &arm in &config.arms {
            for &seed in seeds {
                out.extend((0..config.folds.len()).map(|fold| FoldSpec { arm, fold, seed, agents }));
            }
        }
    }
    out
}

/// Why test sequence `id` cannot be used: it is not among the loaded `sequences` (which
/// `--sequences` may have narrowed; the folder may well hold it).
fn not_loaded(id: &str, sequences: &[SequenceTracks]) -> String {
    let loaded: Vec<&str> = sequences.iter().map(|s| s.id.as_str()).collect();
    format!(
        "test sequence {id} is not among the sequences loaded ({}): add it to --sequences, or leave --sequences out \
         to load every sequence of the folder",
        loaded.join(", ")
    )
}

/// Fails unless every test sequence is loaded, no sequence is in two folds, and every arm's
/// tracks are there.
///
/// # Errors
/// As above, naming the sequence.
pub fn check_inputs(sequences: &[SequenceTracks], config: &ExperimentConfig) -> anyhow::Result<()> {
    let mut seen = BTreeSet::new();
    for id in config.test_sequences() {
        anyhow::ensure!(sequences.iter().any(|s| s.id == id), "{}", not_loaded(&id, sequences));
        anyhow::ensure!(seen.insert(id.clone()), "test sequence {id} is in two folds");
    }
    for &source in &config.arms {
        if let Some(s) = sequences.iter().find(|s| !s.has(source)) {
            anyhow::bail!("arm {source}: the estimator's tracks of sequence {} were not loaded", s.id);
        }
    }
    Ok(())
}

/// The model files of `seed` (f32 and int8), by (arm, fold), each blob parsed once.
type SeedModels = Vec<((Source, usize), [ModelFile; 2])>;

/// The two model files of every fold of `seed` for `agents` in `trained` (trained for `specs`).
fn seed_models(
    config: &ExperimentConfig,
    specs: &[FoldSpec],
    trained: &[CachedFold],
    (seed, agents): (u64, Dynamics),
) -> anyhow::Result<SeedModels> {
    let mut out = SeedModels::new();
    for (spec, t) in specs.iter().zip(trained).filter(|(s, _)| s.seed == seed && s.agents == agents) {
        let name = spec.name(config);
        let files = [
            ModelFile::from_bytes(t.f32_blob.clone(), &name)?,
            ModelFile::from_bytes(t.int8_blob.clone(), &format!("{name} (int8)"))?,
        ];
        out.push(((spec.arm, spec.fold), files));
    }
    Ok(out)
}

/// The model files of `arm` for the fold holding out `id`.
fn models_for<'m>(
    config: &ExperimentConfig,
    models: &'m SeedModels,
    arm: Source,
    id: &str,
) -> anyhow::Result<&'m [ModelFile; 2]> {
    let fold = config.fold_of(id).with_context(|| format!("sequence {id} is in no fold"))?;
    models
        .iter()
        .find(|(key, _)| *key == (arm, fold))
        .map(|(_, files)| files)
        .with_context(|| format!("no trained model for {arm}, fold {fold}"))
}

/// Scores the models of `seed` (trained for `specs`, in `trained`) on every test sequence,
/// each agent type of the rule by its own models: Table IV for the arms' own futures, and,
/// when the estimated arm brought the simulator's truth, the same against that truth and the
/// deployment comparison.
///
/// # Errors
/// A missing model; a blob that does not load; I/O errors for --out.
pub fn score_seed(
    sequences: &[SequenceTracks],
    config: &ExperimentConfig,
    specs: &[FoldSpec],
    trained: &[CachedFold],
    seed: u64,
) -> anyhow::Result<ExperimentResult> {
    if let Some(dir) = &config.out {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        for (spec, fold) in specs.iter().zip(trained).filter(|(s, _)| s.seed == seed) {
            let name = spec.name(config);
            for (ext, bytes) in [("blob", &fold.f32_blob), ("blob.int8", &fold.int8_blob)] {
                let path = dir.join(format!("{name}.{ext}"));
                dynotraj_formats::atomic::write_file(&path, bytes)
                    .with_context(|| format!("writing {}", path.display()))?;
            }
        }
    }
    let mut per_agent = Vec::new();
    for (k, agents) in config.rule.agent_types().into_iter().enumerate() {
        let for_agents = config.for_agents(agents);
        // An agent type after the first with no eligible run in any test sequence has no rows.
        let tests = for_agents.test_sequences();
        if k > 0 && !for_agents.holds_runs(sequences.iter().filter(|s| tests.contains(&s.id))) {
            log::info!("no eligible {} in the test sequences: none scored", agents.agents());
            continue;
        }
        per_agent.push(score_agents(sequences, &for_agents, specs, trained, (seed, agents))?);
    }
    anyhow::ensure!(!per_agent.is_empty(), "--classes: no class to forecast");
    let mut result = per_agent.remove(0);
    result.folds = specs.iter().zip(trained).filter(|(s, _)| s.seed == seed).map(|(_, f)| f.report.clone()).collect();
    result.other_agents = per_agent;
    Ok(result)
}

/// [`score_seed`] for the agent type of `config`'s rule (one), by the models trained on it.
fn score_agents(
    sequences: &[SequenceTracks],
    config: &ExperimentConfig,
    specs: &[FoldSpec],
    trained: &[CachedFold],
    (seed, agents): (u64, Dynamics),
) -> anyhow::Result<ExperimentResult> {
    let ids = config.test_sequences();
    let tests: Vec<&SequenceTracks> = ids
        .iter()
        .map(|id| sequences.iter().find(|s| &s.id == id).with_context(|| not_loaded(id, sequences)))
        .collect::<anyhow::Result<_>>()?;
    let folds = specs
        .iter()
        .zip(trained)
        .filter(|(s, _)| s.seed == seed && s.agents == agents)
        .map(|(_, f)| f.report.clone())
        .collect();
    let models = seed_models(config, specs, trained, (seed, agents))?;
    // The common reference: the simulator's truth of each test sequence, and the instances
    // that every arm has; only when every test sequence has a truth (none from real images).
    let truths: Option<Vec<Scene>> =
        tests.iter().map(|s| s.truth().map(|t| Scene::new(t, Source::Gt, config.dt))).collect();
    // Per arm, per test sequence: the eligible runs of the arm's own tracks.
    let runs_by_arm: Vec<Vec<Vec<EligibleRun>>> = config
        .arms
        .iter()
        .map(|&a| tests.iter().map(|s| eligible_runs(s.tracks_for(a), &config.rule)).collect())
        .collect();
    // The instances every arm has, named by the true object they follow (a front-end with box
    // or motion masks names its objects itself), then each arm's share of them in its own ids.
    let own_keys: Vec<Vec<BTreeSet<(i32, u32)>>> =
        runs_by_arm.iter().map(|per_test| per_test.iter().map(|r| instance_keys(r)).collect()).collect();
    let true_keys = |source: Source, test: &SequenceTracks, keys: &BTreeSet<(i32, u32)>| -> BTreeSet<(i32, u32)> {
        keys.iter().filter_map(|&(id, f)| Some((test.true_track_id(source, id)?, f))).collect()
    };
    let common_true: Vec<BTreeSet<(i32, u32)>> = tests
        .iter()
        .enumerate()
        .map(|(i, test)| {
            let mut sets = config
                .arms
                .iter()
                .zip(&own_keys)
                .filter_map(|(&a, per_test)| per_test.get(i).map(|k| true_keys(a, test, k)));
            let first = sets.next().unwrap_or_default();
            sets.fold(first, |acc, k| acc.intersection(&k).copied().collect())
        })
        .collect();
    let common_keys: Vec<Vec<BTreeSet<(i32, u32)>>> = config
        .arms
        .iter()
        .zip(&own_keys)
        .map(|(&a, per_test)| {
            tests
                .iter()
                .zip(per_test)
                .zip(&common_true)
                .map(|((test, keys), common)| {
                    let shared =
                        |&(id, f): &(i32, u32)| test.true_track_id(a, id).is_some_and(|t| common.contains(&(t, f)));
                    keys.iter().copied().filter(shared).collect()
                })
                .collect()
        })
        .collect();
    let scenes_by_arm: Vec<Vec<Scene>> =
        config.arms.iter().map(|&a| tests.iter().map(|s| s.scene(a, config.dt)).collect()).collect();
    let world_yaws: Vec<Option<std::collections::BTreeMap<u32, f32>>> = tests
        .iter()
        .map(|t| t.estimated.as_ref().map(dynotraj_sources::estimation::EstimatedTracks::world_yaw))
        .collect();
    let no_keys = BTreeSet::new();
    let references_for = |source: Source| -> Vec<Option<Reference<'_>>> {
        let keys = config.arms.iter().position(|a| *a == source).and_then(|a| common_keys.get(a));
        (0..tests.len())
            .map(|i| {
                let world_yaw = world_yaws[i].as_ref().filter(|_| source.is_estimated());
                truths.as_ref().and_then(|t| t.get(i)).map(|truth| Reference::Common {
                    truth,
                    only: keys.and_then(|k| k.get(i)).unwrap_or(&no_keys),
                    world_yaw,
                })
            })
            .collect()
    };
    let (mut arms, mut common_arms) = (Vec::new(), Vec::new());
    for ((&source, runs), scenes) in config.arms.iter().zip(&runs_by_arm).zip(&scenes_by_arm) {
        let references = references_for(source);
        let mut learned =
            [ArmScores::new(format!("learned f32 on {source}")), ArmScores::new(format!("learned int8 on {source}"))];
        let mut learned_common = learned.clone();
        for (((test, seq_runs), scene), reference) in tests.iter().zip(runs).zip(scenes).zip(&references) {
            let files = models_for(config, &models, source, &test.id)?;
            for ((arm, common), file) in learned.iter_mut().zip(learned_common.iter_mut()).zip(files) {
                score_both(seq_runs, scene, &mut file.predictor(), config.dt, *reference, arm, common);
            }
        }
        arms.extend(learned);
        if truths.is_some() {
            common_arms.extend(learned_common);
        }
        // The motion prior alone, with the settings each fold chose on its training sequences.
        let mut prior = ArmScores::new(format!("prior on {source}"));
        let mut prior_common = prior.clone();
        for (((test, seq_runs), scene), reference) in tests.iter().zip(runs).zip(scenes).zip(&references) {
            let [f32_file, _] = models_for(config, &models, source, &test.id)?;
            let mut p = MotionPrior(*f32_file.blob().prior());
            score_both(seq_runs, scene, &mut p, config.dt, *reference, &mut prior, &mut prior_common);
        }
        arms.push(prior);
        if truths.is_some() {
            common_arms.push(prior_common);
        }
        for mut baseline in Baseline::ALL {
            let mut own = ArmScores::new(format!("{} on {source}", baseline.name()));
            let mut common = own.clone();
            for ((r, sc), rf) in runs.iter().zip(scenes).zip(&references) {
                score_both(r, sc, &mut baseline, config.dt, *rf, &mut own, &mut common);
            }
            arms.push(own);
            if truths.is_some() {
                common_arms.push(common);
            }
        }
    }
    // Deployment: what a vehicle sees at run time is its own estimates; every arm's model runs
    // on the estimated arm's inputs, scored against the truth on the common instances.
    let deployment = match (config.arms.iter().position(|a| *a == Source::Estimated), truths.is_some()) {
        (Some(e), true) => {
            let references = references_for(Source::Estimated);
            let mut rows = Vec::new();
            for &source in &config.arms {
                let mut row = [
                    ArmScores::new(format!("learned f32 trained on {source}")),
                    ArmScores::new(format!("learned int8 trained on {source}")),
                ];
                for (((test, r), sc), rf) in tests.iter().zip(&runs_by_arm[e]).zip(&scenes_by_arm[e]).zip(&references) {
                    let files = models_for(config, &models, source, &test.id)?;
                    for (arm, file) in row.iter_mut().zip(files) {
                        let reference = rf.context("deployment needs the simulator's truth")?;
                        arm.push_sequence(&score_sequence_against(r, sc, &mut file.predictor(), config.dt, reference));
                    }
                }
                rows.extend(row);
                let mut prior = ArmScores::new(format!("prior chosen on {source}"));
                for (((test, r), sc), rf) in tests.iter().zip(&runs_by_arm[e]).zip(&scenes_by_arm[e]).zip(&references) {
                    let [f32_file, _] = models_for(config, &models, source, &test.id)?;
                    let reference = rf.context("deployment needs the simulator's truth")?;
                    let mut p = MotionPrior(*f32_file.blob().prior());
                    prior.push_sequence(&score_sequence_against(r, sc, &mut p, config.dt, reference));
                }
                rows.push(prior);
            }
            for mut baseline in Baseline::ALL {
                let mut row = ArmScores::new(format!("{} (no training)", baseline.name()));
                for ((r, sc), rf) in runs_by_arm[e].iter().zip(&scenes_by_arm[e]).zip(&references) {
                    let reference = rf.context("deployment needs the simulator's truth")?;
                    row.push_sequence(&score_sequence_against(r, sc, &mut baseline, config.dt, reference));
                }
                rows.push(row);
            }
            Some((forecast_table(&ids, &rows, &[]), rows))
        }
        _ => None,
    };
    let names: Vec<&str> = config.arms.iter().map(Source::name).collect();
    let table = forecast_table(&ids, &arms, &paper::reference_rows(&names, &ids));
    let common = truths.is_some().then(|| (forecast_table(&ids, &common_arms, &[]), common_arms));
    Ok(ExperimentResult {
        agents,
        other_agents: Vec::new(),
        table,
        arms,
        common,
        deployment,
        folds,
        seconds: 0.0,
        loading_seconds: 0.0,
    })
}
