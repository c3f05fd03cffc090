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
use opencv::core::{CV_8UC1, CV_16UC1, Mat, Point2f, Scalar};
use opencv::prelude::*;

use super::depth::DepthMap;
use super::error::{FrontEndError, cv};
use super::features::detect;
use super::image_io::{read_grey, read_u16, same_size};
use super::masks::{Detection, Instances, from_boxes};
use super::motion::{MotionParams, OneEndedCorner, segments_one_ended};
use super::stereo::{D1, Stereo, StereoParams, d1_error};
use super::tracker::{Tracker, TrackerParams};

/// The left and right images (grey) and ground-truth disparity of KITTI stereo 2015 training
/// pair `name` under `root`.
///
/// # Errors
/// Missing or unreadable images, or images of different sizes, named.
fn read_stereo2015(root: &Path, name: &str) -> Result<(Mat, Mat, Mat), FrontEndError> {
    let dir = root.join("stereo2015/training");
    let (lp, rp, gp) =
        (dir.join("image_2").join(name), dir.join("image_3").join(name), dir.join("disp_occ_0").join(name));
    let left = read_grey(&lp, "left image")?;
    let right = read_grey(&rp, "right image")?;
    same_size(&right, &rp, &left, &lp)?;
    let truth = read_u16(&gp, "ground-truth disparity")?;
    same_size(&truth, &gp, &left, &lp)?;
    Ok((left, right, truth))
}

/// D1 of the stereo stage on `<root>/stereo2015/training/{image_2,image_3,disp_occ_0}/<name>`.
///
/// # Errors
/// Missing or unreadable images, named.
pub fn stereo2015_d1(root: &Path, name: &str, params: StereoParams) -> Result<D1, FrontEndError> {
    let (left, right, truth) = read_stereo2015(root, name)?;
    let map = Stereo::new(params)?.disparity(&left, &right)?;
    d1_error(&map, &truth)
}

/// The hand-placed box (l, t, r, b) of the one car of KITTI stereo 2015 training pair
/// 000046_10 (the set has no object maps here); its car pixels are the box's ground-truth pixels
/// with at least 0.7 x the box's median disparity, which leaves out the far background in the
/// box's corners.
pub const CAR_BOX_000046: [f32; 4] = [608.0, 180.0, 840.0, 262.0];

/// Disparity errors against ground truth over a set of pixels or points.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PairErrors {
    /// Pixels (or points) with ground truth and an estimate.
    pub scored: usize,
    /// Pixels (or points) with ground truth but no estimate.
    pub missing: usize,
    /// Mean absolute error over the scored ones, pixels.
    pub mean_abs_px: f64,
    /// Median absolute error over the scored ones, pixels.
    pub median_abs_px: f64,
    /// Mean signed error (estimate minus truth), pixels.
    pub bias_px: f64,
    /// Share of the scored ones off by more than 3 px and 5 % (KITTI's D1 without the missing).
    pub d1: f64,
}

impl PairErrors {
    fn of(errors: &[(f32, f32)], missing: usize) -> Self {
        let n = errors.len();
        if n == 0 {
            return Self { missing, ..Self::default() };
        }
        let mut abs: Vec<f64> = errors.iter().map(|(e, _)| f64::from(e.abs())).collect();
        abs.sort_by(f64::total_cmp);
        Self {
            scored: n,
            missing,
            mean_abs_px: abs.iter().sum::<f64>() / n as f64,
            median_abs_px: abs.get(n / 2).copied().unwrap_or(f64::NAN),
            bias_px: errors.iter().map(|(e, _)| f64::from(*e)).sum::<f64>() / n as f64,
            d1: errors.iter().filter(|(e, gt)| e.abs() > 3.0 && e.abs() > 0.05 * gt).count() as f64 / n as f64,
        }
    }
}

/// The stereo front-end on the real pair against its ground truth: the dense map over all pixels
/// and over the car's, and at the points the tracker would send (corners over the whole image,
/// and a grid of textured pixels of the car's mask refined by depth from its box), with the dense
/// value and with the sub-pixel refinement.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RealPairCheck {
    /// Dense map, all ground-truth pixels.
    pub dense_all: PairErrors,
    /// Dense map, the car's pixels.
    pub dense_car: PairErrors,
    /// Corners: the dense value at the point.
    pub corners_dense: PairErrors,
    /// Corners: refined to sub-pixel.
    pub corners_subpixel: PairErrors,
    /// Car points: the dense value.
    pub car_dense: PairErrors,
    /// Car points: refined to sub-pixel over the car's mask.
    pub car_subpixel: PairErrors,
}

