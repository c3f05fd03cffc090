//! `dynotraj dataset`: the paper's Table I.

use clap::Args;

use super::common::DataArgs;
use crate::report::{Format, Table};
use crate::trajectory::{eligible_runs, Source};

/// Options of `dynotraj dataset`.
#[derive(Debug, Args)]
pub struct DatasetArgs {
    /// Data options.
    #[command(flatten)]
    pub data: DataArgs,
    /// Sequences to list, comma-separated (default: every sequence in the folder).
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
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
    let mut headers = vec![String::new()];
    headers.extend(seqs.iter().map(|s| s.id.clone()));
    headers.push("sum".into());
    let mut t = Table::new(headers);
    let only_labels = args.source == [Source::Gt];
    for &source in &args.source {
        let suffix = if only_labels { String::new() } else { format!(" ({source})") };
        let mut objects = vec![format!("eligible objects{suffix}")];
        let mut instances = vec![format!("test instances{suffix}")];
        let (mut total_objects, mut total_instances) = (0, 0);
        for s in &seqs {
            let runs = eligible_runs(s.tracks_for(source), &rule);
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
        t.push(objects);
        t.push(instances);
    }
    Ok(t)
}
