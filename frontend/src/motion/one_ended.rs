//! The motion segmentation's verdict where depth is known at one end only: a corner with stereo
//! depth in an earlier frame, followed into a later frame that has none (a single stereo pair
//! and the left frames after it). The corner is judged on its image position alone, under the
//! same noise model as a probe, and the moving ones are clustered as the probes are.

use dynotraj_core::estimate::PointModel;
use dynotraj_core::geometry::Pose3;

use super::cluster::{clusters, coherent};
use super::{MotionParams, Seen, normalised_residual};

/// A corner's pixel and depth then, and its pixel now.
pub type OneEndedCorner = ((f32, f32, f32), (f32, f32));

/// What the one-ended verdict found.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct OneEndedSegments {
    /// Corners judged.
    pub judged: usize,
    /// Corners judged moving.
    pub moving: usize,
    /// The moving objects: each the indices of its corners in the input.
    pub segments: Vec<Vec<usize>>,
}

/// Judges `corners` (pixel and depth then, pixel now) against the camera motion `pose` from
/// then to now, with stereo `fb` for the depth's noise, and clusters the moving ones into
/// objects as [`super::MotionSegmenter`] does (at least [`MotionParams::min_points`] corners
/// whose residual directions agree).
#[must_use]
pub fn segments_one_ended(
    corners: &[OneEndedCorner],
    pose: &Pose3,
    model: &PointModel,
    fb: f32,
    p: &MotionParams,
) -> OneEndedSegments {
    let mut out = OneEndedSegments::default();
    let mut moving = Vec::new();
    let mut directions = Vec::new();
    for (i, &((u0, v0, z), (u1, v1))) in corners.iter().enumerate() {
        let then = Seen { u: u0, v: v0, depth: Some(z), around: None };
        let now = Seen { u: u1, v: v1, depth: None, around: None };
        let Some((r, m2)) = normalised_residual(model, pose, (&then, &now), fb, p) else { continue };
        out.judged += 1;
        if m2 > p.moving_sigmas * p.moving_sigmas {
            out.moving += 1;
            moving.push((i, pose.transform_point(&model.back_project(u0, v0, z))));
            directions.push(r.try_normalize(1e-6).unwrap_or_else(nalgebra::Vector3::zeros));
        }
    }
    for members in clusters(&moving, model, p.link_m) {
        if members.len() >= p.min_points && coherent(&members, &directions, p.min_coherence) {
            out.segments.push(members.iter().filter_map(|&m| moving.get(m).map(|(i, _)| *i)).collect());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynotraj_core::estimate::{EstimatorParams, Intrinsics};

    #[test]
    fn a_static_scene_has_no_segment_and_a_group_moving_alike_is_one() {
        let model = PointModel::new(&EstimatorParams::kitti(Intrinsics::KITTI_0926, 0.1));
        let fb = Intrinsics::KITTI_0926.stereo_fb;
        // The camera drives 1 m forward: static points move in the image as the motion says.
        let pose = Pose3::translation(0.0, 0.0, -1.0);
        let project = |x: f32, y: f32, z: f32| {
            let (u, v) = model.project(&nalgebra::Point3::new(x, y, z)).unwrap();
            (u, v)
        };
        let corner = |x: f32, y: f32, z: f32, moved: f32| {
            let (u0, v0) = project(x, y, z);
            ((u0, v0, z), project(x + moved, y, z - 1.0))
        };
        let mut corners: Vec<_> =
            (0..40).map(|i| corner(-6.0 + 0.3 * i as f32, 1.0, 12.0 + 0.2 * i as f32, 0.0)).collect();
        let p = MotionParams::default();
        let still = segments_one_ended(&corners, &pose, &model, fb, &p);
        assert_eq!((still.judged, still.moving, still.segments.len()), (40, 0, 0), "{still:?}");
        // Eight points of a car 15 m ahead, moving 0.8 m to the side as well.
        corners.extend((0..8).map(|i| corner(2.0 + 0.2 * i as f32, 0.5, 15.0, 0.8)));
        let found = segments_one_ended(&corners, &pose, &model, fb, &p);
        assert_eq!(found.segments, vec![(40..48).collect::<Vec<_>>()], "{found:?}");
    }
}