/// [`RealPairCheck`] of `<root>/stereo2015/training/.../<name>` with the car box `car`.
///
/// # Errors
/// Missing or unreadable images, named.
pub fn stereo2015_points(
    root: &Path,
    name: &str,
    car: [f32; 4],
    params: StereoParams,
    tracker: &TrackerParams,
) -> Result<RealPairCheck, FrontEndError> {
    let (left, right, truth) = read_stereo2015(root, name)?;
    let disparity = Stereo::new(params)?.disparity(&left, &right)?;
    let gt_at = |u: i32, v: i32| -> Option<f32> {
        truth.at_2d::<u16>(v, u).ok().copied().filter(|g| *g > 0).map(|g| f32::from(g) / 256.0)
    };
    let in_box = |u: f32, v: f32| u >= car[0] && u <= car[2] && v >= car[1] && v <= car[3];
    let mut box_gt: Vec<f32> = Vec::new();
    for v in 0..truth.rows() {
        for u in 0..truth.cols() {
            if let Some(g) = gt_at(u, v).filter(|_| in_box(u as f32, v as f32)) {
                box_gt.push(g);
            }
        }
    }
    box_gt.sort_by(f32::total_cmp);
    let car_floor = 0.7 * box_gt.get(box_gt.len() / 2).copied().unwrap_or(f32::MAX);
    let is_car = |u: f32, v: f32, g: f32| in_box(u, v) && g >= car_floor;
    let (mut all, mut on_car) = (Vec::new(), Vec::new());
    let (mut all_missing, mut car_missing) = (0, 0);
    for v in 0..truth.rows() {
        for u in 0..truth.cols() {
            let Some(g) = gt_at(u, v) else { continue };
            let car_pixel = is_car(u as f32, v as f32, g);
            match disparity.at(u as f32, v as f32) {
                Some(d) => {
                    all.push((d - g, g));
                    if car_pixel {
                        on_car.push((d - g, g));
                    }
                }
                None => {
                    all_missing += 1;
                    car_missing += usize::from(car_pixel);
                }
            }
        }
    }
    // Depth only shapes the car's mask (its depth tolerance is in metres); disparities are
    // compared as disparities, so KITTI's usual f b serves here.
    let fb = 389.6;
    let depth = DepthMap::Stereo { disparity: disparity.clone(), fb, pair: Some((left.clone(), right.clone())) };
    let car_det = Detection { bbox: car, class: dynotraj_core::wire::ObjectClass::Car, object_id: Some(1) };
    let inst = from_boxes(left.cols(), left.rows(), &[(1, car_det)], &depth)?;
    let label = |x: i64, y: i64| -> Option<u16> {
        let (x, y) = (i32::try_from(x).ok()?, i32::try_from(y).ok()?);
        inst.labels.at_2d::<u16>(y, x).ok().copied()
    };
    let background = Mat::new_rows_cols_with_default(left.rows(), left.cols(), CV_8UC1, Scalar::all(255.0))
        .map_err(cv("corner mask"))?;
    let corners = detect(&left, &background, &[], 1000, &tracker.detect)?.points;
    let mut car_points = Vec::new();
    for v in (car[1] as i32..=car[3] as i32).step_by(3) {
        for u in (car[0] as i32..=car[2] as i32).step_by(3) {
            if label(i64::from(u), i64::from(v)) == Some(1) {
                car_points.push(Point2f::new(u as f32, v as f32));
            }
        }
    }
    let subpixel = tracker.subpixel.unwrap_or_default();
    let score = |points: &[Point2f], refine: bool| {
        let (mut errors, mut missing) = (Vec::new(), 0);
        for q in points {
            let Some(g) = gt_at(q.x.round() as i32, q.y.round() as i32) else { continue };
            let own = label(q.x.round() as i64, q.y.round() as i64);
            let z = if refine {
                depth.at_point(q.x, q.y, |x, y| label(x, y) == own, Some(&subpixel)).0
            } else {
                depth.at(q.x, q.y)
            };
            match z {
                Some(z) => errors.push((fb / z - g, g)),
                None => missing += 1,
            }
        }
        PairErrors::of(&errors, missing)
    };
    Ok(RealPairCheck {
        dense_all: PairErrors::of(&all, all_missing),
        dense_car: PairErrors::of(&on_car, car_missing),
        corners_dense: score(&corners, false),
        corners_subpixel: score(&corners, true),
        car_dense: score(&car_points, false),
        car_subpixel: score(&car_points, true),
    })
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
#[derive(Debug, Clone, PartialEq)]
pub struct OdometryCheck {
    /// Static corners sent at frame 12 (with stereo depth).
    pub corners: usize,
    /// KLT survival (forward-backward checked) 12 -> 13 and 13 -> 14.
    pub survival: [f64; 2],
    /// Ego-motion error 12 -> 13 and 12 -> 14.
    pub motion: [Option<MotionError>; 2],
    /// The tracker's counters after frame 14.
    pub stats: super::FrontEndStats,
    /// The motion segmentation's verdict on the corners of frame 12 in frames 13 and 14, under
    /// the fitted ego-motion (the street is static: every segment is false).
    pub segments: [Option<super::motion::OneEndedSegments>; 2],
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
    let depth12 = DepthMap::Stereo { disparity, fb: bf as f32, pair: None };
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
    let mut segments = [None, None];
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
        // Each corner of frame 12 still tracked: its pixel and depth then, its pixel now.
        let corners: Vec<OneEndedCorner> = sent12
            .iter()
            .filter_map(|t| {
                let (_, u, v) = now.iter().find(|(id, _, _)| *id == t.track_id)?;
                Some(((t.u, t.v, t.depth), (*u, *v)))
            })
            .collect();
        let corrs: Vec<Correspondence> = corners
            .iter()
            .map(|&((u0, v0, z), (u, v))| Correspondence { src: model.back_project(u0, v0, z).coords, u, v, depth: z })
            .collect();
        let truth = pose(*k)?.inverse() * pose(12)?;
        let fit = fit_pose(&corrs, Some(&Pose3::identity()), &est_params.camera_fit, &model, &mut Pcg32::new(1)).ok();
        if let (Some(fit), Some(slot)) = (&fit, segments.get_mut(i)) {
            *slot = Some(segments_one_ended(&corners, &fit.pose, &model, bf as f32, &MotionParams::default()));
        }
        motion[i] = fit.map(|fit| {
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
    Ok(OdometryCheck { corners: sent12.len(), survival, motion, stats: tracker.stats, segments })
}
