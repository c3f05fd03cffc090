//! Robust pose fit from correspondences: minimal-set RANSAC (3-point TRIAD hypotheses, MSAC
//! scoring on the stereo reprojection residual, a fixed iteration budget with the standard early
//! stop), then Levenberg-Marquardt on a truncated Huber cost, then the fit's information matrix.
//!
//! The pose `m` maps source points into camera k. Both the ego-motion (source = camera k-1) and
//! each object's motion (source = the object's landmarks, in its frame at k-1) are this problem.
//!
//! Source points are taken as exact. A two-view refinement of their depths (each source point
//! one unknown along its ray, eliminated by a Schur complement) was tried: it removes the
//! shrinkage of fitted rotations that noisy source depths cause, but it raised the variance of
//! per-frame object motions so much that object RPE doubled on the KITTI-driven simulator.
//! Averaging object points over frames as landmarks ([`super::landmarks`]) removes most of the
//! shrinkage instead, and lowers the variance too.

use nalgebra::{Matrix6, Vector6};

use super::lie::{Mat6, pose_is_finite};
use super::params::FitParams;
use super::point_model::{Correspondence, PointModel};
use super::rng::Pcg32;
use super::triad::rigid_from_three;
use crate::geometry::{Pose3, se3_exp};

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

/// Fits the pose of `corrs`. `guess` (e.g. the constant-motion prediction) is scored as an extra
/// hypothesis before the random ones.
///
/// # Errors
/// [`FitFailure`] when there are too few points or inliers, or the numbers break down.
pub fn fit_pose(
    corrs: &[Correspondence],
    guess: Option<&Pose3>,
    fp: &FitParams,
    model: &PointModel,
    rng: &mut Pcg32,
) -> Result<Fit, FitFailure> {
    let min_inliers = usize::from(fp.min_inliers).max(3);
    if corrs.len() < min_inliers {
        return Err(FitFailure::TooFewPoints);
    }
    let best = ransac(corrs, guess, fp, model, rng).ok_or(FitFailure::TooFewInliers)?;
    if usize::from(best.1) < min_inliers {
        return Err(FitFailure::TooFewInliers);
    }
    let (pose, normal) = refine(corrs, best.0, fp, model);
    let fit = information(&pose, &normal, fp).ok_or(FitFailure::Numerical)?;
    if usize::from(fit.inliers) < min_inliers {
        return Err(FitFailure::TooFewInliers);
    }
    Ok(fit)
}

