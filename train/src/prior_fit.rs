//! Choosing the motion prior's settings on a fold's training sequences.
//!
//! The prior (`dynotraj_core::predict::prior`) has six settings; they are chosen per source,
//! since a smoothed source carries acceleration and turn that a noisy one does not, and only on
//! the sequences a fold trains on, never on the ones it is scored on. The search is coordinate
//! descent over small grids, each step keeping the best mean ADE over every training instance:
//! 1. the velocity window, with no acceleration and no turn (the `cv-fit` family; the last
//!    displacement too at frame rates of [`LAST_DISPLACEMENT_MIN_PERIOD_S`] and slower);
//! 2. the trend window, acceleration gain and decay, with no turn;
//! 3. the trend window, turn gain and decay, with step 2's acceleration;
//!
//! and those three steps once for each share of the previous forecast carried into the next
//! ([`CARRY_PERCENTS`]), keeping the best of the five.
//!
//! What "best" means is a [`PriorObjective`]: by default the best ADE among the settings whose
//! consistency error (the paper's ACE) is no worse than constant velocity's on the same
//! instances, since a planner needs forecasts that do not jump from one frame to the next; the
//! mean ADE alone, or ADE plus ACE, on request.
//!
//! About 700 settings, each a prior forecast per instance: a few seconds per fold.

use dynotraj_core::BevState;
use dynotraj_core::limits::{HORIZON, MAX_PRIOR_HISTORY, MIN_HISTORY};
use dynotraj_core::metrics::ace;
use dynotraj_core::predict::{Baseline, Forecast, MotionPrior, Predictor, PriorSettings, carry_forward};
use dynotraj_core::{Point2, limits::PRIOR_STATES};
use rayon::prelude::*;

use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::{EligibilityRule, Source, eligible_runs};

/// Velocity windows tried, states.
pub const VELOCITY_WINDOWS: [u8; 5] = [3, 5, 7, 9, 11];

/// The slowest frame rate's period from which the last displacement (a window of two states) is
/// tried too, seconds (4 Hz). At the 2.5 Hz of pedestrian recordings it is a velocity of its
/// own; at a vehicle camera's 10-20 Hz it carries two frames' position noise at full gain
/// (`dynotraj_core::predict::fit`).
pub const LAST_DISPLACEMENT_MIN_PERIOD_S: f32 = 0.25;

/// The velocity windows tried at frame period `dt`.
#[must_use]
pub fn velocity_windows(dt: f32) -> Vec<u8> {
    let last_displacement = (dt >= LAST_DISPLACEMENT_MIN_PERIOD_S).then_some(2);
    last_displacement.into_iter().chain(VELOCITY_WINDOWS).collect()
}

/// Trend windows tried, states.
pub const TREND_WINDOWS: [u8; 4] = [7, 11, 15, PRIOR_STATES as u8];
/// Gains tried.
pub const GAINS: [f32; 5] = [0.0, 0.25, 0.5, 0.75, 1.0];
/// Decays per frame tried.
pub const DECAYS: [f32; 3] = [1.0, 0.95, 0.9];
/// Shares of the forecast at the frame before carried into the next, percent
/// (`dynotraj_core::predict::consistency`); steps 1-3 are run once for each.
pub const CARRY_PERCENTS: [u8; 5] = [0, 20, 40, 60, 80];

/// What the tuning minimises.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PriorObjective {
    /// The mean ADE.
    Ade,
    /// The mean ADE among the settings whose mean ACE is at most constant velocity's on the same
    /// instances (where none is, the least ACE): the default, since a planner needs forecasts
    /// that do not jump from frame to frame as much as close ones, and carrying part of the last
    /// forecast lets a trend through at cv's consistency (docs/decisions.md).
    #[default]
    AdeWithinCvAce,
    /// The mean ADE plus the mean ACE, both in metres.
    AdePlusAce,
}

