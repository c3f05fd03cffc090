//! Eligible objects and test instances, as the paper defines them.
//!
//! An object is eligible when it is seen in at least `MIN_ELIGIBLE_RUN` (32) consecutive frames
//! (one history frame, the current frame and the 30-frame horizon) and it moves. A test instance
//! is every frame s of such a run with at least one earlier frame (history up to `MAX_HISTORY`)
//! and `HORIZON` later frames in the run.
//!
//! "Moving" (the paper leaves it implicit; many KITTI labels are parked cars): the net
//! displacement between the first and last frame of the run, divided by the run's frame count,
//! is at least `min_step_m` (default 0.1 m per frame, 1 m/s at KITTI's real 10 Hz). Parked cars
//! in these labels drift 0.01-0.05 m per frame through label noise and ego-pose error; the
//! slowest real traffic in sequence 0020 creeps at about 0.1 m per frame.

use dynotraj_core::BevState;
use dynotraj_core::limits::{HORIZON, MIN_ELIGIBLE_RUN, MIN_HISTORY};
use dynotraj_core::predict::Dynamics;
use dynotraj_core::wire::ObjectClass;

use super::ObjectTrack;

/// When a run of frames counts as a moving object.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MovingRule {
    /// Least net displacement per frame, metres.
    pub min_step_m: f32,
}

impl Default for MovingRule {
    fn default() -> Self {
        Self { min_step_m: 0.1 }
    }
}

/// Which runs are eligible.
#[derive(Debug, Clone, PartialEq)]
pub struct EligibilityRule {
    /// Fewest consecutive frames.
    pub min_run: usize,
    /// The moving test.
    pub moving: MovingRule,
    /// Object classes considered.
    pub classes: Vec<ObjectClass>,
}

impl Default for EligibilityRule {
    /// The paper's 32 frames, the documented moving rule, and every forecast class
    /// ([`ObjectClass::FORECAST`]: vehicles, cyclists and pedestrians).
    fn default() -> Self {
        Self { min_run: MIN_ELIGIBLE_RUN, moving: MovingRule::default(), classes: ObjectClass::FORECAST.to_vec() }
    }
}

impl EligibilityRule {
    /// This rule for the agents of `dynamics` only: its classes that `dynamics` forecasts
    /// ([`Dynamics::of_class`]). A model is trained and scored on one agent type.
    #[must_use]
    pub fn for_agents(&self, dynamics: Dynamics) -> Self {
        let classes = self.classes.iter().copied().filter(|&c| Dynamics::of_class(c) == dynamics).collect();
        Self { classes, ..self.clone() }
    }

    /// The agent types among this rule's classes, in [`Dynamics::ALL`] order.
    #[must_use]
    pub fn agent_types(&self) -> Vec<Dynamics> {
        Dynamics::ALL.into_iter().filter(|&d| self.classes.iter().any(|&c| Dynamics::of_class(c) == d)).collect()
    }
}

/// A run of consecutive frames of one object that passes the rule.
#[derive(Debug, Clone, PartialEq)]
pub struct EligibleRun {
    /// Track id.
    pub track_id: i32,
    /// Class.
    pub class: ObjectClass,
    /// Frame of the first state.
    pub first_frame: u32,
    /// GT states, one per consecutive frame.
    pub states: Vec<BevState>,
}

impl EligibleRun {
    /// Indices (into `states`) of the run's test instances.
    #[must_use]
    pub fn instances(&self) -> std::ops::Range<usize> {
        instance_frames(self.states.len())
    }
}

/// Indices of the test instances of a run of `len` consecutive frames: at least `MIN_HISTORY`
/// frames before and `HORIZON` frames after.
#[must_use]
pub fn instance_frames(len: usize) -> std::ops::Range<usize> {
    MIN_HISTORY..len.saturating_sub(HORIZON).max(MIN_HISTORY)
}

/// The eligible runs of `tracks` under `rule`, in track order. An object seen in several long
/// runs (an occlusion gap between them) yields one entry per run.
#[must_use]
pub fn eligible_runs(tracks: &[ObjectTrack], rule: &EligibilityRule) -> Vec<EligibleRun> {
    let mut out = Vec::new();
    for t in tracks.iter().filter(|t| rule.classes.contains(&t.class)) {
        for run in t.runs() {
            let (first_frame, states) = (t.frames[run.start], &t.states[run]);
            if states.len() >= rule.min_run && is_moving(states, &rule.moving) {
                out.push(EligibleRun { track_id: t.track_id, class: t.class, first_frame, states: states.to_vec() });
            }
        }
    }
    out
}

fn is_moving(states: &[BevState], rule: &MovingRule) -> bool {
    match (states.first(), states.last()) {
        (Some(a), Some(b)) => a.position().distance(&b.position()) >= rule.min_step_m * states.len() as f32,
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track(id: i32, frames: Vec<u32>, step: f32) -> ObjectTrack {
        let states = frames.iter().map(|&f| BevState { x: f as f32 * step, ..Default::default() }).collect();
        ObjectTrack { track_id: id, class: ObjectClass::Car, frames, states }
    }

    #[test]
    fn run_length_and_motion_decide() {
        let long_moving = track(1, (0..40).collect(), 1.0);
        let short = track(2, (0..31).collect(), 1.0);
        let parked = track(3, (0..100).collect(), 0.02);
        let gap: Vec<u32> = (0..32).chain(50..60).collect();
        let with_gap = track(4, gap, 1.0);
        let runs = eligible_runs(&[long_moving, short, parked, with_gap], &EligibilityRule::default());
        let ids: Vec<_> = runs.iter().map(|r| (r.track_id, r.states.len())).collect();
        assert_eq!(ids, vec![(1, 40), (4, 32)]);
        // 40 frames: instances at 1..=9 (s + 30 <= 39).
        assert_eq!(runs[0].instances(), 1..10);
        assert_eq!(runs[1].instances().len(), 1);
        assert_eq!(instance_frames(5).len(), 0);
    }

    #[test]
    fn a_rule_splits_into_its_agent_types() {
        let all = EligibilityRule::default();
        assert_eq!(all.agent_types(), vec![Dynamics::Unicycle, Dynamics::SingleIntegrator]);
        let walkers = all.for_agents(Dynamics::SingleIntegrator);
        assert_eq!(walkers.classes, vec![ObjectClass::Pedestrian]);
        assert_eq!(walkers.agent_types(), vec![Dynamics::SingleIntegrator]);
        let drivers = all.for_agents(Dynamics::Unicycle);
        assert!(!drivers.classes.contains(&ObjectClass::Pedestrian) && drivers.classes.contains(&ObjectClass::Cyclist));
        let mut walker = track(5, (0..40).collect(), 0.15);
        walker.class = ObjectClass::Pedestrian;
        let car = track(6, (0..40).collect(), 1.0);
        let runs = |rule: &EligibilityRule| -> Vec<i32> {
            eligible_runs(&[walker.clone(), car.clone()], rule).iter().map(|r| r.track_id).collect()
        };
        assert_eq!(runs(&all), vec![5, 6]);
        assert_eq!(runs(&walkers), vec![5]);
        assert_eq!(runs(&drivers), vec![6]);
    }
}
