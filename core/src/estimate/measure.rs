//! Turning a frame pair into a motion measurement: correspondences from matched tracks, the
//! robust fit, and the conversion of the fit into a body-frame twist with its information.

use heapless::Vec;
use nalgebra::Point3;

use super::fit::{Fit, fit_pose};
use super::frame::Obs;
use super::lie::{Mat6, Vec6, ad_matrix, adjoint, map_information};
use super::matching::for_each_match;
use super::motion_smoother::{ChainScratch, Smoothness};
use super::params::FitParams;
use super::point_model::{Correspondence, PointModel};
use super::rng::Pcg32;
use crate::geometry::{Pose3, se3_log};
use crate::limits::MAX_STATIC_TRACKS;

/// What a motion measurement works with, lent by the estimator for one measurement: the point
/// model, the RANSAC generator, room for correspondences, and the smoother's prior and scratch
/// of the path the measured step joins.
pub struct Measuring<'a, const W: usize> {
    /// The point measurement model.
    pub model: &'a PointModel,
    /// The robust fit's sampling.
    pub rng: &'a mut Pcg32,
    /// Correspondences, filled per measurement.
    pub corrs: &'a mut Correspondences,
    /// The smoother's prior of the path measured.
    pub smoothness: &'a Smoothness,
    /// The smoother's scratch.
    pub scratch: &'a mut ChainScratch<W>,
}

/// Most correspondences of one fit: the larger of the static and the per-object capacity.
pub const MAX_CORRESPONDENCES: usize = MAX_STATIC_TRACKS;
const _: () = assert!(crate::limits::MAX_POINTS_PER_OBJECT <= MAX_CORRESPONDENCES);

/// The correspondence scratch shared by all fits of a frame.
pub type Correspondences = Vec<Correspondence, MAX_CORRESPONDENCES>;

/// Fills `out` with the tracks of `previous` (frame k-1) matched by id in `current` (frame k),
/// each previous point back-projected and mapped by `to_source` (camera k-1 -> source frame).
pub fn correspondences(
    previous: &[Obs],
    current: &[Obs],
    to_source: &Pose3,
    model: &PointModel,
    out: &mut Correspondences,
) {
    out.clear();
    for_each_match(previous, current, |p, c| {
        let src = to_source.transform_point(&model.back_project(p.u(), p.v(), p.depth)).coords;
        // Cannot overflow: both lists are at most MAX_CORRESPONDENCES long.
        let _ = out.push(Correspondence { src, u: c.u(), v: c.v(), depth: c.depth });
    });
}

/// A motion measurement: the body-frame motion `delta` and, for the chain, its twist and the
/// twist's information.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionMeasurement {
    /// The measured motion.
    pub delta: Pose3,
    /// `log(delta)`.
    pub xi: Vec6,
    /// Information of `xi`.
    pub information: Mat6,
    /// Inliers of the fit.
    pub inliers: u16,
}

/// Measures the motion `delta` in `camera_k^-1 * frame * delta = m`, where `m` is the fitted
/// pose from the source frame (`frame` at k-1) into camera k and `a = camera_k^-1 * frame` is
/// known. `guess` is the expected `delta` (constant motion). `None` when the fit fails.
pub fn measure_motion(
    corrs: &Correspondences,
    a: &Pose3,
    guess: &Pose3,
    fp: &FitParams,
    model: &PointModel,
    rng: &mut Pcg32,
) -> Option<MotionMeasurement> {
    let m_guess = a * guess;
    let Fit { pose, information, inliers, .. } = fit_pose(corrs, Some(&m_guess), fp, model, rng).ok()?;
    let information =
        with_shared_depth_error(&information, &pose, model.depth_error(pose.translation.z, fp.shared_disparity_px));
    // A right perturbation of m is a right perturbation of delta, so the information carries over.
    let delta = a.inverse() * pose;
    plausible(&delta, fp).then(|| twist_measurement(&delta, &information, inliers)).flatten()
}

/// The information of a right perturbation of `m` (source -> camera) once the source frame's
/// origin is also uncertain by `sigma` metres along its viewing ray: the rank-one covariance
/// `sigma^2 e e^T`, `e = [R^T u; 0]` with `u` the ray, added by Sherman-Morrison. Unchanged for
/// a zero `sigma`, an origin at the camera or a result that is not finite.
#[must_use]
pub fn with_shared_depth_error(info: &Mat6, m: &Pose3, sigma: f32) -> Mat6 {
    let t = m.translation.vector;
    let norm = t.norm();
    if !(sigma > 0.0 && norm > 0.0 && sigma.is_finite()) {
        return *info;
    }
    let v = m.rotation.inverse() * (t / norm);
    let e = Vec6::new(v.x, v.y, v.z, 0.0, 0.0, 0.0);
    let ie = info * e;
    let denom = 1.0 / (sigma * sigma) + e.dot(&ie);
    let out = info - ie * ie.transpose() / denom;
    if denom > 0.0 && out.iter().all(|x| x.is_finite()) { out } else { *info }
}

