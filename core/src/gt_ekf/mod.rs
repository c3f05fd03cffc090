//! Smoothing of bird's-eye object trajectories: the unicycle EKF that is the paper's GT+EKF
//! baseline, and a fixed-window Rauch-Tung-Striebel smoother over it.
//!
//! The filter's output at frame k uses only measurements up to k (causal: what an online vehicle
//! knows). The RTS smoother's output for frame k has also seen up to `W - 1` later frames; it may
//! shape training targets or be reported as a labelled variant, never fed as a causal input.

mod ekf;
mod rts;

pub use ekf::{EkfParams, Measurement, UnicycleEkf};
pub use rts::FixedLagRts;
