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

use crate::on_step::{OnStep, step};
use std::io::Write;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use dynotraj_core::wire::{DecoderStats, FrameBuf, FrameDecoder, LinkStats, MAX_FRAME_LEN, Message, encode};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

use crate::link::{LinkReader, LinkWriter, read_some};
use dynotraj_formats::tracks_file::Tracks;

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
    pub on_frame: Option<OnStep>,
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

fn read_answers(mut rx: LinkReader, last_answered: &AtomicU64, out: &mpsc::Sender<Seen>) {
    let mut decoder = FrameDecoder::new();
    let mut seen = Seen::default();
    let mut buf = [0u8; 4096];
    while let Some(n) = read_some(&mut rx, &mut buf) {
        let mut bye = false;
        for msg in decoder.feed(buf.get(..n).unwrap_or_default()) {
            match msg {
                Message::FrameStats(s) => {
                    seen.answered.push(s.frame);
                    seen.frames_lost = s.frames_lost;
                    last_answered.store(u64::from(s.frame) + 1, Ordering::Release);
                }
                Message::LinkStats(l) => {
                    seen.goodbye = Some(l);
                    bye = true;
                }
                _ => {}
            }
        }
        if bye {
            break;
        }
    }
    seen.received = decoder.stats();
    let _ = out.send(seen);
}

/// Damages `bytes` (one encoded wire frame) in place or returns how to send it; the fault
/// index into [`SoakReport::faults`].
fn damage(bytes: &mut Vec<u8>, rng: &mut Xoshiro256PlusPlus) -> usize {
    if bytes.is_empty() {
        return 2;
    }
    match rng.random_range(0..3) {
        0 => {
            let at = rng.random_range(0..bytes.len());
            if let Some(b) = bytes.get_mut(at) {
                *b ^= rng.random_range(1..=255u8);
            }
            0
        }
        1 => {
            let keep = rng.random_range(0..bytes.len());
            bytes.truncate(keep);
            1
        }
        _ => {
            let copy = bytes.clone();
            bytes.extend_from_slice(&copy);
            2
        }
    }
}

/// Encodes wire frames and damages some on their way out.
struct FaultySender<'w> {
    tx: &'w mut LinkWriter,
    buf: FrameBuf,
    rng: Xoshiro256PlusPlus,
    probability: f64,
}

impl FaultySender<'_> {
    /// Sends `msg`, damaged with the probability when `faults`; returns whether it was.
    fn send(&mut self, msg: &Message, faults: bool, report: &mut SoakReport) -> anyhow::Result<bool> {
        let n = encode(msg, &mut self.buf).context("encoding a frame")?;
        let mut bytes = self.buf.get(..n).unwrap_or_default().to_vec();
        let hit = faults && self.rng.random_bool(self.probability);
        if hit {
            let kind = damage(&mut bytes, &mut self.rng);
            if let Some(c) = report.faults.get_mut(kind) {
                *c += 1;
            }
        }
        self.tx.write_all(&bytes).context("writing to the link")?;
        report.wire_frames_sent += 1;
        Ok(hit)
    }
}

/// Streams `opt.frames` camera frames of `base` (looped and renumbered) over the link with
/// random faults; `edge_pid` is the edge's process for its memory figures.
///
/// # Errors
/// The base has no frames, or a write to the link fails.
pub fn soak(
    base: &Tracks,
    rx: LinkReader,
    mut tx: LinkWriter,
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
    let mut sender = FaultySender {
        tx: &mut tx,
        buf: [0; MAX_FRAME_LEN],
        rng: Xoshiro256PlusPlus::seed_from_u64(opt.seed),
        probability: opt.fault_probability.clamp(0.0, 1.0),
    };
    sender.send(&Message::CameraInfo(base.camera), false, &mut report)?;
    let period_us = base
        .frames
        .get(1)
        .zip(base.frames.first())
        .map_or(50_000, |(b, a)| b.timestamp_us.saturating_sub(a.timestamp_us).max(1));
    let mut edge_start = None;
    for k in 0..opt.frames {
        // Bounded backlog: wait (with a deadline, since a damaged frame is never answered)
        // until the edge has answered a frame close enough behind this one.
        let deadline = Instant::now() + Duration::from_millis(500);
        while k > last_answered.load(Ordering::Acquire) + opt.max_in_flight && Instant::now() < deadline {
            std::thread::sleep(Duration::from_micros(200));
        }
        let Some(f) = usize::try_from(k).ok().and_then(|i| base.frames.get(i % base.frames.len())) else { break };
        let frame = u32::try_from(k).context("frame number")?;
        let mut hit = false;
        for part in &f.parts {
            let mut p = part.clone();
            p.frame = frame;
            p.timestamp_us = k * period_us;
            hit |= sender.send(&Message::FrameTracks(p), true, &mut report)?;
        }
        sender.tx.flush().context("writing to the link")?;
        if let Some(d) = usize::try_from(k).ok().and_then(|i| damaged.get_mut(i)) {
            *d = hit;
        }
        report.frames_sent += 1;
        step(opt.on_frame.as_ref(), report.frames_sent);
        if k == 16 {
            edge_start = edge_pid.and_then(memory_of);
        }
    }
    let edge_end = edge_pid.and_then(memory_of);
    let goodbye = LinkStats {
        frames_sent: u32::try_from(report.wire_frames_sent + 1).unwrap_or(u32::MAX),
        received: DecoderStats::default(),
    };
    sender.send(&Message::LinkStats(goodbye), false, &mut report)?;
    sender.tx.flush().context("writing to the link")?;
    let seen = seen_rx.recv_timeout(opt.reply_timeout).unwrap_or_default();
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
