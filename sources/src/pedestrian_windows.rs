//! The forecasting windows of a pedestrian recording (ETH/UCY), as the field scores them: every
//! pedestrian at every step with [`HISTORY_STEPS`] observed positions (the current one
//! included) and [`FUTURE_STEPS`] after it, with the other pedestrians present at that step as
//! neighbours.
//!
//! The recordings hold positions only; each window's states (heading, speed) are computed from
//! the positions inside its own history, by backward differences, so nothing a forecast reads
//! comes from outside what it observed. (Trajectron++'s preprocessing takes central differences
//! over the whole track, which lets the newest velocity see one step of the future.)

use std::collections::BTreeMap;

use dynotraj_core::{BevState, Point2};
use dynotraj_formats::eth_ucy::{Recording, Walk};

/// Observed positions per window, the current one included (3.2 s at 2.5 Hz).
pub const HISTORY_STEPS: usize = 8;

/// Positions forecast per window (4.8 s at 2.5 Hz).
pub const FUTURE_STEPS: usize = 12;

/// A step shorter than this (metres) gives no heading: the previous heading is held.
const STILL_STEP_M: f32 = 0.01;

/// One forecasting instance.
#[derive(Debug, Clone, PartialEq)]
pub struct Window {
    /// The pedestrian's id in the recording.
    pub pedestrian: u32,
    /// Index of the pedestrian's walk in the recording (windows of one walk are nearly the same
    /// instance; resampling keeps them together).
    pub walk: usize,
    /// The step of the current (newest observed) position.
    pub step: u32,
    /// States of the observed positions, oldest first ([`HISTORY_STEPS`] of them).
    pub history: Vec<BevState>,
    /// The true positions of the next [`FUTURE_STEPS`] steps.
    pub future: Vec<Point2>,
    /// The other pedestrians present at `step`: their states over the same steps, as far back
    /// as each was observed within the window, oldest first.
    pub neighbours: Vec<Vec<BevState>>,
}

impl Window {
    /// The neighbours' histories as slices, what [`Context::with_neighbours`](dynotraj_core::predict::Context::with_neighbours) takes (no
    /// observer: the recordings are seen from above).
    #[must_use]
    pub fn neighbour_histories(&self) -> Vec<&[BevState]> {
        self.neighbours.iter().map(Vec::as_slice).collect()
    }

    /// The history followed by the future as states (the future's heading and speed from
    /// backward differences too): what a trainer that reads one slice of states takes.
    #[must_use]
    pub fn states(&self, dt: f32) -> Vec<BevState> {
        let mut positions: Vec<Point2> = self.history.iter().map(BevState::position).collect();
        positions.extend(&self.future);
        states_from_positions(&positions, dt)
    }
}

/// States of consecutive `positions` at period `dt`: speed and heading from the step into each
/// position (the first takes the step out of it). A step shorter than `STILL_STEP_M` holds
/// the heading, unless no step of the window so far was longer: a slow walker's millimetre steps
/// are then all the direction there is (before any step the heading is the first long step's,
/// else the first nonzero step's).
#[must_use]
pub fn states_from_positions(positions: &[Point2], dt: f32) -> Vec<BevState> {
    let step_into = |k: usize| -> Option<Point2> {
        let (a, b) =
            if k == 0 { (positions.first()?, positions.get(1)?) } else { (positions.get(k - 1)?, positions.get(k)?) };
        Some(Point2::new(b.x - a.x, b.y - a.y))
    };
    let long = |d: &Point2| d.x.hypot(d.y) >= STILL_STEP_M;
    let nonzero = |d: &Point2| d.x != 0.0 || d.y != 0.0;
    let steps: Vec<Point2> = (0..positions.len()).filter_map(step_into).collect();
    let first = steps.iter().find(|d| long(d)).or_else(|| steps.iter().find(|d| nonzero(d)));
    let mut heading = first.map_or(0.0, |d| d.y.atan2(d.x));
    let mut moved = false;
    positions
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let d = step_into(k).unwrap_or_default();
            if long(&d) || (!moved && nonzero(&d)) {
                heading = d.y.atan2(d.x);
            }
            moved |= long(&d);
            BevState { x: p.x, y: p.y, heading, speed: d.x.hypot(d.y) / dt }
        })
        .collect()
}

