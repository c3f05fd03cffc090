//! Choosing the motion prior's settings on a fold's training sequences.
//!
//! The prior (`dynotraj_core::predict::prior`) has six settings; they are chosen per source,
//! since a smoothed source carries acceleration and turn that a noisy one does not, and only on
//! the sequences a fold trains on, never on the ones it is scored on. The search is coordinate
//! descent over small grids, each step keeping the best mean ADE over every training instance:
//! 1. the velocity window, with no acceleration and no turn (the `cv-fit` family);
//! 2. the trend window, acceleration gain and decay, with no turn;
//! 3. the trend window, turn gain and decay, with step 2's acceleration.
//!
//! About 140 settings, each a prior forecast per instance: a second or two per fold.

use dynotraj_core::BevState;
use dynotraj_core::limits::{HORIZON, MAX_PRIOR_HISTORY, MIN_HISTORY};
use dynotraj_core::predict::{Forecast, MotionPrior, Predictor as _, PriorSettings};
use dynotraj_core::{Point2, limits::PRIOR_STATES};
use rayon::prelude::*;

use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::{EligibilityRule, Source, eligible_runs};

/// Velocity windows tried, states.
pub const VELOCITY_WINDOWS: [u8; 5] = [3, 5, 7, 9, 11];
/// Trend windows tried, states.
pub const TREND_WINDOWS: [u8; 4] = [7, 11, 15, PRIOR_STATES as u8];
/// Gains tried.
pub const GAINS: [f32; 5] = [0.0, 0.25, 0.5, 0.75, 1.0];
/// Decays per frame tried.
pub const DECAYS: [f32; 3] = [1.0, 0.95, 0.9];

/// One instance: its history (up to `PRIOR_STATES` states) and true future positions.
#[derive(Debug, Clone)]
pub struct PriorInstance {
    history: Vec<BevState>,
    future: [Point2; HORIZON],
}

/// Every test instance of every eligible run of `sequences` through `source`.
#[must_use]
pub fn prior_instances(
    sequences: &[&SequenceTracks],
    source: Source,
    dt: f32,
    rule: &EligibilityRule,
) -> Vec<PriorInstance> {
    let mut out = Vec::new();
    for seq in sequences {
        for run in eligible_runs(seq.tracks_for(source), rule) {
            let states = source.apply(&run.states, dt);
            for s in run.instances() {
                if s < MIN_HISTORY {
                    continue;
                }
                let (Some(history), Some(future)) =
                    (states.get(s.saturating_sub(MAX_PRIOR_HISTORY)..=s), states.get(s + 1..=s + HORIZON))
                else {
                    continue;
                };
                if !history.iter().chain(future).all(BevState::is_finite) {
                    continue;
                }
                let mut f = [Point2::default(); HORIZON];
                for (p, st) in f.iter_mut().zip(future) {
                    *p = st.position();
                }
                out.push(PriorInstance { history: history.to_vec(), future: f });
            }
        }
    }
    out
}

/// Mean ADE (metres) of the prior with `settings` over `instances` (instances it cannot
/// forecast count as infinitely far, so such settings never win).
#[must_use]
pub fn prior_ade(settings: &PriorSettings, instances: &[PriorInstance], dt: f32) -> f64 {
    if instances.is_empty() {
        return f64::INFINITY;
    }
    let mut prior = MotionPrior(*settings);
    let mut out: Forecast = [Point2::default(); HORIZON];
    let mut sum = 0.0f64;
    for inst in instances {
        if prior.predict(&inst.history, dt, &mut out).is_err() {
            return f64::INFINITY;
        }
        let ade: f32 = out.iter().zip(&inst.future).map(|(p, q)| p.distance(q)).sum::<f32>() / HORIZON as f32;
        sum += f64::from(ade);
    }
    sum / instances.len() as f64
}

/// The best of `candidates` by [`prior_ade`] (the first among equals), on every core.
fn best(candidates: Vec<PriorSettings>, instances: &[PriorInstance], dt: f32) -> PriorSettings {
    let scored: Vec<(PriorSettings, f64)> =
        candidates.into_par_iter().map(|c| (c, prior_ade(&c, instances, dt))).collect();
    scored.into_iter().fold((PriorSettings::OFF, f64::INFINITY), |b, c| if c.1 < b.1 { c } else { b }).0
}

/// The settings the coordinate descent of the module docs chooses on `instances`;
/// [`PriorSettings::OFF`] when there are none.
#[must_use]
pub fn tune_prior(instances: &[PriorInstance], dt: f32) -> PriorSettings {
    if instances.is_empty() {
        return PriorSettings::OFF;
    }
    let off = PriorSettings::OFF;
    let v =
        best(VELOCITY_WINDOWS.iter().map(|&w| PriorSettings { velocity_window: w, ..off }).collect(), instances, dt);
    let mut accel = Vec::new();
    for &trend_window in &TREND_WINDOWS {
        for &accel_gain in &GAINS {
            for &accel_decay in &DECAYS {
                accel.push(PriorSettings { trend_window, accel_gain, accel_decay, ..v });
            }
        }
    }
    let a = best(accel, instances, dt);
    let mut turn = Vec::new();
    for &trend_window in &TREND_WINDOWS {
        for &turn_gain in &GAINS {
            for &turn_decay in &DECAYS {
                turn.push(PriorSettings { trend_window, turn_gain, turn_decay, ..a });
            }
        }
    }
    best(turn, instances, dt)
}

#[cfg(test)]
mod tests {
    use dynotraj_core::predict::unicycle_step;

    use super::*;

    /// Runs that brake steadily: the prior should learn to carry the braking on.
    fn braking(n: usize) -> Vec<PriorInstance> {
        let dt = 0.05;
        (0..n)
            .map(|i| {
                let mut s = BevState { x: i as f32 * 10.0, y: 0.0, heading: 0.3 * i as f32, speed: 12.0 };
                let states: Vec<BevState> = (0..PRIOR_STATES + HORIZON)
                    .map(|_| {
                        let now = s;
                        s = unicycle_step(&s, 0.0, -1.5, dt);
                        now
                    })
                    .collect();
                let mut future = [Point2::default(); HORIZON];
                for (f, st) in future.iter_mut().zip(&states[PRIOR_STATES..]) {
                    *f = st.position();
                }
                PriorInstance { history: states[..PRIOR_STATES].to_vec(), future }
            })
            .collect()
    }

    #[test]
    fn steady_braking_is_learned_and_beats_no_prior() {
        let dt = 0.05;
        let inst = braking(8);
        let chosen = tune_prior(&inst, dt);
        assert!(chosen.accel_gain >= 0.75 && chosen.accel_decay == 1.0, "{chosen:?}");
        assert!(prior_ade(&chosen, &inst, dt) < 0.5 * prior_ade(&PriorSettings::OFF, &inst, dt));
        assert!(chosen.is_valid());
        assert_eq!(tune_prior(&[], dt), PriorSettings::OFF);
    }
}
