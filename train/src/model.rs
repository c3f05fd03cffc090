//! The network of `dynotraj_core::model::arch` on candle, plus the training-only parts.
//!
//! Inference parts (exported, in layout order): the history encoder `enc`, the edge encoder
//! `edge`, p(z|x) `pz1`/`pz2`, the decoder's initial state `dec_init`, the decoder GRU `gru`
//! and its output layer `out`. Training-only parts (in the checkpoint, not in the blob): the
//! future encoder, a bidirectional LSTM(FUTURE_ENC) over the standardised future positions
//! (`future` forward and `future`..`_reverse` backward, PyTorch names) whose forward direction
//! starts from `future_h0`/`future_c0` of the current own feature row (as Trajectron++ starts it
//! from the current state), and q(z|x,y) `qz` = Linear(cond + 2 FUTURE_ENC -> k) over
//! [x, h_forward, h_backward].

use candle_core::{D, DType, Device, Result, Tensor};
use candle_nn::{Linear, Module as _, VarMap};
use dynotraj_core::model::arch::{Dims, FEATURES, FUTURE_ENC, OUTPUTS, PZ_HIDDEN};
use dynotraj_core::predict::Dynamics;

use super::batch::Batch;
use super::cells::{GruCell, LstmCell, bias, linear, linear_within};
use super::dynamics::{control_covariance, controls, cumsum_time, integrate, position_covariance, velocity_residual};
use super::fused::gru_gates;
use super::params::ParamStore;

/// The whole network: the inference parts and the training-only parts.
#[derive(Debug, Clone)]
pub struct Network {
    /// Widths.
    pub dims: Dims,
    /// History encoder LSTM(FEATURES -> enc).
    pub enc: LstmCell,
    /// Edge encoder LSTM(2 FEATURES -> edge).
    pub edge: LstmCell,
    /// p(z|x) first layer (cond -> PZ_HIDDEN), followed by ReLU.
    pub pz1: Linear,
    /// p(z|x) second layer (PZ_HIDDEN -> k): logits.
    pub pz2: Linear,
    /// Decoder initial state (k + cond -> dec) over [z, x].
    pub dec_init: Linear,
    /// Decoder GRU cell (2 + k + cond -> dec) over [u_prev, z, x].
    pub gru: GruCell,
    /// Decoder output (dec -> OUTPUTS): [mu_w, mu_a, log_sigma_w, log_sigma_a, rho_raw].
    pub out: Linear,
    /// Future encoder, forward direction (training only).
    pub future_fwd: LstmCell,
    /// Future encoder, backward direction (training only).
    pub future_bwd: LstmCell,
    /// Forward future encoder's initial h from the current own features (training only).
    pub future_h0: Linear,
    /// Forward future encoder's initial c from the current own features (training only).
    pub future_c0: Linear,
    /// q(z|x,y) (cond + 2 FUTURE_ENC -> k) (training only).
    pub qz: Linear,
    /// How the decoder's outputs move the forecast (the blob's header carries it).
    pub dynamics: Dynamics,
}

/// Which latent modes the decoder runs.
#[derive(Debug, Clone)]
pub enum Modes {
    /// Every mode for every sample: row b * k + j is sample b under mode j.
    All,
    /// One mode per sample, given as one-hot rows [B, k].
    OneHot(Tensor),
}

/// A decoder rollout.
#[derive(Debug, Clone)]
pub struct Rollout {
    /// Positions of the mean controls [R, H, 2] over the batch's horizon H, metres, agent frame.
    pub positions: Tensor,
    /// Position covariances [R, H, 2, 2] (when asked for).
    pub covariances: Option<Tensor>,
}

impl Network {
    /// A freshly initialised network of `dims` (seeded) and the store of all its variables.
    ///
    /// # Errors
    /// Unsupported widths.
    pub fn new(dims: Dims, seed: u64) -> Result<(Self, VarMap)> {
        if !dims.is_supported() {
            candle_core::bail!("unsupported widths {dims:?}");
        }
        let mut p = ParamStore::new(seed);
        let (k, cond, dec) = (dims.k, dims.cond(), dims.dec);
        let net = Self {
            dims,
            enc: LstmCell::new(&mut p, "enc", "", FEATURES, dims.enc)?,
            edge: LstmCell::new(&mut p, "edge", "", 2 * FEATURES, dims.edge)?,
            pz1: linear(&mut p, "pz1", cond, PZ_HIDDEN)?,
            pz2: linear(&mut p, "pz2", PZ_HIDDEN, k)?,
            dec_init: linear(&mut p, "dec_init", k + cond, dec)?,
            gru: GruCell::new(&mut p, "gru", 2 + k + cond, dec)?,
            // Zero output layer: the untrained model forecasts a zero residual, i.e. exactly the
            // motion prior (cv-fit when it is off), and training starts from that solution.
            out: linear_within(&mut p, "out", dec, OUTPUTS, 0.0)?,
            future_fwd: LstmCell::new(&mut p, "future", "", 2, FUTURE_ENC)?,
            future_bwd: LstmCell::new(&mut p, "future", "_reverse", 2, FUTURE_ENC)?,
            future_h0: linear(&mut p, "future_h0", FEATURES, FUTURE_ENC)?,
            future_c0: linear(&mut p, "future_c0", FEATURES, FUTURE_ENC)?,
            qz: linear(&mut p, "qz", cond + 2 * FUTURE_ENC, k)?,
            dynamics: Dynamics::Unicycle,
        };
        Ok((net, p.into_vars()))
    }

