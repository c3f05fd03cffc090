//! A soak run: a long stream of camera frames into an edge over a link that corrupts, drops
//! and duplicates bytes at random, with everything counted so the totals can be checked.
//!
//! The frames of a base recording are sent again and again, renumbered so that frame numbers
//! keep rising (the estimator sees the scene jump back at each loop and re-initialises its
//! objects, a documented outcome). Each wire frame is damaged with a given probability: one
//! byte flipped, a tail of it dropped, or the whole frame sent twice. A camera frame with a
//! damaged part is "damaged"; every other one is "clean" and must be answered. The host keeps
//! only counters (no replies), so a run of any length uses fixed host memory; the edge's
//! resident memory is read from /proc at the start and the end when its process id is known.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use dynotraj_core::wire::{DecoderStats, LinkStats, Message};
use dynotraj_formats::tracks_file::Tracks;

use crate::OnFrame;
use crate::endpoint::{LinkReader, LinkWriter};
use crate::fault::FaultInjector;
use crate::wire_io::{LinkEvent, WireSender, read_link};

/// How to soak.
#[derive(Debug, Clone)]
pub struct SoakOptions {
    /// Camera frames to send.
    pub frames: u64,
    /// Probability that a wire frame is damaged.
    pub fault_probability: f64,
    /// Seed of the faults.
    pub seed: u64,
    /// How long to wait for the edge's goodbye at the end.
    pub reply_timeout: Duration,
    /// Send at most this many camera frames ahead of the last one answered (the edge then
    /// works through a bounded backlog instead of the operating system's socket buffers).
    pub max_in_flight: u64,
    /// Told the number of camera frames sent, after each.
    pub on_frame: Option<OnFrame>,
    /// Set (by a signal handler) to stop sending: the soak then ends as if `frames` were
    /// reached, says goodbye and counts what it sent.
    pub stop: Option<Arc<AtomicBool>>,
}

impl Default for SoakOptions {
    fn default() -> Self {
        Self {
            frames: 100_000,
            fault_probability: 0.01,
            seed: 1,
            reply_timeout: Duration::from_secs(30),
            max_in_flight: 8,
            on_frame: None,
            stop: None,
        }
    }
}

/// Resident memory of a process, KiB.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Memory {
    /// `VmRSS`.
    pub rss_kib: u64,
    /// `VmHWM` (peak resident).
    pub peak_kib: u64,
}

/// Reads `VmRSS` and `VmHWM` of process `pid` (Linux), if it can.
#[must_use]
pub fn memory_of(pid: u32) -> Option<Memory> {
    let text = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let field = |name: &str| text.lines().find(|l| l.starts_with(name))?.split_whitespace().nth(1)?.parse().ok();
    Some(Memory { rss_kib: field("VmRSS:")?, peak_kib: field("VmHWM:")? })
}

/// What a soak did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SoakReport {
    /// Camera frames sent.
    pub frames_sent: u64,
    /// Wire frames sent (parts, camera model, goodbye).
    pub wire_frames_sent: u64,
    /// Faults injected: flipped bytes, dropped tails, duplicated frames.
    pub faults: [u64; 3],
    /// Camera frames with at least one damaged part.
    pub damaged_frames: u64,
    /// Camera frames the edge answered (a `FrameStats`).
    pub answered: u64,
    /// Clean camera frames the edge did not answer (must be 0).
    pub clean_unanswered: u64,
    /// The edge's own count of frames lost, at its last answer.
    pub edge_frames_lost: u32,
    /// The edge's goodbye (what its decoder accepted and rejected), if it came.
    pub edge_link: Option<LinkStats>,
    /// What the host's decoder rejected of the edge's bytes.
    pub host_received: DecoderStats,
    /// Edge memory after the first frames and at the end.
    pub edge_memory: Option<(Memory, Memory)>,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Whether [`SoakOptions::stop`] ended it before `frames`.
    pub interrupted: bool,
}

impl SoakReport {
    /// Faults injected in all.
    #[must_use]
    pub fn faults_injected(&self) -> u64 {
        self.faults.iter().sum()
    }
}

/// What the reader thread saw.
#[derive(Debug, Default)]
struct Seen {
    answered: Vec<u32>,
    frames_lost: u32,
    goodbye: Option<LinkStats>,
    received: DecoderStats,
}

fn read_answers(rx: LinkReader, last_answered: &AtomicU64, out: &mpsc::Sender<Seen>) {
    let mut seen = Seen::default();
    seen.received = read_link(rx, |event| {
        let LinkEvent::Message(_, msg) = event else { return true };
        match *msg {
            Message::FrameStats(s) => {
                seen.answered.push(s.frame);
                seen.frames_lost = s.frames_lost;
                last_answered.store(u64::from(s.frame) + 1, Ordering::Release);
            }
            Message::LinkStats(l) => seen.goodbye = Some(l),
            _ => {}
        }
        true
    });
    let _ = out.send(seen);
}

