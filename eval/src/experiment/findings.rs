//! Plain-language findings from the experiment's measured rows: does each arm's learned model
//! beat constant velocity, and how do the arms compare.

use dynotraj_core::metrics::ForecastScores;

use crate::report::ArmScores;
use dynotraj_sources::trajectory::Source;

fn triple(s: &ForecastScores) -> [f64; 3] {
    [s.ade.value().unwrap_or(f64::NAN), s.fde.value().unwrap_or(f64::NAN), s.ace.value().unwrap_or(f64::NAN)]
}

/// The weighted (per forecast) ADE, FDE and ACE of the row labelled `label`.
pub fn total_of(arms: &[ArmScores], label: &str) -> Option<[f64; 3]> {
    arms.iter().find(|a| a.label == label).map(|a| triple(&a.total()))
}

fn compare(a: [f64; 3], b: [f64; 3]) -> String {
    let word = |x: f64, y: f64| {
        if x < y {
            "lower"
        } else if x > y {
            "higher"
        } else {
            "equal"
        }
    };
    format!(
        "ADE {:.2} vs {:.2} ({}), FDE {:.2} vs {:.2} ({}), ACE {:.2} vs {:.2} ({})",
        a[0],
        b[0],
        word(a[0], b[0]),
        a[1],
        b[1],
        word(a[1], b[1]),
        a[2],
        b[2],
        word(a[2], b[2])
    )
}

/// How the rows were scored, for the sentences.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scoring {
    /// Each arm against its own source's future, on its own instances (the paper's protocol).
    OwnFuture,
    /// Every arm against the simulator's truth, on the instances all arms share.
    CommonTruth,
}

/// One or two sentences per arm (its int8 model against cv, and against cv-fit, on the same
/// source) and one per pair of the Estimated arm with a GT arm (int8 models), scored as
/// `scoring` says.
#[must_use]
pub fn findings(arms: &[ArmScores], sources: &[Source], scoring: Scoring) -> Vec<String> {
    let how = match scoring {
        Scoring::OwnFuture => "each scored against its own source's future, on its own instances",
        Scoring::CommonTruth => "both scored against the simulator's truth, on the instances every arm has",
    };
    let prefix = match scoring {
        Scoring::OwnFuture => "",
        Scoring::CommonTruth => "Against the simulator's truth: ",
    };
    let mut out = Vec::new();
    for s in sources {
        if let (Some(l), Some(cv)) =
            (total_of(arms, &format!("learned int8 on {s}")), total_of(arms, &format!("cv on {s}")))
        {
            let beats = l[0] < cv[0];
            out.push(format!(
                "{prefix}{s}: the learned int8 model {} constant velocity on the weighted ADE: {}.",
                if beats { "beats" } else { "does not beat" },
                compare(l, cv)
            ));
            if let Some(fit) = total_of(arms, &format!("cv-fit on {s}")) {
                out.push(format!(
                    "{prefix}{s}: against its own zero-control forecast (cv-fit, constant velocity along the \
                        fitted velocity) the learned int8 model {} on the weighted ADE: {}.",
                    if l[0] < fit[0] { "gains" } else { "gains nothing" },
                    compare(l, fit)
                ));
            }
        }
    }
    for ours in sources.iter().filter(|s| s.is_estimated()) {
        for other in sources.iter().filter(|s| !s.is_estimated()) {
            if let (Some(a), Some(b)) = (
                total_of(arms, &format!("learned int8 on {ours}")),
                total_of(arms, &format!("learned int8 on {other}")),
            ) {
                out.push(format!("{prefix}{ours} against {other} (learned int8, {how}): {}.", compare(a, b)));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arm(label: &str, ade: f32) -> ArmScores {
        let mut s = ForecastScores::default();
        s.ade.push(ade);
        s.fde.push(ade * 2.0);
        s.ace.push(ade / 2.0);
        ArmScores { label: label.into(), per_sequence: vec![s], per_run: vec![s] }
    }

    #[test]
    fn findings_say_who_beats_whom() {
        let arms = [
            arm("learned int8 on gt", 1.3),
            arm("cv on gt", 1.2),
            arm("learned int8 on estimated", 1.0),
            arm("cv on estimated", 1.1),
        ];
        let f = findings(&arms, &[Source::Estimated, Source::Gt], Scoring::OwnFuture);
        assert_eq!(f.len(), 3, "{f:?}");
        assert!(f[0].starts_with("estimated: the learned int8 model beats"), "{}", f[0]);
        assert!(f[1].starts_with("gt: the learned int8 model does not beat"), "{}", f[1]);
        assert!(f[2].contains("ADE 1.00 vs 1.30 (lower)"), "{}", f[2]);
        let with_fit = [arm("learned int8 on gt", 1.3), arm("cv on gt", 1.2), arm("cv-fit on gt", 1.25)];
        let g = findings(&with_fit, &[Source::Gt], Scoring::OwnFuture);
        assert_eq!(g.len(), 2, "{g:?}");
        assert!(
            g[1].starts_with("gt: against its own zero-control forecast") && g[1].contains("gains nothing"),
            "{}",
            g[1]
        );
    }
}
