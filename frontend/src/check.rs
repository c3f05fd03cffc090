//! The front-end on the few real KITTI images at hand (`../shared/kitti`), with ground truth:
//! - stereo: D1 of the matcher on a KITTI 2015 stereo pair against its ground-truth disparity;
//! - odometry 06, frames 12-14: KLT survival of the static corners, and the ego-motion of the
//!   front-end's tracks fitted by the core's robust pose fit, against the ground-truth poses.
//!
//! Only frame 12 of odometry 06 has a right image here, so only frame 12 has stereo depth: the
//! motions 12->13 and 12->14 are fitted 3D-2D (frame 12's back-projected points against the
//! tracked pixels in 13 and 14) with the core's [`fit_pose`] and its disparity residual
//! disabled (`stereo_fb = 0`), i.e. a robust PnP. The observed depth a 3D-2D correspondence
//! lacks is set to the source depth; it only seeds the 3-point Kabsch hypotheses, since the
//! scoring and refinement then use pixels only. Frame 14 exists here only in colour, so the
//! colour images (converted to grey) are used for all frames, with camera.yaml's `bf`.

use std::path::Path;

use dynotraj_core::estimate::{Correspondence, EstimatorParams, Intrinsics, Pcg32, PointModel, fit_pose};
use dynotraj_core::geometry::Pose3;
use nalgebra::Isometry3;
use opencv::core::{CV_16UC1, Mat, Scalar};
use opencv::prelude::*;

use super::depth::DepthMap;
use super::error::{FrontEndError, cv};
use super::image_io::{read_grey, read_u16, same_size};
use super::masks::Instances;
use super::stereo::{D1, Stereo, StereoParams, d1_error};
use super::tracker::{Tracker, TrackerParams};

/// D1 of the stereo stage on `<root>/stereo2015/training/{image_2,image_3,disp_occ_0}/<name>`.
///
/// # Errors
/// Missing or unreadable images, named.
pub fn stereo2015_d1(root: &Path, name: &str, params: StereoParams) -> Result<D1, FrontEndError> {
    let dir = root.join("stereo2015/training");
    let (lp, rp, gp) =
        (dir.join("image_2").join(name), dir.join("image_3").join(name), dir.join("disp_occ_0").join(name));
    let left = read_grey(&lp, "left image")?;
    let right = read_grey(&rp, "right image")?;
    same_size(&right, &rp, &left, &lp)?;
    let truth = read_u16(&gp, "ground-truth disparity")?;
    same_size(&truth, &gp, &left, &lp)?;
    let map = Stereo::new(params)?.disparity(&left, &right)?;
    d1_error(&map, &truth)
}

/// One frame pair's ego-motion error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionError {
    /// Correspondences fitted.
    pub points: usize,
    /// Inliers of the fit.
    pub inliers: u16,
    /// Translation error, metres.
    pub translation_m: f64,
    /// Rotation error, degrees.
    pub rotation_deg: f64,
    /// The true translation, metres (for scale).
    pub true_translation_m: f64,
}

/// What the odometry check measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryCheck {
    /// Static corners sent at frame 12 (with stereo depth).
    pub corners: usize,
    /// KLT survival (forward-backward checked) 12 -> 13 and 13 -> 14.
    pub survival: [f64; 2],
    /// Ego-motion error 12 -> 13 and 12 -> 14.
    pub motion: [Option<MotionError>; 2],
    /// The tracker's counters after frame 14.
    pub stats: super::FrontEndStats,
}

/// Reads `Camera.<key>: value` from an ORB-SLAM style camera.yaml.
fn yaml_number(text: &str, path: &Path, key: &str) -> Result<f64, FrontEndError> {
    text.lines()
        .find_map(|l| {
            l.trim()
                .strip_prefix(key)
                .and_then(|r| r.trim().strip_prefix(':'))
                .and_then(|v| v.trim().parse::<f64>().ok())
        })
        .ok_or_else(|| FrontEndError::Unreadable {
            path: path.to_path_buf(),
            expected: format!("a camera.yaml with a numeric `{key}`"),
        })
}