    /// The condition x = [h_edge, h_hist] [B, cond].
    ///
    /// # Errors
    /// Shape errors.
    pub fn encode(&self, b: &Batch) -> Result<Tensor> {
        let n = b.size()?;
        let zeros = |w: usize| Tensor::zeros((n, w), DType::F32, b.own.device());
        let (h_hist, _) =
            self.enc.run_masked(&b.own, &b.mask, b.steps, &zeros(self.dims.enc)?, &zeros(self.dims.enc)?)?;
        let (h_edge, _) =
            self.edge.run_masked(&b.edge_input, &b.mask, b.steps, &zeros(self.dims.edge)?, &zeros(self.dims.edge)?)?;
        Tensor::cat(&[h_edge, h_hist], 1)
    }

    /// Logits of p(z|x) [B, k].
    ///
    /// # Errors
    /// Shape errors.
    pub fn prior_logits(&self, x: &Tensor) -> Result<Tensor> {
        self.pz2.forward(&self.pz1.forward(x)?.relu()?)
    }

    /// Logits of q(z|x,y) [B, k] (training only).
    ///
    /// # Errors
    /// Shape errors.
    pub fn posterior_logits(&self, x: &Tensor, b: &Batch) -> Result<Tensor> {
        let n = b.size()?;
        let h0 = self.future_h0.forward(&b.current)?;
        let c0 = self.future_c0.forward(&b.current)?;
        let horizon = b.future_std.dim(1)?;
        let all = Tensor::ones((n, horizon), DType::F32, x.device())?;
        let (h_fwd, _) = self.future_fwd.run_masked(&b.future_std, &all, horizon, &h0, &c0)?;
        let zero = Tensor::zeros((n, FUTURE_ENC), DType::F32, x.device())?;
        let reversed = b.future_std.flip(&[1])?;
        let (h_bwd, _) = self.future_bwd.run_masked(&reversed, &all, horizon, &zero, &zero)?;
        self.qz.forward(&Tensor::cat(&[x, &h_fwd, &h_bwd], 1)?)
    }

