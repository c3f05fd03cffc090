//! One frame: `0x00 COBS([version][postcard(Message)][CRC-32 LE]) 0x00`, encoded and decoded whole.

use crate::crc::{CRC32, crc32};
use postcard::experimental::max_size::MaxSize;
use postcard::ser_flavors::crc::CrcModifier;
use postcard::ser_flavors::{Cobs, Slice};

use super::{Message, PROTOCOL_VERSION, WireError};

/// Longest postcard encoding of a [`Message`], bytes.
pub const MAX_MESSAGE_LEN: usize = <Message as MaxSize>::POSTCARD_MAX_SIZE;
/// Longest frame payload before COBS: version byte, message, CRC-32.
pub const MAX_PAYLOAD_LEN: usize = VERSION_LEN + MAX_MESSAGE_LEN + CRC_LEN;
/// Longest COBS encoding of a payload (a frame without its delimiter): what a decoder buffers.
pub(super) const MAX_ENCODED_LEN: usize = cobs::max_encoding_length(MAX_PAYLOAD_LEN);
/// Longest frame on the wire, both delimiters included: a buffer of this size holds any frame.
pub const MAX_FRAME_LEN: usize = MAX_ENCODED_LEN + 2;
/// The byte that starts and ends every frame; COBS guarantees it occurs nowhere else.
pub const DELIMITER: u8 = 0x00;

/// A buffer that holds any encoded frame.
pub type FrameBuf = [u8; MAX_FRAME_LEN];

/// Length of the version byte.
const VERSION_LEN: usize = 1;
/// Length of the CRC-32 trailer.
const CRC_LEN: usize = 4;
/// Shortest valid payload: version and CRC around an (impossible) empty body.
const MIN_PAYLOAD_LEN: usize = VERSION_LEN + CRC_LEN;

/// Encodes `msg` as one complete frame, both delimiters included, into `out`, and returns the
/// frame's length. `out` of [`MAX_FRAME_LEN`] bytes (a [`FrameBuf`]) always suffices.
///
/// The leading delimiter costs one byte per frame and buys this: a corrupted delimiter, or
/// garbage before a frame, can only ever cost the frame it touches, never the next one.
///
/// # Errors
/// [`WireError::BufferTooSmall`] when `out` is too short for this frame.
pub fn encode(msg: &Message, out: &mut [u8]) -> Result<usize, WireError> {
    // postcard's flavors in a stack: the CRC sees the plain bytes and appends its trailer, COBS
    // stuffs everything into `out` as it comes. No payload buffer of its own (1.4 KiB of stack).
    let (lead, rest) = out.split_first_mut().ok_or(WireError::BufferTooSmall)?;
    *lead = DELIMITER;
    let cobs = Cobs::try_new(Slice::new(rest)).map_err(encode_error)?;
    let flavor = CrcModifier::new(cobs, CRC32.digest());
    let written = postcard::serialize_with_flavor(&(PROTOCOL_VERSION, msg), flavor).map_err(encode_error)?;
    Ok(written.len() + 1)
}

/// A postcard error while encoding: out of room in the caller's buffer, or a message postcard
/// cannot encode.
const fn encode_error(e: postcard::Error) -> WireError {
    match e {
        postcard::Error::SerializeBufferFull => WireError::BufferTooSmall,
        _ => WireError::Encode,
    }
}

/// Decodes one frame, in place: `frame` holds the COBS bytes of exactly one frame, with or
/// without its delimiters, and is overwritten by the payload. Checks, in order: COBS,
/// length, CRC (so a corrupted version byte is a CRC error), version, then the postcard body,
/// which must be exactly one [`Message`].
///
/// # Errors
/// [`WireError::Cobs`], [`WireError::Crc`], [`WireError::Version`] or [`WireError::Decode`],
/// after the first check that fails.
pub fn decode(frame: &mut [u8]) -> Result<Message, WireError> {
    let frame = match frame.split_first_mut() {
        Some((&mut DELIMITER, rest)) => rest,
        _ => frame,
    };
    let frame = match frame.split_last_mut() {
        Some((&mut DELIMITER, rest)) => rest,
        _ => frame,
    };
    // cobs stops at a zero; a zero inside means this is not one frame.
    if frame.contains(&DELIMITER) {
        return Err(WireError::Cobs);
    }
    let n = cobs::decode_in_place(frame).map_err(|_| WireError::Cobs)?;
    let payload = frame.get(..n).ok_or(WireError::Cobs)?;
    if payload.len() < MIN_PAYLOAD_LEN {
        return Err(WireError::Crc);
    }
    let (checked, crc) = payload.split_last_chunk::<CRC_LEN>().ok_or(WireError::Crc)?;
    if crc32(checked) != u32::from_le_bytes(*crc) {
        return Err(WireError::Crc);
    }
    let (&version, body) = checked.split_first().ok_or(WireError::Crc)?;
    if version != PROTOCOL_VERSION {
        return Err(WireError::Version { found: version });
    }
    match postcard::take_from_bytes::<Message>(body) {
        Ok((msg, [])) => Ok(msg),
        _ => Err(WireError::Decode),
    }
}
