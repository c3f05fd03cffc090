//! The paper's Table IV layout: ADE, FDE and ACE per sequence and their weighted average (per
//! forecast), one row per arm, optionally beside published reference rows.

use dynotraj_core::metrics::{ForecastScores, Mean};

use super::{Table, fmt_opt};

/// One arm's scores, one entry per sequence (in the table's column order).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ArmScores {
    /// Row label.
    pub label: String,
    /// Scores per sequence.
    pub per_sequence: Vec<ForecastScores>,
}

impl ArmScores {
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
