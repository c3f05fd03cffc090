//! Synthetic training data for the tests: the simulator's unicycle runs under constant
//! controls as samples, which a trained predictor should learn to extrapolate better than it
//! starts.

use dynotraj_core::BevState;
use dynotraj_core::predict::{Context, PriorSettings};
pub use dynotraj_sim::unicycle_runs::constant_control_runs;

use super::dataset::{Sample, sample_at};

/// Every instance of every run as a sample (no neighbours, no motion prior: the network has
/// the whole motion to learn), group = run index.
#[must_use]
pub fn samples(runs: &[Vec<BevState>], dt: f32) -> Vec<Sample> {
    runs.iter()
        .enumerate()
        .flat_map(|(g, states)| {
            (1..states.len()).filter_map(move |s| sample_at(states, s, &Context::NONE, dt, g, &PriorSettings::OFF))
        })
        .collect()
}
