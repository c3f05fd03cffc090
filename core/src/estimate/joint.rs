//! The joint fixed-lag solve: camera motions and object motions of the window refined together.
//!
//! # The model
//!
//! Variables: the camera's body motions `c_1 .. c_n` and each object's body motions
//! `xi_1 .. xi_m` over the window (twists). Factors, all Gaussian:
//! - camera: each frame's ego-motion fit (`z^c_k`, `Lambda^c_k`) and the camera's
//!   constant-motion prior ([`super::ChainSmoother`]);
//! - object: its constant-motion prior, and per frame its point fit. An object's points at frame
//!   k measure `m_k = C_k^-1 L_k` (camera k from object frame). With the object pose at k-1 and
//!   the camera pose at k-1 held, its body motion is `delta_k = L_(k-1)^-1 C_(k-1) n_k m_k`,
//!   where `n_k = exp(c_k)` is the camera motion. The fit was made with the frame-to-frame
//!   camera motion `c̄_k`; to first order in `c_k - c̄_k`
//!
//!   `xi_k = z_k + B_k (c_k - c̄_k)`,  `B_k = (I + ad(z_k)/2) Ad(m_k^-1) (I - ad(c̄_k)/2)`
//!
//!   (right perturbation `n exp(e)` moves `delta` to `delta exp(Ad(m^-1) e)`; the outer factors
//!   are the first-order Jacobians of log and exp). So the object factor is
//!   `xi_k - z_k - B_k (c_k - c̄_k) ~ N(0, Lambda_k^-1)`: it ties each object motion to the
//!   camera motion of the same frame and nothing else. Objects are coupled to each other only
//!   through the camera.
//!
//! # The solve
//!
//! The joint normal equations are block-tridiagonal per chain plus one 6x6 coupling block per
//! (object, frame) between the object's and the camera's motion of that frame. Eliminating
//! objects onto the camera exactly fills the camera's system densely (each object's chain
//! couples all its frames: a 6W x 6W matrix, 57 KiB at W = 20), which the RAM budget does not
//! hold. Instead, block Gauss-Seidel with a fixed number of sweeps ([`JOINT_SWEEPS`]): each
//! sweep solves every object chain exactly with the camera held, accumulates each object's
//! factors onto the camera's diagonal blocks (`B^T Lambda B`, `B^T Lambda y` with
//! `y = xi - z + B c̄`), then solves the camera chain exactly with the objects held. Each block
//! solve minimises the joint cost over its block, so the cost never rises and the iteration
//! converges to the joint optimum (block Gauss-Seidel on a symmetric positive definite system);
//! a final object solve makes the objects consistent with the last camera solution. Memory:
//! this scratch (camera solution, its linearisation twists, one accumulated block per frame).
//!
//! # Leaving the window
//!
//! The camera's oldest motion is marginalised from its own factors (the object factors' share
//! of its information is dropped: conservative); each object's oldest slot is first conditioned
//! on the camera motion as solved (`z += B (c - c̄)`, the camera fixed) and then marginalised in
//! its own chain. That keeps every chain's memory fixed; exact joint marginalisation would
//! couple all chains' priors.

use super::lie::{Mat6, PackedSym6, VEC6_ZERO, Vec6, ad_matrix, adjoint, lin_to_pose};
use super::motion_smoother::{ChainScratch, ChainSmoother, SlotView, Smoothness};
pub use super::params::JOINT_SWEEPS;

/// The coupling `B` of an object slot to the camera motion `c_bar` it was measured against.
#[must_use]
pub fn coupling(object: &SlotView, c_bar: &Vec6) -> Mat6 {
    let m = lin_to_pose(&object.lin);
    (Mat6::identity() + ad_matrix(&object.z) * 0.5)
        * adjoint(&m.inverse())
        * (Mat6::identity() - ad_matrix(c_bar) * 0.5)
}