/// One instance: its history (up to `PRIOR_STATES` states) and true future positions.
#[derive(Debug, Clone)]
pub struct PriorInstance {
    history: Vec<BevState>,
    /// The positions scored: the next [`HORIZON`] or fewer.
    future: Vec<Point2>,
    /// The instance before it in the list is the same run one frame earlier (the pair an ACE
    /// is measured on).
    follows: bool,
}

impl PriorInstance {
    /// An instance of `history` (oldest first) whose next positions are `future` (1 to
    /// [`HORIZON`] of them, the forecast's first steps scored); `follows` when the instance
    /// before it in its list is the same agent one step earlier. `None` for an empty history or
    /// a future of another length.
    #[must_use]
    pub fn new(history: Vec<BevState>, future: Vec<Point2>, follows: bool) -> Option<Self> {
        (!history.is_empty() && (1..=HORIZON).contains(&future.len())).then_some(Self { history, future, follows })
    }
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
            let mut previous = None;
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
                out.push(PriorInstance {
                    history: history.to_vec(),
                    future: future.iter().map(BevState::position).collect(),
                    follows: previous == Some(s - 1),
                });
                previous = Some(s);
            }
        }
    }
    out
}

/// Mean ADE and mean ACE (metres) of one predictor over a list of instances.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PriorScore {
    /// Mean ADE over the instances.
    pub ade: f64,
    /// Mean ACE over the pairs of consecutive instances (0 when there are none).
    pub ace: f64,
}

impl PriorScore {
    /// What no setting should be chosen for: a predictor that failed on an instance.
    const FAILED: Self = Self { ade: f64::INFINITY, ace: f64::INFINITY };
}

/// [`PriorScore`] of `predictor` over `instances`, each forecast that follows another blended
/// with it as [`Predictor::carry`] says (a predictor that cannot forecast one of them scores
/// infinitely far, so it never wins).
#[must_use]
pub fn score(predictor: &mut impl Predictor, instances: &[PriorInstance], dt: f32) -> PriorScore {
    if instances.is_empty() {
        return PriorScore::FAILED;
    }
    let mut out: Forecast = [Point2::default(); HORIZON];
    let mut before: Forecast = [Point2::default(); HORIZON];
    let (mut ade_sum, mut ace_sum, mut pairs) = (0.0f64, 0.0f64, 0usize);
    for inst in instances {
        if predictor.predict(&inst.history, dt, &mut out).is_err() {
            return PriorScore::FAILED;
        }
        if inst.follows {
            carry_forward(&before, predictor.carry(), &mut out);
        }
        let ade: f32 =
            out.iter().zip(&inst.future).map(|(p, q)| p.distance(q)).sum::<f32>() / inst.future.len().max(1) as f32;
        ade_sum += f64::from(ade);
        if let (true, Some(a)) = (inst.follows, ace(&before, &out)) {
            ace_sum += f64::from(a);
            pairs += 1;
        }
        before = out;
    }
    PriorScore { ade: ade_sum / instances.len() as f64, ace: if pairs == 0 { 0.0 } else { ace_sum / pairs as f64 } }
}

/// Mean ADE (metres) of the prior with `settings` over `instances` (instances it cannot
/// forecast count as infinitely far, so such settings never win).
#[must_use]
pub fn prior_ade(settings: &PriorSettings, instances: &[PriorInstance], dt: f32) -> f64 {
    score(&mut MotionPrior(*settings), instances, dt).ade
}

/// The best of `candidates` under `objective` (the first among equals), on every core;
/// `cv_ace` is constant velocity's mean ACE on the same instances.
fn best(
    candidates: Vec<PriorSettings>,
    instances: &[PriorInstance],
    dt: f32,
    objective: PriorObjective,
    cv_ace: f64,
) -> PriorSettings {
    // Compared as (excess over an ACE bound, cost): the first part is 0 unless the objective
    // bounds ACE.
    let key = |s: &PriorScore| match objective {
        PriorObjective::Ade => (0.0, s.ade),
        PriorObjective::AdeWithinCvAce => ((s.ace - cv_ace).max(0.0), s.ade),
        PriorObjective::AdePlusAce => (0.0, s.ade + s.ace),
    };
    let scored: Vec<(PriorSettings, (f64, f64))> = candidates
        .into_par_iter()
        .map(|c| {
            let s = score(&mut MotionPrior(c), instances, dt);
            (c, key(&s))
        })
        .collect();
    scored
        .into_iter()
        .fold((PriorSettings::OFF, (f64::INFINITY, f64::INFINITY)), |b, c| if c.1 < b.1 { c } else { b })
        .0
}

