//! The dynamically-extended unicycle on candle tensors (and a pedestrian's single integrator:
//! [`velocity_residual`], whose positions are prefix sums), vectorised over the horizon: the mean
//! rollout, step for step the same arithmetic as `dynotraj_core::predict::unicycle_step`
//! (which inference runs), and the propagation of the control covariance to a position
//! covariance for the likelihood.
//!
//! The decoder's recurrence never reads the unicycle state (it feeds back its own mean
//! controls), so the whole horizon's controls are known before integrating: headings and
//! speeds are prefix sums of the controls, every step's displacement is computed at once, and
//! positions are prefix sums of the displacements. Tensors are [R, T]: one row per sample and
//! latent mode, one column per future step, agent frame.
//!
//! Covariance (Trajectron++'s `integrate_distribution`): with state (x, y, heading, speed),
//! P_(t+1) = F_t P_t F_t^T + G_t Q_t G_t^T from P_0 = 0, Q_t the control covariance. The
//! Jacobians F (state) and G (controls) are those of the mid-step-heading form
//! x' = x + d cos(m), y' = y + d sin(m), d = v dt + a dt^2 / 2, m = heading + omega dt / 2, for
//! both branches: the closed form's own Jacobians differ from these by a relative
//! O((omega dt)^2) (below 1e-3 at the paper's limits and 20 Hz) but hold 1/omega^3 terms that
//! cancel catastrophically in f32 near the branch threshold. The mean, which is what is scored,
//! uses the exact closed form.
//!
//! In that form F_t = [[I, J_t], [0, I]] and G_t = [[J_t dt/2], [dt I]] with
//! J_t = [[-d sin m, dt cos m], [d cos m, dt sin m]]. Products of such F add their J, so the
//! position block after T steps is, with C_T = sum_(i<T) J_i and D_s = C_s + J_s / 2,
//!
//! ```text
//! P_T = dt^2 sum_(s<T) (C_T - D_s) Q_s (C_T - D_s)^T
//!     = dt^2 [C_T (sum Q_s) C_T^T - X_T - X_T^T + sum D_s Q_s D_s^T],  X_T = (sum D_s Q_s) C_T^T
//! ```
//!
//! where every sum over s < T is a prefix sum: the whole horizon in a few tensor operations
//! (the tests hold it to the step-by-step 4x4 recursion).

use candle_core::{D, DType, Result, Tensor};
use dynotraj_core::limits::{MAX_ACCEL, MAX_TURN_RATE};
use dynotraj_core::model::arch::{ACCEL_SCALE, TURN_RATE_SCALE};
use dynotraj_core::predict::Dynamics;
use dynotraj_core::predict::dynamics::{MAX_VELOCITY_RESIDUAL, VELOCITY_RESIDUAL_SCALE};

/// Below this turn rate (rad/s) the straight form is used, as in core's `unicycle_step`.
const STRAIGHT_TURN_RATE: f32 = 0.01;

/// Physical controls from the decoder's standardised means [R, T, 2] (turn rate,
/// acceleration) added to the motion prior's `prior` [R, T, 2], clamped to the paper's limits:
/// two [R, T] tensors. The clamp passes no gradient outside the limits.
///
/// # Errors
/// Shape errors.
pub fn controls(mu: &Tensor, prior: &Tensor) -> Result<(Tensor, Tensor)> {
    let part = |t: &Tensor, i: usize| t.narrow(D::Minus1, i, 1)?.squeeze(D::Minus1);
    let w = ((part(mu, 0)? * f64::from(TURN_RATE_SCALE))? + part(prior, 0)?)?.clamp(-MAX_TURN_RATE, MAX_TURN_RATE)?;
    let a = ((part(mu, 1)? * f64::from(ACCEL_SCALE))? + part(prior, 1)?)?.clamp(-MAX_ACCEL, MAX_ACCEL)?;
    Ok((w, a))
}

/// Inclusive prefix sums over dimension 1 of `x` [R, T, ...].
///
/// # Errors
/// Shape errors.
pub fn cumsum_time(x: &Tensor) -> Result<Tensor> {
    let dims = x.dims().to_vec();
    let (r, t) = (x.dim(0)?, x.dim(1)?);
    let k: usize = dims.iter().skip(2).product();
    let upper = Tensor::triu2(t, DType::F32, x.device())?;
    // [R, T, k] -> [R, k, T] rows, times the upper-triangular ones: row j sums columns <= j.
    let rows = x.reshape((r, t, k))?.transpose(1, 2)?.contiguous()?.reshape((r * k, t))?;
    rows.matmul(&upper)?.reshape((r, k, t))?.transpose(1, 2)?.contiguous()?.reshape(dims)
}

