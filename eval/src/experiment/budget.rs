//! The error budget of the estimated source: at every test instance of its causal tracks, how
//! far the state a forecaster reads is from the simulator's truth, and how much forecast error
//! that costs.
//!
//! Per instance (frame f of an eligible causal run whose object the simulator also holds at
//! f - 1 ..= f + HORIZON):
//! - position: the object relative to the camera (rotated into the camera's heading), the
//!   estimate's (its object frame's origin) against the truth's (the box centre); mean and
//!   median, since a few lost objects dominate the mean. The two worlds differ by the camera's
//!   drift, so absolute positions are not comparable; the vehicle needs the relative one anyway.
//! - velocity as constant velocity reads it (the last position difference, over `dt`): the
//!   error of its speed (absolute, and signed: a lasting bias survives the mean, noise does
//!   not) and of its direction (turned into the truth's world by the frame's
//!   world yaw). Direction errors count only where the truth moves faster than
//!   [`MOVING_MPS`]: at a standstill a direction means nothing.
//! - the estimate's own speed and heading (the bird's-eye track's velocity; with
//!   `--no-bev-track` the SE(3) motion's speed and the pose's heading), which constant velocity
//!   does not read: the same errors and the constant-velocity ADE from it, to show whether it
//!   is the better input.
//! - turn rate as the motion prior reads it ([`PriorSettings::DEFAULT`]'s trend), estimated
//!   history against true history, where both give a plan.
//! - what the errors cost: the ADE against the true future of constant velocity started from
//!   the true velocity (the floor no state estimate can beat), from the estimate's velocity,
//!   and from the true velocity with only the speed or only the direction taken from the
//!   estimate. Their differences to the floor split the estimator's share by term (the rest is
//!   their interaction).
//!
//! Groups: every instance; per sequence; per true distance band from the camera; per class;
//! and the instances less than [`START_FRAMES`] frames after their run began (a run starts or
//! resumes there), against the later ones.

use std::collections::BTreeMap;

use dynotraj_core::BevState;
use dynotraj_core::geometry::{Point2, angle_diff};
use dynotraj_core::limits::HORIZON;
use dynotraj_core::predict::PriorSettings;
use dynotraj_core::predict::prior::plan;

use crate::report::{Cell, ColumnKind, Data, Table};
use dynotraj_sources::estimation::CameraPair;
use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::{EligibilityRule, ObjectTrack, Source, eligible_runs};

/// True speed below which a velocity's direction is not scored, m/s.
pub const MOVING_MPS: f32 = 1.0;

/// Instances fewer than this many frames after their run's first state are "run start".
pub const START_FRAMES: usize = 10;

/// Upper ends of the distance bands, metres (the last band is open).
pub const DISTANCE_BANDS_M: [f32; 3] = [20.0, 40.0, 80.0];

/// One instance's errors and costs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InstanceErrors {
    /// Position relative to the camera, metres.
    pub position_m: f32,
    /// Speed of the constant-velocity estimate minus the true one, absolute, m/s.
    pub speed_mps: f32,
    /// The same, signed: a lasting bias shows here, noise averages out.
    pub speed_bias_mps: f32,
    /// Direction of the velocity, absolute, radians; `None` when the truth is nearly still.
    pub direction_rad: Option<f32>,
    /// The estimator's own speed (from its SE(3) motion, not from positions), absolute error, m/s.
    pub own_speed_mps: f32,
    /// The same, signed.
    pub own_speed_bias_mps: f32,
    /// The estimator's own heading against the truth's direction of travel, absolute, radians;
    /// `None` when the truth is nearly still.
    pub own_direction_rad: Option<f32>,
    /// The prior's turn rate, absolute error, rad/s; `None` without a plan on either side.
    pub turn_rate_rps: Option<f32>,
    /// ADE of constant velocity from the true velocity, metres.
    pub ade_truth: f32,
    /// ADE of constant velocity from the estimate's velocity, metres.
    pub ade_estimate: f32,
    /// ADE of constant velocity from the estimator's own speed and heading, metres.
    pub ade_own: f32,
    /// ADE from the true direction at the estimate's speed, metres.
    pub ade_speed_only: f32,
    /// ADE from the true speed in the estimate's direction, metres.
    pub ade_direction_only: f32,
}

/// Where an instance belongs.
#[derive(Debug, Clone, PartialEq)]
pub struct Tagged {
    /// Sequence id.
    pub sequence: String,
    /// Class name.
    pub class: String,
    /// True distance from the camera, metres.
    pub distance_m: f32,
    /// Frames since its run's first state.
    pub since_start: usize,
    /// The errors.
    pub errors: InstanceErrors,
}

