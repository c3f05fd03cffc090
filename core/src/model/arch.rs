//! The predictor's architecture: one definition shared by host training, float inference and
//! int8 inference.
//!
//! A Trajectron++-style CVAE, unimodal at inference, sized for an ECU:
//!
//! ```text
//! history (<= 7 states)  --features-->  LSTM(FEATURES -> enc)            -> h_hist (enc)
//! own + summed neighbour features  ---> LSTM(2*FEATURES -> edge)         -> h_edge (edge)
//! x = [h_edge, h_hist]                                                     (cond = edge + enc)
//! p(z|x) = Linear(cond -> PZ_HIDDEN), ReLU, Linear(PZ_HIDDEN -> k)         logits over k modes
//! z = one-hot(argmax p(z|x))                                               (inference)
//! h_0 = Linear(k + cond -> dec)(concat(z, x))
//! u_prev = features::initial_control(newest feature row): the current standardised
//!          (turn rate / TURN_RATE_SCALE, longitudinal acceleration / ACCEL_SCALE)
//! prior = predict::prior::plan(history, blob's prior settings): agent frame, speed, and
//!         the prior's controls (w_t, a_t) for every step
//! for t in 0..HORIZON:
//!     h_t = GRUCell(2 + k + cond -> dec)(concat(u_prev, z, x), h_(t-1))
//!     out = Linear(dec -> OUTPUTS)(h_t) = [mu_w, mu_a, log_sigma_w, log_sigma_a, rho_raw]
//!     u_prev = (mu_w, mu_a)                     (standardised, unclamped: fed back as is)
//!     control = clamp(w_t + mu_w * TURN_RATE_SCALE, +-0.7), clamp(a_t + mu_a * ACCEL_SCALE, +-4)
//!     state = unicycle_step(state, control, dt)  (agent frame, from (0, 0, 0, speed))
//! ```
//!
//! The network is a residual over the motion prior (`predict::prior`): at zero output it
//! forecasts the prior exactly, bit for bit. With `PriorSettings::OFF` the prior is the
//! `cv-fit` baseline and the network is the paper's setting (seven states, no prior).
//!
//! Training adds q(z|x,y) = Linear(cond + 2*FUTURE_ENC -> k) over a bidirectional LSTM of the
//! future positions; it is not needed at inference and not exported.
//!
//! Differences from Trajectron++, chosen for tiny data sets and the ECU:
//! - Inputs are agent-centric *and rotated* into the current heading frame (Trajectron++ only
//!   translates): a 76-run data set cannot teach rotation invariance.
//! - One edge type, so the additive attention over edge types reduces to weight 1 and is
//!   omitted.
//! - The first decoder input is the observed current control instead of a learned projection.
//!
//! # Features
//!
//! For a history of states s_0..s_n (oldest first, s_n current; 1 <= n <= MAX_HISTORY), the
//! agent frame (`prior::plan`) has its origin at s_n's position and its x axis along
//! the prior's fitted current velocity (along s_n's heading below 1 m/s). Per state:
//! position p_i (agent frame), velocity v_i = (p_i - p_(i-1)) / dt (v_0 = v_1; 0 when n = 0),
//! acceleration a_i = (v_i - v_(i-1)) / dt (a_0 = 0), relative heading wrap(h_i - h_n), heading
//! rate r_i = wrap(h_i - h_(i-1)) / dt (r_0 = r_1). The feature vector is
//! [p.x / POS_SCALE, p.y / POS_SCALE, v.x / VEL_SCALE, v.y / VEL_SCALE, a.x / ACC_SCALE,
//! a.y / ACC_SCALE, dh / PI, rate / HEADING_RATE_SCALE, trend speed / VEL_SCALE, trend
//! acceleration / ACC_SCALE, trend turn rate / HEADING_RATE_SCALE, age / AGE_SCALE_FRAMES,
//! range / RANGE_SCALE], each clamped to +-FEATURE_CLAMP. The last five are the same in every
//! row and zero for neighbours: the prior's long-window estimates (`prior::Trend`); the track's
//! age, the states of history before the current one, counted up to `MAX_PRIOR_HISTORY`
//! (a history is clipped at its run's start, so a young track has a short one); and the current
//! distance from the observing camera (`predict::Context::observer`, 0 when unknown). Age and
//! range are what the input's quality depends on: a run's first velocities and a far object's
//! depth are the estimator's largest errors.
//! Neighbour features use the same formulas with the neighbour's states, still in the *own*
//! agent frame (so a neighbour's position says where it is relative to the agent); the edge
//! LSTM's input at step i is [own features_i, sum over neighbours within NEIGHBOUR_RADIUS_M at
//! the current frame of their features_i] (zeros when there are none).
//!
//! # Weight layout (float, little-endian f32, row-major, in this order)
//!
//! PyTorch conventions (which candle-nn follows): LSTM gates (i, f, g, o), GRU gates (r, z, n)
//! with n = tanh(W_in x + b_in + r * (W_hn h + b_hn)).
//! 1. enc LSTM: w_ih `[4 enc, FEATURES]`, w_hh `[4 enc, enc]`, b_ih `[4 enc]`, b_hh `[4 enc]`
//! 2. edge LSTM: w_ih `[4 edge, 2 FEATURES]`, w_hh `[4 edge, edge]`, b_ih `[4 edge]`, b_hh `[4 edge]`
//! 3. p(z|x) layer 1: w `[PZ_HIDDEN, cond]`, b `[PZ_HIDDEN]`
//! 4. p(z|x) layer 2: w `[k, PZ_HIDDEN]`, b `[k]`
//! 5. decoder initial state: w `[dec, k + cond]`, b `[dec]`
//! 6. decoder GRU cell: w_ih `[3 dec, 2 + k + cond]`, w_hh `[3 dec, dec]`, b_ih `[3 dec]`, b_hh `[3 dec]`
//! 7. decoder output: w `[OUTPUTS, dec]`, b `[OUTPUTS]`
//!
//! Concatenation orders are exactly as written above: x = [h_edge, h_hist]; decoder initial
//! input [z, x]; GRU input [u_prev, z, x].