/// Score of a pose: MSAC cost (sum of squared residuals truncated at the threshold) and inliers;
/// `None` as soon as the partial cost reaches `bound` (the best cost so far). Every term is
/// non-negative and a rounded sum of non-negative terms never decreases, so a pose stopped
/// early could not have scored below `bound`: the search picks the same pose as a full scoring
/// would, for a fraction of the residuals on poor hypotheses.
fn score(corrs: &[Correspondence], m: &Pose3, tau2: f32, model: &PointModel, bound: f32) -> Option<(f32, u16)> {
    let mut cost = 0.0;
    let mut inliers = 0u16;
    for c in corrs {
        let r2 = model.residual(m, c).map_or(tau2, |r| r.norm_squared());
        if r2 < tau2 {
            cost += r2;
            inliers = inliers.saturating_add(1);
        } else {
            cost += tau2;
        }
        if cost >= bound {
            return None;
        }
    }
    Some((cost, inliers))
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
fn ransac(
    corrs: &[Correspondence],
    guess: Option<&Pose3>,
    fp: &FitParams,
    model: &PointModel,
    rng: &mut Pcg32,
) -> Option<(Pose3, u16)> {
    let tau2 = fp.inlier_px * fp.inlier_px;
    let n = corrs.len();
    let mut best: Option<(Pose3, f32, u16)> = None;
    let mut needed = fp.ransac_iterations;
    // A hypothesis that scores better becomes the best, and the iterations still needed follow
    // its inlier share (recomputed only then: it depends on nothing else).
    let consider = |m: Pose3, best: &mut Option<(Pose3, f32, u16)>, needed: &mut u16| {
        let bound = best.as_ref().map_or(f32::INFINITY, |b| b.1);
        if let Some((cost, inl)) = score(corrs, &m, tau2, model, bound) {
            *best = Some((m, cost, inl));
            *needed = needed_iterations(f32::from(inl) / n as f32, fp.confidence, fp.ransac_iterations);
        }
    };
    if let Some(g) = guess.filter(|g| pose_is_finite(g)) {
        consider(*g, &mut best, &mut needed);
    }
    let mut it = 0u16;
    while it < needed {
        it += 1;
        let Some([i, j, k]) = rng.three_distinct(n) else { break };
        let (Some(a), Some(b), Some(c)) = (corrs.get(i), corrs.get(j), corrs.get(k)) else { continue };
        let src = [a.src, b.src, c.src];
        let dst = [model.target(a), model.target(b), model.target(c)];
        let Some(m) = rigid_from_three(&src, &dst) else { continue };
        consider(m, &mut best, &mut needed);
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

/// Levenberg-Marquardt on the truncated Huber cost from `m`, for at most
/// `fp.refine_iterations` iterations; returns the pose and its normal equations.
///
/// Each iteration costs one pass over the points: the candidate's residuals and Jacobians give
/// both its cost (to accept or reject it) and, when accepted, the next system, and a rejected
/// step keeps the current system (only the damping changes). The loop ends once an accepted
/// step lowers the cost by less than [`COST_DONE`] of it, or once the next step promises less
/// than that: Gauss-Newton converges about quadratically there, so the steps left would move
/// the pose by far less than its noise.
fn refine(corrs: &[Correspondence], mut m: Pose3, fp: &FitParams, model: &PointModel) -> (Pose3, Normal) {
    let mut lambda = LM_START;
    let mut at_m = normal_equations(corrs, &m, fp, model);
    for _ in 0..fp.refine_iterations {
        let mut damped = at_m.h;
        for i in 0..6 {
            if let Some(d) = damped.get_mut((i, i)) {
                *d += lambda * (*d).max(1e-6);
            }
        }
        let Some(chol) = damped.cholesky() else {
            lambda = (lambda * 10.0).min(LM_MAX);
            continue;
        };
        let step: Vector6<f32> = -chol.solve(&at_m.g);
        if !step.iter().all(|v| v.is_finite()) {
            break;
        }
        // The decrease the quadratic model promises for this step; when even that is below
        // COST_DONE of the cost the pose has converged, and the pass over the points that would
        // confirm it (a third of a fit's work) is skipped.
        let promised = -(at_m.g.dot(&step) + 0.5 * step.dot(&(at_m.h * step)));
        if promised <= COST_DONE * at_m.cost {
            break;
        }
        let candidate = super::lie::normalised(m * se3_exp(&step));
        let at_candidate = normal_equations(corrs, &candidate, fp, model);
        if at_candidate.cost < at_m.cost {
            let decrease = at_m.cost - at_candidate.cost;
            m = candidate;
            at_m = at_candidate;
            lambda = (lambda * 0.1).max(LM_MIN);
            if decrease <= COST_DONE * at_m.cost {
                break;
            }
        } else {
            lambda = (lambda * 10.0).min(LM_MAX);
        }
        if step.norm() < STEP_DONE {
            break;
        }
    }
    (m, at_m)
}

/// An accepted step that lowers the cost by less than this share of it ends the refinement.
const COST_DONE: f32 = 1e-3;

/// Gauss-Newton normal equations at a pose, with its robust cost.
#[derive(Debug, Clone, Copy)]
struct Normal {
    /// J^T W J.
    h: Mat6,
    /// J^T W r.
    g: Vector6<f32>,
    /// sum w r^2 over the inliers.
    sq: f32,
    /// Points with a non-zero weight.
    inliers: u16,
    /// Truncated Huber cost over every point (a point without a residual costs the maximum).
    cost: f32,
}

/// The normal equations and robust cost at `m`. J^T W J is accumulated in its lower triangle by
/// symmetric rank-1 updates (it is symmetric) and mirrored once at the end.
fn normal_equations(corrs: &[Correspondence], m: &Pose3, fp: &FitParams, model: &PointModel) -> Normal {
    let mut n = Normal { h: Matrix6::zeros(), g: Vector6::zeros(), sq: 0.0, inliers: 0, cost: 0.0 };
    let rot = m.rotation.to_rotation_matrix().into_inner();
    let t = m.translation.vector;
    // Inside the Huber kernel (most points) cost and weight need no square root, which the MCU
    // computes in software.
    let quadratic = fp.huber_px.min(fp.inlier_px);
    for c in corrs {
        let Some((r, [j0, j1, j2])) = model.linearise(&rot, &t, c) else {
            n.cost += robust_cost(f32::INFINITY, fp.huber_px, fp.inlier_px);
            continue;
        };
        let r2 = r.norm_squared();
        let (cost, w) = if r2 <= quadratic * quadratic {
            (0.5 * r2, 1.0)
        } else {
            let norm = libm::sqrtf(r2);
            (robust_cost(norm, fp.huber_px, fp.inlier_px), robust_weight(norm, fp.huber_px, fp.inlier_px))
        };
        n.cost += cost;
        if w <= 0.0 {
            continue;
        }
        n.h.syger(w, &j0, &j0, 1.0);
        n.h.syger(w, &j1, &j1, 1.0);
        n.h.syger(w, &j2, &j2, 1.0);
        n.g += (j0 * r.x + j1 * r.y + j2 * r.z) * w;
        n.sq += w * r2;
        n.inliers = n.inliers.saturating_add(1);
    }
    n.h.fill_upper_triangle_with_lower_triangle();
    n
}

/// The fit's information: J^T W J over the inliers divided by the a-posteriori residual variance
/// (floored at `min_sigma_px`), so that the information reflects the noise actually seen,
/// including the source points' own depth noise.
fn information(m: &Pose3, n: &Normal, fp: &FitParams) -> Option<Fit> {
    let dof = (3 * usize::from(n.inliers)).saturating_sub(6).max(1) as f32;
    let sigma = libm::sqrtf(n.sq / dof).max(fp.min_sigma_px);
    let information = n.h / (sigma * sigma);
    (pose_is_finite(m) && information.iter().all(|v| v.is_finite()) && sigma.is_finite()).then_some(Fit {
        pose: *m,
        information,
        inliers: n.inliers,
        sigma_px: sigma,
    })
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    extern crate std;
    use super::*;
    use crate::estimate::params::{EstimatorParams, Intrinsics};
    use crate::geometry::{rotation_angle, se3_exp};
    use nalgebra::{Point3, Vector3};
    use std::vec::Vec;

    /// Correspondences of `n` points seen from camera k after the motion `m`, with outliers every
    /// `outlier_every` points and deterministic pixel noise of about `noise` px.
    fn scene(m: &Pose3, n: usize, outlier_every: usize, noise: f32) -> (Vec<Correspondence>, PointModel) {
        let params = EstimatorParams::kitti(Intrinsics::KITTI_0926, 0.1);
        let model = PointModel::new(&params);
        let mut rng = Pcg32::new(9);
        let mut out = Vec::new();
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
            out.push(Correspondence { src, u, v, depth });
        }
        (out, model)
    }

    #[test]
    fn recovers_motion_despite_outliers() {
        let m = se3_exp(&nalgebra::Vector6::new(0.1, 0.02, -1.0, 0.001, 0.02, -0.003));
        let (corrs, model) = scene(&m, 200, 5, 0.3);
        let params = EstimatorParams::kitti(Intrinsics::KITTI_0926, 0.1);
        let mut rng = Pcg32::new(1);
        let fit = fit_pose(&corrs, None, &params.camera_fit, &model, &mut rng).unwrap();
        let err = fit.pose.inverse() * m;
        assert!(err.translation.vector.norm() < 0.02, "{err:?}");
        assert!(rotation_angle(&err) < 1e-3);
        assert!(fit.inliers >= 150 && fit.inliers <= 165, "{}", fit.inliers);
        assert!(fit.information.cholesky().is_some());
    }

    #[test]
    fn a_bounded_score_stops_only_where_the_full_score_could_not_win() {
        let m = se3_exp(&nalgebra::Vector6::new(0.1, 0.02, -1.0, 0.001, 0.02, -0.003));
        let (corrs, model) = scene(&m, 120, 4, 0.5);
        let tau2 = 9.0;
        for k in 0..8 {
            let off = 0.004 * k as f32;
            let pose = m * se3_exp(&nalgebra::Vector6::new(off, -off, 2.0 * off, off * 0.1, -off * 0.2, off * 0.05));
            let (full, inliers) = score(&corrs, &pose, tau2, &model, f32::INFINITY).unwrap();
            for bound in [0.5 * full, full, full * 1.000_001 + 1e-3, 2.0 * full] {
                let bounded = score(&corrs, &pose, tau2, &model, bound);
                assert_eq!(bounded.is_some(), full < bound, "pose {k}, bound {bound} vs cost {full}");
                if let Some(b) = bounded {
                    assert_eq!(b, (full, inliers));
                }
            }
        }
    }

    #[test]
    fn too_few_points_fail_cleanly() {
        let m = Pose3::identity();
        let (corrs, model) = scene(&m, 40, 0, 0.0);
        let params = EstimatorParams::kitti(Intrinsics::KITTI_0926, 0.1);
        let mut rng = Pcg32::new(1);
        assert_eq!(fit_pose(&corrs[..2], None, &params.object_fit, &model, &mut rng), Err(FitFailure::TooFewPoints));
        // All outliers: nothing agrees.
        let bad: Vec<Correspondence> = corrs
            .iter()
            .enumerate()
            .map(|(i, c)| Correspondence { u: c.u + 40.0 * (i % 7) as f32, v: c.v - 30.0 * (i % 5) as f32, ..*c })
            .collect();
        assert!(fit_pose(&bad[..8], None, &params.object_fit, &model, &mut rng).is_err());
        let nan = [Correspondence { src: Vector3::new(f32::NAN, 0.0, 1.0), u: 1.0, v: 1.0, depth: 1.0 }; 10];
        assert!(fit_pose(&nan, None, &params.object_fit, &model, &mut rng).is_err());
    }
}
