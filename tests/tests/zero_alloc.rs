//! Core must not touch the heap: decoding a whole sequence of frames, running the EKF and its
//! smoother, forecasting and scoring all happen with zero allocations.

use dynotraj_core::gt_ekf::{EkfParams, FixedLagRts, Measurement};
use dynotraj_core::limits::HORIZON;
use dynotraj_core::metrics::{ForecastScores, RpeAccumulator, ace, ade, fde};
use dynotraj_core::predict::{Baseline, Context, Predictor};
use dynotraj_core::wire::{FrameBuf, FrameDecoder, MAX_FRAME_LEN, Message, encode, frame_parts};
use dynotraj_core::{BevState, Point2};
use dynotraj_sim::drive::{DriveSpec, feature_tracks, generate};
use dynotraj_tests::alloc_counter::{CountingAllocator, count_allocations};
use nalgebra::Isometry3;

#[global_allocator]
static ALLOC: CountingAllocator = CountingAllocator;

#[test]
fn core_decodes_filters_predicts_and_scores_without_allocating() {
    // Set-up (may allocate): a drive, its feature tracks, and the encoded byte stream.
    let spec = DriveSpec { frames: 80, label_noise_m: 0.2, label_heading_noise: 0.05, ..DriveSpec::default() };
    let drive = generate(&spec);
    let frames = feature_tracks(&drive, 256, 128, 3);
    let mut stream = Vec::new();
    let mut parts_sent = 0;
    for (k, tracks) in frames.iter().enumerate() {
        for part in frame_parts(k as u32, k as u64 * 100_000, tracks).expect("within capacity") {
            let mut buf: FrameBuf = [0; MAX_FRAME_LEN];
            let n = encode(&Message::FrameTracks(part), &mut buf).expect("encodes");
            stream.extend_from_slice(&buf[..n]);
            parts_sent += 1;
        }
    }
    let car: Vec<BevState> = drive.labels.iter().filter(|l| l.track_id == 1).map(|l| l.truth).collect();
    let noisy: Vec<Measurement> = drive
        .labels
        .iter()
        .filter(|l| l.track_id == 1)
        .map(|l| {
            let w = drive.camera_poses[l.frame as usize] * l.location_cam;
            Measurement {
                position: Some(Point2::new(w.x as f32, w.z as f32)),
                heading: Some(-l.rotation_y as f32),
                speed: None,
            }
        })
        .collect();
    let poses: Vec<Isometry3<f32>> = drive.camera_poses.iter().map(|p| p.cast::<f32>()).collect();

    // Measured: everything core does on the ECU.
    let (result, allocations) = count_allocations(|| {
        let mut decoder = FrameDecoder::new();
        let mut parts = 0usize;
        let mut points = 0usize;
        for chunk in stream.chunks(61) {
            for msg in decoder.feed(chunk) {
                if let Message::FrameTracks(ft) = msg {
                    parts += 1;
                    points += ft.tracks.len();
                }
            }
        }
        let mut rts = FixedLagRts::<20>::new(EkfParams::vehicle(spec.dt));
        let mut smoothed = 0usize;
        for z in &noisy {
            if rts.push(z).is_some() {
                smoothed += 1;
            }
        }
        let mut scores = ForecastScores::default();
        let mut previous = [Point2::default(); HORIZON];
        let mut cv = Baseline::ConstantVelocity;
        for s in 1..car.len() - HORIZON {
            let mut forecast = [Point2::default(); HORIZON];
            cv.predict(&car[..=s], spec.dt, &mut forecast).expect("forecast");
            let mut truth = [Point2::default(); HORIZON];
            for (t, st) in truth.iter_mut().zip(&car[s + 1..=s + HORIZON]) {
                *t = st.position();
            }
            scores.ade.push(ade(&forecast, &truth).unwrap_or(f32::NAN));
            scores.fde.push(fde(&forecast, &truth).unwrap_or(f32::NAN));
            if s > 1 {
                scores.ace.push(ace(&previous, &forecast).unwrap_or(f32::NAN));
            }
            previous = forecast;
        }
        // An estimate that drifts 1 cm a frame along world x: every pair is off by 1 cm.
        let mut rpe = RpeAccumulator::new();
        for (k, p) in poses.iter().enumerate() {
            let drifted = nalgebra::Translation3::new(0.01 * k as f32, 0.0, 0.0) * p;
            rpe.push(p, &drifted);
        }
        (parts, points, decoder.stats(), smoothed, scores, rpe.result())
    });
    let (parts, points, stats, smoothed, scores, rpe) = result;
    assert_eq!(allocations, 0, "core allocated on the heap");
    assert_eq!(parts, parts_sent);
    assert_eq!(points, frames.iter().map(Vec::len).sum::<usize>());
    assert_eq!(stats.frames_rejected(), 0);
    assert_eq!(smoothed, noisy.len() - 20, "one smoothed state per frame once the window is full");
    assert_eq!(scores.ade.count() as usize, car.len() - HORIZON - 1);
    assert!(scores.ade.value().is_some_and(f64::is_finite));
    let rpe = rpe.expect("pairs scored");
    assert_eq!(rpe.pairs, 79);
    assert!((rpe.translation - 0.01).abs() < 1e-4, "RPE of a 1 cm-a-frame drift: {}", rpe.translation);
    assert!(rpe.rotation < 1e-4, "no rotation error: {}", rpe.rotation);
}

#[test]
fn the_counter_sees_allocations() {
    let (v, n) = count_allocations(|| vec![1u8; 100]);
    assert_eq!(v.len(), 100);
    assert!(n >= 1, "the counting allocator must count, or the test above proves nothing");
}

#[test]
fn learned_inference_does_not_allocate() {
    use dynotraj_core::model::blob::{ModelBlob, Precision};
    use dynotraj_core::model::{Dims, LearnedPredictor};
    use dynotraj_sim::cost_inputs::random_blob;

    let history: Vec<BevState> =
        (0..7).map(|i| BevState { x: 0.5 * i as f32, y: 0.1, heading: 0.02 * i as f32, speed: 10.0 }).collect();
    let other: Vec<BevState> =
        (0..7).map(|i| BevState { x: 0.4 * i as f32, y: 5.0, heading: 0.0, speed: 8.0 }).collect();
    for precision in [Precision::Int8, Precision::F32] {
        let bytes = random_blob(&Dims::DEFAULT, precision, 0.05);
        let blob = ModelBlob::parse(&bytes).expect("valid blob");
        let ((), allocations) = count_allocations(|| {
            let mut p = LearnedPredictor::new(blob);
            let neighbours: [&[BevState]; 1] = [&other];
            let mut out = [Point2::default(); HORIZON];
            for _ in 0..10 {
                p.predict_in_context(&history, &Context::with_neighbours(&neighbours), 0.05, &mut out)
                    .expect("forecast");
            }
            assert!(out.iter().all(|q| q.x.is_finite()));
        });
        assert_eq!(allocations, 0, "{precision:?} inference allocated");
    }
}