/// True when a frame-to-frame motion is within the fit's plausibility bounds.
#[must_use]
pub fn plausible(delta: &Pose3, fp: &FitParams) -> bool {
    delta.rotation.angle() <= fp.max_rotation && delta.translation.vector.norm() <= fp.max_translation
}

/// The twist form of a measured motion with information `info` on a right perturbation:
/// `log(delta * exp(d)) ~ log(delta) + (I + ad(xi) / 2) d` to first order (BCH).
#[must_use]
pub fn twist_measurement(delta: &Pose3, info: &Mat6, inliers: u16) -> Option<MotionMeasurement> {
    let xi = se3_log(delta);
    let jac = Mat6::identity() + ad_matrix(&xi) * 0.5;
    let information = map_information(info, &jac)?;
    (xi.iter().all(|v| v.is_finite()) && information.iter().all(|v| v.is_finite())).then_some(MotionMeasurement {
        delta: *delta,
        xi,
        information,
        inliers,
    })
}

/// The information of `n = m^-1` given the information of a right perturbation of `m`:
/// `(m exp(d))^-1 = n exp(-Ad(m) d)`.
#[must_use]
pub fn inverse_information(m: &Pose3, info: &Mat6) -> Option<Mat6> {
    map_information(info, &(-adjoint(m)))
}

/// The robust centroid of camera-frame points mapped to the world by `camera`: the per-axis
/// median, then the mean of the points within `radius` of it. `None` without points.
pub fn robust_centroid(points: &[Obs], camera: &Pose3, model: &PointModel, radius: f32) -> Option<Point3<f32>> {
    let mut axis: Vec<f32, { crate::limits::MAX_POINTS_PER_OBJECT }> = Vec::new();
    let world = |o: &Obs| camera.transform_point(&model.back_project(o.u(), o.v(), o.depth));
    let mut median = [0.0f32; 3];
    for (d, m) in median.iter_mut().enumerate() {
        axis.clear();
        for o in points {
            let p = world(o);
            let _ = axis.push(p.coords.get(d).copied().unwrap_or(0.0));
        }
        if axis.is_empty() {
            return None;
        }
        let mid = axis.len() / 2;
        let (_, v, _) = axis.select_nth_unstable_by(mid, f32::total_cmp);
        *m = *v;
    }
    let median = Point3::from(median);
    let (mut sum, mut n) = (nalgebra::Vector3::zeros(), 0u32);
    for o in points {
        let p = world(o);
        if (p - median).norm() <= radius {
            sum += p.coords;
            n += 1;
        }
    }
    let c = if n > 0 { Point3::from(sum / n as f32) } else { median };
    c.coords.iter().all(|v| v.is_finite()).then_some(c)
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion, Vector3};

    #[test]
    fn a_shared_depth_error_lowers_the_information_along_the_ray_only() {
        let info = Mat6::identity() * 100.0;
        // The source frame's origin 40 m ahead and 3 m right of camera k, the frame turned 0.5 rad.
        let m = Pose3::from_parts(
            Translation3::new(3.0, 0.0, 40.0),
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 0.5),
        );
        assert_eq!(with_shared_depth_error(&info, &m, 0.0), info);
        let sigma = 0.5;
        let out = with_shared_depth_error(&info, &m, sigma);
        // The ray in the source frame's axes (rho is a right perturbation).
        let ray = m.rotation.inverse() * m.translation.vector.normalize();
        let e = Vec6::new(ray.x, ray.y, ray.z, 0.0, 0.0, 0.0);
        // Along the ray the variance is the points' (1/100) plus sigma^2.
        let along = (out * e).dot(&e);
        assert!((1.0 / along - (0.01 + sigma * sigma)).abs() < 1e-4, "{along}");
        // Across it, and in rotation, nothing changes.
        let across = Vector3::y().cross(&ray).normalize();
        let c = Vec6::new(across.x, across.y, across.z, 0.0, 0.0, 0.0);
        assert!(((out * c).dot(&c) - 100.0).abs() < 1e-3);
        assert!((out[(3, 3)] - 100.0).abs() < 1e-4);
    }
}
