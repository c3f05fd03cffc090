//! LSTM and GRU cells and linear layers on candle, with PyTorch's parameter names, shapes and
//! gate orders (which candle-nn 0.11's `LSTM`/`GRU` use too, and which the blob layout of
//! `dynotraj_core::model::arch` is written in): LSTM gates (i, f, g, o), GRU gates (r, z, n)
//! with n = tanh(W_in x + b_in + r * (W_hn h + b_hn)).
//!
//! The cells are written here rather than taken from candle-nn so that the input projection of
//! a whole sequence (or the constant part of the decoder's input) is one matrix product instead
//! of one per step; the tests hold them to candle-nn's cells and to a hand-written step over the
//! exported weights.

use candle_core::{D, Result, Tensor};
use candle_nn::Linear;
use candle_nn::ops::sigmoid;

use super::fused::gru_gates;
use super::params::{ParamStore, default_bound};

/// A linear layer `y = x W^T + b` named `{prefix}.weight`, `{prefix}.bias`.
///
/// # Errors
/// A name clash in the store.
pub fn linear(store: &mut ParamStore, prefix: &str, input: usize, output: usize) -> Result<Linear> {
    linear_within(store, prefix, input, output, default_bound(input))
}

/// A [`linear`] layer whose initial weights and bias are uniform in +-`bound` (0: all zero).
///
/// # Errors
/// A name clash in the store.
pub fn linear_within(store: &mut ParamStore, prefix: &str, input: usize, output: usize, bound: f32) -> Result<Linear> {
    let w = store.uniform(&format!("{prefix}.weight"), &[output, input], bound)?;
    let b = store.uniform(&format!("{prefix}.bias"), &[output], bound)?;
    Ok(Linear::new(w, Some(b)))
}

/// The bias of a layer made by [`linear`] (always present).
///
/// # Errors
/// Never for layers made by [`linear`].
pub fn bias(l: &Linear) -> Result<&Tensor> {
    l.bias().ok_or_else(|| candle_core::Error::Msg("linear layer without bias".into()))
}

/// An LSTM cell with weights `{prefix}.weight_ih_l0{suffix}` [4H, in], `weight_hh_l0{suffix}`
/// [4H, H], `bias_ih_l0{suffix}` [4H], `bias_hh_l0{suffix}` [4H] (suffix "" or "_reverse", as
/// PyTorch names the two directions of a bidirectional LSTM).
#[derive(Debug, Clone)]
pub struct LstmCell {
    /// Input weights [4H, in].
    pub w_ih: Tensor,
    /// Recurrent weights [4H, H].
    pub w_hh: Tensor,
    /// Input bias [4H].
    pub b_ih: Tensor,
    /// Recurrent bias [4H].
    pub b_hh: Tensor,
    /// Hidden width H.
    pub hidden: usize,
}

impl LstmCell {
    /// Creates the cell's parameters.
    ///
    /// # Errors
    /// A name clash in the store.
    pub fn new(store: &mut ParamStore, prefix: &str, suffix: &str, input: usize, hidden: usize) -> Result<Self> {
        let bound = default_bound(hidden);
        let name = |what: &str| format!("{prefix}.{what}_l0{suffix}");
        Ok(Self {
            w_ih: store.uniform(&name("weight_ih"), &[4 * hidden, input], bound)?,
            w_hh: store.uniform(&name("weight_hh"), &[4 * hidden, hidden], bound)?,
            b_ih: store.uniform(&name("bias_ih"), &[4 * hidden], bound)?,
            b_hh: store.uniform(&name("bias_hh"), &[4 * hidden], bound)?,
            hidden,
        })
    }

    /// Input projections `x W_ih^T + b_ih + b_hh` of every step at once: [B, T, in] -> [B, T, 4H].
    ///
    /// # Errors
    /// Shape errors.
    pub fn project(&self, x: &Tensor) -> Result<Tensor> {
        let (b, t, i) = x.dims3()?;
        let bias = (&self.b_ih + &self.b_hh)?;
        x.reshape((b * t, i))?.matmul(&self.w_ih.t()?)?.broadcast_add(&bias)?.reshape((b, t, 4 * self.hidden))
    }

