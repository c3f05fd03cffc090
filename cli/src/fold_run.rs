//! Options shared by the commands that train folds and write a report (`experiment`,
//! `benchmark`): widths, training settings, the report folder with its caches, the format.

use std::path::PathBuf;

use clap::Args;

use super::model_args::DEFAULT_DIMS;
use super::model_cost::parse_dims;
use super::train::HyperArgs;
use dynotraj_eval::experiment::ExperimentConfig;
use dynotraj_eval::loading::DataRequest;
use dynotraj_eval::report::{Format, check_table, render_tables};
use dynotraj_sources::trajectory::Source;

/// Training and report options of a run of folds.
#[derive(Debug, Args)]
pub struct FoldRunArgs {
    /// Model widths enc,edge,k,dec.
    #[arg(long, default_value = DEFAULT_DIMS, value_name = "DIMS")]
    pub dims: String,
    /// Training settings of every fold.
    #[command(flatten)]
    pub hyper: HyperArgs,
    /// Report folder, e.g. reports/kitti: REPORT.md, every table as Markdown and CSV,
    /// figures/, each fold's model blobs in models/ (`<arm>-<held-out ids>.blob`, `.blob.int8`)
    /// and the fold and estimate cache in cache/ (a rerun trains only folds whose inputs
    /// changed).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Estimate and train everything again even when the cache holds it.
    #[arg(long)]
    pub no_cache: bool,
    /// Output format of the tables printed: md, csv or json (one observation per row; JSON of
    /// several tables is one object keyed by table name). The report folder has every table in
    /// all three, one file each.
    #[arg(long, value_parser = crate::numbers::choices(&Format::CHOICES), default_value = "md")]
    pub format: Format,
    /// With --format csv or json, print only this table (named as its file in the report
    /// folder, e.g. table_iv). CSV holds one table, so it needs this flag whenever several
    /// tables are printed.
    #[arg(long, value_name = "NAME")]
    pub table: Option<String>,
}

impl FoldRunArgs {
    /// Checks `--table` before the run (which may take hours) against `names`, the tables the
    /// command may print.
    ///
    /// # Errors
    /// `--table` with Markdown or naming another table; CSV without `--table` when several
    /// tables may be printed.
    pub fn check_table(&self, names: &[&str]) -> anyhow::Result<()> {
        check_table(self.format, self.table.as_deref(), names)
    }

    /// Prints `named` tables in `--format` (CSV and JSON only; `--table` choosing one).
    ///
    /// # Errors
    /// See [`render_tables`].
    pub fn print_machine(&self, named: &[(&str, &dynotraj_eval::report::Table)]) -> anyhow::Result<()> {
        print!("{}", render_tables(self.format, self.table.as_deref(), named)?);
        Ok(())
    }

    /// The fold cache: the report's cache/, none with `--no-cache` or without `--out`.
    #[must_use]
    pub fn fold_cache(&self) -> Option<PathBuf> {
        self.out.as_ref().filter(|_| !self.no_cache).map(|d| d.join("cache"))
    }

    /// Where estimates are kept: `--estimate-cache`, else the report's cache; none with
    /// `--no-cache` (which recomputes the estimates too).
    #[must_use]
    pub fn estimate_cache(&self, data: &DataRequest) -> Option<PathBuf> {
        data.estimate.cache.clone().filter(|_| !self.no_cache).or_else(|| self.fold_cache())
    }

    /// The run's configuration for `arms` over `data`, without folds (the command makes them).
    ///
    /// # Errors
    /// A flag out of range, named.
    pub fn config(&self, data: &DataRequest, arms: &[Source]) -> anyhow::Result<ExperimentConfig> {
        Ok(ExperimentConfig {
            arms: arms.to_vec(),
            folds: Vec::new(),
            dims: parse_dims(&self.dims)?,
            hyper: self.hyper.hyper()?,
            validation_fraction: self.hyper.val_fraction,
            mirror: self.hyper.mirror,
            prior: self.hyper.prior_choice(),
            validate_on_sequences: self.hyper.val_sequences,
            dt: data.dt,
            rule: data.rule.clone(),
            out: self.out.as_ref().map(|d| d.join("models")),
            cache: self.fold_cache(),
            jobs: data.jobs,
            stop: None,
        })
    }

    /// The command line a report names: `dynotraj <command>` and the arguments given.
    #[must_use]
    pub fn command_line(command: &str) -> String {
        std::iter::once(format!("dynotraj {command}")).chain(std::env::args().skip(2)).collect::<Vec<_>>().join(" ")
    }
}
