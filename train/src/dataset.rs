//! Training samples: one per test instance of every eligible run, through one source.
//!
//! A sample holds what inference computes from the history (the core's own feature code, so
//! training and the ECU cannot drift apart) and the target: the source's next
//! [`HORIZON`] positions in the agent frame. Each source is trained on its own future, as the
//! paper scores it.
//!
//! Histories: at instance s the agent's history is states[s - MAX_PRIOR_HISTORY ..= s], clipped
//! at the run start (2 to 21 states, oldest first): the motion prior reads up to all of it, the
//! network's rows the newest seven. Neighbours are every other track of the
//! sequence through the same source, split at gaps ([`dynotraj_sources::scene::Scene`], which evaluation
//! uses too), each contributing its states over the same frames if it is present at frame s;
//! `neighbour_sum` keeps the closest within the radius.

use dynotraj_core::limits::{HORIZON, MAX_PRIOR_HISTORY, MIN_HISTORY};
use dynotraj_core::model::arch::{FEATURES, MAX_STEPS};
use dynotraj_core::model::features::{
    FeatureScales, OwnContext, StepFeatures, initial_control, neighbour_sum, state_features,
};
use dynotraj_core::predict::prior::{Controls, plan};
use dynotraj_core::predict::{Context, PriorSettings, unicycle_step};
use dynotraj_core::{BevState, Point2};
use rand::SeedableRng as _;
use rand::seq::SliceRandom as _;
use rand_xoshiro::Xoshiro256PlusPlus;

use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::{EligibilityRule, Source, eligible_runs};

/// One training instance.
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    /// The run it comes from (a global index): samples of one run stay on one side of the
    /// validation split, since consecutive instances of a run are nearly the same.
    pub group: usize,
    /// Real history rows (2..=MAX_STEPS): rows `steps..` of `own` and `neighbours` are zero.
    pub steps: usize,
    /// Own features, oldest first (`state_features`).
    pub own: StepFeatures,
    /// Summed neighbour features aligned with `own` (`neighbour_sum`).
    pub neighbours: StepFeatures,
    /// The decoder's first control input (`initial_control` of the newest row).
    pub initial_control: [f32; 2],
    /// The unicycle's initial speed, m/s (the motion prior's start).
    pub speed: f32,
    /// The motion prior's controls (turn rate, acceleration) per step: the network's output
    /// is added to them.
    pub prior: Controls,
    /// Future positions, frames s+1 ..= s+horizon, agent frame, metres (zero after them).
    pub future: [Point2; HORIZON],
    /// Future steps trained on and scored (at most [`HORIZON`]: a benchmark whose horizon is
    /// shorter trains the decoder's first steps only).
    pub horizon: usize,
    /// The last step of the history (previous position to current), agent frame, metres: what
    /// constant velocity repeats.
    pub last_step: Point2,
}

impl Sample {
    /// The newest own feature row.
    #[must_use]
    pub fn current_row(&self) -> [f32; FEATURES] {
        self.own.get(self.steps.saturating_sub(1)).copied().unwrap_or([0.0; FEATURES])
    }

    /// ADE (metres) of the constant-velocity forecast from the last two positions (core's
    /// `constant_velocity`), the reference a learned forecast should beat.
    #[must_use]
    pub fn constant_velocity_ade(&self) -> f32 {
        self.straight_line_ade(self.last_step)
    }

    /// ADE (metres) of the forecast at zero residual: the motion prior's, at frame period `dt`.
    #[must_use]
    pub fn prior_ade(&self, dt: f32) -> f32 {
        let mut state = BevState { x: 0.0, y: 0.0, heading: 0.0, speed: self.speed };
        let sum: f32 = self
            .prior
            .iter()
            .zip(self.scored_future())
            .map(|([w, a], p)| {
                state = unicycle_step(&state, *w, *a, dt);
                (state.x - p.x).hypot(state.y - p.y)
            })
            .sum();
        sum / self.horizon as f32
    }

    /// The future positions trained on and scored.
    #[must_use]
    pub fn scored_future(&self) -> &[Point2] {
        self.future.get(..self.horizon).unwrap_or(&self.future)
    }

    /// ADE (metres) of the forecast that moves by `step` (agent frame) every frame.
    fn straight_line_ade(&self, step: Point2) -> f32 {
        let sum: f32 = self
            .scored_future()
            .iter()
            .enumerate()
            .map(|(k, p)| ((k + 1) as f32 * step.x - p.x).hypot((k + 1) as f32 * step.y - p.y))
            .sum();
        sum / self.horizon as f32
    }

