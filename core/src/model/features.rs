//! Input features of the predictor (see the feature definition in [`super::arch`]): one
//! implementation, used by host training and by ECU inference alike.

use super::arch::{
    ACC_SCALE, ACCEL_SCALE, AGE_SCALE_FRAMES, FEATURE_CLAMP, FEATURES, HEADING_RATE_SCALE, MAX_NEIGHBOURS, MAX_STEPS,
    NEIGHBOUR_RADIUS_M, POS_SCALE, RANGE_SCALE, TURN_RATE_SCALE, VEL_SCALE,
};
use crate::geometry::{AgentFrame, BevState, Point2, angle_diff};
use crate::limits::MAX_PRIOR_HISTORY;
use crate::predict::Dynamics;
use crate::predict::prior::Trend;

/// Standardised features of up to [`MAX_STEPS`] states, oldest first.
pub type StepFeatures = [[f32; FEATURES]; MAX_STEPS];

/// What the features are standardised by, and how far a neighbour counts: per agent dynamics,
/// since a walker's metre is a car's ten (Trajectron++ standardises and draws its attention
/// radius per agent type too).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeatureScales {
    /// Positions, metres.
    pub pos: f32,
    /// Velocities (and the trend's speed), m/s.
    pub vel: f32,
    /// Accelerations (and the trend's), m/s^2.
    pub acc: f32,
    /// Heading rates (and the trend's turn rate), rad/s.
    pub heading_rate: f32,
    /// Neighbours closer than this at the current frame feed the edge encoder, metres.
    pub neighbour_radius_m: f32,
}

impl FeatureScales {
    /// Vehicles and cyclists (the unicycle's agents).
    pub const VEHICLE: Self = Self {
        pos: POS_SCALE,
        vel: VEL_SCALE,
        acc: ACC_SCALE,
        heading_rate: HEADING_RATE_SCALE,
        neighbour_radius_m: NEIGHBOUR_RADIUS_M,
    };

    /// Pedestrians (the single integrator's): Trajectron++'s pedestrian standardisation (1 m/s^2
    /// of acceleration, 2 m/s of velocity), positions over a 3.2 s history by 2 m so a brisk
    /// walk stays inside the clamp, and its 3 m pedestrian attention radius.
    pub const PEDESTRIAN: Self =
        Self { pos: 2.0, vel: 2.0, acc: 1.0, heading_rate: HEADING_RATE_SCALE, neighbour_radius_m: 3.0 };

    /// The scales of agents moving under `dynamics`.
    #[must_use]
    pub const fn of(dynamics: Dynamics) -> Self {
        match dynamics {
            Dynamics::Unicycle => Self::VEHICLE,
            Dynamics::SingleIntegrator => Self::PEDESTRIAN,
        }
    }
}

/// What only the agent's own feature rows carry; a neighbour's rows hold zeros there.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OwnContext {
    /// The motion prior's long-window estimates of the agent.
    pub trend: Trend,
    /// States of history before the current one: the track's age in frames, counted up to
    /// [`MAX_PRIOR_HISTORY`] (a forecast reads no more).
    pub age: usize,
    /// Distance from the observing camera at the current frame, metres; `None` when unknown.
    pub range_m: Option<f32>,
}

impl OwnContext {
    /// The context of `history` (oldest first, clipped at its run's start, current last) seen
    /// from `observer`, with the prior's `trend`.
    #[must_use]
    pub fn of(history: &[BevState], observer: Option<Point2>, trend: Trend) -> Self {
        let range_m = history.last().zip(observer).map(|(s, o)| s.position().distance(&o));
        Self { trend, age: history.len().saturating_sub(1).min(MAX_PRIOR_HISTORY), range_m }
    }

    /// The standardised columns, in feature order.
    fn columns(&self, scales: &FeatureScales) -> [f32; 5] {
        let t = &self.trend;
        [
            clamp(t.speed / scales.vel),
            clamp(t.accel / scales.acc),
            clamp(t.turn_rate / scales.heading_rate),
            clamp(self.age.min(MAX_PRIOR_HISTORY) as f32 / AGE_SCALE_FRAMES),
            clamp(self.range_m.map_or(0.0, |r| r / RANGE_SCALE)),
        ]
    }
}

fn clamp(v: f32) -> f32 {
    if v.is_nan() { 0.0 } else { v.clamp(-FEATURE_CLAMP, FEATURE_CLAMP) }
}

/// The newest [`MAX_STEPS`] states of a history.
fn newest(states: &[BevState]) -> &[BevState] {
    states.get(states.len().saturating_sub(MAX_STEPS)..).unwrap_or(states)
}

