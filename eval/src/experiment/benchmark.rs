//! The generalisation benchmark (not in the paper): every loaded sequence held out once, in
//! folds of several whole sequences, each fold trained with several seeds, every arm scored
//! against its own future and, with the estimated arm, against the simulator's truth and in
//! the deployment comparison (every arm's model on the estimated inputs).

use std::time::Instant;

use super::findings::total_of;
use super::folds::{FoldSpec, TrainProgress, train_folds};
use super::{ExperimentConfig, ExperimentResult, FoldReport, check_inputs, fold_specs, score_seed};
use crate::report::{ArmScores, Cell, ColumnKind, Data, Table, forecast_table};
use dynotraj_core::predict::Dynamics;
use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::Source;

/// The benchmark's seeds by default.
pub const DEFAULT_SEEDS: [u64; 3] = [1, 2, 3];

/// The benchmark's number of folds by default (sixteen sequences: four of four).
pub const DEFAULT_GROUPS: usize = 4;

/// The goal's largest ratio of the learned int8 model's weighted ADE and FDE to cv's.
pub const GOAL_VS_CV: f64 = 0.88;
/// The goal's bound on the upper end of that ratio's 95 % interval.
pub const GOAL_VS_CV_HIGH: f64 = 0.92;
/// The goal's largest ratio of the learned int8 model's weighted ADE and FDE to the motion
/// prior's (its interval's upper end must also be below 1).
pub const GOAL_VS_PRIOR: f64 = 0.97;

/// Splits `ids` into `groups` folds: sorted, then dealt out in turn (fold k holds the k-th,
/// (k + groups)-th, ... sequence), so the folds mix early and late drives. Fewer ids than
/// groups give one fold per id.
#[must_use]
pub fn sequence_groups(ids: &[String], groups: usize) -> Vec<Vec<String>> {
    let mut sorted = ids.to_vec();
    sorted.sort();
    sorted.dedup();
    let n = groups.clamp(1, sorted.len().max(1));
    let mut out = vec![Vec::new(); n];
    for (i, id) in sorted.into_iter().enumerate() {
        if let Some(f) = out.get_mut(i % n) {
            f.push(id);
        }
    }
    out.retain(|f| !f.is_empty());
    out
}

/// The benchmark's results: one experiment result per seed.
#[derive(Debug, Clone)]
pub struct BenchmarkResult {
    /// The seeds, in order.
    pub seeds: Vec<u64>,
    /// Per seed: the tables and rows (the per-sequence layout of Table IV without the paper's
    /// rows, which are on other folds).
    pub per_seed: Vec<ExperimentResult>,
    /// Every fold trained, every seed.
    pub folds: Vec<FoldReport>,
    /// Wall-clock seconds of training and scoring.
    pub seconds: f64,
}

/// Trains every (arm, fold, seed) on `config.jobs` threads and scores each seed.
///
/// # Errors
/// See [`super::run_experiment`].
pub fn run_benchmark(
    sequences: &[SequenceTracks],
    config: &ExperimentConfig,
    seeds: &[u64],
    progress: &dyn TrainProgress,
) -> anyhow::Result<BenchmarkResult> {
    let start = Instant::now();
    check_inputs(sequences, config)?;
    let config = &config.with_present_agents(sequences);
    anyhow::ensure!(!seeds.is_empty(), "--seeds: expected at least one seed");
    let specs = fold_specs(config, seeds);
    let trained = train_folds(sequences, config, &specs, progress)?;
    let ids = config.test_sequences();
    let mut per_seed = Vec::new();
    for &seed in seeds {
        let mut r = score_seed(sequences, config, &specs, &trained, seed)?;
        r.table = forecast_table(&ids, &r.arms, &[]);
        for other in &mut r.other_agents {
            other.table = forecast_table(&ids, &other.arms, &[]);
        }
        per_seed.push(r);
    }
    let folds = trained.into_iter().map(|t| t.report).collect();
    Ok(BenchmarkResult { seeds: seeds.to_vec(), per_seed, folds, seconds: start.elapsed().as_secs_f64() })
}