    /// One step from the projected input `gx` [B, 4H] and state (h, c) [B, H] each.
    ///
    /// # Errors
    /// Shape errors.
    pub fn step(&self, gx: &Tensor, h: &Tensor, c: &Tensor) -> Result<(Tensor, Tensor)> {
        let g = (gx + h.matmul(&self.w_hh.t()?)?)?;
        let hd = self.hidden;
        let ifo_i = sigmoid(&g.narrow(D::Minus1, 0, 2 * hd)?)?;
        let (i, f) = (ifo_i.narrow(D::Minus1, 0, hd)?, ifo_i.narrow(D::Minus1, hd, hd)?);
        let gg = g.narrow(D::Minus1, 2 * hd, hd)?.tanh()?;
        let o = sigmoid(&g.narrow(D::Minus1, 3 * hd, hd)?)?;
        let c = ((f * c)? + (i * gg)?)?;
        let h = (o * c.tanh()?)?;
        Ok((h, c))
    }

    /// Runs over `x` [B, T, in] from state (h0, c0), where sample b has `mask[b, t]` = 1 for its
    /// real steps t < n_b (rows aligned at the start, row 0 real for every sample) and 0 after:
    /// a sample's state is kept unchanged past its last real step, so the result is the state
    /// after exactly n_b steps, as inference computes it. Only the first `steps` rows are run.
    ///
    /// # Errors
    /// Shape errors.
    pub fn run_masked(
        &self,
        x: &Tensor,
        mask: &Tensor,
        steps: usize,
        h0: &Tensor,
        c0: &Tensor,
    ) -> Result<(Tensor, Tensor)> {
        let gx = self.project(x)?;
        let (mut h, mut c) = (h0.clone(), c0.clone());
        for t in 0..steps {
            let (h1, c1) = self.step(&gx.narrow(1, t, 1)?.squeeze(1)?, &h, &c)?;
            if t == 0 {
                (h, c) = (h1, c1);
            } else {
                // h = h_old + m * (h_new - h_old): m = 0 keeps the old state exactly.
                let m = mask.narrow(1, t, 1)?;
                h = (&h + (h1 - &h)?.broadcast_mul(&m)?)?;
                c = (&c + (c1 - &c)?.broadcast_mul(&m)?)?;
            }
        }
        Ok((h, c))
    }
}

/// A GRU cell with weights `{prefix}.weight_ih_l0` [3H, in], `weight_hh_l0` [3H, H],
/// `bias_ih_l0` [3H], `bias_hh_l0` [3H].
#[derive(Debug, Clone)]
pub struct GruCell {
    /// Input weights [3H, in].
    pub w_ih: Tensor,
    /// Recurrent weights [3H, H].
    pub w_hh: Tensor,
    /// Input bias [3H].
    pub b_ih: Tensor,
    /// Recurrent bias [3H].
    pub b_hh: Tensor,
    /// Hidden width H.
    pub hidden: usize,
}

impl GruCell {
    /// Creates the cell's parameters.
    ///
    /// # Errors
    /// A name clash in the store.
    pub fn new(store: &mut ParamStore, prefix: &str, input: usize, hidden: usize) -> Result<Self> {
        let bound = default_bound(hidden);
        Ok(Self {
            w_ih: store.uniform(&format!("{prefix}.weight_ih_l0"), &[3 * hidden, input], bound)?,
            w_hh: store.uniform(&format!("{prefix}.weight_hh_l0"), &[3 * hidden, hidden], bound)?,
            b_ih: store.uniform(&format!("{prefix}.bias_ih_l0"), &[3 * hidden], bound)?,
            b_hh: store.uniform(&format!("{prefix}.bias_hh_l0"), &[3 * hidden], bound)?,
            hidden,
        })
    }

    /// The input projection `x W_ih[:, cols]^T` of input columns `start..start + len` (no
    /// bias): the decoder splits its input into a per-step part and a constant part.
    ///
    /// # Errors
    /// Shape errors.
    pub fn project_columns(&self, x: &Tensor, start: usize, len: usize) -> Result<Tensor> {
        x.matmul(&self.w_ih.narrow(1, start, len)?.contiguous()?.t()?)
    }

    /// One step from the input projection `gx` [B, 3H] (`x W_ih^T`, without `b_ih`) and h [B, H].
    ///
    /// # Errors
    /// Shape errors.
    pub fn step(&self, gx: &Tensor, h: &Tensor) -> Result<Tensor> {
        let gx = gx.broadcast_add(&self.b_ih)?;
        let gh = h.matmul(&self.w_hh.t()?)?.broadcast_add(&self.b_hh)?;
        gru_gates(&gx, &gh, h)
    }
}
