//! Streaming a tracks recording to an edge and collecting what it answers: the host side of
//! `dynotraj stream`, also used by the tests.
//!
//! The host sends the camera model, optionally a model blob in chunks, then each camera
//! frame's parts, paced at the frame rate (or in lockstep: the next frame only once the edge
//! has answered the last one), and finally its [`LinkStats`] as a goodbye. A reader thread
//! decodes the edge's replies as they arrive and timestamps them; a frame's latency is the
//! time from sending its last part to receiving its [`FrameStats`].

use std::io::Write;
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use anyhow::Context as _;
use dynotraj_core::wire::{
    DecoderStats, FrameBuf, FrameDecoder, FrameStats, LinkStats, MAX_FRAME_LEN, Message, encode, model_chunks,
};

use crate::link::{LinkReader, LinkWriter, read_some};
use crate::tracks_file::Tracks;

/// How to stream.
#[derive(Debug, Clone)]
pub struct StreamOptions {
    /// Frames per second to send at; `None` sends as fast as the link (and lockstep) allows.
    pub rate_hz: Option<f64>,
    /// Wait for each frame's answer before sending the next (a lossless comparison run).
    pub lockstep: bool,
    /// How long to wait for an answer in lockstep, and for the edge's goodbye at the end.
    pub reply_timeout: Duration,
    /// A model blob to send before the frames.
    pub model: Option<Vec<u8>>,
}

impl Default for StreamOptions {
    fn default() -> Self {
        Self { rate_hz: None, lockstep: false, reply_timeout: Duration::from_secs(10), model: None }
    }
}

/// One frame as the host saw it.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameReport {
    /// Camera frame index.
    pub frame: u32,
    /// When its last part was sent, since the stream started.
    pub sent: Duration,
    /// When its [`FrameStats`] arrived, since the stream started.
    pub answered: Option<Duration>,
    /// The edge's statistics of the frame.
    pub stats: Option<FrameStats>,
}

impl FrameReport {
    /// Time from the last part sent to the statistics received.
    #[must_use]
    pub fn latency(&self) -> Option<Duration> {
        self.answered.map(|a| a.saturating_sub(self.sent))
    }
}

/// What came back.
#[derive(Debug, Clone, Default)]
pub struct StreamResult {
    /// The edge's messages, in arrival order.
    pub replies: Vec<Message>,
    /// The edge's bytes as received.
    pub raw: Vec<u8>,
    /// One report per frame sent.
    pub frames: Vec<FrameReport>,
    /// The edge's closing statistics, if it said goodbye.
    pub edge_link: Option<LinkStats>,
    /// What the host's decoder rejected of the edge's bytes.
    pub received: DecoderStats,
    /// Frames (wire frames) the host sent.
    pub frames_sent: u32,
}

/// What the reader thread hands over.
enum Event {
    Message(Instant, Box<Message>),
    Bytes(Vec<u8>),
    Closed(DecoderStats),
}

/// Streams `tracks` over the link and collects the answers.
///
/// # Errors
/// A write to the link fails, or a frame cannot be encoded.
pub fn stream(
    tracks: &Tracks,
    rx: LinkReader,
    mut tx: LinkWriter,
    opt: &StreamOptions,
) -> anyhow::Result<StreamResult> {
    let (events_tx, events) = mpsc::channel();
    std::thread::spawn(move || read_replies(rx, &events_tx));
    let start = Instant::now();
    let mut out = StreamResult::default();
    let mut sender = Sender { tx: &mut tx, buf: [0; MAX_FRAME_LEN], sent: 0 };
    sender.send(&Message::CameraInfo(tracks.camera))?;
    if let Some(blob) = &opt.model {
        for chunk in model_chunks(blob).context("model blob")? {
            sender.send(&Message::ModelChunk(chunk))?;
        }
    }
    let mut closed = false;
    for (k, frame) in tracks.frames.iter().enumerate() {
        if let Some(rate) = opt.rate_hz.filter(|r| *r > 0.0) {
            let due = start + Duration::from_secs_f64(k as f64 / rate);
            std::thread::sleep(due.saturating_duration_since(Instant::now()));
        }
        for part in &frame.parts {
            sender.send(&Message::FrameTracks(part.clone()))?;
        }
        out.frames.push(FrameReport { frame: frame.frame, sent: start.elapsed(), answered: None, stats: None });
        if opt.lockstep {
            let deadline = Instant::now() + opt.reply_timeout;
            while !closed && !answered(&out, frame.frame) {
                closed |= !drain(&events, &mut out, start, Some(deadline));
                if Instant::now() >= deadline {
                    break;
                }
            }
        } else {
            closed |= !drain(&events, &mut out, start, None);
        }
    }
    sender.send(&Message::LinkStats(LinkStats { frames_sent: sender.sent + 1, received: DecoderStats::default() }))?;
    out.frames_sent = sender.sent;
    let deadline = Instant::now() + opt.reply_timeout;
    while !closed && out.edge_link.is_none() && Instant::now() < deadline {
        closed |= !drain(&events, &mut out, start, Some(deadline));
    }
    Ok(out)
}

