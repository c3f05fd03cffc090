//! The fixed-lag smoother of one chain of per-frame motions, in fixed memory.
//!
//! Variables: the body-frame motions `xi_1 .. xi_n` (twists, one per frame of the window,
//! `n <= W`) of one object (or of the camera). Factors, all Gaussian in the twists:
//! - a measurement per frame: the frame-to-frame fit's twist `z_i` with its information
//!   `Lambda_i` (the point measurements' Laplace approximation; a frame without a fit has none);
//! - a constant-motion prior between consecutive motions, `xi_i - xi_(i-1) ~ N(0, S^-1)` with
//!   `S` diagonal from [`SmootherParams`] (DynoSAM's smoothing factor);
//! - a prior on `xi_1`: what the frames that left the window said (exact marginalisation).
//!
//! The normal equations are block-tridiagonal with 6x6 blocks and are solved exactly in O(W)
//! by block forward elimination and back substitution. Each 6x6 inversion is Jacobi-scaled,
//! because rotations (radians) and translations (metres) have information a million apart.
//! The model is linear in the twists, so one solve is the optimum: nothing to relinearise.
//!
//! Memory: `W` slots of 27 floats (twist and packed information), plus one prior; the solve's
//! scratch ([`ChainScratch`]) is shared by all chains.

use heapless::Deque;

use super::lie::{Mat6, PackedSym6, VEC6_ZERO, Vec6, lin_to_pose, map_information, pose_to_lin};
use super::params::SmootherParams;

/// Information added to every diagonal block: keeps a window without any measurement solvable
/// (a standard deviation of 1000 m or rad, i.e. no information).
const REGULARISATION: f32 = 1e-6;

/// One frame's measurement of its motion.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Slot {
    /// Measured twist.
    z: [f32; 6],
    /// Its information (zero for a frame without a fit).
    info: PackedSym6,
    /// What couples this slot to another chain in the joint solve ([`super::joint`]): for the
    /// camera the twist the objects of this frame were measured against, for an object the
    /// fitted camera-from-object pose (translation, rotation vector).
    lin: [f32; 6],
}

/// A read-only view of one slot, for the joint solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlotView {
    /// Measured twist.
    pub z: Vec6,
    /// Its information (zero for a frame without a fit).
    pub info: Mat6,
    /// Whether the frame has a measurement (non-zero information).
    pub measured: bool,
    /// The coupling data (see the slot's docs).
    pub lin: [f32; 6],
}

/// The information `1 / sigma^2` of a standard deviation; 0 (no information) for a
/// non-positive or non-finite one.
const fn information_of(sigma: f32) -> f32 {
    if sigma.is_finite() && sigma > 0.0 { 1.0 / (sigma * sigma) } else { 0.0 }
}

/// The diagonal information of the constant-motion prior.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Smoothness {
    diag: Vec6,
}

impl Smoothness {
    /// The prior of `p`. Non-positive or non-finite sigmas give no smoothing.
    #[must_use]
    pub const fn new(p: &SmootherParams) -> Self {
        let (t, r) = (information_of(p.sigma_translation), information_of(p.sigma_rotation));
        Self { diag: Vec6::new(t, t, t, r, r, r) }
    }

    pub(crate) fn matrix(&self) -> Mat6 {
        Mat6::from_diagonal(&self.diag)
    }

    /// The diagonal information on the change of a body twist `[rho; omega]` per frame.
    #[must_use]
    pub fn information(&self) -> [f32; 6] {
        self.diag.into()
    }
}

/// Scratch of one solve: per slot the inverse of the eliminated diagonal block (symmetric, so
/// packed) and the eliminated right-hand side, which back substitution overwrites with the
/// solution.
#[derive(Debug, Clone, PartialEq)]
pub struct ChainScratch<const W: usize> {
    d_inv: [PackedSym6; W],
    y: [Vec6; W],
}

