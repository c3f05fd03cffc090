//! The edge's work per message: tracks -> estimator -> histories -> predictor -> messages out.

use dynotraj_core::estimate::{
    EDGE_PROFILE, Estimator, EstimatorParams, EstimatorStats, Intrinsics, PoseEstimate, Pushed,
};
use dynotraj_core::geometry::{BevState, Point2, bev_point};
use dynotraj_core::limits::{HORIZON, MAX_OBJECTS, PAPER_FRAME_RATE_HZ, PRIOR_STATES};
use dynotraj_core::model::blob::ModelBlob;
use dynotraj_core::model::kernel::Kernel;
use dynotraj_core::model::{Scratch, forecast};
use dynotraj_core::predict::{Carry, Context, Dynamics, Forecast, ForecastMemory, constant_velocity};
use dynotraj_core::wire::{CameraInfo, EstimateKind, FrameStats, FrameTracks, Message, Prediction};
use dynotraj_dsp::DspDot;
use heapless::Vec;

use crate::history::Histories;
use crate::transport::Clock;

/// Agent types, each with a model slot: [`Dynamics::ALL`].
const AGENT_TYPES: usize = Dynamics::ALL.len();

/// Seed of the estimator's RANSAC sampling: fixed, so every build of the edge computes the
/// same bits from the same stream.
pub const ESTIMATOR_SEED: u64 = 0x6479_6e6f;

/// The estimator's smoothing window on the edge, frames: the edge profile's
/// ([`dynotraj_core::estimate::EDGE_PROFILE`]). Both edge builds use it, so they compute the
/// same bits.
pub const EDGE_WINDOW: usize = EDGE_PROFILE.window;

/// The estimator parameters of the edge: the edge profile's for this camera. On the track
/// simulator the joint solve the host profile adds leaves object RPE unchanged (0.110 vs
/// 0.105-0.110 m) for about three times the compute (docs/results.md), and under QEMU its extra
/// stack did not fit beside the window in 128 KiB.
const fn edge_params(intrinsics: Intrinsics, dt: f32) -> EstimatorParams {
    EDGE_PROFILE.params(intrinsics, dt)
}

/// The edge's own counters, beyond the estimator's and the decoder's.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EdgeStats {
    /// Camera frames estimated.
    pub frames_estimated: u32,
    /// Camera frames never estimated: gaps in the frame numbers of estimated frames (a frame
    /// whose parts were lost on the link is one).
    pub frames_lost: u32,
    /// Frames that arrived before any camera model; not estimated.
    pub frames_without_camera: u32,
    /// Forecasts sent.
    pub forecasts: u32,
    /// Forecasts the learned model could not make (for instance a frame rate it was not
    /// trained at), made by constant velocity instead.
    pub forecasts_fallback: u32,
    /// Objects with a history that got no forecast at all (non-finite states).
    pub forecasts_failed: u32,
    /// Messages the edge does not consume (sent the wrong way, or a model after the frames).
    pub messages_ignored: u32,
}

impl EdgeStats {
    /// Every counter at zero.
    pub const ZERO: Self = Self {
        frames_estimated: 0,
        frames_lost: 0,
        frames_without_camera: 0,
        forecasts: 0,
        forecasts_fallback: 0,
        forecasts_failed: 0,
        messages_ignored: 0,
    };
}

impl Default for EdgeStats {
    fn default() -> Self {
        Self::ZERO
    }
}

/// The estimator and the predictor over one stream, and what they keep between frames.
/// `W` is the estimator's smoothing window.
#[derive(Debug)]
pub struct Pipeline<'m, const W: usize = EDGE_WINDOW> {
    estimator: Estimator<W>,
    camera: Option<CameraInfo>,
    /// Frame period of forecasts, seconds (from the camera model's rate).
    dt: f32,
    estimate: PoseEstimate,
    histories: Histories,
    /// The learned model of each agent type ([`Dynamics::index`]), if any: only these small
    /// views change with the models. An object whose agent type has none is forecast by
    /// constant velocity.
    models: [Option<Kernel<'m, DspDot>>; AGENT_TYPES],
    /// The learned model's working memory, built with the edge (a predictor built when a model
    /// arrives would put its 8 KiB of scratch on the stack for a moment).
    scratch: Scratch,
    /// Each object's last forecast, which its next carries as the model's prior says.
    forecasts: ForecastMemory<MAX_OBJECTS>,
    stats: EdgeStats,
    last_frame: Option<u32>,
    /// Compute spent on parts of the frame being assembled.
    pending_compute: u64,
}