/// Streams `opt.frames` camera frames of `base` (looped and renumbered) over the link with
/// random faults; `edge_pid` is the edge's process for its memory figures.
///
/// # Errors
/// The base has no frames, or a write to the link fails.
pub fn soak(
    base: &Tracks,
    rx: LinkReader,
    tx: LinkWriter,
    opt: &SoakOptions,
    edge_pid: Option<u32>,
) -> anyhow::Result<SoakReport> {
    anyhow::ensure!(!base.frames.is_empty(), "the base recording has no frames");
    let start = Instant::now();
    let last_answered = Arc::new(AtomicU64::new(0));
    let (seen_tx, seen_rx) = mpsc::channel();
    let reader_mark = Arc::clone(&last_answered);
    // Detached: it ends with the edge's goodbye or the link's close.
    std::thread::spawn(move || read_answers(rx, &reader_mark, &seen_tx));
    let mut report = SoakReport::default();
    let mut damaged = vec![false; usize::try_from(opt.frames).context("--frames")?];
    let mut sender = WireSender::new(FaultInjector::new(tx, opt.fault_probability, opt.seed));
    sender.writer_mut().arm(false);
    sender.send(&Message::CameraInfo(base.camera))?;
    sender.writer_mut().arm(true);
    let period_us = base
        .frames
        .get(1)
        .zip(base.frames.first())
        .map_or(50_000, |(b, a)| b.timestamp_us.saturating_sub(a.timestamp_us).max(1));
    let mut edge_start = None;
    for k in 0..opt.frames {
        if opt.stop.as_ref().is_some_and(|s| s.load(Ordering::Relaxed)) {
            report.interrupted = true;
            break;
        }
        // Bounded backlog: wait (with a deadline, since a damaged frame is never answered)
        // until the edge has answered a frame close enough behind this one.
        let deadline = Instant::now() + Duration::from_millis(500);
        while k > last_answered.load(Ordering::Acquire) + opt.max_in_flight && Instant::now() < deadline {
            std::thread::sleep(Duration::from_micros(200));
        }
        let Some(f) = usize::try_from(k).ok().and_then(|i| base.frames.get(i % base.frames.len())) else { break };
        let frame = u32::try_from(k).context("frame number")?;
        let sent = f
            .parts
            .iter()
            .try_for_each(|part| {
                let mut p = part.clone();
                p.frame = frame;
                p.timestamp_us = k * period_us;
                sender.send(&Message::FrameTracks(p))
            })
            .and_then(|()| sender.flush());
        if let Err(e) = sent {
            // A signal that stops this soak may have stopped the edge first.
            if opt.stop.as_ref().is_some_and(|s| s.load(Ordering::Relaxed)) {
                report.interrupted = true;
                break;
            }
            return Err(e);
        }
        if let Some(d) = usize::try_from(k).ok().and_then(|i| damaged.get_mut(i)) {
            *d = sender.writer_mut().take_damaged();
        }
        report.frames_sent += 1;
        if let Some(hook) = &opt.on_frame {
            (hook.0)(report.frames_sent);
        }
        if k == 16 {
            edge_start = edge_pid.and_then(memory_of);
        }
    }
    let edge_end = edge_pid.and_then(memory_of);
    let goodbye = LinkStats {
        frames_sent: u32::try_from(sender.sent() + 1).unwrap_or(u32::MAX),
        received: DecoderStats::default(),
    };
    sender.writer_mut().arm(false);
    let said = sender.send(&Message::LinkStats(goodbye)).and_then(|()| sender.flush());
    // Interrupted, the edge may have been stopped by the same signal: what was counted stands.
    if !report.interrupted {
        said?;
    }
    report.wire_frames_sent = sender.sent();
    report.faults = sender.writer().counts();
    let seen = seen_rx.recv_timeout(opt.reply_timeout).unwrap_or_default();
    damaged.truncate(usize::try_from(report.frames_sent).unwrap_or(usize::MAX));
    let mut answered = vec![false; damaged.len()];
    for &f in &seen.answered {
        if let Some(a) = answered.get_mut(f as usize) {
            *a = true;
        }
    }
    report.damaged_frames = damaged.iter().filter(|d| **d).count() as u64;
    report.answered = answered.iter().filter(|a| **a).count() as u64;
    report.clean_unanswered = damaged.iter().zip(&answered).filter(|(d, a)| !**d && !**a).count() as u64;
    report.edge_frames_lost = seen.frames_lost;
    report.edge_link = seen.goodbye;
    report.host_received = seen.received;
    report.edge_memory = edge_start.zip(edge_end);
    report.seconds = start.elapsed().as_secs_f64();
    Ok(report)
}
