//! Robust pose fit from correspondences: minimal-set RANSAC (3-point Kabsch hypotheses, MSAC
//! scoring on the stereo reprojection residual, a fixed iteration budget with the standard early
//! stop), then Levenberg-Marquardt on a truncated Huber cost, then the fit's information matrix.
//!
//! The pose `m` maps source points into camera k. Both the ego-motion (source = camera k-1) and
//! each object's motion (source = the object's frame at k-1) are this problem.
//!
//! The refinement estimates, with the pose, a disparity correction of every inlier's source point
//! (see [`super::model`]) under a Gaussian prior from its measured disparity: a two-view bundle
//! adjustment in which each point has one unknown. The corrections are eliminated point by point
//! (a scalar Schur complement), so an iteration costs O(n) and solves one 6x6 system; the
//! information returned is the pose's marginal information with the corrections eliminated.

use nalgebra::{Matrix6, Vector3, Vector6};

use super::kabsch::kabsch3;
use super::lie::{normalised, pose_is_finite, Mat6};
use super::model::{Correspondence, Correspondences, PointModel};
use super::params::FitParams;
use super::rng::Pcg32;
use crate::geometry::{se3_exp, Pose3};

/// A successful fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fit {
    /// The pose mapping source points into camera k.
    pub pose: Pose3,
    /// Information (inverse covariance) of a right perturbation of `pose`, `[rho; omega]`.
    pub information: Mat6,
    /// Inliers of the final pose.
    pub inliers: u16,
    /// A-posteriori residual standard deviation of the inliers, pixels.
    pub sigma_px: f32,
}

/// Why a fit failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FitFailure {
    /// Fewer correspondences than a minimal set or than the inlier minimum.
    TooFewPoints,
    /// No hypothesis gathered the inlier minimum.
    TooFewInliers,
    /// A singular or non-finite system.
    Numerical,
}

/// Levenberg-Marquardt damping at the start, and its bounds.
const LM_START: f32 = 1e-3;
const LM_MIN: f32 = 1e-7;
const LM_MAX: f32 = 1e7;
/// A step shorter than this (twist norm) ends the refinement.
const STEP_DONE: f32 = 1e-7;

/// Fits the pose of `corrs`, refining their source depths. `guess` (e.g. the constant-motion
/// prediction) is scored as an extra hypothesis before the random ones.
///
/// # Errors
/// [`FitFailure`] when there are too few points or inliers, or the numbers break down.
pub fn fit_pose<const N: usize>(
    corrs: &mut Correspondences<N>,
    guess: Option<&Pose3>,
    fp: &FitParams,
    model: &PointModel,
    rng: &mut Pcg32,
) -> Result<Fit, FitFailure> {
    let min_inliers = usize::from(fp.min_inliers).max(3);
    if corrs.list.len() < min_inliers {
        return Err(FitFailure::TooFewPoints);
    }
    for c in corrs.list.iter_mut() {
        c.delta = 0.0;
        c.delta_trial = 0.0;
    }
    let best = ransac(corrs, guess, fp, model, rng).ok_or(FitFailure::TooFewInliers)?;
    if usize::from(best.1) < min_inliers {
        return Err(FitFailure::TooFewInliers);
    }
    let pose = refine(corrs, best.0, fp, model);
    let fit = information(corrs, &pose, fp, model).ok_or(FitFailure::Numerical)?;
    if usize::from(fit.inliers) < min_inliers {
        return Err(FitFailure::TooFewInliers);
    }
    Ok(fit)
}

/// Score of a pose with the measured source depths: MSAC cost (sum of squared residuals
/// truncated at the threshold) and inliers.
fn score<const N: usize>(corrs: &Correspondences<N>, m: &Pose3, tau2: f32, model: &PointModel) -> (f32, u16) {
    let mut cost = 0.0;
    let mut inliers = 0u16;
    for c in &corrs.list {
        let src = model.source(&corrs.origin, c, 0.0);
        let r2 = model.residual(m, &src, c).map_or(tau2, |r| r.norm_squared());
        if r2 < tau2 {
            cost += r2;
            inliers = inliers.saturating_add(1);
        } else {
            cost += tau2;
        }
    }
    (cost, inliers)
}

