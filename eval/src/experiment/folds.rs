//! The training stage of an experiment: every (arm, fold, seed) trained once, the folds on a
//! pool of `--jobs` threads, each read from the fold cache when it holds it.

use anyhow::Context as _;
use dynotraj_core::model::blob::Precision;
use dynotraj_core::predict::Dynamics;

use super::cache::{CachedFold, FoldCache, fold_key};
use super::{ExperimentConfig, FoldReport};
use crate::jobs::map_jobs;
use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::Source;
use dynotraj_train::{Event, TrainConfig, train_fold_with};

/// One model to train: an arm, one of the config's folds (by index) and a seed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FoldSpec {
    /// The source trained on.
    pub arm: Source,
    /// Index into [`ExperimentConfig::folds`].
    pub fold: usize,
    /// The seed of the weights and the shuffling.
    pub seed: u64,
    /// The agent type trained: the classes of the config's rule that this dynamics forecasts.
    pub agents: Dynamics,
}

/// What the training stage tells its caller while it runs; called from the worker threads.
pub trait TrainProgress: Sync {
    /// Training of `folds` folds starts.
    fn training(&self, folds: usize) {
        let _ = folds;
    }
    /// A step or an epoch of the fold named `label` finished.
    fn event(&self, label: &str, event: Event);
    /// The fold named `label` is trained (or was read from the cache).
    fn done(&self, label: &str, report: &FoldReport);
}

/// A [`TrainProgress`] that shows nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct Quiet;

impl TrainProgress for Quiet {
    fn event(&self, _: &str, _: Event) {}
    fn done(&self, _: &str, _: &FoldReport) {}
}

impl crate::loading::LoadProgress for Quiet {
    fn loading(&self, _: usize, _: bool) {}
    fn loaded(&self, _: &str, _: bool) {}
    fn finished(&self) {}
}

impl FoldSpec {
    /// The fold's name in files and messages: `<arm>-<held-out ids joined by +>`, with
    /// `-s<seed>` unless the seed is the config's own (so one-seed experiments keep their names)
    /// and `-pedestrians` for a model of pedestrians (vehicles' names are as they always were).
    #[must_use]
    pub fn name(&self, config: &ExperimentConfig) -> String {
        let held = config.folds.get(self.fold).map(|f| f.join("+")).unwrap_or_default();
        let mut name = format!("{}-{held}", self.arm);
        if self.seed != config.hyper.seed {
            name.push_str(&format!("-s{}", self.seed));
        }
        if self.agents != Dynamics::Unicycle {
            name.push('-');
            name.push_str(self.agents.agents());
        }
        name
    }

    /// The training set-up of this fold.
    #[must_use]
    pub fn train_config<'a>(&self, sequences: &'a [SequenceTracks], config: &ExperimentConfig) -> TrainConfig<'a> {
        let mut train = TrainConfig::new(sequences, config.folds.get(self.fold).cloned().unwrap_or_default(), self.arm);
        train.dt = config.dt;
        train.rule = config.rule.for_agents(self.agents);
        train.dims = config.dims;
        train.hyper = config.hyper;
        train.hyper.seed = self.seed;
        train.validation_fraction = config.validation_fraction;
        train.mirror = config.mirror;
        train.prior = config.prior;
        train.validate_on_sequences = config.validate_on_sequences;
        train.dynamics = self.agents;
        // Vehicles are in every drive, so a fold without them is a mistake worth an error;
        // pedestrians are rare enough in driving data that some folds' sequences hold none.
        train.empty_ships_prior = self.agents != Dynamics::Unicycle;
        train
    }
}

/// A run stopped by [`super::ExperimentConfig::stop`] before every fold was trained.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "interrupted after {done} of {total} folds; {}",
    if *kept { "the trained folds are in the fold cache, and a rerun with the same --out continues from them" } else { "nothing is kept without --out" }
)]
pub struct Interrupted {
    /// Folds trained or read from the cache.
    pub done: usize,
    /// Folds the run had.
    pub total: usize,
    /// Whether a fold cache keeps the trained ones.
    pub kept: bool,
}

