//! The wire protocol: every message of the pipeline, and its framing. Host and edge share this
//! one definition and meet only here.
//!
//! # Messages
//!
//! A frame carries one [`Message`]: [`FrameTracks`] (host -> edge, a camera frame's feature
//! tracks in parts of [`TRACKS_PER_MESSAGE`], made by [`frame_parts`]), [`ObjectStates`] and
//! [`Prediction`] (edge -> host), [`ModelChunk`] (host -> edge, a model blob in pieces made
//! by [`model_chunks`]), [`CameraInfo`] (host -> edge, the camera model, first in every stream)
//! [`LinkStats`] (either way), [`FrameStats`] (edge -> host, per camera frame) and [`Notice`]
//! (edge -> host, an event of the session: the model it was sent refused, the link busy).
//!
//! # Framing
//!
//! ```text
//! payload = [PROTOCOL_VERSION: u8] [postcard(Message)] [CRC-32/ISO-HDLC: u32 LE]
//! frame   = 0x00 COBS(payload) 0x00
//! ```
//!
//! The CRC covers the version byte and the postcard bytes. COBS removes every zero from the
//! payload, so `0x00` only ever ends a frame and a receiver that joins mid-stream or meets
//! garbage resynchronises at the next `0x00`. Every frame starts with a `0x00` as well as
//! ending with one: at one byte per frame this bounds any corruption, even of a delimiter or
//! by garbage just before a frame, to the frame it touches. Receivers ignore empty frames
//! (consecutive `0x00`s), so a transmitter may also send a lone `0x00` when it (re)starts.
//!
//! All sizes are compile-time constants: a message is at most [`MAX_MESSAGE_LEN`] bytes of
//! postcard, a payload [`MAX_PAYLOAD_LEN`], and a frame on the wire [`MAX_FRAME_LEN`]
//! (a [`FrameBuf`]). [`encode`] writes one frame into a caller buffer; [`FrameDecoder`] turns
//! a byte stream in arbitrary chunks back into messages, counting every rejected frame and
//! byte in [`DecoderStats`]; [`decode`] decodes one already delimited frame (file replay).
//!
//! # Versioning
//!
//! [`PROTOCOL_VERSION`] changes with any change to the bytes of an existing message; receivers
//! reject (and count) frames of other versions instead of misreading them.

mod decoder;
mod error;
mod frame;
mod messages;
mod notice;
mod parts;
mod stats;
#[cfg(test)]
mod tests;

pub use crate::class::ObjectClass;
pub use crate::crc::crc32;
pub use decoder::{Feed, FrameDecoder};
pub use error::WireError;
pub use frame::{DELIMITER, FrameBuf, MAX_FRAME_LEN, MAX_MESSAGE_LEN, MAX_PAYLOAD_LEN, decode, encode};
pub use messages::{
    CameraInfo, CameraPose, ComputeUnit, EstimateKind, FrameStats, FrameTracks, LinkStats, MODEL_CHUNK_LEN, Message,
    ModelChunk, ObjectState, ObjectStates, Prediction, STATIC_OBJECT_ID, TRACKS_PER_MESSAGE, Track,
};
pub use notice::{Forecaster, ModelRefusal, Notice};
pub use parts::{FrameParts, MAX_FRAME_PARTS, MAX_FRAME_TRACKS, ModelChunks, frame_parts, model_chunks};
pub use stats::DecoderStats;

/// Version of the wire protocol, the first byte of every payload. History: 1 first release;
/// 2 added [`ObjectState::heading_known`]. [`Message::Notice`] was appended in 2 (existing
/// messages keep their bytes; an older receiver counts a notice as a decode error).
pub const PROTOCOL_VERSION: u8 = 2;