impl BenchmarkResult {
    /// The agent types scored, the first (whose rows `per_seed` holds) first.
    #[must_use]
    pub fn agent_types(&self) -> Vec<Dynamics> {
        self.per_seed
            .first()
            .map(|r| std::iter::once(r.agents).chain(r.other_agents.iter().map(|o| o.agents)).collect())
            .unwrap_or_default()
    }

    /// The benchmark of agent type `agents` alone, as if run for it only: its rows per seed
    /// and its folds. `None` when it was not scored.
    #[must_use]
    pub fn of_agents(&self, agents: Dynamics) -> Option<Self> {
        let per_seed = self
            .per_seed
            .iter()
            .map(|r| {
                if r.agents == agents {
                    Some(ExperimentResult { other_agents: Vec::new(), ..r.clone() })
                } else {
                    r.other_agents.iter().find(|o| o.agents == agents).cloned()
                }
            })
            .collect::<Option<Vec<_>>>()?;
        let folds = self.folds.iter().filter(|f| f.agents == agents).cloned().collect();
        Some(Self { seeds: self.seeds.clone(), per_seed, folds, seconds: self.seconds })
    }
}

/// One of `count` equal parts of a run's work, `index` from 0: the units whose number modulo
/// `count` is `index` (a cluster's array job runs each part on its own machine).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// Which part, from 0.
    pub index: usize,
    /// How many parts.
    pub count: usize,
}

/// The environment variables a cluster's array job gives each task its index in: Kubernetes
/// Indexed Jobs, then Slurm job arrays.
pub const SHARD_INDEX_VARIABLES: [&str; 2] = ["JOB_COMPLETION_INDEX", "SLURM_ARRAY_TASK_ID"];

impl Shard {
    /// `I/N`, or `N` alone with the index taken from `index_of` (a variable's value by name:
    /// the first of [`SHARD_INDEX_VARIABLES`] that is set).
    ///
    /// # Errors
    /// Anything else, saying what was expected.
    pub fn parse_with(text: &str, index_of: impl Fn(&str) -> Option<String>) -> Result<Self, String> {
        let expected = || {
            format!(
                "expected I/N with 0 <= I < N (e.g. 0/4), or N with the index in {}, found `{text}`",
                SHARD_INDEX_VARIABLES.join(" or ")
            )
        };
        let number = |t: &str| t.trim().parse::<usize>().map_err(|_| expected());
        let (index, count) = match text.split_once('/') {
            Some((i, n)) => (number(i)?, number(n)?),
            None => {
                let count = number(text)?;
                let (name, value) = SHARD_INDEX_VARIABLES
                    .iter()
                    .find_map(|v| index_of(v).map(|value| (*v, value)))
                    .ok_or_else(|| {
                        format!(
                            "--shard {text}: neither {} is set, so the index is unknown",
                            SHARD_INDEX_VARIABLES.join(" nor ")
                        )
                    })?;
                let index =
                    value.trim().parse::<usize>().map_err(|_| format!("{name}={value}: expected a whole number"))?;
                if index >= count {
                    return Err(format!("{name}={index} is not below the {count} shards of --shard {text}"));
                }
                (index, count)
            }
        };
        if index < count { Ok(Self { index, count }) } else { Err(expected()) }
    }

    /// Whether the unit at `position` (from 0, in the run's order) is this shard's.
    #[must_use]
    pub const fn takes(&self, position: usize) -> bool {
        position % self.count == self.index
    }
}

impl std::str::FromStr for Shard {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        Self::parse_with(text, |name| std::env::var(name).ok())
    }
}