/// Scratch and state of one joint solve: the camera's current solution over the window, the
/// camera motions the objects were measured against, and the object factors accumulated onto
/// each camera frame.
#[derive(Debug, Clone, PartialEq)]
pub struct JointScratch<const W: usize> {
    camera_x: [Vec6; W],
    c_bar: [Vec6; W],
    acc_info: [PackedSym6; W],
    acc_rhs: [Vec6; W],
    n: usize,
    first_step: u32,
}

impl<const W: usize> Default for JointScratch<W> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const W: usize> JointScratch<W> {
    /// Empty scratch (no camera: objects are solved alone).
    #[must_use]
    pub const fn new() -> Self {
        Self {
            camera_x: [VEC6_ZERO; W],
            c_bar: [VEC6_ZERO; W],
            acc_info: [PackedSym6::ZERO; W],
            acc_rhs: [VEC6_ZERO; W],
            n: 0,
            first_step: 0,
        }
    }

    /// Takes the camera chain (oldest slot at step `first_step`) and its solution `xs`.
    pub fn load_camera(&mut self, chain: &ChainSmoother<W>, first_step: u32, xs: &[Vec6]) {
        self.n = 0;
        self.first_step = first_step;
        for (j, (x, (cx, cb))) in xs.iter().zip(self.camera_x.iter_mut().zip(self.c_bar.iter_mut())).enumerate() {
            let Some(slot) = chain.slot(j) else { break };
            *cx = *x;
            *cb = Vec6::from_column_slice(&slot.lin);
            self.n = j + 1;
        }
    }

    /// Forgets the camera (its solve failed): objects are then solved alone.
    pub fn unload_camera(&mut self) {
        self.n = 0;
    }

    /// The camera's solution, oldest first.
    #[must_use]
    pub fn camera_solution(&self) -> &[Vec6] {
        self.camera_x.get(..self.n).unwrap_or(&[])
    }

    /// Replaces the camera's solution (after a camera solve with the object factors).
    pub fn set_camera_solution(&mut self, xs: &[Vec6]) {
        for (d, x) in self.camera_x.iter_mut().zip(xs).take(self.n) {
            *d = *x;
        }
    }

    fn camera_index(&self, step: u32) -> Option<usize> {
        let j = step.checked_sub(self.first_step)? as usize;
        (j < self.n).then_some(j)
    }

    /// Object slot `i` of `chain` (oldest slot at `first_step`) and the camera frame it is
    /// coupled to: `(slot, B, c_current - c_bar)`, or `None` when uncoupled.
    fn coupled(&self, chain: &ChainSmoother<W>, first_step: u32, i: usize) -> Option<(SlotView, Mat6, usize)> {
        let step = first_step.checked_add(u32::try_from(i).ok()?)?;
        let j = self.camera_index(step)?;
        let slot = chain.slot(i).filter(|s| s.measured)?;
        let b = coupling(&slot, self.c_bar.get(j)?);
        b.iter().all(|v| v.is_finite()).then_some((slot, b, j))
    }

    /// The object factor of slot `i` with the camera held: extra right-hand side
    /// `Lambda B (c - c_bar)` (the measurement moved by the camera's correction).
    #[must_use]
    pub fn object_extra(&self, chain: &ChainSmoother<W>, first_step: u32, i: usize) -> Option<(Mat6, Vec6)> {
        let (slot, b, j) = self.coupled(chain, first_step, i)?;
        let d = self.camera_x.get(j)? - self.c_bar.get(j)?;
        Some((Mat6::zeros(), slot.info * (b * d)))
    }

    /// The shift of the oldest object slot's measurement that fixes its camera motion at the
    /// current solution, `B (c - c_bar)`, before the slot is marginalised.
    #[must_use]
    pub fn front_shift(&self, chain: &ChainSmoother<W>, first_step: u32) -> Option<Vec6> {
        let (_, b, j) = self.coupled(chain, first_step, 0)?;
        Some(b * (self.camera_x.get(j)? - self.c_bar.get(j)?))
    }

