//! The paper's Table IV layout: ADE, FDE and ACE per sequence and their weighted average (per
//! forecast), one row per arm, optionally beside published reference rows.
//!
//! Its data (CSV, JSON) has one row per arm and sequence: `row_kind` (`data`, `weighted_average`
//! over the sequences, `paper` and `paper_average` for published figures), `arm`, `sequence`
//! (empty on averages), `ade`, `fde`, `ace`, `instances` (ADE/FDE), `ace_pairs`.

use dynotraj_core::metrics::{ForecastScores, Mean};

use super::{Cell, ColumnKind, Data, Table, fmt_opt};

/// One arm's scores, one entry per sequence (in the table's column order).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ArmScores {
    /// Row label.
    pub label: String,
    /// Scores per sequence.
    pub per_sequence: Vec<ForecastScores>,
    /// Scores per object run, every sequence's in turn (the units of the bootstrap
    /// intervals: [`super::bootstrap`]). Rows of one source list the same runs in the same
    /// order.
    pub per_run: Vec<ForecastScores>,
}

impl ArmScores {
    /// An empty row labelled `label`.
    #[must_use]
    pub fn new(label: impl Into<String>) -> Self {
        Self { label: label.into(), ..Self::default() }
    }

    /// Adds one sequence's scores and its runs'.
    pub fn push_sequence(&mut self, scores: &crate::forecast_eval::ForecastRunScores) {
        self.per_sequence.push(scores.scores);
        self.per_run.extend_from_slice(&scores.runs);
    }

    /// The weighted average over every sequence (per forecast, as the paper reports).
    #[must_use]
    pub fn total(&self) -> ForecastScores {
        let mut t = ForecastScores::default();
        for s in &self.per_sequence {
            t.merge(s);
        }
        t
    }
}

/// Published figures to print beside measured rows: per metric, per sequence (aligned with the
/// table's columns; `None` where not published) and the average.
#[derive(Debug, Clone, PartialEq)]
pub struct ReferenceRow {
    /// Row label, e.g. "paper: GT".
    pub label: String,
    /// (ADE, FDE, ACE) per column.
    pub per_sequence: Vec<Option<[f64; 3]>>,
    /// (ADE, FDE, ACE) averages.
    pub average: [f64; 3],
}

/// Builds the table: for each metric, the measured arms then the reference rows; last, the
/// instance (and ACE pair) counts: one row when all arms share them, else one per distinct set.
#[must_use]
pub fn forecast_table(ids: &[String], arms: &[ArmScores], references: &[ReferenceRow]) -> Table {
    markdown(ids, arms, references).with_data(forecast_data(ids, arms, references))
}

/// One row per arm and sequence (then the arm's weighted average), the references after.
fn forecast_data(ids: &[String], arms: &[ArmScores], references: &[ReferenceRow]) -> Data {
    use ColumnKind::{Int, Num, Text};
    let mut d = Data::new([
        ("row_kind", Text),
        ("arm", Text),
        ("sequence", Text),
        ("ade", Num),
        ("fde", Num),
        ("ace", Num),
        ("instances", Int),
        ("ace_pairs", Int),
    ]);
    let scores = |s: &ForecastScores| {
        [s.ade.value(), s.fde.value(), s.ace.value()]
            .map(|v| Cell::opt(v, 2))
            .into_iter()
            .chain([Cell::int(s.ade.count()), Cell::int(s.ace.count())])
    };
    for arm in arms {
        let head = |kind: &str, seq: Cell| [Cell::text(kind), Cell::text(arm.label.as_str()), seq];
        for (id, s) in ids.iter().zip(&arm.per_sequence) {
            d.push(head("data", Cell::text(id.as_str())).into_iter().chain(scores(s)).collect());
        }
        d.push(head("weighted_average", Cell::Blank).into_iter().chain(scores(&arm.total())).collect());
    }
    for r in references {
        let head = |kind: &str, seq: Cell| [Cell::text(kind), Cell::text(r.label.as_str()), seq];
        for (id, v) in ids.iter().zip(&r.per_sequence) {
            let m = |i: usize| Cell::opt(v.map(|v| v[i]), 2);
            d.push(
                head("paper", Cell::text(id.as_str()))
                    .into_iter()
                    .chain([m(0), m(1), m(2), Cell::Blank, Cell::Blank])
                    .collect(),
            );
        }
        let a = r.average.map(|v| Cell::num(v, 2));
        d.push(head("paper_average", Cell::Blank).into_iter().chain(a).chain([Cell::Blank, Cell::Blank]).collect());
    }
    d
}

/// The Markdown layout: metrics down, sequences across.
fn markdown(ids: &[String], arms: &[ArmScores], references: &[ReferenceRow]) -> Table {
    let mut headers = vec!["metric".to_string(), "arm".to_string()];
    headers.extend(ids.iter().cloned());
    headers.push("avg".into());
    let mut t = Table::new(headers);
    type Metric = fn(&ForecastScores) -> &Mean;
    let metrics: [(&str, Metric); 3] = [("ADE", |s| &s.ade), ("FDE", |s| &s.fde), ("ACE", |s| &s.ace)];
    for (m, (metric, get)) in metrics.into_iter().enumerate() {
        for arm in arms {
            let mut row = vec![metric.to_string(), arm.label.clone()];
            let mut total = Mean::new();
            for s in &arm.per_sequence {
                row.push(fmt_opt(get(s).value(), 2));
                total.merge(get(s));
            }
            row.push(fmt_opt(total.value(), 2));
            t.push(row);
        }
        for r in references {
            let mut row = vec![metric.to_string(), r.label.clone()];
            row.extend(r.per_sequence.iter().map(|v| fmt_opt(v.map(|v| v[m]), 2)));
            row.push(format!("{:.2}", r.average[m]));
            t.push(row);
        }
    }
    // Instance counts: one row when every arm was scored on the same instances, else a row for
    // each arm whose counts differ from those of every arm before it (sources with their own
    // eligible runs, such as the estimator's, have their own instances).
    let mut seen: Vec<Vec<String>> = Vec::new();
    for arm in arms {
        let mut cells = Vec::new();
        let mut n = (0, 0);
        for s in &arm.per_sequence {
            cells.push(format!("{} ({})", s.ade.count(), s.ace.count()));
            n.0 += s.ade.count();
            n.1 += s.ace.count();
        }
        cells.push(format!("{} ({})", n.0, n.1));
        if !seen.contains(&cells) {
            seen.push(cells);
            let mut row = vec!["instances".to_string(), format!("ADE/FDE (ACE pairs): {}", arm.label)];
            row.extend(seen.last().into_iter().flatten().cloned());
            t.push(row);
        }
    }
    if seen.len() == 1
        && let Some(row) = t.rows.last_mut()
    {
        row[1] = "ADE/FDE (ACE pairs)".to_string();
    }
    t
}