fn answered(out: &StreamResult, frame: u32) -> bool {
    out.frames.iter().rev().find(|f| f.frame == frame).is_some_and(|f| f.stats.is_some())
}

/// Takes the reader's events: all pending ones, or (with a deadline) waits for at least one.
/// Returns false once the link closed.
fn drain(events: &Receiver<Event>, out: &mut StreamResult, start: Instant, deadline: Option<Instant>) -> bool {
    let mut first = deadline.map(|d| events.recv_timeout(d.saturating_duration_since(Instant::now())));
    loop {
        let ev = match first.take() {
            Some(Ok(ev)) => ev,
            Some(Err(RecvTimeoutError::Timeout)) => return true,
            Some(Err(RecvTimeoutError::Disconnected)) => return false,
            None => match events.try_recv() {
                Ok(ev) => ev,
                Err(mpsc::TryRecvError::Empty) => return true,
                Err(mpsc::TryRecvError::Disconnected) => return false,
            },
        };
        match ev {
            Event::Bytes(b) => out.raw.extend_from_slice(&b),
            Event::Closed(stats) => {
                out.received = stats;
                return false;
            }
            Event::Message(at, msg) => {
                let msg = *msg;
                match &msg {
                    Message::FrameStats(s) => {
                        if let Some(f) = out.frames.iter_mut().rev().find(|f| f.frame == s.frame) {
                            f.answered = Some(at.saturating_duration_since(start));
                            f.stats = Some(*s);
                        }
                    }
                    Message::LinkStats(l) => out.edge_link = Some(*l),
                    _ => {}
                }
                out.replies.push(msg);
            }
        }
    }
}

/// The reader thread: decodes the edge's bytes until the link closes.
fn read_replies(mut rx: LinkReader, events: &mpsc::Sender<Event>) {
    let mut decoder = FrameDecoder::new();
    let mut buf = [0u8; 4096];
    while let Some(n) = read_some(&mut rx, &mut buf) {
        let at = Instant::now();
        let chunk = &buf[..n];
        if events.send(Event::Bytes(chunk.to_vec())).is_err() {
            return;
        }
        let mut goodbye = false;
        for msg in decoder.feed(chunk) {
            goodbye |= matches!(msg, Message::LinkStats(_));
            if events.send(Event::Message(at, Box::new(msg))).is_err() {
                return;
            }
        }
        if goodbye {
            break;
        }
    }
    let _ = events.send(Event::Closed(decoder.stats()));
}

/// Encodes and writes frames, counting them.
struct Sender<'w> {
    tx: &'w mut LinkWriter,
    buf: FrameBuf,
    sent: u32,
}

impl Sender<'_> {
    fn send(&mut self, msg: &Message) -> anyhow::Result<()> {
        let n = encode(msg, &mut self.buf).context("encoding a frame")?;
        self.tx.write_all(&self.buf[..n]).context("writing to the link")?;
        self.tx.flush().context("writing to the link")?;
        self.sent += 1;
        Ok(())
    }
}