    /// Rolls the decoder out over the horizon from condition `x` [B, cond] and batch `bt`'s first
    /// control input, current speed and motion-prior controls, for `modes`, integrating the
    /// clamped sums of the prior's and the mean controls with the unicycle at period `dt`
    /// exactly as inference does; with `covariance` also propagates the control covariance to
    /// positions.
    ///
    /// # Errors
    /// Shape errors.
    pub fn decode(&self, x: &Tensor, modes: &Modes, bt: &Batch, dt: f32, covariance: bool) -> Result<Rollout> {
        let (u0, speed, prior) = (&bt.initial_control, &bt.speed, &bt.prior);
        let horizon = prior.dim(1)?;
        let Dims { k, dec, .. } = self.dims;
        let cond = self.dims.cond();
        let b = x.dim(0)?;
        let init_w = self.dec_init.weight();
        // The decoder's inputs [z, x] and [u, z, x] are split by columns: x's and z's parts are
        // fixed over the rollout and computed once, only u's part changes per step.
        let x_init = x.matmul(&init_w.narrow(1, k, cond)?.contiguous()?.t()?)?.broadcast_add(bias(&self.dec_init)?)?;
        let x_gru = self.gru.project_columns(x, 2 + k, cond)?;
        let z_init = init_w.narrow(1, 0, k)?.contiguous()?.t()?; // [k, dec]: row j is one-hot j's part
        let z_gru = self.gru.w_ih.narrow(1, 2, k)?.contiguous()?.t()?; // [k, 3 dec]
        let (mut h, fixed_gx, mut u, speed, prior) = match modes {
            Modes::All => {
                let per_mode = |xp: &Tensor, zp: &Tensor, w: usize| {
                    xp.unsqueeze(1)?.broadcast_add(&zp.unsqueeze(0)?)?.reshape((b * k, w))
                };
                let repeat = |t: &Tensor, w: usize| t.unsqueeze(1)?.broadcast_as((b, k, w))?.reshape((b * k, w));
                (
                    per_mode(&x_init, &z_init, dec)?,
                    per_mode(&x_gru, &z_gru, 3 * dec)?,
                    repeat(u0, 2)?,
                    repeat(speed, 1)?,
                    repeat(&prior.reshape((b, 2 * horizon))?, 2 * horizon)?.reshape((b * k, horizon, 2))?,
                )
            }
            Modes::OneHot(z) => {
                ((x_init + z.matmul(&z_init)?)?, (x_gru + z.matmul(&z_gru)?)?, u0.clone(), speed.clone(), prior.clone())
            }
        };
        // Step t's input u_t is the observed control (t = 0) or the mean control
        // mu_(t-1) = W_mu h_(t-1) + b_mu fed back (unclamped, as inference does). Only the
        // recurrence and that feedback run per step; the outputs and the unicycle need no
        // recurrence and are computed for the whole horizon after the loop.
        let rows = h.dim(0)?;
        let w_u = self.gru.w_ih.narrow(1, 0, 2)?.contiguous()?.t()?; // [2, 3 dec]
        let w_mu = self.out.weight().narrow(0, 0, 2)?.contiguous()?.t()?; // [dec, 2]
        let b_mu = bias(&self.out)?.narrow(0, 0, 2)?.broadcast_as((rows, 2))?;
        let constant = fixed_gx.broadcast_add(&self.gru.b_ih)?;
        // Biases broadcast once: their gradients are then reduced once per batch, not per step.
        let b_hh = self.gru.b_hh.broadcast_as((rows, 3 * dec))?;
        let w_hh = self.gru.w_hh.t()?;
        let mut hs = Vec::with_capacity(horizon);
        for _ in 0..horizon {
            let gx = (u.matmul(&w_u)? + &constant)?;
            let gh = (h.matmul(&w_hh)? + &b_hh)?;
            h = gru_gates(&gx, &gh, &h)?;
            u = (h.matmul(&w_mu)? + &b_mu)?;
            hs.push(h.clone());
        }
        let hs = Tensor::stack(&hs, 1)?; // [R, horizon, dec]
        let out = hs
            .reshape((rows * horizon, dec))?
            .matmul(&self.out.weight().t()?)?
            .broadcast_add(bias(&self.out)?)?
            .reshape((rows, horizon, OUTPUTS))?;
        let dt = f64::from(dt);
        let mean = out.narrow(D::Minus1, 0, 2)?;
        let spread = || control_covariance(&out.narrow(D::Minus1, 2, 2)?, &out.narrow(D::Minus1, 4, 1)?, self.dynamics);
        match self.dynamics {
            Dynamics::Unicycle => {
                let (w, a) = controls(&mean, &prior)?;
                let (positions, mid) = integrate(&w, &a, &speed, dt)?;
                let covariances = if covariance { Some(position_covariance(&mid, &spread()?, dt)?) } else { None };
                Ok(Rollout { positions, covariances })
            }
            Dynamics::SingleIntegrator => {
                let (w, a) = controls(&mean.zeros_like()?, &prior)?;
                let (path, _) = integrate(&w, &a, &speed, dt)?;
                let positions = (path + (cumsum_time(&velocity_residual(&mean)?)? * dt)?)?;
                let covariances = if covariance { Some((cumsum_time(&spread()?)? * (dt * dt))?) } else { None };
                Ok(Rollout { positions, covariances })
            }
        }
    }

    /// The unimodal forecast [B, H, 2] (agent frame, metres): the most likely mode of
    /// p(z|x) and the mean controls, as inference forecasts.
    ///
    /// # Errors
    /// Shape errors.
    pub fn forecast(&self, b: &Batch, dt: f32) -> Result<Tensor> {
        let x = self.encode(b)?;
        let z = one_hot_argmax(&self.prior_logits(&x)?)?;
        Ok(self.decode(&x, &Modes::OneHot(z), b, dt, false)?.positions)
    }
}

/// One-hot rows [B, k] of the first largest logit of each row.
///
/// # Errors
/// Shape errors.
pub fn one_hot_argmax(logits: &Tensor) -> Result<Tensor> {
    let k = logits.dim(1)?;
    let best = logits.argmax_keepdim(1)?; // [B, 1] u32
    let ids = Tensor::arange(0u32, k as u32, &Device::Cpu)?.unsqueeze(0)?;
    best.broadcast_eq(&ids)?.to_dtype(DType::F32)
}

/// Mean ADE (metres) of forecasts [B, H, 2] against `future` [B, H, 2], and the
/// per-sample values.
///
/// # Errors
/// Shape errors.
pub fn ade(forecast: &Tensor, future: &Tensor) -> Result<Vec<f32>> {
    (forecast - future)?.sqr()?.sum(D::Minus1)?.sqrt()?.mean(1)?.to_vec1::<f32>()
}
