//! Synthetic training data for the tests: unicycle runs under constant controls, which a
//! trained predictor should learn to extrapolate better than it starts.

use dynotraj_core::BevState;
use dynotraj_core::predict::{PriorSettings, unicycle_step};
use rand::{Rng as _, SeedableRng as _};
use rand_xoshiro::Xoshiro256PlusPlus;

use super::dataset::{Sample, sample_at};

/// `runs` runs of `len` states at period `dt`, each under its own constant turn rate (within
/// +-0.5 rad/s, half of them clearly turning) and acceleration (+-1 m/s^2) from a speed of
/// 4-14 m/s, in random places and headings.
#[must_use]
pub fn constant_control_runs(runs: usize, len: usize, dt: f32, seed: u64) -> Vec<Vec<BevState>> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    (0..runs)
        .map(|i| {
            let w = if i % 2 == 0 { rng.random_range(-0.5..0.5) } else { rng.random_range(-0.005..0.005) };
            let a = rng.random_range(-1.0..1.0);
            let mut s = BevState {
                x: rng.random_range(-50.0..50.0),
                y: rng.random_range(-50.0..50.0),
                heading: rng.random_range(-3.0..3.0),
                speed: rng.random_range(4.0..14.0),
            };
            let mut out = vec![s];
            for _ in 1..len {
                s = unicycle_step(&s, w, a, dt);
                out.push(s);
            }
            out
        })
        .collect()
}

/// Every instance of every run as a sample (no neighbours, no motion prior: the network has
/// the whole motion to learn), group = run index.
#[must_use]
pub fn samples(runs: &[Vec<BevState>], dt: f32) -> Vec<Sample> {
    runs.iter()
        .enumerate()
        .flat_map(|(g, states)| {
            (1..states.len()).filter_map(move |s| sample_at(states, s, &[], dt, g, &PriorSettings::OFF))
        })
        .collect()
}
