//! `dynotraj model-cost`: speed and memory of predictor inference on this machine, per object, for
//! float and int8 blobs, beside the baselines.

use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context as _;
use clap::Args;
use dynotraj_core::limits::HORIZON;
use dynotraj_core::model::blob::{Precision, blob_len, write_blob_with};
use dynotraj_core::model::{Dims, LearnedPredictor, Scratch};
use dynotraj_core::predict::{Baseline, Context, Dynamics, Forecast, MotionPrior, PriorSettings};
use dynotraj_core::{BevState, Point2};

use super::common::DEFAULT_DIMS;
use super::common::DynamicsArg;
use dynotraj_core::predict::Predictor;
use dynotraj_eval::report::{Cell, ColumnKind, Data, Format, Table};
use dynotraj_formats::model_file::ModelFile;

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

pub use dynotraj_sim::cost_inputs::{random_blob, random_blob_with};

fn time_per_forecast(f: &mut dyn Predictor, dt: f32, iterations: u32) -> f64 {
    let (history, other) = dynotraj_sim::cost_inputs::forecast_histories();
    let neighbours: [&[BevState]; 1] = [&other];
    let mut out: Forecast = [Point2::default(); HORIZON];
    let _ = f.predict_in_context(&history, &Context::with_neighbours(&neighbours), dt, &mut out);
    let start = Instant::now();
    for _ in 0..iterations {
        let _ = f.predict_in_context(black_box(&history), &Context::with_neighbours(&neighbours), dt, &mut out);
        black_box(&out);
    }
    start.elapsed().as_secs_f64() * 1e6 / f64::from(iterations)
}

/// A model to time: its name, widths, and each precision's blob.
type TimedModel = (String, Dims, Vec<(&'static str, Vec<u8>)>);

/// Times every configuration.
///
/// # Errors
/// A bad --dims or an unreadable model.
pub fn table(args: &ModelCostArgs) -> anyhow::Result<Table> {
    let dt = 0.05;
    use ColumnKind::{Int, Num, Text};
    let mut t =
        Table::new(["predictor", "dims enc,edge,k,dec", "parameters", "blob bytes", "scratch bytes", "us per object"]);
    // Data: the predictor and the model it runs apart; the widths one column each.
    let mut d = Data::new([
        ("predictor", Text),
        ("model", Text),
        ("enc", Int),
        ("edge", Int),
        ("k", Int),
        ("dec", Int),
        ("parameters", Int),
        ("blob_bytes", Int),
        ("scratch_bytes", Int),
        ("us_per_object", Num),
    ]);
    let mut configs: Vec<TimedModel> = Vec::new();
    let dynamics = Dynamics::from(args.dynamics);
    if let Some(path) = &args.model {
        let f = ModelFile::load(path)?;
        let dims = f.blob().dims();
        let int8_path = PathBuf::from(format!("{}.int8", path.display()));
        let blobs = if f.blob().precision() == Precision::Int8 {
            // An int8 blob has no f32 twin to time: its row says int8.
            vec![("int8", f.bytes().to_vec())]
        } else {
            let q = if int8_path.exists() {
                ModelFile::load(&int8_path)?.bytes().to_vec()
            } else {
                let mut buf = vec![0; blob_len(&dims, Precision::Int8)];
                let tensors = dynotraj_formats::model_file::float_tensors(&f.blob());
                let slices: Vec<&[f32]> = tensors.iter().map(Vec::as_slice).collect();
                let b = f.blob();
                write_blob_with(&dims, Precision::Int8, b.frame_period_s(), b.prior(), b.dynamics(), &slices, &mut buf)
                    .map_err(|e| anyhow::anyhow!("quantising {}: {e}", path.display()))?;
                buf
            };
            vec![("f32", f.bytes().to_vec()), ("int8", q)]
        };
        configs.push((format!("{}, {}", path.display(), f.blob().dynamics().name()), dims, blobs));
    } else {
        for d in args.dims.split(';') {
            let dims = parse_dims(d)?;
            if let Some(dir) = &args.out {
                std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
                let path = dir.join(format!("random-{},{},{},{}.int8", dims.enc, dims.edge, dims.k, dims.dec));
                dynotraj_formats::atomic::write_file(&path, random_blob_with(&dims, Precision::Int8, dt, dynamics))
                    .with_context(|| format!("writing {}", path.display()))?;
            }
            configs.push((
                format!("random weights, {}", dynamics.name()),
                dims,
                vec![
                    ("f32", random_blob_with(&dims, Precision::F32, dt, dynamics)),
                    ("int8", random_blob_with(&dims, Precision::Int8, dt, dynamics)),
                ],
            ));
        }
    }
    let fmt_dims = |d: &Dims| format!("{},{},{},{}", d.enc, d.edge, d.k, d.dec);
    for (name, dims, blobs) in &configs {
        for &(precision, ref bytes) in blobs {
            let file = ModelFile::from_bytes(bytes.clone(), name)?;
            let mut p: LearnedPredictor<'_> = file.predictor();
            let us = Cell::num(time_per_forecast(&mut p, dt, args.iterations), 1);
            let sizes = [dims.parameters(), bytes.len(), std::mem::size_of::<Scratch>()].map(Cell::int);
            t.push(
                [format!("{precision} ({name})"), fmt_dims(dims)]
                    .into_iter()
                    .chain(sizes.iter().map(Cell::md))
                    .chain([us.md()]),
            );
            let widths = [dims.enc, dims.edge, dims.k, dims.dec].map(Cell::int);
            d.push(
                [Cell::text(precision), Cell::text(name.as_str())]
                    .into_iter()
                    .chain(widths)
                    .chain(sizes)
                    .chain([us])
                    .collect(),
            );
        }
    }
    let mut prior = MotionPrior(PriorSettings::DEFAULT);
    let mut rows: Vec<(&str, &mut dyn Predictor)> = vec![("prior", &mut prior)];
    let mut baselines = Baseline::ALL;
    rows.extend(baselines.iter_mut().map(|b| (b.name(), b as &mut dyn Predictor)));
    for (name, p) in rows {
        let us = Cell::num(time_per_forecast(p, dt, args.iterations * 10), 2);
        t.push([name.to_string(), "-".into(), "0".into(), "0".into(), "0".into(), us.md()]);
        let blank = [Cell::Blank, Cell::Blank, Cell::Blank, Cell::Blank, Cell::Blank];
        d.push([Cell::text(name)].into_iter().chain(blank).chain([0, 0, 0].map(Cell::int)).chain([us]).collect());
    }
    Ok(t.with_data(d))
}

/// Prints the timings.
///
/// # Errors
/// See [`table`].
pub fn run(args: &ModelCostArgs) -> anyhow::Result<()> {
    print!("{}", table(args)?.render(args.format));
    Ok(())
}
