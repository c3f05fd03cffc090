//! Speed and memory of predictor inference on this machine, per object, for float and int8
//! blobs, beside the motion prior and the baselines (what `dynotraj model-cost` prints).

use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context as _;
use dynotraj_core::limits::HORIZON;
use dynotraj_core::model::blob::{Precision, blob_len, write_blob_with};
use dynotraj_core::model::{Dims, LearnedPredictor, Scratch};
use dynotraj_core::predict::{Baseline, Context, Dynamics, Forecast, MotionPrior, Predictor, PriorSettings};
use dynotraj_core::{BevState, Point2};
use dynotraj_formats::model_file::ModelFile;
use dynotraj_sim::cost_inputs::random_blob_with;

use crate::report::{Cell, ColumnKind, Data, Table};

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

/// What to time: a trained blob, or random-weight blobs of given widths.
#[derive(Debug, Clone)]
pub struct ModelCostRequest {
    /// A trained blob. An f32 one is timed with its int8 twin, read from PATH.int8 when
    /// present, else quantised here; an int8 one is timed alone.
    pub model: Option<PathBuf>,
    /// Without a model: the widths of the random-weight blobs timed.
    pub dims: Vec<Dims>,
    /// Dynamics of the random-weight blobs.
    pub dynamics: Dynamics,
    /// Forecasts timed per configuration (ten times as many for the baselines).
    pub iterations: u32,
    /// Where each random-weight int8 blob is written, `random-ENC,EDGE,K,DEC.int8`.
    pub out: Option<PathBuf>,
}

/// Times every configuration, and the motion prior and the baselines beside them.
///
/// # Errors
/// An unreadable model or a blob that cannot be written, named.
pub fn model_cost_table(args: &ModelCostRequest) -> anyhow::Result<Table> {
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
    let dynamics = args.dynamics;
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
        for &dims in &args.dims {
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