/// Hypotheses needed for `confidence` at inlier share `w` with 3-point samples.
fn needed_iterations(w: f32, confidence: f32, budget: u16) -> u16 {
    let w3 = w * w * w;
    if w3 >= 1.0 - 1e-6 {
        return 0;
    }
    let n = libm::logf(1.0 - confidence.clamp(0.0, 0.999_999)) / libm::logf(1.0 - w3.max(1e-6));
    if n.is_finite() && n >= 0.0 {
        // Bounded by the budget before the conversion.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let n = libm::ceilf(n.min(f32::from(budget))) as u16;
        n
    } else {
        budget
    }
}

/// The best hypothesis: (pose, inliers).
fn ransac<const N: usize>(
    corrs: &Correspondences<N>,
    guess: Option<&Pose3>,
    fp: &FitParams,
    model: &PointModel,
    rng: &mut Pcg32,
) -> Option<(Pose3, u16)> {
    let tau2 = fp.inlier_px * fp.inlier_px;
    let n = corrs.list.len();
    let mut best: Option<(Pose3, f32, u16)> = None;
    let consider = |m: Pose3, best: &mut Option<(Pose3, f32, u16)>| {
        let (cost, inl) = score(corrs, &m, tau2, model);
        if best.as_ref().is_none_or(|b| cost < b.1) {
            *best = Some((m, cost, inl));
        }
    };
    if let Some(g) = guess.filter(|g| pose_is_finite(g)) {
        consider(*g, &mut best);
    }
    let mut needed = fp.ransac_iterations;
    if let Some((_, _, inl)) = best {
        needed = needed_iterations(f32::from(inl) / n as f32, fp.confidence, fp.ransac_iterations);
    }
    let mut it = 0u16;
    while it < needed {
        it += 1;
        let Some([i, j, k]) = rng.three_distinct(n) else { break };
        let (Some(a), Some(b), Some(c)) = (corrs.list.get(i), corrs.list.get(j), corrs.list.get(k)) else { continue };
        let o = &corrs.origin;
        let src = [model.source(o, a, 0.0), model.source(o, b, 0.0), model.source(o, c, 0.0)];
        let dst = [model.target(a), model.target(b), model.target(c)];
        let Some(m) = kabsch3(&src, &dst) else { continue };
        consider(m, &mut best);
        if let Some((_, _, inl)) = best {
            needed = needed_iterations(f32::from(inl) / n as f32, fp.confidence, fp.ransac_iterations);
        }
    }
    best.map(|(m, _, inl)| (m, inl))
}

/// Truncated Huber cost of a residual norm `r`: quadratic to `k`, linear to `tau`, flat after.
fn robust_cost(r: f32, k: f32, tau: f32) -> f32 {
    let r = r.min(tau);
    if r <= k { 0.5 * r * r } else { k * (r - 0.5 * k) }
}

/// IRLS weight of a residual norm `r`: 1 to `k`, `k / r` to `tau`, 0 after.
fn robust_weight(r: f32, k: f32, tau: f32) -> f32 {
    if r > tau {
        0.0
    } else if r <= k {
        1.0
    } else {
        k / r
    }
}

/// Robust cost of one correspondence at pose `m` with correction `delta`: the truncated Huber
/// cost of its residual plus, for an inlier, the prior on the correction.
fn point_cost(c: &Correspondence, origin: &Vector3<f32>, m: &Pose3, delta: f32, fp: &FitParams, model: &PointModel) -> f32 {
    let src = model.source(origin, c, delta);
    let r = model.residual(m, &src, c).map_or(f32::INFINITY, |r| r.norm());
    let wd = model.disparity_weight() * delta;
    let prior = if r <= fp.inlier_px { 0.5 * wd * wd } else { 0.0 };
    robust_cost(r, fp.huber_px, fp.inlier_px) + prior
}

