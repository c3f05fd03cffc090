//! The model blob: one versioned, checksummed byte image of a trained predictor, in float or int8
//! precision, that the core reads in place (from flash, or from a caller's buffer filled over the
//! link) without copying or allocating.
//!
//! ```text
//! offset size  field
//!  0     4     magic "DTJM"
//!  4     2     BLOB_VERSION (u16 LE)
//!  6     1     precision: 0 = f32, 1 = int8
//!  7     1     dynamics: 0 = unicycle, 1 = single integrator (`predict::Dynamics`)
//!  8     8     enc, edge, k, dec (u16 LE each)
//! 16     8     FEATURES, MAX_STEPS, HORIZON, OUTPUTS (u16 LE each): must match this build
//! 24     4     frame period the model was trained at, seconds (f32 LE)
//! 28     4     payload length, bytes (u32 LE)
//! 32     1     motion prior: velocity window, states (u8)
//! 33     1     motion prior: trend window, states (u8)
//! 34     1     motion prior: carry, percent (u8; 0 in blobs written before it)
//! 35     1     reserved, 0
//! 36    16     motion prior: accel gain, turn gain, accel decay, turn decay (f32 LE each)
//! 52     n     payload: the tensors of `Dims::tensors`, in order
//! 52+n   4     CRC-32/ISO-HDLC of bytes 0 .. 52+n (u32 LE)
//! ```
//!
//! Payload, f32: every tensor as little-endian f32, row-major. Int8: a weight matrix is its
//! per-row (per output channel) f32 scales, then its int8 values row-major, padded with zeros to
//! a multiple of 4 bytes (w = q * scale, scale = max |w| of the row / 127); a bias stays f32.

use super::arch::{Dims, FEATURES, MAX_STEPS, OUTPUTS, TENSORS};
use crate::crc::crc32;
use crate::limits::HORIZON;
use crate::predict::{Dynamics, PriorSettings};

/// The blob's magic bytes.
pub const BLOB_MAGIC: [u8; 4] = *b"DTJM";
/// Version of the blob layout (and of the architecture it encodes, including where the rollout
/// starts: a blob's controls are corrections to that start). 2: the rollout starts from the
/// fitted current velocity instead of the last displacement. 3: the controls are a residual
/// over the motion prior whose settings the header holds, and the features include its
/// long-window estimates; a version-2 blob is refused (its network never saw those inputs).
pub const BLOB_VERSION: u16 = 3;
/// Header length, bytes.
pub const HEADER_LEN: usize = 52;
/// CRC trailer length, bytes.
const CRC_LEN: usize = 4;

/// Numeric precision of a blob's weights.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Precision {
    /// 32-bit floats.
    F32,
    /// 8-bit integer weights with per-output-channel f32 scales; biases in f32.
    Int8,
}

impl Precision {
    const fn code(self) -> u8 {
        match self {
            Self::F32 => 0,
            Self::Int8 => 1,
        }
    }
}

/// Why a blob was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BlobError {
    /// Fewer bytes than the header and trailer, or than the header says.
    TooShort {
        /// Bytes needed.
        need: usize,
        /// Bytes given.
        have: usize,
    },
    /// The first four bytes are not "DTJM".
    BadMagic,
    /// A blob layout version this build does not read.
    Version {
        /// The version found.
        found: u16,
    },
    /// An unknown precision code.
    Precision {
        /// The code found.
        found: u8,
    },
    /// An unknown dynamics code.
    Dynamics {
        /// The code found.
        found: u8,
    },
    /// Widths that are zero or beyond the MAX_* capacities of this build.
    UnsupportedDims,
    /// FEATURES, MAX_STEPS, HORIZON or OUTPUTS differ from this build's.
    ShapeMismatch,
    /// The payload length disagrees with the widths.
    Length {
        /// Length the widths imply.
        expected: usize,
        /// Length found.
        found: usize,
    },
    /// The CRC does not match: the blob is corrupt.
    Crc,
    /// A weight, scale, bias or the frame period is not finite (or the period not positive).
    NonFinite,
    /// The motion prior's settings are out of their ranges (`PriorSettings::is_valid`).
    Prior,
    /// A tensor given to the writer has the wrong number of values, or too few tensors.
    TensorShape {
        /// Index of the tensor in layout order.
        index: usize,
    },
    /// Bytes after the blob's CRC where the blob must end ([`ModelBlob::parse_exact`]).
    Trailing {
        /// Bytes after the blob.
        extra: usize,
    },
    /// The output buffer is too small.
    BufferTooSmall,
}