    /// The same instance reflected across the agent's heading axis (y -> -y): a car turning
    /// left becomes one turning right. Traffic has no preferred side at these horizons, so the
    /// reflection is as likely as the original; it doubles the training instances of a data
    /// set of about 65 runs per fold.
    #[must_use]
    pub fn mirrored(&self) -> Self {
        let flip = |rows: &StepFeatures| {
            rows.map(|r| core::array::from_fn(|i| if MIRRORED_FEATURES.contains(&i) { -r[i] } else { r[i] }))
        };
        let [w, a] = self.initial_control;
        Self {
            own: flip(&self.own),
            neighbours: flip(&self.neighbours),
            initial_control: [-w, a],
            prior: self.prior.map(|[w, a]| [-w, a]),
            future: self.future.map(|p| Point2::new(p.x, -p.y)),
            last_step: Point2::new(self.last_step.x, -self.last_step.y),
            ..self.clone()
        }
    }
}

/// Feature columns that change sign under a reflection across the agent's x axis: y, vy, ay,
/// relative heading, heading rate and the prior's turn rate (see `state_features`).
const MIRRORED_FEATURES: [usize; 6] = [1, 3, 5, 6, 7, 10];

/// The sample of instance `s` of `states` (one source's consecutive states, from its run's
/// start), in `context` (neighbour histories ending at the same frame, the observer), over
/// motion prior `prior`. `None` when s has no earlier frame or fewer than [`HORIZON`] later
/// ones, or a state is not finite.
#[must_use]
pub fn sample_at(
    states: &[BevState],
    s: usize,
    context: &Context<'_>,
    dt: f32,
    group: usize,
    prior: &PriorSettings,
) -> Option<Sample> {
    sample_over(states, s, HORIZON, context, dt, group, prior, &FeatureScales::VEHICLE)
}

/// [`sample_at`] with `horizon` future steps (at most [`HORIZON`]), features standardised by
/// `scales` (those of the dynamics the model is trained with).
#[must_use]
#[expect(clippy::too_many_arguments, reason = "sample_at's inputs and the two a benchmark of its own sets")]
pub fn sample_over(
    states: &[BevState],
    s: usize,
    horizon: usize,
    context: &Context<'_>,
    dt: f32,
    group: usize,
    prior: &PriorSettings,
    scales: &FeatureScales,
) -> Option<Sample> {
    if s < MIN_HISTORY || horizon == 0 || horizon > HORIZON {
        return None;
    }
    let history = states.get(s.saturating_sub(MAX_PRIOR_HISTORY)..=s)?;
    let future_states = states.get(s + 1..=s + horizon)?;
    if !history.iter().chain(future_states).all(BevState::is_finite) {
        return None;
    }
    let plan = plan(history, prior, dt)?;
    let frame = plan.frame;
    let mut own = [[0.0; FEATURES]; MAX_STEPS];
    let own_context = OwnContext::of(history, context.observer, plan.trend);
    let steps = state_features(history, &frame, dt, Some(&own_context), scales, &mut own);
    let mut summed = [[0.0; FEATURES]; MAX_STEPS];
    let finite: Vec<&[BevState]> =
        context.neighbours.iter().copied().filter(|h| h.iter().all(BevState::is_finite)).collect();
    neighbour_sum(&finite, &frame, steps, dt, scales, &mut summed);
    let mut future = [Point2::default(); HORIZON];
    for (f, st) in future.iter_mut().zip(future_states) {
        *f = frame.to_agent(&st.position());
    }
    let initial_control = initial_control(own.get(steps - 1)?, scales);
    let [.., before, now] = history else { return None };
    let (before, now) = (frame.to_agent(&before.position()), frame.to_agent(&now.position()));
    Some(Sample {
        group,
        steps,
        own,
        neighbours: summed,
        initial_control,
        speed: plan.speed,
        prior: plan.controls,
        future,
        horizon,
        last_step: Point2::new(now.x - before.x, now.y - before.y),
    })
}

/// The samples of every eligible run of `seq` under `rule`, through `source` at frame period
/// `dt`, with the features of `scales` (the dynamics trained); run k of the sequence gets group
/// `first_group + k`. Returns the samples and the number of runs.
#[must_use]
pub fn sequence_samples(
    seq: &SequenceTracks,
    source: Source,
    dt: f32,
    rule: &EligibilityRule,
    first_group: usize,
    (prior, scales): (&PriorSettings, &FeatureScales),
) -> (Vec<Sample>, usize) {
    let tracks = seq.tracks_for(source);
    let scene = seq.scene(source, dt);
    let runs = eligible_runs(tracks, rule);
    let mut out = Vec::new();
    for (k, run) in runs.iter().enumerate() {
        let states = source.apply(&run.states, dt);
        for s in run.instances() {
            let frame = run.first_frame + s as u32;
            let neighbours = scene.neighbours_at(run.track_id, frame);
            let context = scene.context_at(&neighbours, frame);
            out.extend(sample_over(&states, s, HORIZON, &context, dt, first_group + k, prior, scales));
        }
    }
    (out, runs.len())
}