/// One point's linearisation: pose block, pose-correction coupling, correction block and the
/// gradients, already weighted.
struct PointBlock {
    h_mm: Mat6,
    h_md: Vector6<f32>,
    h_dd: f32,
    g_m: Vector6<f32>,
    g_d: f32,
    /// Robust weight times squared residual, for the noise estimate.
    wr2: f32,
}

/// The linearisation of correspondence `c` at `(m, c.delta)`, or `None` for an outlier.
fn point_block(c: &Correspondence, origin: &Vector3<f32>, m: &Pose3, fp: &FitParams, model: &PointModel) -> Option<PointBlock> {
    let src = model.source(origin, c, c.delta);
    let (r, j_m, j_p) = model.residual_and_jacobians(m, &src, c)?;
    let w = robust_weight(r.norm(), fp.huber_px, fp.inlier_px);
    if w <= 0.0 {
        return None;
    }
    let wd = model.disparity_weight();
    let j_d = j_p * model.source_derivative(c, c.delta);
    let prior = if model.refines_depth() { wd * wd } else { 1.0 };
    Some(PointBlock {
        h_mm: j_m.transpose() * j_m * w,
        h_md: j_m.transpose() * j_d * w,
        h_dd: w * j_d.norm_squared() + prior,
        g_m: j_m.transpose() * r * w,
        g_d: w * j_d.dot(&r) + prior * c.delta,
        wr2: w * r.norm_squared() + prior * c.delta * c.delta,
    })
}

/// The reduced normal equations at `m` (corrections eliminated): (H, g, sum w r^2, inliers).
fn reduced_system<const N: usize>(corrs: &Correspondences<N>, m: &Pose3, fp: &FitParams, model: &PointModel) -> (Mat6, Vector6<f32>, f32, u16) {
    let mut h = Matrix6::zeros();
    let mut g = Vector6::zeros();
    let mut sq = 0.0;
    let mut inliers = 0u16;
    for c in &corrs.list {
        let Some(b) = point_block(c, &corrs.origin, m, fp, model) else { continue };
        h += b.h_mm - b.h_md * b.h_md.transpose() / b.h_dd;
        g += b.g_m - b.h_md * (b.g_d / b.h_dd);
        sq += b.wr2;
        inliers = inliers.saturating_add(1);
    }
    (h, g, sq, inliers)
}

/// Levenberg-Marquardt from `m` over the pose and the source corrections, for a fixed number of
/// iterations. The corrections of accepted steps are kept in the correspondences.
fn refine<const N: usize>(corrs: &mut Correspondences<N>, mut m: Pose3, fp: &FitParams, model: &PointModel) -> Pose3 {
    let origin = corrs.origin;
    let mut lambda = LM_START;
    let mut cost: f32 = corrs.list.iter().map(|c| point_cost(c, &origin, &m, c.delta, fp, model)).sum();
    for _ in 0..fp.refine_iterations {
        let (h, g, _, _) = reduced_system(corrs, &m, fp, model);
        let mut damped = h;
        for i in 0..6 {
            if let Some(d) = damped.get_mut((i, i)) {
                *d += lambda * (*d).max(1e-6);
            }
        }
        let Some(chol) = damped.cholesky() else {
            lambda = (lambda * 10.0).min(LM_MAX);
            continue;
        };
        let step: Vector6<f32> = -chol.solve(&g);
        if !step.iter().all(|v| v.is_finite()) {
            break;
        }
        // Back-substitute each point's correction step, then evaluate the candidate.
        let candidate = normalised(m * se3_exp(&step));
        let mut c_cost = 0.0;
        for c in corrs.list.iter_mut() {
            c.delta_trial = match point_block(c, &origin, &m, fp, model) {
                Some(b) if model.refines_depth() => c.delta - (b.g_d + b.h_md.dot(&step)) / b.h_dd,
                _ => c.delta,
            };
            if !c.delta_trial.is_finite() {
                c.delta_trial = c.delta;
            }
            c_cost += point_cost(c, &origin, &candidate, c.delta_trial, fp, model);
        }
        if c_cost < cost {
            m = candidate;
            cost = c_cost;
            for c in corrs.list.iter_mut() {
                c.delta = c.delta_trial;
            }
            lambda = (lambda * 0.1).max(LM_MIN);
        } else {
            lambda = (lambda * 10.0).min(LM_MAX);
        }
        if step.norm() < STEP_DONE {
            break;
        }
    }
    m
}

