//! `dynotraj experiment`: the paper's leave-one-sequence-out experiment for the chosen arms.

use std::path::PathBuf;

use clap::Args;

use super::data_args::DataArgs;
use super::fold_run::FoldRunArgs;
use super::train_progress::TrainBars;
use dynotraj_eval::experiment::figures::{ObjectChoice, parse_object_choice};
use dynotraj_eval::experiment::paper::test_sequences;
use dynotraj_eval::experiment::request::{ExperimentOutput, ExperimentRequest, ReportRequest};
use dynotraj_eval::report::Format;
use dynotraj_sources::trajectory::Source;

/// Options of `dynotraj experiment`.
#[derive(Debug, Args)]
pub struct ExperimentArgs {
    /// Data options.
    #[command(flatten)]
    pub data: DataArgs,
    /// Arms: the sources trained and tested (gt, gt-ekf, estimated, estimated-ekf; gt-rts and
    /// estimated-smoothed are the labelled non-causal variants), comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "gt,gt-ekf", value_name = "LIST")]
    pub arms: Vec<Source>,
    /// Sequences to load (default: every sequence in --kitti); every loaded sequence that is
    /// not the fold's test sequence is trained on. The paper's setting is
    /// `--sequences 0000,0001,0002,0003,0004,0005,0006,0018,0020`.
    #[arg(long = "sequences", visible_alias = "sequence", value_delimiter = ',', value_parser = crate::numbers::sequence_id, value_name = "LIST")]
    pub sequences: Vec<String>,
    /// Test sequences, each held out in turn (default: the paper's 0000, 0003, 0005, 0018, 0020).
    #[arg(long, value_delimiter = ',', value_parser = crate::numbers::sequence_id, value_name = "LIST")]
    pub tests: Vec<String>,
    /// Objects the per-object figures draw, as SEQ:ID with ID the object number (the KITTI
    /// track id plus 1, as in the pose files and `estimate --per-object`); repeatable or
    /// comma-separated (default: the longest eligible moving object of 0000, and of 0018 for
    /// its heading).
    #[arg(long = "object", value_delimiter = ',', value_parser = parse_object_choice, value_name = "SEQ:ID")]
    pub objects: Vec<ObjectChoice>,
    /// Also write recordings for Foxglove, one per test sequence (`DIR/<seq>.mcap`, MCAP with
    /// Foxglove's schemas): per arm and frame, each eligible object's recent states and the
    /// forecasts of its fold model (int8) and of constant velocity. Needs --out (the fold
    /// models are read from its models/).
    #[arg(long, value_name = "DIR", requires = "out")]
    pub record: Option<PathBuf>,
    /// The recordings' encoding.
    #[command(flatten)]
    pub record_encoding: crate::record_args::RecordEncodingArgs,
    /// Widths, training settings, report folder and format.
    #[command(flatten)]
    pub run: FoldRunArgs,
}

impl ExperimentArgs {
    /// The request these options make, every flag checked before any work.
    ///
    /// # Errors
    /// A flag out of range or a test sequence given twice, named.
    pub fn request(&self) -> anyhow::Result<ExperimentRequest<'_>> {
        let data = self.data.request()?;
        let config = self.run.config(&data, &self.arms)?;
        let report = self.run.out.as_deref().map(|dir| ReportRequest {
            dir,
            record: self.record.as_deref(),
            record_encoding: self.record_encoding.into(),
            command: FoldRunArgs::command_line("experiment"),
        });
        Ok(ExperimentRequest {
            estimate_cache: self.run.estimate_cache(&data),
            data,
            sequences: &self.sequences,
            tests: test_sequences("--tests", &self.tests)?,
            objects: &self.objects,
            config,
            report,
            stop_from_now: Some(crate::interrupt::stop_flag),
        })
    }
}

/// Runs the experiment ([`dynotraj_eval::experiment::request::experiment`]) with progress bars.
///
/// # Errors
/// Bad flags, loading, training or writing errors, named.
pub fn experiment(args: &ExperimentArgs) -> anyhow::Result<ExperimentOutput> {
    let bars = TrainBars::default();
    let output = dynotraj_eval::experiment::request::experiment(&args.request()?, &bars);
    bars.finish();
    output
}

/// Prints the table and the fold summary.
///
/// # Errors
/// See [`experiment`].
pub fn run(args: &ExperimentArgs) -> anyhow::Result<()> {
    args.run.out.as_deref().map(|d| dynotraj_formats::atomic::output_folder("--out", d)).transpose()?;
    args.record.as_deref().map(|d| dynotraj_formats::atomic::output_folder("--record", d)).transpose()?;
    let names: &[&str] =
        if args.arms.iter().any(Source::is_estimated) { &["table_iv", "table_iv_truth"] } else { &["table_iv"] };
    args.run.check_table(names)?;
    let ExperimentOutput { result, summary, report, .. } = experiment(args)?;
    // A table that cannot be printed (a --table the run did not make) fails the command only
    // once the report is written.
    let mut printed = Ok(());
    if args.run.format == Format::Md {
        print!("{}", result.table.render(Format::Md));
        if let Some((table, _)) = &result.common {
            println!("\nAgainst the simulator's truth, on the instances every arm has:\n");
            print!("{}", table.render(Format::Md));
        }
        for other in &result.other_agents {
            println!("\n{}, by their own models:\n", other.agents.agents());
            print!("{}", other.table.render(Format::Md));
        }
    } else {
        let mut named = vec![("table_iv", &result.table)];
        if let Some((table, _)) = &result.common {
            named.push(("table_iv_truth", table));
        }
        printed = args.run.print_machine(&named);
    }
    eprint!("{summary}");
    for said in report? {
        eprintln!("{said}");
    }
    printed
}
