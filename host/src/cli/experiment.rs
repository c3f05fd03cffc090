//! `dynotraj experiment`: the paper's leave-one-sequence-out experiment for the chosen arms.

use std::path::PathBuf;

use clap::Args;

use super::bench::parse_dims;
use super::common::{DataArgs, DEFAULT_DIMS, PAPER_TEST_SEQUENCES};
use super::train::HyperArgs;
use crate::experiment::{run_experiment, ExperimentConfig};
use crate::report::{Format, Table};
use crate::train::Event;
use crate::trajectory::Source;

/// Options of `dynotraj experiment`.
#[derive(Debug, Args)]
pub struct ExperimentArgs {
    /// Data options.
    #[command(flatten)]
    pub data: DataArgs,
    /// Arms: the sources trained and tested (gt, gt-ekf, estimated; gt-rts and
    /// estimated-smoothed are the labelled non-causal variants), comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "gt,gt-ekf", value_name = "LIST")]
    pub arms: Vec<Source>,
    /// Test sequences, each held out in turn (training uses every other sequence in --kitti).
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    pub sequences: Vec<String>,
    /// Model widths enc,edge,k,dec.
    #[arg(long, default_value = DEFAULT_DIMS, value_name = "DIMS")]
    pub dims: String,
    /// Training settings of every fold.
    #[command(flatten)]
    pub hyper: HyperArgs,
    /// Folder for each fold's model blobs (`<arm>-<seq>.blob`, `.blob.int8`).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Output format of the table.
    #[arg(long, value_enum, default_value_t = Format::Md)]
    pub format: Format,
}

/// Runs the experiment and returns its table and a summary of the folds.
///
/// # Errors
/// Loading, training or writing errors, named.
pub fn table(args: &ExperimentArgs) -> anyhow::Result<(Table, String)> {
    let sequences = args.data.load_for(&[], &args.arms)?;
    let test_sequences =
        if args.sequences.is_empty() { PAPER_TEST_SEQUENCES.iter().map(ToString::to_string).collect() } else { args.sequences.clone() };
    let config = ExperimentConfig {
        arms: args.arms.clone(),
        test_sequences,
        dims: parse_dims(&args.dims)?,
        hyper: args.hyper.hyper()?,
        validation_fraction: args.hyper.val_fraction,
        mirror: args.hyper.mirror,
        validate_on_sequences: args.hyper.val_sequences,
        dt: args.data.dt()?,
        rule: args.data.rule()?,
        out: args.out.clone(),
    };
    let bar = super::common::progress(0, "training");
    let mut current = String::new();
    let result = run_experiment(&sequences, &config, &mut |label, e| {
        if label != current {
            current = label.to_string();
            bar.set_position(0);
        }
        match e {
            Event::Step { step, total, loss } => {
                bar.set_length(total as u64);
                bar.set_position(step as u64);
                bar.set_message(format!("{label} loss {loss:.2}"));
            }
            Event::Epoch(_) => {}
        }
    })?;
    bar.finish_and_clear();
    let mut summary = String::from("folds (arm / held-out sequence: training instances, epoch kept, output shrink, validation ADE vs cv, seconds):\n");
    for f in &result.folds {
        summary.push_str(&format!(
            "  {} / {}: {} instances, epoch {}, shrink {}, val ADE {:.3} m (cv {:.3} m), {:.1} s\n",
            f.arm, f.sequence, f.train_instances, f.best_epoch, f.shrink, f.val_ade, f.val_cv_ade, f.seconds
        ));
    }
    summary.push_str(&format!("total: {:.1} s\n", result.seconds));
    Ok((result.table, summary))
}

/// Prints the table and the fold summary.
///
/// # Errors
/// See [`table`].
pub fn run(args: &ExperimentArgs) -> anyhow::Result<()> {
    let (t, summary) = table(args)?;
    print!("{}", t.render(args.format));
    eprint!("{summary}");
    Ok(())
}
