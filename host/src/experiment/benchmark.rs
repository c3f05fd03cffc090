//! The generalisation benchmark (not in the paper): every loaded sequence held out once, in
//! folds of several whole sequences, each fold trained with several seeds, every arm scored
//! against its own future and, with the estimated arm, against the simulator's truth and in
//! the deployment comparison (every arm's model on the estimated inputs).

use std::time::Instant;

use super::findings::total_of;
use super::folds::{TrainProgress, train_folds};
use super::{ExperimentConfig, ExperimentResult, FoldReport, check_inputs, fold_specs, score_seed};
use crate::report::{ArmScores, Cell, ColumnKind, Data, Table, forecast_table};
use crate::sequence::SequenceTracks;
use crate::trajectory::Source;

/// The benchmark's seeds by default.
pub const DEFAULT_SEEDS: [u64; 3] = [1, 2, 3];

/// The benchmark's number of folds by default (sixteen sequences: four of four).
pub const DEFAULT_GROUPS: usize = 4;

/// How much better than cv and cv-fit the learned int8 model must be on weighted ADE and FDE
/// for the benchmark's goal (a share: 0.1 = 10 %).
pub const GOAL_GAIN: f64 = 0.10;

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
    anyhow::ensure!(!seeds.is_empty(), "--seeds: expected at least one seed");
    let specs = fold_specs(config, seeds);
    let trained = train_folds(sequences, config, &specs, progress)?;
    let ids = config.test_sequences();
    let mut per_seed = Vec::new();
    for &seed in seeds {
        let mut r = score_seed(sequences, config, &specs, &trained, seed)?;
        r.table = forecast_table(&ids, &r.arms, &[]);
        per_seed.push(r);
    }
    let folds = trained.into_iter().map(|t| t.report).collect();
    Ok(BenchmarkResult { seeds: seeds.to_vec(), per_seed, folds, seconds: start.elapsed().as_secs_f64() })
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

/// The goal, per arm and seed: the learned int8 model's weighted ADE and FDE against cv and
/// cv-fit (change in %, negative is better) and its ACE against cv-fit's; whether the goal
/// ([`GOAL_GAIN`] better than both on ADE and FDE, ACE no worse than cv-fit's) is met.
#[must_use]
pub fn goal_table(result: &BenchmarkResult, arms: &[Source]) -> Table {
    let mut t = Table::new([
        "arm",
        "seed",
        "int8 ADE",
        "vs cv",
        "vs cv-fit",
        "int8 FDE",
        "vs cv",
        "vs cv-fit",
        "int8 ACE",
        "cv-fit ACE",
        "goal met",
    ]);
    let mut d = Data::new([
        ("arm", ColumnKind::Text),
        ("seed", ColumnKind::Int),
        ("int8_ade", ColumnKind::Num),
        ("ade_change_vs_cv_pct", ColumnKind::Num),
        ("ade_change_vs_cv_fit_pct", ColumnKind::Num),
        ("int8_fde", ColumnKind::Num),
        ("fde_change_vs_cv_pct", ColumnKind::Num),
        ("fde_change_vs_cv_fit_pct", ColumnKind::Num),
        ("int8_ace", ColumnKind::Num),
        ("cv_fit_ace", ColumnKind::Num),
        ("goal_met", ColumnKind::Text),
    ]);
    let pct = |a: f64, b: f64| Cell::num(100.0 * (a / b - 1.0), 1);
    for arm in arms {
        for (seed, r) in result.seeds.iter().zip(&result.per_seed) {
            let (Some(l), Some(cv), Some(fit)) = (
                weighted(&r.arms, &format!("learned int8 on {arm}")),
                weighted(&r.arms, &format!("cv on {arm}")),
                weighted(&r.arms, &format!("cv-fit on {arm}")),
            ) else {
                continue;
            };
            let better = |k: usize| l[k] <= (1.0 - GOAL_GAIN) * cv[k] && l[k] <= (1.0 - GOAL_GAIN) * fit[k];
            let met = better(0) && better(1) && l[2] <= fit[2];
            let cells = vec![
                Cell::text(arm.to_string()),
                Cell::int(*seed),
                Cell::num(l[0], 3),
                pct(l[0], cv[0]),
                pct(l[0], fit[0]),
                Cell::num(l[1], 3),
                pct(l[1], cv[1]),
                pct(l[1], fit[1]),
                Cell::num(l[2], 3),
                Cell::num(fit[2], 3),
                Cell::text(if met { "yes" } else { "no" }),
            ];
            // Markdown shows the changes signed, in per cent.
            t.push(cells.iter().enumerate().map(|(i, c)| match (i, c) {
                (3 | 4 | 6 | 7, Cell::Num(v, _)) => format!("{v:+.1} %"),
                _ => c.md(),
            }));
            d.push(cells);
        }
    }
    t.with_data(d)
}

#[cfg(test)]
mod tests {
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