impl core::fmt::Display for BlobError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::TooShort { need, have } => write!(f, "model blob too short: need {need} bytes, have {have}"),
            Self::BadMagic => f.write_str("not a model blob (magic is not DTJM)"),
            Self::Version { found } => write!(
                f,
                "model blob version {found}, this build reads {BLOB_VERSION} (retrain: version 3 adds the motion prior)"
            ),
            Self::Precision { found } => write!(f, "unknown model precision code {found}"),
            Self::Dynamics { found } => {
                write!(f, "unknown model dynamics code {found} (0 unicycle, 1 single integrator)")
            }
            Self::UnsupportedDims => f.write_str("model widths are zero or exceed this build's capacities"),
            Self::ShapeMismatch => f.write_str("model features, history, horizon or outputs differ from this build's"),
            Self::Length { expected, found } => write!(f, "model payload is {found} bytes, its widths need {expected}"),
            Self::Crc => f.write_str("model blob CRC mismatch: corrupt"),
            Self::NonFinite => f.write_str("model blob holds a non-finite value"),
            Self::Prior => f.write_str("model blob's motion-prior settings are out of range"),
            Self::TensorShape { index } => write!(f, "tensor {index} has the wrong number of values"),
            Self::Trailing { extra } => write!(f, "{extra} bytes after the model blob's CRC, where it must end"),
            Self::BufferTooSmall => f.write_str("output buffer too small for the model blob"),
        }
    }
}

impl core::error::Error for BlobError {}

/// Bytes one tensor of `rows` x `cols` takes in `precision` (a bias has cols = 1).
const fn tensor_len(rows: usize, cols: usize, precision: Precision) -> usize {
    match precision {
        Precision::Int8 if cols > 1 => rows * 4 + (rows * cols).div_ceil(4) * 4,
        _ => rows * cols * 4,
    }
}

/// Payload length of a model of `dims` in `precision`, bytes.
#[must_use]
pub const fn payload_len(dims: &Dims, precision: Precision) -> usize {
    let t = dims.tensors();
    let mut n = 0;
    let mut i = 0;
    while i < TENSORS {
        if let Some((rows, cols)) = const_get(&t, i) {
            n += tensor_len(rows, cols, precision);
        }
        i += 1;
    }
    n
}

/// `t[i]` without a panicking index, usable in const context.
const fn const_get(t: &[(usize, usize); TENSORS], i: usize) -> Option<(usize, usize)> {
    match t.split_at_checked(i) {
        Some((_, [first, ..])) => Some(*first),
        _ => None,
    }
}

/// Total blob length of a model of `dims` in `precision`, bytes.
#[must_use]
pub const fn blob_len(dims: &Dims, precision: Precision) -> usize {
    HEADER_LEN + payload_len(dims, precision) + CRC_LEN
}

/// One tensor of a parsed blob, borrowed from its bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TensorView<'a> {
    /// f32 values, row-major.
    F32 {
        /// Rows.
        rows: usize,
        /// Columns (1 for a bias).
        cols: usize,
        /// `rows * cols` little-endian f32.
        data: &'a [u8],
    },
    /// int8 values with per-row scales.
    Int8 {
        /// Rows.
        rows: usize,
        /// Columns.
        cols: usize,
        /// `rows` little-endian f32 scales.
        scales: &'a [u8],
        /// `rows * cols` int8 values, row-major.
        data: &'a [u8],
    },
}

/// A validated model blob, read in place.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelBlob<'a> {
    dims: Dims,
    precision: Precision,
    frame_period_s: f32,
    prior: PriorSettings,
    dynamics: Dynamics,
    payload: &'a [u8],
    /// Where each tensor starts in the payload and its shape, computed once on parse: looking
    /// them up by walking the layout at every affine map was 5% of the firmware's instructions.
    layout: [TensorPlace; TENSORS],
}

/// One tensor's place in the payload.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct TensorPlace {
    offset: usize,
    len: usize,
    rows: usize,
    cols: usize,
}

