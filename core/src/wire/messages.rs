//! The messages of the pipeline: the one definition shared by host and edge.
//!
//! Frames of reference: "world" is the camera-convention frame of the first camera pose of a
//! sequence (x right, y down, z forward, as KITTI's odometry poses); bird's-eye quantities live
//! on its (x, z) plane, as in [`crate::geometry`].
//!
//! Compatibility: postcard encodes fields in declaration order and enum variants by index, so
//! any change here other than appending a [`Message`] variant changes the protocol and must bump
//! [`super::PROTOCOL_VERSION`].

use heapless::Vec;
use postcard::experimental::max_size::MaxSize;
use serde::{Deserialize, Serialize};

use super::{DecoderStats, Notice, ObjectClass};
use crate::geometry::{BevState, Point2};
use crate::limits::{HORIZON, MAX_OBJECTS};

/// Most tracks in one [`FrameTracks`] message: 64 keep the largest wire frame
/// ([`super::MAX_FRAME_LEN`]) under 1.5 KB, a receive buffer any Cortex-M4 can afford.
pub const TRACKS_PER_MESSAGE: usize = 64;
/// Most model bytes in one [`ModelChunk`].
pub const MODEL_CHUNK_LEN: usize = 128;
/// The object id of the static background: a track with this id belongs to no object.
pub const STATIC_OBJECT_ID: u16 = 0;

/// Any message of the pipeline: what one wire frame carries.
///
/// Its size is that of the largest variant (a full [`FrameTracks`]): without `alloc` there is
/// nothing to box, and receivers hold one message at a time.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, MaxSize)]
pub enum Message {
    /// Host -> edge: one part of one camera frame's feature tracks.
    FrameTracks(FrameTracks),
    /// Edge -> host: the estimated camera pose and object states at a frame.
    ObjectStates(ObjectStates),
    /// Edge -> host: one object's forecast.
    Prediction(Prediction),
    /// Host -> edge: one piece of a predictor model blob.
    ModelChunk(ModelChunk),
    /// Either way: the sender's link health.
    LinkStats(LinkStats),
    /// Host -> edge: the camera model of the stream; sent first and whenever it changes.
    CameraInfo(CameraInfo),
    /// Edge -> host: what the edge did with one camera frame (sent after its forecasts).
    FrameStats(FrameStats),
    /// Edge -> host: an event of the session (a model refused, the link busy or idle).
    Notice(Notice),
}

/// The camera model the tracks of a stream are measured with (rectified pinhole, left camera as
/// reference). A stream or a tracks file starts with it: the edge cannot estimate without it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct CameraInfo {
    /// Focal length along u, pixels.
    pub fx: f32,
    /// Focal length along v, pixels.
    pub fy: f32,
    /// Principal point u, pixels.
    pub cx: f32,
    /// Principal point v, pixels.
    pub cy: f32,
    /// Stereo baseline times fx, pixel metres (disparity = `stereo_fb / depth`); zero or less
    /// for a depth sensor without a stereo noise model.
    pub stereo_fb: f32,
    /// Image width, pixels.
    pub width: u16,
    /// Image height, pixels.
    pub height: u16,
    /// Nominal frame rate, Hz (the paper treats KITTI as 20).
    pub frame_rate_hz: f32,
}

/// One feature track's observation in the current frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct Track {
    /// Track id, stable for as long as the front-end follows the feature.
    pub track_id: u32,
    /// Owning object, or [`STATIC_OBJECT_ID`] for the static background.
    pub object_id: u16,
    /// Class of the owning object ([`ObjectClass::Background`] for static tracks).
    pub class: ObjectClass,
    /// Pixel column in the left (reference) image.
    pub u: f32,
    /// Pixel row in the left (reference) image.
    pub v: f32,
    /// Depth along the optical axis, metres.
    pub depth: f32,
}

impl Track {
    /// True when the track belongs to the static background.
    #[must_use]
    pub const fn is_static(&self) -> bool {
        self.object_id == STATIC_OBJECT_ID
    }
}

/// One part of one camera frame's feature tracks.
///
/// A whole frame (up to [`super::MAX_FRAME_TRACKS`] tracks) does not fit one MCU receive
/// buffer, so it travels as `parts` messages numbered `part = 0..parts`, all with the same
/// `frame` and `timestamp_us`, each with at most [`TRACKS_PER_MESSAGE`] tracks in the sender's
/// order; every part but the last is full. A frame without tracks is one empty part, so the
/// receiver still learns of the frame and its time. The receiver has the frame once it holds
/// all `parts` parts; a part of another frame arriving first means parts were lost, and the
/// incomplete frame is dropped (and counted) by the receiver. [`super::frame_parts`] makes the
/// parts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct FrameTracks {
    /// Camera frame index.
    pub frame: u32,
    /// Capture time of the frame, microseconds (the sender's clock).
    pub timestamp_us: u64,
    /// This part's index, `0..parts`.
    pub part: u16,
    /// Number of parts of this frame, at least 1.
    pub parts: u16,
    /// This part's tracks.
    pub tracks: Vec<Track, TRACKS_PER_MESSAGE>,
}

impl FrameTracks {
    /// True when the part numbering is possible: `1 <= parts <= MAX_FRAME_PARTS` and
    /// `part < parts`. Receivers check it before using `part` to index anything.
    #[must_use]
    pub fn is_well_formed(&self) -> bool {
        self.part < self.parts && usize::from(self.parts) <= super::MAX_FRAME_PARTS
    }
}

