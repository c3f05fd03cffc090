//! DynoSAM's hybrid object smoother, run offline over the estimator's fits: a measurement of
//! the formulation, not a part of the estimator.
//!
//! The estimator's chain smoother takes each frame's fit as a motion from its estimate of the
//! previous frame. DynoSAM's hybrid formulation takes the fit as what it is, an absolute
//! measurement of the object's pose against its landmarks, with a constant-motion residual over
//! three consecutive poses (and a vehicle's kinematic prior on each motion); the normal
//! equations are then block-pentadiagonal in the poses. [`rewrite`] solves that by Gauss-Newton
//! over the same fixed-lag window, from the fits the run recorded ([`EstimatorRun::fits`]), and
//! puts its poses in place of the run's causal and smoothed object poses, so Table III scores
//! both formulations on the same fits. The landmarks the fits were made against are still
//! fused by the estimator's own smoother: what the hybrid would change in the map is not in this
//! measurement. A window starts afresh where the object frame is turned (RPE does not pair
//! across a turn either).

use std::collections::{BTreeMap, VecDeque};

use dynotraj_core::estimate::{
    EstimatorParams, NewestFit, PoseEstimate, Smoothness, ad_matrix, adjoint as core_adjoint, moves_like_a_vehicle,
};
use dynotraj_core::geometry::{se3_exp, se3_log};
use nalgebra::{DMatrix, DVector, Isometry3, Matrix6, Vector6};

use super::runner::EstimatorRun;

type Pose = Isometry3<f64>;
type Mat6 = Matrix6<f64>;
type Vec6 = Vector6<f64>;

/// Gauss-Newton iterations per solve at most (the window starts at the last solution, so one
/// or two are enough; the rest stop at convergence).
const MAX_ITERATIONS: usize = 5;
/// An update smaller than this (metres or radians) ends the iterations.
const CONVERGED: f64 = 1e-7;
/// Information added to every diagonal: keeps a pose without any factor solvable.
const REGULARISATION: f64 = 1e-9;

/// The hybrid smoother's settings, from the estimator's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HybridParams {
    /// Poses in the window: a pose leaves it, smoothed, after `window - 1` later frames (the
    /// chain smoother's lag).
    pub window: usize,
    /// Diagonal information of the change of body motion from one frame to the next.
    pub smoothness: [f64; 6],
    /// Diagonal information of a vehicle's body motion once its heading is known.
    pub kinematic: [f64; 6],
    /// What each fit's information is multiplied by (1: the fit's own, as the estimator
    /// weighs it).
    pub fit_weight: f64,
}

impl HybridParams {
    /// The settings the estimator's chain smoother runs with under `params` and `window`.
    #[must_use]
    pub fn of(params: &EstimatorParams, window: usize) -> Self {
        let smoothness = Smoothness::new(&params.object_smoother).information().map(f64::from);
        let kinematic = params.vehicle_kinematics.map_or([0.0; 6], |k| k.information().map(f64::from));
        Self { window: window.max(2), smoothness, kinematic, fit_weight: 1.0 }
    }
}

/// How many of the run's object poses the hybrid smoother replaced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct HybridCounts {
    /// Causal object poses replaced.
    pub causal: usize,
    /// Causal object estimates left out (no fit to start a window from).
    pub causal_left_out: usize,
    /// Smoothed object poses replaced.
    pub smoothed: usize,
    /// Smoothed object estimates left out (the estimator's frames without a window: a run's
    /// first frame, frames before its first fit after a turn).
    pub smoothed_left_out: usize,
    /// Solves whose normal equations were not positive definite (the window keeps its poses).
    pub failed_solves: usize,
}

/// One frame's pose in a window.
#[derive(Debug, Clone, Copy)]
struct Node {
    /// Index of the frame in the run.
    index: usize,
    pose: Pose,
    /// The fit's pose in the world and its information, if the frame had one.
    measured: Option<(Pose, Mat6)>,
    /// The fit's pose in its camera (camera from object), if the frame had one.
    fitted: Option<Pose>,
}