impl<const W: usize> ChainScratch<W> {
    /// Zeroed scratch.
    #[must_use]
    pub const fn new() -> Self {
        Self { d_inv: [PackedSym6::ZERO; W], y: [VEC6_ZERO; W] }
    }

    /// The solution of the last solve, oldest slot first.
    #[must_use]
    pub fn solution(&self, n: usize) -> &[Vec6] {
        self.y.get(..n).unwrap_or(&[])
    }
}

impl<const W: usize> Default for ChainScratch<W> {
    fn default() -> Self {
        Self::new()
    }
}

/// The inverse of a symmetric positive definite 6x6 matrix, Jacobi-scaled; `None` if it is not
/// positive definite or not finite.
#[must_use]
pub fn spd_inverse(m: &Mat6) -> Option<Mat6> {
    let mut scale = Vec6::zeros();
    for (i, s) in scale.iter_mut().enumerate() {
        let d = m.get((i, i)).copied().unwrap_or(0.0);
        if !(d.is_finite() && d > 0.0) {
            return None;
        }
        *s = 1.0 / libm::sqrtf(d);
    }
    let inv = diagonal_scaled(m, &scale).cholesky()?.inverse();
    let out = diagonal_scaled(&inv, &scale);
    let out = (out + out.transpose()) * 0.5;
    out.iter().all(|v| v.is_finite()).then_some(out)
}

/// `diag(d) m` (row i scaled by `d_i`), entry by entry: what the dense product with a diagonal
/// matrix computes (its other terms are exact zeros), for a sixth of the work.
fn scaled_rows(d: &Vec6, m: &Mat6) -> Mat6 {
    let mut out = *m;
    for col in out.column_iter_mut() {
        for (x, di) in col.into_iter().zip(d.iter()) {
            *x *= di;
        }
    }
    out
}

/// `m diag(d)` (column j scaled by `d_j`), entry by entry, as [`scaled_rows`].
fn scaled_columns(m: &Mat6, d: &Vec6) -> Mat6 {
    let mut out = *m;
    for (mut col, dj) in out.column_iter_mut().zip(d.iter()) {
        col *= *dj;
    }
    out
}

/// `diag(s) m diag(s)`.
fn diagonal_scaled(m: &Mat6, s: &Vec6) -> Mat6 {
    scaled_columns(&scaled_rows(s, m), s)
}

/// The chain of one object's (or the camera's) motions over the last `W` frames.
#[derive(Debug, Clone)]
pub struct ChainSmoother<const W: usize> {
    slots: Deque<Slot, W>,
    /// Prior on the oldest slot: mean and information (zero information: no prior).
    prior_mean: [f32; 6],
    prior_info: PackedSym6,
    /// Diagonal information of a zero-mean prior on every slot's twist (a vehicle's kinematics,
    /// [`super::params::KinematicPrior`]); zero: none.
    kinematic: [f32; 6],
}

impl<const W: usize> Default for ChainSmoother<W> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const W: usize> ChainSmoother<W> {
    /// An empty chain without prior.
    #[must_use]
    pub const fn new() -> Self {
        Self { slots: Deque::new(), prior_mean: [0.0; 6], prior_info: PackedSym6::ZERO, kinematic: [0.0; 6] }
    }

    /// Puts a zero-mean prior of diagonal information `info` on every slot's twist, from the
    /// next solve on (zeros remove it).
    pub fn set_kinematic(&mut self, info: [f32; 6]) {
        if info.iter().all(|v| v.is_finite() && *v >= 0.0) {
            self.kinematic = info;
        }
    }

    fn kinematic_matrix(&self) -> Mat6 {
        Mat6::from_diagonal(&Vec6::from_column_slice(&self.kinematic))
    }

    /// Slots held.
    #[must_use]
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// True without slots.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// True when no further slot fits.
    #[must_use]
    pub fn is_full(&self) -> bool {
        self.slots.is_full()
    }

    /// Empties the chain and forgets its prior.
    pub fn clear(&mut self) {
        self.slots.clear();
        self.prior_mean = [0.0; 6];
        self.prior_info = PackedSym6::ZERO;
        self.kinematic = [0.0; 6];
    }

