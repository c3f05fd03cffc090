//! Edge -> host notices: what happened to the session that the host cannot see in the
//! per-frame messages (the model it sent refused, the link busy or idle).

use postcard::experimental::max_size::MaxSize;
use serde::{Deserialize, Serialize};

use crate::limits::KEY_ID_LEN;

/// Something about the session the host has to know, sent by the edge when it happens.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub enum Notice {
    /// How the edge forecasts from the next frame on: sent when a stream starts (its
    /// [`super::CameraInfo`]) and when a model sent over the link is taken.
    Forecasting(Forecaster),
    /// The model sent over the link was refused: forecasts go on as before (constant velocity
    /// when no model was in use). Sent once per refused load.
    ModelRefused(ModelRefusal),
    /// The edge is serving another host: this connection is closed without a session.
    Busy,
    /// Nothing arrived for `seconds`: the edge ends the session.
    IdleTimeout {
        /// The edge's idle limit, seconds.
        seconds: u32,
    },
}

/// What makes the edge's forecasts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub enum Forecaster {
    /// No learned model: constant velocity.
    ConstantVelocity,
    /// A learned model (linked in, or loaded over the link and checked).
    Model {
        /// Length of the model blob, bytes (without a signature trailer).
        len: u32,
    },
}

/// Why the edge refused a model sent over the link.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub enum ModelRefusal {
    /// This edge takes no model over the link (it was given one, or built without the
    /// loader), or the chunks came after the first camera frame.
    NotAccepted,
    /// The blob is longer than the edge's model buffer.
    TooLarge {
        /// The buffer's length, bytes.
        capacity: u32,
    },
    /// A chunk arrived out of order or outside the blob (a chunk was lost).
    OutOfOrder,
    /// Every byte arrived but the CRC does not match.
    Crc,
    /// No signature trailer (`dynotraj sign` makes one).
    Unsigned,
    /// Signed by another key than the one the edge was provisioned with.
    OtherKey {
        /// The key id in the trailer.
        found: [u8; KEY_ID_LEN],
        /// The key id of the edge's provisioned key.
        expected: [u8; KEY_ID_LEN],
    },
    /// The signature does not verify: the bytes were changed after signing (or the edge's
    /// provisioned key is not a valid key).
    BadSignature,
    /// Signed correctly, but not a model blob this edge can run (layout, widths or shapes).
    InvalidBlob,
}

impl core::fmt::Display for Forecaster {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::ConstantVelocity => f.write_str("constant velocity (no model)"),
            Self::Model { len } => write!(f, "a learned model of {len} B"),
        }
    }
}

impl core::fmt::Display for ModelRefusal {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NotAccepted => {
                f.write_str("this edge takes no model over the link now (it has its own, or the frames had begun)")
            }
            Self::TooLarge { capacity } => write!(f, "the model is larger than the edge's {capacity}-byte buffer"),
            Self::OutOfOrder => f.write_str("a model chunk was lost or came out of order"),
            Self::Crc => f.write_str("the model's bytes arrived damaged (CRC mismatch)"),
            Self::Unsigned => f.write_str("the model is not signed (sign it with `dynotraj sign`)"),
            Self::OtherKey { found, expected } => {
                f.write_str("the model is signed by key ")?;
                write_hex(f, found)?;
                f.write_str(", but the edge trusts key ")?;
                write_hex(f, expected)
            }
            Self::BadSignature => f.write_str("the model's signature does not verify (changed after signing)"),
            Self::InvalidBlob => f.write_str("the signed file is not a model blob this edge can run"),
        }
    }
}

impl core::fmt::Display for Notice {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Forecasting(by) => write!(f, "forecasting with {by}"),
            Self::ModelRefused(why) => write!(f, "model refused: {why}"),
            Self::Busy => f.write_str("the edge is serving another host"),
            Self::IdleTimeout { seconds } => write!(f, "nothing arrived for {seconds} s: the edge ended the session"),
        }
    }
}

/// `bytes` as lower-case hex digits.
fn write_hex(f: &mut core::fmt::Formatter<'_>, bytes: &[u8]) -> core::fmt::Result {
    bytes.iter().try_for_each(|b| write!(f, "{b:02x}"))
}
