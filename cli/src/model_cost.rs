//! `dynotraj model-cost`: speed and memory of predictor inference on this machine, per object, for
//! float and int8 blobs, beside the baselines ([`dynotraj_eval::model_cost`]).

use std::path::PathBuf;

use clap::Args;
use dynotraj_core::model::Dims;

use super::model_args::{DEFAULT_DIMS, DynamicsArg};
use dynotraj_eval::model_cost::{ModelCostRequest, model_cost_table};
use dynotraj_eval::report::Format;

/// Options of `dynotraj model-cost`.
#[derive(Debug, Args)]
pub struct ModelCostArgs {
    /// A trained blob. An f32 one is timed with its int8 twin, read from PATH.int8 when
    /// present, else quantised here; an int8 one is timed alone. Without it, blobs of --dims
    /// with seeded random weights are timed (same cost).
    #[arg(long, value_name = "PATH")]
    pub model: Option<PathBuf>,
    /// Widths enc,edge,k,dec (one or more sets separated by `;`) when no --model is given.
    #[arg(long, default_value = DEFAULT_DIMS, value_name = "DIMS")]
    pub dims: String,
    /// Dynamics of the random-weight blobs (a --model's are its own): the unicycle of vehicles
    /// or the single integrator of pedestrians.
    #[arg(long, value_enum, default_value_t = DynamicsArg::Unicycle)]
    pub dynamics: DynamicsArg,
    /// Forecasts timed per configuration.
    #[arg(long, default_value_t = 2000)]
    pub iterations: u32,
    /// Output format.
    #[arg(long, value_parser = crate::numbers::choices(&Format::CHOICES), default_value = "md")]
    pub format: Format,
    /// Folder for each --dims set's seeded random int8 blob, `<DIR>/random-ENC,EDGE,K,DEC.int8`,
    /// to link into the firmware (`DYNOTRAJ_FW_MODEL`) and count its instructions per frame.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

/// Parses `enc,edge,k,dec`.
///
/// # Errors
/// A malformed or unsupported set of widths, named.
pub fn parse_dims(s: &str) -> anyhow::Result<Dims> {
    let v: Vec<usize> = s
        .split(',')
        .map(|p| p.trim().parse::<usize>())
        .collect::<Result<_, _>>()
        .map_err(|e| anyhow::anyhow!("--dims `{s}`: {e}; expected enc,edge,k,dec"))?;
    let [enc, edge, k, dec] = v[..] else { anyhow::bail!("--dims `{s}`: expected four widths enc,edge,k,dec") };
    let d = Dims { enc, edge, k, dec };
    anyhow::ensure!(d.is_supported(), "--dims `{s}`: widths must be 1..=64 (enc, edge), 1..=25 (k), 1..=128 (dec)");
    Ok(d)
}

/// Prints the timings.
///
/// # Errors
/// A bad --dims, an unreadable model or a blob that cannot be written.
pub fn run(args: &ModelCostArgs) -> anyhow::Result<()> {
    print!("{}", model_cost_table(&args.request()?)?.render(args.format));
    Ok(())
}

impl ModelCostArgs {
    /// What these options ask to time.
    ///
    /// # Errors
    /// A bad --dims, named.
    pub fn request(&self) -> anyhow::Result<ModelCostRequest> {
        Ok(ModelCostRequest {
            model: self.model.clone(),
            dims: self.dims.split(';').map(parse_dims).collect::<anyhow::Result<_>>()?,
            dynamics: self.dynamics.into(),
            iterations: self.iterations,
            out: self.out.clone(),
        })
    }
}