/// Trains (or finds in the fold cache) this shard's part of the benchmark's folds: every fold,
/// seed and arm in [`fold_specs`] order, those whose position modulo `shard.count` is
/// `shard.index`. The fold cache is the store the shards share: a run without a shard then
/// reads every fold from it and writes the report. Returns (folds of this shard, folds in all).
///
/// # Errors
/// No fold cache (without one a shard's work would be lost); what [`train_folds`] returns.
pub fn train_shard(
    sequences: &[SequenceTracks],
    config: &ExperimentConfig,
    seeds: &[u64],
    shard: Shard,
    progress: &dyn TrainProgress,
) -> anyhow::Result<(usize, usize)> {
    check_inputs(sequences, config)?;
    let config = &config.with_present_agents(sequences);
    anyhow::ensure!(
        config.cache.is_some(),
        "--shard: needs a fold cache (--out DIR, without --no-cache): it is where the shards' folds meet"
    );
    let specs = fold_specs(config, seeds);
    let mine: Vec<FoldSpec> = specs.iter().enumerate().filter(|(k, _)| shard.takes(*k)).map(|(_, s)| *s).collect();
    train_folds(sequences, config, &mine, progress)?;
    Ok((mine.len(), specs.len()))
}

/// The weighted (per forecast) ADE, FDE and ACE of the row labelled `label`.
/// `None` when a metric has no value.
fn weighted(rows: &[ArmScores], label: &str) -> Option<[f64; 3]> {
    total_of(rows, label).filter(|v| v.iter().all(|x| x.is_finite()))
}

/// One row per (metric, row label) of `rows_of` (per seed), the seeds side by side, their mean
/// and spread (largest minus smallest).
#[must_use]
pub fn seeds_table(result: &BenchmarkResult, rows_of: impl Fn(&ExperimentResult) -> Option<&[ArmScores]>) -> Table {
    let mut headers = vec!["metric".to_string(), "row".to_string()];
    headers.extend(result.seeds.iter().map(|s| format!("seed {s}")));
    headers.extend(["mean".to_string(), "spread".to_string()]);
    let mut t = Table::new(headers);
    // Data: per row label, one row per seed (then the mean and the spread) with its three metrics.
    let mut d = Data::new([
        ("row_kind", ColumnKind::Text),
        ("arm", ColumnKind::Text),
        ("seed", ColumnKind::Int),
        ("ade", ColumnKind::Num),
        ("fde", ColumnKind::Num),
        ("ace", ColumnKind::Num),
    ]);
    let Some(first) = result.per_seed.first().and_then(&rows_of) else { return t.with_data(d) };
    let mut cells: Vec<Vec<[Cell; 3]>> = vec![Vec::new(); first.len()];
    for (m, metric) in ["ADE", "FDE", "ACE"].into_iter().enumerate() {
        for (a, arm) in first.iter().enumerate() {
            let values: Vec<Option<f64>> = result
                .per_seed
                .iter()
                .map(|r| rows_of(r).and_then(|rows| weighted(rows, &arm.label)).map(|v| v[m]))
                .collect();
            let known: Vec<f64> = values.iter().flatten().copied().collect();
            let mean = (!known.is_empty()).then(|| known.iter().sum::<f64>() / known.len() as f64);
            let spread = (!known.is_empty()).then(|| {
                known.iter().copied().fold(f64::MIN, f64::max) - known.iter().copied().fold(f64::MAX, f64::min)
            });
            let row_cells: Vec<Cell> = values.iter().chain([&mean, &spread]).map(|v| Cell::opt(*v, 3)).collect();
            let mut row = vec![metric.to_string(), arm.label.clone()];
            row.extend(row_cells.iter().map(Cell::md));
            t.push(row);
            if let Some(per_arm) = cells.get_mut(a) {
                per_arm.resize(row_cells.len(), [Cell::Missing, Cell::Missing, Cell::Missing]);
                for (slot, c) in per_arm.iter_mut().zip(row_cells) {
                    slot[m] = c;
                }
            }
        }
    }
    for (arm, per_arm) in first.iter().zip(cells) {
        let n = result.seeds.len();
        for (i, metrics) in per_arm.into_iter().enumerate() {
            let (kind, seed) = match i.checked_sub(n) {
                None => ("data", result.seeds.get(i).map_or(Cell::Missing, |s| Cell::int(*s))),
                Some(0) => ("mean", Cell::Blank),
                Some(_) => ("spread", Cell::Blank),
            };
            d.push([Cell::text(kind), Cell::text(arm.label.as_str()), seed].into_iter().chain(metrics).collect());
        }
    }
    t.with_data(d)
}