/// Exclusive prefix sums over dimension 1 of `x` [R, T]: column t sums columns < t.
fn cumsum_before(x: &Tensor) -> Result<Tensor> {
    let (r, t) = x.dims2()?;
    let zero = Tensor::zeros((r, 1), DType::F32, x.device())?;
    Tensor::cat(&[&zero, &cumsum_time(x)?.narrow(1, 0, t - 1)?], 1)
}

/// The mid-step travel d and heading m of every step [R, T], for the covariance.
#[derive(Debug, Clone)]
pub struct MidSteps {
    /// d = v dt + a dt^2 / 2.
    pub travel: Tensor,
    /// cos(m).
    pub cos_mid: Tensor,
    /// sin(m).
    pub sin_mid: Tensor,
}

/// Integrates clamped controls (w, a) [R, T] from the origin, heading 0 and `speed` [R, 1] at
/// period `dt`, as core's `unicycle_step`: the closed form where |w| > 0.01, the
/// mid-step-heading straight form elsewhere. Returns positions [R, T, 2] and the mid steps.
///
/// # Errors
/// Shape errors.
pub fn integrate(w: &Tensor, a: &Tensor, speed: &Tensor, dt: f64) -> Result<(Tensor, MidSteps)> {
    let w_dt = (w * dt)?;
    let phi = cumsum_before(&w_dt)?; // heading before each step
    let v = cumsum_before(&(a * dt)?)?.broadcast_add(speed)?; // speed before each step
    let phi1 = (&phi + &w_dt)?;
    // Closed form. Division is guarded: straight-branch entries divide by 1 instead (their
    // closed-form value is discarded, and an inf or NaN there would still poison the gradient
    // through the product rule).
    let turning = w.abs()?.gt(STRAIGHT_TURN_RATE)?;
    let ws = turning.where_cond(w, &w.ones_like()?)?;
    let (s0, c0) = (phi.sin()?, phi.cos()?);
    let (s1, c1) = (phi1.sin()?, phi1.cos()?);
    let (dc, ds) = ((&c1 - &c0)?, (&s1 - &s0)?);
    let a_w2 = (a / ws.sqr()?)?;
    let (v_w, a_w) = ((&v / &ws)?, (a / &ws)?);
    let x_turn = (((&a_w2 * &dc)? + (&v_w * &ds)?)? + ((&a_w * &s1)? * dt)?)?;
    let y_turn = (((&a_w2 * &ds)? - (&v_w * &dc)?)? - ((&a_w * &c1)? * dt)?)?;
    // Straight form along the mid-step heading.
    let travel = ((&v * dt)? + (a * (0.5 * dt * dt))?)?;
    let mid = (&phi + (w * (0.5 * dt))?)?;
    let (cos_mid, sin_mid) = (mid.cos()?, mid.sin()?);
    let dx = turning.where_cond(&x_turn, &(&travel * &cos_mid)?)?;
    let dy = turning.where_cond(&y_turn, &(&travel * &sin_mid)?)?;
    let positions = Tensor::stack(&[cumsum_time(&dx)?, cumsum_time(&dy)?], 2)?;
    Ok((positions, MidSteps { travel, cos_mid, sin_mid }))
}

/// The control covariance [R, T, 2, 2] in physical units of `dynamics` from the decoder's log
/// sigmas [R, T, 2] and raw correlations [R, T, 1] (rho = tanh(raw)).
///
/// # Errors
/// Shape errors.
pub fn control_covariance(log_sigma: &Tensor, rho_raw: &Tensor, dynamics: Dynamics) -> Result<Tensor> {
    let (r, t, _) = log_sigma.dims3()?;
    let [scale_0, scale_1] = dynamics.residual_scales();
    // Bounded log sigmas keep exp finite; the bounds sit far outside any useful spread.
    let sigma = log_sigma.clamp(-8.0f32, 4.0f32)?.exp()?;
    let sw = (sigma.narrow(D::Minus1, 0, 1)? * f64::from(scale_0))?;
    let sa = (sigma.narrow(D::Minus1, 1, 1)? * f64::from(scale_1))?;
    let off = ((rho_raw.tanh()? * &sw)? * &sa)?;
    Tensor::cat(&[sw.sqr()?, off.clone(), off, sa.sqr()?], D::Minus1)?.reshape((r, t, 2, 2))
}

