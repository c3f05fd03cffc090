//! The paper's "Estimated" source (Ours): bird's-eye object tracks taken from the core
//! estimator's own output, with no label in any state.
//!
//! Here the estimator runs on the track-level simulator driven by the sequence's real labels,
//! ego poses and calibration (`crate::estimation`): simulated feature tracks, with pixel and
//! depth noise and outliers, streamed through the wire into `dynotraj_core::estimate`. Real
//! KITTI images are not available here; a user's full download goes through the image
//! front-end instead (`dynotraj track`, then `dynotraj estimate --tracks`).
//!
//! Two variants, as for the labels:
//! - causal: at each frame, the smoother's estimate of its newest frame, what an online vehicle
//!   has at that frame (the input the edge forecasts from);
//! - smoothed: each frame as it leaves the fixed-lag window, having seen up to `W - 1` later
//!   frames (the paper's DynoSAM output is of this kind). Not causal: reported apart.
//!
//! Only states whose heading comes from the object's motion are kept (`heading_known`): before
//! that the object frame keeps a placeholder orientation, which a forecast must not start
//! from. Track ids are the KITTI ids (`object_id - 1`), so the estimated tracks can be paired
//! with the labels of the same object.

use std::collections::BTreeMap;

use dynotraj_core::BevState;
use dynotraj_core::estimate::{PoseEstimate, bev_heading};
use dynotraj_core::wire::ObjectClass;

use crate::estimation::score::{FrameRpe, moving_objects, rpe_over_time};
use crate::estimation::simulated::{EvalOptions, evaluate_sequence, kitti_track_id};
use crate::estimation::{EstimatorRun, Kind, RunScores};
use crate::trajectory::ObjectTrack;
use dynotraj_formats::kitti::SequenceData;
use dynotraj_sim::track_sim::SimFrame;

/// What the estimator ran on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum EstimateInput {
    /// Tracks of the track-level simulator driven by the sequence's labels and ego poses
    /// ([`crate::estimation::settings::SimulatedInput::Tracks`]).
    Tracks,
    /// The image front-end's tracks of the sequence's own stereo images (no truth).
    Images,
    /// The image front-end's tracks of a rendering of the sequence by the image simulator.
    Rendered,
}

/// The camera at one frame on the bird's-eye plane: the simulator's and the causal estimate's.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CameraPair {
    /// The true camera, in the truth's world.
    pub truth: BevState,
    /// The causal estimate of the camera, in the estimator's world.
    pub estimate: BevState,
}

impl CameraPair {
    /// The yaw (radians) that turns the estimator's world into the truth's at this frame: the
    /// true camera's heading minus the causal estimate's.
    #[must_use]
    pub fn world_yaw(&self) -> f32 {
        dynotraj_core::geometry::angle_diff(self.truth.heading, self.estimate.heading)
    }
}

/// A sequence's tracks through the estimator, both variants, and how well it did.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EstimatedTracks {
    /// What the estimator ran on.
    pub input: EstimateInput,
    /// Newest-frame estimates (causal).
    pub causal: Vec<ObjectTrack>,
    /// Estimates as they left the smoothing window (saw later frames).
    pub smoothed: Vec<ObjectTrack>,
    /// RPE of the run against the simulator's truth (the paper's Table III for Ours); `None`
    /// on real images.
    pub rpe: Option<RunScores>,
    /// The simulator's true bird's-eye paths of every simulated object (box centre, heading;
    /// speed 0: only positions are used), the common reference every arm can be scored
    /// against; empty on real images.
    pub truth: Vec<ObjectTrack>,
    /// Where the front-end gave its objects ids of its own (box or motion masks): the true
    /// track id of each track that followed a true object, the one holding most of its points
    /// (`truth` holds a copy of that object's path under the track's own id too). `None`
    /// where the track ids are the truth's.
    pub truth_of: Option<BTreeMap<i32, i32>>,
    /// Per frame: the camera on the bird's-eye plane, true and as the causal estimate has it
    /// (position and heading; speed 0), each in its own world: what turns the estimator's
    /// world into the truth's ([`EstimatedTracks::world_yaw`]) and places an object relative to
    /// the vehicle in both (the experiment's error budget). Empty on real images.
    pub cameras: std::collections::BTreeMap<u32, CameraPair>,
    /// Per frame: the causal estimate of the camera's position on the bird's-eye plane, in the
    /// estimator's world, on every input (real images too): where its tracks are seen from,
    /// which the forecaster's range feature reads.
    pub observer: std::collections::BTreeMap<u32, dynotraj_core::Point2>,
    /// Per output kind, in [`Kind::ALL`] order: the translational RPE of each frame against the
    /// simulator's truth (the pairs behind `rpe`, over time); empty on real images.
    pub rpe_frames: [Vec<FrameRpe>; 3],
    /// Frames estimated.
    pub frames: usize,
}