/// Trains (or reads from the cache) every fold of `specs`, `config.jobs` at a time; the
/// results are in the order of `specs` and do not depend on the number of jobs.
///
/// # Errors
/// A fold with no training data; a numerical failure; cache or blob errors, named by fold;
/// [`Interrupted`] when `config.stop` was set before every fold ran.
pub fn train_folds(
    sequences: &[SequenceTracks],
    config: &ExperimentConfig,
    specs: &[FoldSpec],
    progress: &dyn TrainProgress,
) -> anyhow::Result<Vec<CachedFold>> {
    let cache = config.cache.as_deref().map(FoldCache::open).transpose()?;
    let stopped = || config.stop.as_ref().is_some_and(|s| s.load(std::sync::atomic::Ordering::Relaxed));
    let results = map_jobs(specs, config.jobs, |spec| -> anyhow::Result<Option<CachedFold>> {
        if stopped() {
            return Ok(None);
        }
        let train = spec.train_config(sequences, config);
        let name = spec.name(config);
        let key = fold_key(&train);
        let template = FoldReport {
            arm: spec.arm,
            agents: spec.agents,
            sequence: train.exclude.join("+"),
            seed: spec.seed,
            train_instances: 0,
            val_ade: f32::NAN,
            val_cv_ade: f32::NAN,
            val_prior_ade: f32::NAN,
            prior: dynotraj_core::predict::PriorSettings::OFF,
            best_epoch: 0,
            shrink: 1.0,
            seconds: 0.0,
            cached: true,
        };
        if let Some(fold) = cache.as_ref().and_then(|c| c.load(&name, key, &template)) {
            log::info!("{name}: trained fold {key:016x} read from the cache");
            progress.done(&name, &fold.report);
            return Ok(Some(fold));
        }
        let model = train_fold_with(&train, &mut |e| progress.event(&name, e))
            .with_context(|| format!("training fold {name}"))?;
        let r = &model.report;
        let report = FoldReport {
            train_instances: r.train_instances,
            val_ade: r.best_val_ade,
            val_cv_ade: r.val_cv_ade,
            val_prior_ade: r.val_prior_ade,
            prior: r.prior,
            best_epoch: r.best_epoch,
            shrink: r.shrink,
            seconds: r.seconds,
            cached: false,
            ..template
        };
        let fold =
            CachedFold { f32_blob: model.blob(Precision::F32)?, int8_blob: model.blob(Precision::Int8)?, report };
        if let Some(c) = &cache {
            c.store(&name, key, &fold)?;
        }
        progress.done(&name, &fold.report);
        Ok(Some(fold))
    })?;
    let folds: Vec<Option<CachedFold>> = results.into_iter().collect::<anyhow::Result<_>>()?;
    let done = folds.iter().flatten().count();
    if done < folds.len() {
        return Err(Interrupted { done, total: folds.len(), kept: cache.is_some() }.into());
    }
    Ok(folds.into_iter().flatten().collect())
}

#[cfg(test)]
mod tests {
    use dynotraj_core::model::arch::Dims;
    use dynotraj_core::wire::ObjectClass;

    use super::*;
    use dynotraj_sim::unicycle_runs::constant_control_runs;
    use dynotraj_sources::trajectory::{EligibilityRule, ObjectTrack};
    use dynotraj_train::Hyper;

    fn sequence(id: &str, seed: u64) -> SequenceTracks {
        let tracks = constant_control_runs(4, 50, 0.05, seed)
            .into_iter()
            .enumerate()
            .map(|(i, states)| ObjectTrack {
                track_id: i as i32,
                class: ObjectClass::Car,
                frames: (0..states.len() as u32).collect(),
                states,
            })
            .collect();
        SequenceTracks { id: id.into(), frame_count: 50, tracks, estimated: None, camera_path: Vec::new() }
    }

    fn config(jobs: usize) -> ExperimentConfig {
        ExperimentConfig {
            arms: vec![Source::Gt],
            folds: vec![vec!["a".into()], vec!["b".into(), "c".into()]],
            dims: Dims { enc: 8, edge: 8, k: 2, dec: 8 },
            hyper: Hyper { epochs: 2, batch: 32, ..Hyper::default() },
            validation_fraction: 0.3,
            validate_on_sequences: true,
            mirror: true,
            prior: dynotraj_train::PriorChoice::Tuned,
            dt: 0.05,
            rule: EligibilityRule::default().for_agents(Dynamics::Unicycle),
            out: None,
            cache: None,
            jobs,
            stop: None,
        }
    }

    /// The same data, settings and seed give the same models bit for bit, whether the folds
    /// train one after another or two at a time; another seed gives other models.
    #[test]
    fn training_is_reproducible_and_independent_of_the_number_of_jobs() {
        let sequences: Vec<SequenceTracks> =
            ["a", "b", "c", "d", "e"].iter().zip(1..).map(|(id, s)| sequence(id, s)).collect();
        let specs = super::super::fold_specs(&config(1), &[1, 2]);
        assert_eq!(specs.len(), 4);
        let one = train_folds(&sequences, &config(1), &specs, &Quiet).unwrap();
        let again = train_folds(&sequences, &config(1), &specs, &Quiet).unwrap();
        let two = train_folds(&sequences, &config(2), &specs, &Quiet).unwrap();
        assert!(
            one.iter().all(|f| f.report.train_instances > 50),
            "{:?}",
            one.iter().map(|f| f.report.train_instances).collect::<Vec<_>>()
        );
        for ((a, b), c) in one.iter().zip(&again).zip(&two) {
            assert_eq!(a.f32_blob, b.f32_blob, "{}: a rerun differs", a.report.sequence);
            assert_eq!(a.int8_blob, b.int8_blob);
            assert_eq!(a.f32_blob, c.f32_blob, "{}: two jobs differ from one", a.report.sequence);
        }
        let seed = |s: u64| {
            one.iter()
                .zip(&specs)
                .filter(move |(_, p)| p.seed == s && p.arm == Source::Gt)
                .map(|(f, _)| f.f32_blob.clone())
                .collect::<Vec<_>>()
        };
        assert_ne!(seed(1), seed(2), "the seed changes the weights");
    }