/// The fit's information: the reduced (corrections eliminated) J^T W J over the inliers divided
/// by the a-posteriori residual variance (floored at `min_sigma_px`), so that the information
/// reflects the noise actually seen.
fn information<const N: usize>(corrs: &Correspondences<N>, m: &Pose3, fp: &FitParams, model: &PointModel) -> Option<Fit> {
    let (h, _, sq, inliers) = reduced_system(corrs, m, fp, model);
    let dof = (3 * usize::from(inliers)).saturating_sub(6).max(1) as f32;
    let sigma = libm::sqrtf(sq / dof).max(fp.min_sigma_px);
    let information = h / (sigma * sigma);
    (pose_is_finite(m) && information.iter().all(|v| v.is_finite()) && sigma.is_finite())
        .then_some(Fit { pose: *m, information, inliers, sigma_px: sigma })
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    extern crate std;
    use super::*;
    use crate::estimate::params::{EstimatorParams, Intrinsics};
    use crate::geometry::{rotation_angle, se3_exp};
    use nalgebra::{Point3, Vector3};

    /// Correspondences of `n` points seen from camera k after the motion `m`, with outliers every
    /// `outlier_every` points and deterministic pixel noise of about `noise` px.
    fn scene(m: &Pose3, n: usize, outlier_every: usize, noise: f32) -> (Correspondences<256>, PointModel) {
        let params = EstimatorParams::kitti(Intrinsics::KITTI_0926, 0.1);
        let model = PointModel::new(&params);
        let mut rng = Pcg32::new(9);
        let mut out = Correspondences::new();
        for i in 0..n {
            let src = Vector3::new(
                rng.below(2000) as f32 / 100.0 - 10.0,
                rng.below(400) as f32 / 100.0 - 2.0,
                5.0 + rng.below(2500) as f32 / 100.0,
            );
            let p = m.transform_point(&Point3::from(src));
            let Some((mut u, mut v)) = model.project(&p) else { continue };
            let jitter = |g: &mut Pcg32| (g.below(1000) as f32 / 1000.0 - 0.5) * 2.0 * noise;
            u += jitter(&mut rng);
            v += jitter(&mut rng);
            let mut depth = p.z;
            if outlier_every > 0 && i % outlier_every == 0 {
                u += 25.0;
                depth *= 1.5;
            }
            let _ = out.list.push(Correspondence { ray: src / src.z, src_depth: src.z, u, v, depth, ..Default::default() });
        }
        (out, model)
    }

    #[test]
    fn recovers_motion_despite_outliers() {
        let m = se3_exp(&nalgebra::Vector6::new(0.1, 0.02, -1.0, 0.001, 0.02, -0.003));
        let (mut corrs, model) = scene(&m, 200, 5, 0.3);
        let params = EstimatorParams::kitti(Intrinsics::KITTI_0926, 0.1);
        let mut rng = Pcg32::new(1);
        let fit = fit_pose(&mut corrs, None, &params.camera_fit, &model, &mut rng).unwrap();
        let err = fit.pose.inverse() * m;
        assert!(err.translation.vector.norm() < 0.02, "{err:?}");
        assert!(rotation_angle(&err) < 1e-3);
        assert!(fit.inliers >= 150 && fit.inliers <= 165, "{}", fit.inliers);
        assert!(fit.information.cholesky().is_some());
    }

    #[test]
    fn depth_refinement_removes_the_rotation_bias_of_noisy_far_points() {
        // A small object 30 m ahead turning by 3 degrees; source depths with 1.2 m of noise.
        let params = EstimatorParams::kitti(Intrinsics::KITTI_0926, 0.1);
        let model = PointModel::new(&params);
        let turn = se3_exp(&nalgebra::Vector6::new(0.3, 0.0, 0.0, 0.0, 0.052, 0.0));
        let place = Pose3::translation(0.0, 0.0, 30.0);
        let m = place * turn;
        let mut rng = Pcg32::new(5);
        let gauss = |g: &mut Pcg32| (0..12).map(|_| g.below(10_000) as f32 / 10_000.0).sum::<f32>() - 6.0;
        let mut corrs = Correspondences::<256>::new();
        for _ in 0..120 {
            let body = Vector3::new(rng.below(400) as f32 / 100.0 - 2.0, rng.below(150) as f32 / 100.0 - 0.75, rng.below(180) as f32 / 100.0 - 0.9);
            let truth_src = body;
            let p = m.transform_point(&Point3::from(truth_src));
            let (u, v) = model.project(&p).unwrap();
            let depth = 387.5744 / (387.5744 / p.z + 0.5 * gauss(&mut rng));
            // Source seen from a camera at the object frame's -30 m: its ray and noisy depth.
            let cam_src = place.transform_point(&Point3::from(truth_src));
            let z0 = 387.5744 / (387.5744 / cam_src.z + 0.5 * gauss(&mut rng));
            let ray = place.inverse().rotation * (cam_src.coords / cam_src.z);
            let _ = corrs.list.push(Correspondence { ray, src_depth: z0, u: u + 0.5 * gauss(&mut rng), v: v + 0.5 * gauss(&mut rng), depth, ..Default::default() });
        }
        corrs.origin = place.inverse().translation.vector;
        let fit = fit_pose(&mut corrs, Some(&place), &params.object_fit, &model, &mut rng).unwrap();
        let yaw = (place.inverse() * fit.pose).rotation.scaled_axis().y;
        // Taking the noisy source depths as exact gives about 0.03 here (attenuation).
        assert!((yaw - 0.052).abs() < 0.01, "yaw {yaw} vs 0.052");
    }

    #[test]
    fn too_few_points_fail_cleanly() {
        let m = Pose3::identity();
        let (corrs, model) = scene(&m, 40, 0, 0.0);
        let params = EstimatorParams::kitti(Intrinsics::KITTI_0926, 0.1);
        let mut rng = Pcg32::new(1);
        let mut two = Correspondences::<256>::new();
        two.list.extend(corrs.list.iter().take(2).copied());
        assert_eq!(fit_pose(&mut two, None, &params.object_fit, &model, &mut rng), Err(FitFailure::TooFewPoints));
        // All outliers: nothing agrees.
        let mut bad = Correspondences::<256>::new();
        bad.list.extend(corrs.list.iter().take(8).enumerate().map(|(i, c)| Correspondence { u: c.u + 40.0 * (i % 7) as f32, v: c.v - 30.0 * (i % 5) as f32, ..*c }));
        assert!(fit_pose(&mut bad, None, &params.object_fit, &model, &mut rng).is_err());
        let mut nan = Correspondences::<256>::new();
        nan.list.extend([Correspondence { ray: Vector3::new(f32::NAN, 0.0, 1.0), src_depth: 1.0, u: 1.0, v: 1.0, depth: 1.0, ..Default::default() }; 10]);
        assert!(fit_pose(&mut nan, None, &params.object_fit, &model, &mut rng).is_err());
    }
}
