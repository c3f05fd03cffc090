//! Named estimator profiles: the settings that decide what the estimator costs and how well it
//! does, chosen together so that a host run and the firmware can be told apart by one name.
//!
//! The smoothing window is a const generic of [`super::Estimator`] (its memory is fixed at
//! build time), so a profile names it as a number for the caller to instantiate with.

use super::params::JOINT_SWEEPS;
use super::params::{EstimatorParams, Intrinsics};

/// The host's smoothing window, frames (DynoSAM's sliding window is 20 frames).
pub const DEFAULT_WINDOW: usize = 20;

/// The firmware's smoothing window, frames: 0.4 s at the paper's 20 Hz. The ECU's 128 KiB of
/// RAM holds the estimator, the int8 predictor's scratch, the link buffers and the stack only
/// with a short window: each window frame costs about 2.5-3 KiB over 16 objects and the camera
/// (`tests/tests/estimate_size_budget.rs` holds the budget).
pub const EDGE_WINDOW: usize = 8;

/// A named estimator configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EstimatorProfile {
    /// The name a user picks it by.
    pub name: &'static str,
    /// Smoothing window, frames (instantiate [`super::Estimator`] with it).
    pub window: usize,
    /// Joint camera-object sweeps per frame ([`super::EstimatorParams::joint_sweeps`]).
    pub joint_sweeps: u8,
}

/// The host: DynoSAM's window and the joint camera-object solve.
pub const HOST_PROFILE: EstimatorProfile =
    EstimatorProfile { name: "host", window: DEFAULT_WINDOW, joint_sweeps: JOINT_SWEEPS as u8 };

/// What the firmware runs: the short window, and camera and objects smoothed apart (the joint
/// solve's compute and stack do not fit the ECU beside the predictor).
pub const EDGE_PROFILE: EstimatorProfile = EstimatorProfile { name: "edge", window: EDGE_WINDOW, joint_sweeps: 0 };

/// Every profile, host first.
pub const PROFILES: [EstimatorProfile; 2] = [HOST_PROFILE, EDGE_PROFILE];

impl EstimatorProfile {
    /// The estimator parameters of this profile for a KITTI-like rig with `intrinsics`, frames
    /// `nominal_dt` apart: [`EstimatorParams::kitti`] with the profile's joint sweeps.
    #[must_use]
    pub const fn params(&self, intrinsics: Intrinsics, nominal_dt: f32) -> EstimatorParams {
        let mut p = EstimatorParams::kitti(intrinsics, nominal_dt);
        p.joint_sweeps = self.joint_sweeps;
        p
    }

    /// The profile called `name`, if any.
    #[must_use]
    pub fn named(name: &str) -> Option<Self> {
        PROFILES.into_iter().find(|p| p.name == name)
    }
}
