//! Inference: the forward pass of [`super::arch`] over a [`ModelBlob`], in f32 or int8 by the
//! blob's precision, in fixed caller-owned scratch memory.

use super::arch::{Dims, FEATURES, MAX_DEC, MAX_EDGE, MAX_ENC, MAX_K, OUTPUTS, PZ_HIDDEN, tensor as t};
use super::blob::ModelBlob;
use super::blob::Precision;
use super::dot::{Int8Dot, PortableDot};
use super::features::{FeatureScales, OwnContext, StepFeatures, initial_control, neighbour_sum, state_features};
use super::kernel::{Activation, Exact, Kernel, MAX_AFFINE_IN, ShapeError, Table};
use crate::geometry::BevState;
use crate::limits::HORIZON;
use crate::predict::prior::{Rollout, plan};
use crate::predict::{Context, Forecast, PredictError, Predictor, checked_history_of};

/// Largest gate vector: four LSTM gates of the widest encoder, or three GRU gates.
const MAX_GATES: usize = if 4 * MAX_ENC > 3 * MAX_DEC { 4 * MAX_ENC } else { 3 * MAX_DEC };
/// Largest condition vector.
const MAX_COND: usize = MAX_ENC + MAX_EDGE;
/// Largest encoder width (history or edge).
const MAX_ENCODER: usize = if MAX_ENC > MAX_EDGE { MAX_ENC } else { MAX_EDGE };

/// Working memory of one forward pass. Its size is fixed by the MAX_* capacities, whatever the
/// model: one `Scratch` serves every blob this build accepts.
#[derive(Debug, Clone)]
pub struct Scratch {
    own: StepFeatures,
    neighbours: StepFeatures,
    h: [f32; MAX_DEC],
    gates_x: [f32; MAX_GATES],
    gates_h: [f32; MAX_GATES],
    gru_fixed: [f32; 3 * MAX_DEC],
    cond: [f32; MAX_COND],
    input: [f32; MAX_AFFINE_IN],
    pz: [f32; PZ_HIDDEN],
    logits: [f32; MAX_K],
    out: [f32; OUTPUTS],
}

impl Default for Scratch {
    fn default() -> Self {
        Self::ZERO
    }
}

impl Scratch {
    /// Zeroed working memory, as a constant: an edge keeps one in a static, built at compile
    /// time (a value built at run time would need 8 KiB of stack for a moment).
    pub const ZERO: Self = Self {
        own: [[0.0; FEATURES]; super::arch::MAX_STEPS],
        neighbours: [[0.0; FEATURES]; super::arch::MAX_STEPS],
        h: [0.0; MAX_DEC],
        gates_x: [0.0; MAX_GATES],
        gates_h: [0.0; MAX_GATES],
        gru_fixed: [0.0; 3 * MAX_DEC],
        cond: [0.0; MAX_COND],
        input: [0.0; MAX_AFFINE_IN],
        pz: [0.0; PZ_HIDDEN],
        logits: [0.0; MAX_K],
        out: [0.0; OUTPUTS],
    };
}

/// The learned predictor over a blob, unimodal: the most likely latent mode and the mean
/// controls. `D` does its int8 dot products.
#[derive(Debug, Clone)]
pub struct LearnedPredictor<'a, D = PortableDot> {
    kernel: Kernel<'a, D>,
    scratch: Scratch,
}

impl<'a> LearnedPredictor<'a> {
    /// A predictor reading `blob` in place, with the portable dot products.
    #[must_use]
    pub fn new(blob: ModelBlob<'a>) -> Self {
        Self::with_dot(blob)
    }
}

impl<'a, D: Int8Dot> LearnedPredictor<'a, D> {
    /// A predictor reading `blob` in place, with the dot products of `D` (same forecasts, bit
    /// for bit, as [`LearnedPredictor::new`]'s).
    #[must_use]
    pub fn with_dot(blob: ModelBlob<'a>) -> Self {
        Self { kernel: Kernel::with_dot(blob), scratch: Scratch::default() }
    }

