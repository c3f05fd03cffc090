//! The estimator touches no heap: decoding a whole simulated sequence from the wire, assembling
//! frames, fitting, smoothing, reading every output and flushing allocate nothing.

use dynotraj_core::estimate::{DEFAULT_WINDOW, Estimator, EstimatorParams, Intrinsics, PoseEstimate, Pushed};
use dynotraj_core::wire::{FrameBuf, FrameDecoder, MAX_FRAME_LEN, Message, encode, frame_parts};
use dynotraj_sim::drive::{DriveSpec, generate};
use dynotraj_sim::track_sim::{LabelBox, SimSpec, simulate};
use dynotraj_tests::alloc_counter::{CountingAllocator, count_allocations};

#[global_allocator]
static ALLOC: CountingAllocator = CountingAllocator;

#[test]
fn a_whole_sequence_allocates_nothing() {
    // Set-up (may allocate): a simulated sequence at full budget, encoded as a byte stream.
    let drive = generate(&DriveSpec { frames: 60, ..DriveSpec::default() });
    let spec = SimSpec::kitti(Intrinsics::KITTI_0926, (1242.0, 375.0), 0.1, 11);
    let frames = simulate(&drive.camera_poses, &LabelBox::of_drive(&drive), &spec);
    let mut stream = Vec::new();
    for f in &frames {
        for part in frame_parts(f.frame, f.timestamp_us, &f.tracks).expect("within the wire budget") {
            let mut buf: FrameBuf = [0; MAX_FRAME_LEN];
            let n = encode(&Message::FrameTracks(part), &mut buf).expect("encodes");
            stream.extend_from_slice(&buf[..n]);
        }
    }
    let params = EstimatorParams::kitti(Intrinsics::KITTI_0926, 0.1);

    // Measured: everything the ECU does with the stream.
    let ((estimated, smoothed, objects), allocations) = count_allocations(|| {
        let mut est: Estimator<DEFAULT_WINDOW> = Estimator::new(params, 3);
        let mut decoder = FrameDecoder::new();
        let mut out = PoseEstimate::new();
        let (mut estimated, mut smoothed, mut objects) = (0usize, 0usize, 0usize);
        for chunk in stream.chunks(97) {
            for msg in decoder.feed(chunk) {
                let Message::FrameTracks(part) = msg else { continue };
                if let Pushed::Frame { smoothed: s } = est.push(&part) {
                    estimated += 1;
                    est.causal(&mut out);
                    objects += out.objects.len();
                    est.frame_to_frame(&mut out);
                    let _ = out.to_wire(dynotraj_core::wire::EstimateKind::Causal);
                    if s {
                        smoothed += 1;
                        let _ = est.smoothed().to_wire(dynotraj_core::wire::EstimateKind::Smoothed);
                    }
                    objects += est.map_points().count();
                }
            }
        }
        est.flush(|_| smoothed += 1);
        (estimated, smoothed, objects)
    });
    assert_eq!(estimated, 60);
    assert_eq!(smoothed, 60, "every frame leaves the window once, flushed at the end");
    assert!(objects > 100);
    assert_eq!(allocations, 0, "the estimator allocated {allocations} times");
}
