//! The link layer of the edge: frame decoding and the bookkeeping of frame parts.

use dynotraj_core::wire::{DecoderStats, FrameDecoder, Message};

/// What the link has seen, beyond the decoder's own counters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LoopStats {
    /// Camera frames whose every part arrived.
    pub frames_complete: u32,
    /// Camera frames abandoned with parts missing (a newer frame started first).
    pub frames_incomplete: u32,
    /// Messages other than frame parts (handed on, not counted as frames).
    pub messages_other: u32,
}

/// Decodes the received byte stream and keeps the frame-part bookkeeping.
#[derive(Debug, Clone, Default)]
pub struct EdgeLoop {
    decoder: FrameDecoder,
    stats: LoopStats,
    /// Frame, parts received, parts expected of the frame being received.
    current: Option<(u32, u16, u16)>,
}

impl EdgeLoop {
    /// A fresh link.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Feeds received bytes through the decoder and counts frames.
    pub fn on_bytes(&mut self, chunk: &[u8]) {
        self.on_bytes_with(chunk, |_| true);
    }

    /// Feeds received bytes through the decoder, counts frames and hands each whole message
    /// to `f`, which returns whether to go on; the rest of `chunk` is dropped when it says no.
    pub fn on_bytes_with(&mut self, chunk: &[u8], mut f: impl FnMut(Message) -> bool) {
        let Self { decoder, stats, current } = self;
        for msg in decoder.feed(chunk) {
            if let Message::FrameTracks(ft) = &msg {
                *current = match *current {
                    Some((frame, got, parts)) if frame == ft.frame => Some((frame, got.saturating_add(1), parts)),
                    other => {
                        if let Some((_, got, parts)) = other
                            && got < parts
                        {
                            stats.frames_incomplete += 1;
                        }
                        Some((ft.frame, 1, ft.parts))
                    }
                };
                if let Some((_, got, parts)) = *current
                    && got == parts
                {
                    stats.frames_complete += 1;
                }
            } else {
                stats.messages_other += 1;
            }
            if !f(msg) {
                break;
            }
        }
    }

    /// The link's counters.
    #[must_use]
    pub const fn stats(&self) -> LoopStats {
        self.stats
    }

    /// The decoder's counters.
    #[must_use]
    pub const fn decoder_stats(&self) -> DecoderStats {
        self.decoder.stats()
    }

    /// The peer closed the stream: an unfinished frame's bytes are counted as dropped.
    pub fn end_of_stream(&mut self) {
        self.decoder.finish();
    }
}