/// The ADE of holding velocity `v` from the origin against the displacements `truth`.
fn ade_of_velocity(v: Point2, truth: &[Point2], dt: f32) -> f32 {
    let n = truth.len().max(1) as f32;
    truth
        .iter()
        .enumerate()
        .map(|(k, t)| {
            let s = (k + 1) as f32 * dt;
            Point2::new(v.x * s, v.y * s).distance(t)
        })
        .sum::<f32>()
        / n
}

fn rotate(p: Point2, angle: f32) -> Point2 {
    let (s, c) = angle.sin_cos();
    Point2::new(c * p.x - s * p.y, s * p.x + c * p.y)
}

fn relative(p: Point2, camera: &BevState) -> Point2 {
    rotate(Point2::new(p.x - camera.x, p.y - camera.y), -camera.heading)
}

/// The true states of `truth` at frames `from..=to`, or `None` where one is missing.
fn truth_span(truth: &ObjectTrack, from: u32, to: u32) -> Option<&[BevState]> {
    let start = truth.frames.binary_search(&from).ok()?;
    let end = start + usize::try_from(to.checked_sub(from)?).ok()?;
    (truth.frames.get(end) == Some(&to)).then_some(())?;
    truth.states.get(start..=end)
}

/// The errors of one instance (estimated history `history`, current last, at frame `frame`)
/// and the truth's distance from the camera, metres.
fn instance_errors(
    history: &[BevState],
    frame: u32,
    truth: &ObjectTrack,
    camera: &CameraPair,
    dt: f32,
) -> Option<(InstanceErrors, f32)> {
    let [.., prev, cur] = history else { return None };
    let first = frame.checked_sub(u32::try_from(history.len() - 1).ok()?)?;
    let past = truth_span(truth, frame.checked_sub(1)?, frame)?;
    let future = truth_span(truth, frame, frame + HORIZON as u32)?;
    let [t_prev, t_cur] = past else { return None };
    let anchor = t_cur.position();
    let displacements: Vec<Point2> =
        future.iter().skip(1).map(|p| Point2::new(p.x - anchor.x, p.y - anchor.y)).collect();
    let yaw = camera.world_yaw();
    let v_est = rotate(Point2::new((cur.x - prev.x) / dt, (cur.y - prev.y) / dt), yaw);
    let v_true = Point2::new((t_cur.x - t_prev.x) / dt, (t_cur.y - t_prev.y) / dt);
    let (speed_est, speed_true) = (v_est.x.hypot(v_est.y), v_true.x.hypot(v_true.y));
    let (dir_est, dir_true) = (v_est.y.atan2(v_est.x), v_true.y.atan2(v_true.x));
    let along = |speed: f32, dir: f32| Point2::new(speed * dir.cos(), speed * dir.sin());
    let true_relative = relative(anchor, &camera.truth);
    let position = relative(cur.position(), &camera.estimate).distance(&true_relative);
    let true_history = truth_span(truth, first.max(truth.frames.first().copied()?), frame);
    let own_dir = cur.heading + yaw;
    let turn_rate = true_history.and_then(|th| {
        let (e, t) = (plan(history, &PriorSettings::DEFAULT, dt)?, plan(th, &PriorSettings::DEFAULT, dt)?);
        Some((e.trend.turn_rate - t.trend.turn_rate).abs())
    });
    let errors = InstanceErrors {
        position_m: position,
        speed_mps: (speed_est - speed_true).abs(),
        speed_bias_mps: speed_est - speed_true,
        direction_rad: (speed_true >= MOVING_MPS).then(|| angle_diff(dir_est, dir_true).abs()),
        own_speed_mps: (cur.speed - speed_true).abs(),
        own_speed_bias_mps: cur.speed - speed_true,
        own_direction_rad: (speed_true >= MOVING_MPS).then(|| angle_diff(own_dir, dir_true).abs()),
        turn_rate_rps: turn_rate,
        ade_truth: ade_of_velocity(v_true, &displacements, dt),
        ade_estimate: ade_of_velocity(v_est, &displacements, dt),
        ade_own: ade_of_velocity(along(cur.speed, own_dir), &displacements, dt),
        ade_speed_only: ade_of_velocity(along(speed_est, dir_true), &displacements, dt),
        ade_direction_only: ade_of_velocity(along(speed_true, dir_est), &displacements, dt),
    };
    Some((errors, true_relative.distance(&Point2::new(0.0, 0.0))))
}

