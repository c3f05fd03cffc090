//! The arithmetic of inference over a blob's tensors: affine maps and activations, in f32 (the
//! reference) or int8 (int8 weights, per-call int8 activations, i32 accumulation, table-based
//! sigmoid and tanh). The network code above it is shared by both.

use super::arch::{MAX_DEC, MAX_K};
use super::blob::{ModelBlob, TensorView, le_f32};
use super::lut::{sigmoid_lut, tanh_lut};

/// Longest input of any affine map: the decoder GRU's [u_prev (2), z (k), x (cond)].
pub const MAX_AFFINE_IN: usize = 2 + MAX_K + 2 * MAX_DEC;

/// Inputs shorter than this are multiplied in f32 with dequantised int8 weights instead of
/// being quantised (the decoder's two control columns).
const NARROW_IN: usize = 4;
/// Rows multiplied together: each activation is loaded once for four rows of weights, and the
/// per-row setup is shared (on the MCU the products cost about 3.3 instructions each, and the
/// setup had been about 60 instructions per row).
const ROW_BLOCK: usize = 4;
/// Inputs up to this length are quantised into a buffer of this size (every input of the
/// 8- and 16-wide networks), longer ones into one of [`MAX_AFFINE_IN`].
const SHORT_IN: usize = 48;

/// Why an affine map could not be applied: a shape the blob does not have (a bug, not an input
/// error: blobs are validated on load). Callers turn it into a refused forecast.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ShapeError;

/// Affine maps and activations over one blob.
#[derive(Debug, Clone, Copy)]
pub struct Kernel<'a> {
    blob: ModelBlob<'a>,
}

