//! dynotraj-edge: the firmware loop that runs the core on a stream of wire frames.
//!
//! `no_std` and allocation-free so that the same loop runs as a host process and as Cortex-M
//! firmware. This first version decodes frames, tracks the frame-parts bookkeeping and answers
//! with link statistics; the estimator and the predictor plug in here as they land.
#![no_std]

use dynotraj_core::wire::{encode, FrameBuf, FrameDecoder, LinkStats, Message, WireError};

/// Where the loop's bytes come from and go to (UART on the MCU; TCP or stdio on the host).
pub trait Transport {
    /// The transport's error.
    type Error;
    /// Reads available bytes into `buf`; `Ok(0)` means the stream ended.
    ///
    /// # Errors
    /// A transport failure.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error>;
    /// Writes all of `bytes`.
    ///
    /// # Errors
    /// A transport failure.
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), Self::Error>;
}

/// What the loop has seen, beyond the decoder's own counters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LoopStats {
    /// Camera frames whose every part arrived.
    pub frames_complete: u32,
    /// Camera frames abandoned with parts missing (a newer frame started first).
    pub frames_incomplete: u32,
    /// Messages that the loop does not consume (sent the wrong way).
    pub messages_ignored: u32,
}

/// The firmware loop's state.
#[derive(Debug, Clone, Default)]
pub struct EdgeLoop {
    decoder: FrameDecoder,
    stats: LoopStats,
    current: Option<(u32, u16, u16)>,
    frames_sent: u32,
}

impl EdgeLoop {
    /// A fresh loop.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Feeds received bytes through the decoder and handles each whole message.
    pub fn on_bytes(&mut self, chunk: &[u8]) {
        let mut feed = self.decoder.feed(chunk);
        let mut handled = LoopStats::default();
        let mut current = self.current;
        for msg in feed.by_ref() {
            match msg {
                Message::FrameTracks(ft) => {
                    current = match current {
                        Some((frame, got, parts)) if frame == ft.frame => Some((frame, got.saturating_add(1), parts)),
                        other => {
                            if let Some((_, got, parts)) = other
                                && got < parts
                            {
                                handled.frames_incomplete += 1;
                            }
                            Some((ft.frame, 1, ft.parts))
                        }
                    };
                    if let Some((_, got, parts)) = current
                        && got == parts
                    {
                        handled.frames_complete += 1;
                    }
                }
                _ => handled.messages_ignored += 1,
            }
        }
        self.current = current;
        self.stats.frames_complete += handled.frames_complete;
        self.stats.frames_incomplete += handled.frames_incomplete;
        self.stats.messages_ignored += handled.messages_ignored;
    }

    /// The loop's counters.
    #[must_use]
    pub const fn stats(&self) -> LoopStats {
        self.stats
    }

    /// The link statistics message for the peer.
    #[must_use]
    pub const fn link_stats(&self) -> LinkStats {
        LinkStats { frames_sent: self.frames_sent, received: self.decoder.stats() }
    }

    /// Runs until the transport's stream ends, then reports link statistics to the peer.
    ///
    /// # Errors
    /// A transport failure, or a message that cannot be encoded.
    pub fn run<T: Transport>(&mut self, io: &mut T) -> Result<(), RunError<T::Error>> {
        let mut buf = [0u8; 256];
        loop {
            let n = io.read(&mut buf).map_err(RunError::Transport)?;
            let Some(chunk) = buf.get(..n) else { break };
            if chunk.is_empty() {
                break;
            }
            self.on_bytes(chunk);
        }
        self.send(io, &Message::LinkStats(self.link_stats()))
    }

    fn send<T: Transport>(&mut self, io: &mut T, msg: &Message) -> Result<(), RunError<T::Error>> {
        let mut frame: FrameBuf = [0; dynotraj_core::wire::MAX_FRAME_LEN];
        let n = encode(msg, &mut frame).map_err(RunError::Wire)?;
        io.write_all(frame.get(..n).unwrap_or(&[])).map_err(RunError::Transport)?;
        self.frames_sent = self.frames_sent.saturating_add(1);
        Ok(())
    }
}

/// Why [`EdgeLoop::run`] stopped.
#[derive(Debug)]
pub enum RunError<E> {
    /// The transport failed.
    Transport(E),
    /// A message could not be encoded.
    Wire(WireError),
}