/// Every scored instance of the estimated source's causal tracks in `sequences` (those without
/// the simulator's truth are skipped), with the history the forecasters read (the prior's).
#[must_use]
pub fn budget_instances(sequences: &[SequenceTracks], rule: &EligibilityRule, dt: f32) -> Vec<Tagged> {
    let mut out = Vec::new();
    for seq in sequences {
        let Some(est) = &seq.estimated else { continue };
        let truth: BTreeMap<i32, &ObjectTrack> = est.truth.iter().map(|t| (t.track_id, t)).collect();
        for run in eligible_runs(seq.tracks_for(Source::Estimated), rule) {
            let Some(t) = truth.get(&run.track_id) else { continue };
            for s in run.instances() {
                let frame = run.first_frame + s as u32;
                let Some(camera) = est.cameras.get(&frame) else { continue };
                let from = s.saturating_sub(PriorSettings::DEFAULT.states() - 1);
                let Some(history) = run.states.get(from..=s) else { continue };
                let Some((errors, distance_m)) = instance_errors(history, frame, t, camera, dt) else { continue };
                out.push(Tagged {
                    sequence: seq.id.clone(),
                    class: format!("{:?}", run.class),
                    distance_m,
                    since_start: s,
                    errors,
                });
            }
        }
    }
    out
}

/// The distance band of `d` metres, as its row label.
#[must_use]
pub fn distance_band(d: f32) -> String {
    let mut low = 0.0;
    for high in DISTANCE_BANDS_M {
        if d < high {
            return format!("{low:.0}-{high:.0} m");
        }
        low = high;
    }
    format!("{low:.0}+ m")
}

/// Means of a group's instances, in the order of [`COLUMNS`] after the instance count.
fn means(group: &[&Tagged]) -> [f64; 14] {
    let mean = |f: &dyn Fn(&InstanceErrors) -> Option<f32>| {
        let v: Vec<f64> = group.iter().filter_map(|t| f(&t.errors)).map(f64::from).collect();
        if v.is_empty() { f64::NAN } else { v.iter().sum::<f64>() / v.len() as f64 }
    };
    let floor = mean(&|e| Some(e.ade_truth));
    let mut positions: Vec<f32> = group.iter().map(|t| t.errors.position_m).collect();
    positions.sort_by(f32::total_cmp);
    let median = positions.get(positions.len() / 2).map_or(f64::NAN, |&p| f64::from(p));
    [
        mean(&|e| Some(e.position_m)),
        median,
        mean(&|e| Some(e.speed_mps)),
        mean(&|e| Some(e.speed_bias_mps)),
        mean(&|e| e.direction_rad).to_degrees(),
        mean(&|e| Some(e.own_speed_mps)),
        mean(&|e| Some(e.own_speed_bias_mps)),
        mean(&|e| e.own_direction_rad).to_degrees(),
        mean(&|e| e.turn_rate_rps).to_degrees(),
        floor,
        mean(&|e| Some(e.ade_estimate)),
        mean(&|e| Some(e.ade_speed_only)) - floor,
        mean(&|e| Some(e.ade_direction_only)) - floor,
        mean(&|e| Some(e.ade_own)),
    ]
}

/// The budget's columns after the instance count: Markdown header, data name, decimals.
const COLUMNS: [(&str, &str, usize); 14] = [
    ("position (m)", "position_m", 3),
    ("position, median (m)", "position_median_m", 3),
    ("speed, cv (m/s)", "speed_mps", 3),
    ("speed bias, cv (m/s)", "speed_bias_mps", 3),
    ("direction, cv (deg)", "direction_deg", 1),
    ("speed, estimator (m/s)", "own_speed_mps", 3),
    ("speed bias, estimator (m/s)", "own_speed_bias_mps", 3),
    ("heading, estimator (deg)", "own_heading_deg", 1),
    ("turn rate, prior (deg/s)", "turn_rate_deg_s", 1),
    ("cv ADE from truth (m)", "cv_ade_truth_m", 3),
    ("cv ADE from Ours (m)", "cv_ade_estimate_m", 3),
    ("of which speed (m)", "speed_share_m", 3),
    ("of which direction (m)", "direction_share_m", 3),
    ("cv ADE from the estimator's velocity (m)", "cv_ade_own_m", 3),
];

