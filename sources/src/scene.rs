//! A sequence's tracks as one source sees them, indexed by frame: what a forecast at frame s
//! may use of its own history and of its neighbours'.

use std::collections::BTreeMap;

use dynotraj_core::limits::MAX_HISTORY;
use dynotraj_core::predict::Context;
use dynotraj_core::{BevState, Point2};

use crate::trajectory::{ObjectTrack, Source};

/// One run of consecutive frames of a track, through a source.
#[derive(Debug, Clone, PartialEq)]
pub struct SourcedRun {
    /// Track id.
    pub track_id: i32,
    /// Frame of `states[0]`.
    pub first_frame: u32,
    /// The source's state per frame.
    pub states: Vec<BevState>,
}

impl SourcedRun {
    /// States from `frame - past` (clipped at the run start) to `frame`, or `None` when the run
    /// does not hold `frame`.
    #[must_use]
    pub fn history_at(&self, frame: u32, past: usize) -> Option<&[BevState]> {
        let end = usize::try_from(frame.checked_sub(self.first_frame)?).ok()?;
        if end >= self.states.len() {
            return None;
        }
        Some(&self.states[end.saturating_sub(past)..=end])
    }
}

/// Every track of a sequence through one source, split into runs of consecutive frames (each
/// run filtered separately: a source never carries state across a gap).
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// The runs, in track order then frame order.
    pub runs: Vec<SourcedRun>,
    /// Where the observing camera is per frame, in the runs' world; empty when unknown.
    pub observer: BTreeMap<u32, Point2>,
}

impl Scene {
    /// Applies `source` at frame period `dt` to every run of every track.
    #[must_use]
    pub fn new(tracks: &[ObjectTrack], source: Source, dt: f32) -> Self {
        let runs = tracks
            .iter()
            .flat_map(|t| {
                t.runs().map(move |r| SourcedRun {
                    track_id: t.track_id,
                    first_frame: t.frames[r.start],
                    states: source.apply(&t.states[r], dt),
                })
            })
            .collect();
        Self { runs, observer: BTreeMap::new() }
    }

    /// The same scene seen from `observer` (the camera's position per frame).
    #[must_use]
    pub fn seen_from(self, observer: BTreeMap<u32, Point2>) -> Self {
        Self { observer, ..self }
    }

    /// What a forecast of `track_id` at `frame` knows beyond its own history: `neighbours`
    /// ([`Scene::neighbours_at`]) and the observer at that frame.
    #[must_use]
    pub fn context_at<'a>(&self, neighbours: &'a [&'a [BevState]], frame: u32) -> Context<'a> {
        Context { neighbours, observer: self.observer.get(&frame).copied() }
    }

    /// The run of `track_id` that holds `frame`.
    #[must_use]
    pub fn run_at(&self, track_id: i32, frame: u32) -> Option<&SourcedRun> {
        self.runs.iter().find(|r| r.track_id == track_id && r.history_at(frame, 0).is_some())
    }

    /// The histories (up to `MAX_HISTORY` past frames, ending at `frame`) of every other track
    /// present at `frame`. The predictor picks the ones within its radius.
    #[must_use]
    pub fn neighbours_at(&self, track_id: i32, frame: u32) -> Vec<&[BevState]> {
        self.runs.iter().filter(|r| r.track_id != track_id).filter_map(|r| r.history_at(frame, MAX_HISTORY)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynotraj_core::wire::ObjectClass;

    fn track(id: i32, frames: Vec<u32>) -> ObjectTrack {
        let states = frames.iter().map(|&f| BevState { x: f as f32, y: id as f32, heading: 0.0, speed: 1.0 }).collect();
        ObjectTrack { track_id: id, class: ObjectClass::Car, frames, states }
    }

    #[test]
    fn histories_stop_at_gaps_and_neighbours_exclude_self() {
        let scene =
            Scene::new(&[track(1, (0..10).collect()), track(2, (3..5).chain(7..12).collect())], Source::Gt, 0.1);
        assert_eq!(scene.runs.len(), 3);
        assert_eq!(scene.run_at(1, 9).and_then(|r| r.history_at(9, 6)).map(<[_]>::len), Some(7));
        assert_eq!(scene.run_at(1, 2).and_then(|r| r.history_at(2, 6)).map(<[_]>::len), Some(3));
        let n = scene.neighbours_at(1, 8);
        assert_eq!(n.len(), 1);
        assert_eq!(n[0].len(), 2, "track 2's run restarts at frame 7");
        assert!(scene.neighbours_at(1, 6).is_empty());
        assert!(scene.run_at(2, 6).is_none());
    }
}