    /// With pedestrians in the rule, each fold also trains a pedestrian model of its own; with no
    /// pedestrian in its training sequences it ships the prior (no error), under another name
    /// and cache key than the vehicles' model of the same fold.
    #[test]
    fn pedestrian_folds_without_pedestrians_ship_the_prior() {
        let sequences: Vec<SequenceTracks> = ["a", "b", "c"].iter().zip(1..).map(|(id, s)| sequence(id, s)).collect();
        let mut both = config(1);
        both.rule = EligibilityRule::default();
        both.folds = vec![vec!["a".into()]];
        let specs = super::super::fold_specs(&both, &[1]);
        let agents: Vec<Dynamics> = specs.iter().map(|s| s.agents).collect();
        assert_eq!(agents, vec![Dynamics::Unicycle, Dynamics::SingleIntegrator]);
        assert_eq!(specs[0].name(&both), "gt-a");
        assert_eq!(specs[1].name(&both), "gt-a-pedestrians");
        let keys: Vec<u64> =
            specs.iter().map(|s| super::super::cache::fold_key(&s.train_config(&sequences, &both))).collect();
        assert_ne!(keys[0], keys[1]);
        let vehicles_only = FoldSpec { agents: Dynamics::Unicycle, ..specs[0] };
        assert_eq!(
            keys[0],
            super::super::cache::fold_key(&vehicles_only.train_config(&sequences, &config(1))),
            "a vehicle fold's key does not depend on whether pedestrians are in the rule"
        );
        let trained = train_folds(&sequences, &both, &specs, &Quiet).unwrap();
        assert!(trained[0].report.train_instances > 50);
        let walkers = &trained[1].report;
        assert_eq!((walkers.train_instances, walkers.best_epoch, walkers.agents), (0, 0, Dynamics::SingleIntegrator));
        let blob = dynotraj_core::model::blob::ModelBlob::parse(&trained[1].int8_blob).unwrap();
        assert_eq!(blob.dynamics(), Dynamics::SingleIntegrator);
        assert_eq!(*blob.prior(), dynotraj_core::predict::PriorSettings::OFF);
        let mut vehicles = both.clone();
        vehicles.rule = vehicles.rule.for_agents(Dynamics::Unicycle);
        let mut strict = FoldSpec { agents: Dynamics::Unicycle, ..specs[0] }.train_config(&sequences, &vehicles);
        strict.sequences = &sequences[..1];
        strict.exclude = vec!["a".into()];
        let e = dynotraj_train::train_fold(&strict).err().unwrap();
        assert!(format!("{e:#}").contains("no training instances of vehicles"), "{e:#}");
    }

    /// A second restart can only keep a model at least as good on validation as the first,
    /// which is plain training with the fold's seed.
    #[test]
    fn restarts_keep_the_best_validation_model() {
        let sequences: Vec<SequenceTracks> =
            ["a", "b", "c", "d"].iter().zip(1..).map(|(id, s)| sequence(id, s)).collect();
        let mut one = config(1);
        one.folds = vec![vec!["a".into()]];
        let mut two = one.clone();
        two.hyper.restarts = 2;
        let spec = FoldSpec { arm: Source::Gt, fold: 0, seed: 1, agents: Dynamics::Unicycle };
        let plain = dynotraj_train::train_fold(&spec.train_config(&sequences, &one)).unwrap();
        let best = dynotraj_train::train_fold(&spec.train_config(&sequences, &two)).unwrap();
        assert_eq!(plain.report.kept_seed, 1);
        assert!(
            best.report.best_val_ade <= plain.report.best_val_ade,
            "{} > {}",
            best.report.best_val_ade,
            plain.report.best_val_ade
        );
        if best.report.kept_seed == 1 {
            assert_eq!(best.blob(Precision::F32).unwrap(), plain.blob(Precision::F32).unwrap());
        } else {
            assert_eq!(best.report.kept_seed, dynotraj_train::restart_seed(1, 1));
            assert!(best.report.best_val_ade < plain.report.best_val_ade);
        }
    }
}