impl<'a> Kernel<'a> {
    /// The kernel of `blob`.
    #[must_use]
    pub const fn new(blob: ModelBlob<'a>) -> Self {
        Self { blob }
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
        match self.blob.tensor(w).ok_or(ShapeError)? {
            TensorView::F32 { rows, cols, data } => {
                check(rows, cols, &cols_used, out)?;
                for (o, row) in out.iter_mut().zip(data.chunks_exact(4 * cols)) {
                    let part = row.get(4 * cols_used.start..4 * cols_used.end).ok_or(ShapeError)?;
                    let dot: f32 = part.chunks_exact(4).zip(x).map(|(c, xi)| le_f32(c) * xi).sum();
                    *o = if overwrite { dot } else { *o + dot };
                }
            }
            TensorView::Int8 { rows, cols, scales, data } => {
                check(rows, cols, &cols_used, out)?;
                affine_int8(Int8Rows { cols, scales, data }, cols_used, x, out, overwrite)?;
            }
        }
        if let Some(b) = b {
            match self.blob.tensor(b).ok_or(ShapeError)? {
                TensorView::F32 { rows, data, .. } if rows >= out.len() => {
                    for (o, b) in out.iter_mut().zip(data.chunks_exact(4)) {
                        *o += le_f32(b);
                    }
                }
                _ => return Err(ShapeError),
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

/// int8 inference's activations: the interpolated table of [`super::lut`].
#[derive(Debug, Clone, Copy)]
pub struct Table;

impl Activation for Table {
    fn sigmoid(x: f32) -> f32 {
        sigmoid_lut(x)
    }
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
/// Rows go four at a time through [`dot4_i8`]; rows and scales are walked by iterators so that
/// the MCU computes no checked index products per row (with the firmware's overflow checks,
/// the per-row setup had cost more than the products of a 16-wide row).
fn affine_int8<'a>(
    t: Int8Rows<'a>,
    used: core::ops::Range<usize>,
    x: &[f32],
    out: &mut [f32],
    overwrite: bool,
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
        if let [x0, x1] = *x {
            // The decoder's two controls, 30 times per forecast: written out.
            for ((row, scale), o) in rows {
                let Some(&[w0, w1]) = row.get(first..end) else { return Err(ShapeError) };
                let dot = (w(w0) * x0 + w(w1) * x1) * le_f32(scale);
                *o = if overwrite { dot } else { *o + dot };
            }
        } else {
            for ((row, scale), o) in rows {
                let part = row.get(first..end).ok_or(ShapeError)?;
                let dot = part.iter().zip(x).fold(0.0f32, |acc, (&b, xi)| acc + w(b) * xi) * le_f32(scale);
                *o = if overwrite { dot } else { *o + dot };
            }
        }
        return Ok(());
    }
    // A short input quantises into a short buffer: clearing the full MAX_AFFINE_IN bytes on
    // every call cost more than the products of a small network's row block.
    let mut small = [0i8; SHORT_IN];
    let mut long;
    let xq = if x.len() <= SHORT_IN {
        small.get_mut(..x.len())
    } else {
        long = [0i8; MAX_AFFINE_IN];
        long.get_mut(..x.len())
    }
    .ok_or(ShapeError)?;
    let sx = quantise(x, xq);
    let xq = &*xq;
    // |acc| <= 127 * 127 * MAX_AFFINE_IN < 2^24: exact in f32.
    let store = |o: &mut f32, acc: i32, scale: &[u8]| {
        let dot = acc as f32 * (le_f32(scale) * sx);
        *o = if overwrite { dot } else { *o + dot };
    };
    let blocked = out.len() - out.len() % ROW_BLOCK;
    let (out_blocked, out_rest) = out.split_at_mut(blocked);
    let (rows_blocked, rows_rest) = data.split_at_checked(blocked * cols).ok_or(ShapeError)?;
    let (scales_blocked, scales_rest) = scales.split_at_checked(4 * blocked).ok_or(ShapeError)?;
    let blocks = rows_blocked
        .chunks_exact(ROW_BLOCK * cols)
        .zip(scales_blocked.chunks_exact(4 * ROW_BLOCK))
        .zip(out_blocked.chunks_exact_mut(ROW_BLOCK));
    for ((w, scale), o) in blocks {
        let mut rows = w.chunks_exact(cols);
        let mut row = || rows.next().and_then(|r| r.get(first..end)).ok_or(ShapeError);
        let acc = dot4_i8([row()?, row()?, row()?, row()?], xq);
        for ((o, a), s) in o.iter_mut().zip(acc).zip(scale.chunks_exact(4)) {
            store(o, a, s);
        }
    }
    for ((row, s), o) in rows_rest.chunks_exact(cols).zip(scales_rest.chunks_exact(4)).zip(out_rest) {
        store(o, dot_i8(row.get(first..end).ok_or(ShapeError)?, xq), s);
    }
    Ok(())
}

fn check(rows: usize, cols: usize, used: &core::ops::Range<usize>, out: &[f32]) -> Result<(), ShapeError> {
    if used.end <= cols && out.len() <= rows && used.len() <= MAX_AFFINE_IN { Ok(()) } else { Err(ShapeError) }
}

/// The dot product of int8 weights (as stored bytes) with int8 activations.
///
/// Four products per step from one 32-bit load of each side, added with wrapping arithmetic:
/// |sum| <= 127 * 127 * MAX_AFFINE_IN < 2^24 cannot overflow, and checked additions (the
/// firmware builds with overflow checks) cost a compare and a branch per product on the MCU
/// (measured: about 8 instructions per multiply-accumulate before, see docs/results.md).
fn dot_i8(w: &[u8], x: &[i8]) -> i32 {
    let product = |a: u8, b: i8| i32::from(a as i8).wrapping_mul(i32::from(b));
    let (wq, xq) = (w.chunks_exact(4), x.chunks_exact(4));
    let tail = wq.remainder().iter().zip(xq.remainder()).fold(0i32, |acc, (&a, &b)| acc.wrapping_add(product(a, b)));
    wq.zip(xq).fold(tail, |acc, (a, b)| match (a, b) {
        ([a0, a1, a2, a3], [b0, b1, b2, b3]) => acc
            .wrapping_add(product(*a0, *b0))
            .wrapping_add(product(*a1, *b1))
            .wrapping_add(product(*a2, *b2))
            .wrapping_add(product(*a3, *b3)),
        _ => acc,
    })
}

/// The dot products of four rows of int8 weights, each as long as `x`, with the int8
/// activations `x` (each activation loaded once for the four rows).
fn dot4_i8(w: [&[u8]; 4], x: &[i8]) -> [i32; 4] {
    let [w0, w1, w2, w3] = w;
    // Wrapping: see dot_i8.
    let mac = |acc: i32, w: u8, xi: i32| acc.wrapping_add(i32::from(w as i8).wrapping_mul(xi));
    x.iter().zip(w0).zip(w1).zip(w2).zip(w3).fold([0i32; 4], |[a0, a1, a2, a3], ((((&xi, &b0), &b1), &b2), &b3)| {
        let xi = i32::from(xi);
        [mac(a0, b0, xi), mac(a1, b1, xi), mac(a2, b2, xi), mac(a3, b3, xi)]
    })
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