impl<const W: usize> Default for Pipeline<'_, W> {
    fn default() -> Self {
        Self::new()
    }
}

impl<'m, const W: usize> Pipeline<'m, W> {
    /// An edge with no camera model yet and no learned model (constant-velocity forecasts).
    #[must_use]
    pub const fn new() -> Self {
        let dt = 1.0 / PAPER_FRAME_RATE_HZ;
        Self {
            estimator: Estimator::new(edge_params(Intrinsics::KITTI_0926, dt), ESTIMATOR_SEED),
            camera: None,
            dt,
            estimate: PoseEstimate::new(),
            histories: Histories::new(),
            models: [const { None }; AGENT_TYPES],
            scratch: Scratch::ZERO,
            forecasts: ForecastMemory::new(),
            stats: EdgeStats::ZERO,
            last_frame: None,
            pending_compute: 0,
        }
    }

    /// Back to the state of [`Pipeline::new`], in place (no second edge on the stack: the MCU
    /// keeps the edge in a static and has less stack than its size).
    pub fn reset(&mut self) {
        // Every field named (no `..`), as in `Estimator::reset`.
        // The scratch is working memory, written before it is read by every forecast.
        let Self {
            estimator,
            camera,
            dt,
            estimate,
            histories,
            models,
            scratch: _,
            forecasts,
            stats,
            last_frame,
            pending_compute,
        } = self;
        *dt = 1.0 / PAPER_FRAME_RATE_HZ;
        estimator.reset(edge_params(Intrinsics::KITTI_0926, *dt), ESTIMATOR_SEED);
        *camera = None;
        estimate.reset(0, 0);
        *histories = Histories::new();
        forecasts.clear();
        *models = [const { None }; AGENT_TYPES];
        *stats = EdgeStats::ZERO;
        *last_frame = None;
        *pending_compute = 0;
    }

    /// Forecasts the agents of `blob`'s dynamics with its learned model from now on (the
    /// model of the other agent type stays).
    pub fn set_model(&mut self, blob: ModelBlob<'m>) {
        let dynamics = blob.dynamics();
        if let Some(slot) = self.models.get_mut(dynamics.index()) {
            *slot = Some(Kernel::with_dot(blob));
        }
    }

    /// Whether a learned model is in use, for any agent type.
    #[must_use]
    pub fn has_model(&self) -> bool {
        self.models.iter().any(Option::is_some)
    }

    /// The edge's counters.
    #[must_use]
    pub const fn stats(&self) -> &EdgeStats {
        &self.stats
    }

    /// The estimator (for its counters).
    #[must_use]
    pub const fn estimator(&self) -> &Estimator<W> {
        &self.estimator
    }

    /// Takes one message from the link; messages for the host go to `out` in order: per
    /// estimated frame its causal [`Message::ObjectStates`], the smoothed one of the frame
    /// leaving the window (if any), one [`Message::Prediction`] per object with a history, and
    /// a [`Message::FrameStats`]. `bytes_dropped` is the link's count so far, for the stats.
    ///
    /// # Errors
    /// Whatever `out` returns; the edge's state stays consistent.
    pub fn handle<C: Clock, E>(
        &mut self,
        msg: &Message,
        clock: &mut C,
        bytes_dropped: u32,
        out: &mut impl FnMut(&Message) -> Result<(), E>,
    ) -> Result<(), E> {
        match msg {
            Message::CameraInfo(info) => {
                self.start_stream(info);
                Ok(())
            }
            Message::FrameTracks(part) => self.on_part(part, clock, bytes_dropped, out),
            Message::ObjectStates(_)
            | Message::Prediction(_)
            | Message::ModelChunk(_)
            | Message::LinkStats(_)
            | Message::FrameStats(_)
            | Message::Notice(_) => {
                self.stats.messages_ignored = self.stats.messages_ignored.saturating_add(1);
                Ok(())
            }
        }
    }