/// The places of every tensor of `dims` in `precision`.
fn layout(dims: &Dims, precision: Precision) -> [TensorPlace; TENSORS] {
    let mut out = [TensorPlace::default(); TENSORS];
    let mut at = 0;
    for (place, (rows, cols)) in out.iter_mut().zip(dims.tensors()) {
        let len = tensor_len(rows, cols, precision);
        *place = TensorPlace { offset: at, len, rows, cols };
        at += len;
    }
    out
}

fn u16_at(b: &[u8], at: usize) -> Option<u16> {
    b.get(at..at + 2).and_then(|s| s.try_into().ok()).map(u16::from_le_bytes)
}

fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    b.get(at..at + 4).and_then(|s| s.try_into().ok()).map(u32::from_le_bytes)
}

/// Reads the `i`-th little-endian f32 of `b` (0.0 past the end; callers stay in bounds).
#[must_use]
pub fn f32_at(b: &[u8], i: usize) -> f32 {
    b.get(4 * i..4 * i + 4).map_or(0.0, le_f32)
}

/// The little-endian f32 in a 4-byte chunk (0.0 for another length, which `chunks_exact(4)`
/// never yields): for walking a tensor's floats by iterator, without an index product each.
#[must_use]
pub fn le_f32(b: &[u8]) -> f32 {
    if let [a, b, c, d] = *b { f32::from_le_bytes([a, b, c, d]) } else { 0.0 }
}

impl<'a> ModelBlob<'a> {
    /// Validates `bytes` as a model blob: length, magic, version, precision, widths, shapes,
    /// payload length, CRC and finiteness of every float. Trailing bytes after the CRC are
    /// ignored (a receive buffer may be larger than the blob).
    ///
    /// # Errors
    /// See [`BlobError`].
    pub fn parse(bytes: &'a [u8]) -> Result<Self, BlobError> {
        let short = |need| BlobError::TooShort { need, have: bytes.len() };
        let header = bytes.get(..HEADER_LEN).ok_or(short(HEADER_LEN + CRC_LEN))?;
        if header.get(..4) != Some(&BLOB_MAGIC[..]) {
            return Err(BlobError::BadMagic);
        }
        let h16 = |at| u16_at(header, at).map_or(0, usize::from);
        let version = u16_at(header, 4).unwrap_or(0);
        if version != BLOB_VERSION {
            return Err(BlobError::Version { found: version });
        }
        let precision = match header.get(6).copied() {
            Some(0) => Precision::F32,
            Some(1) => Precision::Int8,
            other => return Err(BlobError::Precision { found: other.unwrap_or(0) }),
        };
        let code = header.get(7).copied().unwrap_or(0);
        let dynamics = Dynamics::from_code(code).ok_or(BlobError::Dynamics { found: code })?;
        let dims = Dims { enc: h16(8), edge: h16(10), k: h16(12), dec: h16(14) };
        if !dims.is_supported() {
            return Err(BlobError::UnsupportedDims);
        }
        if (h16(16), h16(18), h16(20), h16(22)) != (FEATURES, MAX_STEPS, HORIZON, OUTPUTS) {
            return Err(BlobError::ShapeMismatch);
        }
        let frame_period_s = f32_at(header, 6); // the f32 at byte offset 24
        let found = u32_at(header, 28).map_or(0, |v| v as usize);
        let expected = payload_len(&dims, precision);
        if found != expected {
            return Err(BlobError::Length { expected, found });
        }
        let total = HEADER_LEN + expected + CRC_LEN;
        let body = bytes.get(..HEADER_LEN + expected).ok_or(short(total))?;
        let crc = u32_at(bytes, HEADER_LEN + expected).ok_or(short(total))?;
        if crc32(body) != crc {
            return Err(BlobError::Crc);
        }
        if !(frame_period_s.is_finite() && frame_period_s > 0.0) {
            return Err(BlobError::NonFinite);
        }
        let prior = PriorSettings {
            velocity_window: header.get(32).copied().unwrap_or(0),
            trend_window: header.get(33).copied().unwrap_or(0),
            carry_percent: header.get(34).copied().unwrap_or(0),
            accel_gain: f32_at(header, 9),
            turn_gain: f32_at(header, 10),
            accel_decay: f32_at(header, 11),
            turn_decay: f32_at(header, 12),
        };
        if !prior.is_valid() {
            return Err(BlobError::Prior);
        }
        let blob = Self {
            dims,
            precision,
            frame_period_s,
            prior,
            dynamics,
            payload: body.get(HEADER_LEN..).unwrap_or(&[]),
            layout: layout(&dims, precision),
        };
        if !blob.floats_are_finite() {
            return Err(BlobError::NonFinite);
        }
        Ok(blob)
    }