/// The goal, per arm and seed, with run-bootstrap intervals ([`crate::report::bootstrap`]):
/// the learned int8 model's weighted ADE and FDE as ratios to cv's and to the motion prior's,
/// the prior's to cv's, and ACE against cv's. Met when the model is at most
/// [`GOAL_VS_CV`] of cv on ADE and FDE with the interval's upper end below
/// [`GOAL_VS_CV_HIGH`], at most [`GOAL_VS_PRIOR`] of the prior with the interval's upper end
/// below 1, and its ACE no worse than cv's.
#[must_use]
pub fn goal_table(result: &BenchmarkResult, arms: &[Source]) -> Table {
    use crate::report::bootstrap::{Metric, RatioInterval, ratio_interval};
    let mut t = Table::new([
        "arm",
        "seed",
        "int8 ADE",
        "ADE / cv",
        "ADE / prior",
        "int8 FDE",
        "FDE / cv",
        "FDE / prior",
        "prior ADE / cv",
        "int8 ACE",
        "cv ACE",
        "folds keeping a trained epoch",
        "goal met",
    ]);
    let mut columns = vec![("arm", ColumnKind::Text), ("seed", ColumnKind::Int)];
    let ratio_columns = [
        ["ade_vs_cv", "ade_vs_cv_low", "ade_vs_cv_high"],
        ["ade_vs_prior", "ade_vs_prior_low", "ade_vs_prior_high"],
        ["fde_vs_cv", "fde_vs_cv_low", "fde_vs_cv_high"],
        ["fde_vs_prior", "fde_vs_prior_low", "fde_vs_prior_high"],
        ["prior_ade_vs_cv", "prior_ade_vs_cv_low", "prior_ade_vs_cv_high"],
    ];
    columns.push(("int8_ade", ColumnKind::Num));
    columns.push(("int8_fde", ColumnKind::Num));
    for names in &ratio_columns {
        columns.extend(names.iter().map(|n| (*n, ColumnKind::Num)));
    }
    columns.extend([
        ("int8_ace", ColumnKind::Num),
        ("cv_ace", ColumnKind::Num),
        ("folds_trained", ColumnKind::Int),
        ("folds", ColumnKind::Int),
        ("goal_met", ColumnKind::Text),
    ]);
    let mut d = Data::new(columns);
    let md = |r: &Option<RatioInterval>| {
        r.map_or_else(|| "-".to_string(), |r| format!("{:.3} [{:.3}, {:.3}]", r.ratio, r.low, r.high))
    };
    for arm in arms {
        for (seed, r) in result.seeds.iter().zip(&result.per_seed) {
            let row = |label: String| r.arms.iter().find(|a| a.label == label);
            let (Some(l), Some(cv), Some(prior)) =
                (row(format!("learned int8 on {arm}")), row(format!("cv on {arm}")), row(format!("prior on {arm}")))
            else {
                continue;
            };
            let (Some(lw), Some(cvw)) = (weighted(&r.arms, &l.label), weighted(&r.arms, &cv.label)) else {
                continue;
            };
            let ratios = [
                ratio_interval(&l.per_run, &cv.per_run, Metric::Ade),
                ratio_interval(&l.per_run, &prior.per_run, Metric::Ade),
                ratio_interval(&l.per_run, &cv.per_run, Metric::Fde),
                ratio_interval(&l.per_run, &prior.per_run, Metric::Fde),
                ratio_interval(&prior.per_run, &cv.per_run, Metric::Ade),
            ];
            let vs_cv = |i: usize| ratios[i].is_some_and(|x| x.ratio <= GOAL_VS_CV && x.high < GOAL_VS_CV_HIGH);
            let vs_prior = |i: usize| ratios[i].is_some_and(|x| x.ratio <= GOAL_VS_PRIOR && x.high < 1.0);
            let met = vs_cv(0) && vs_cv(2) && vs_prior(1) && vs_prior(3) && lw[2] <= cvw[2];
            let verdict = if met { "yes" } else { "no" };
            let folds: Vec<&FoldReport> = result.folds.iter().filter(|f| f.arm == *arm && f.seed == *seed).collect();
            let trained = folds.iter().filter(|f| f.best_epoch > 0).count();
            t.push([
                arm.to_string(),
                seed.to_string(),
                format!("{:.3}", lw[0]),
                md(&ratios[0]),
                md(&ratios[1]),
                format!("{:.3}", lw[1]),
                md(&ratios[2]),
                md(&ratios[3]),
                md(&ratios[4]),
                format!("{:.3}", lw[2]),
                format!("{:.3}", cvw[2]),
                format!("{trained} / {}", folds.len()),
                verdict.to_string(),
            ]);
            let mut cells =
                vec![Cell::text(arm.to_string()), Cell::int(*seed), Cell::num(lw[0], 3), Cell::num(lw[1], 3)];
            for r in &ratios {
                cells.extend([
                    Cell::opt(r.map(|x| x.ratio), 4),
                    Cell::opt(r.map(|x| x.low), 4),
                    Cell::opt(r.map(|x| x.high), 4),
                ]);
            }
            cells.extend([
                Cell::num(lw[2], 3),
                Cell::num(cvw[2], 3),
                Cell::int(trained),
                Cell::int(folds.len()),
                Cell::text(verdict),
            ]);
            d.push(cells);
        }
    }
    t.with_data(d)
}

