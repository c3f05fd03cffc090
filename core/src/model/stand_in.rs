//! Stand-in weights: a blob with the memory and arithmetic of a trained model of given widths
//! and no data behind it, for cost measurements and tests on every target (the host, the MCU),
//! written into the caller's buffers.

use super::arch::{Dims, TENSORS};
use super::blob::{BlobError, Precision, write_blob_with};
use crate::predict::{Dynamics, PriorSettings};

/// The seed of the stand-in blobs that the cost measurements, the fixtures and the firmware's
/// timing program share, so that each of them times the same weights.
pub const STAND_IN_SEED: u32 = 0x2545_f491;

/// Fills `weights` with pseudo-random values in (-0.2, 0.2), seeded by `seed` (a xorshift32
/// sequence; a zero seed, which xorshift never leaves, is taken as [`STAND_IN_SEED`]).
pub fn stand_in_weights(seed: u32, weights: &mut [f32]) {
    let mut state = if seed == 0 { STAND_IN_SEED } else { seed };
    for w in weights {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        *w = (state as f32 / u32::MAX as f32 - 0.5) * 0.4;
    }
}

/// Writes the blob of `dims` in `precision` whose weights are [`stand_in_weights`] of `seed`,
/// with the default prior, forecasting with `dynamics` at `frame_period_s`, into `out`;
/// `scratch` holds the f32 weights on the way (at least `dims.parameters()` values). Returns
/// the blob's length.
///
/// # Errors
/// [`BlobError::TooShort`] when `scratch` is shorter than the parameters (counted in values),
/// and whatever [`write_blob_with`] says of the widths, the period or `out`.
pub fn write_stand_in_blob(
    (dims, precision, dynamics): (&Dims, Precision, Dynamics),
    frame_period_s: f32,
    seed: u32,
    scratch: &mut [f32],
    out: &mut [u8],
) -> Result<usize, BlobError> {
    let have = scratch.len();
    let flat = scratch.get_mut(..dims.parameters()).ok_or(BlobError::TooShort { need: dims.parameters(), have })?;
    stand_in_weights(seed, flat);
    let mut rest: &[f32] = flat;
    let mut slices: [&[f32]; TENSORS] = [&[]; TENSORS];
    for (s, (r, c)) in slices.iter_mut().zip(dims.tensors()) {
        let (a, b) = rest.split_at_checked(r * c).ok_or(BlobError::UnsupportedDims)?;
        *s = a;
        rest = b;
    }
    write_blob_with(dims, precision, frame_period_s, &PriorSettings::DEFAULT, dynamics, &slices, out)
}
