//! The core's hot paths under criterion: one estimator frame at the ECU's full budget (16
//! objects), one forecast of the default-size model in f32 and int8, and decoding a stream of
//! wire frames. Short runs (10 samples, 2 s each) so that `cargo bench` takes a few minutes.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use dynotraj_benches::{estimator_scene, random_blob, wire_stream};
use dynotraj_core::estimate::{
    DEFAULT_WINDOW, Estimator, EstimatorParams, HOST_PROFILE, Intrinsics, PoseEstimate, Pushed,
};
use dynotraj_core::limits::HORIZON;
use dynotraj_core::model::blob::{ModelBlob, Precision};
use dynotraj_core::model::{Dims, LearnedPredictor};
use dynotraj_core::predict::{Context, Forecast, Predictor as _};
use dynotraj_core::wire::FrameDecoder;
use dynotraj_core::{BevState, Point2};

/// Frames pushed before timing starts: the smoothing window fills and objects are initialised.
const WARMUP: usize = 30;
/// Frames simulated; a run that needs more starts a new estimator (its warm-up untimed).
const FRAMES: usize = WARMUP + 120;
const DT: f32 = 0.05;

fn quick(c: &mut Criterion) -> criterion::BenchmarkGroup<'_, criterion::measurement::WallTime> {
    let mut g = c.benchmark_group("core");
    g.sample_size(10).warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(2));
    g
}

fn estimator_frame(c: &mut Criterion) {
    let parts = estimator_scene(FRAMES, 1);
    let mut params = EstimatorParams::kitti(Intrinsics::KITTI_0926, 0.1);
    params.joint_sweeps = HOST_PROFILE.joint_sweeps;
    let mut g = quick(c);
    g.bench_function("estimator frame, 16 objects (host profile)", |b| {
        b.iter_custom(|iters| {
            let mut timed = Duration::ZERO;
            let mut done = 0u64;
            while done < iters {
                let mut est: Box<Estimator<DEFAULT_WINDOW>> = Box::new(Estimator::new(params, 1));
                let mut out = PoseEstimate::new();
                for (k, frame) in parts.iter().enumerate() {
                    if k >= WARMUP && done == iters {
                        break;
                    }
                    let t0 = Instant::now();
                    for p in frame {
                        if let Pushed::Frame { .. } = est.push(p) {
                            est.causal(&mut out);
                        }
                    }
                    black_box(&out);
                    if k >= WARMUP {
                        timed += t0.elapsed();
                        done += 1;
                    }
                }
            }
            timed
        });
    });
    g.finish();
}

fn forecasts(c: &mut Criterion) {
    let (history, other) = dynotraj_sim::cost_inputs::forecast_histories();
    let neighbours: [&[BevState]; 1] = [&other];
    let mut g = quick(c);
    for (name, precision) in
        [("forecast f32 (default dims)", Precision::F32), ("forecast int8 (default dims)", Precision::Int8)]
    {
        let bytes = random_blob(&Dims::DEFAULT, precision, DT);
        let blob = ModelBlob::parse(&bytes).unwrap_or_else(|e| panic!("{name}: {e:?}"));
        let mut p = LearnedPredictor::new(blob);
        let mut out: Forecast = [Point2::default(); HORIZON];
        // A forecast that fails early (a period mismatch, a short history) would time nothing.
        let first = p.predict_in_context(&history, &Context::with_neighbours(&neighbours), DT, &mut out);
        assert!(first.is_ok(), "{name}: {first:?}");
        g.bench_function(name, |b| {
            b.iter(|| {
                let r = p.predict_in_context(black_box(&history), &Context::with_neighbours(&neighbours), DT, &mut out);
                black_box(r.is_ok());
                black_box(&out);
            });
        });
    }
    g.finish();
}

fn wire_decode(c: &mut Criterion) {
    let parts = estimator_scene(20, 2);
    let stream = wire_stream(&parts);
    let messages = parts.iter().map(Vec::len).sum::<usize>();
    let mut g = quick(c);
    g.throughput(Throughput::Bytes(stream.len() as u64));
    g.bench_function(format!("wire decode, {messages} frame parts in 64-byte chunks"), |b| {
        let mut dec = Box::new(FrameDecoder::new());
        b.iter(|| {
            let mut n = 0usize;
            for chunk in stream.chunks(64) {
                n += dec.feed(black_box(chunk)).count();
            }
            assert_eq!(n, messages, "every frame decodes");
        });
    });
    g.finish();
}

criterion_group!(benches, estimator_frame, forecasts, wire_decode);
criterion_main!(benches);