    /// Empties the accumulated object factors.
    pub fn clear_factors(&mut self) {
        self.acc_info.iter_mut().for_each(|a| *a = PackedSym6::ZERO);
        self.acc_rhs.iter_mut().for_each(|a| *a = Vec6::zeros());
    }

    /// Adds an object's factors, with its motions held at `xs`, onto the camera frames.
    pub fn accumulate(&mut self, chain: &ChainSmoother<W>, first_step: u32, xs: &[Vec6]) {
        for (i, x) in xs.iter().enumerate() {
            let Some((slot, b, j)) = self.coupled(chain, first_step, i) else { continue };
            let Some(c_bar) = self.c_bar.get(j) else { continue };
            let bt_l = b.transpose() * slot.info;
            let y = x - slot.z + b * c_bar;
            let (info, rhs) = (bt_l * b, bt_l * y);
            if !(info.iter().all(|v| v.is_finite()) && rhs.iter().all(|v| v.is_finite())) {
                continue;
            }
            if let (Some(a), Some(r)) = (self.acc_info.get_mut(j), self.acc_rhs.get_mut(j)) {
                *a = PackedSym6::pack(&(a.unpack() + (info + info.transpose()) * 0.5));
                *r += rhs;
            }
        }
    }

    /// The accumulated object factors on camera frame `j`.
    #[must_use]
    pub fn camera_extra(&self, j: usize) -> Option<(Mat6, Vec6)> {
        (j < self.n).then(|| Some((self.acc_info.get(j)?.unpack(), *self.acc_rhs.get(j)?))).flatten()
    }
}

/// How the joint solve weighs and iterates: the constant-motion priors of the camera and of
/// the objects, and the number of sweeps.
#[derive(Debug, Clone, Copy)]
pub struct JointSettings<'p> {
    /// The camera chain's prior.
    pub camera_prior: &'p Smoothness,
    /// Every object chain's prior.
    pub object_prior: &'p Smoothness,
    /// Gauss-Seidel sweeps after the camera's first solve.
    pub sweeps: u8,
}

