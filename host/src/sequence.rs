//! Loading a KITTI tracking sequence into world-frame ground-truth tracks.

use anyhow::Context as _;
use dynotraj_core::wire::ObjectClass;
use nalgebra::Point3;

use crate::kitti::{SequenceData, TrackingDir};
use crate::trajectory::{ground_truth_tracks, LabelledObservation, Track};

/// The labelled objects of one sequence as world-frame bird's-eye tracks.
#[derive(Debug, Clone)]
pub struct GroundTruthSequence {
    /// Sequence id, e.g. "0000".
    pub id: String,
    /// Frames in the sequence.
    pub frame_count: usize,
    /// One track per labelled object (DontCare regions and unknown types excluded).
    pub tracks: Vec<Track>,
}

/// Loads sequence `id` of `dir` and builds its ground-truth tracks at frame period `dt`.
///
/// # Errors
/// Any loading error of the sequence's files, with the file named.
pub fn load_ground_truth(dir: &TrackingDir, id: &str, dt: f32) -> anyhow::Result<GroundTruthSequence> {
    let data = dir.load_sequence(id).with_context(|| format!("loading KITTI tracking sequence {id}"))?;
    Ok(ground_truth_of(id, &data, dt))
}

/// Builds ground-truth tracks from loaded sequence data.
#[must_use]
pub fn ground_truth_of(id: &str, data: &SequenceData, dt: f32) -> GroundTruthSequence {
    let observations: Vec<LabelledObservation> = data
        .labels
        .iter()
        .filter(|r| !r.is_dont_care())
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
    GroundTruthSequence { id: id.to_string(), frame_count: data.frame_count, tracks: ground_truth_tracks(&observations, &data.poses, dt) }
}
