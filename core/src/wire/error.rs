//! Errors of encoding, decoding and splitting.

use core::fmt;

/// Why a message could not be encoded, a frame decoded, or a payload split into messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WireError {
    /// The output buffer cannot hold the frame; [`super::MAX_FRAME_LEN`] always can.
    BufferTooSmall,
    /// postcard could not serialise the message. Messages within their capacities always
    /// serialise; this exists so that a broken invariant is an error rather than a panic.
    Encode,
    /// The frame is not valid COBS.
    Cobs,
    /// The CRC does not match, or the frame is too short to hold a version byte and a CRC.
    Crc,
    /// The frame is intact but speaks another protocol version.
    Version {
        /// The version byte received.
        found: u8,
    },
    /// The frame is intact and of our version, but its body is not a [`super::Message`]
    /// (or has bytes left over after one).
    Decode,
    /// More tracks than one frame may carry ([`super::MAX_FRAME_TRACKS`]).
    TooManyTracks,
    /// A model blob longer than a `u32` can describe.
    BlobTooLarge,
}

impl fmt::Display for WireError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::BufferTooSmall => f.write_str("output buffer too small for the frame"),
            Self::Encode => f.write_str("message could not be serialised"),
            Self::Cobs => f.write_str("frame is not valid COBS"),
            Self::Crc => f.write_str("frame CRC mismatch or frame too short"),
            Self::Version { found } => {
                write!(f, "protocol version {found}, expected {}", super::PROTOCOL_VERSION)
            }
            Self::Decode => f.write_str("frame body is not a valid message"),
            Self::TooManyTracks => f.write_str("too many tracks for one frame"),
            Self::BlobTooLarge => f.write_str("model blob longer than u32::MAX bytes"),
        }
    }
}

impl core::error::Error for WireError {}