    /// Appends the next frame: its measured twist and information, or `None` for a frame
    /// without a fit (the prior carries the motion through), and its coupling data `lin`.
    /// Returns `false` (and stores nothing) when the chain is full or the measurement or `lin`
    /// is not finite.
    pub fn push(&mut self, measurement: Option<(&Vec6, &Mat6)>, lin: &[f32; 6]) -> bool {
        if !lin.iter().all(|v| v.is_finite()) {
            return false;
        }
        let slot = match measurement {
            Some((z, info)) => {
                let info = PackedSym6::pack(&((info + info.transpose()) * 0.5));
                if !(z.iter().all(|v| v.is_finite()) && info.is_finite()) {
                    return false;
                }
                let mut zz = [0.0; 6];
                zz.iter_mut().zip(z.iter()).for_each(|(a, b)| *a = *b);
                Slot { z: zz, info, lin: *lin }
            }
            None => Slot { z: [0.0; 6], info: PackedSym6::ZERO, lin: *lin },
        };
        self.slots.push_back(slot).is_ok()
    }

    /// Slot `i` (oldest first).
    #[must_use]
    pub fn slot(&self, i: usize) -> Option<SlotView> {
        let s = self.slots.iter().nth(i)?;
        Some(SlotView {
            z: Vec6::from_column_slice(&s.z),
            info: s.info.unpack(),
            measured: s.info.0.iter().any(|v| *v != 0.0),
            lin: s.lin,
        })
    }

    /// Adds `dz` to the oldest slot's measured twist: fixes the other chain's variable that the
    /// slot is coupled to before the slot is marginalised (see [`super::joint`]).
    pub fn shift_front(&mut self, dz: &Vec6) {
        if let Some(s) = self.slots.front_mut()
            && dz.iter().all(|v| v.is_finite())
        {
            s.z.iter_mut().zip(dz.iter()).for_each(|(a, b)| *a += *b);
        }
    }

    /// Solves the window; the solution (oldest first) is in `scratch.solution(n)` with `n` the
    /// returned slot count. `None` when the system is not positive definite (never seen with the
    /// regularisation; answered by the caller with a hold).
    pub fn solve(&self, s: &Smoothness, scratch: &mut ChainScratch<W>) -> Option<usize> {
        self.solve_with(s, scratch, |_| None)
    }

    /// [`ChainSmoother::solve`] with `extra(i)` (information, right-hand side) added to slot
    /// `i`'s diagonal block and right-hand side: the other chains' factors on this chain's
    /// variables in the joint solve, with those chains held at their current estimates.
    pub fn solve_with(
        &self,
        s: &Smoothness,
        scratch: &mut ChainScratch<W>,
        mut extra: impl FnMut(usize) -> Option<(Mat6, Vec6)>,
    ) -> Option<usize> {
        let n = self.slots.len();
        let sm = s.matrix();
        let prior_info = self.prior_info.unpack();
        let prior_mean = Vec6::from_column_slice(&self.prior_mean);
        let kinematic = self.kinematic_matrix();
        // Forward elimination.
        let mut prev: Option<(Mat6, Vec6)> = None;
        for (i, slot) in self.slots.iter().enumerate() {
            let info = slot.info.unpack();
            let z = Vec6::from_column_slice(&slot.z);
            let mut a = info + kinematic + Mat6::identity() * REGULARISATION;
            let mut b = info * z;
            if i == 0 {
                a += prior_info;
                b += prior_info * prior_mean;
            } else {
                a += sm;
            }
            if i + 1 < n {
                a += sm;
            }
            if let Some((ea, eb)) = extra(i) {
                a += ea;
                b += eb;
            }
            if let Some((d_inv_prev, y_prev)) = &prev {
                let t = scaled_rows(&s.diag, d_inv_prev);
                a -= scaled_columns(&t, &s.diag);
                b += t * y_prev;
            }
            let d_inv = spd_inverse(&a)?;
            *scratch.d_inv.get_mut(i)? = PackedSym6::pack(&d_inv);
            *scratch.y.get_mut(i)? = b;
            prev = Some((d_inv, b));
        }
        // Back substitution, in place of y.
        let mut next: Option<Vec6> = None;
        for i in (0..n).rev() {
            let d_inv = scratch.d_inv.get(i)?.unpack();
            let y = scratch.y.get_mut(i)?;
            let x = match next {
                Some(xn) => d_inv * (*y + s.diag.component_mul(&xn)),
                None => d_inv * *y,
            };
            *y = x;
            next = Some(x);
        }
        Some(n)
    }

