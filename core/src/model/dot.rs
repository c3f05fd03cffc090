//! The int8 products of inference: the one piece of arithmetic that a target may do with its own
//! instructions (the Cortex-M4's dual 16-bit multiply-accumulate, in a crate outside core, since
//! it needs `unsafe`). [`PortableDot`] is the reference every other implementation must equal bit
//! for bit.

/// Products of rows of int8 weights (stored as bytes, read as `i8`) with int8 activations.
pub trait Int8Dot {
    /// `out[r] = sum(w[r * stride + i] as i8 * x[i] for i < x.len())` for every `r <
    /// out.len()`: the rows of a row-major matrix of `stride` columns, from the column `w`
    /// starts at.
    ///
    /// Callers pass `x` at most [`MAX_AFFINE_IN`](super::kernel::MAX_AFFINE_IN) long and `w`
    /// holding every row read; the sums are then exact (|sum| <= 128 * 128 * MAX_AFFINE_IN <
    /// 2^31), and an implementation must return exactly what [`PortableDot`] returns, for every
    /// byte value. Rows that `w` does not hold are a caller's bug: their outputs are then
    /// unspecified, but there is no panic.
    fn rows(w: &[u8], stride: usize, x: &[i8], out: &mut [i32]);
}

/// The products in portable Rust: the reference, and what every target without its own
/// implementation runs.
#[derive(Debug, Clone, Copy, Default)]
pub struct PortableDot;

impl Int8Dot for PortableDot {
    /// Rows four at a time (each activation loaded once for the four), walked by iterators so
    /// that the MCU computes no checked index products per row (the firmware builds with
    /// overflow checks).
    fn rows(w: &[u8], stride: usize, x: &[i8], out: &mut [i32]) {
        let len = x.len();
        let mut rows = w.chunks(stride.max(1));
        let mut row = || rows.next().and_then(|r| r.get(..len));
        let mut blocks = out.chunks_exact_mut(4);
        for o in &mut blocks {
            let (Some(a), Some(b), Some(c), Some(d)) = (row(), row(), row(), row()) else { return };
            o.copy_from_slice(&dot4([a, b, c, d], x));
        }
        for o in blocks.into_remainder() {
            let Some(r) = row() else { return };
            *o = dot(r, x);
        }
    }
}

/// `sum(w[i] as i8 * x[i])`: four products per step from one 32-bit load of each side, added with
/// wrapping arithmetic. The sum cannot overflow (see [`Int8Dot::rows`]), and checked additions
/// cost a compare and a branch per product on the MCU.
fn dot(w: &[u8], x: &[i8]) -> i32 {
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

/// The products of four rows, each as long as `x`, with `x`.
fn dot4(w: [&[u8]; 4], x: &[i8]) -> [i32; 4] {
    let [w0, w1, w2, w3] = w;
    let mac = |acc: i32, w: u8, xi: i8| acc.wrapping_add(product(w, xi));
    x.iter().zip(w0).zip(w1).zip(w2).zip(w3).fold([0i32; 4], |[a0, a1, a2, a3], ((((&xi, &b0), &b1), &b2), &b3)| {
        [mac(a0, b0, xi), mac(a1, b1, xi), mac(a2, b2, xi), mac(a3, b3, xi)]
    })
}

/// One product of a stored weight byte and an activation.
const fn product(w: u8, x: i8) -> i32 {
    (w as i8 as i32).wrapping_mul(x as i32)
}

#[cfg(test)]
#[allow(clippy::indexing_slicing)]
mod tests {
    use super::*;

    #[test]
    fn portable_products_are_the_plain_sums_for_every_shape_and_extreme_values() {
        let mut state = 7u32;
        let mut byte = move || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 24) as u8
        };
        let mut w = [0u8; 9 * 24];
        let mut x = [0i8; 20];
        for round in 0..3 {
            for (i, v) in w.iter_mut().enumerate() {
                *v = if round == 0 { 0x80 } else { byte() ^ (i as u8) };
            }
            for v in &mut x {
                *v = if round == 0 { i8::MIN } else { byte() as i8 };
            }
            for (stride, first) in [(20, 0), (24, 3), (9, 9)] {
                for len in 0..=(stride - first).min(20) {
                    for rows in 0..=9usize {
                        if rows * stride > w.len() {
                            continue;
                        }
                        let mut out = [i32::MIN; 9];
                        let xs = &x[..len];
                        PortableDot::rows(&w[first..], stride, xs, &mut out[..rows]);
                        for (r, &got) in out[..rows].iter().enumerate() {
                            let row = &w[first + r * stride..][..len];
                            let want: i32 = row.iter().zip(xs).map(|(&a, &b)| i32::from(a as i8) * i32::from(b)).sum();
                            assert_eq!(got, want, "stride {stride} first {first} len {len} row {r} of {rows}");
                        }
                        assert!(out[rows..].iter().all(|&v| v == i32::MIN), "rows past out untouched");
                    }
                }
            }
        }
    }
}
