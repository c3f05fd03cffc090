//! `dynotraj dataset`: the paper's Table I.

use clap::Args;

use super::common::DataArgs;
use crate::report::{Format, Table, instances_table};
use crate::trajectory::Source;

/// Options of `dynotraj dataset`.
#[derive(Debug, Args)]
pub struct DatasetArgs {
    /// Data options.
    #[command(flatten)]
    pub data: DataArgs,
    /// Sequences to list, comma-separated (default: every sequence in the folder).
    #[arg(long = "sequences", visible_alias = "sequence", value_delimiter = ',', value_name = "LIST")]
    pub sequences: Vec<String>,
    /// Sources whose tracks are counted, comma-separated: gt (the labels; gt-ekf and gt-rts
    /// share their runs), estimated (the estimator's causal tracks), estimated-smoothed.
    #[arg(long, value_delimiter = ',', default_value = "gt", value_name = "LIST")]
    pub source: Vec<Source>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Md)]
    pub format: Format,
}

/// Prints eligible objects and test instances per sequence with totals.
///
/// # Errors
/// Loading errors, named.
pub fn run(args: &DatasetArgs) -> anyhow::Result<()> {
    print!("{}", table(args)?.render(args.format));
    Ok(())
}

/// Eligible objects and test instances per sequence with totals.
///
/// # Errors
/// Loading errors, named.
pub fn table(args: &DatasetArgs) -> anyhow::Result<Table> {
    let rule = args.data.rule()?;
    let seqs = args.data.load_for(&args.sequences, &args.source)?;
    Ok(instances_table(&seqs, &args.source, &rule))
}
