//! `dynotraj pedestrians`: the ETH/UCY pedestrian benchmark (leave one scene out) with its report.

use std::path::PathBuf;

use clap::Args;

use super::model_args::DynamicsArg;
use super::train_progress::TrainBars;
use dynotraj_core::model::arch::Dims;
use dynotraj_eval::experiment::report::write_report;
use dynotraj_eval::pedestrian_benchmark::{BenchmarkOptions, ratio_table, report, run, scene_table};
use dynotraj_eval::report::Format;
use dynotraj_train::Hyper;

/// Options of `dynotraj pedestrians`.
#[derive(Debug, Args)]
pub struct PedestriansArgs {
    /// The ETH/UCY folder as the benchmark ships it (`all_data/`, `train/`, `val/`), e.g.
    /// ../shared/trajectories/eth_ucy.
    #[arg(long, value_name = "DIR")]
    pub data: PathBuf,
    /// Scenes held out, comma-separated (eth, hotel, univ, zara1, zara2; default all).
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    pub scenes: Vec<String>,
    /// Network widths: history encoder, edge encoder, latent modes, decoder.
    #[arg(long, default_value = super::model_args::DEFAULT_DIMS, value_parser = super::model_cost::parse_dims, value_name = "ENC,EDGE,K,DEC")]
    pub dims: Dims,
    /// Seed of the weights and the shuffling.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Most epochs per scene (early stopping may end sooner).
    #[arg(long, default_value_t = Hyper::default().epochs)]
    pub epochs: usize,
    /// The learned model's dynamics: Trajectron++'s single integrator for pedestrians (a
    /// velocity residual), or the vehicles' unicycle.
    #[arg(long, value_enum, default_value_t = DynamicsArg::SingleIntegrator)]
    pub dynamics: DynamicsArg,
    /// Score constant velocity and the motion prior only (no training).
    #[arg(long)]
    pub no_train: bool,
    /// Scenes trained at once (default: the cores this process may use).
    #[arg(long, value_parser = dynotraj_eval::jobs::parse_jobs)]
    pub jobs: Option<usize>,
    /// Report folder (REPORT.md, each table as Markdown, CSV and JSON).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

/// Runs the benchmark, prints its tables and writes the report.
///
/// # Errors
/// A recording that cannot be read (named), an unknown scene, training or writing errors.
pub fn run_command(args: &PedestriansArgs) -> anyhow::Result<()> {
    args.out.as_deref().map(|d| dynotraj_formats::atomic::output_folder("--out", d)).transpose()?;
    let start = std::time::Instant::now();
    let options = BenchmarkOptions {
        data: args.data.clone(),
        scenes: args.scenes.clone(),
        dims: args.dims,
        hyper: Hyper { seed: args.seed, epochs: args.epochs, ..Hyper::default() },
        dynamics: args.dynamics.into(),
        train: !args.no_train,
    };
    let bars = TrainBars::default();
    let results = run(&options, args.jobs.unwrap_or_else(dynotraj_eval::jobs::default_jobs), &bars)?;
    bars.finish();
    for (title, table) in [
        ("ADE / FDE per scene (m)", scene_table(&results)),
        ("Ratios, 95 % intervals over walks", ratio_table(&results)),
    ] {
        println!("{title}\n");
        print!("{}", table.render(Format::Md));
        println!();
    }
    if let Some(dir) = &args.out {
        let command = std::env::args().collect::<Vec<_>>().join(" ");
        let path = write_report(dir, &report(&results, &options, command, start.elapsed().as_secs_f64()))?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}
