//! `dynotraj experiment`: the paper's leave-one-sequence-out experiment for the chosen arms.

use std::path::PathBuf;

use clap::Args;

use super::data_args::{DataArgs, PAPER_TEST_SEQUENCES};
use super::fold_run::FoldRunArgs;
use super::train_progress::TrainBars;
use dynotraj_eval::experiment::figures::{ObjectChoice, parse_object_choice, subjects};
use dynotraj_eval::experiment::sections::{ReportFolder, RunSettings, write_report_folder};
use dynotraj_eval::experiment::{ExperimentConfig, ExperimentResult, run_experiment};
use dynotraj_eval::report::{Format, Table};
use dynotraj_sources::sequence::SequenceTracks;
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

/// Runs the experiment and returns its table and a summary of the folds.
///
/// # Errors
/// Loading, training or writing errors, named.
pub fn table(args: &ExperimentArgs) -> anyhow::Result<(Table, String)> {
    let (result, summary, _) = experiment(args)?;
    Ok((result.table, summary))
}

/// The test sequences: `--tests`, else the paper's five.
fn test_ids(args: &ExperimentArgs) -> anyhow::Result<Vec<String>> {
    Ok(if args.tests.is_empty() {
        PAPER_TEST_SEQUENCES.iter().map(ToString::to_string).collect()
    } else {
        dynotraj_sources::drives::distinct_ids("--tests", args.tests.clone())?
    })
}

/// Runs the experiment; returns its result, the fold summary and the loaded sequences.
///
/// # Errors
/// Loading, training or writing errors, named.
pub fn experiment(args: &ExperimentArgs) -> anyhow::Result<(ExperimentResult, String, Vec<SequenceTracks>)> {
    let start = std::time::Instant::now();
    args.run.check(&args.data, &args.arms)?;
    // Flags that need no data fail before the (possibly long) loading.
    let test_sequences = test_ids(args)?;
    let sequences = args.data.load_cached(&args.sequences, &args.arms, args.run.estimate_cache(&args.data))?;
    // A bad --object fails before the folds are trained, not after.
    subjects(&args.objects, &sequences, &args.data.rule()?)?;
    let mut config = args
        .run
        .config(&args.data, &args.arms, ExperimentConfig::one_sequence_folds(&test_sequences))?
        .with_present_agents(&sequences);
    // From here on Ctrl-C or SIGTERM stops between folds, keeping what the fold cache holds.
    config.stop = Some(crate::interrupt::stop_flag()?);
    let loading_seconds = start.elapsed().as_secs_f64();
    let bars = TrainBars::new(dynotraj_eval::experiment::fold_specs(&config, &[config.hyper.seed]).len());
    let result = run_experiment(&sequences, &config, &bars);
    bars.finish();
    let mut result = result?;
    // The whole command: loading and estimating the sequences too.
    result.seconds = start.elapsed().as_secs_f64();
    result.loading_seconds = loading_seconds;
    let summary = result.fold_summary();
    Ok((result, summary, sequences))
}

/// Prints the table and the fold summary.
///
/// # Errors
/// See [`table`].
pub fn run(args: &ExperimentArgs) -> anyhow::Result<()> {
    args.run.out.as_deref().map(|d| dynotraj_formats::atomic::output_folder("--out", d)).transpose()?;
    args.record.as_deref().map(|d| dynotraj_formats::atomic::output_folder("--record", d)).transpose()?;
    let names: &[&str] =
        if args.arms.iter().any(Source::is_estimated) { &["table_iv", "table_iv_truth"] } else { &["table_iv"] };
    args.run.check_table(names)?;
    let (result, summary, sequences) = experiment(args)?;
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
    if let Some(dir) = &args.run.out {
        let mut command = String::from("dynotraj experiment");
        for a in std::env::args().skip(2) {
            command.push(' ');
            command.push_str(&a);
        }
        let run = RunSettings {
            arms: &args.arms,
            render_scale: args.data.ours.render_scale,
            jobs: args.data.ours.jobs,
            dt: args.data.dt()?,
            history_frames: args.run.hyper.prior_choice().history_frames(),
        };
        let tests = test_ids(args)?;
        let folder = ReportFolder {
            dir,
            record: args.record.as_deref(),
            record_encoding: args.record_encoding.into(),
            command,
            objects: &args.objects,
            tests: &tests,
        };
        for said in write_report_folder(&folder, &run, &result, &sequences, &args.data.rule()?)? {
            eprintln!("{said}");
        }
    }
    printed
}
