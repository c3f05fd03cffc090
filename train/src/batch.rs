//! A mini-batch of samples as candle tensors.

use candle_core::{Device, Result, Tensor};
use dynotraj_core::limits::HORIZON;
use dynotraj_core::model::arch::{FEATURES, MAX_STEPS, POS_SCALE};

use super::dataset::Sample;

/// The tensors of B samples.
#[derive(Debug, Clone)]
pub struct Batch {
    /// Own features [B, MAX_STEPS, FEATURES], rows aligned at the start (row 0 oldest).
    pub own: Tensor,
    /// Own features and summed neighbour features side by side [B, MAX_STEPS, 2 FEATURES]:
    /// the edge encoder's input.
    pub edge_input: Tensor,
    /// 1 for real rows, 0 for padding [B, MAX_STEPS].
    pub mask: Tensor,
    /// Rows any sample needs: the longest history in the batch.
    pub steps: usize,
    /// Newest own feature row [B, FEATURES].
    pub current: Tensor,
    /// Decoder's first control input [B, 2].
    pub initial_control: Tensor,
    /// Current speed [B, 1].
    pub speed: Tensor,
    /// The motion prior's controls [B, H, 2] (turn rate, acceleration; physical units) over the
    /// samples' horizon H.
    pub prior: Tensor,
    /// Future positions [B, H, 2], metres, agent frame.
    pub future: Tensor,
    /// Future positions / POS_SCALE [B, H, 2]: the future encoder's input.
    pub future_std: Tensor,
}

impl Batch {
    /// Builds the tensors of `samples` (at least one).
    ///
    /// # Errors
    /// An empty slice; samples of different horizons.
    pub fn new(samples: &[&Sample], device: &Device) -> Result<Self> {
        let b = samples.len();
        let Some(h) = samples.first().map(|s| s.horizon) else { candle_core::bail!("empty batch") };
        if h == 0 || h > HORIZON || samples.iter().any(|s| s.horizon != h) {
            candle_core::bail!("a batch's samples share one horizon of 1..={HORIZON} steps");
        }
        let mut own = Vec::with_capacity(b * MAX_STEPS * FEATURES);
        let mut edge = Vec::with_capacity(b * MAX_STEPS * 2 * FEATURES);
        let mut mask = Vec::with_capacity(b * MAX_STEPS);
        let mut current = Vec::with_capacity(b * FEATURES);
        let (mut u0, mut speed, mut future) =
            (Vec::with_capacity(2 * b), Vec::with_capacity(b), Vec::with_capacity(2 * b * h));
        let mut prior: Vec<f32> = Vec::with_capacity(2 * b * h);
        for s in samples {
            for (t, (o, n)) in s.own.iter().zip(&s.neighbours).enumerate() {
                own.extend_from_slice(o);
                edge.extend_from_slice(o);
                edge.extend_from_slice(n);
                mask.push(if t < s.steps { 1.0f32 } else { 0.0 });
            }
            current.extend_from_slice(&s.current_row());
            u0.extend_from_slice(&s.initial_control);
            speed.push(s.speed);
            prior.extend(s.prior.iter().take(h).flatten());
            future.extend(s.scored_future().iter().flat_map(|p| [p.x, p.y]));
        }
        let future = Tensor::from_vec(future, (b, h, 2), device)?;
        Ok(Self {
            own: Tensor::from_vec(own, (b, MAX_STEPS, FEATURES), device)?,
            edge_input: Tensor::from_vec(edge, (b, MAX_STEPS, 2 * FEATURES), device)?,
            mask: Tensor::from_vec(mask, (b, MAX_STEPS), device)?,
            steps: samples.iter().map(|s| s.steps).max().unwrap_or(1).clamp(1, MAX_STEPS),
            current: Tensor::from_vec(current, (b, FEATURES), device)?,
            initial_control: Tensor::from_vec(u0, (b, 2), device)?,
            speed: Tensor::from_vec(speed, (b, 1), device)?,
            prior: Tensor::from_vec(prior, (b, h, 2), device)?,
            future_std: (&future / f64::from(POS_SCALE))?,
            future,
        })
    }

    /// Samples in the batch.
    ///
    /// # Errors
    /// Never for a batch made by [`Batch::new`].
    pub fn size(&self) -> Result<usize> {
        self.speed.dim(0)
    }
}