/// A single integrator's residual velocity [R, T, 2] (m/s, agent frame) from the decoder's
/// standardised means, each component clamped as core's rollout clamps it.
///
/// # Errors
/// Shape errors.
pub fn velocity_residual(mu: &Tensor) -> Result<Tensor> {
    (mu * f64::from(VELOCITY_RESIDUAL_SCALE))?.clamp(-MAX_VELOCITY_RESIDUAL, MAX_VELOCITY_RESIDUAL)
}

/// Products of the 2x2 matrices of [R, T, 2, 2] tensors.
fn mat2_mul(m: &Tensor, n: &Tensor) -> Result<Tensor> {
    m.unsqueeze(4)?.broadcast_mul(&n.unsqueeze(2)?)?.sum(3)
}

/// Transposes of the 2x2 matrices of a [R, T, 2, 2] tensor.
fn mat2_t(m: &Tensor) -> Result<Tensor> {
    m.transpose(2, 3)
}

/// Position covariances [R, T, 2, 2] after each step (m^2), from the mid steps and the control
/// covariances `q` [R, T, 2, 2] (see the module docs).
///
/// # Errors
/// Shape errors.
pub fn position_covariance(mid: &MidSteps, q: &Tensor, dt: f64) -> Result<Tensor> {
    let (r, t) = mid.travel.dims2()?;
    let j = Tensor::stack(
        &[
            (&mid.travel * &mid.sin_mid)?.neg()?,
            (&mid.cos_mid * dt)?,
            (&mid.travel * &mid.cos_mid)?,
            (&mid.sin_mid * dt)?,
        ],
        2,
    )?
    .reshape((r, t, 2, 2))?;
    let c = cumsum_time(&j)?;
    let d = (&c - (&j * 0.5)?)?;
    let dq = mat2_mul(&d, q)?;
    let sum_q = cumsum_time(q)?;
    let sum_dq = cumsum_time(&dq)?;
    let sum_dqd = cumsum_time(&mat2_mul(&dq, &mat2_t(&d)?)?)?;
    let x = mat2_mul(&sum_dq, &mat2_t(&c)?)?;
    let cqc = mat2_mul(&mat2_mul(&c, &sum_q)?, &mat2_t(&c)?)?;
    (((cqc - &x)? - mat2_t(&x)?)? + sum_dqd)? * (dt * dt)
}

#[cfg(test)]
mod tests {
    use candle_core::Device;
    use dynotraj_core::BevState;
    use dynotraj_core::predict::unicycle_step;

    use super::*;

    /// Raw (unclamped) controls per row and step: turning, straight, beyond the limits.
    fn raw_controls(rows: usize, t: usize) -> (Vec<f32>, Vec<f32>) {
        let w = (0..rows * t).map(|i| match (i / t) % 3 {
            0 => 0.9 * ((i as f32) * 0.3).sin(),
            1 => 0.004 * ((i as f32) * 0.7).cos(),
            _ => 1.5,
        });
        let a = (0..rows * t).map(|i| 6.0 * ((i as f32) * 0.11).sin());
        (w.collect(), a.collect())
    }

    #[test]
    fn the_rollout_is_cores_unicycle_in_both_branches_and_clamped() {
        let (rows, t, dt) = (6, 30, 0.05f32);
        let (w, a) = raw_controls(rows, t);
        let speeds: Vec<f32> = (0..rows).map(|r| 3.0 + 2.0 * r as f32).collect();
        let dev = Device::Cpu;
        let mu = Tensor::stack(
            &[
                (Tensor::from_vec(w.clone(), (rows, t), &dev).unwrap() / f64::from(TURN_RATE_SCALE)).unwrap(),
                (Tensor::from_vec(a.clone(), (rows, t), &dev).unwrap() / f64::from(ACCEL_SCALE)).unwrap(),
            ],
            2,
        )
        .unwrap();
        let (wc, ac) = controls(&mu, &mu.zeros_like().unwrap()).unwrap();
        let speed = Tensor::from_vec(speeds.clone(), (rows, 1), &dev).unwrap();
        let (pos, _) = integrate(&wc, &ac, &speed, f64::from(dt)).unwrap();
        let pos = pos.to_vec3::<f32>().unwrap();
        for r in 0..rows {
            let mut s = BevState { x: 0.0, y: 0.0, heading: 0.0, speed: speeds[r] };
            for k in 0..t {
                s = unicycle_step(&s, w[r * t + k], a[r * t + k], dt);
                let p = &pos[r][k];
                assert!((p[0] - s.x).abs() < 2e-4 && (p[1] - s.y).abs() < 2e-4, "row {r} step {k}: {p:?} vs {s:?}");
            }
        }
    }