/// The odometry check on `<root>/odometry/06` (frames 12, 13, 14).
///
/// # Errors
/// Missing or unreadable files, named.
pub fn odometry06(root: &Path, stereo: StereoParams, params: TrackerParams) -> Result<OdometryCheck, FrontEndError> {
    let dir = root.join("odometry/06");
    let yaml_path = dir.join("camera.yaml");
    let yaml = std::fs::read_to_string(&yaml_path)
        .map_err(|source| FrontEndError::Io { path: yaml_path.clone(), cause: source })?;
    let num = |k: &str| yaml_number(&yaml, &yaml_path, k);
    let (fx, fy, cx, cy, bf) =
        (num("Camera.fx")?, num("Camera.fy")?, num("Camera.cx")?, num("Camera.cy")?, num("Camera.bf")?);
    let poses_path = dir.join("poses_gt.txt");
    let poses = dynotraj_formats::kitti::read_poses(&poses_path)
        .map_err(|e| FrontEndError::Unreadable { path: poses_path.clone(), expected: format!("KITTI poses ({e})") })?;
    let pose = |k: usize| {
        poses.get(k).copied().ok_or_else(|| FrontEndError::Unreadable {
            path: poses_path.clone(),
            expected: format!("a pose for frame {k}"),
        })
    };

    let frames: Vec<(std::path::PathBuf, Mat)> = [12, 13, 14]
        .iter()
        .map(|k| {
            let p = dir.join(format!("kitti06-{k}-color.png"));
            read_grey(&p, "left image").map(|m| (p, m))
        })
        .collect::<Result<_, _>>()?;
    let rp = dir.join("kitti06-12-R-color.png");
    let right = read_grey(&rp, "right image of frame 12")?;
    same_size(&right, &rp, &frames[0].1, &frames[0].0)?;
    for (p, m) in &frames[1..] {
        same_size(m, p, &frames[0].1, &frames[0].0)?;
    }
    let disparity = Stereo::new(stereo)?.disparity(&frames[0].1, &right)?;
    let depth12 = DepthMap::Stereo { disparity, fb: bf as f32 };
    let (w, h) = (frames[0].1.cols(), frames[0].1.rows());
    let background = Instances {
        labels: Mat::new_rows_cols_with_default(h, w, CV_16UC1, Scalar::all(0.0)).map_err(cv("label image"))?,
        objects: Vec::new(),
        empty: 0,
    };
    // Frames 13 and 14 have no depth: the tracker still follows their points.
    let no_depth = DepthMap::Given(
        Mat::new_rows_cols_with_default(h, w, opencv::core::CV_32F, Scalar::all(0.0)).map_err(cv("depth image"))?,
    );
    let mut tracker = Tracker::new(params);
    let sent12 = tracker.process(&frames[0].1, &depth12, &background)?;
    let mut survival = [0.0; 2];
    let mut motion = [None, None];
    let mut est_params = EstimatorParams::kitti(
        Intrinsics { fx: fx as f32, fy: fy as f32, cx: cx as f32, cy: cy as f32, stereo_fb: 0.0 },
        0.1,
    );
    est_params.pixel_sigma = 1.0;
    let model = PointModel::new(&est_params);
    for (i, k) in [13usize, 14].iter().enumerate() {
        let before = tracker.stats;
        tracker.process(&frames[i + 1].1, &no_depth, &background)?;
        let s = tracker.stats;
        let tracked = s.static_tracked - before.static_tracked;
        let tried =
            tracked + (s.static_lost - before.static_lost) + (s.static_failed_check - before.static_failed_check);
        survival[i] = if tried == 0 { 0.0 } else { tracked as f64 / tried as f64 };
        let now = tracker.static_points();
        let corrs: Vec<Correspondence> = sent12
            .iter()
            .filter_map(|t| {
                let (_, u, v) = now.iter().find(|(id, _, _)| *id == t.track_id)?;
                let src = model.back_project(t.u, t.v, t.depth).coords;
                Some(Correspondence { src, u: *u, v: *v, depth: t.depth })
            })
            .collect();
        let truth = pose(*k)?.inverse() * pose(12)?;
        motion[i] = fit_pose(&corrs, Some(&Pose3::identity()), &est_params.camera_fit, &model, &mut Pcg32::new(1))
            .ok()
            .map(|fit| {
                let est: Isometry3<f64> = fit.pose.cast::<f64>();
                let e = truth.inverse() * est;
                MotionError {
                    points: corrs.len(),
                    inliers: fit.inliers,
                    translation_m: e.translation.vector.norm(),
                    rotation_deg: e.rotation.angle().to_degrees(),
                    true_translation_m: truth.translation.vector.norm(),
                }
            });
    }
    Ok(OdometryCheck { corners: sent12.len(), survival, motion, stats: tracker.stats })
}