#[cfg(test)]
mod tests {
    #[test]
    fn shards_parse_as_index_of_count_or_take_the_index_from_the_job() {
        let none = |_: &str| None;
        assert_eq!(Shard::parse_with("1/4", none), Ok(Shard { index: 1, count: 4 }));
        for bad in ["4/4", "a/2", "1/0", "-1/2", "x"] {
            let e = Shard::parse_with(bad, none).unwrap_err();
            assert!(e.starts_with("expected I/N with 0 <= I < N") && e.contains(bad), "{bad}: {e}");
        }
        let e = Shard::parse_with("4", none).unwrap_err();
        assert!(e.contains("neither JOB_COMPLETION_INDEX nor SLURM_ARRAY_TASK_ID is set"), "{e}");
        let slurm = |name: &str| (name == "SLURM_ARRAY_TASK_ID").then(|| "3".to_string());
        assert_eq!(Shard::parse_with("4", slurm), Ok(Shard { index: 3, count: 4 }));
        let both = |name: &str| Some(if name == "JOB_COMPLETION_INDEX" { "0" } else { "3" }.to_string());
        assert_eq!(Shard::parse_with("4", both), Ok(Shard { index: 0, count: 4 }), "Kubernetes first");
        let e = Shard::parse_with("2", slurm).unwrap_err();
        assert_eq!(e, "SLURM_ARRAY_TASK_ID=3 is not below the 2 shards of --shard 2");
    }

    use super::*;

    fn ids(v: &[&str]) -> Vec<String> {
        v.iter().map(ToString::to_string).collect()
    }

    #[test]
    fn every_sequence_is_in_exactly_one_group() {
        let all = ids(&[
            "0013", "0000", "0001", "0002", "0003", "0004", "0005", "0006", "0007", "0008", "0009", "0010", "0011",
            "0012", "0018", "0020",
        ]);
        let g = sequence_groups(&all, 4);
        assert_eq!(g.len(), 4);
        assert_eq!(g[0], ids(&["0000", "0004", "0008", "0012"]));
        assert_eq!(g[3], ids(&["0003", "0007", "0011", "0020"]));
        let mut flat: Vec<String> = g.concat();
        flat.sort();
        let mut sorted = all.clone();
        sorted.sort();
        assert_eq!(flat, sorted);
        assert_eq!(sequence_groups(&ids(&["0001", "0000"]), 4), vec![ids(&["0000"]), ids(&["0001"])]);
        assert!(sequence_groups(&[], 4).is_empty());
    }
}