    /// A (new) camera model starts a new stream: the estimator starts afresh with it. Never
    /// inlined: the fresh histories (2 KiB) are built on its own stack frame.
    #[inline(never)]
    fn start_stream(&mut self, info: &CameraInfo) {
        let rate = info.frame_rate_hz;
        self.dt = if rate.is_finite() && rate > 0.0 { 1.0 / rate } else { 1.0 / PAPER_FRAME_RATE_HZ };
        let params = edge_params(Intrinsics::from(info), self.dt);
        self.estimator.reset(params, ESTIMATOR_SEED);
        self.camera = Some(*info);
        self.histories = Histories::new();
        self.forecasts.clear();
        self.last_frame = None;
        self.pending_compute = 0;
        // In hundredths of a hertz: formatting a float would cost the firmware 10 KB of flash.
        let centi_hz = (rate * 100.0) as u32;
        log::info!(
            "stream start: camera {}x{} at {}.{:02} Hz",
            info.width,
            info.height,
            centi_hz / 100,
            centi_hz % 100
        );
    }

    /// Never inlined, as the estimator's phases: its locals are on the stack only while a part
    /// is handled, not under everything else the link does.
    #[inline(never)]
    fn on_part<C: Clock, E>(
        &mut self,
        part: &FrameTracks,
        clock: &mut C,
        bytes_dropped: u32,
        out: &mut impl FnMut(&Message) -> Result<(), E>,
    ) -> Result<(), E> {
        if self.camera.is_none() {
            if part.part == 0 {
                self.stats.frames_without_camera = self.stats.frames_without_camera.saturating_add(1);
                if self.stats.frames_without_camera == 1 {
                    log::warn!(
                        "frame {} arrived before any camera model: not estimated (nor any until one)",
                        part.frame
                    );
                }
            }
            return Ok(());
        }
        let before = *self.estimator.stats();
        let t0 = clock.now();
        let pushed = self.estimator.push(part);
        self.pending_compute = self.pending_compute.saturating_add(clock.now().saturating_sub(t0));
        log_capacity(part.frame, &before, self.estimator.stats());
        let Pushed::Frame { smoothed } = pushed else { return Ok(()) };

        let t0 = clock.now();
        self.estimator.causal(&mut self.estimate);
        self.histories.update(&self.estimate);
        let mut compute = core::mem::take(&mut self.pending_compute).saturating_add(clock.now().saturating_sub(t0));
        self.count_frame(self.estimate.frame);
        emit(out, || Message::ObjectStates(self.estimate.to_wire(EstimateKind::Causal)))?;
        if smoothed {
            emit(out, || Message::ObjectStates(self.estimator.smoothed().to_wire(EstimateKind::Smoothed)))?;
        }
        let mut sent: u16 = 0;
        for i in 0..self.histories.current().len() {
            let t0 = clock.now();
            let forecast = self.forecast(i);
            compute = compute.saturating_add(clock.now().saturating_sub(t0));
            if let Some(p) = forecast {
                emit(out, || Message::Prediction(p))?;
                sent = sent.saturating_add(1);
            }
        }
        self.stats.forecasts = self.stats.forecasts.saturating_add(u32::from(sent));
        let e = self.estimator.stats();
        log::debug!(
            "frame {} objects {} forecasts {} compute {}",
            self.estimate.frame,
            self.estimate.objects.len(),
            sent,
            compute
        );
        let stats = FrameStats {
            frame: self.estimate.frame,
            frames_lost: self.stats.frames_lost,
            objects: u16::try_from(self.estimate.objects.len()).unwrap_or(u16::MAX),
            predictions: sent,
            objects_dropped: e.runs_evicted.saturating_add(self.stats.forecasts_failed),
            tracks_dropped: e
                .static_tracks_dropped
                .saturating_add(e.object_points_dropped)
                .saturating_add(e.object_tracks_dropped),
            bytes_dropped,
            compute: u32::try_from(compute).unwrap_or(u32::MAX),
            unit: C::UNIT,
        };
        emit(out, || Message::FrameStats(stats))
    }

    fn count_frame(&mut self, frame: u32) {
        if let Some(last) = self.last_frame
            && frame > last
        {
            self.stats.frames_lost = self.stats.frames_lost.saturating_add(frame - last - 1);
            if frame - last > 1 {
                log::warn!(
                    "frames lost: {} before frame {} ({} in all)",
                    frame - last - 1,
                    frame,
                    self.stats.frames_lost
                );
            }
        }
        self.last_frame = Some(frame);
        self.stats.frames_estimated = self.stats.frames_estimated.saturating_add(1);
    }