/// What the poses that left a window say of the oldest ones still in it: a Gaussian on the
/// first `poses.len()` poses (at most two: the constant-motion residual spans three poses).
#[derive(Debug, Clone)]
struct Prior {
    poses: Vec<Pose>,
    information: DMatrix<f64>,
}

/// One object's window.
#[derive(Debug, Clone)]
struct Window {
    orientation: u16,
    kinematic: bool,
    nodes: VecDeque<Node>,
    prior: Option<Prior>,
    /// The body motion into the oldest pose, to predict a second pose from the first.
    motion_before: Option<Vec6>,
    /// The causal pose of the newest frame: the previous one moved on by the newest motion as
    /// the window saw it then (never revised, as the estimator's causal output).
    causal: Pose,
}

fn log(p: &Pose) -> Vec6 {
    se3_log(&p.cast::<f32>()).cast::<f64>()
}

fn exp(xi: &Vec6) -> Pose {
    se3_exp(&xi.cast::<f32>()).cast::<f64>()
}

/// The adjoint of `t` on twists `[rho; omega]`: `t exp(xi) = exp(Ad(t) xi) t`.
fn adjoint(t: &Pose) -> Mat6 {
    core_adjoint(&t.cast::<f32>()).cast::<f64>()
}

/// The inverse right Jacobian of SE(3) at `xi` to second order: `log(exp(xi) exp(d)) = xi +
/// Jr^-1(xi) d`. A frame's motion is a metre or more, so its first-order term couples a
/// rotation perturbation into the translation by half a metre per radian: not negligible.
fn inverse_right_jacobian(xi: &Vec6) -> Mat6 {
    let a = ad_matrix(&xi.cast::<f32>()).cast::<f64>();
    Mat6::identity() + a * 0.5 + a * a / 12.0
}

/// The normal equations of one solve, or of the factors on one pose only.
struct Normal {
    h: DMatrix<f64>,
    g: DVector<f64>,
    /// Only factors on this pose are added (what marginalising it needs).
    only_on: Option<usize>,
}

impl Normal {
    fn new(n: usize, only_on: Option<usize>) -> Self {
        Self { h: DMatrix::identity(6 * n, 6 * n) * REGULARISATION, g: DVector::zeros(6 * n), only_on }
    }

    /// Adds the factor `r` (residual) with information `info`, whose Jacobian with respect to
    /// node `i`'s right perturbation is `j` for each `(i, j)` of `jacobians`.
    fn add(&mut self, r: &Vec6, info: &Mat6, jacobians: &[(usize, Mat6)]) {
        if self.only_on.is_some_and(|i| jacobians.iter().all(|(a, _)| *a != i)) {
            return;
        }
        for (a, ja) in jacobians {
            let jt_info = ja.transpose() * info;
            let ga = jt_info * r;
            let mut gv = self.g.rows_mut(6 * a, 6);
            gv += ga;
            for (b, jb) in jacobians {
                let mut block = self.h.view_mut((6 * a, 6 * b), (6, 6));
                block += jt_info * jb;
            }
        }
    }

    /// Adds `prior`, on the first poses of `nodes` (its Jacobian is the identity).
    fn add_prior(&mut self, prior: &Prior, nodes: &VecDeque<Node>) {
        if self.only_on.is_some_and(|i| i != 0) {
            return;
        }
        let k = prior.poses.len().min(nodes.len());
        let mut r = DVector::zeros(6 * k);
        for (i, (z, node)) in prior.poses.iter().zip(nodes).enumerate() {
            r.rows_mut(6 * i, 6).copy_from(&log(&(z.inverse() * node.pose)));
        }
        let info = prior.information.view((0, 0), (6 * k, 6 * k));
        let mut g = self.g.rows_mut(0, 6 * k);
        g += info * r;
        let mut h = self.h.view_mut((0, 0), (6 * k, 6 * k));
        h += info;
    }
}

impl Window {
    fn new(orientation: u16, kinematic: bool, node: Node) -> Self {
        Self {
            orientation,
            kinematic,
            causal: node.pose,
            nodes: VecDeque::from([node]),
            prior: None,
            motion_before: None,
        }
    }