/// Block Gauss-Seidel over the window: the camera chain alone first, then `settings.sweeps`
/// sweeps of (every object chain with the camera held, the camera chain with the objects held).
/// Each object is `(chain, step of its oldest slot)`; `objects` is called once per sweep. Leaves
/// the camera's solution in `joint`, or an empty one if the camera's solve failed.
pub fn solve_joint<'a, const W: usize, I>(
    joint: &mut JointScratch<W>,
    camera: &ChainSmoother<W>,
    camera_first_step: u32,
    settings: JointSettings<'_>,
    scratch: &mut ChainScratch<W>,
    mut objects: impl FnMut() -> I,
) where
    I: Iterator<Item = (&'a ChainSmoother<W>, u32)>,
{
    let JointSettings { camera_prior, object_prior, sweeps } = settings;
    match camera.solve(camera_prior, scratch) {
        Some(n) => joint.load_camera(camera, camera_first_step, scratch.solution(n)),
        None => {
            joint.unload_camera();
            return;
        }
    }
    for _ in 0..sweeps {
        joint.clear_factors();
        let mut coupled = false;
        for (chain, first) in objects() {
            if chain.is_empty() {
                continue;
            }
            if let Some(n) = chain.solve_with(object_prior, scratch, |i| joint.object_extra(chain, first, i)) {
                joint.accumulate(chain, first, scratch.solution(n));
                coupled = true;
            }
        }
        if !coupled {
            break;
        }
        if let Some(n) = camera.solve_with(camera_prior, scratch, |j| joint.camera_extra(j)) {
            joint.set_camera_solution(scratch.solution(n));
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::estimate::lie::pose_to_lin;
    use crate::geometry::{se3_exp, se3_log};

    #[test]
    fn coupling_is_the_first_order_effect_of_the_camera_motion() {
        // delta(c) = A exp(c) m with A = L_(k-1)^-1 C_(k-1): log(delta(c_bar + d)) - log(delta(c_bar)) ~ B d.
        let a = se3_exp(&Vec6::new(0.3, -0.1, -12.0, 0.01, 0.2, -0.02));
        let m = se3_exp(&Vec6::new(2.0, 1.5, 15.0, 0.02, -0.4, 0.01));
        let c_bar = Vec6::new(0.05, 0.01, 0.9, 0.002, 0.01, -0.001);
        let delta = |c: &Vec6| a * se3_exp(c) * m;
        let z = se3_log(&delta(&c_bar));
        let slot = SlotView { z, info: Mat6::identity(), measured: true, lin: pose_to_lin(&m) };
        let b = coupling(&slot, &c_bar);
        let d = Vec6::new(1e-3, -2e-3, 3e-3, 1e-4, -2e-4, 1e-4);
        let got = se3_log(&delta(&(c_bar + d))) - z;
        let want = b * d;
        assert!((got - want).norm() < 0.05 * want.norm(), "{got:?} vs {want:?}");
        // Without the Jacobian terms it would be worse: the test can tell.
        let plain = adjoint(&m.inverse()) * d;
        assert!((got - plain).norm() > (got - want).norm());
    }

    /// The joint normal equations of a camera chain and two object chains over 4 frames, built
    /// densely in f64 and solved directly: block Gauss-Seidel must converge to that solution.
    #[test]
    fn gauss_seidel_converges_to_the_dense_joint_solution() {
        use crate::estimate::params::SmootherParams;
        const N: usize = 4;
        const REG: f64 = 1e-6;
        let cam_s = Smoothness::new(&SmootherParams { sigma_translation: 0.05, sigma_rotation: 0.005 });
        let obj_s = Smoothness::new(&SmootherParams { sigma_translation: 0.02, sigma_rotation: 0.002 });
        let v = |a: f32, b: f32| Vec6::new(0.1 * a, -0.02 * b, a, 0.001 * b, 0.01 * a, -0.002);
        let info_c = Mat6::from_diagonal(&Vec6::new(4e4, 4e4, 1e4, 1e7, 1e7, 1e7));
        let info_o = Mat6::from_diagonal(&Vec6::new(400.0, 400.0, 100.0, 1e4, 1e4, 1e4));
        let mut cam = ChainSmoother::<N>::new();
        let mut objs = [ChainSmoother::<N>::new(), ChainSmoother::<N>::new()];
        let ms =
            [se3_exp(&Vec6::new(3.0, 1.0, 15.0, 0.0, 0.3, 0.0)), se3_exp(&Vec6::new(-4.0, 1.2, 25.0, 0.01, -0.2, 0.0))];
        for k in 0..N {
            let kf = k as f32;
            let c = v(1.0 + 0.05 * kf, kf);
            let mut lin = [0.0; 6];
            lin.iter_mut().zip(c.iter()).for_each(|(a, b)| *a = *b);
            // The measured camera twist differs from the one objects were measured against (a
            // held frame would): the coupling must move the objects.
            let z_c = c + Vec6::new(0.01 * (kf - 1.5), 0.0, 0.02, 1e-4 * kf, -2e-4, 0.0);
            assert!(cam.push(Some((&z_c, &info_c)), &lin));
            for (o, chain) in objs.iter_mut().enumerate() {
                let z = v(0.5 + 0.1 * kf * (o as f32 + 1.0), 1.0 - kf);
                assert!(chain.push(Some((&z, &info_o)), &pose_to_lin(&ms[o])));
            }
        }
        let mut joint = JointScratch::<N>::new();
        let mut scratch = ChainScratch::<N>::new();
        let objects = || objs.iter().map(|c| (c, 1u32));
        let settings = JointSettings { camera_prior: &cam_s, object_prior: &obj_s, sweeps: 60 };
        solve_joint(&mut joint, &cam, 1, settings, &mut scratch, objects);
        let gs_cam: [Vec6; N] = core::array::from_fn(|j| joint.camera_solution()[j]);

        // Dense: variables [c_1..c_N, xi^0_1..xi^0_N, xi^1_1..xi^1_N].
        const D: usize = 6 * N * 3;
        let mut a = nalgebra::SMatrix::<f64, D, D>::zeros();
        let mut b = nalgebra::SVector::<f64, D>::zeros();
        let f = |m: &Mat6| m.map(f64::from);
        let fv = |m: &Vec6| m.map(f64::from);
        let add_prior = |a: &mut nalgebra::SMatrix<f64, D, D>, base: usize, s: &Smoothness| {
            let d = f(&s.matrix());
            for k in 1..N {
                let (i, j) = (base + 6 * k, base + 6 * (k - 1));
                let mut blk = a.fixed_view_mut::<6, 6>(i, i);
                blk += &d;
                let mut blk = a.fixed_view_mut::<6, 6>(j, j);
                blk += &d;
                let mut blk = a.fixed_view_mut::<6, 6>(i, j);
                blk -= &d;
                let mut blk = a.fixed_view_mut::<6, 6>(j, i);
                blk -= &d;
            }
        };
        for j in 0..N {
            let s = cam.slot(j).unwrap();
            let mut blk = a.fixed_view_mut::<6, 6>(6 * j, 6 * j);
            blk += &(f(&s.info) + nalgebra::Matrix6::identity() * REG);
            let mut blk = b.fixed_rows_mut::<6>(6 * j);
            blk += &(f(&s.info) * fv(&s.z));
        }
        add_prior(&mut a, 0, &cam_s);
        for (o, chain) in objs.iter().enumerate() {
            let base = 6 * N * (o + 1);
            add_prior(&mut a, base, &obj_s);
            for k in 0..N {
                let s = chain.slot(k).unwrap();
                let c_bar = Vec6::from_column_slice(&cam.slot(k).unwrap().lin);
                let bm = f(&coupling(&s, &c_bar));
                let l = f(&s.info);
                // r = xi - B c - (z - B c_bar); J = [-B, I] on (c, xi).
                let y = fv(&s.z) - bm * fv(&c_bar);
                let (ci, xi) = (6 * k, base + 6 * k);
                let mut blk = a.fixed_view_mut::<6, 6>(ci, ci);
                blk += &(bm.transpose() * l * bm);
                let mut blk = a.fixed_view_mut::<6, 6>(xi, xi);
                blk += &(l + nalgebra::Matrix6::identity() * REG);
                let mut blk = a.fixed_view_mut::<6, 6>(ci, xi);
                blk -= &(bm.transpose() * l);
                let mut blk = a.fixed_view_mut::<6, 6>(xi, ci);
                blk -= &(l * bm);
                let mut blk = b.fixed_rows_mut::<6>(ci);
                blk -= &(bm.transpose() * l * y);
                let mut blk = b.fixed_rows_mut::<6>(xi);
                blk += &(l * y);
            }
        }
        let x = a.lu().solve(&b).unwrap();
        let mut moved = 0.0f64;
        for j in 0..N {
            let want = x.fixed_rows::<6>(6 * j);
            let got = fv(&gs_cam[j]);
            assert!((got - want).norm() < 1e-4, "camera {j}: {got:?} vs {want:?}");
            moved += (want - fv(&cam.slot(j).unwrap().z)).norm();
        }
        // The objects' final solve with the camera held at the joint solution matches too.
        for (o, chain) in objs.iter().enumerate() {
            let n = chain.solve_with(&obj_s, &mut scratch, |i| joint.object_extra(chain, 1, i)).unwrap();
            for k in 0..n {
                let want = x.fixed_rows::<6>(6 * N * (o + 1) + 6 * k);
                let got = fv(&scratch.solution(n)[k]);
                assert!((got - want).norm() < 1e-3 * want.norm().max(1.0), "object {o} frame {k}: {got:?} vs {want:?}");
            }
        }
        assert!(moved > 1e-3, "the coupling moved nothing: the test could not fail");
    }
}