/// Which information an estimate uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub enum EstimateKind {
    /// Uses only frames up to its own: what an online system knows at that frame. Only causal
    /// estimates may feed a forecast's history.
    Causal,
    /// Has seen later frames (fixed-lag or RTS smoothing): fit for training targets, never
    /// for forecast inputs.
    Smoothed,
}

/// A camera pose in the world frame: a camera point `p` is at `R(rotation) p + translation`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct CameraPose {
    /// Camera centre in the world frame, metres.
    pub translation: [f32; 3],
    /// Camera-to-world rotation as a unit quaternion `[x, y, z, w]`.
    pub rotation: [f32; 4],
}

impl CameraPose {
    /// The camera at the world origin, unrotated.
    pub const IDENTITY: Self = Self { translation: [0.0; 3], rotation: [0.0, 0.0, 0.0, 1.0] };
}

/// One object's estimated state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct ObjectState {
    /// Object id (never [`STATIC_OBJECT_ID`]).
    pub object_id: u16,
    /// Object class.
    pub class: ObjectClass,
    /// Bird's-eye position, heading and speed in the world frame.
    pub state: BevState,
    /// Heading rate, rad/s, counter-clockwise seen from above.
    pub heading_rate: f32,
    /// Whether `state.heading` comes from the object's motion. False while the object has not
    /// moved far enough to tell (the heading is then the world x axis, a placeholder): a
    /// receiver must not start a forecast history from such a state.
    pub heading_known: bool,
}

/// The estimated camera pose and object states at one frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct ObjectStates {
    /// Camera frame index.
    pub frame: u32,
    /// Capture time of the frame, microseconds (copied from its [`FrameTracks`]).
    pub timestamp_us: u64,
    /// Whether these estimates saw later frames.
    pub kind: EstimateKind,
    /// Camera pose at the frame.
    pub camera: CameraPose,
    /// The objects tracked at the frame.
    pub objects: Vec<ObjectState, MAX_OBJECTS>,
}

/// One object's forecast from one frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct Prediction {
    /// The frame the forecast starts from (its last history frame).
    pub frame: u32,
    /// The forecast object.
    pub object_id: u16,
    /// Time between consecutive points, seconds.
    pub dt: f32,
    /// Predicted bird's-eye positions in the world frame: `points[k]` is `(k + 1) * dt`
    /// seconds after `frame`.
    pub points: Vec<Point2, HORIZON>,
}

/// One piece of a model blob: the edge writes `data` at `offset` and accepts the blob once
/// `blob_len` bytes with CRC-32/ISO-HDLC `blob_crc` ([`super::crc32`]) have arrived.
/// [`super::model_chunks`] makes the pieces.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct ModelChunk {
    /// Length of the whole blob, bytes.
    pub blob_len: u32,
    /// CRC-32/ISO-HDLC of the whole blob: identifies the blob and checks the reassembly.
    pub blob_crc: u32,
    /// Position of `data` in the blob, bytes.
    pub offset: u32,
    /// The bytes at `offset..offset + data.len()`.
    pub data: Vec<u8, MODEL_CHUNK_LEN>,
}

impl ModelChunk {
    /// True when `data` lies inside the blob; receivers check it before writing.
    #[must_use]
    pub fn is_within_blob(&self) -> bool {
        u32::try_from(self.data.len())
            .ok()
            .and_then(|len| self.offset.checked_add(len))
            .is_some_and(|end| end <= self.blob_len)
    }
}

/// A node's link health: what its frame decoder counted, and how many frames it sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, MaxSize)]
pub struct LinkStats {
    /// Frames the sender has encoded and sent.
    pub frames_sent: u32,
    /// The sender's receive-side counters.
    pub received: DecoderStats,
}

/// The unit of [`FrameStats::compute`]: each edge build measures with the clock it has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub enum ComputeUnit {
    /// Wall-clock nanoseconds (host builds).
    Nanoseconds,
    /// Instructions retired (the MCU build under QEMU `-icount`, or a cycle counter).
    Instructions,
}

/// What the edge did with one camera frame: sent after the frame's [`ObjectStates`] and
/// [`Prediction`]s, so the host learns losses and compute per frame. Counters marked
/// cumulative count since the edge started and saturate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct FrameStats {
    /// Camera frame index.
    pub frame: u32,
    /// Cumulative: camera frames the edge never estimated (parts lost on the link, or frame
    /// numbers skipped).
    pub frames_lost: u32,
    /// Objects estimated at this frame.
    pub objects: u16,
    /// Forecasts sent for this frame.
    pub predictions: u16,
    /// Cumulative: objects lost for capacity (runs evicted from the estimator's object table)
    /// or whose forecast failed.
    pub objects_dropped: u32,
    /// Cumulative: feature tracks dropped for capacity (static, per-object and object limits).
    pub tracks_dropped: u32,
    /// Cumulative: bytes the edge's receiver dropped (bad frames, and receive-buffer overruns).
    pub bytes_dropped: u32,
    /// Compute spent on this frame (estimation, forecasts, encoding), in `unit`.
    pub compute: u32,
    /// The unit of `compute`.
    pub unit: ComputeUnit,
}
