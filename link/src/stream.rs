//! Streaming a tracks recording to an edge and collecting what it answers: the host side of
//! `dynotraj stream`, also used by the tests.
//!
//! The host sends the camera model, optionally a model blob in chunks, then each camera
//! frame's parts, paced at the frame rate (or in lockstep: the next frame only once the edge
//! has answered the last one), and finally its [`LinkStats`] as a goodbye. A reader thread
//! decodes the edge's replies as they arrive and timestamps them; a frame's latency is the
//! time from sending its last part to receiving its [`FrameStats`].

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use anyhow::Context as _;
use dynotraj_core::wire::{DecoderStats, Forecaster, FrameStats, LinkStats, Message, Notice, model_chunks};
use dynotraj_formats::tracks_file::Tracks;

use crate::OnFrame;
use crate::endpoint::{LinkReader, LinkWriter};
use crate::wire_io::{LinkEvent, WireSender, read_link};

/// The longest wait before [`StreamOptions::stop`] is looked at again.
const STOP_POLL: Duration = Duration::from_millis(100);

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
    /// Set (by a signal handler) to stop sending: the stream then ends as if the recording
    /// ended there, keeping what was received.
    pub stop: Option<Arc<AtomicBool>>,
    /// Told the number of camera frames sent, after each.
    pub on_frame: Option<OnFrame>,
}

impl Default for StreamOptions {
    fn default() -> Self {
        Self {
            rate_hz: None,
            lockstep: false,
            reply_timeout: Duration::from_secs(10),
            model: None,
            stop: None,
            on_frame: None,
        }
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
    /// What the edge said forecast the frame (its last [`Notice::Forecasting`] before the
    /// frame's statistics); `None` when it did not say.
    pub forecaster: Option<Forecaster>,
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
    /// The edge's notices, in arrival order.
    pub notices: Vec<Notice>,
    /// Whether the stream was stopped before the recording's end ([`StreamOptions::stop`]).
    pub interrupted: bool,
    /// Why sending stopped early, when a write to the link failed (the edge went away, or
    /// closed the link after saying it is busy); what was received until then is kept.
    pub link_error: Option<String>,
}

impl StreamResult {
    /// What the edge last said makes its forecasts.
    #[must_use]
    pub fn forecaster(&self) -> Option<Forecaster> {
        self.notices.iter().rev().find_map(|n| if let Notice::Forecasting(f) = n { Some(*f) } else { None })
    }

    /// Whether the edge said it is serving another host.
    #[must_use]
    pub fn busy(&self) -> bool {
        self.notices.contains(&Notice::Busy)
    }

    /// An error when the edge refused the model `model` the stream sent to edge `to` (its
    /// forecasts were then not the model's); otherwise a warning when the edge never said that
    /// it forecasts with it.
    ///
    /// # Errors
    /// The edge's refusal, with its reason.
    pub fn model_taken(&self, model: &std::path::Path, to: &impl std::fmt::Display) -> anyhow::Result<Option<String>> {
        let refusal = self.notices.iter().find_map(|n| if let Notice::ModelRefused(r) = n { Some(*r) } else { None });
        if let Some(why) = refusal {
            anyhow::bail!(
                "edge {to}: refused --model {}: {why}; its forecasts were not the model's ({})",
                model.display(),
                self.forecaster().map_or_else(|| "forecaster unknown".to_string(), |f| f.to_string())
            );
        }
        Ok((!matches!(self.forecaster(), Some(Forecaster::Model { .. })) && !self.frames.is_empty()).then(|| {
            format!(
                "warning: edge {to}: did not say that it forecasts with --model {} (an edge without session notices?)",
                model.display()
            )
        }))
    }

    /// An error when the edge `to` did not answer as the stream needs: no frame at all, or (in
    /// lockstep, where every frame waits for its answer) not every frame.
    ///
    /// # Errors
    /// Frames unanswered, counted.
    pub fn answered(&self, to: &impl std::fmt::Display, lockstep: bool, timeout_s: f64) -> anyhow::Result<()> {
        let sent = self.frames.len();
        let answered = self.frames.iter().filter(|f| f.stats.is_some()).count();
        anyhow::ensure!(
            sent == 0 || answered > 0,
            "edge {to}: {sent} frames sent and none answered within --timeout {timeout_s} s (is an edge serving that \
             link?)"
        );
        anyhow::ensure!(
            !lockstep || answered == sent,
            "edge {to}: {} of {sent} frames unanswered in lockstep (the edge stopped or stalled)",
            sent - answered
        );
        Ok(())
    }
}

/// What the reader thread hands over.
enum Event {
    Message(Instant, Box<Message>),
    Bytes(Vec<u8>),
    Closed(DecoderStats),
}

/// Streams `tracks` over the link and collects the answers. A write that fails (or a frame
/// that cannot be encoded) ends the sending and is kept in [`StreamResult::link_error`], with
/// everything received until then.
pub fn stream(tracks: &Tracks, rx: LinkReader, tx: LinkWriter, opt: &StreamOptions) -> StreamResult {
    let (events_tx, events) = mpsc::channel();
    std::thread::spawn(move || read_replies(rx, &events_tx));
    let mut run = Run { events, out: StreamResult::default(), start: Instant::now(), closed: false, opt };
    let mut sender = WireSender::new(tx);
    let sent = run.send_all(tracks, &mut sender).and_then(|()| {
        let frames_sent = u32::try_from(sender.sent() + 1).unwrap_or(u32::MAX);
        send_flushed(&mut sender, &Message::LinkStats(LinkStats { frames_sent, received: DecoderStats::default() }))
    });
    if let Err(e) = sent {
        run.out.link_error = Some(format!("{e:#}"));
    }
    run.out.frames_sent = u32::try_from(sender.sent()).unwrap_or(u32::MAX);
    // The edge's goodbye, or (after a failed write) its last words before the link closes.
    let deadline = Instant::now() + opt.reply_timeout;
    while !run.closed && run.out.edge_link.is_none() && Instant::now() < deadline && !run.stopped() {
        run.drain(Some(deadline));
    }
    run.out
}

/// One stream in progress: the reader's events and what came of them.
struct Run<'o> {
    events: Receiver<Event>,
    out: StreamResult,
    start: Instant,
    closed: bool,
    opt: &'o StreamOptions,
}

