//! The arithmetic of inference over a blob's tensors: affine maps and activations, in f32 (the
//! reference) or int8 (int8 weights, per-call int8 activations, i32 accumulation, table-based
//! sigmoid and tanh). The network code above it is shared by both.

use super::arch::{MAX_DEC, MAX_K};
use super::blob::{f32_at, ModelBlob, Precision, TensorView};
use super::lut::{sigmoid_lut, tanh_lut};

/// Longest input of any affine map: the decoder GRU's [u_prev (2), z (k), x (cond)].
pub const MAX_AFFINE_IN: usize = 2 + MAX_K + 2 * MAX_DEC;

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

    /// `out = W x (+ b)`, W tensor `w`, b tensor `b` (a bias is always f32).
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
    pub fn affine_columns(&self, w: usize, first: usize, b: Option<usize>, x: &[f32], out: &mut [f32], overwrite: bool) -> Result<(), ShapeError> {
        let cols_used = first..first + x.len();
        match self.blob.tensor(w).ok_or(ShapeError)? {
            TensorView::F32 { rows, cols, data } => {
                check(rows, cols, &cols_used, out)?;
                for (o, row) in out.iter_mut().zip(data.chunks_exact(4 * cols)) {
                    let part = row.get(4 * cols_used.start..4 * cols_used.end).ok_or(ShapeError)?;
                    let dot: f32 = part.chunks_exact(4).zip(x).map(|(c, xi)| f32_at(c, 0) * xi).sum();
                    *o = if overwrite { dot } else { *o + dot };
                }
            }
            TensorView::Int8 { rows, cols, scales, data } => {
                check(rows, cols, &cols_used, out)?;
                let mut xq = [0i8; MAX_AFFINE_IN];
                let sx = quantise(x, &mut xq);
                let xq = xq.get(..x.len()).ok_or(ShapeError)?;
                for (r, (o, row)) in out.iter_mut().zip(data.chunks_exact(cols)).enumerate() {
                    let part = row.get(cols_used.clone()).ok_or(ShapeError)?;
                    let acc = dot_i8(part, xq);
                    // |acc| <= 127 * 127 * MAX_AFFINE_IN < 2^24: exact in f32.
                    let dot = acc as f32 * f32_at(scales, r) * sx;
                    *o = if overwrite { dot } else { *o + dot };
                }
            }
        }
        if let Some(b) = b {
            match self.blob.tensor(b).ok_or(ShapeError)? {
                TensorView::F32 { rows, data, .. } if rows == out.len() => {
                    for (i, o) in out.iter_mut().enumerate() {
                        *o += f32_at(data, i);
                    }
                }
                _ => return Err(ShapeError),
            }
        }
        Ok(())
    }

    /// The logistic sigmoid in this blob's precision.
    #[must_use]
    pub fn sigmoid(&self, x: f32) -> f32 {
        match self.blob.precision() {
            Precision::F32 => 1.0 / (1.0 + libm::expf(-x)),
            Precision::Int8 => sigmoid_lut(x),
        }
    }

    /// tanh in this blob's precision.
    #[must_use]
    pub fn tanh(&self, x: f32) -> f32 {
        match self.blob.precision() {
            Precision::F32 => libm::tanhf(x),
            Precision::Int8 => tanh_lut(x),
        }
    }
}

fn check(rows: usize, cols: usize, used: &core::ops::Range<usize>, out: &[f32]) -> Result<(), ShapeError> {
    if used.end <= cols && out.len() == rows && used.len() <= MAX_AFFINE_IN { Ok(()) } else { Err(ShapeError) }
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

/// Symmetric per-vector int8 quantisation of `x` into `q`; returns the scale (x ~ q * scale).
/// Rounds half away from zero as `libm::roundf` does (adding +-(0.5 - EPSILON / 4), so that a
/// value just below a half does not round up, then truncating), but with the hardware
/// float-to-int conversion and a multiply instead of a division per element: the division and
/// the software `roundf` were most of the quantisation's cost on the MCU.
fn quantise(x: &[f32], q: &mut [i8; MAX_AFFINE_IN]) -> f32 {
    let max = x.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    if !(max > 0.0 && max.is_finite()) {
        q.fill(0);
        return 0.0;
    }
    let s = max / 127.0;
    let inv = 127.0 / max;
    for (d, v) in q.iter_mut().zip(x) {
        let y = v * inv;
        // |y| <= 127 (to rounding) by construction; the float-to-int cast saturates anyway.
        *d = (y + (0.5 - 0.25 * f32::EPSILON).copysign(y)) as i8;
    }
    s
}