/// Every window of `recording` at period `dt`, ordered by walk then step.
#[must_use]
pub fn windows(recording: &Recording, dt: f32) -> Vec<Window> {
    let mut present: BTreeMap<u32, Vec<usize>> = BTreeMap::new();
    for (i, w) in recording.walks.iter().enumerate() {
        for step in w.first_step..w.end_step() {
            present.entry(step).or_default().push(i);
        }
    }
    let span = HISTORY_STEPS + FUTURE_STEPS;
    let mut out = Vec::new();
    for (i, walk) in recording.walks.iter().enumerate() {
        for (start, positions) in walk.positions.windows(span).enumerate() {
            let (observed, future) = positions.split_at(HISTORY_STEPS);
            let first = walk.first_step + start as u32;
            let step = first + HISTORY_STEPS as u32 - 1;
            let neighbours = present
                .get(&step)
                .into_iter()
                .flatten()
                .filter(|&&j| j != i)
                .filter_map(|&j| recording.walks.get(j))
                .map(|other| observed_states(other, first, step, dt))
                .collect();
            out.push(Window {
                pedestrian: walk.id,
                walk: i,
                step,
                history: states_from_positions(observed, dt),
                future: future.to_vec(),
                neighbours,
            });
        }
    }
    out
}

/// `walk`'s states over steps `first..=last` (from its own first step when later), computed
/// from those positions alone.
fn observed_states(walk: &Walk, first: u32, last: u32, dt: f32) -> Vec<BevState> {
    let positions: Vec<Point2> = (first.max(walk.first_step)..=last).filter_map(|s| walk.at(s)).collect();
    states_from_positions(&positions, dt)
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use dynotraj_formats::eth_ucy::parse;

    use super::*;

    fn line_walk(id: u32, first: u32, n: usize, y: f32) -> String {
        (0..n).map(|k| format!("{}\t{id}\t{}\t{y}\n", (first as usize + k) * 10, 0.5 * k as f32)).collect()
    }

    #[test]
    fn every_full_window_is_found_with_the_neighbours_present_at_its_step() {
        // Pedestrian 1 walks 25 steps from step 0; pedestrian 2 is there from step 10 to 14.
        let text = line_walk(1, 0, 25, 0.0) + &line_walk(2, 10, 5, 3.0);
        let rec = parse(&text, Path::new("x.txt")).unwrap();
        let w = windows(&rec, 0.4);
        assert_eq!(w.len(), 25 - 20 + 1, "pedestrian 2 is too short for a window");
        assert!(w.iter().all(|w| w.pedestrian == 1 && w.history.len() == 8 && w.future.len() == 12));
        assert_eq!(w.first().map(|w| w.step), Some(7));
        // At step 10 pedestrian 2 has one observed position in the window, at step 12 three.
        let at = |s: u32| w.iter().find(|w| w.step == s).unwrap();
        assert_eq!(at(7).neighbours.len(), 0);
        assert_eq!(at(10).neighbours.iter().map(Vec::len).collect::<Vec<_>>(), vec![1]);
        assert_eq!(at(12).neighbours[0].len(), 3);
        assert!(at(12).neighbours[0].iter().all(|s| (s.y - 3.0).abs() < 1e-6));
        let h = &at(12).history;
        assert!(h.iter().all(|s| (s.speed - 1.25).abs() < 1e-4 && s.heading.abs() < 1e-6), "{h:?}");
        assert!((at(12).future[0].x - 6.5).abs() < 1e-5, "the step after 12 is 13, at 6.5 m");
    }

    #[test]
    fn states_hold_the_heading_while_still_and_use_only_earlier_steps() {
        let p = |x: f32, y: f32| Point2::new(x, y);
        let s = states_from_positions(&[p(0.0, 0.0), p(0.0, 0.0), p(0.0, 1.0), p(0.0, 1.0), p(-1.0, 1.0)], 0.5);
        let headings: Vec<f32> = s.iter().map(|s| s.heading).collect();
        let half_pi = std::f32::consts::FRAC_PI_2;
        assert_eq!(headings, vec![half_pi, half_pi, half_pi, half_pi, std::f32::consts::PI]);
        let speeds: Vec<f32> = s.iter().map(|s| s.speed).collect();
        assert_eq!(speeds, vec![0.0, 0.0, 2.0, 0.0, 2.0], "the first state takes the step out of it");
        assert!(states_from_positions(&[p(1.0, 1.0)], 0.4)[0].is_finite());
        // A slow walker going -x in 8 mm steps heads -x, not along a default.
        let slow: Vec<Point2> = (0..8).map(|k| p(2.0 - 0.008 * k as f32, 3.5)).collect();
        assert!(
            states_from_positions(&slow, 0.4).iter().all(|s| (s.heading.abs() - std::f32::consts::PI).abs() < 1e-4)
        );
    }
}
