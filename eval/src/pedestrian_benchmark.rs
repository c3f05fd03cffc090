//! The pedestrian benchmark: ETH/UCY, leave one scene out, as Trajectron++ and Social-GAN run it.
//!
//! Each of the five scenes is held out once: its whole recordings are the test set; every other
//! recording's time split trains (`train/NAME_train.txt`) and selects (`val/NAME_val.txt`). A
//! forecast is scored at every pedestrian with 8 observed positions and 12 after them
//! ([`crate`]'s sources build the windows), one forecast per agent (the most likely mode), ADE
//! and FDE in metres over the 12 steps. Constant velocity, the fold's motion prior (chosen on its
//! training windows) and the learned model in f32 and int8 are scored on the same windows;
//! the model forecasts its whole horizon and the first 12 steps are scored, which is what it
//! was trained on. Ratios carry bootstrap intervals over whole walks (a pedestrian's run).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context as _;
use dynotraj_core::Point2;
use dynotraj_core::limits::HORIZON;
use dynotraj_core::metrics::ForecastScores;
use dynotraj_core::model::arch::Dims;
use dynotraj_core::model::blob::{ModelBlob, Precision};
use dynotraj_core::model::features::FeatureScales;
use dynotraj_core::model::infer::LearnedPredictor;
use dynotraj_core::predict::{
    Carry, Context, Dynamics, Forecast, MotionPrior, Predictor as _, PriorSettings, carry_forward, constant_velocity,
};
use dynotraj_formats::eth_ucy::{PERIOD_S, Recording, read};
use dynotraj_sources::pedestrian_windows::{FUTURE_STEPS, HISTORY_STEPS, Window, windows};
use dynotraj_sources::trajectory::Source;
use dynotraj_train::prior_fit::{PriorInstance, PriorObjective, tune_prior};
use dynotraj_train::{Event, Hyper, Split, TrainConfig, TrainReport, sample_over, train_split};

use crate::experiment::FoldReport;
use crate::experiment::folds::TrainProgress;
use crate::experiment::report::{Report, Section};
use crate::jobs::map_jobs;
use crate::report::Table;
use crate::report::bootstrap::{Metric, RatioInterval, ratio_interval};

/// One scene of the benchmark: its name and the recordings it tests on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Scene {
    /// The name the field gives it.
    pub name: &'static str,
    /// Its recordings (tested whole; never trained or selected on in its fold).
    pub test: &'static [&'static str],
}

/// The five scenes.
pub const SCENES: [Scene; 5] = [
    Scene { name: "eth", test: &["biwi_eth"] },
    Scene { name: "hotel", test: &["biwi_hotel"] },
    Scene { name: "univ", test: &["students001", "students003"] },
    Scene { name: "zara1", test: &["crowds_zara01"] },
    Scene { name: "zara2", test: &["crowds_zara02"] },
];

/// Every recording of the data set (the two that are never a test scene train every fold).
pub const RECORDINGS: [&str; 8] = [
    "biwi_eth",
    "biwi_hotel",
    "crowds_zara01",
    "crowds_zara02",
    "crowds_zara03",
    "students001",
    "students003",
    "uni_examples",
];

/// Trajectron++'s published most-likely ADE / FDE per scene (its evaluation of the same data and
/// splits, one forecast per agent), with the average last.
pub const TRAJECTRON_PP: [(&str, f64, f64); 6] = [
    ("eth", 0.71, 1.68),
    ("hotel", 0.22, 0.46),
    ("univ", 0.41, 1.07),
    ("zara1", 0.30, 0.77),
    ("zara2", 0.23, 0.59),
    ("average", 0.37, 0.95),
];

/// The predictors scored, in table order.
pub const ROWS: [&str; 4] = ["cv", "prior", "learned f32", "learned int8"];

/// How the benchmark runs.
#[derive(Debug, Clone)]
pub struct BenchmarkOptions {
    /// The data folder (`all_data/`, `train/`, `val/`).
    pub data: PathBuf,
    /// Scenes to hold out (names of [`SCENES`]; all when empty).
    pub scenes: Vec<String>,
    /// Network widths.
    pub dims: Dims,
    /// Optimisation settings.
    pub hyper: Hyper,
    /// How the learned model's outputs move its forecast.
    pub dynamics: Dynamics,
    /// Train the learned model (otherwise only cv and the prior are scored).
    pub train: bool,
}

