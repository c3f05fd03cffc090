//! Relative pose error (Sturm et al., TUM RGB-D benchmark) with delta = 1 frame, as evo computes
//! it: E_i = (Q_i^-1 Q_(i+1))^-1 (P_i^-1 P_(i+1)), Q the reference and P the estimate;
//! RPE_t = sqrt(mean |trans(E_i)|^2), RPE_r = sqrt(mean angle(E_i)^2).

use crate::geometry::{Pose3, rotation_angle};

/// RMSE of the relative pose error.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RpeResult {
    /// Translation RMSE, metres.
    pub translation: f64,
    /// Rotation RMSE, radians.
    pub rotation: f64,
    /// Pose pairs scored.
    pub pairs: u32,
}

/// The relative pose error of one pair of consecutive frames.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairError {
    /// |trans(E_i)|, metres.
    pub translation: f64,
    /// angle(E_i), radians.
    pub rotation: f64,
}

/// Streaming RPE over pairs of consecutive poses. Call [`RpeAccumulator::break_segment`] at a
/// gap so that no pair spans it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RpeAccumulator {
    prev: Option<(Pose3, Pose3)>,
    sum_t2: f64,
    sum_r2: f64,
    pairs: u32,
}

impl RpeAccumulator {
    /// An empty accumulator.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds the next frame's reference and estimated pose; returns the error of the pair it
    /// closes (with the previous frame), when there is one and it is finite (what is counted),
    /// so that a caller can follow the error over time.
    pub fn push(&mut self, reference: &Pose3, estimate: &Pose3) -> Option<PairError> {
        let mut counted = None;
        if let Some((q0, p0)) = &self.prev {
            let dq = q0.inv_mul(reference);
            let dp = p0.inv_mul(estimate);
            let e = dq.inv_mul(&dp);
            let t = f64::from(e.translation.vector.norm());
            let r = f64::from(rotation_angle(&e));
            if t.is_finite() && r.is_finite() {
                self.sum_t2 += t * t;
                self.sum_r2 += r * r;
                self.pairs = self.pairs.saturating_add(1);
                counted = Some(PairError { translation: t, rotation: r });
            }
        }
        self.prev = Some((*reference, *estimate));
        counted
    }

    /// Ends the current run of consecutive frames.
    pub fn break_segment(&mut self) {
        self.prev = None;
    }

    /// Merges another accumulator's sums (pairs are weighted equally).
    pub fn merge(&mut self, other: &Self) {
        self.sum_t2 += other.sum_t2;
        self.sum_r2 += other.sum_r2;
        self.pairs = self.pairs.saturating_add(other.pairs);
    }

    /// The RMSEs, or `None` before any pair.
    #[must_use]
    pub fn result(&self) -> Option<RpeResult> {
        (self.pairs > 0).then(|| {
            let n = f64::from(self.pairs);
            RpeResult {
                translation: libm::sqrt(self.sum_t2 / n),
                rotation: libm::sqrt(self.sum_r2 / n),
                pairs: self.pairs,
            }
        })
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion, Vector3};

    fn pose(x: f32, yaw: f32) -> Pose3 {
        Pose3::from_parts(Translation3::new(x, 0.0, 0.0), UnitQuaternion::from_axis_angle(&Vector3::y_axis(), yaw))
    }

    #[test]
    fn identical_and_globally_offset_trajectories_score_zero() {
        let mut acc = RpeAccumulator::new();
        let offset = pose(5.0, 0.3);
        for k in 0..10 {
            let q = pose(k as f32, 0.01 * k as f32);
            acc.push(&q, &(offset * q));
        }
        let r = acc.result().unwrap();
        assert_eq!(r.pairs, 9);
        assert!(r.translation < 1e-5 && r.rotation < 1e-5, "{r:?}");
    }

    #[test]
    fn constant_step_error_is_recovered() {
        let mut acc = RpeAccumulator::new();
        for k in 0..5 {
            // The estimate travels 1.1 m per frame instead of 1 m.
            acc.push(&pose(k as f32, 0.0), &pose(1.1 * k as f32, 0.0));
        }
        let r = acc.result().unwrap();
        assert!((r.translation - 0.1).abs() < 1e-4 && r.rotation < 1e-6, "{r:?}");
        // Each pair's own error is what the RMSE averages.
        let mut acc = RpeAccumulator::new();
        assert_eq!(acc.push(&pose(0.0, 0.0), &pose(0.0, 0.0)), None, "no pair before the second frame");
        let pair = acc.push(&pose(1.0, 0.0), &pose(1.3, 0.0)).unwrap();
        assert!((pair.translation - 0.3).abs() < 1e-5 && pair.rotation < 1e-6, "{pair:?}");
        acc.break_segment();
        assert_eq!(acc.push(&pose(2.0, 0.0), &pose(2.0, 0.0)), None, "no pair across a gap");
        let mut acc = RpeAccumulator::new();
        for k in 0..5 {
            // The estimate turns 0.02 rad per frame where the reference stands still.
            acc.push(&pose(0.0, 0.0), &pose(0.0, 0.02 * k as f32));
        }
        let r = acc.result().unwrap();
        assert!((r.rotation - 0.02).abs() < 1e-5 && r.translation < 1e-6, "{r:?}");
        assert!(RpeAccumulator::new().result().is_none());
    }
}