use crate::limits::{HORIZON, MAX_PRIOR_HISTORY};

/// Features per history state: eight of the state itself, three of the motion prior's
/// long-window estimates, the track's age and its range from the observer.
pub const FEATURES: usize = 13;
pub use crate::limits::MAX_STEPS;
/// Hidden width of p(z|x).
pub const PZ_HIDDEN: usize = 32;
/// Decoder outputs per step: mean (2), log sigma (2), correlation (1) of the controls.
pub const OUTPUTS: usize = 5;
/// Width of each direction of the training-only future encoder.
pub const FUTURE_ENC: usize = 32;
/// Position standardisation, metres.
pub const POS_SCALE: f32 = 10.0;
/// Velocity standardisation, m/s.
pub const VEL_SCALE: f32 = 15.0;
/// Acceleration standardisation, m/s^2.
pub const ACC_SCALE: f32 = 4.0;
/// Heading-rate standardisation, rad/s.
pub const HEADING_RATE_SCALE: f32 = 1.0;
/// Track-age standardisation, frames: the longest history a forecast reads, so the feature
/// runs from 0 (a run's second frame has one past state: 1 / AGE_SCALE_FRAMES) to 1.
pub const AGE_SCALE_FRAMES: f32 = MAX_PRIOR_HISTORY as f32;
/// Range standardisation, metres.
pub const RANGE_SCALE: f32 = 50.0;
/// Standardised features are clamped to this magnitude (guards against wild inputs).
pub const FEATURE_CLAMP: f32 = 5.0;
pub use crate::predict::dynamics::{ACCEL_SCALE, TURN_RATE_SCALE};
/// Neighbours closer than this at the current frame feed the edge encoder, metres
/// (Trajectron++'s vehicle-vehicle attention radius).
pub const NEIGHBOUR_RADIUS_M: f32 = 30.0;
/// Most neighbours summed per agent (the closest ones).
pub const MAX_NEIGHBOURS: usize = 15;

/// Largest widths a blob may declare; inference scratch is sized by these.
pub const MAX_ENC: usize = 64;
/// Largest edge-encoder width.
pub const MAX_EDGE: usize = 64;
/// Largest number of latent modes.
pub const MAX_K: usize = 25;
/// Largest decoder width: above the widest decoder the size study measured (48; the ECU default
/// is 8, docs/results.md). The scratch every edge holds is sized by it: each 64 more cost the
/// firmware 2.5 KiB of RAM.
pub const MAX_DEC: usize = 64;

/// The widths of one model. The defaults are the ECU configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Dims {
    /// History encoder LSTM width.
    pub enc: usize,
    /// Edge encoder LSTM width.
    pub edge: usize,
    /// Latent modes.
    pub k: usize,
    /// Decoder GRU width.
    pub dec: usize,
}

