//! `dynotraj dataset`: the paper's Table I.

use clap::Args;

use super::data_args::DataArgs;
use super::progress::LoadBar;
use dynotraj_eval::experiment::benchmark::Shard;
use dynotraj_eval::experiment::budget::{budget_instances, budget_table};
use dynotraj_eval::report::{Format, Table, instances_table};
use dynotraj_sources::trajectory::Source;

/// Options of `dynotraj dataset`.
#[derive(Debug, Args)]
pub struct DatasetArgs {
    /// Data options.
    #[command(flatten)]
    pub data: DataArgs,
    /// Sequences to list, comma-separated (default: every sequence in the folder).
    #[arg(long = "sequences", visible_alias = "sequence", value_delimiter = ',', value_parser = crate::numbers::sequence_id, value_name = "LIST")]
    pub sequences: Vec<String>,
    /// Sources whose tracks are counted, comma-separated: gt (the labels; gt-ekf and gt-rts
    /// share their runs), estimated (the estimator's causal tracks; estimated-ekf shares
    /// them), estimated-smoothed.
    #[arg(long, value_delimiter = ',', default_value = "gt", value_name = "LIST")]
    pub source: Vec<Source>,
    /// Also the error budget of the estimated source: per test instance of its causal tracks,
    /// the position (relative to the camera), speed, direction and turn-rate errors against the
    /// simulator's truth and the constant-velocity ADE they cost, per sequence, distance band,
    /// class and run start. Needs `--source estimated` on rendered or simulated inputs.
    #[arg(long)]
    pub budget: bool,
    /// Only this part of the drives, I of N (`0/4` .. `3/4`; or `N` alone, the index taken
    /// from JOB_COMPLETION_INDEX (Kubernetes Indexed Jobs) or SLURM_ARRAY_TASK_ID (Slurm job
    /// arrays)): the drives whose position modulo N is I, estimated into --estimate-cache, for
    /// one task of a cluster's array job; the table lists those drives.
    #[arg(long, value_name = "I/N", requires = "estimate_cache")]
    pub shard: Option<Shard>,
    /// Output format.
    #[arg(long, value_parser = crate::numbers::choices(&Format::CHOICES), default_value = "md")]
    pub format: Format,
}

/// Prints eligible objects and test instances per sequence with totals.
///
/// # Errors
/// Loading errors, named.
pub fn run(args: &DatasetArgs) -> anyhow::Result<()> {
    let (table, budget) = tables(args)?;
    print!("{}", table.render(args.format));
    if let Some(budget) = budget {
        if args.format == Format::Md {
            println!("\nError budget of the estimated source's causal states against the simulator's truth:\n");
        }
        print!("{}", budget.render(args.format));
    }
    Ok(())
}

/// Eligible objects and test instances per sequence with totals.
///
/// # Errors
/// As [`tables`].
pub fn table(args: &DatasetArgs) -> anyhow::Result<Table> {
    Ok(tables(args)?.0)
}

/// Eligible objects and test instances per sequence with totals, and with `--budget` the
/// estimated source's error budget.
///
/// # Errors
/// Loading errors, named; `--budget` without the estimated source or on sequences without
/// the simulator's truth.
pub fn tables(args: &DatasetArgs) -> anyhow::Result<(Table, Option<Table>)> {
    if args.budget && !args.source.contains(&Source::Estimated) {
        anyhow::bail!("--budget measures the estimated source: add estimated to --source");
    }
    let data = args.data.request()?;
    let rule = &data.rule;
    let mut drives = data.drives(&args.sequences)?;
    if let Some(shard) = args.shard {
        let all = drives.len();
        drives = drives.into_iter().enumerate().filter(|(k, _)| shard.takes(*k)).map(|(_, d)| d).collect();
        eprintln!("shard {}/{}: {} of {all} drives", shard.index, shard.count, drives.len());
        if drives.is_empty() {
            return Ok((instances_table(&[], &args.source, rule), None));
        }
    }
    let seqs = data.load_drives(&drives, &args.source, data.estimate.cache.clone(), &LoadBar::default())?;
    let budget = if args.budget {
        let instances = budget_instances(&seqs, rule, data.dt);
        if instances.is_empty() {
            anyhow::bail!(
                "--budget: no test instance of the estimated source has the simulator's truth (real images have \
                    none; use rendered images or --ours-input tracks)"
            );
        }
        Some(budget_table(&instances))
    } else {
        None
    };
    Ok((instances_table(&seqs, &args.source, rule), budget))
}