/// Training and validation samples.
#[derive(Debug, Clone, Default)]
pub struct Split {
    /// Samples to fit.
    pub train: Vec<Sample>,
    /// Held-out samples for early stopping.
    pub validation: Vec<Sample>,
}

/// Splits `samples` by run: a seeded shuffle of the `groups` run indices puts
/// round(`fraction` * groups) of them (at least one when there are two or more runs, never
/// all) in validation.
#[must_use]
pub fn split_by_run(samples: Vec<Sample>, groups: usize, fraction: f32, seed: u64) -> Split {
    let mut ids: Vec<usize> = (0..groups).collect();
    ids.shuffle(&mut Xoshiro256PlusPlus::seed_from_u64(seed));
    let wanted = (fraction.clamp(0.0, 1.0) * groups as f32).round() as usize;
    let n_val = if groups >= 2 { wanted.clamp(1, groups - 1) } else { 0 };
    let mut is_val = vec![false; groups];
    for &g in ids.iter().take(n_val) {
        is_val[g] = true;
    }
    let (validation, train) = samples.into_iter().partition(|s| is_val.get(s.group).copied().unwrap_or(false));
    Split { train, validation }
}

/// Splits samples grouped by sequence (`per_sequence`) by whole sequences: a seeded shuffle of
/// the sequences moves them into validation until it holds at least `fraction` of the
/// samples, never all sequences. Why: a fold's test sequence is another place and traffic,
/// and runs of the training sequences judge a model on the traffic it was trained on; a held-out
/// sequence asks what the test asks, whether the learned correction transfers.
#[must_use]
pub fn split_by_sequence(per_sequence: Vec<Vec<Sample>>, fraction: f32, seed: u64) -> Split {
    let total: usize = per_sequence.iter().map(Vec::len).sum();
    let wanted = (fraction.clamp(0.0, 1.0) * total as f32).ceil() as usize;
    let mut ids: Vec<usize> = (0..per_sequence.len()).collect();
    ids.shuffle(&mut Xoshiro256PlusPlus::seed_from_u64(seed));
    let (mut is_val, mut held) = (vec![false; per_sequence.len()], 0);
    for &i in ids.iter().take(per_sequence.len().saturating_sub(1)) {
        if held >= wanted {
            break;
        }
        is_val[i] = true;
        held += per_sequence[i].len();
    }
    let mut split = Split::default();
    for (samples, val) in per_sequence.into_iter().zip(is_val) {
        if val { split.validation.extend(samples) } else { split.train.extend(samples) }
    }
    split
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(n: usize, speed: f32, dt: f32) -> Vec<BevState> {
        (0..n).map(|k| BevState { x: 5.0 + speed * dt * k as f32, y: 2.0, heading: 0.0, speed }).collect()
    }

    #[test]
    fn samples_follow_the_instance_rules() {
        let dt = 0.05;
        let states = line(40, 10.0, dt);
        assert!(sample_at(&states, 0, &Context::NONE, dt, 0, &PriorSettings::DEFAULT).is_none(), "no history frame");
        assert!(sample_at(&states, 10, &Context::NONE, dt, 0, &PriorSettings::DEFAULT).is_none(), "no full horizon");
        let s = sample_at(&states, 3, &Context::NONE, dt, 7, &PriorSettings::DEFAULT).unwrap();
        assert_eq!((s.steps, s.group), (4, 7));
        assert_eq!(s.own[4], [0.0; FEATURES]);
        // One frame ahead along the heading: 0.5 m.
        assert!((s.future[0].x - 0.5).abs() < 1e-4 && s.future[0].y.abs() < 1e-5);
        assert!((s.future[HORIZON - 1].x - 15.0).abs() < 1e-3);
        assert!((s.speed - 10.0).abs() < 1e-3);
        assert_eq!(sample_at(&states, 9, &Context::NONE, dt, 0, &PriorSettings::DEFAULT).unwrap().steps, MAX_STEPS);
        assert!(s.constant_velocity_ade() < 1e-3);
        // Whatever the features are scaled by: a walker at 1.25 m/s, 2.5 Hz, 12 steps.
        let walk = line(30, 1.25, 0.4);
        let p =
            sample_over(&walk, 7, 12, &Context::NONE, 0.4, 0, &PriorSettings::OFF, &FeatureScales::PEDESTRIAN).unwrap();
        assert!(p.constant_velocity_ade() < 1e-4 && (p.last_step.x - 0.5).abs() < 1e-5, "{:?}", p.last_step);
    }

    #[test]
    fn neighbours_are_summed_and_the_split_keeps_runs_whole() {
        let dt = 0.05;
        let states = line(40, 10.0, dt);
        let other: Vec<BevState> = line(40, 10.0, dt).iter().map(|s| BevState { y: s.y + 3.0, ..*s }).collect();
        let s =
            sample_at(&states, 8, &Context::with_neighbours(&[&other[2..=8]]), dt, 0, &PriorSettings::DEFAULT).unwrap();
        assert!((s.neighbours[6][1] - 0.3).abs() < 1e-5, "{:?}", s.neighbours[6]);
        let samples: Vec<Sample> = (0..10)
            .flat_map(|g| {
                (1..5).map(move |k| {
                    sample_at(&line(40, 1.0 + k as f32, dt), k, &Context::NONE, dt, g, &PriorSettings::DEFAULT)
                })
            })
            .flatten()
            .collect();
        let split = split_by_run(samples, 10, 0.2, 1);
        assert_eq!(split.validation.len(), 8);
        assert_eq!(split.train.len(), 32);
        assert!(split.validation.iter().all(|v| split.train.iter().all(|t| t.group != v.group)));
    }

    #[test]
    fn the_sequence_split_holds_out_whole_sequences_and_never_all() {
        let dt = 0.05;
        let seq = |g: usize, n: usize| {
            (0..n)
                .filter_map(|k| {
                    sample_at(&line(40, 5.0, dt), 1 + k % 8, &Context::NONE, dt, g, &PriorSettings::DEFAULT)
                })
                .collect::<Vec<_>>()
        };
        let split = split_by_sequence(vec![seq(0, 10), seq(1, 10), seq(2, 10), seq(3, 10)], 0.3, 2);
        assert_eq!((split.validation.len(), split.train.len()), (20, 20), "two whole sequences reach 30%");
        let groups = |v: &[Sample]| v.iter().map(|s| s.group).collect::<std::collections::BTreeSet<_>>();
        assert!(groups(&split.validation).is_disjoint(&groups(&split.train)));
        let all = split_by_sequence(vec![seq(0, 5), seq(1, 5)], 0.99, 2);
        assert_eq!((all.validation.len(), all.train.len()), (5, 5), "one sequence always stays for training");
    }

    #[test]
    fn the_mirrored_sample_is_the_sample_of_the_reflected_run() {
        let dt = 0.05;
        // A left turn and its reflection across the world x axis (a right turn).
        let turn: Vec<BevState> = (0..40)
            .map(|k| {
                let h = 0.02 * k as f32;
                BevState { x: 5.0 + 20.0 * h.sin(), y: 20.0 * (1.0 - h.cos()), heading: h, speed: 8.0 }
            })
            .collect();
        let reflected: Vec<BevState> = turn.iter().map(|s| BevState { y: -s.y, heading: -s.heading, ..*s }).collect();
        let other: Vec<BevState> = turn.iter().map(|s| BevState { x: s.x + 4.0, y: s.y + 3.0, ..*s }).collect();
        let other_r: Vec<BevState> = other.iter().map(|s| BevState { y: -s.y, heading: -s.heading, ..*s }).collect();
        let a = sample_at(&turn, 6, &Context::with_neighbours(&[&other[..=6]]), dt, 0, &PriorSettings::DEFAULT)
            .unwrap()
            .mirrored();
        let b = sample_at(&reflected, 6, &Context::with_neighbours(&[&other_r[..=6]]), dt, 0, &PriorSettings::DEFAULT)
            .unwrap();
        let close = |x: f32, y: f32| (x - y).abs() < 1e-3;
        assert!(
            a.own.iter().flatten().zip(b.own.iter().flatten()).all(|(x, y)| close(*x, *y)),
            "{:?}\n{:?}",
            a.own,
            b.own
        );
        assert!(a.neighbours.iter().flatten().zip(b.neighbours.iter().flatten()).all(|(x, y)| close(*x, *y)));
        assert!(a.future.iter().zip(&b.future).all(|(p, q)| close(p.x, q.x) && close(p.y, q.y)));
        assert!(close(a.initial_control[0], b.initial_control[0]) && a.initial_control[0].abs() > 0.01);
        assert!(a.future[HORIZON - 1].y < -0.5, "the mirrored turn goes right");
    }
}
