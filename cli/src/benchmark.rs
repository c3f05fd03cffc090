//! `dynotraj benchmark`: the generalisation benchmark (every sequence held out once, in folds of
//! whole sequences, several seeds) with its report folder.

use clap::Args;

use super::data_args::DataArgs;
use super::fold_run::FoldRunArgs;
use super::train_progress::TrainBars;
use dynotraj_eval::experiment::benchmark::DEFAULT_GROUPS;
use dynotraj_eval::experiment::benchmark_request::{BenchmarkOutput, BenchmarkRequest, benchmark};
use dynotraj_eval::report::Format;
use dynotraj_sources::trajectory::Source;

/// Options of `dynotraj benchmark`.
#[derive(Debug, Args)]
pub struct BenchmarkArgs {
    /// Data options.
    #[command(flatten)]
    pub data: DataArgs,
    /// Arms: the sources trained and tested, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "gt,gt-ekf,estimated", value_name = "LIST")]
    pub arms: Vec<Source>,
    /// Sequences to load (default: every sequence in --kitti); each is held out once.
    #[arg(long = "sequences", visible_alias = "sequence", value_delimiter = ',', value_parser = crate::numbers::sequence_id, value_name = "LIST")]
    pub sequences: Vec<String>,
    /// Number of folds: the sorted sequences are dealt out in turn (fold k holds the k-th,
    /// (k + N)-th, ... sequence).
    #[arg(long, default_value_t = DEFAULT_GROUPS, value_name = "N")]
    pub folds: usize,
    /// Seeds each fold is trained with (weights and shuffling; the validation sequences do not
    /// depend on it).
    #[arg(long, value_delimiter = ',', default_value = "1,2,3", value_name = "LIST")]
    pub seeds: Vec<u64>,
    /// Only this part of the trainings, I of N (`0/4` .. `3/4`; or `N` alone, the index taken
    /// from JOB_COMPLETION_INDEX (Kubernetes Indexed Jobs) or SLURM_ARRAY_TASK_ID (Slurm job
    /// arrays)), for one machine of a cluster's array job: its folds go into the fold cache of
    /// --out, and no report is written; the same command without --shard, once every part has
    /// run, reads them all and writes the report.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<dynotraj_eval::experiment::benchmark::Shard>,
    /// Widths, training settings, report folder and format.
    #[command(flatten)]
    pub run: FoldRunArgs,
}

impl BenchmarkArgs {
    /// The request these options make, every flag checked before any work.
    ///
    /// # Errors
    /// A flag out of range, named.
    pub fn request(&self) -> anyhow::Result<BenchmarkRequest<'_>> {
        let data = self.data.request()?;
        Ok(BenchmarkRequest {
            config: self.run.config(&data, &self.arms)?,
            estimate_cache: self.run.estimate_cache(&data),
            data,
            sequences: &self.sequences,
            groups: self.folds,
            seeds: &self.seeds,
            shard: self.shard,
            report: self.run.out.as_deref().map(|dir| (dir, FoldRunArgs::command_line("benchmark"))),
            stop_from_now: Some(crate::interrupt::stop_flag),
        })
    }
}

/// Runs the benchmark ([`dynotraj_eval::experiment::benchmark_request::benchmark`]), prints its
/// summary tables and where its report went.
///
/// # Errors
/// Bad flags, loading, training or writing errors, named.
pub fn run(args: &BenchmarkArgs) -> anyhow::Result<()> {
    args.run.out.as_deref().map(|d| dynotraj_formats::atomic::output_folder("--out", d)).transpose()?;
    args.run.check_table(&["weighted", "goal"])?;
    let request = args.request()?;
    let bars = TrainBars::default();
    let output = benchmark(&request, &bars);
    bars.finish();
    match output? {
        BenchmarkOutput::Shard { shard, mine, all } => println!(
            "shard {}/{}: {mine} of {all} trainings in the fold cache of --out; the same command without --shard, once \
             every shard has run, writes the report",
            shard.index, shard.count
        ),
        BenchmarkOutput::Report { sections, loading_seconds, training_seconds, seconds, report } => {
            if args.run.format == Format::Md {
                for s in sections.iter().take(2) {
                    println!("{}\n", s.title);
                    print!("{}", s.table.render(Format::Md));
                    println!();
                }
            } else {
                let named: Vec<(&str, &dynotraj_eval::report::Table)> =
                    sections.iter().take(2).map(|s| (s.stem.as_str(), &s.table)).collect();
                args.run.print_machine(&named)?;
            }
            eprintln!(
                "loading and estimating {loading_seconds:.0} s, training and scoring {training_seconds:.0} s, total \
                 {seconds:.0} s"
            );
            if let Some(path) = report.transpose()? {
                eprintln!("wrote {}", path.display());
            }
        }
    }
    Ok(())
}