    /// [`ModelBlob::parse`] of bytes that must hold the blob and nothing else: a file or a
    /// signed message, where bytes after the CRC mean a wrong or doubly wrapped file.
    ///
    /// # Errors
    /// See [`BlobError`]; [`BlobError::Trailing`] for bytes after the CRC.
    pub fn parse_exact(bytes: &'a [u8]) -> Result<Self, BlobError> {
        let blob = Self::parse(bytes)?;
        let len = HEADER_LEN + blob.payload.len() + CRC_LEN;
        match bytes.len().checked_sub(len) {
            Some(0) => Ok(blob),
            Some(extra) => Err(BlobError::Trailing { extra }),
            None => Err(BlobError::TooShort { need: len, have: bytes.len() }),
        }
    }

    fn floats_are_finite(&self) -> bool {
        (0..TENSORS).all(|i| match self.tensor(i) {
            Some(TensorView::F32 { data, .. }) => {
                data.chunks_exact(4).all(|c| c.try_into().is_ok_and(|b| f32::from_le_bytes(b).is_finite()))
            }
            Some(TensorView::Int8 { scales, .. }) => {
                scales.chunks_exact(4).all(|c| c.try_into().is_ok_and(|b| f32::from_le_bytes(b).is_finite()))
            }
            None => false,
        })
    }

    /// The model's widths.
    #[must_use]
    pub const fn dims(&self) -> Dims {
        self.dims
    }

    /// The weights' precision.
    #[must_use]
    pub const fn precision(&self) -> Precision {
        self.precision
    }

    /// The frame period the model was trained at, seconds.
    #[must_use]
    pub const fn frame_period_s(&self) -> f32 {
        self.frame_period_s
    }

    /// The motion prior the network's controls are added to.
    #[must_use]
    pub const fn prior(&self) -> &PriorSettings {
        &self.prior
    }

    /// How the network's outputs move the forecast.
    #[must_use]
    pub const fn dynamics(&self) -> Dynamics {
        self.dynamics
    }

    /// Tensor `index` in layout order (`None` past the last).
    #[must_use]
    pub fn tensor(&self, index: usize) -> Option<TensorView<'a>> {
        let TensorPlace { offset, len, rows, cols } = *self.layout.get(index)?;
        let bytes = self.payload.get(offset..offset + len)?;
        Some(match self.precision {
            Precision::Int8 if cols > 1 => {
                let (scales, data) = bytes.split_at_checked(rows * 4)?;
                TensorView::Int8 { rows, cols, scales, data: data.get(..rows * cols)? }
            }
            _ => TensorView::F32 { rows, cols, data: bytes },
        })
    }
}

/// Writes a unicycle blob of `dims` in `precision` from float tensors given in layout order
/// (each row-major, `rows * cols` values), quantising for int8. Returns the blob length.
///
/// # Errors
/// [`BlobError::TensorShape`] for a missing or mis-sized tensor, [`BlobError::NonFinite`] for a
/// non-finite value, [`BlobError::UnsupportedDims`], [`BlobError::BufferTooSmall`].
pub fn write_blob(
    dims: &Dims,
    precision: Precision,
    frame_period_s: f32,
    prior: &PriorSettings,
    tensors: &[&[f32]],
    out: &mut [u8],
) -> Result<usize, BlobError> {
    write_blob_with(dims, precision, frame_period_s, prior, Dynamics::Unicycle, tensors, out)
}

