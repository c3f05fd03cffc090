//! The paper's published Table IV (KITTI, 30-frame horizon, weighted averages over 522
//! forecasts), printed beside measured rows. Figures copied from the paper's table.

use crate::report::ReferenceRow;

/// The paper's test sequences, in its column order.
pub const SEQUENCES: [&str; 5] = ["0000", "0003", "0005", "0018", "0020"];

/// The test sequences of a command's `flag`: those `given`, each once, else [`SEQUENCES`].
///
/// # Errors
/// A sequence given twice, named.
pub fn test_sequences(flag: &str, given: &[String]) -> anyhow::Result<Vec<String>> {
    if given.is_empty() {
        Ok(SEQUENCES.iter().map(ToString::to_string).collect())
    } else {
        dynotraj_sources::drives::distinct_ids(flag, given.to_vec())
    }
}

/// [ADE, FDE, ACE] of one sequence or of the average.
type Scores = [f64; 3];

/// (label, scores per sequence in [`SEQUENCES`] order, average).
const TABLE_IV: [(&str, [Scores; 5], Scores); 3] = [
    (
        "paper: Ours (DynoSAM)",
        [[1.15, 3.18, 0.39], [0.47, 1.36, 0.26], [0.99, 2.74, 0.21], [0.44, 1.27, 0.71], [0.55, 1.60, 0.80]],
        [0.76, 2.15, 0.51],
    ),
    (
        "paper: GT",
        [[1.61, 4.18, 0.76], [0.99, 2.36, 1.48], [1.44, 3.83, 0.56], [0.49, 1.18, 0.65], [0.77, 2.12, 0.96]],
        [1.11, 2.90, 0.88],
    ),
    (
        "paper: GT+EKF",
        [[1.45, 3.89, 0.67], [0.86, 2.35, 1.27], [1.40, 3.76, 0.46], [0.39, 0.93, 0.39], [0.69, 1.98, 0.79]],
        [1.00, 2.73, 0.73],
    ),
];

/// The paper's rows for the arms named (`"estimated"` or `"ours"`, `"gt"`, `"gt-ekf"`),
/// aligned with `ids`.
#[must_use]
pub fn reference_rows(arms: &[&str], ids: &[String]) -> Vec<ReferenceRow> {
    let index = |arm: &str| match arm {
        "ours" | "estimated" => Some(0),
        "gt" => Some(1),
        "gt-ekf" => Some(2),
        _ => None,
    };
    arms.iter()
        .filter_map(|a| index(a))
        .filter_map(|i| TABLE_IV.get(i))
        .map(|(label, per, avg)| ReferenceRow {
            label: (*label).to_string(),
            per_sequence: ids
                .iter()
                .map(|id| SEQUENCES.iter().position(|s| s == id).and_then(|j| per.get(j)).copied())
                .collect(),
            average: *avg,
        })
        .collect()
}