    /// The forecast of the `i`-th current object, with the other objects as neighbours; `None`
    /// while its history is too short (a new object) or when no forecast can be made.
    #[inline(never)]
    fn forecast(&mut self, i: usize) -> Option<Prediction> {
        let current = self.histories.current();
        let own = current.get(i)?;
        let history = own.states();
        if history.len() < 2 {
            return None;
        }
        let mut neighbours: Vec<&[BevState], MAX_OBJECTS> = Vec::new();
        for (j, h) in current.iter().enumerate() {
            if j != i {
                let _ = neighbours.push(h.states());
            }
        }
        let mut points: Forecast = [Point2::new(0.0, 0.0); HORIZON];
        let mut long = [BevState { x: 0.0, y: 0.0, heading: 0.0, speed: 0.0 }; PRIOR_STATES];
        let long = own.long_states(&mut long);
        // Seen from the camera the objects were placed against: the range the model reads.
        let observer = Some(bev_point(&self.estimate.camera.translation.vector.into()));
        let context = Context { neighbours: &neighbours, observer };
        let model = self.models.get(Dynamics::of_class(own.class).index()).and_then(Option::as_ref);
        let learned = model.map(|k| forecast(k, &mut self.scratch, long, &context, self.dt, &mut points));
        // The model's carry for its own forecasts; a constant-velocity fallback carries none.
        let carry = match (model, &learned) {
            (Some(k), Some(Ok(()))) => k.blob().prior().carry(),
            _ => Carry::NONE,
        };
        let ok = match learned {
            Some(Ok(())) => true,
            Some(Err(e)) => {
                self.stats.forecasts_fallback = self.stats.forecasts_fallback.saturating_add(1);
                if self.stats.forecasts_fallback == 1 {
                    log::warn!("learned model failed ({e:?}): constant velocity instead (counted, not logged again)");
                }
                constant_velocity(history, self.dt, &mut points).is_ok()
            }
            None => constant_velocity(history, self.dt, &mut points).is_ok(),
        };
        if !ok {
            self.stats.forecasts_failed = self.stats.forecasts_failed.saturating_add(1);
            if self.stats.forecasts_failed == 1 {
                log::warn!("object {}: no forecast (non-finite states; counted, not logged again)", own.object_id);
            }
            return None;
        }
        self.forecasts.blend(u32::from(own.object_id), self.estimate.frame, carry, &mut points);
        Some(Prediction {
            frame: self.estimate.frame,
            object_id: own.object_id,
            dt: self.dt,
            points: Vec::from_slice(&points).ok()?,
        })
    }
}

/// Builds a message and hands it to `out`, in a stack frame of its own: a [`Message`] is as
/// large as its largest variant (about 2 KiB), and built inline each would stay in the caller's
/// frame for the whole camera frame (measured on the MCU: 7.3 KiB of stack in `on_part`).
#[inline(never)]
fn emit<E>(out: &mut impl FnMut(&Message) -> Result<(), E>, build: impl FnOnce() -> Message) -> Result<(), E> {
    out(&build())
}

/// Says when a capacity of the estimator was first reached in a stream (warning: the first
/// drop of each kind; every later one at debug level, so not a line per frame at warning).
fn log_capacity(frame: u32, before: &EstimatorStats, after: &EstimatorStats) {
    if !log::log_enabled!(log::Level::Warn) {
        return;
    }
    let drops = [
        ("static tracks dropped (static capacity)", before.static_tracks_dropped, after.static_tracks_dropped),
        ("object points dropped (per-object capacity)", before.object_points_dropped, after.object_points_dropped),
        ("object tracks dropped (object capacity)", before.object_tracks_dropped, after.object_tracks_dropped),
        ("runs evicted (run capacity)", before.runs_evicted, after.runs_evicted),
    ];
    for (what, was, now) in drops {
        if now > was {
            if was == 0 {
                log::warn!("capacity reached at frame {frame}: {} {what}; later drops only counted", now - was);
            } else {
                log::debug!("frame {frame}: {} {what}", now - was);
            }
        }
    }
}