    /// Removes the oldest slot, folding what it said into the prior of the next one (exact
    /// marginalisation of a linear-Gaussian chain: the oldest motion's posterior from its own
    /// factors, pushed through the constant-motion prior). Returns `false` if the chain was
    /// empty or the numbers broke down (the prior is then dropped, which only loses information).
    pub fn pop_marginalise(&mut self, s: &Smoothness) -> bool {
        let Some(slot) = self.slots.pop_front() else { return false };
        let info = slot.info.unpack();
        let pinfo = self.prior_info.unpack();
        let own = info + pinfo + self.kinematic_matrix() + Mat6::identity() * REGULARISATION;
        let rhs = info * Vec6::from_column_slice(&slot.z) + pinfo * Vec6::from_column_slice(&self.prior_mean);
        let smooth_cov = Mat6::from_diagonal(&s.diag.map(|v| if v > 0.0 { 1.0 / v } else { 1.0 / REGULARISATION }));
        let next = spd_inverse(&own).and_then(|cov| {
            let mean = cov * rhs;
            let info = spd_inverse(&(cov + smooth_cov))?;
            Some((mean, info))
        });
        match next {
            Some((mean, info)) if mean.iter().all(|v| v.is_finite()) => {
                mean.iter().zip(self.prior_mean.iter_mut()).for_each(|(a, b)| *b = *a);
                self.prior_info = PackedSym6::pack(&info);
                true
            }
            _ => {
                self.prior_mean = [0.0; 6];
                self.prior_info = PackedSym6::ZERO;
                false
            }
        }
    }