    /// The blob.
    #[must_use]
    pub const fn blob(&self) -> &ModelBlob<'a> {
        self.kernel.blob()
    }
}

/// A learned model's forecast ([`Predictor::predict_in_context`] of [`LearnedPredictor`]) over a
/// kernel and working memory held apart: an edge keeps its [`Scratch`] in its static state and
/// only the small kernel changes with the model.
///
/// # Errors
/// See [`PredictError`]; a frame period that differs from the model's is `BadFramePeriod`.
pub fn forecast<D: Int8Dot>(
    kernel: &Kernel<'_, D>,
    s: &mut Scratch,
    history: &[BevState],
    context: &Context<'_>,
    dt: f32,
    out: &mut Forecast,
) -> Result<(), PredictError> {
    let prior = kernel.blob().prior();
    let full = history;
    let history = checked_history_of(history, dt, prior.states())?;
    let trained = kernel.blob().frame_period_s();
    if (dt - trained).abs() > 1e-4 * trained {
        return Err(PredictError::BadFramePeriod);
    }
    let Some(plan) = plan(history, prior, dt) else { return Err(PredictError::HistoryTooShort) };
    let own = OwnContext::of(full, context.observer, plan.trend);
    let dynamics = kernel.blob().dynamics();
    let scales = FeatureScales::of(dynamics);
    let n = state_features(history, &plan.frame, dt, Some(&own), &scales, &mut s.own);
    neighbour_sum(context.neighbours, &plan.frame, n, dt, &scales, &mut s.neighbours);
    let u0 = initial_control(s.own.get(n.wrapping_sub(1)).unwrap_or(&[0.0; FEATURES]), &scales);
    let mut rollout = Rollout::with_dynamics(&plan, dt, dynamics);
    forward(kernel, s, n, u0, |t, residual| {
        if let (Some(p), Some(o)) = (rollout.step(t, residual), out.get_mut(t)) {
            *o = p;
        }
    })
    .map_err(|ShapeError| PredictError::NonFinite)?;
    if out.iter().all(|p| p.x.is_finite() && p.y.is_finite()) { Ok(()) } else { Err(PredictError::NonFinite) }
}

/// Forecasts from a history (oldest first, current last, clipped at its run's start: its length
/// is the track's age) in a context (the other objects, each a history ending at the same
/// current frame; the observer), at the frame period the model was trained at.
impl<D: Int8Dot> Predictor for LearnedPredictor<'_, D> {
    fn predict(&mut self, history: &[BevState], dt: f32, out: &mut Forecast) -> Result<(), PredictError> {
        self.predict_in_context(history, &Context::NONE, dt, out)
    }

    fn predict_in_context(
        &mut self,
        history: &[BevState],
        context: &Context<'_>,
        dt: f32,
        out: &mut Forecast,
    ) -> Result<(), PredictError> {
        forecast(&self.kernel, &mut self.scratch, history, context, dt, out)
    }

    fn carry(&self) -> crate::predict::Carry {
        self.kernel.blob().prior().carry()
    }
}

/// One LSTM step (PyTorch gates i, f, g, o) over `input`, updating `h[..w]` and `c[..w]`.
fn lstm_step<D: Int8Dot>(
    k: &Kernel<'_, D>,
    tensors: [usize; 4],
    input: &[f32],
    w: usize,
    s: &mut LstmState<'_>,
) -> Result<(), ShapeError> {
    let [w_ih, w_hh, b_ih, b_hh] = tensors;
    let gx = s.gates_x.get_mut(..4 * w).ok_or(ShapeError)?;
    k.affine(w_ih, Some(b_ih), input, gx)?;
    let gh = s.gates_h.get_mut(..4 * w).ok_or(ShapeError)?;
    k.affine(w_hh, Some(b_hh), s.h.get(..w).ok_or(ShapeError)?, gh)?;
    match k.blob().precision() {
        Precision::F32 => lstm_gates::<Exact>(s, w),
        Precision::Int8 => lstm_gates::<Table>(s, w),
    }
}

