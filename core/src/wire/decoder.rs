//! Streaming frame decoder: reassembles frames from arbitrary chunks of a byte stream.

use super::frame::MAX_ENCODED_LEN;
use super::{DELIMITER, DecoderStats, Message, decode};

/// Reassembles frames from a byte stream cut into arbitrary chunks, and decodes them.
///
/// A state machine with one fixed buffer and no clock (as postcard's `CobsAccumulator`, plus
/// counters). Bytes accumulate until a delimiter; the frame is then decoded with
/// [`super::decode`]. A frame that fails any check is dropped and counted, and decoding
/// resumes at the next delimiter, so corruption costs only the frames it touches. A frame
/// with no delimiter within [`super::MAX_FRAME_LEN`] bytes is discarded up to the next
/// delimiter and counted as an overflow. Empty frames (consecutive delimiters) are sync bytes
/// and are ignored without counting; a transmitter sends one after a restart to flush a
/// receiver's half-received frame.
#[derive(Debug, Clone)]
pub struct FrameDecoder {
    /// The current frame's COBS bytes, delimiter excluded.
    buf: [u8; MAX_ENCODED_LEN],
    /// Bytes of `buf` in use.
    len: usize,
    /// True while discarding an overlong frame up to its delimiter.
    overflowed: bool,
    /// What happened so far.
    stats: DecoderStats,
}

impl Default for FrameDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameDecoder {
    /// A decoder waiting for the start of a frame.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_ENCODED_LEN],
            len: 0,
            overflowed: false,
            stats: DecoderStats {
                frames_ok: 0,
                crc_errors: 0,
                cobs_errors: 0,
                version_errors: 0,
                decode_errors: 0,
                overflows: 0,
                bytes_discarded: 0,
            },
        }
    }

    /// Feeds `chunk` and returns an iterator over the messages it completes:
    /// `for msg in decoder.feed(chunk) { ... }`.
    ///
    /// Input is consumed only as the iterator advances; a caller that stops early finds the
    /// unread bytes in [`Feed::remaining`].
    pub fn feed<'d, 'a>(&'d mut self, chunk: &'a [u8]) -> Feed<'d, 'a> {
        Feed { decoder: self, rest: chunk }
    }

    /// The counters so far.
    #[must_use]
    pub const fn stats(&self) -> DecoderStats {
        self.stats
    }

    /// Bytes of an unfinished frame held in the buffer (not yet counted anywhere).
    #[must_use]
    pub const fn pending_len(&self) -> usize {
        self.len
    }

    /// Ends the stream (the peer closed it): the bytes of an unfinished frame can no longer
    /// complete, so they are counted as discarded, and the decoder waits for a new frame.
    pub fn finish(&mut self) {
        if !self.overflowed {
            self.stats.count_discarded(self.len);
        }
        self.len = 0;
        self.overflowed = false;
    }

    /// Appends delimiter-free `data` to the current frame, or discards it past the buffer.
    fn extend(&mut self, data: &[u8]) {
        if self.overflowed {
            self.stats.count_discarded(data.len());
            return;
        }
        let end = self.len.saturating_add(data.len());
        if let Some(dst) = self.buf.get_mut(self.len..end) {
            dst.copy_from_slice(data);
            self.len = end;
        } else {
            self.stats.count_overflow();
            self.stats.count_discarded(end);
            self.len = 0;
            self.overflowed = true;
        }
    }

    /// Ends the current frame at a delimiter; returns its message if it is valid. Never
    /// inlined: the deserializer's temporaries (several messages' worth) are on the stack only
    /// while a frame is decoded, not while the caller handles the message.
    #[inline(never)]
    fn end_frame(&mut self) -> Option<Message> {
        let len = core::mem::take(&mut self.len);
        if core::mem::take(&mut self.overflowed) {
            self.stats.count_discarded(1);
            return None;
        }
        if len == 0 {
            return None;
        }
        let result = decode(self.buf.get_mut(..len)?);
        match result {
            Ok(msg) => {
                self.stats.count_ok();
                Some(msg)
            }
            Err(err) => {
                log::debug!("wire: dropped a {len}-byte frame: {err}");
                self.stats.count_error(err);
                self.stats.count_discarded(len + 1);
                None
            }
        }
    }
}

/// The messages completed by one chunk of input; see [`FrameDecoder::feed`].
#[derive(Debug)]
pub struct Feed<'d, 'a> {
    /// The decoder being fed.
    decoder: &'d mut FrameDecoder,
    /// Input not consumed yet.
    rest: &'a [u8],
}

impl<'a> Feed<'_, 'a> {
    /// Input not consumed yet: empty once the iterator has returned `None`.
    #[must_use]
    pub const fn remaining(&self) -> &'a [u8] {
        self.rest
    }
}

impl Iterator for Feed<'_, '_> {
    type Item = Message;

    fn next(&mut self) -> Option<Message> {
        loop {
            let Some(at) = self.rest.iter().position(|&b| b == DELIMITER) else {
                self.decoder.extend(self.rest);
                self.rest = &[];
                return None;
            };
            let (data, tail) = self.rest.split_at_checked(at)?;
            self.decoder.extend(data);
            self.rest = tail.get(1..).unwrap_or_default();
            if let Some(msg) = self.decoder.end_frame() {
                return Some(msg);
            }
        }
    }
}
