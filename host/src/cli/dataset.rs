//! `dynotraj dataset`: the paper's Table I.

use clap::Args;

use super::common::DataArgs;
use crate::report::{Format, Table};
use crate::trajectory::eligible_runs;

/// Options of `dynotraj dataset`.
#[derive(Debug, Args)]
pub struct DatasetArgs {
    /// Data options.
    #[command(flatten)]
    pub data: DataArgs,
    /// Sequences to list, comma-separated (default: every sequence in the folder).
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    pub sequences: Vec<String>,
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
    let seqs = args.data.load(&args.sequences)?;
    let mut headers = vec![String::new()];
    headers.extend(seqs.iter().map(|s| s.id.clone()));
    headers.push("sum".into());
    let mut objects = vec!["eligible objects".to_string()];
    let mut instances = vec!["test instances".to_string()];
    let (mut total_objects, mut total_instances) = (0, 0);
    for s in &seqs {
        let runs = eligible_runs(&s.tracks, &rule);
        let mut ids: Vec<i32> = runs.iter().map(|r| r.track_id).collect();
        ids.dedup();
        let n: usize = runs.iter().map(|r| r.instances().len()).sum();
        let cell = |v: usize| if v == 0 { "-".to_string() } else { v.to_string() };
        objects.push(cell(ids.len()));
        instances.push(cell(n));
        total_objects += ids.len();
        total_instances += n;
    }
    objects.push(total_objects.to_string());
    instances.push(total_instances.to_string());
    let mut t = Table::new(headers);
    t.push(objects);
    t.push(instances);
    Ok(t)
}