/// The LSTM's cell and output update from its summed-in gate vectors.
fn lstm_gates<A: Activation>(s: &mut LstmState<'_>, w: usize) -> Result<(), ShapeError> {
    let (h, c) = (s.h.get_mut(..w).ok_or(ShapeError)?, s.c.get_mut(..w).ok_or(ShapeError)?);
    let gates = |g, q| gate(g, q, w);
    let (gx, gh) = (&*s.gates_x, &*s.gates_h);
    let (xi, xf, xg, xo) = (gates(gx, 0)?, gates(gx, 1)?, gates(gx, 2)?, gates(gx, 3)?);
    let (hi, hf, hg, ho) = (gates(gh, 0)?, gates(gh, 1)?, gates(gh, 2)?, gates(gh, 3)?);
    // Zipped iterators: one index for all ten vectors, no bounds check per gate.
    let units = h.iter_mut().zip(c.iter_mut()).zip(xi.iter().zip(hi)).zip(xf.iter().zip(hf));
    for ((((hj, cj), (xi, hi)), (xf, hf)), ((xg, hg), (xo, ho))) in units.zip(xg.iter().zip(hg).zip(xo.iter().zip(ho)))
    {
        let (i, f, gg, o) = (A::sigmoid(xi + hi), A::sigmoid(xf + hf), A::tanh(xg + hg), A::sigmoid(xo + ho));
        *cj = f * *cj + i * gg;
        *hj = o * A::tanh(*cj);
    }
    Ok(())
}

/// Gate `q` of width `w` in a vector of stacked gates.
fn gate(g: &[f32], q: usize, w: usize) -> Result<&[f32], ShapeError> {
    g.get(q * w..(q + 1) * w).ok_or(ShapeError)
}

/// Borrowed LSTM working state.
struct LstmState<'s> {
    h: &'s mut [f32],
    c: &'s mut [f32],
    gates_x: &'s mut [f32],
    gates_h: &'s mut [f32],
}

