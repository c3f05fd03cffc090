//! The link layer of the edge: frame decoding. A camera frame's parts are assembled once, by
//! the core estimator's [`dynotraj_core::estimate::FrameAssembler`], which also counts the frames
//! that arrived whole and those abandoned with parts missing.

use dynotraj_core::wire::{DecoderStats, FrameDecoder, Message};

/// Decodes the received byte stream.
#[derive(Debug, Clone)]
pub struct LinkDecoder {
    decoder: FrameDecoder,
}

impl Default for LinkDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl LinkDecoder {
    /// A fresh link.
    #[must_use]
    pub const fn new() -> Self {
        Self { decoder: FrameDecoder::new() }
    }

    /// Feeds received bytes through the decoder and hands each whole message to `f`, which
    /// returns whether to go on; the rest of `chunk` is dropped when it says no.
    pub fn on_bytes_with(&mut self, chunk: &[u8], mut f: impl FnMut(&Message) -> bool) {
        // Borrowed where the decoder put it, in a binding made afresh each time: moving it out
        // of the `Option` (as `for` does), or assigning over an old one, puts a second copy of
        // the 1.3 KiB message on the MCU's stack.
        let mut feed = self.decoder.feed(chunk);
        loop {
            let next = feed.next();
            let Some(msg) = &next else { break };
            if !f(msg) {
                break;
            }
        }
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
