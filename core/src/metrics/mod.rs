//! Metrics: ADE, FDE and ACE as the paper defines them, their running means, and RPE (Sturm et
//! al.) for pose trajectories.
//!
//! Sums run in f64 so that averages over long sequences do not drift on an f32-only FPU's
//! rounding; the per-item computations stay f32.

mod displacement;
mod mean;
mod rpe;

pub use displacement::{ace, ade, fde, step_errors};
pub use mean::{ForecastScores, Mean};
pub use rpe::{PairError, RpeAccumulator, RpeResult};
