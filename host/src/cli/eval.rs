//! `dynotraj eval`: ADE, FDE and ACE per sequence and their weighted average (Table IV layout).

use clap::{Args, ValueEnum};
use dynotraj_core::metrics::{ForecastScores, Mean};
use dynotraj_core::predict::{Baseline, Predictor};

use super::common::{progress, DataArgs, PAPER_TEST_SEQUENCES};
use crate::evaluate::score_run;
use crate::report::{fmt_opt, Format, Table};
use crate::trajectory::{eligible_runs, Source};

/// The predictors `eval` can run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PredictorName {
    /// Constant velocity from the last two positions.
    Cv,
    /// Constant turn rate and acceleration on the unicycle, within the paper's limits.
    Ctra,
}

impl PredictorName {
    fn build(self) -> Box<dyn Predictor> {
        match self {
            Self::Cv => Box::new(Baseline::ConstantVelocity),
            Self::Ctra => Box::new(Baseline::Ctra),
        }
    }
}

/// Options of `dynotraj eval`.
#[derive(Debug, Args)]
pub struct EvalArgs {
    /// Data options.
    #[command(flatten)]
    pub data: DataArgs,
    /// Trajectory sources, comma-separated: gt (labels), gt-ekf (forward EKF: causal), gt-rts
    /// (fixed-lag RTS smoother: its inputs have seen later frames, reported apart). Each source
    /// is scored against its own future (the paper's protocol).
    #[arg(long, value_delimiter = ',', default_value = "gt", value_name = "LIST")]
    pub source: Vec<Source>,
    /// Predictors, comma-separated.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "cv", value_name = "LIST")]
    pub predictor: Vec<PredictorName>,
    /// Test sequences, comma-separated (default: the paper's 0000,0003,0005,0018,0020).
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    pub sequences: Vec<String>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Md)]
    pub format: Format,
}

/// One arm's scores per sequence.
struct ArmScores {
    label: String,
    per_sequence: Vec<ForecastScores>,
    failed: u32,
}

/// Scores every (source, predictor) arm on every sequence and prints the table.
///
/// # Errors
/// Loading errors, named.
pub fn run(args: &EvalArgs) -> anyhow::Result<()> {
    print!("{}", table(args)?.render(args.format));
    Ok(())
}

/// Scores every (source, predictor) arm on every sequence: the Table IV layout.
///
/// # Errors
/// Loading errors, named.
pub fn table(args: &EvalArgs) -> anyhow::Result<Table> {
    let rule = args.data.rule()?;
    let dt = args.data.dt()?;
    let ids: Vec<String> =
        if args.sequences.is_empty() { PAPER_TEST_SEQUENCES.iter().map(ToString::to_string).collect() } else { args.sequences.clone() };
    let seqs = args.data.load(&ids)?;
    let runs: Vec<_> = seqs.iter().map(|s| eligible_runs(&s.tracks, &rule)).collect();

    let mut arms = Vec::new();
    let bar = progress((args.source.len() * args.predictor.len()) as u64, "scoring");
    for &source in &args.source {
        for &name in &args.predictor {
            let mut predictor = name.build();
            let mut arm = ArmScores { label: arm_label(name, source), per_sequence: Vec::new(), failed: 0 };
            for seq_runs in &runs {
                let mut scores = ForecastScores::default();
                for run in seq_runs {
                    let states = source.apply(&run.states, dt);
                    let r = score_run(&states, run.instances(), predictor.as_mut(), dt);
                    scores.merge(&r.scores);
                    arm.failed += r.failed;
                }
                arm.per_sequence.push(scores);
            }
            if arm.failed > 0 {
                log::warn!("{}: {} instances could not be forecast (non-finite input)", arm.label, arm.failed);
            }
            arms.push(arm);
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    Ok(arms_table(&ids, &arms))
}

fn arm_label(p: PredictorName, s: Source) -> String {
    let name = format!("{} on {}", p.to_possible_value().map_or("?".into(), |v| v.get_name().to_string()), s.name());
    if s.is_causal() { name } else { format!("{name} (inputs saw later frames)") }
}

fn arms_table(ids: &[String], arms: &[ArmScores]) -> Table {
    let mut headers = vec!["metric".to_string(), "arm".to_string()];
    headers.extend(ids.iter().cloned());
    headers.push("avg".into());
    let mut t = Table::new(headers);
    type Metric = fn(&ForecastScores) -> &Mean;
    let metrics: [(&str, Metric); 3] = [("ADE", |s| &s.ade), ("FDE", |s| &s.fde), ("ACE", |s| &s.ace)];
    for (metric, get) in metrics {
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
    }
    if let Some(arm) = arms.first() {
        let mut row = vec!["instances".to_string(), "ADE/FDE (ACE pairs)".to_string()];
        let mut n = (0, 0);
        for s in &arm.per_sequence {
            row.push(format!("{} ({})", s.ade.count(), s.ace.count()));
            n.0 += s.ade.count();
            n.1 += s.ace.count();
        }
        row.push(format!("{} ({})", n.0, n.1));
        t.push(row);
    }
    t
}