    /// Re-expresses every twist in a body frame turned by `r` (`xi' = ad * xi` with
    /// `ad = Ad(r^-1)`), when an object's frame is re-oriented; the coupling poses (camera from
    /// object) become `m * r`.
    pub fn reframe(&mut self, ad: &Mat6, r: &crate::geometry::Pose3) {
        let map = |z: &mut [f32; 6], info: &mut PackedSym6| {
            let zz = ad * Vec6::from_column_slice(z);
            zz.iter().zip(z.iter_mut()).for_each(|(a, b)| *b = *a);
            if let Some(i) = map_information(&info.unpack(), ad) {
                *info = PackedSym6::pack(&i);
            }
        };
        for slot in self.slots.iter_mut() {
            map(&mut slot.z, &mut slot.info);
            slot.lin = pose_to_lin(&(lin_to_pose(&slot.lin) * r));
        }
        map(&mut self.prior_mean, &mut self.prior_info);
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    fn meas(v: f32) -> Vec6 {
        Vec6::new(v, 0.0, 0.0, 0.0, 0.0, 0.01 * v)
    }

    /// A dense solve of the same normal equations, for reference.
    fn dense(zs: &[Option<f32>; 6], info: f32, s: &Smoothness) -> [Vec6; 6] {
        let mut a = nalgebra::SMatrix::<f64, 36, 36>::zeros();
        let mut b = nalgebra::SVector::<f64, 36>::zeros();
        for (i, z) in zs.iter().enumerate() {
            for k in 0..6 {
                a[(6 * i + k, 6 * i + k)] += f64::from(REGULARISATION);
                if let Some(z) = z {
                    a[(6 * i + k, 6 * i + k)] += f64::from(info);
                    b[6 * i + k] += f64::from(info * meas(*z)[k]);
                }
                if i > 0 {
                    let d = f64::from(s.diag[k]);
                    a[(6 * i + k, 6 * i + k)] += d;
                    a[(6 * (i - 1) + k, 6 * (i - 1) + k)] += d;
                    a[(6 * i + k, 6 * (i - 1) + k)] -= d;
                    a[(6 * (i - 1) + k, 6 * i + k)] -= d;
                }
            }
        }
        let x = a.lu().solve(&b).unwrap();
        core::array::from_fn(|i| Vec6::from_fn(|k, _| x[6 * i + k] as f32))
    }

    #[test]
    fn block_solve_matches_a_dense_solve() {
        let s = Smoothness::new(&SmootherParams { sigma_translation: 0.2, sigma_rotation: 0.01 });
        let zs = [Some(1.0), Some(1.3), None, Some(0.7), Some(1.1), Some(0.9)];
        let mut c = ChainSmoother::<8>::new();
        let info = Mat6::identity() * 25.0;
        for z in zs {
            assert!(c.push(z.map(meas).as_ref().map(|m| (m, &info)), &[0.0; 6]));
        }
        let mut scratch = ChainScratch::<8>::new();
        let n = c.solve(&s, &mut scratch).unwrap();
        let want = dense(&zs, 25.0, &s);
        for (got, want) in scratch.solution(n).iter().zip(&want) {
            assert!((got - want).norm() < 1e-3, "{got:?} vs {want:?}");
        }
    }

    #[test]
    fn marginalising_keeps_the_newest_estimates() {
        // Solving 6 frames at once and solving after dropping the first two (marginalised)
        // give the same newest estimates: marginalisation is exact for this chain.
        let s = Smoothness::new(&SmootherParams { sigma_translation: 0.1, sigma_rotation: 0.01 });
        let info = Mat6::identity() * 100.0;
        let zs = [1.0, 1.2, 0.8, 1.1, 1.05, 0.95];
        let mut full = ChainSmoother::<6>::new();
        let mut sliding = ChainSmoother::<4>::new();
        let mut s1 = ChainScratch::<6>::new();
        let mut s2 = ChainScratch::<4>::new();
        for z in zs {
            full.push(Some((&meas(z), &info)), &[0.0; 6]);
            if sliding.is_full() {
                assert!(sliding.pop_marginalise(&s));
            }
            sliding.push(Some((&meas(z), &info)), &[0.0; 6]);
        }
        let n1 = full.solve(&s, &mut s1).unwrap();
        let n2 = sliding.solve(&s, &mut s2).unwrap();
        let (a, b) = (s1.solution(n1), s2.solution(n2));
        for k in 0..n2 {
            assert!((a[n1 - n2 + k] - b[k]).norm() < 1e-4, "{k}: {:?} vs {:?}", a[n1 - n2 + k], b[k]);
        }
    }

    #[test]
    fn empty_window_and_bad_input_do_not_fail() {
        let s = Smoothness::new(&SmootherParams { sigma_translation: 0.2, sigma_rotation: 0.01 });
        let mut c = ChainSmoother::<3>::new();
        let mut scratch = ChainScratch::<3>::new();
        assert_eq!(c.solve(&s, &mut scratch), Some(0));
        assert!(c.push(None, &[0.0; 6]));
        assert!(c.solve(&s, &mut scratch).is_some());
        let nan = Vec6::repeat(f32::NAN);
        assert!(!c.push(Some((&nan, &Mat6::identity())), &[0.0; 6]));
        assert!(!c.push(None, &[f32::NAN; 6]));
        assert!(c.push(None, &[0.0; 6]) && c.push(None, &[0.0; 6]));
        assert!(!c.push(None, &[0.0; 6]));
        assert!(c.pop_marginalise(&s));
        assert!(spd_inverse(&Mat6::zeros()).is_none());
        assert!(spd_inverse(&(Mat6::identity() * f32::NAN)).is_none());
    }
}