/// Features of `states` (oldest first; the newest [`MAX_STEPS`] are used) in `frame`,
/// standardised by `scales`, written to `out[..n]`; returns n. Rows past n are zeroed. `own`
/// (the agent's trend, age and range) fills the last five columns of every row; neighbours have
/// none (zeros).
pub fn state_features(
    states: &[BevState],
    frame: &AgentFrame,
    dt: f32,
    own: Option<&OwnContext>,
    scales: &FeatureScales,
    out: &mut StepFeatures,
) -> usize {
    let states = newest(states);
    let n = states.len();
    let inv_dt = if dt > 0.0 && dt.is_finite() { 1.0 / dt } else { 0.0 };
    let rate = |a: Point2, b: Point2| Point2::new((a.x - b.x) * inv_dt, (a.y - b.y) * inv_dt);

    let mut pos = [Point2::default(); MAX_STEPS];
    for (p, s) in pos.iter_mut().zip(states) {
        *p = frame.to_agent(&s.position());
    }
    // v_i = (p_i - p_(i-1)) / dt, v_0 = v_1; a_i = (v_i - v_(i-1)) / dt, a_0 = 0;
    // heading rate r_i = wrap(h_i - h_(i-1)) / dt, r_0 = r_1.
    let mut vel = [Point2::default(); MAX_STEPS];
    let mut turn = [0.0f32; MAX_STEPS];
    for (i, (w, ws)) in pos.get(..n).unwrap_or(&[]).windows(2).zip(states.windows(2)).enumerate() {
        if let ([p0, p1], [s0, s1], Some(v), Some(r)) = (w, ws, vel.get_mut(i + 1), turn.get_mut(i + 1)) {
            *v = rate(*p1, *p0);
            *r = angle_diff(s1.heading, s0.heading) * inv_dt;
        }
    }
    if let ([v0, v1, ..], [r0, r1, ..]) = (&mut vel[..], &mut turn[..])
        && n > 1
    {
        *v0 = *v1;
        *r0 = *r1;
    }
    let long = own.map_or([0.0; 5], |o| o.columns(scales));
    let mut prev_v: Option<Point2> = None;
    for (((row, s), (p, v)), r) in out.iter_mut().zip(states).zip(pos.iter().zip(&vel)).zip(&turn) {
        let a = prev_v.map_or(Point2::default(), |pv| rate(*v, pv));
        *row = [
            clamp(p.x / scales.pos),
            clamp(p.y / scales.pos),
            clamp(v.x / scales.vel),
            clamp(v.y / scales.vel),
            clamp(a.x / scales.acc),
            clamp(a.y / scales.acc),
            clamp(angle_diff(s.heading, frame.heading()) / core::f32::consts::PI),
            clamp(r / scales.heading_rate),
            long[0],
            long[1],
            long[2],
            long[3],
            long[4],
        ];
        prev_v = Some(*v);
    }
    for row in out.iter_mut().skip(n) {
        *row = [0.0; FEATURES];
    }
    n
}

/// The decoder's first control input: the current (turn rate, longitudinal acceleration) of the
/// agent, standardised as a unicycle decoder's outputs are, taken from the newest feature row
/// (standardised by `scales`).
#[must_use]
pub fn initial_control(current_row: &[f32; FEATURES], scales: &FeatureScales) -> [f32; 2] {
    let [_, _, _, _, ax, _, _, rate, ..] = *current_row;
    [clamp(rate * scales.heading_rate / TURN_RATE_SCALE), clamp(ax * scales.acc / ACCEL_SCALE)]
}

