//! Streams simulated frames through the wire into the core estimator and collects its outputs.

use dynotraj_core::estimate::{Estimator, EstimatorParams, EstimatorStats, NewestFit, PoseEstimate, Pushed};
use dynotraj_core::wire::{FrameBuf, FrameDecoder, MAX_FRAME_LEN, Message, encode};
use dynotraj_formats::tracks_file::TracksFrame;
use dynotraj_sim::track_sim::SimFrame;

/// Which of the estimator's outputs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Kind {
    /// Frame-to-frame (DynoSAM's front-end, causal).
    FrameToFrame,
    /// The smoother's newest frame (causal).
    Causal,
    /// A frame as it leaves the smoother's window (has seen later frames).
    Smoothed,
}

impl Kind {
    /// All kinds, in report order.
    pub const ALL: [Kind; 3] = [Kind::FrameToFrame, Kind::Causal, Kind::Smoothed];

    /// Short name for tables and file names.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Kind::FrameToFrame => "f2f",
            Kind::Causal => "causal",
            Kind::Smoothed => "smoothed",
        }
    }
}

/// The estimator's outputs over a sequence, indexed by position in the simulated frames.
#[derive(Debug, Clone)]
pub struct EstimatorRun {
    /// Frame-to-frame estimate per frame.
    pub frame_to_frame: Vec<Option<PoseEstimate>>,
    /// Causal estimate per frame.
    pub causal: Vec<Option<PoseEstimate>>,
    /// Smoothed estimate per frame.
    pub smoothed: Vec<Option<PoseEstimate>>,
    /// The object fits of each frame, against its causal camera (what
    /// [`super::hybrid::rewrite`] smooths).
    pub fits: Vec<Vec<NewestFit>>,
    /// The estimator's counters at the end.
    pub stats: EstimatorStats,
    /// Bytes sent over the (simulated) link.
    pub wire_bytes: usize,
}

impl EstimatorRun {
    /// A run of `n` frames without any estimate yet.
    #[must_use]
    pub fn empty(n: usize) -> Self {
        Self {
            frame_to_frame: vec![None; n],
            causal: vec![None; n],
            smoothed: vec![None; n],
            fits: vec![Vec::new(); n],
            stats: EstimatorStats::default(),
            wire_bytes: 0,
        }
    }

    /// The estimates of one kind.
    #[must_use]
    pub fn of(&self, kind: Kind) -> &[Option<PoseEstimate>] {
        match kind {
            Kind::FrameToFrame => &self.frame_to_frame,
            Kind::Causal => &self.causal,
            Kind::Smoothed => &self.smoothed,
        }
    }
}

/// Runs an estimator with window `W` over `frames`, each frame split into wire parts, encoded,
/// and decoded again by a streaming decoder before the estimator sees it.
///
/// # Panics
/// Never on estimator input; only if a simulated frame has more tracks than the wire allows
/// (the simulator's budgets are the wire's).
#[must_use]
pub fn run_estimator<const W: usize>(frames: &[SimFrame], params: EstimatorParams, seed: u64) -> EstimatorRun {
    let mut decoder = FrameDecoder::new();
    let mut buf: FrameBuf = [0; MAX_FRAME_LEN];
    let mut bytes = Vec::new();
    let mut wire_bytes = 0;
    let mut received = Vec::with_capacity(frames.len());
    for f in frames {
        bytes.clear();
        let split = TracksFrame::split(f.frame, f.timestamp_us, &f.tracks)
            .expect("the simulator stays within the wire's track budget");
        for part in split.parts {
            let len = encode(&Message::FrameTracks(part), &mut buf).expect("a frame buffer holds any message");
            bytes.extend_from_slice(&buf[..len]);
        }
        wire_bytes += bytes.len();
        let parts =
            decoder.feed(&bytes).filter_map(|m| if let Message::FrameTracks(p) = m { Some(p) } else { None }).collect();
        received.push(TracksFrame { frame: f.frame, timestamp_us: f.timestamp_us, parts });
    }
    let mut run = run_parts::<W>(&received, params, seed);
    run.wire_bytes = wire_bytes;
    run
}

/// Runs an estimator with window `W` over frames already in wire parts (a simulated stream after
/// the link, or a tracks file). Outputs are indexed by position in `frames`.
#[must_use]
pub fn run_parts<const W: usize>(frames: &[TracksFrame], params: EstimatorParams, seed: u64) -> EstimatorRun {
    let mut est: Box<Estimator<W>> = Box::new(Estimator::new(params, seed));
    let n = frames.len();
    let mut run = EstimatorRun::empty(n);
    let index_of = |frame: u32| frames.iter().position(|f| f.frame == frame);
    for (i, f) in frames.iter().enumerate() {
        for part in &f.parts {
            if let Pushed::Frame { smoothed } = est.push(part) {
                let mut e = PoseEstimate::new();
                est.frame_to_frame(&mut e);
                run.frame_to_frame[i] = Some(e.clone());
                est.causal(&mut e);
                run.causal[i] = Some(e);
                run.fits[i] = est.newest_fits().collect();
                if smoothed {
                    let s = est.smoothed();
                    if let Some(j) = index_of(s.frame) {
                        run.smoothed[j] = Some(s.clone());
                    }
                }
            }
        }
    }
    est.flush(|s| {
        if let Some(j) = index_of(s.frame) {
            run.smoothed[j] = Some(s.clone());
        }
    });
    run.stats = *est.stats();
    run
}
