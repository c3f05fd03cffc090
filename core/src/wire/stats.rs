//! The frame decoder's counters.

use postcard::experimental::max_size::MaxSize;
use serde::{Deserialize, Serialize};

use super::WireError;

/// What a [`super::FrameDecoder`] has seen, so that nothing is lost silently. Counters saturate
/// instead of wrapping (a wrapped counter would read as a healthy link).
///
/// Every received byte is either part of an accepted frame (its bytes and delimiter), an
/// empty-frame sync `0x00`, counted in `bytes_discarded`, or still pending in the decoder.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, MaxSize)]
pub struct DecoderStats {
    /// Frames decoded and delivered.
    pub frames_ok: u32,
    /// Frames whose CRC did not match, or too short to hold a version byte and a CRC.
    pub crc_errors: u32,
    /// Frames that were not valid COBS.
    pub cobs_errors: u32,
    /// Frames with a good CRC but another protocol version.
    pub version_errors: u32,
    /// Frames with a good CRC and version whose body postcard could not decode.
    pub decode_errors: u32,
    /// Frames longer than [`super::MAX_FRAME_LEN`], discarded up to the next delimiter.
    pub overflows: u32,
    /// Bytes of all rejected frames, their delimiters included.
    pub bytes_discarded: u32,
}

impl DecoderStats {
    /// Frames rejected for any reason.
    #[must_use]
    pub const fn frames_rejected(&self) -> u32 {
        self.crc_errors
            .saturating_add(self.cobs_errors)
            .saturating_add(self.version_errors)
            .saturating_add(self.decode_errors)
            .saturating_add(self.overflows)
    }

    /// Counts one frame rejected with `err` (errors that are not about a received frame are
    /// not counted).
    pub(super) fn count_error(&mut self, err: WireError) {
        let counter = match err {
            WireError::Crc => &mut self.crc_errors,
            WireError::Cobs => &mut self.cobs_errors,
            WireError::Version { .. } => &mut self.version_errors,
            WireError::Decode => &mut self.decode_errors,
            WireError::BufferTooSmall | WireError::Encode | WireError::TooManyTracks | WireError::BlobTooLarge => {
                return;
            }
        };
        bump(counter, 1);
    }

    /// Counts one overflowing frame.
    pub(super) fn count_overflow(&mut self) {
        bump(&mut self.overflows, 1);
    }

    /// Counts `n` discarded bytes.
    pub(super) fn count_discarded(&mut self, n: usize) {
        bump(&mut self.bytes_discarded, n);
    }

    /// Counts one delivered frame.
    pub(super) fn count_ok(&mut self) {
        bump(&mut self.frames_ok, 1);
    }
}

/// Adds `n` to `counter`, saturating.
fn bump(counter: &mut u32, n: usize) {
    *counter = counter.saturating_add(u32::try_from(n).unwrap_or(u32::MAX));
}
