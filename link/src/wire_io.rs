//! Messages to wire frames on a writer, and a link's bytes back to messages: one encoder and
//! one decoder loop for every client of the link.

use std::io::Write;
use std::time::Instant;

use anyhow::Context as _;
use dynotraj_core::wire::{DecoderStats, FrameBuf, FrameDecoder, MAX_FRAME_LEN, Message, encode};

use crate::endpoint::{LinkReader, read_some};

/// Encodes messages and writes each wire frame with one `write_all`, so that a writer that
/// acts per write (a [`crate::fault::FaultInjector`]) sees whole frames.
pub struct WireSender<W: Write> {
    writer: W,
    buf: FrameBuf,
    sent: u64,
}

impl<W: Write> WireSender<W> {
    /// A sender over `writer`.
    pub const fn new(writer: W) -> Self {
        Self { writer, buf: [0; MAX_FRAME_LEN], sent: 0 }
    }

    /// Encodes and writes `msg` (not flushed: see [`Self::flush`]).
    ///
    /// # Errors
    /// A message too large for a frame, or a failed write.
    pub fn send(&mut self, msg: &Message) -> anyhow::Result<()> {
        let n = encode(msg, &mut self.buf).context("encoding a frame")?;
        self.writer.write_all(self.buf.get(..n).unwrap_or_default()).context("writing to the link")?;
        self.sent += 1;
        Ok(())
    }

    /// Flushes the writer.
    ///
    /// # Errors
    /// A failed write.
    pub fn flush(&mut self) -> anyhow::Result<()> {
        self.writer.flush().context("writing to the link")
    }

    /// Wire frames sent so far.
    #[must_use]
    pub const fn sent(&self) -> u64 {
        self.sent
    }

    /// The writer, for what it counted.
    pub const fn writer(&self) -> &W {
        &self.writer
    }

    /// The writer, with everything sent.
    pub fn into_writer(self) -> W {
        self.writer
    }

    /// The writer, to set it up between messages.
    pub const fn writer_mut(&mut self) -> &mut W {
        &mut self.writer
    }
}

/// What [`read_link`] hands its caller.
pub enum LinkEvent<'a> {
    /// Bytes as they arrived, before decoding.
    Bytes(Instant, &'a [u8]),
    /// A message decoded from them (boxed: a message is large beside a slice).
    Message(Instant, Box<Message>),
}

/// Reads and decodes the link until it closes, the edge says goodbye (its `LinkStats`), or
/// `on` returns false; returns what the decoder rejected.
pub fn read_link(mut rx: LinkReader, mut on: impl FnMut(LinkEvent<'_>) -> bool) -> DecoderStats {
    let mut decoder = FrameDecoder::new();
    let mut buf = [0u8; 4096];
    while let Some(n) = read_some(&mut rx, &mut buf) {
        let at = Instant::now();
        let chunk = buf.get(..n).unwrap_or_default();
        if !on(LinkEvent::Bytes(at, chunk)) {
            return decoder.stats();
        }
        let mut goodbye = false;
        for msg in decoder.feed(chunk) {
            goodbye |= matches!(msg, Message::LinkStats(_));
            if !on(LinkEvent::Message(at, Box::new(msg))) {
                return decoder.stats();
            }
        }
        if goodbye {
            break;
        }
    }
    decoder.stats()
}
