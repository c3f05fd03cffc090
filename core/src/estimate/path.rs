//! A smoothed path: a fixed pose (the anchor, the newest frame that left the window) followed by
//! the chain of per-frame body motions still in the window. Camera and objects each have one.
//!
//! Poses are `anchor * exp(x_1) * ... * exp(x_i)` with `x` the chain's solution: the newest of
//! them is the best current estimate of the newest pose (the frame the next motion is measured
//! from). The pose of the frame right after the anchor, once it leaves the window, is the
//! smoothed estimate and becomes the new anchor (fixed from then on).
//!
//! The causal output is the filtered trajectory: each new step appends the newest motion as the
//! smoother sees it at that step, `causal_k = causal_(k-1) * exp(x_k)`. It is never revised, so
//! consecutive causal poses form a trajectory an online system could have logged (the current
//! estimate is revised with every frame, and pairs of it would carry those revisions).

use super::lie::{Mat6, VEC6_ZERO, Vec6, adjoint, normalised};
use super::motion_smoother::{ChainScratch, ChainSmoother, Smoothness};
use crate::geometry::{POSE3_IDENTITY, Pose3, se3_exp};

/// A pose leaving the window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Emitted {
    /// The smoothed pose.
    pub pose: Pose3,
    /// Body-frame twist of the motion into that frame (the first frame of a path has none and
    /// reports the motion out of it instead).
    pub xi: Vec6,
}

/// The window's normal equations could not be solved (not positive definite or not finite).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SolveFailed;

/// One smoothed path; see the module docs.
#[derive(Debug, Clone)]
pub struct SmoothedPath<const W: usize> {
    anchor: Pose3,
    anchor_step: u32,
    anchor_emitted: bool,
    chain: ChainSmoother<W>,
    current: Pose3,
    causal: Pose3,
    causal_xi: Vec6,
}

