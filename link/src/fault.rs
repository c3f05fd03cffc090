//! A writer that damages wire frames at random on their way to the link: each `write` is one
//! whole frame (as [`crate::wire_io::WireSender`] writes them), which is flipped in one byte,
//! cut short, or sent twice with a set probability, and counted.

use std::io::{self, Write};

use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// The kinds of damage, in the order [`FaultInjector::counts`] counts them.
pub const FAULT_KINDS: [&str; 3] = ["byte flipped", "tail dropped", "frame duplicated"];

/// Wraps a writer and damages the frames written through it.
pub struct FaultInjector<W: Write> {
    inner: W,
    rng: Xoshiro256PlusPlus,
    probability: f64,
    armed: bool,
    counts: [u64; 3],
    damaged_since: bool,
}

impl<W: Write> FaultInjector<W> {
    /// Damages each frame written to `inner` with `probability` (clamped to 0..=1), drawing from
    /// a generator seeded with `seed`; armed from the start.
    pub fn new(inner: W, probability: f64, seed: u64) -> Self {
        let probability = if probability.is_nan() { 0.0 } else { probability.clamp(0.0, 1.0) };
        Self {
            inner,
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
            probability,
            armed: true,
            counts: [0; 3],
            damaged_since: false,
        }
    }

    /// Whether frames written from now on may be damaged (a run's opening and closing
    /// messages go through clean).
    pub fn arm(&mut self, armed: bool) {
        self.armed = armed;
    }

    /// Faults injected so far, per kind ([`FAULT_KINDS`]).
    #[must_use]
    pub const fn counts(&self) -> [u64; 3] {
        self.counts
    }

    /// Whether a frame was damaged since the last call.
    pub fn take_damaged(&mut self) -> bool {
        std::mem::take(&mut self.damaged_since)
    }

    /// Damages `frame` in place; returns the kind.
    fn damage(&mut self, frame: &mut Vec<u8>) -> usize {
        if frame.is_empty() {
            return 2;
        }
        match self.rng.random_range(0..3) {
            0 => {
                let at = self.rng.random_range(0..frame.len());
                let flip = self.rng.random_range(1..=255u8);
                if let Some(b) = frame.get_mut(at) {
                    *b ^= flip;
                }
                0
            }
            1 => {
                let keep = self.rng.random_range(0..frame.len());
                frame.truncate(keep);
                1
            }
            _ => {
                let copy = frame.clone();
                frame.extend_from_slice(&copy);
                2
            }
        }
    }
}

impl<W: Write> Write for FaultInjector<W> {
    fn write(&mut self, frame: &[u8]) -> io::Result<usize> {
        if !(self.armed && self.rng.random_bool(self.probability)) {
            self.inner.write_all(frame)?;
            return Ok(frame.len());
        }
        let mut bytes = frame.to_vec();
        let kind = self.damage(&mut bytes);
        if let Some(c) = self.counts.get_mut(kind) {
            *c += 1;
        }
        self.damaged_since = true;
        self.inner.write_all(&bytes)?;
        Ok(frame.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unarmed_or_fault_free_injector_passes_frames_unchanged() {
        let mut f = FaultInjector::new(Vec::new(), 0.0, 1);
        f.write_all(b"\x00abc\x00").unwrap();
        f.arm(false);
        let mut g = FaultInjector::new(Vec::new(), 1.0, 1);
        g.arm(false);
        g.write_all(b"\x00abc\x00").unwrap();
        assert_eq!((f.inner, f.counts), (b"\x00abc\x00".to_vec(), [0; 3]));
        assert_eq!((g.inner, g.counts), (b"\x00abc\x00".to_vec(), [0; 3]));
    }

    #[test]
    fn every_frame_is_damaged_at_probability_one_and_counted_by_kind() {
        let frame = b"\x00some frame bytes\x00";
        let mut f = FaultInjector::new(Vec::new(), 1.0, 7);
        let mut written = 0;
        for _ in 0..300 {
            let before = f.inner.len();
            f.write_all(frame).unwrap();
            assert!(f.take_damaged());
            assert!(!f.take_damaged());
            let out = &f.inner[before..];
            written += 1;
            assert!(out != frame, "frame {written} went through undamaged");
        }
        let counts = f.counts();
        assert_eq!(counts.iter().sum::<u64>(), 300);
        assert!(counts.iter().all(|&c| c > 50), "{counts:?}");
    }

    #[test]
    fn the_same_seed_damages_the_same_way() {
        let run = |seed| {
            let mut f = FaultInjector::new(Vec::new(), 0.3, seed);
            for k in 0..200u8 {
                f.write_all(&[0, k, k, k, 0]).unwrap();
            }
            (f.inner, f.counts)
        };
        assert_eq!(run(5), run(5));
        assert_ne!(run(5), run(6));
    }
}
