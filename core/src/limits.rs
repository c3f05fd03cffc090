//! Named capacities of the core and the paper's fixed horizons and physical limits.
//!
//! The capacities follow the ECU budget (docs/architecture.md, "Budgets"): 16 tracked objects, 256 static tracks and
//! 128 points per object, a 30-frame horizon.

/// Prediction horizon in frames (the paper: 30 frames, "1.5 s" at its assumed 20 Hz).
pub const HORIZON: usize = 30;
/// Most history frames (before the current one) fed to a predictor.
pub const MAX_HISTORY: usize = 6;
/// Most states in a history the network reads: [`MAX_HISTORY`] past frames and the current one.
pub const MAX_STEPS: usize = MAX_HISTORY + 1;
/// Bytes of a signer's public key that name it (a signed blob's trailer, the edge's notice of a
/// model signed by another key).
pub const KEY_ID_LEN: usize = 8;
/// Most history frames (before the current one) the motion prior reads: its acceleration and
/// turn rate need a longer memory than the network's input (21 states are 2 s of KITTI's real
/// 10 Hz; `predict::prior`).
pub const MAX_PRIOR_HISTORY: usize = 20;
/// States a motion-prior history holds at most: [`MAX_PRIOR_HISTORY`] and the current one.
pub const PRIOR_STATES: usize = MAX_PRIOR_HISTORY + 1;
/// Fewest history frames (before the current one) a forecast needs.
pub const MIN_HISTORY: usize = 1;
/// Shortest run of consecutive frames that makes an object eligible: one history frame, the
/// current frame and the horizon (the paper's 32).
pub const MIN_ELIGIBLE_RUN: usize = MIN_HISTORY + 1 + HORIZON;
/// Most objects tracked at once.
pub const MAX_OBJECTS: usize = 16;
/// Most static (background) feature tracks per frame.
pub const MAX_STATIC_TRACKS: usize = 256;
/// Most feature points per object per frame.
pub const MAX_POINTS_PER_OBJECT: usize = 128;
/// The paper's turn-rate limit, rad/s (applied as |omega| <= this).
pub const MAX_TURN_RATE: f32 = 0.7;
/// The paper's acceleration limit, m/s^2 (applied as |a| <= this).
pub const MAX_ACCEL: f32 = 4.0;
/// The frame rate the paper assumes for KITTI, Hz (the cameras really run at 10 Hz).
pub const PAPER_FRAME_RATE_HZ: f32 = 20.0;

/// Largest plausible |coordinate| of a bird's-eye position, metres. Beyond it a value is garbage,
/// not a vehicle: squared in covariance arithmetic or extrapolated over a horizon it overflows
/// f32 (found by the property tests), so filters treat it as missing and predictors refuse it.
pub const MAX_ABS_POSITION: f32 = 1.0e6;
/// Largest plausible |speed|, m/s; beyond it a value is treated like [`MAX_ABS_POSITION`].
pub const MAX_ABS_SPEED: f32 = 1.0e3;
