//! Fixed-window (fixed-lag) Rauch-Tung-Striebel smoother over the unicycle EKF.
//!
//! The smoother keeps the last `W` filter steps. Each new frame runs the forward filter, then a
//! backward RTS pass over the window; the oldest frame of a full window leaves it smoothed with
//! `W - 1` frames of look-ahead. Memory is fixed: `W` steps of 4x4 covariances.

use heapless::Deque;
use nalgebra::Vector4;

use super::ekf::{FilterStep, state_diff, state_of};
use super::{EkfParams, Measurement, UnicycleEkf};
use crate::geometry::BevState;

/// A fixed-lag RTS smoother keeping the last `W` frames (`W >= 1`).
#[derive(Debug, Clone)]
pub struct FixedLagRts<const W: usize> {
    filter: UnicycleEkf,
    window: Deque<FilterStep, W>,
}

impl<const W: usize> FixedLagRts<W> {
    /// A smoother over a fresh filter with the given parameters.
    #[must_use]
    pub fn new(params: EkfParams) -> Self {
        Self { filter: UnicycleEkf::new(params), window: Deque::new() }
    }

    /// The forward filter (its state is the causal estimate of the newest frame).
    #[must_use]
    pub const fn filter(&self) -> &UnicycleEkf {
        &self.filter
    }

    /// Frames currently held.
    #[must_use]
    pub fn len(&self) -> usize {
        self.window.len()
    }

    /// True when no frame is held.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.window.is_empty()
    }

    /// Runs the filter on the next frame's measurement. When the window was full, the oldest
    /// frame leaves it and its smoothed state is returned. Frames before the filter's first
    /// position are not held and return `None`.
    pub fn push(&mut self, z: &Measurement) -> Option<BevState> {
        let step = self.filter.step(z)?;
        let leaving = if self.window.is_full() {
            let mut oldest = None;
            self.smooth_into(|i, s| {
                if i == 0 {
                    oldest = Some(s);
                }
            });
            self.window.pop_front();
            oldest
        } else {
            None
        };
        // Cannot fail: a slot was freed above when the window was full (and W >= 1).
        let _ = self.window.push_back(step);
        leaving
    }

    /// Smoothed states of every frame in the window, oldest first, passed to `out(index, state)`.
    /// Use at the end of a track to flush the frames still held.
    pub fn smooth_into(&self, mut out: impl FnMut(usize, BevState)) {
        let n = self.window.len();
        let Some(last) = self.window.back() else { return };
        // Backward pass from the newest frame. Only the states are carried (the smoothed
        // covariances are not needed by any consumer), which halves the work.
        let mut next_smoothed: Vector4<f32> = last.posterior;
        let mut next: &FilterStep = last;
        out(n - 1, state_of(&next_smoothed));
        for (i, cur) in self.window.iter().enumerate().rev().skip(1) {
            let smoothed = match next.prior_cov.try_inverse() {
                Some(prior_inv) => {
                    let gain = cur.posterior_cov * next.transition.transpose() * prior_inv;
                    cur.posterior + gain * state_diff(&next_smoothed, &next.prior)
                }
                // A singular prior (never seen with positive process noise) keeps the filtered
                // state rather than failing.
                None => cur.posterior,
            };
            out(i, state_of(&smoothed));
            next_smoothed = smoothed;
            next = cur;
        }
    }

    /// Clears the window and the filter (for a track that vanished and came back).
    pub fn reset(&mut self) {
        self.filter.reset();
        self.window.clear();
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;
    use crate::geometry::Point2;

    #[test]
    fn smoothing_beats_filtering_on_noisy_constant_motion() {
        const W: usize = 10;
        let dt = 0.1;
        let mut s = FixedLagRts::<W>::new(EkfParams::vehicle(dt));
        let mut seed = 12345u32;
        let mut noise = || {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            (seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        let truth = |k: usize| Point2::new(8.0 * dt * k as f32, 2.0);
        let (mut err_f, mut err_s, mut n) = (0.0, 0.0, 0);
        let mut filtered = [0.0f32; 200];
        for k in 0..200 {
            let t = truth(k);
            let z = Measurement {
                position: Some(Point2::new(t.x + 0.5 * noise(), t.y + 0.5 * noise())),
                heading: Some(0.1 * noise()),
                speed: None,
            };
            if let Some(sm) = s.push(&z) {
                let j = k - W;
                if j > 30 {
                    err_s += sm.position().distance(&truth(j));
                    err_f += filtered[j];
                    n += 1;
                }
            }
            filtered[k] = s.filter().state().unwrap().position().distance(&t);
        }
        assert!(n > 100);
        assert!(err_s < 0.8 * err_f, "smoothed {err_s} vs filtered {err_f}");
    }

    #[test]
    fn flush_reports_every_held_frame_once() {
        let mut s = FixedLagRts::<4>::new(EkfParams::vehicle(0.1));
        for k in 0..3 {
            let z = Measurement { position: Some(Point2::new(k as f32, 0.0)), ..Default::default() };
            assert!(s.push(&z).is_none());
        }
        let mut seen = [false; 3];
        s.smooth_into(|i, st| {
            assert!(st.is_finite());
            seen[i] = true;
        });
        assert_eq!(seen, [true; 3]);
    }
}