/// [`write_blob`] for a model of `dynamics`.
///
/// # Errors
/// See [`write_blob`].
pub fn write_blob_with(
    dims: &Dims,
    precision: Precision,
    frame_period_s: f32,
    prior: &PriorSettings,
    dynamics: Dynamics,
    tensors: &[&[f32]],
    out: &mut [u8],
) -> Result<usize, BlobError> {
    if !dims.is_supported() {
        return Err(BlobError::UnsupportedDims);
    }
    if !(frame_period_s.is_finite() && frame_period_s > 0.0) {
        return Err(BlobError::NonFinite);
    }
    if !prior.is_valid() {
        return Err(BlobError::Prior);
    }
    let total = blob_len(dims, precision);
    let out = out.get_mut(..total).ok_or(BlobError::BufferTooSmall)?;
    out.fill(0);
    let payload = payload_len(dims, precision);
    let mut header = [0u8; HEADER_LEN];
    let fields16 = [dims.enc, dims.edge, dims.k, dims.dec, FEATURES, MAX_STEPS, HORIZON, OUTPUTS];
    for (chunk, v) in header.get_mut(8..24).unwrap_or(&mut []).chunks_exact_mut(2).zip(fields16) {
        chunk.copy_from_slice(&u16::try_from(v).map_err(|_| BlobError::UnsupportedDims)?.to_le_bytes());
    }
    header.get_mut(..4).unwrap_or(&mut []).copy_from_slice(&BLOB_MAGIC);
    header.get_mut(4..6).unwrap_or(&mut []).copy_from_slice(&BLOB_VERSION.to_le_bytes());
    if let Some([p, d]) = header.get_mut(6..8) {
        (*p, *d) = (precision.code(), dynamics.code());
    }
    header.get_mut(24..28).unwrap_or(&mut []).copy_from_slice(&frame_period_s.to_le_bytes());
    header
        .get_mut(28..32)
        .unwrap_or(&mut [])
        .copy_from_slice(&u32::try_from(payload).map_err(|_| BlobError::UnsupportedDims)?.to_le_bytes());
    if let Some([v, t, c]) = header.get_mut(32..35) {
        (*v, *t, *c) = (prior.velocity_window, prior.trend_window, prior.carry_percent);
    }
    let floats = [prior.accel_gain, prior.turn_gain, prior.accel_decay, prior.turn_decay];
    for (chunk, v) in header.get_mut(36..52).unwrap_or(&mut []).chunks_exact_mut(4).zip(floats) {
        chunk.copy_from_slice(&v.to_le_bytes());
    }
    out.get_mut(..HEADER_LEN).ok_or(BlobError::BufferTooSmall)?.copy_from_slice(&header);

    let mut at = HEADER_LEN;
    for (index, (rows, cols)) in dims.tensors().into_iter().enumerate() {
        let values = tensors.get(index).ok_or(BlobError::TensorShape { index })?;
        if values.len() != rows * cols {
            return Err(BlobError::TensorShape { index });
        }
        if !values.iter().all(|v| v.is_finite()) {
            return Err(BlobError::NonFinite);
        }
        let len = tensor_len(rows, cols, precision);
        let dst = out.get_mut(at..at + len).ok_or(BlobError::BufferTooSmall)?;
        match precision {
            Precision::Int8 if cols > 1 => {
                let (scales, data) = dst.split_at_mut(rows * 4);
                for ((row, scale), q) in
                    values.chunks_exact(cols).zip(scales.chunks_exact_mut(4)).zip(data.chunks_mut(cols))
                {
                    let max = row.iter().fold(0.0f32, |m, v| m.max(v.abs()));
                    let s = if max > 0.0 { max / 127.0 } else { 1.0 };
                    scale.copy_from_slice(&s.to_le_bytes());
                    for (dst, v) in q.iter_mut().zip(row) {
                        // The cast saturates, and the value is within +-127 by construction.
                        *dst = libm::roundf(v / s).clamp(-127.0, 127.0) as i8 as u8;
                    }
                }
            }
            _ => {
                for (dst, v) in dst.chunks_exact_mut(4).zip(values.iter()) {
                    dst.copy_from_slice(&v.to_le_bytes());
                }
            }
        }
        at += len;
    }
    let crc = crc32(out.get(..at).ok_or(BlobError::BufferTooSmall)?);
    out.get_mut(at..at + CRC_LEN).ok_or(BlobError::BufferTooSmall)?.copy_from_slice(&crc.to_le_bytes());
    Ok(total)
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::needless_range_loop)]
mod tests;
