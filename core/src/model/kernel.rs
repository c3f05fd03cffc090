//! The arithmetic of inference over a blob's tensors: affine maps and activations, in f32 (the
//! reference) or int8 (int8 weights, per-call int8 activations, i32 accumulation, table-based
//! sigmoid and tanh). The network code above it is shared by both.

use core::marker::PhantomData;

use super::arch::{MAX_DEC, MAX_K};
use super::blob::{ModelBlob, TensorView, le_f32};
use super::dot::{Int8Dot, PortableDot};
use super::lut::{sigmoid_lut, tanh_lut};

/// Longest input of any affine map: the decoder GRU's [u_prev (2), z (k), x (cond)].
pub const MAX_AFFINE_IN: usize = 2 + MAX_K + 2 * MAX_DEC;

/// Inputs shorter than this are multiplied in f32 with dequantised int8 weights instead of
/// being quantised (the decoder's two control columns).
const NARROW_IN: usize = 4;
/// Rows whose sums wait in a buffer before being added to an output (an int8 product added to
/// what the output holds; a product that overwrites its output uses the output as its buffer).
const ADD_CHUNK: usize = 16;
/// Inputs up to this length are quantised into a buffer of this size (the recurrent inputs of the
/// 8- and 16-wide networks)...
const TINY_IN: usize = 16;
/// ... up to this length into one of this size (every input of those networks), longer ones into
/// one of [`MAX_AFFINE_IN`].
const SHORT_IN: usize = 48;

/// Why an affine map could not be applied: a shape the blob does not have (a bug, not an input
/// error: blobs are validated on load). Callers turn it into a refused forecast.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ShapeError;

/// Affine maps and activations over one blob, with the int8 dot products of `D`.
#[derive(Debug, Clone, Copy)]
pub struct Kernel<'a, D = PortableDot> {
    blob: ModelBlob<'a>,
    dot: PhantomData<fn() -> D>,
}

impl<'a> Kernel<'a> {
    /// The kernel of `blob`, with the portable dot products.
    #[must_use]
    pub const fn new(blob: ModelBlob<'a>) -> Self {
        Self::with_dot(blob)
    }
}

impl<'a, D: Int8Dot> Kernel<'a, D> {
    /// The kernel of `blob`, with the dot products of `D`.
    #[must_use]
    pub const fn with_dot(blob: ModelBlob<'a>) -> Self {
        Self { blob, dot: PhantomData }
    }

    /// The blob.
    #[must_use]
    pub const fn blob(&self) -> &ModelBlob<'a> {
        &self.blob
    }

    /// `out = W x (+ b)`, W tensor `w`, b tensor `b` (a bias is always f32). An `out` shorter
    /// than the tensor's rows receives its first `out.len()` rows only (outputs nobody reads
    /// are not computed).
    ///
    /// # Errors
    /// [`ShapeError`] when `x` or `out` do not fit the tensor.
    pub fn affine(&self, w: usize, b: Option<usize>, x: &[f32], out: &mut [f32]) -> Result<(), ShapeError> {
        self.affine_columns(w, 0, b, x, out, true)
    }

    /// `out (+)= W[:, first..first + x.len()] x (+ b)`: the product with a block of columns, so
    /// that a constant part of an input can be multiplied once instead of at every step. With
    /// `overwrite` false the product is added to `out`.
    ///
    /// # Errors
    /// [`ShapeError`] when the columns or `out` do not fit the tensor.
    pub fn affine_columns(
        &self,
        w: usize,
        first: usize,
        b: Option<usize>,
        x: &[f32],
        out: &mut [f32],
        overwrite: bool,
    ) -> Result<(), ShapeError> {
        let cols_used = first..first + x.len();
        let bias = match b {
            None => None,
            Some(b) => match self.blob.tensor(b).ok_or(ShapeError)? {
                TensorView::F32 { rows, data, .. } if rows >= out.len() => Some(data),
                _ => return Err(ShapeError),
            },
        };
        match self.blob.tensor(w).ok_or(ShapeError)? {
            TensorView::F32 { rows, cols, data } => {
                check(rows, cols, &cols_used, out)?;
                for (o, row) in out.iter_mut().zip(data.chunks_exact(4 * cols)) {
                    let part = row.get(4 * cols_used.start..4 * cols_used.end).ok_or(ShapeError)?;
                    let dot: f32 = part.chunks_exact(4).zip(x).map(|(c, xi)| le_f32(c) * xi).sum();
                    *o = if overwrite { dot } else { *o + dot };
                }
                if let Some(bias) = bias {
                    add_bias(out, bias);
                }
            }
            TensorView::Int8 { rows, cols, scales, data } => {
                check(rows, cols, &cols_used, out)?;
                affine_int8::<D>(Int8Rows { cols, scales, data }, cols_used, x, out, overwrite, bias)?;
            }
        }
        Ok(())
    }
}