impl Run<'_> {
    fn stopped(&self) -> bool {
        self.opt.stop.as_ref().is_some_and(|s| s.load(Ordering::Relaxed))
    }

    fn drain(&mut self, deadline: Option<Instant>) {
        self.closed |= !drain(&self.events, &mut self.out, self.start, deadline);
    }

    /// Sends the camera model, the model blob and every frame (paced, or in lockstep), until
    /// the recording ends, the stop flag is set or the edge says it is busy.
    fn send_all(&mut self, tracks: &Tracks, sender: &mut WireSender<LinkWriter>) -> anyhow::Result<()> {
        send_flushed(sender, &Message::CameraInfo(tracks.camera))?;
        if let Some(blob) = &self.opt.model {
            for chunk in model_chunks(blob).context("model blob")? {
                send_flushed(sender, &Message::ModelChunk(chunk))?;
            }
        }
        for (k, frame) in tracks.frames.iter().enumerate() {
            if self.stopped() || (self.closed && self.out.busy()) {
                self.out.interrupted = self.stopped();
                return Ok(());
            }
            if let Some(rate) = self.opt.rate_hz.filter(|r| *r > 0.0) {
                let due = self.start + Duration::from_secs_f64(k as f64 / rate);
                while !self.stopped() && Instant::now() < due {
                    std::thread::sleep(due.saturating_duration_since(Instant::now()).min(STOP_POLL));
                }
            }
            for part in &frame.parts {
                send_flushed(sender, &Message::FrameTracks(part.clone()))?;
            }
            let sent = self.start.elapsed();
            if let Some(hook) = &self.opt.on_frame {
                (hook.0)(k as u64 + 1);
            }
            self.out.frames.push(FrameReport {
                frame: frame.frame,
                sent,
                answered: None,
                stats: None,
                forecaster: None,
            });
            if self.opt.lockstep {
                let deadline = Instant::now() + self.opt.reply_timeout;
                while !self.closed && !answered(&self.out, frame.frame) && !self.stopped() && Instant::now() < deadline
                {
                    self.drain(Some(deadline));
                }
            } else {
                self.drain(None);
            }
        }
        Ok(())
    }
}

fn answered(out: &StreamResult, frame: u32) -> bool {
    out.frames.iter().rev().find(|f| f.frame == frame).is_some_and(|f| f.stats.is_some())
}

/// Takes the reader's events: all pending ones, or (with a deadline) waits for one, until the
/// deadline and at most [`STOP_POLL`]. Returns false once the link closed.
fn drain(events: &Receiver<Event>, out: &mut StreamResult, start: Instant, deadline: Option<Instant>) -> bool {
    let mut first = deadline.map(|d| events.recv_timeout(d.saturating_duration_since(Instant::now()).min(STOP_POLL)));
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
                        let forecaster = out.forecaster();
                        if let Some(f) = out.frames.iter_mut().rev().find(|f| f.frame == s.frame) {
                            f.answered = Some(at.saturating_duration_since(start));
                            f.stats = Some(*s);
                            f.forecaster = forecaster;
                        }
                    }
                    Message::LinkStats(l) => out.edge_link = Some(*l),
                    Message::Notice(n) => out.notices.push(*n),
                    _ => {}
                }
                out.replies.push(msg);
            }
        }
    }
}

/// The reader thread: decodes the edge's bytes until the link closes.
fn read_replies(rx: LinkReader, events: &mpsc::Sender<Event>) {
    let stats = read_link(rx, |event| {
        let ev = match event {
            LinkEvent::Bytes(_, chunk) => Event::Bytes(chunk.to_vec()),
            LinkEvent::Message(at, msg) => Event::Message(at, msg),
        };
        events.send(ev).is_ok()
    });
    let _ = events.send(Event::Closed(stats));
}

/// Sends `msg` at once: a stream's latencies are measured from the write.
fn send_flushed(sender: &mut WireSender<LinkWriter>, msg: &Message) -> anyhow::Result<()> {
    sender.send(msg)?;
    sender.flush()
}