/// The settings the coordinate descent of the module docs chooses on `instances` under
/// `objective`; [`PriorSettings::OFF`] when there are none.
#[must_use]
pub fn tune_prior(instances: &[PriorInstance], dt: f32, objective: PriorObjective) -> PriorSettings {
    if instances.is_empty() {
        return PriorSettings::OFF;
    }
    let cv_ace = score(&mut Baseline::ConstantVelocity, instances, dt).ace;
    let best = |candidates| best(candidates, instances, dt, objective, cv_ace);
    let per_carry: Vec<PriorSettings> = CARRY_PERCENTS
        .iter()
        .map(|&carry_percent| descend(PriorSettings { carry_percent, ..PriorSettings::OFF }, dt, &best))
        .collect();
    best(per_carry)
}

/// Steps 1-3 of the module docs from `off` (whose carry every candidate keeps).
fn descend(off: PriorSettings, dt: f32, best: &impl Fn(Vec<PriorSettings>) -> PriorSettings) -> PriorSettings {
    let v = best(velocity_windows(dt).into_iter().map(|w| PriorSettings { velocity_window: w, ..off }).collect());
    let mut accel = Vec::new();
    for &trend_window in &TREND_WINDOWS {
        for &accel_gain in &GAINS {
            for &accel_decay in &DECAYS {
                accel.push(PriorSettings { trend_window, accel_gain, accel_decay, ..v });
            }
        }
    }
    let a = best(accel);
    let mut turn = Vec::new();
    for &trend_window in &TREND_WINDOWS {
        for &turn_gain in &GAINS {
            for &turn_decay in &DECAYS {
                turn.push(PriorSettings { trend_window, turn_gain, turn_decay, ..a });
            }
        }
    }
    best(turn)
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
                PriorInstance { history: states[..PRIOR_STATES].to_vec(), future: future.to_vec(), follows: false }
            })
            .collect()
    }

    /// Consecutive instances of one long braking run whose positions wobble 10 cm along the
    /// track (a smoothed source's slow error): the trend's fits follow the wobble, so the
    /// prior that carries the braking forecasts less consistently than a straight line.
    fn wobbling_brake(n: usize) -> Vec<PriorInstance> {
        let dt = 0.05;
        let mut s = BevState { x: 0.0, y: 0.0, heading: 0.0, speed: 10.0 };
        let mut states = Vec::new();
        for k in 0..n + PRIOR_STATES + HORIZON {
            let t = k as f32 * dt;
            s = unicycle_step(&s, 0.0, -1.0, dt);
            let wobble = 0.1 * (t * 4.0).sin();
            states.push(BevState { x: s.x + wobble, y: s.y, ..s });
        }
        (0..n)
            .map(|i| {
                let now = i + PRIOR_STATES - 1;
                let mut future = [Point2::default(); HORIZON];
                for (f, st) in future.iter_mut().zip(&states[now + 1..]) {
                    *f = st.position();
                }
                PriorInstance { history: states[i..=now].to_vec(), future: future.to_vec(), follows: i > 0 }
            })
            .collect()
    }

    #[test]
    fn the_last_displacement_is_a_window_at_walking_rates_only() {
        assert_eq!(velocity_windows(0.05), VELOCITY_WINDOWS.to_vec(), "20 Hz");
        assert_eq!(velocity_windows(0.1), VELOCITY_WINDOWS.to_vec(), "10 Hz");
        assert_eq!(velocity_windows(0.4), vec![2, 3, 5, 7, 9, 11], "2.5 Hz");
    }

    #[test]
    fn steady_braking_is_learned_and_beats_no_prior() {
        let dt = 0.05;
        let inst = braking(8);
        let chosen = tune_prior(&inst, dt, PriorObjective::Ade);
        assert!(chosen.accel_gain >= 0.75 && chosen.accel_decay == 1.0, "{chosen:?}");
        assert!(prior_ade(&chosen, &inst, dt) < 0.5 * prior_ade(&PriorSettings::OFF, &inst, dt));
        assert!(chosen.is_valid());
        assert_eq!(tune_prior(&[], dt, PriorObjective::Ade), PriorSettings::OFF);
    }

    #[test]
    fn an_ace_bound_keeps_the_prior_as_consistent_as_cv() {
        let dt = 0.05;
        let inst = wobbling_brake(120);
        let cv = score(&mut Baseline::ConstantVelocity, &inst, dt);
        assert!(cv.ace > 0.0, "consecutive instances give ACE pairs");
        let by_ade = tune_prior(&inst, dt, PriorObjective::Ade);
        let by_ade_score = score(&mut MotionPrior(by_ade), &inst, dt);
        // The test means something only where the ADE choice is the less consistent one.
        assert!(by_ade_score.ace > cv.ace, "{by_ade_score:?} against cv {cv:?}");
        let bounded = tune_prior(&inst, dt, PriorObjective::AdeWithinCvAce);
        let bounded_score = score(&mut MotionPrior(bounded), &inst, dt);
        assert!(bounded_score.ace <= cv.ace, "{bounded_score:?} against cv {cv:?}");
        assert!(bounded_score.ade >= by_ade_score.ade);
        let summed = score(&mut MotionPrior(tune_prior(&inst, dt, PriorObjective::AdePlusAce)), &inst, dt);
        assert!(summed.ade + summed.ace <= by_ade_score.ade + by_ade_score.ace);
    }

    /// Consecutive instances of one steady run whose positions jitter by up to 5 cm from frame
    /// to frame (a label's noise).
    fn jittering(n: usize) -> Vec<PriorInstance> {
        let dt = 0.05;
        let mut s = BevState { x: 0.0, y: 0.0, heading: 0.0, speed: 10.0 };
        let mut states = Vec::new();
        for k in 0..n + PRIOR_STATES + HORIZON {
            s = unicycle_step(&s, 0.0, 0.0, dt);
            let jitter = 0.05 * ((k * 7919 % 13) as f32 / 6.0 - 1.0);
            states.push(BevState { x: s.x, y: s.y + jitter, ..s });
        }
        (0..n)
            .map(|i| {
                let now = i + PRIOR_STATES - 1;
                let future = states[now + 1..=now + HORIZON].iter().map(BevState::position).collect();
                PriorInstance { history: states[i..=now].to_vec(), future, follows: i > 0 }
            })
            .collect()
    }

    #[test]
    fn carrying_the_last_forecast_makes_consecutive_forecasts_agree() {
        let dt = 0.05;
        let inst = jittering(120);
        let fresh = PriorSettings { accel_gain: 1.0, trend_window: 11, ..PriorSettings::OFF };
        let (a, b) = (
            score(&mut MotionPrior(fresh), &inst, dt),
            score(&mut MotionPrior(PriorSettings { carry_percent: 50, ..fresh }), &inst, dt),
        );
        assert!(b.ace < 0.7 * a.ace, "carried {b:?} against fresh {a:?}");
        // Instances that do not follow one another are scored as made.
        let apart: Vec<PriorInstance> = inst.iter().cloned().map(|i| PriorInstance { follows: false, ..i }).collect();
        let (c, d) = (
            score(&mut MotionPrior(fresh), &apart, dt),
            score(&mut MotionPrior(PriorSettings { carry_percent: 50, ..fresh }), &apart, dt),
        );
        assert_eq!(c, d);
        // The bounded choice may carry; whatever it picks is within the grid.
        let bounded = tune_prior(&inst, dt, PriorObjective::AdeWithinCvAce);
        assert!(CARRY_PERCENTS.contains(&bounded.carry_percent), "{bounded:?}");
    }
}