    /// Builds the normal equations at the current poses (only the factors on pose `only_on`
    /// when given).
    fn normal(&self, p: &HybridParams, only_on: Option<usize>) -> Normal {
        let n = self.nodes.len();
        let mut eq = Normal::new(n, only_on);
        let id = Mat6::identity();
        for (i, node) in self.nodes.iter().enumerate() {
            if let Some((z, info)) = &node.measured {
                eq.add(&log(&(z.inverse() * node.pose)), info, &[(i, id)]);
            }
        }
        if let Some(prior) = &self.prior {
            eq.add_prior(prior, &self.nodes);
        }
        // Motion k (into node k, k >= 1): m_k = log(M_k), M_k = L_(k-1)^-1 L_k; its Jacobian is
        // Jr^-1(m_k) for node k and -Jr^-1(m_k) Ad(M_k^-1) for node k - 1.
        let motions: Vec<(Vec6, Mat6, Mat6)> = self
            .nodes
            .iter()
            .zip(self.nodes.iter().skip(1))
            .map(|(a, b)| {
                let m = a.pose.inverse() * b.pose;
                let xi = log(&m);
                let jr_inv = inverse_right_jacobian(&xi);
                (xi, jr_inv, -jr_inv * adjoint(&m.inverse()))
            })
            .collect();
        let smooth = Mat6::from_diagonal(&Vec6::from_column_slice(&p.smoothness));
        let kinematic = Mat6::from_diagonal(&Vec6::from_column_slice(&p.kinematic));
        for (k0, (m, jnow, jprev)) in motions.iter().enumerate() {
            let k = k0 + 1;
            if self.kinematic {
                eq.add(m, &kinematic, &[(k, *jnow), (k - 1, *jprev)]);
            }
            if let Some((m_before, jnow_before, jprev_before)) = k0.checked_sub(1).and_then(|j| motions.get(j)) {
                eq.add(&(m - m_before), &smooth, &[(k, *jnow), (k - 1, jprev - jnow_before), (k - 2, -jprev_before)]);
            }
        }
        eq
    }

    /// Gauss-Newton from the current poses; `false` when the normal equations were not
    /// positive definite (the poses stay as they were).
    fn solve(&mut self, p: &HybridParams) -> bool {
        for _ in 0..MAX_ITERATIONS {
            let eq = self.normal(p, None);
            let Some(chol) = eq.h.cholesky() else { return false };
            let delta = -chol.solve(&eq.g);
            for (i, node) in self.nodes.iter_mut().enumerate() {
                let d = Vec6::from_iterator(delta.rows(6 * i, 6).iter().copied());
                node.pose *= exp(&d);
            }
            if delta.amax() < CONVERGED {
                break;
            }
        }
        true
    }

    /// Re-expresses the window in the object frame turned by `r` (a pose `L` becomes `L r`),
    /// as the estimator turned its own, now of orientation `orientation`.
    fn turn(&mut self, r: &Pose, orientation: u16, kinematic: bool) {
        // A right perturbation d of L is one of Ad(r^-1) d of L r.
        let ad = adjoint(r);
        let info_map = |info: &Mat6| ad.transpose() * info * ad;
        for node in &mut self.nodes {
            node.pose *= r;
            node.fitted = node.fitted.map(|m| m * r);
            node.measured = node.measured.map(|(z, info)| (z * r, info_map(&info)));
        }
        if let Some(prior) = &mut self.prior {
            for z in &mut prior.poses {
                *z *= r;
            }
            let k = prior.poses.len();
            let mut a = DMatrix::zeros(6 * k, 6 * k);
            for i in 0..k {
                a.view_mut((6 * i, 6 * i), (6, 6)).copy_from(&ad);
            }
            prior.information = a.transpose() * &prior.information * a;
        }
        let ad_inv = adjoint(&r.inverse());
        self.motion_before = self.motion_before.map(|m| ad_inv * m);
        self.causal *= r;
        self.orientation = orientation;
        self.kinematic = kinematic;
    }