/// One scene's results.
#[derive(Debug, Clone)]
pub struct SceneResult {
    /// The scene's name.
    pub scene: &'static str,
    /// Test windows (forecasts scored per predictor).
    pub windows: usize,
    /// Per predictor of [`ROWS`] (the learned rows absent without training): per walk of the
    /// test recordings, its forecasts' scores.
    pub rows: Vec<(&'static str, Vec<ForecastScores>)>,
    /// The motion prior chosen on the training windows.
    pub prior: PriorSettings,
    /// What training did, when it ran.
    pub training: Option<TrainReport>,
    /// Training and validation windows.
    pub train_windows: (usize, usize),
    /// Wall-clock seconds of the scene's whole run.
    pub seconds: f64,
}

impl SceneResult {
    /// The pooled scores of row `label`.
    #[must_use]
    pub fn total(&self, label: &str) -> Option<ForecastScores> {
        let (_, walks) = self.rows.iter().find(|(l, _)| *l == label)?;
        let mut total = ForecastScores::default();
        for w in walks {
            total.merge(w);
        }
        Some(total)
    }

    /// Row `num` over row `den` in `metric`, with its walk-bootstrap interval.
    #[must_use]
    pub fn ratio(&self, num: &str, den: &str, metric: Metric) -> Option<RatioInterval> {
        let rows = |l: &str| self.rows.iter().find(|(r, _)| *r == l).map(|(_, w)| w);
        ratio_interval(rows(num)?, rows(den)?, metric)
    }
}

/// The path of recording `name` in split `split` (`all_data`, `train`, `val`) of `data`.
#[must_use]
pub fn recording_path(data: &Path, split: &str, name: &str) -> PathBuf {
    match split {
        "all_data" => data.join(split).join(format!("{name}.txt")),
        _ => data.join(split).join(format!("{name}_{split}.txt")),
    }
}

/// The recordings of `names` in `split`.
fn load(data: &Path, split: &str, names: &[&str]) -> anyhow::Result<Vec<Recording>> {
    names.iter().map(|n| Ok(read(&recording_path(data, split, n))?)).collect()
}

/// The scenes `names` asks for (all when empty).
///
/// # Errors
/// A name that is not a scene.
pub fn chosen_scenes(names: &[String]) -> anyhow::Result<Vec<Scene>> {
    if names.is_empty() {
        return Ok(SCENES.to_vec());
    }
    names
        .iter()
        .map(|n| {
            SCENES
                .iter()
                .copied()
                .find(|s| s.name == n)
                .with_context(|| format!("--scenes: no scene {n:?} (expected {})", SCENES.map(|s| s.name).join(", ")))
        })
        .collect()
}

/// The windows of `recordings` with each window's walk made unique across them.
fn windows_of(recordings: &[Recording]) -> Vec<Window> {
    let mut out = Vec::new();
    let mut offset = 0;
    for r in recordings {
        out.extend(windows(r, PERIOD_S).into_iter().map(|w| Window { walk: w.walk + offset, ..w }));
        offset += r.walks.len();
    }
    out
}

/// The motion prior's instances of `windows` (consecutive windows of one walk marked as pairs).
fn prior_instances(windows: &[Window]) -> Vec<PriorInstance> {
    let mut out = Vec::with_capacity(windows.len());
    let mut previous: Option<(usize, u32)> = None;
    for w in windows {
        let follows = previous == Some((w.walk, w.step.wrapping_sub(1)));
        out.extend(PriorInstance::new(w.history.clone(), w.future.clone(), follows));
        previous = Some((w.walk, w.step));
    }
    out
}

/// Training samples of `windows` over motion prior `prior`, grouped by walk, with the features of
/// the dynamics `config` trains (so the blob's dynamics, which inference reads them by, and the
/// samples cannot disagree).
fn samples(windows: &[Window], prior: &PriorSettings, config: &TrainConfig<'_>) -> Vec<dynotraj_train::Sample> {
    let scales = FeatureScales::of(config.dynamics);
    windows
        .iter()
        .filter_map(|w| {
            let refs = w.neighbour_histories();
            let context = Context::with_neighbours(&refs);
            sample_over(
                &w.states(PERIOD_S),
                HISTORY_STEPS - 1,
                FUTURE_STEPS,
                &context,
                config.dt,
                w.walk,
                prior,
                &scales,
            )
        })
        .collect()
}

/// Scores of `predict` on every window, one entry per walk (in walk order). A window that
/// follows another of its walk by one step is blended with that one's forecast by `carry`, as
/// a forecaster running frame after frame does (and as the prior's tuning scores them).
fn score(
    windows: &[Window],
    carry: Carry,
    mut predict: impl FnMut(&Window, &mut Forecast) -> bool,
) -> Vec<ForecastScores> {
    let mut per_walk: Vec<ForecastScores> = Vec::new();
    let mut last_walk = None;
    let mut out: Forecast = [Point2::default(); HORIZON];
    let mut previous: Option<(usize, u32, Forecast)> = None;
    for w in windows {
        if last_walk != Some(w.walk) {
            per_walk.push(ForecastScores::default());
            last_walk = Some(w.walk);
        }
        let Some(scores) = per_walk.last_mut() else { continue };
        if !predict(w, &mut out) {
            previous = None;
            continue;
        }
        if let Some((walk, step, last)) = &previous
            && *walk == w.walk
            && step.wrapping_add(1) == w.step
        {
            carry_forward(last, carry, &mut out);
        }
        previous = Some((w.walk, w.step, out));
        let errors: Vec<f32> = out.iter().zip(&w.future).map(|(p, q)| p.distance(q)).collect();
        let n = errors.len().max(1) as f32;
        scores.ade.push(errors.iter().sum::<f32>() / n);
        scores.fde.push(errors.last().copied().unwrap_or(f32::NAN));
    }
    per_walk
}

/// Runs one scene: chooses the prior and trains on the other recordings, scores the scene's.
///
/// # Errors
/// A recording that cannot be read; no training window; training errors.
pub fn run_scene(
    scene: Scene,
    options: &BenchmarkOptions,
    observer: &mut dyn FnMut(Event),
) -> anyhow::Result<SceneResult> {
    let start = Instant::now();
    let trained_on: Vec<&str> = RECORDINGS.iter().copied().filter(|r| !scene.test.contains(r)).collect();
    let train = windows_of(&load(&options.data, "train", &trained_on)?);
    let val = windows_of(&load(&options.data, "val", &trained_on)?);
    let test = windows_of(&load(&options.data, "all_data", scene.test)?);
    anyhow::ensure!(!train.is_empty(), "scene {}: no training window in {trained_on:?}", scene.name);
    let prior = tune_prior(&prior_instances(&train), PERIOD_S, PriorObjective::Ade);
    let dt = PERIOD_S;
    let mut rows: Vec<(&'static str, Vec<ForecastScores>)> = vec![
        ("cv", score(&test, Carry::NONE, |w, out| constant_velocity(&w.history, dt, out).is_ok())),
        ("prior", score(&test, prior.carry(), |w, out| MotionPrior(prior).predict(&w.history, dt, out).is_ok())),
    ];
    let training = if options.train {
        let config = TrainConfig {
            dt,
            dims: options.dims,
            hyper: options.hyper,
            dynamics: options.dynamics,
            ..TrainConfig::new(&[], Vec::new(), Source::Gt)
        };
        let split = Split { train: samples(&train, &prior, &config), validation: samples(&val, &prior, &config) };
        let names = trained_on.iter().map(|n| (*n).to_owned()).collect();
        let model = train_split(split, names, prior, &config, start, observer)?;
        for (label, precision) in [("learned f32", Precision::F32), ("learned int8", Precision::Int8)] {
            let bytes = model.blob(precision)?;
            let blob = ModelBlob::parse(&bytes).map_err(|e| anyhow::anyhow!("the {label} blob: {e:?}"))?;
            anyhow::ensure!(
                blob.dynamics() == options.dynamics,
                "the {label} blob forecasts with {} dynamics, its samples were made for {}",
                blob.dynamics().name(),
                options.dynamics.name()
            );
            let carry = blob.prior().carry();
            let mut learned = LearnedPredictor::new(blob);
            rows.push((
                label,
                score(&test, carry, |w, out| {
                    let refs = w.neighbour_histories();
                    learned.predict_in_context(&w.history, &Context::with_neighbours(&refs), dt, out).is_ok()
                }),
            ));
        }
        Some(model.report)
    } else {
        None
    };
    Ok(SceneResult {
        scene: scene.name,
        windows: test.len(),
        rows,
        prior,
        training,
        train_windows: (train.len(), val.len()),
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// Every scene `options` asks for, on a pool of `jobs` threads, in [`SCENES`] order; `progress`
/// hears each scene's training (labelled by the scene's name).
///
/// # Errors
/// An unknown scene; see [`run_scene`].
pub fn run(options: &BenchmarkOptions, jobs: usize, progress: &dyn TrainProgress) -> anyhow::Result<Vec<SceneResult>> {
    let scenes = chosen_scenes(&options.scenes)?;
    progress.training(if options.train { scenes.len() } else { 0 });
    map_jobs(&scenes, jobs, |scene| {
        let result = run_scene(*scene, options, &mut |e| progress.event(scene.name, e))?;
        if let Some(fold) = fold_reports(std::slice::from_ref(&result), options.hyper.seed).first() {
            progress.done(scene.name, fold);
        }
        Ok(result)
    })?
    .into_iter()
    .collect()
}

/// A mean of metres as the tables print it.
fn metres(v: Option<f64>) -> String {
    v.map_or_else(|| "-".to_owned(), |v| format!("{v:.3}"))
}

/// A ratio and its interval as the tables print it.
fn interval(r: Option<RatioInterval>) -> String {
    r.map_or_else(|| "-".to_owned(), |r| format!("{:.3} [{:.3}, {:.3}]", r.ratio, r.low, r.high))
}

/// ADE and FDE per scene and predictor, the average over the scenes (the field's average: each
/// scene counts once), and Trajectron++'s published row beside them.
#[must_use]
pub fn scene_table(results: &[SceneResult]) -> Table {
    let mut headers = vec!["scene".to_owned(), "test windows".to_owned()];
    for row in ROWS {
        headers.push(format!("{row} ADE"));
        headers.push(format!("{row} FDE"));
    }
    headers.extend(["Trajectron++ ADE".to_owned(), "Trajectron++ FDE".to_owned()]);
    let mut t = Table::new(headers);
    let published = |scene: &str| TRAJECTRON_PP.iter().find(|(s, _, _)| *s == scene).map(|&(_, a, f)| (a, f));
    let mut sums = [[(0.0f64, 0usize); 2]; ROWS.len()];
    for r in results {
        let mut cells = vec![r.scene.to_owned(), r.windows.to_string()];
        for (k, row) in ROWS.iter().enumerate() {
            let total = r.total(row);
            for (m, value) in [total.as_ref().and_then(|t| t.ade.value()), total.as_ref().and_then(|t| t.fde.value())]
                .into_iter()
                .enumerate()
            {
                if let (Some(v), Some(sum)) = (value, sums.get_mut(k).and_then(|s| s.get_mut(m))) {
                    *sum = (sum.0 + v, sum.1 + 1);
                }
                cells.push(metres(value));
            }
        }
        let (a, f) = published(r.scene).unzip();
        cells.extend([metres(a), metres(f)]);
        t.push(cells);
    }
    if results.len() > 1 {
        let mut cells = vec!["average".to_owned(), results.iter().map(|r| r.windows).sum::<usize>().to_string()];
        for (k, _) in ROWS.iter().enumerate() {
            for m in 0..2 {
                let (sum, n) = sums.get(k).and_then(|s| s.get(m)).copied().unwrap_or((0.0, 0));
                cells.push(metres((n == results.len()).then(|| sum / n as f64)));
            }
        }
        let every_scene = results.len() == SCENES.len();
        let (a, f) = published("average").filter(|_| every_scene).unzip();
        cells.extend([metres(a), metres(f)]);
        t.push(cells);
    }
    t
}

/// Ratios of ADE and FDE with their bootstrap intervals over walks, per scene and pooled over
/// every scene's walks.
#[must_use]
pub fn ratio_table(results: &[SceneResult]) -> Table {
    let pairs = [
        ("learned int8", "cv", Metric::Ade),
        ("learned int8", "prior", Metric::Ade),
        ("prior", "cv", Metric::Ade),
        ("learned int8", "cv", Metric::Fde),
    ];
    let mut headers = vec!["scene".to_owned()];
    headers
        .extend(pairs.iter().map(|(n, d, m)| format!("{n} / {d} {}", if *m == Metric::Ade { "ADE" } else { "FDE" })));
    let mut t = Table::new(headers);
    let mut pooled: Vec<(&'static str, Vec<ForecastScores>)> = ROWS.iter().map(|r| (*r, Vec::new())).collect();
    for r in results {
        let mut cells = vec![r.scene.to_owned()];
        cells.extend(pairs.iter().map(|(n, d, m)| interval(r.ratio(n, d, *m))));
        t.push(cells);
        for (label, walks) in &r.rows {
            if let Some((_, all)) = pooled.iter_mut().find(|(l, _)| l == label) {
                all.extend(walks.iter().copied());
            }
        }
    }
    if results.len() > 1 {
        let all = SceneResult {
            scene: "all walks",
            windows: 0,
            rows: pooled,
            prior: PriorSettings::OFF,
            training: None,
            train_windows: (0, 0),
            seconds: 0.0,
        };
        let mut cells = vec![all.scene.to_owned()];
        cells.extend(pairs.iter().map(|(n, d, m)| interval(all.ratio(n, d, *m))));
        t.push(cells);
    }
    t
}

/// Each scene's training: its windows, the epoch kept and the judged validation gain over the
/// prior.
#[must_use]
pub fn training_table(results: &[SceneResult]) -> Table {
    let mut t = Table::new([
        "scene",
        "train windows",
        "val windows",
        "epoch kept",
        "best epoch's val ADE / prior's [95 %]",
        "val cv ADE",
        "val prior ADE",
        "val ADE kept",
        "seconds",
    ]);
    for r in results {
        let Some(tr) = r.training.as_ref() else { continue };
        t.push([
            r.scene.to_owned(),
            r.train_windows.0.to_string(),
            r.train_windows.1.to_string(),
            tr.best_epoch.to_string(),
            interval(tr.gain),
            format!("{:.3}", tr.val_cv_ade),
            format!("{:.3}", tr.val_prior_ade),
            format!("{:.3}", tr.best_val_ade),
            format!("{:.0}", tr.seconds),
        ]);
    }
    t
}

/// Each scene's training as the experiment's fold summary reads it.
#[must_use]
pub fn fold_reports(results: &[SceneResult], seed: u64) -> Vec<FoldReport> {
    results
        .iter()
        .filter_map(|r| {
            let t = r.training.as_ref()?;
            Some(FoldReport {
                arm: Source::Gt,
                agents: Dynamics::SingleIntegrator,
                sequence: r.scene.to_owned(),
                seed,
                train_instances: t.train_instances,
                val_ade: t.best_val_ade,
                val_cv_ade: t.val_cv_ade,
                val_prior_ade: t.val_prior_ade,
                prior: r.prior,
                best_epoch: t.best_epoch,
                shrink: t.shrink,
                seconds: t.seconds,
                cached: false,
            })
        })
        .collect()
}

/// The report of a run of `options`: the scene table, the ratios, the folds.
#[must_use]
pub fn report(results: &[SceneResult], options: &BenchmarkOptions, command: String, seconds: f64) -> Report {
    let section = |stem: &str, title: &str, caption: &str, table: Table| Section {
        stem: stem.to_owned(),
        title: title.to_owned(),
        caption: caption.to_owned(),
        table,
    };
    Report {
        title: "Pedestrians: ETH/UCY, leave one scene out".to_owned(),
        command,
        sections: vec![
            section(
                "scenes",
                "ADE / FDE per scene (metres, one forecast per agent)",
                "8 observed positions (3.2 s), 12 forecast (4.8 s), every window of the scene's recordings. \
                 The average counts each scene once. Trajectron++'s row is its published most-likely \
                 evaluation of the same data and splits; its preprocessing differentiates whole tracks, so its \
                 newest velocity sees one future step, ours does not.",
                scene_table(results),
            ),
            section(
                "ratios",
                "Ratios with 95 % bootstrap intervals over walks",
                "Each walk (a pedestrian's consecutive observations) is one resampling unit.",
                ratio_table(results),
            ),
            section(
                "training",
                "Training per scene",
                "A trained epoch is kept only when its validation gain over the prior holds under a \
                 bootstrap over walks (upper end below 1); otherwise the scene ships the prior (epoch 0).",
                training_table(results),
            ),
        ],
        folds: fold_reports(results, options.hyper.seed),
        seconds,
        notes: vec![format!(
            "Learned model: widths {:?}, {} dynamics, seed {}, at most {} epochs; the prior and the \
             model chosen on the training recordings' train windows, the epoch on their val windows.",
            options.dims,
            options.dynamics.name(),
            options.hyper.seed,
            options.hyper.epochs
        )],
        figures: Vec::new(),
    }
}

#[cfg(test)]
mod tests;
