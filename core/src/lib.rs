//! dynotraj-core: the fixed-size, `no_std`, allocation-free heart of dynotraj.
//!
//! Everything here runs unchanged on a Cortex-M4F ECU and on the host. The core never does I/O
//! and never reads a clock: callers pass bytes, frames and timestamps in and take messages out.
//! Every capacity is a named const or a const generic; running out of room is a documented,
//! counted outcome, never a panic.
//!
//! Modules:
//! - [`crc`]: the one checksum (CRC-32) of frames, model chunks and blobs.
//! - [`class`]: what an object is (KITTI's types), and so the agent type that forecasts it.
//! - [`limits`]: the named capacities and the paper's horizons and limits.
//! - [`log_level`]: the log level the programs' `-q` and `-v` flags ask for.
//! - [`wire`]: every message of the pipeline, and its framing (postcard + CRC-32 + COBS).
//! - [`geometry`]: SE(3)/SE(2) helpers, camera-to-bird's-eye projection, angle wrapping.
//! - [`gt_ekf`]: the unicycle EKF (the paper's GT+EKF baseline) and its fixed-window RTS smoother.
//! - [`predict`]: unicycle dynamics and the baseline predictors (constant velocity, CTRA).
//! - [`metrics`]: ADE, FDE, ACE and RPE.
//! - [`estimate`]: the dynamic-SLAM estimator: camera ego-motion and every object's SE(3)
//!   motion from feature tracks, smoothed in a fixed-lag window (the paper's Estimated source).
//! - [`model`]: the learned predictor: its architecture, the model blob, float and int8
//!   inference, and the signature check of a blob sent to the edge.
#![no_std]
#![forbid(unsafe_code)]

pub mod class;
pub mod crc;
pub mod estimate;
pub mod geometry;
pub mod gt_ekf;
pub mod limits;
pub mod log_level;
pub mod metrics;
pub mod model;
pub mod predict;
pub mod wire;

pub use geometry::{BevState, Point2};