/// Simulates, estimates and collects the tracks of sequence `data` with `opt`.
#[must_use]
pub fn estimated_tracks(id: &str, data: &SequenceData, opt: &EvalOptions) -> EstimatedTracks {
    let r = evaluate_sequence(id, data, opt);
    EstimatedTracks::of_run(EstimateInput::Tracks, &r.run, Some(r.scores), &r.sim, r.min_step_m)
}

/// The tracks of the front-end and estimator on a rendering of the sequence, with its truth;
/// objects moving at least `min_step_m` per frame are scored (as for `e.scores`).
#[must_use]
pub fn rendered_estimated_tracks(e: &crate::estimation::from_images::RenderedRun, min_step_m: f64) -> EstimatedTracks {
    let mut tracks = EstimatedTracks::of_run(EstimateInput::Rendered, &e.run, Some(e.scores), &e.frames, min_step_m);
    tracks.truth_of =
        e.truth_of.as_ref().map(|m| m.iter().map(|(&o, &t)| (kitti_track_id(o), kitti_track_id(t))).collect());
    tracks
}

/// The tracks of an estimator run on real images (no truth, no RPE).
#[must_use]
pub fn image_estimated_tracks(run: &EstimatorRun) -> EstimatedTracks {
    EstimatedTracks::of_run(EstimateInput::Images, run, None, &[], 0.0)
}

impl EstimatedTracks {
    /// The true track id behind track `id`: itself where the track ids are the truth's, else
    /// the object [`EstimatedTracks::truth_of`] maps it to (`None`: it followed no true
    /// object).
    #[must_use]
    pub fn true_track_id(&self, id: i32) -> Option<i32> {
        match &self.truth_of {
            None => Some(id),
            Some(m) => m.get(&id).copied(),
        }
    }

    /// Per frame, [`CameraPair::world_yaw`]. The estimator's world drifts from the truth's as
    /// camera errors accumulate; a displacement forecast at frame s is turned by this before it
    /// is held to the true one. Empty on real images.
    #[must_use]
    pub fn world_yaw(&self) -> BTreeMap<u32, f32> {
        self.cameras.iter().map(|(&frame, c)| (frame, c.world_yaw())).collect()
    }

    /// Both variants' tracks of `run`, with what is known of its accuracy and the truth of the
    /// simulated frames `sim` it ran on (empty for real images); objects moving at least
    /// `min_step_m` a frame are the ones RPE scores.
    fn of_run(
        input: EstimateInput,
        run: &EstimatorRun,
        rpe: Option<RunScores>,
        sim: &[SimFrame],
        min_step_m: f64,
    ) -> Self {
        let bev = |pose: &dynotraj_core::geometry::Pose3| BevState {
            x: pose.translation.vector.x,
            y: pose.translation.vector.z,
            heading: bev_heading(pose),
            speed: 0.0,
        };
        let cameras: BTreeMap<u32, CameraPair> = sim
            .iter()
            .zip(run.of(Kind::Causal))
            .filter_map(|(f, e)| {
                let e = e.as_ref()?;
                Some((f.frame, CameraPair { truth: bev(&f.camera.cast::<f32>()), estimate: bev(&e.camera) }))
            })
            .collect();
        let observer = run.of(Kind::Causal).iter().flatten().map(|e| (e.frame, bev(&e.camera).position())).collect();
        let moving = moving_objects(sim, min_step_m);
        let rpe_frames =
            Kind::ALL.map(|k| if sim.is_empty() { Vec::new() } else { rpe_over_time(sim, run.of(k), &moving) });
        Self {
            input,
            causal: tracks_of_estimates(run.of(Kind::Causal)),
            smoothed: tracks_of_estimates(run.of(Kind::Smoothed)),
            rpe,
            truth: truth_tracks(sim),
            truth_of: None,
            cameras,
            observer,
            rpe_frames,
            frames: run.causal.len(),
        }
    }
}

/// The simulator's true object paths, one track per object, ordered by id (track id = KITTI
/// id): the box centre on the bird's-eye plane and the heading of its x axis.
#[must_use]
pub fn truth_tracks(sim: &[SimFrame]) -> Vec<ObjectTrack> {
    let mut by_id: BTreeMap<u16, ObjectTrack> = BTreeMap::new();
    for f in sim {
        for o in &f.objects {
            let t = by_id.entry(o.object_id).or_insert_with(|| ObjectTrack {
                track_id: kitti_track_id(o.object_id),
                class: o.class,
                frames: Vec::new(),
                states: Vec::new(),
            });
            let p = o.pose.translation.vector;
            let x_axis = o.pose.rotation * nalgebra::Vector3::x();
            t.frames.push(f.frame);
            t.states.push(BevState {
                x: p.x as f32,
                y: p.z as f32,
                heading: x_axis.z.atan2(x_axis.x) as f32,
                speed: 0.0,
            });
        }
    }
    by_id.into_values().collect()
}