/// The forward pass: encoders, latent, decoder. Hands each step's residual (physical units of
/// the blob's dynamics, unclamped: the rollout adds it to the prior's and clamps) to `emit`.
fn forward<D: Int8Dot>(
    k: &Kernel<'_, D>,
    s: &mut Scratch,
    n: usize,
    u0: [f32; 2],
    mut emit: impl FnMut(usize, [f32; 2]),
) -> Result<(), ShapeError> {
    let Dims { enc, edge, k: modes, dec } = k.blob().dims();
    let cond = enc + edge;
    let [scale_0, scale_1] = k.blob().dynamics().residual_scales();

    // History encoder -> cond[edge..cond]; edge encoder -> cond[..edge].
    for (which, width) in [(0usize, enc), (1, edge)] {
        let mut h = [0.0f32; MAX_ENCODER];
        let mut c = [0.0f32; MAX_ENCODER];
        for i in 0..n {
            let own = s.own.get(i).ok_or(ShapeError)?;
            let input = s.input.get_mut(..if which == 0 { FEATURES } else { 2 * FEATURES }).ok_or(ShapeError)?;
            let (a, b) = input.split_at_mut(FEATURES.min(input.len()));
            a.copy_from_slice(own);
            if which == 1 {
                b.copy_from_slice(s.neighbours.get(i).ok_or(ShapeError)?);
            }
            let tensors = if which == 0 {
                [t::ENC_W_IH, t::ENC_W_HH, t::ENC_B_IH, t::ENC_B_HH]
            } else {
                [t::EDGE_W_IH, t::EDGE_W_HH, t::EDGE_B_IH, t::EDGE_B_HH]
            };
            let mut st = LstmState { h: &mut h, c: &mut c, gates_x: &mut s.gates_x, gates_h: &mut s.gates_h };
            lstm_step(k, tensors, input, width, &mut st)?;
        }
        let dst = if which == 0 { s.cond.get_mut(edge..cond) } else { s.cond.get_mut(..edge) };
        dst.ok_or(ShapeError)?.copy_from_slice(h.get(..width).ok_or(ShapeError)?);
    }
    let x = s.cond.get(..cond).ok_or(ShapeError)?;

    // p(z|x): the most likely mode.
    k.affine(t::PZ1_W, Some(t::PZ1_B), x, &mut s.pz)?;
    for v in &mut s.pz {
        *v = v.max(0.0);
    }
    let logits = s.logits.get_mut(..modes).ok_or(ShapeError)?;
    k.affine(t::PZ2_W, Some(t::PZ2_B), &s.pz, logits)?;
    let z = logits
        .iter()
        .enumerate()
        .fold((0, f32::NEG_INFINITY), |best, (i, &l)| if l > best.1 { (i, l) } else { best })
        .0;

    // Decoder initial state from [z, x].
    let init_in = s.input.get_mut(..modes + cond).ok_or(ShapeError)?;
    init_in.fill(0.0);
    if let Some(zi) = init_in.get_mut(z) {
        *zi = 1.0;
    }
    init_in.get_mut(modes..).ok_or(ShapeError)?.copy_from_slice(x);
    let h = s.h.get_mut(..dec).ok_or(ShapeError)?;
    k.affine(t::INIT_W, Some(t::INIT_B), s.input.get(..modes + cond).ok_or(ShapeError)?, h)?;

    // GRU input [u_prev, z, x]: z and x stay fixed over the rollout, so their product with the
    // input weights (plus the input bias) is computed once; each step adds only the u columns.
    // This removes about half of the decoder's multiply-accumulates.
    let fixed = s.gru_fixed.get_mut(..3 * dec).ok_or(ShapeError)?;
    k.affine_columns(t::GRU_W_IH, 2, Some(t::GRU_B_IH), s.input.get(..modes + cond).ok_or(ShapeError)?, fixed, true)?;
    let mut u = u0;
    for step in 0..HORIZON {
        gru_step(k, s, &u, dec)?;
        // Only the mean controls are read at inference: the spreads and correlation (the other
        // three outputs) are for training.
        let mean = s.out.get_mut(..2).ok_or(ShapeError)?;
        k.affine(t::OUT_W, Some(t::OUT_B), s.h.get(..dec).ok_or(ShapeError)?, mean)?;
        let [mu_w, mu_a, ..] = s.out;
        u = [mu_w, mu_a];
        emit(step, [mu_w * scale_0, mu_a * scale_1]);
    }
    Ok(())
}

/// One GRU step (PyTorch gates r, z, n) on input [u, z, x], whose fixed [z, x] part is already
/// in `s.gru_fixed`, updating `s.h[..w]`.
fn gru_step<D: Int8Dot>(k: &Kernel<'_, D>, s: &mut Scratch, u: &[f32; 2], w: usize) -> Result<(), ShapeError> {
    let gx = s.gates_x.get_mut(..3 * w).ok_or(ShapeError)?;
    gx.copy_from_slice(s.gru_fixed.get(..3 * w).ok_or(ShapeError)?);
    k.affine_columns(t::GRU_W_IH, 0, None, u, gx, false)?;
    let gh = s.gates_h.get_mut(..3 * w).ok_or(ShapeError)?;
    k.affine(t::GRU_W_HH, Some(t::GRU_B_HH), s.h.get(..w).ok_or(ShapeError)?, gh)?;
    match k.blob().precision() {
        Precision::F32 => gru_gates::<Exact>(s, w),
        Precision::Int8 => gru_gates::<Table>(s, w),
    }
}