impl<const W: usize> Default for SmoothedPath<W> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const W: usize> SmoothedPath<W> {
    /// An empty path at the identity.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            anchor: POSE3_IDENTITY,
            anchor_step: 0,
            anchor_emitted: false,
            chain: ChainSmoother::new(),
            current: POSE3_IDENTITY,
            causal: POSE3_IDENTITY,
            causal_xi: VEC6_ZERO,
        }
    }

    /// Restarts the path at `pose`, the pose of step `step`.
    pub fn start(&mut self, pose: Pose3, step: u32) {
        self.anchor = pose;
        self.anchor_step = step;
        self.anchor_emitted = false;
        self.chain.clear();
        self.current = pose;
        self.causal = pose;
        self.causal_xi = Vec6::zeros();
    }

    /// The causal (filtered) pose of the newest step.
    #[must_use]
    pub const fn causal(&self) -> &Pose3 {
        &self.causal
    }

    /// The best current estimate of the newest step's pose (revised by every later frame).
    #[must_use]
    pub const fn current(&self) -> &Pose3 {
        &self.current
    }

    /// The causal body twist of the newest step's motion.
    #[must_use]
    pub const fn causal_xi(&self) -> &Vec6 {
        &self.causal_xi
    }

    /// Steps not yet emitted.
    #[must_use]
    pub fn pending(&self) -> usize {
        self.chain.len() + usize::from(!self.anchor_emitted)
    }

    /// The step of the chain's oldest slot (the slot after the anchor).
    #[must_use]
    pub fn first_slot_step(&self) -> u32 {
        self.anchor_step.wrapping_add(1)
    }

    /// Puts a zero-mean prior of diagonal information `info` on every body motion of the
    /// window ([`ChainSmoother::set_kinematic`]) until the path restarts.
    pub fn set_kinematic(&mut self, info: [f32; 6]) {
        self.chain.set_kinematic(info);
    }

    /// The chain of body motions in the window.
    #[must_use]
    pub const fn chain(&self) -> &ChainSmoother<W> {
        &self.chain
    }

    /// Appends the next step's measured body twist and information (`None`: no fit) with its
    /// coupling data `lin`, without solving ([`SmoothedPath::apply`] follows the solve).
    pub fn push(
        &mut self,
        measurement: Option<(&Vec6, &Mat6)>,
        lin: &[f32; 6],
        s: &Smoothness,
        scratch: &mut ChainScratch<W>,
    ) {
        if self.chain.is_full() {
            // Never happens while steps are emitted in order; keeps memory fixed if they are not.
            self.pop(s, scratch);
        }
        if !self.chain.push(measurement, lin) {
            let _ = self.chain.push(None, &[0.0; 6]);
        }
    }

    /// Appends the next step's measured body twist and information (`None`: no fit), solves the
    /// window and updates the causal estimate; then, when `leaving` is a step of this path that
    /// leaves the window, returns its smoothed pose. `Err(())` when the solve broke down: the
    /// causal pose then advances by the previous motion (a hold) and nothing is emitted.
    ///
    /// # Errors
    /// [`SolveFailed`] as above.
    pub fn advance(
        &mut self,
        measurement: Option<(&Vec6, &Mat6)>,
        s: &Smoothness,
        scratch: &mut ChainScratch<W>,
        leaving: Option<u32>,
    ) -> Result<Option<Emitted>, SolveFailed> {
        self.push(measurement, &[0.0; 6], s, scratch);
        let n = self.chain.solve(s, scratch);
        self.apply(n.map(|n| scratch.solution(n)), s, leaving, true, None)
    }

    /// Emits `leaving` without adding a step (for a path whose object is gone, and for flushing).
    ///
    /// # Errors
    /// [`SolveFailed`] when the solve broke down.
    pub fn drain(
        &mut self,
        s: &Smoothness,
        scratch: &mut ChainScratch<W>,
        leaving: u32,
    ) -> Result<Option<Emitted>, SolveFailed> {
        let n = self.chain.solve(s, scratch);
        self.apply(n.map(|n| scratch.solution(n)), s, Some(leaving), false, None)
    }

    /// Takes the window's solution `xs` (oldest first; `None`: the solve broke down): sets the
    /// current pose, on a `new_step` extends the causal one, and emits `leaving` if it is this
    /// path's. `front_shift` is added to the oldest slot's measurement before it is marginalised
    /// (the joint solve's fixing of the camera motion that slot was coupled to).
    ///
    /// # Errors
    /// [`SolveFailed`] when `xs` is `None` (the causal pose then advances by the previous motion).
    pub fn apply(
        &mut self,
        xs: Option<&[Vec6]>,
        s: &Smoothness,
        leaving: Option<u32>,
        new_step: bool,
        front_shift: Option<Vec6>,
    ) -> Result<Option<Emitted>, SolveFailed> {
        let Some(xs) = xs else {
            if new_step {
                let step = se3_exp(&self.causal_xi);
                self.current = normalised(self.current * step);
                self.causal = normalised(self.causal * step);
            }
            return Err(SolveFailed);
        };
        let mut pose = self.anchor;
        for x in xs {
            pose *= se3_exp(x);
        }
        self.current = normalised(pose);
        if new_step && let Some(x) = xs.last() {
            self.causal_xi = *x;
            self.causal = normalised(self.causal * se3_exp(x));
        }
        let first = xs.first().copied();
        Ok(match leaving {
            Some(j) if j == self.anchor_step && !self.anchor_emitted => {
                self.anchor_emitted = true;
                Some(Emitted { pose: self.anchor, xi: first.unwrap_or_else(Vec6::zeros) })
            }
            Some(j) if self.anchor_step.checked_add(1) == Some(j) => first.map(|x| {
                self.anchor = normalised(self.anchor * se3_exp(&x));
                self.anchor_step = j;
                self.anchor_emitted = true;
                if let Some(dz) = front_shift {
                    self.chain.shift_front(&dz);
                }
                self.chain.pop_marginalise(s);
                Emitted { pose: self.anchor, xi: x }
            }),
            _ => None,
        })
    }

    /// Drops the oldest step after solving for it (keeps the anchor moving with its estimate).
    fn pop(&mut self, s: &Smoothness, scratch: &mut ChainScratch<W>) {
        if let Some(n) = self.chain.solve(s, scratch)
            && let Some(x) = scratch.solution(n).first()
        {
            self.anchor *= se3_exp(x);
        }
        self.anchor_step = self.anchor_step.saturating_add(1);
        self.anchor_emitted = true;
        self.chain.pop_marginalise(s);
    }

    /// Turns the body frame by the pure rotation `r`: every pose `P` becomes `P * r` and every
    /// body twist `xi` becomes `Ad(r^-1) xi`.
    pub fn reframe(&mut self, r: &Pose3) {
        let ad = adjoint(&r.inverse());
        self.anchor *= r;
        self.current *= r;
        self.causal *= r;
        self.causal_xi = ad * self.causal_xi;
        self.chain.reframe(&ad, r);
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::estimate::params::SmootherParams;

    #[test]
    fn emits_each_step_once_in_order() {
        const W: usize = 4;
        let s = Smoothness::new(&SmootherParams { sigma_translation: 0.1, sigma_rotation: 0.01 });
        let mut scratch = ChainScratch::<W>::new();
        let mut p = SmoothedPath::<W>::new();
        p.start(Pose3::identity(), 0);
        let xi = Vec6::new(1.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        let info = Mat6::identity() * 100.0;
        let mut emitted = [None; 12];
        for k in 1..10u32 {
            let leaving = k.checked_sub(W as u32 - 1);
            if let Some(e) = p.advance(Some((&xi, &info)), &s, &mut scratch, leaving).unwrap() {
                emitted[leaving.unwrap() as usize] = Some(e.pose.translation.vector.x);
            }
            assert!((p.causal().translation.vector.x - k as f32).abs() < 1e-3);
            assert!((p.current().translation.vector.x - k as f32).abs() < 1e-3);
        }
        for j in 10 - W as u32 + 1..=9 {
            if let Some(e) = p.drain(&s, &mut scratch, j).unwrap() {
                emitted[j as usize] = Some(e.pose.translation.vector.x);
            }
        }
        assert_eq!(p.pending(), 0);
        for (j, e) in emitted.iter().take(10).enumerate() {
            assert!((e.unwrap() - j as f32).abs() < 1e-3, "{j}: {e:?}");
        }
    }
}