/// The summed neighbour features of the edge encoder, aligned with the agent's `n` feature
/// rows: each neighbour history (oldest first, ending at the agent's current frame) is
/// featurised in the agent's frame (standardised by `scales`) and added row by row, aligned at
/// the newest row. Only neighbours within `scales.neighbour_radius_m` of the agent at the
/// current frame count, the closest [`MAX_NEIGHBOURS`] of them. Returns how many were summed.
pub fn neighbour_sum(
    neighbours: &[&[BevState]],
    frame: &AgentFrame,
    n: usize,
    dt: f32,
    scales: &FeatureScales,
    out: &mut StepFeatures,
) -> usize {
    *out = [[0.0; FEATURES]; MAX_STEPS];
    // The closest neighbours in one pass, without allocating: `chosen[..count]` stays sorted by
    // squared distance (earlier index first among equals), each distance computed once.
    let mut chosen: [(usize, f32); MAX_NEIGHBOURS] = [(usize::MAX, f32::INFINITY); MAX_NEIGHBOURS];
    let mut count = 0;
    for (j, h) in neighbours.iter().enumerate() {
        let Some(p) = h.last().map(|s| frame.to_agent(&s.position())) else { continue };
        let d2 = p.x * p.x + p.y * p.y;
        if d2.is_nan() || d2 > scales.neighbour_radius_m * scales.neighbour_radius_m {
            continue;
        }
        let at = chosen.get(..count).unwrap_or(&[]).iter().position(|&(_, c)| d2 < c).unwrap_or(count);
        let last = count.min(MAX_NEIGHBOURS - 1);
        // Empty when the list is full and this one is the farthest (rotating an empty slice
        // would panic).
        if let Some(tail @ [_, ..]) = chosen.get_mut(at..=last) {
            // The farthest falls off the end when the list is full.
            tail.rotate_right(1);
            if let Some(first) = tail.first_mut() {
                *first = (j, d2);
            }
            count = (count + 1).min(MAX_NEIGHBOURS);
        }
    }
    let chosen = chosen.get(..count).unwrap_or(&[]);
    let mut rows: StepFeatures = [[0.0; FEATURES]; MAX_STEPS];
    for (j, _) in chosen {
        let Some(h) = neighbours.get(*j) else { continue };
        let m = state_features(h, frame, dt, None, scales, &mut rows);
        // Align the newest rows: neighbour row m-1 adds to agent row n-1.
        for (dst, src) in
            out.get_mut(..n).unwrap_or(&mut []).iter_mut().rev().zip(rows.get(..m).unwrap_or(&[]).iter().rev())
        {
            for (d, s) in dst.iter_mut().zip(src) {
                *d += s;
            }
        }
    }
    count
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::unwrap_used)]
mod tests {
    use super::*;

    const V: FeatureScales = FeatureScales::VEHICLE;

    fn st(x: f32, y: f32, heading: f32) -> BevState {
        BevState { x, y, heading, speed: 0.0 }
    }

    #[test]
    fn features_are_rotation_and_translation_invariant() {
        let dt = 0.1;
        let base: [BevState; 4] = core::array::from_fn(|i| st(i as f32, 0.05 * (i * i) as f32, 0.1 * i as f32));
        let (c, s) = (libm::cosf(1.0), libm::sinf(1.0));
        let moved: [BevState; 4] = core::array::from_fn(|i| {
            st(5.0 + c * base[i].x - s * base[i].y, -3.0 + s * base[i].x + c * base[i].y, base[i].heading + 1.0)
        });
        let (mut a, mut b) = ([[0.0; FEATURES]; MAX_STEPS], [[0.0; FEATURES]; MAX_STEPS]);
        assert_eq!(state_features(&base, &AgentFrame::of(&base[3]), dt, None, &V, &mut a), 4);
        state_features(&moved, &AgentFrame::of(&moved[3]), dt, None, &V, &mut b);
        for (ra, rb) in a.iter().zip(&b) {
            for (x, y) in ra.iter().zip(rb) {
                assert!((x - y).abs() < 1e-4, "{a:?}\n{b:?}");
            }
        }
        // The newest row sits at the origin with zero relative heading.
        assert!(a[3][0].abs() < 1e-6 && a[3][1].abs() < 1e-6 && a[3][6].abs() < 1e-6);
        // Constant 1 m per frame along the heading frame's x: vx = 10 m/s.
        assert!(a[2][2] > 0.0 && a[4] == [0.0; FEATURES]);
    }

    #[test]
    fn age_and_range_fill_every_own_row_and_no_neighbour_row() {
        let run: [BevState; 30] = core::array::from_fn(|i| st(i as f32, 0.0, 0.0));
        let observer = Point2::new(-20.0, 0.0);
        let young = OwnContext::of(&run[..3], Some(observer), Trend::default());
        let old = OwnContext::of(&run, Some(observer), Trend::default());
        assert_eq!((young.age, old.age), (2, MAX_PRIOR_HISTORY), "age counts past states, up to the cap");
        assert!((young.range_m.unwrap() - 22.0).abs() < 1e-5);
        let mut out = [[0.0; FEATURES]; MAX_STEPS];
        let n = state_features(&run[..3], &AgentFrame::of(&run[2]), 0.1, Some(&young), &V, &mut out);
        for row in &out[..n] {
            assert!((row[11] - 2.0 / AGE_SCALE_FRAMES).abs() < 1e-6 && (row[12] - 22.0 / RANGE_SCALE).abs() < 1e-6);
        }
        let unknown = OwnContext::of(&run, None, Trend::default());
        state_features(&run, &AgentFrame::of(&run[29]), 0.1, Some(&unknown), &V, &mut out);
        assert_eq!((out[0][11], out[0][12]), (1.0, 0.0), "an unknown observer reads as range 0");
        let mut summed = [[0.0; FEATURES]; MAX_STEPS];
        let near: [&[BevState]; 1] = [&run[..3]];
        neighbour_sum(&near, &AgentFrame::of(&run[2]), 3, 0.1, &V, &mut summed);
        assert!(summed[..3].iter().all(|r| r[8..] == [0.0; 5]), "neighbours carry no trend, age or range");
    }

