//! World-frame bird's-eye trajectories of labelled objects (the GT source).

use std::collections::BTreeMap;

use dynotraj_core::BevState;
use dynotraj_core::geometry::{bev_heading_of_rotation_y, bev_point};
use dynotraj_core::wire::ObjectClass;
use nalgebra::{Isometry3, Point3};

use dynotraj_formats::kitti::SequenceData;

/// One labelled object in one frame, in the labelling camera's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LabelledObservation {
    /// Frame index.
    pub frame: u32,
    /// Track id (unique per sequence).
    pub track_id: i32,
    /// Object class.
    pub class: ObjectClass,
    /// Box position in the camera frame (KITTI: bottom centre, rectified camera 0), metres.
    pub location: Point3<f64>,
    /// KITTI `rotation_y`, radians.
    pub rotation_y: f64,
}

/// An object's world-frame trajectory on the bird's-eye plane, frames strictly increasing
/// (possibly with gaps where the object was not labelled).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ObjectTrack {
    /// Track id.
    pub track_id: i32,
    /// Class of the object (its first label's).
    pub class: ObjectClass,
    /// Frame of each state.
    pub frames: Vec<u32>,
    /// World bird's-eye state per frame: position of the box, heading from `rotation_y`, and
    /// the finite-difference speed (backward; see [`ground_truth_tracks`]).
    pub states: Vec<BevState>,
}

impl ObjectTrack {
    /// Index ranges (into `frames` and `states`) of the track's runs of consecutive frames, in
    /// order: a gap in the labels ends a run.
    pub fn runs(&self) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
        let n = self.frames.len();
        let ends = (1..=n).filter(move |&end| end == n || self.frames[end] != self.frames[end - 1] + 1);
        ends.scan(0, |start, end| Some(std::mem::replace(start, end)..end))
    }
}

/// Puts every labelled observation in the world frame with the camera poses `camera_poses`
/// (T_world_cam per frame) and groups them into tracks, ordered by track id.
///
/// Speed is the backward finite difference |p_k - p_(k-1)| / dt between consecutive frames; at
/// the first frame of a run of consecutive frames (no previous frame) it is the forward
/// difference, and 0 for a single frame. Observations whose frame has no pose are skipped (the
/// loader has already checked that poses cover every labelled frame).
#[must_use]
pub fn ground_truth_tracks(
    observations: &[LabelledObservation],
    camera_poses: &[Isometry3<f64>],
    dt: f32,
) -> Vec<ObjectTrack> {
    let mut by_id: BTreeMap<i32, Vec<(u32, BevState, ObjectClass)>> = BTreeMap::new();
    for o in observations {
        let Some(pose) = camera_poses.get(o.frame as usize) else { continue };
        let world = pose * o.location;
        let p = bev_point(&world.cast::<f32>());
        let heading = bev_heading_of_rotation_y(o.rotation_y as f32, &pose.rotation.to_rotation_matrix().cast::<f32>());
        let state = BevState { x: p.x, y: p.y, heading, speed: 0.0 };
        by_id.entry(o.track_id).or_default().push((o.frame, state, o.class));
    }
    by_id
        .into_iter()
        .map(|(track_id, mut obs)| {
            obs.sort_by_key(|(f, _, _)| *f);
            obs.dedup_by_key(|(f, _, _)| *f);
            let class = obs.first().map_or(ObjectClass::Misc, |o| o.2);
            let frames: Vec<u32> = obs.iter().map(|o| o.0).collect();
            let mut states: Vec<BevState> = obs.iter().map(|o| o.1).collect();
            fill_finite_difference_speed(&frames, &mut states, dt);
            ObjectTrack { track_id, class, frames, states }
        })
        .collect()
}

fn fill_finite_difference_speed(frames: &[u32], states: &mut [BevState], dt: f32) {
    let n = states.len();
    let step_speed = |a: &BevState, b: &BevState| a.position().distance(&b.position()) / dt;
    let speeds: Vec<f32> = (0..n)
        .map(|i| {
            let consecutive = |j: usize| j + 1 < n && frames[j + 1] == frames[j] + 1;
            if i > 0 && consecutive(i - 1) {
                step_speed(&states[i - 1], &states[i])
            } else if consecutive(i) {
                step_speed(&states[i], &states[i + 1])
            } else {
                0.0
            }
        })
        .collect();
    for (s, v) in states.iter_mut().zip(speeds) {
        s.speed = v;
    }
}

/// The labelled objects of a loaded sequence as world-frame tracks at frame period `dt`
/// (DontCare regions and unknown types left out).
#[must_use]
pub fn label_tracks(data: &SequenceData, dt: f32) -> Vec<ObjectTrack> {
    let observations: Vec<LabelledObservation> = data
        .labels
        .iter()
        .filter(|r| !r.is_dont_care() && !r.is_box_only())
        .filter_map(|r| {
            Some(LabelledObservation {
                frame: u32::try_from(r.frame).ok()?,
                track_id: i32::try_from(r.track_id).ok()?,
                class: ObjectClass::from_kitti_name(&r.object_type)?,
                location: Point3::new(r.x, r.y, r.z),
                rotation_y: r.rotation_y,
            })
        })
        .collect();
    ground_truth_tracks(&observations, &data.poses, dt)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn obs(frame: u32, id: i32, x: f64, z: f64, ry: f64) -> LabelledObservation {
        LabelledObservation {
            frame,
            track_id: id,
            class: ObjectClass::Car,
            location: Point3::new(x, 1.5, z),
            rotation_y: ry,
        }
    }

    #[test]
    fn tracks_are_in_the_world_frame_with_speeds() {
        // The camera moves forward 1 m per frame; the object stays 10 m ahead of it, so in the
        // world it moves 1 m per frame along +z, i.e. +y on the plane.
        let poses: Vec<Isometry3<f64>> = (0..4).map(|k| Isometry3::translation(0.0, 0.0, k as f64)).collect();
        let o: Vec<_> = (0..4).map(|k| obs(k, 7, 2.0, 10.0, -std::f64::consts::FRAC_PI_2)).collect();
        let t = ground_truth_tracks(&o, &poses, 0.1);
        assert_eq!(t.len(), 1);
        let s = &t[0].states;
        assert!((s[3].y - 13.0).abs() < 1e-5 && (s[3].x - 2.0).abs() < 1e-6);
        assert!(s.iter().all(|s| (s.speed - 10.0).abs() < 1e-3), "{s:?}");
        assert!((s[0].heading - std::f32::consts::FRAC_PI_2).abs() < 1e-5);
    }

    #[test]
    fn gaps_do_not_make_speed() {
        let poses: Vec<Isometry3<f64>> = (0..10).map(|_| Isometry3::identity()).collect();
        let o = [obs(0, 1, 0.0, 5.0, 0.0), obs(1, 1, 0.0, 6.0, 0.0), obs(5, 1, 0.0, 50.0, 0.0)];
        let t = ground_truth_tracks(&o, &poses, 0.1);
        let s = &t[0].states;
        assert!((s[0].speed - 10.0).abs() < 1e-3 && (s[1].speed - 10.0).abs() < 1e-3);
        assert_eq!(s[2].speed, 0.0);
    }
}