    type M4 = [[f64; 4]; 4];

    fn mul(a: &M4, b: &M4) -> M4 {
        let mut o = [[0.0; 4]; 4];
        for i in 0..4 {
            for j in 0..4 {
                o[i][j] = (0..4).map(|k| a[i][k] * b[k][j]).sum();
            }
        }
        o
    }

    fn tr(a: &M4) -> M4 {
        let mut o = [[0.0; 4]; 4];
        for i in 0..4 {
            for j in 0..4 {
                o[i][j] = a[j][i];
            }
        }
        o
    }

    #[test]
    fn the_prefix_sum_covariance_is_the_step_by_step_recursion() {
        let (rows, t, dt) = (3, 30, 0.05f64);
        let dev = Device::Cpu;
        let travel: Vec<f32> = (0..rows * t).map(|i| 0.2 + 0.3 * ((i as f32) * 0.2).sin().abs()).collect();
        let heading: Vec<f32> = (0..rows * t).map(|i| 0.6 * ((i as f32) * 0.05).sin()).collect();
        let mid = MidSteps {
            travel: Tensor::from_vec(travel.clone(), (rows, t), &dev).unwrap(),
            cos_mid: Tensor::from_vec(heading.iter().map(|h| h.cos()).collect::<Vec<_>>(), (rows, t), &dev).unwrap(),
            sin_mid: Tensor::from_vec(heading.iter().map(|h| h.sin()).collect::<Vec<_>>(), (rows, t), &dev).unwrap(),
        };
        let log_sigma: Vec<f32> = (0..rows * t * 2).map(|i| -1.0 + 0.5 * ((i as f32) * 0.13).cos()).collect();
        let rho: Vec<f32> = (0..rows * t).map(|i| ((i as f32) * 0.31).sin()).collect();
        let q = control_covariance(
            &Tensor::from_vec(log_sigma, (rows, t, 2), &dev).unwrap(),
            &Tensor::from_vec(rho, (rows, t, 1), &dev).unwrap(),
            Dynamics::Unicycle,
        )
        .unwrap();
        let got = position_covariance(&mid, &q, dt).unwrap().reshape((rows, t, 4)).unwrap().to_vec3::<f32>().unwrap();
        let qv = q.reshape((rows, t, 4)).unwrap().to_vec3::<f32>().unwrap();
        for r in 0..rows {
            let mut p: M4 = [[0.0; 4]; 4];
            for k in 0..t {
                let (d, m) = (f64::from(travel[r * t + k]), f64::from(heading[r * t + k]));
                let (c, s) = (m.cos(), m.sin());
                let f: M4 =
                    [[1.0, 0.0, -d * s, dt * c], [0.0, 1.0, d * c, dt * s], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];
                // G as a 4x4 with zero columns 2 and 3, Q padded likewise.
                let g: M4 = [
                    [-d * s * dt / 2.0, dt * dt / 2.0 * c, 0.0, 0.0],
                    [d * c * dt / 2.0, dt * dt / 2.0 * s, 0.0, 0.0],
                    [dt, 0.0, 0.0, 0.0],
                    [0.0, dt, 0.0, 0.0],
                ];
                let qk = &qv[r][k];
                let qm: M4 = [
                    [f64::from(qk[0]), f64::from(qk[1]), 0.0, 0.0],
                    [f64::from(qk[2]), f64::from(qk[3]), 0.0, 0.0],
                    [0.0; 4],
                    [0.0; 4],
                ];
                let fpf = mul(&mul(&f, &p), &tr(&f));
                let gqg = mul(&mul(&g, &qm), &tr(&g));
                for i in 0..4 {
                    for j in 0..4 {
                        p[i][j] = fpf[i][j] + gqg[i][j];
                    }
                }
                let want = [p[0][0], p[0][1], p[1][0], p[1][1]];
                for (gv, wv) in got[r][k].iter().zip(want) {
                    assert!(
                        (f64::from(*gv) - wv).abs() <= 1e-4 * (1.0 + wv.abs()),
                        "row {r} step {k}: {:?} vs {want:?}",
                        got[r][k]
                    );
                }
            }
        }
    }
}