    /// Removes the oldest pose and marginalises it: the factors on it, linearised at the
    /// current poses, become by their Schur complement a prior on the (at most two) poses they
    /// also touch. `None` when the window is empty.
    fn pop(&mut self, p: &HybridParams) -> Option<Node> {
        let k = self.nodes.len().saturating_sub(1).min(2);
        let eq = self.normal(p, Some(0));
        let old = self.nodes.pop_front()?;
        self.motion_before = self.nodes.front().map(|next| log(&(old.pose.inverse() * next.pose)));
        self.prior = None;
        if k == 0 {
            return Some(old);
        }
        let h00: Mat6 = eq.h.fixed_view::<6, 6>(0, 0).into_owned();
        let h0r = eq.h.view((0, 6), (6, 6 * k)).into_owned();
        let hrr = eq.h.view((6, 6), (6 * k, 6 * k)).into_owned();
        let (g0, gr) = (eq.g.rows(0, 6).into_owned(), eq.g.rows(6, 6 * k).into_owned());
        let Some(h00_inv) = h00.try_inverse() else { return Some(old) };
        let t = h0r.transpose() * h00_inv;
        let info = &hrr - &t * &h0r;
        let b = gr - &t * g0;
        let info = (&info + info.transpose()) * 0.5;
        // The prior's mean: where the marginalised factors alone would put the poses.
        let shift = info.clone().cholesky().map(|c| -c.solve(&b));
        if let Some(shift) = shift {
            let poses = self
                .nodes
                .iter()
                .take(k)
                .enumerate()
                .map(|(i, node)| node.pose * exp(&Vec6::from_iterator(shift.rows(6 * i, 6).iter().copied())))
                .collect();
            self.prior = Some(Prior { poses, information: info });
        }
        Some(old)
    }
}