/// The GRU's state update from its gate vectors.
fn gru_gates<A: Activation>(s: &mut Scratch, w: usize) -> Result<(), ShapeError> {
    let gates = |g, q| gate(g, q, w);
    let (gx, gh) = (&s.gates_x, &s.gates_h);
    let (xr, xz, xn) = (gates(gx, 0)?, gates(gx, 1)?, gates(gx, 2)?);
    let (hr, hz, hn) = (gates(gh, 0)?, gates(gh, 1)?, gates(gh, 2)?);
    let h = s.h.get_mut(..w).ok_or(ShapeError)?;
    // Zipped iterators: one index for all seven vectors, no bounds check per gate.
    let units = h.iter_mut().zip(xr.iter().zip(hr)).zip(xz.iter().zip(hz)).zip(xn.iter().zip(hn));
    for (((hj, (xr, hr)), (xz, hz)), (xn, hn)) in units {
        let r = A::sigmoid(xr + hr);
        let z = A::sigmoid(xz + hz);
        let nn = A::tanh(xn + r * hn);
        *hj = (1.0 - z) * nn + z * *hj;
    }
    Ok(())
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    extern crate std;
    use std::vec;
    use std::vec::Vec;

    use super::*;
    use crate::geometry::Point2;
    use crate::limits::PRIOR_STATES;
    use crate::model::blob::{Precision, blob_len, write_blob_with};
    use crate::predict::{Dynamics, MotionPrior, PriorSettings};

    /// A blob of `dims` with stand-in weights of `seed` (in place of a trained model).
    pub(crate) fn random_blob(dims: &Dims, precision: Precision, seed: u32) -> Vec<u8> {
        let mut scratch = vec![0.0; dims.parameters()];
        let mut buf = vec![0u8; blob_len(dims, precision)];
        let stand_in = (dims, precision, crate::predict::Dynamics::Unicycle);
        crate::model::stand_in::write_stand_in_blob(stand_in, 0.05, seed, &mut scratch, &mut buf).unwrap();
        buf
    }

    fn history() -> [BevState; 7] {
        core::array::from_fn(|i| BevState {
            x: 3.0 + 0.6 * i as f32,
            y: -2.0 + 0.05 * (i * i) as f32,
            heading: 0.1 + 0.02 * i as f32,
            speed: 12.0,
        })
    }

    #[test]
    fn int8_follows_float_and_outputs_are_finite() {
        for dims in
            [Dims::DEFAULT, Dims { enc: 16, edge: 8, k: 1, dec: 32 }, Dims { enc: 64, edge: 64, k: 25, dec: 64 }]
        {
            let f = random_blob(&dims, Precision::F32, 3);
            let q = random_blob(&dims, Precision::Int8, 3);
            let mut pf = LearnedPredictor::new(ModelBlob::parse(&f).unwrap());
            let mut pq = LearnedPredictor::new(ModelBlob::parse(&q).unwrap());
            let h = history();
            let other = [BevState { x: 10.0, y: 3.0, heading: 0.0, speed: 5.0 }; 4];
            let nb: [&[BevState]; 1] = [&other];
            let (mut a, mut b) = ([Point2::default(); HORIZON], [Point2::default(); HORIZON]);
            let context = Context { neighbours: &nb, observer: Some(Point2::new(-30.0, 4.0)) };
            pf.predict_in_context(&h, &context, 0.05, &mut a).unwrap();
            pq.predict_in_context(&h, &context, 0.05, &mut b).unwrap();
            let mean: f32 = a.iter().zip(&b).map(|(p, q)| p.distance(q)).sum::<f32>() / HORIZON as f32;
            assert!(mean < 0.1, "{dims:?}: int8 strays {mean} m from float");
            // The forecast starts near the current position and moves.
            assert!(a[0].distance(&h[6].position()) < 2.0 && a[HORIZON - 1].distance(&a[0]) > 0.1);
        }
    }

    #[test]
    fn a_shorter_output_gets_the_first_rows_exactly() {
        let dims = Dims::DEFAULT;
        for precision in [Precision::F32, Precision::Int8] {
            let b = random_blob(&dims, precision, 4);
            let k = Kernel::new(ModelBlob::parse(&b).unwrap());
            let h: Vec<f32> = (0..dims.dec).map(|i| 0.3 * (i as f32 * 0.7).sin()).collect();
            let (mut all, mut first) = ([0.0f32; OUTPUTS], [0.0f32; 2]);
            k.affine(t::OUT_W, Some(t::OUT_B), &h, &mut all).unwrap();
            k.affine(t::OUT_W, Some(t::OUT_B), &h, &mut first).unwrap();
            assert_eq!(first.map(f32::to_bits), [all[0].to_bits(), all[1].to_bits()], "{precision:?}");
            // A longer output than the tensor has rows is refused.
            assert_eq!(k.affine(t::OUT_W, Some(t::OUT_B), &h, &mut [0.0; OUTPUTS + 1]), Err(ShapeError));
        }
    }

    /// A blob of `dims` whose every weight is zero: its residual is zero.
    fn zero_blob(dims: &Dims, precision: Precision, prior: &PriorSettings) -> Vec<u8> {
        bias_blob(dims, precision, prior, Dynamics::Unicycle, [0.0; 2])
    }

    /// A blob whose only nonzero weights are the two mean outputs' biases: every step's
    /// standardised residual is `mean`.
    fn bias_blob(
        dims: &Dims,
        precision: Precision,
        prior: &PriorSettings,
        dynamics: Dynamics,
        mean: [f32; 2],
    ) -> Vec<u8> {
        let mut tensors: Vec<Vec<f32>> = dims.tensors().iter().map(|(r, c)| vec![0.0; r * c]).collect();
        tensors[t::OUT_B][..2].copy_from_slice(&mean);
        let slices: Vec<&[f32]> = tensors.iter().map(Vec::as_slice).collect();
        let mut buf = vec![0u8; blob_len(dims, precision)];
        write_blob_with(dims, precision, 0.05, prior, dynamics, &slices, &mut buf).unwrap();
        buf
    }

    #[test]
    fn a_single_integrator_adds_its_velocity_to_the_prior_s_path() {
        let h = long_history();
        let mut prior_path = [Point2::default(); HORIZON];
        MotionPrior(PriorSettings::DEFAULT).predict(&h, 0.05, &mut prior_path).unwrap();
        let bits = |f: &Forecast| f.map(|p| (p.x.to_bits(), p.y.to_bits()));
        for precision in [Precision::F32, Precision::Int8] {
            let zero =
                bias_blob(&Dims::DEFAULT, precision, &PriorSettings::DEFAULT, Dynamics::SingleIntegrator, [0.0; 2]);
            let blob = ModelBlob::parse(&zero).unwrap();
            assert_eq!(blob.dynamics(), Dynamics::SingleIntegrator);
            let mut out = [Point2::default(); HORIZON];
            LearnedPredictor::new(blob).predict(&h, 0.05, &mut out).unwrap();
            assert_eq!(bits(&out), bits(&prior_path), "{precision:?}: zero residual is the prior");
        }
        // 0.5 m/s to the agent's left on every step (and a bound far past it, clamped).
        let frame = crate::predict::prior::plan(&h, &PriorSettings::DEFAULT, 0.05).unwrap().frame;
        for (mean, expect) in [(0.5f32, 0.5f32), (100.0, crate::predict::dynamics::MAX_VELOCITY_RESIDUAL)] {
            let left = bias_blob(
                &Dims::DEFAULT,
                Precision::F32,
                &PriorSettings::DEFAULT,
                Dynamics::SingleIntegrator,
                [0.0, mean],
            );
            let mut out = [Point2::default(); HORIZON];
            LearnedPredictor::new(ModelBlob::parse(&left).unwrap()).predict(&h, 0.05, &mut out).unwrap();
            for (t, (p, q)) in out.iter().zip(&prior_path).enumerate() {
                let (a, b) = (frame.to_agent(p), frame.to_agent(q));
                let want = expect * 0.05 * (t + 1) as f32;
                assert!((a.x - b.x).abs() < 1e-3 && (a.y - b.y - want).abs() < 1e-3, "step {t}: {a:?} vs {b:?}");
            }
        }
    }

    #[test]
    fn an_unknown_dynamics_code_is_refused() {
        let mut buf = zero_blob(&Dims::DEFAULT, Precision::F32, &PriorSettings::DEFAULT);
        buf[7] = 2;
        let body = buf.len() - 4;
        let crc = crate::crc::crc32(&buf[..body]);
        buf[body..].copy_from_slice(&crc.to_le_bytes());
        assert_eq!(ModelBlob::parse(&buf).err(), Some(crate::model::blob::BlobError::Dynamics { found: 2 }));
    }

    /// A 21-state history that brakes and turns.
    fn long_history() -> [BevState; PRIOR_STATES] {
        let mut s = BevState { x: 40.0, y: 12.0, heading: -0.3, speed: 11.0 };
        core::array::from_fn(|_| {
            let now = s;
            s = crate::predict::unicycle_step(&s, 0.2, -1.2, 0.05);
            now
        })
    }

    #[test]
    fn zero_residual_reproduces_the_prior_bit_for_bit() {
        let settings = [
            PriorSettings::DEFAULT,
            PriorSettings::OFF,
            PriorSettings {
                accel_gain: 1.5,
                turn_gain: 0.7,
                accel_decay: 0.8,
                turn_decay: 1.0,
                ..PriorSettings::DEFAULT
            },
        ];
        for prior in settings {
            for precision in [Precision::F32, Precision::Int8] {
                for dims in [Dims::DEFAULT, Dims { enc: 16, edge: 8, k: 1, dec: 32 }] {
                    let buf = zero_blob(&dims, precision, &prior);
                    let mut p = LearnedPredictor::new(ModelBlob::parse(&buf).unwrap());
                    for h in [&long_history()[..], &long_history()[12..], &history()[..], &history()[4..]] {
                        let (mut a, mut b) = ([Point2::default(); HORIZON], [Point2::default(); HORIZON]);
                        p.predict(h, 0.05, &mut a).unwrap();
                        MotionPrior(prior).predict(h, 0.05, &mut b).unwrap();
                        let bits = |f: &Forecast| f.map(|p| (p.x.to_bits(), p.y.to_bits()));
                        assert_eq!(bits(&a), bits(&b), "{prior:?} {precision:?} {dims:?}, {} states", h.len());
                    }
                }
            }
        }
    }

    #[test]
    fn zero_residual_without_a_prior_is_constant_velocity_along_the_fitted_velocity() {
        use crate::predict::constant_velocity_fit;
        let buf = zero_blob(&Dims::DEFAULT, Precision::F32, &PriorSettings::OFF);
        let mut p = LearnedPredictor::new(ModelBlob::parse(&buf).unwrap());
        let (mut a, mut b) = ([Point2::default(); HORIZON], [Point2::default(); HORIZON]);
        p.predict(&long_history(), 0.05, &mut a).unwrap();
        constant_velocity_fit(&long_history(), 0.05, &mut b).unwrap();
        for (x, y) in a.iter().zip(&b) {
            assert!(x.distance(y) < 1e-3, "{x:?} vs {y:?}");
        }
    }

    #[test]
    fn wrong_frame_period_and_bad_history_are_refused() {
        let f = random_blob(&Dims::DEFAULT, Precision::F32, 1);
        let mut p = LearnedPredictor::new(ModelBlob::parse(&f).unwrap());
        let mut out = [Point2::default(); HORIZON];
        assert_eq!(p.predict(&history(), 0.1, &mut out), Err(PredictError::BadFramePeriod));
        assert_eq!(p.predict(&history()[..1], 0.05, &mut out), Err(PredictError::HistoryTooShort));
        let mut h = history();
        h[3].x = f32::NAN;
        assert_eq!(p.predict(&h, 0.05, &mut out), Err(PredictError::NonFinite));
    }
}