/// The budget table: one row per group (every instance, per sequence, per distance band, per
/// class, run start against later).
#[must_use]
pub fn budget_table(instances: &[Tagged]) -> Table {
    use ColumnKind::{Int, Num, Text};
    let mut headers = vec!["group", "instances"];
    headers.extend(COLUMNS.iter().map(|c| c.0));
    let mut d = Data::new([("group_kind", Text), ("group", Text), ("instances", Int)]);
    d.columns.extend(Data::new(COLUMNS.iter().map(|c| (c.1, Num))).columns);
    let mut rows: Vec<(String, String, Vec<&Tagged>)> = vec![("all".into(), "all".into(), instances.iter().collect())];
    let mut grouped = |kind: &str, key: &dyn Fn(&Tagged) -> String| {
        let mut by: BTreeMap<String, Vec<&Tagged>> = BTreeMap::new();
        for t in instances {
            by.entry(key(t)).or_default().push(t);
        }
        rows.extend(by.into_iter().map(|(k, v)| (kind.to_string(), k, v)));
    };
    grouped("sequence", &|t| t.sequence.clone());
    grouped("distance", &|t| distance_band(t.distance_m));
    grouped("class", &|t| t.class.clone());
    grouped("run", &|t| {
        if t.since_start < START_FRAMES { format!("run start (< {START_FRAMES} frames)") } else { "later".into() }
    });
    let mut t = Table::new(headers);
    for (kind, group, members) in &rows {
        let m = means(members);
        let label = if kind == "all" || kind == "run" { group.clone() } else { format!("{kind} {group}") };
        let mut cells = vec![Cell::int(members.len())];
        cells.extend(m.iter().zip(COLUMNS).map(|(&v, c)| Cell::num(v, c.2)));
        t.push(std::iter::once(label).chain(cells.iter().map(Cell::md)));
        d.push([Cell::text(kind.as_str()), Cell::text(group.as_str())].into_iter().chain(cells).collect());
    }
    t.with_data(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn straight(first: u32, n: usize, speed: f32, dt: f32) -> ObjectTrack {
        ObjectTrack {
            track_id: 0,
            class: dynotraj_core::wire::ObjectClass::Car,
            frames: (first..first + n as u32).collect(),
            states: (0..n).map(|k| BevState { x: 10.0 + speed * dt * k as f32, y: 5.0, heading: 0.0, speed }).collect(),
        }
    }

    #[test]
    fn a_perfect_estimate_costs_nothing_and_a_slow_one_costs_its_speed() {
        let dt = 0.05;
        let truth = straight(0, 60, 10.0, dt);
        let camera = BevState { x: 0.0, y: 0.0, heading: 0.0, speed: 0.0 };
        let pair = CameraPair { truth: camera, estimate: camera };
        let history = &truth.states[..=20];
        let e = instance_errors(history, 20, &truth, &pair, dt).unwrap().0;
        assert!(e.position_m < 1e-4 && e.speed_mps < 1e-3 && e.ade_estimate < 1e-3, "{e:?}");
        assert!(e.direction_rad.unwrap() < 1e-3 && e.turn_rate_rps.unwrap() < 1e-3, "{e:?}");
        // The same path at 8 m/s instead of 10: 2 m/s of speed error, all of it the speed's share.
        let slow = straight(0, 21, 8.0, dt);
        let e = instance_errors(&slow.states, 20, &truth, &pair, dt).unwrap().0;
        assert!((e.speed_mps - 2.0).abs() < 1e-2 && (e.own_speed_mps - 2.0).abs() < 1e-4, "{e:?}");
        assert!((e.speed_bias_mps + 2.0).abs() < 1e-2 && (e.own_speed_bias_mps + 2.0).abs() < 1e-4, "slow: {e:?}");
        assert!((e.ade_own - e.ade_speed_only).abs() < 1e-3, "the estimator's own speed says the same: {e:?}");
        let expected = 2.0 * dt * (1..=HORIZON).map(|k| k as f32).sum::<f32>() / HORIZON as f32;
        assert!((e.ade_estimate - expected).abs() < 1e-2 && (e.ade_speed_only - expected).abs() < 1e-2, "{e:?}");
        assert!(e.ade_direction_only < 1e-3, "{e:?}");
    }

    #[test]
    fn a_camera_turned_in_its_own_world_changes_neither_position_nor_direction() {
        let dt = 0.05;
        let truth = straight(0, 60, 10.0, dt);
        // The estimator's world turned by 0.3 rad about its origin: the same scene.
        let turn = |s: &BevState| {
            let p = rotate(s.position(), 0.3);
            BevState { x: p.x, y: p.y, heading: s.heading + 0.3, speed: s.speed }
        };
        let camera = BevState { x: 2.0, y: -1.0, heading: 0.1, speed: 0.0 };
        let pair = CameraPair { truth: camera, estimate: turn(&camera) };
        let history: Vec<BevState> = truth.states[..=20].iter().map(turn).collect();
        let e = instance_errors(&history, 20, &truth, &pair, dt).unwrap().0;
        assert!(e.position_m < 1e-3 && e.direction_rad.unwrap() < 1e-3 && e.ade_estimate < 1e-3, "{e:?}");
    }

    #[test]
    fn bands_and_missing_truth() {
        assert_eq!(distance_band(5.0), "0-20 m");
        assert_eq!(distance_band(39.9), "20-40 m");
        assert_eq!(distance_band(120.0), "80+ m");
        let dt = 0.05;
        let truth = straight(0, 40, 10.0, dt);
        let camera = BevState { x: 0.0, y: 0.0, heading: 0.0, speed: 0.0 };
        let pair = CameraPair { truth: camera, estimate: camera };
        assert!(instance_errors(&truth.states[..=20], 20, &truth, &pair, dt).is_none(), "no full true horizon");
    }
}
