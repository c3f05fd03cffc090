//! `dynotraj benchmark`: the generalisation benchmark (every sequence held out once, in folds of
//! whole sequences, several seeds) with its report folder.

use clap::Args;

use super::data_args::DataArgs;
use super::fold_run::FoldRunArgs;
use super::train_progress::TrainBars;
use dynotraj_eval::experiment::benchmark::{DEFAULT_GROUPS, run_benchmark, sequence_groups};
use dynotraj_eval::experiment::benchmark_report::{benchmark_report, benchmark_sections};
use dynotraj_eval::experiment::fold_specs;
use dynotraj_eval::experiment::report::write_report;
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

/// Runs the benchmark, prints its summary tables and writes the report.
///
/// # Errors
/// Loading, training or writing errors, named.
pub fn run(args: &BenchmarkArgs) -> anyhow::Result<()> {
    args.run.out.as_deref().map(|d| dynotraj_formats::atomic::output_folder("--out", d)).transpose()?;
    args.run.check_table(&["weighted", "goal"])?;
    args.run.check(&args.data, &args.arms)?;
    // Before the (possibly long) loading: a shard's folds go nowhere without a fold cache.
    anyhow::ensure!(
        args.shard.is_none() || (args.run.out.is_some() && !args.run.no_cache),
        "--shard: needs a fold cache (--out DIR, without --no-cache): it is where the shards' folds meet"
    );
    let start = std::time::Instant::now();
    let sequences = args.data.load_cached(&args.sequences, &args.arms, args.run.estimate_cache(&args.data))?;
    let loaded_s = start.elapsed().as_secs_f64();
    let ids: Vec<String> = sequences.iter().map(|s| s.id.clone()).collect();
    let folds = sequence_groups(&ids, args.folds);
    anyhow::ensure!(
        folds.len() >= 2,
        "--folds: the benchmark needs at least two folds, found {} sequence(s) for {} fold(s)",
        ids.len(),
        args.folds
    );
    let mut config = args.run.config(&args.data, &args.arms, folds)?.with_present_agents(&sequences);
    // From here on Ctrl-C or SIGTERM stops between folds, keeping what the fold cache holds.
    config.stop = Some(crate::interrupt::stop_flag()?);
    if let Some(shard) = args.shard {
        let bars = TrainBars::new(fold_specs(&config, &args.seeds).len().div_ceil(shard.count));
        let done = dynotraj_eval::experiment::benchmark::train_shard(&sequences, &config, &args.seeds, shard, &bars);
        bars.finish();
        let (mine, all) = done?;
        println!(
            "shard {}/{}: {mine} of {all} trainings in the fold cache of --out; the same command without --shard, once \
             every shard has run, writes the report",
            shard.index, shard.count
        );
        return Ok(());
    }
    let bars = TrainBars::new(fold_specs(&config, &args.seeds).len());
    let result = run_benchmark(&sequences, &config, &args.seeds, &bars);
    bars.finish();
    let result = result?;
    let seconds = start.elapsed().as_secs_f64();
    let sections = benchmark_sections(&result, &config, &sequences, (&args.data.rule()?, &args.seeds))?;
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
        "loading and estimating {loaded_s:.0} s, training and scoring {:.0} s, total {seconds:.0} s",
        result.seconds
    );
    if let Some(dir) = &args.run.out {
        let mut command = String::from("dynotraj benchmark");
        for a in std::env::args().skip(2) {
            command.push(' ');
            command.push_str(&a);
        }
        let report = benchmark_report(dir, sections, &result, &config, &sequences, (command, loaded_s, seconds))?;
        let path = write_report(dir, &report)?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}