    #[test]
    fn neighbours_beyond_the_radius_are_ignored_and_rows_align_at_the_newest() {
        let own = [st(0.0, 0.0, 0.0), st(1.0, 0.0, 0.0), st(2.0, 0.0, 0.0)];
        let near = [st(5.0, 2.0, 0.0), st(6.0, 2.0, 0.0)];
        let far = [st(500.0, 0.0, 0.0), st(501.0, 0.0, 0.0)];
        let frame = AgentFrame::of(&own[2]);
        let mut out = [[0.0; FEATURES]; MAX_STEPS];
        let hs: [&[BevState]; 2] = [&near, &far];
        assert_eq!(neighbour_sum(&hs, &frame, 3, 0.1, &V, &mut out), 1);
        assert_eq!(out[0], [0.0; FEATURES], "a shorter neighbour history leaves the oldest row empty");
        assert!((out[2][0] - 4.0 / POS_SCALE).abs() < 1e-6 && (out[2][1] - 2.0 / POS_SCALE).abs() < 1e-6);
    }

    #[test]
    fn only_the_closest_neighbours_within_the_radius_count() {
        let own = [st(0.0, 0.0, 0.0), st(1.0, 0.0, 0.0)];
        let frame = AgentFrame::of(&own[1]);
        // 24 neighbours at distances 1, 2.5, 4, ... (shuffled): more within the radius than are
        // summed, the farthest beyond it.
        let order = [7usize, 19, 2, 11, 23, 0, 14, 5, 9, 21, 3, 16, 12, 1, 22, 8, 18, 4, 13, 20, 6, 10, 17, 15];
        let hists: [[BevState; 2]; 24] = core::array::from_fn(|i| {
            let d = 1.0 + 1.5 * order[i] as f32;
            [st(1.0 + d, 0.5, 0.0), st(1.0 + d, 0.0, 0.0)]
        });
        let refs: [&[BevState]; 24] = core::array::from_fn(|i| &hists[i][..]);
        let mut out = [[0.0; FEATURES]; MAX_STEPS];
        let within = (0..24).filter(|&k| 1.0 + 1.5 * k as f32 <= NEIGHBOUR_RADIUS_M).count();
        assert!(within > MAX_NEIGHBOURS);
        assert_eq!(neighbour_sum(&refs, &frame, 2, 0.1, &V, &mut out), within.min(MAX_NEIGHBOURS));
        // The newest rows' x positions sum to those of the closest ones.
        let want: f32 = (0..MAX_NEIGHBOURS).map(|k| (1.0 + 1.5 * k as f32) / POS_SCALE).sum();
        assert!((out[1][0] - want).abs() < 1e-4, "{} vs {want}", out[1][0]);
    }

    #[test]
    fn a_walker_s_features_are_scaled_for_walking_and_count_only_near_neighbours() {
        let walk: [BevState; 3] = core::array::from_fn(|i| st(0.5 * i as f32, 0.0, 0.0));
        let frame = AgentFrame::of(&walk[2]);
        let (mut car, mut person) = ([[0.0; FEATURES]; MAX_STEPS], [[0.0; FEATURES]; MAX_STEPS]);
        state_features(&walk, &frame, 0.4, None, &V, &mut car);
        state_features(&walk, &frame, 0.4, None, &FeatureScales::of(Dynamics::SingleIntegrator), &mut person);
        // 1.25 m/s: a twelfth of a car's velocity scale, most of a walker's.
        assert!((car[2][2] - 1.25 / 15.0).abs() < 1e-6 && (person[2][2] - 1.25 / 2.0).abs() < 1e-6);
        let near: [BevState; 1] = [st(2.0, 2.0, 0.0)];
        let far: [BevState; 1] = [st(6.0, 3.0, 0.0)];
        let hs: [&[BevState]; 2] = [&near, &far];
        let mut out = [[0.0; FEATURES]; MAX_STEPS];
        assert_eq!(neighbour_sum(&hs, &frame, 3, 0.4, &V, &mut out), 2);
        assert_eq!(neighbour_sum(&hs, &frame, 3, 0.4, &FeatureScales::PEDESTRIAN, &mut out), 1, "3 m for walkers");
    }
}