/// The gate nonlinearities of one precision. The recurrent cells pick one per step and run
/// their unit loop monomorphised over it (a precision test per call had cost a compare and a
/// branch per nonlinearity on the MCU).
pub trait Activation {
    /// The logistic sigmoid.
    fn sigmoid(x: f32) -> f32;
    /// tanh.
    fn tanh(x: f32) -> f32;
}

/// f32 inference's activations: libm.
#[derive(Debug, Clone, Copy)]
pub struct Exact;

impl Activation for Exact {
    fn sigmoid(x: f32) -> f32 {
        1.0 / (1.0 + libm::expf(-x))
    }
    fn tanh(x: f32) -> f32 {
        libm::tanhf(x)
    }
}

/// int8 inference's activations: the interpolated table of `super::lut`.
#[derive(Debug, Clone, Copy)]
pub struct Table;

impl Activation for Table {
    #[inline(always)]
    fn sigmoid(x: f32) -> f32 {
        sigmoid_lut(x)
    }
    #[inline(always)]
    fn tanh(x: f32) -> f32 {
        tanh_lut(x)
    }
}

/// An int8 tensor's rows: `rows * cols` weights and a little-endian f32 scale per row.
struct Int8Rows<'a> {
    cols: usize,
    scales: &'a [u8],
    data: &'a [u8],
}