impl Dims {
    /// The ECU default: encoders and decoder 8 wide, 3 latent modes. The size-vs-accuracy study
    /// of docs/results.md found it as accurate as 32,32,3,48 and larger settings on these
    /// tiny data sets (within the seed-to-seed spread) for a third of the Cortex-M4's
    /// instructions per frame and a ninth of the flash.
    pub const DEFAULT: Self = Self { enc: 8, edge: 8, k: 3, dec: 8 };

    /// Width of the condition vector x = [h_edge, h_hist].
    #[must_use]
    pub const fn cond(&self) -> usize {
        self.edge + self.enc
    }

    /// True when every width is non-zero and within the MAX_* capacities.
    #[must_use]
    pub const fn is_supported(&self) -> bool {
        self.enc > 0
            && self.enc <= MAX_ENC
            && self.edge > 0
            && self.edge <= MAX_EDGE
            && self.k > 0
            && self.k <= MAX_K
            && self.dec > 0
            && self.dec <= MAX_DEC
    }

    /// The (rows, cols) of every weight matrix, in layout order, each followed by its biases
    /// (a bias is reported as (rows, 1)).
    #[must_use]
    pub const fn tensors(&self) -> [(usize, usize); TENSORS] {
        let (enc, edge, k, dec, cond) = (self.enc, self.edge, self.k, self.dec, self.cond());
        [
            (4 * enc, FEATURES),
            (4 * enc, enc),
            (4 * enc, 1),
            (4 * enc, 1),
            (4 * edge, 2 * FEATURES),
            (4 * edge, edge),
            (4 * edge, 1),
            (4 * edge, 1),
            (PZ_HIDDEN, cond),
            (PZ_HIDDEN, 1),
            (k, PZ_HIDDEN),
            (k, 1),
            (dec, k + cond),
            (dec, 1),
            (3 * dec, 2 + k + cond),
            (3 * dec, dec),
            (3 * dec, 1),
            (3 * dec, 1),
            (OUTPUTS, dec),
            (OUTPUTS, 1),
        ]
    }

    /// Total float parameters (the sum of the sizes of [`Dims::tensors`]).
    #[must_use]
    pub const fn parameters(&self) -> usize {
        let (enc, edge, k, dec, cond) = (self.enc, self.edge, self.k, self.dec, self.cond());
        4 * enc * (FEATURES + enc + 2)
            + 4 * edge * (2 * FEATURES + edge + 2)
            + PZ_HIDDEN * (cond + 1)
            + k * (PZ_HIDDEN + 1)
            + dec * (k + cond + 1)
            + 3 * dec * (2 + k + cond + dec + 2)
            + OUTPUTS * (dec + 1)
    }
}

/// Number of tensors in the layout.
pub const TENSORS: usize = 20;

/// Horizon of the decoder, frames.
pub const DECODER_STEPS: usize = HORIZON;

/// Indices of the tensors in layout order.
pub mod tensor {
    /// History encoder LSTM input weights.
    pub const ENC_W_IH: usize = 0;
    /// History encoder LSTM recurrent weights.
    pub const ENC_W_HH: usize = 1;
    /// History encoder LSTM input bias.
    pub const ENC_B_IH: usize = 2;
    /// History encoder LSTM recurrent bias.
    pub const ENC_B_HH: usize = 3;
    /// Edge encoder LSTM input weights.
    pub const EDGE_W_IH: usize = 4;
    /// Edge encoder LSTM recurrent weights.
    pub const EDGE_W_HH: usize = 5;
    /// Edge encoder LSTM input bias.
    pub const EDGE_B_IH: usize = 6;
    /// Edge encoder LSTM recurrent bias.
    pub const EDGE_B_HH: usize = 7;
    /// p(z|x) first layer weights.
    pub const PZ1_W: usize = 8;
    /// p(z|x) first layer bias.
    pub const PZ1_B: usize = 9;
    /// p(z|x) second layer weights.
    pub const PZ2_W: usize = 10;
    /// p(z|x) second layer bias.
    pub const PZ2_B: usize = 11;
    /// Decoder initial-state weights.
    pub const INIT_W: usize = 12;
    /// Decoder initial-state bias.
    pub const INIT_B: usize = 13;
    /// Decoder GRU input weights.
    pub const GRU_W_IH: usize = 14;
    /// Decoder GRU recurrent weights.
    pub const GRU_W_HH: usize = 15;
    /// Decoder GRU input bias.
    pub const GRU_B_IH: usize = 16;
    /// Decoder GRU recurrent bias.
    pub const GRU_B_HH: usize = 17;
    /// Decoder output weights.
    pub const OUT_W: usize = 18;
    /// Decoder output bias.
    pub const OUT_B: usize = 19;
}