/// Replaces `run`'s causal and smoothed object poses by the hybrid smoother's over the same
/// fits (see the module docs). An object estimate the hybrid smoother has no pose for (its run
/// not yet fitted since a turn) is left out, and counted: a pose of the other smoother beside
/// its own would put the two smoothers' difference into RPE's pairs.
pub fn rewrite(run: &mut EstimatorRun, p: &HybridParams) -> HybridCounts {
    let mut counts = HybridCounts::default();
    let mut windows: BTreeMap<u16, Window> = BTreeMap::new();
    // Each smoothed pose with the orientation of the window it was solved in.
    let mut smoothed: BTreeMap<(usize, u16), (Pose, u16)> = BTreeMap::new();
    let flush = |w: Window, smoothed: &mut BTreeMap<(usize, u16), (Pose, u16)>, id: u16| {
        for node in w.nodes {
            smoothed.insert((node.index, id), (node.pose, w.orientation));
        }
    };
    for i in 0..run.causal.len() {
        let fits: BTreeMap<u16, NewestFit> = run.fits.get(i).into_iter().flatten().map(|f| (f.object_id, *f)).collect();
        let Some(Some(causal)) = run.causal.get_mut(i) else {
            for (id, w) in std::mem::take(&mut windows) {
                flush(w, &mut smoothed, id);
            }
            continue;
        };
        let camera: Pose = causal.camera.cast::<f64>();
        let present: Vec<u16> = causal.objects.iter().map(|o| o.object_id).collect();
        let gone: Vec<u16> = windows.keys().copied().filter(|id| !present.contains(id)).collect();
        for id in gone {
            if let Some(w) = windows.remove(&id) {
                flush(w, &mut smoothed, id);
            }
        }
        let mut left_out = Vec::new();
        for object in causal.objects.iter_mut() {
            let id = object.object_id;
            let fit = fits.get(&id);
            let mut measured = fit.map(|f| {
                let info = Mat6::from_fn(|r, c| f64::from(f.information[c][r])) * p.fit_weight;
                (camera * f.camera_from_object.cast::<f64>(), (info + info.transpose()) * 0.5)
            });
            let kinematic = object.heading_known && moves_like_a_vehicle(object.class);
            let mut fitted = fit.map(|f| f.camera_from_object.cast::<f64>());
            // The turn since the window's newest frame: its fit then and as the estimator now
            // holds it. The estimator turned its window after this frame's solve and after the
            // frame leaving it was emitted: so does the window here, this frame's fit taken
            // back into the old object frame until then.
            let turned = windows.get(&id).and_then(|w| {
                let last = w.nodes.back().filter(|b| b.index + 1 == i)?;
                (w.orientation != object.orientation).then_some(())?;
                let now = fit?.previous_camera_from_object?.cast::<f64>();
                Some(last.fitted?.inverse() * now)
            });
            if let Some(r) = turned {
                let back = r.inverse();
                let ad = adjoint(&back);
                measured = measured.map(|(z, info)| (z * back, ad.transpose() * info * ad));
                fitted = fitted.map(|m| m * back);
            }
            let continues = turned.is_some()
                || windows.get(&id).is_some_and(|w| {
                    w.orientation == object.orientation && w.nodes.back().is_some_and(|b| b.index + 1 == i)
                });
            if !continues {
                if let Some(w) = windows.remove(&id) {
                    flush(w, &mut smoothed, id);
                }
                let Some((z, _)) = measured else {
                    counts.causal_left_out += 1;
                    left_out.push(id);
                    continue;
                };
                windows.insert(
                    id,
                    Window::new(object.orientation, kinematic, Node { index: i, pose: z, measured, fitted }),
                );
            } else if let Some(w) = windows.get_mut(&id) {
                // A continuing window is never empty.
                let Some(last) = w.nodes.back() else { continue };
                let motion = match w.nodes.len().checked_sub(2).and_then(|j| w.nodes.get(j)) {
                    Some(before) => before.pose.inverse() * last.pose,
                    None => w.motion_before.as_ref().map_or(Pose::identity(), exp),
                };
                let predicted = last.pose * motion;
                w.nodes.push_back(Node { index: i, pose: measured.map_or(predicted, |m| m.0), measured, fitted });
            }
            let Some(w) = windows.get_mut(&id) else { continue };
            if !w.solve(p) {
                counts.failed_solves += 1;
            }
            if continues {
                let n = w.nodes.len();
                if let (Some(a), Some(b)) = (w.nodes.get(n.wrapping_sub(2)), w.nodes.back()) {
                    w.causal *= a.pose.inverse() * b.pose;
                }
            }
            if w.nodes.len() >= p.window
                && let Some(old) = w.pop(p)
            {
                smoothed.insert((old.index, id), (old.pose, w.orientation));
            }
            if let Some(r) = turned {
                w.turn(&r, object.orientation, kinematic);
            }
            object.pose = w.causal.cast::<f32>();
            counts.causal += 1;
        }
        causal.objects.retain(|o| !left_out.contains(&o.object_id));
    }
    for (id, w) in windows {
        flush(w, &mut smoothed, id);
    }
    for (j, e) in run.smoothed.iter_mut().enumerate() {
        let Some(e) = e else { continue };
        let before = e.objects.len();
        // The estimator turns a frame's whole window when it turns an object's frame, so its
        // smoothed estimate of a frame before the turn is in the new orientation; a window
        // here starts afresh at a turn, so its pose of that frame is in the old one.
        e.objects.retain_mut(|o| match smoothed.get(&(j, o.object_id)) {
            Some((pose, orientation)) if *orientation == o.orientation => {
                o.pose = pose.cast::<f32>();
                true
            }
            _ => false,
        });
        counts.smoothed += e.objects.len();
        counts.smoothed_left_out += before - e.objects.len();
    }
    counts
}

/// Leaves out of `run` every object estimate `hybrid` (the same run after [`rewrite`]) left
/// out, so the estimator's poses are scored on the pairs the hybrid smoother's are.
pub fn restrict_to(run: &mut EstimatorRun, hybrid: &EstimatorRun) {
    let keep = |own: &mut [Option<PoseEstimate>], other: &[Option<PoseEstimate>]| {
        for (e, h) in own.iter_mut().zip(other) {
            if let Some(e) = e {
                let ids: Vec<u16> = h.iter().flat_map(|h| h.objects.iter().map(|o| o.object_id)).collect();
                e.objects.retain(|o| ids.contains(&o.object_id));
            }
        }
    };
    keep(&mut run.causal, &hybrid.causal);
    keep(&mut run.smoothed, &hybrid.smoothed);
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests;