/// `out (+)= W[:, used] x` for an int8 tensor whose shape [`check`] has accepted.
///
/// The products are [`Int8Dot::rows`]'s; scales are walked by iterators so that the MCU
/// computes no checked index products per row.
fn affine_int8<'a, D: Int8Dot>(
    t: Int8Rows<'a>,
    used: core::ops::Range<usize>,
    x: &[f32],
    out: &mut [f32],
    overwrite: bool,
    bias: Option<&[u8]>,
) -> Result<(), ShapeError> {
    let Int8Rows { cols, scales, data } = t;
    if cols == 0 {
        return Err(ShapeError);
    }
    let (first, end) = (used.start, used.end);
    if x.len() < NARROW_IN {
        // A quantisation step costs more than these few products: multiply in f32 with the
        // dequantised weights.
        let rows = data.chunks_exact(cols).zip(scales.chunks_exact(4)).zip(out.iter_mut());
        let w = |b: u8| f32::from(b as i8);
        if let (&[x0, x1], false) = (x, overwrite) {
            // The decoder's two controls added to the fixed part of its gates, 30 times per
            // forecast: written out.
            for ((row, scale), o) in rows {
                let Some(&[w0, w1]) = row.get(first..end) else { return Err(ShapeError) };
                *o += (w(w0) * x0 + w(w1) * x1) * le_f32(scale);
            }
        } else {
            for ((row, scale), o) in rows {
                let part = row.get(first..end).ok_or(ShapeError)?;
                let dot = part.iter().zip(x).fold(0.0f32, |acc, (&b, xi)| acc + w(b) * xi) * le_f32(scale);
                *o = if overwrite { dot } else { *o + dot };
            }
        }
        if let Some(bias) = bias {
            add_bias(out, bias);
        }
        return Ok(());
    }
    // A short input quantises into a short buffer: clearing the full MAX_AFFINE_IN bytes on
    // every call cost more than the products of a small network's row block.
    let (mut tiny, mut short, mut long);
    let xq = if x.len() <= TINY_IN {
        tiny = [0i8; TINY_IN];
        tiny.get_mut(..x.len())
    } else if x.len() <= SHORT_IN {
        short = [0i8; SHORT_IN];
        short.get_mut(..x.len())
    } else {
        long = [0i8; MAX_AFFINE_IN];
        long.get_mut(..x.len())
    }
    .ok_or(ShapeError)?;
    let sx = quantise(x, xq);
    let xq = &*xq;
    let w = data.get(first..).ok_or(ShapeError)?;
    // |sum| <= 127 * 127 * MAX_AFFINE_IN < 2^24: exact in f32.
    let scaled = |sum: i32, scale: &[u8]| sum as f32 * (le_f32(scale) * sx);
    if overwrite {
        // The sums go into `out` itself (an i32 has an f32's size and alignment) and are scaled
        // in place, with the bias added in the same pass: a separate buffer had to be cleared on
        // every call, and a separate bias pass cost 5 instructions per output on the MCU.
        D::rows(w, cols, xq, bytemuck::cast_slice_mut(out));
        let rows = out.iter_mut().zip(scales.chunks_exact(4));
        match bias {
            Some(bias) => {
                for ((o, s), b) in rows.zip(bias.chunks_exact(4)) {
                    *o = scaled(o.to_bits() as i32, s) + le_f32(b);
                }
            }
            None => {
                for (o, s) in rows {
                    *o = scaled(o.to_bits() as i32, s);
                }
            }
        }
    } else {
        let mut sums = [0i32; ADD_CHUNK];
        let chunks = w.chunks(ADD_CHUNK * cols).zip(scales.chunks(4 * ADD_CHUNK)).zip(out.chunks_mut(ADD_CHUNK));
        for ((w, scale), o) in chunks {
            let sums = sums.get_mut(..o.len()).ok_or(ShapeError)?;
            D::rows(w, cols, xq, sums);
            for ((o, &sum), s) in o.iter_mut().zip(&*sums).zip(scale.chunks_exact(4)) {
                *o += scaled(sum, s);
            }
        }
        if let Some(bias) = bias {
            add_bias(out, bias);
        }
    }
    Ok(())
}

/// `out += b`, b a bias tensor's bytes at least as long as `out`.
fn add_bias(out: &mut [f32], bias: &[u8]) {
    for (o, b) in out.iter_mut().zip(bias.chunks_exact(4)) {
        *o += le_f32(b);
    }
}

fn check(rows: usize, cols: usize, used: &core::ops::Range<usize>, out: &[f32]) -> Result<(), ShapeError> {
    if used.end <= cols && out.len() <= rows && used.len() <= MAX_AFFINE_IN { Ok(()) } else { Err(ShapeError) }
}

/// Symmetric per-vector int8 quantisation of `x` into `q`; returns the
/// scale (x ~ q * scale). A vector holding a NaN or an infinity quantises to zeros.
///
/// Written for the MCU: the largest magnitude from the bit patterns (for floats that are not
/// NaN, the order of |x| is the order of their bits without the sign; libm's `fmaxf` was a call
/// per element), a multiply by the reciprocal instead of a division per element, and rounding
/// to nearest, ties to even, by adding and subtracting 1.5 * 2^23 (exact IEEE arithmetic, the
/// same on the host and the MCU, where a software `roundf` was most of the cost); the float to
/// integer conversion cannot saturate as |x * 127 / max| <= 127.
fn quantise(x: &[f32], q: &mut [i8]) -> f32 {
    const ROUND: f32 = 12_582_912.0;
    let max_bits = x.iter().fold(0u32, |m, v| m.max(v.to_bits() & 0x7fff_ffff));
    if max_bits == 0 || max_bits >= f32::INFINITY.to_bits() {
        q.fill(0);
        return 0.0;
    }
    let max = f32::from_bits(max_bits);
    let inv = 127.0 / max;
    for (d, v) in q.iter_mut().zip(x) {
        *d = ((v * inv + ROUND) - ROUND) as i32 as i8;
    }
    max / 127.0
}