/// Groups per-frame estimates into one track per object, ordered by id. Kept: finite states
/// with a known heading. An object whose output segment changes between two consecutive
/// frames (re-initialised under the same id) loses the first frame of its new segment, so that
/// the two segments fall into separate runs ([`ObjectTrack::runs`] splits at frame gaps).
#[must_use]
pub fn tracks_of_estimates(estimates: &[Option<PoseEstimate>]) -> Vec<ObjectTrack> {
    /// Per object: class, then (frame, segment, state) in frame order.
    type Rows = (ObjectClass, Vec<(u32, u16, BevState)>);
    let mut by_id: BTreeMap<u16, Rows> = BTreeMap::new();
    for e in estimates.iter().flatten() {
        for o in e.objects.iter().filter(|o| o.heading_known && o.bev.is_finite()) {
            let rows = &mut by_id.entry(o.object_id).or_insert_with(|| (o.class, Vec::new())).1;
            if let Some(&(frame, segment, _)) = rows.last() {
                if frame >= e.frame {
                    continue;
                }
                if frame + 1 == e.frame && segment != o.segment {
                    // Left out, this frame is the gap that starts the new segment's run at its
                    // next frame.
                    continue;
                }
            }
            rows.push((e.frame, o.segment, o.bev));
        }
    }
    by_id
        .into_iter()
        .map(|(object_id, (class, rows))| ObjectTrack {
            track_id: kitti_track_id(object_id),
            class,
            frames: rows.iter().map(|r| r.0).collect(),
            states: rows.iter().map(|r| r.2).collect(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynotraj_core::estimate::ObjectEstimate;
    use dynotraj_core::geometry::Pose3;

    fn object(id: u16, x: f32, segment: u16, heading_known: bool) -> ObjectEstimate {
        ObjectEstimate {
            object_id: id,
            class: ObjectClass::Car,
            pose: Pose3::identity(),
            motion: Pose3::identity(),
            bev: BevState { x, y: 0.0, heading: 0.0, speed: 1.0 },
            heading_rate: 0.0,
            segment,
            orientation: segment,
            heading_known,
        }
    }

    fn frame(k: u32, objects: &[ObjectEstimate]) -> Option<PoseEstimate> {
        let mut e = PoseEstimate::new();
        e.reset(k, u64::from(k) * 50_000);
        for o in objects {
            e.objects.push(*o).ok()?;
        }
        Some(e)
    }

    #[test]
    fn unknown_headings_are_dropped_and_segments_split_runs() {
        let est = vec![
            frame(0, &[object(5, 0.0, 0, false), object(2, 9.0, 1, true)]),
            frame(1, &[object(5, 1.0, 1, true), object(2, 9.5, 1, true)]),
            frame(2, &[object(5, 2.0, 1, true)]),
            None,
            frame(4, &[object(5, 4.0, 1, true)]),
            // Re-initialised under the same id with no missing frame: its first frame goes.
            frame(5, &[object(5, 5.0, 2, true)]),
            frame(6, &[object(5, 6.0, 2, true)]),
        ];
        let tracks = tracks_of_estimates(&est);
        assert_eq!(tracks.iter().map(|t| t.track_id).collect::<Vec<_>>(), vec![1, 4]);
        let t = &tracks[1];
        assert_eq!(t.frames, vec![1, 2, 4, 6]);
        assert_eq!(t.states.iter().map(|s| s.x).collect::<Vec<_>>(), vec![1.0, 2.0, 4.0, 6.0]);
        assert_eq!(t.runs().collect::<Vec<_>>(), vec![0..2, 2..3, 3..4]);
    }

    #[test]
    fn non_finite_states_never_reach_a_track() {
        let est = vec![frame(0, &[object(1, f32::INFINITY, 1, true)]), frame(1, &[object(1, 1.0, 1, true)])];
        let tracks = tracks_of_estimates(&est);
        assert_eq!(tracks.len(), 1);
        assert_eq!(tracks[0].frames, vec![1]);
    }

    #[test]
    fn a_track_named_by_the_front_end_has_the_true_id_it_was_mapped_to_or_none() {
        let mut e = image_estimated_tracks(&EstimatorRun::empty(0));
        assert_eq!(e.true_track_id(4), Some(4), "ids that are the truth's");
        e.truth_of = Some(BTreeMap::from([(19_999, 4)]));
        assert_eq!((e.true_track_id(19_999), e.true_track_id(20_000)), (Some(4), None));
        e.truth_of = Some(BTreeMap::new());
        assert_eq!(e.true_track_id(4), None, "no object followed a true one");
    }
}
