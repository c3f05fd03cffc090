//! The GRU's gate arithmetic as one candle operation, forward and backward.
//!
//! Composed from candle's element-wise operations, the gates of one decoder step cost about a
//! dozen passes over [R, 3H] buffers forward and twice that backward, which dominated training
//! time (R = batch x modes rows, 30 steps). Fused, they are one pass each way, written so the
//! compiler vectorises them (branch-free exp). Same formulas as PyTorch and core's inference:
//! r = sigmoid(gx_r + gh_r), z = sigmoid(gx_z + gh_z), n = tanh(gx_n + r gh_n),
//! h' = (1 - z) n + z h, where gx = W_ih x + b_ih and gh = W_hh h + b_hh. The tests hold it to
//! the composed version, values and gradients.

use candle_core::{CpuStorage, CustomOp3, Layout, Result, Shape, Tensor};

/// exp for the gates: Cephes' expf (range reduction by ln 2, degree-6 polynomial, about 1 ulp)
/// without branches or libm calls, so the gate loops vectorise; the argument is clamped to
/// the finite range.
#[inline]
fn exp(x: f32) -> f32 {
    const LOG2E: f32 = std::f32::consts::LOG2_E;
    const LN2_HI: f32 = 0.693_359_4;
    const LN2_LO: f32 = -2.121_944_4e-4;
    // Adding and subtracting 1.5 * 2^23 rounds to the nearest integer in f32 arithmetic.
    const ROUND: f32 = 12_582_912.0;
    let x = x.clamp(-87.0, 88.0);
    let k = (x * LOG2E + ROUND) - ROUND;
    let r = x - k * LN2_HI - k * LN2_LO;
    let mut p = 1.987_569_2e-4f32;
    p = p * r + 1.398_199_9e-3;
    p = p * r + 8.333_452e-3;
    p = p * r + 4.166_579_6e-2;
    p = p * r + 1.666_666_5e-1;
    p = p * r + 0.5;
    let e = p * r * r + r + 1.0;
    e * f32::from_bits(((k as i32 + 127) as u32) << 23)
}

#[inline]
fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + exp(-x))
}

/// tanh(x) = 1 - 2 / (exp(2x) + 1): within about 1e-7 of libm's, exact at 0, saturating.
#[inline]
fn tanh(x: f32) -> f32 {
    1.0 - 2.0 / (exp(2.0 * x) + 1.0)
}

/// The contiguous f32 data of a CPU tensor argument.
fn data<'a>(s: &'a CpuStorage, l: &Layout) -> Result<&'a [f32]> {
    let (a, b) =
        l.contiguous_offsets().ok_or_else(|| candle_core::Error::Msg("fused GRU: non-contiguous input".into()))?;
    s.as_slice::<f32>()?.get(a..b).ok_or_else(|| candle_core::Error::Msg("fused GRU: bad layout".into()))
}

/// Checks (gx [R, 3H], gh [R, 3H], other [R, m H]) and returns (R, H).
fn widths(l1: &Layout, l2: &Layout, l3: &Layout, m: usize) -> Result<(usize, usize)> {
    let (r, h3) = l1.shape().dims2()?;
    let (r3, hm) = l3.shape().dims2()?;
    if l2.shape().dims2()? != (r, h3) || r3 != r || h3 % 3 != 0 || hm != m * (h3 / 3) {
        candle_core::bail!("fused GRU: shapes {:?} {:?} {:?}", l1.shape(), l2.shape(), l3.shape());
    }
    Ok((r, h3 / 3))
}

/// The three gate slices (r, z, n parts) of one row of width 3H.
fn thirds(row: &[f32], h: usize) -> (&[f32], &[f32], &[f32]) {
    let (a, rest) = row.split_at(h.min(row.len()));
    let (b, c) = rest.split_at(h.min(rest.len()));
    (a, b, c)
}

/// Forward: (gx, gh, h) -> h'.
struct GruGates;

impl CustomOp3 for GruGates {
    fn name(&self) -> &'static str {
        "gru-gates"
    }

    fn cpu_fwd(
        &self,
        s1: &CpuStorage,
        l1: &Layout,
        s2: &CpuStorage,
        l2: &Layout,
        s3: &CpuStorage,
        l3: &Layout,
    ) -> Result<(CpuStorage, Shape)> {
        let (rows, h) = widths(l1, l2, l3, 1)?;
        let (gx, gh, hp) = (data(s1, l1)?, data(s2, l2)?, data(s3, l3)?);
        let mut out = vec![0.0f32; rows * h];
        for (((o, gx), gh), hp) in
            out.chunks_exact_mut(h).zip(gx.chunks_exact(3 * h)).zip(gh.chunks_exact(3 * h)).zip(hp.chunks_exact(h))
        {
            let ((xr, xz, xn), (hr, hz, hn)) = (thirds(gx, h), thirds(gh, h));
            for ((((((o, &hj), &xr), &xz), &xn), (&hr, &hz)), &hn) in
                o.iter_mut().zip(hp).zip(xr).zip(xz).zip(xn).zip(hr.iter().zip(hz)).zip(hn)
            {
                let r = sigmoid(xr + hr);
                let z = sigmoid(xz + hz);
                let n = tanh(xn + r * hn);
                *o = n + z * (hj - n);
            }
        }
        Ok((CpuStorage::F32(out), Shape::from((rows, h))))
    }

    fn bwd(
        &self,
        gx: &Tensor,
        gh: &Tensor,
        h: &Tensor,
        _res: &Tensor,
        grad: &Tensor,
    ) -> Result<(Option<Tensor>, Option<Tensor>, Option<Tensor>)> {
        let hd = h.dim(1)?;
        let hg = Tensor::cat(&[h, grad], 1)?;
        let all = gx.contiguous()?.apply_op3_no_bwd(&gh.contiguous()?, &hg, &GruGatesBackward)?;
        Ok((Some(all.narrow(1, 0, 3 * hd)?), Some(all.narrow(1, 3 * hd, 3 * hd)?), Some(all.narrow(1, 6 * hd, hd)?)))
    }
}

/// Backward: (gx, gh, [h, dL/dh']) -> [dL/dgx, dL/dgh, dL/dh] ([R, 7H]), recomputing the gates.
struct GruGatesBackward;

impl CustomOp3 for GruGatesBackward {
    fn name(&self) -> &'static str {
        "gru-gates-backward"
    }

    fn cpu_fwd(
        &self,
        s1: &CpuStorage,
        l1: &Layout,
        s2: &CpuStorage,
        l2: &Layout,
        s3: &CpuStorage,
        l3: &Layout,
    ) -> Result<(CpuStorage, Shape)> {
        let (rows, h) = widths(l1, l2, l3, 2)?;
        let (gx, gh, hg) = (data(s1, l1)?, data(s2, l2)?, data(s3, l3)?);
        let mut out = vec![0.0f32; rows * 7 * h];
        for (((o, gx), gh), hg) in out
            .chunks_exact_mut(7 * h)
            .zip(gx.chunks_exact(3 * h))
            .zip(gh.chunks_exact(3 * h))
            .zip(hg.chunks_exact(2 * h))
        {
            let ((xr, xz, xn), (hr, hz, hn)) = (thirds(gx, h), thirds(gh, h));
            let (hp, g) = hg.split_at(h);
            let (d_gx, rest) = o.split_at_mut(3 * h);
            let (d_gh, d_h) = rest.split_at_mut(3 * h);
            let (dxr, rest) = d_gx.split_at_mut(h);
            let (dxz, dxn) = rest.split_at_mut(h);
            let (dhr, rest) = d_gh.split_at_mut(h);
            let (dhz, dhn) = rest.split_at_mut(h);
            let inputs = hp.iter().zip(g).zip(xr.iter().zip(xz).zip(xn)).zip(hr.iter().zip(hz).zip(hn));
            let outputs = dxr
                .iter_mut()
                .zip(dxz.iter_mut())
                .zip(dxn.iter_mut())
                .zip(dhr.iter_mut().zip(dhz.iter_mut()).zip(dhn.iter_mut()))
                .zip(d_h.iter_mut());
            for ((((&hj, &gj), ((&xr, &xz), &xn)), ((&hr, &hz), &hn)), ((((oxr, oxz), oxn), ((ohr, ohz), ohn)), oh)) in
                inputs.zip(outputs)
            {
                let r = sigmoid(xr + hr);
                let z = sigmoid(xz + hz);
                let n = tanh(xn + r * hn);
                let d_n = gj * (1.0 - z) * (1.0 - n * n);
                let d_z = gj * (hj - n) * z * (1.0 - z);
                let d_r = d_n * hn * r * (1.0 - r);
                (*oxr, *oxz, *oxn) = (d_r, d_z, d_n);
                (*ohr, *ohz, *ohn) = (d_r, d_z, d_n * r);
                *oh = gj * z;
            }
        }
        Ok((CpuStorage::F32(out), Shape::from((rows, 7 * h))))
    }
}

/// h' of a GRU step from gx = W_ih x + b_ih [R, 3H], gh = W_hh h + b_hh [R, 3H] and h [R, H],
/// differentiable in all three.
///
/// # Errors
/// Shape errors; a device other than the CPU.
pub fn gru_gates(gx: &Tensor, gh: &Tensor, h: &Tensor) -> Result<Tensor> {
    gx.contiguous()?.apply_op3(&gh.contiguous()?, &h.contiguous()?, GruGates)
}

#[cfg(test)]
mod tests {
    use candle_core::{Device, Var};
    use candle_nn::ops::sigmoid as nn_sigmoid;

    use super::*;

    /// The gates composed from candle's own operations.
    fn composed(gx: &Tensor, gh: &Tensor, h: &Tensor) -> Tensor {
        let hd = h.dim(1).unwrap();
        let part = |t: &Tensor, i: usize| t.narrow(1, i * hd, hd).unwrap();
        let r = nn_sigmoid(&(part(gx, 0) + part(gh, 0)).unwrap()).unwrap();
        let z = nn_sigmoid(&(part(gx, 1) + part(gh, 1)).unwrap()).unwrap();
        let n = (part(gx, 2) + (r * part(gh, 2)).unwrap()).unwrap().tanh().unwrap();
        (&n + (z * (h - &n).unwrap()).unwrap()).unwrap()
    }

    #[test]
    fn the_fused_gates_match_the_composed_ones_in_value_and_gradient() {
        let dev = Device::Cpu;
        let filled = |r: usize, c: usize, s: f32| {
            Tensor::from_vec((0..r * c).map(|i| 2.0 * (i as f32 * 0.61 + s).sin()).collect::<Vec<f32>>(), (r, c), &dev)
                .unwrap()
        };
        let (gx, gh, h) = (
            Var::from_tensor(&filled(5, 12, 0.1)).unwrap(),
            Var::from_tensor(&filled(5, 12, 0.9)).unwrap(),
            Var::from_tensor(&filled(5, 4, 1.7)).unwrap(),
        );
        let weights = filled(5, 4, 2.3);
        let fused = gru_gates(&gx, &gh, &h).unwrap();
        let reference = composed(&gx, &gh, &h);
        let flat = |t: &Tensor| t.flatten_all().unwrap().to_vec1::<f32>().unwrap();
        for (a, b) in flat(&fused).iter().zip(flat(&reference)) {
            assert!((a - b).abs() < 1e-6);
        }
        let g1 = (fused * &weights).unwrap().sum_all().unwrap().backward().unwrap();
        let g2 = (reference * &weights).unwrap().sum_all().unwrap().backward().unwrap();
        for v in [&gx, &gh, &h] {
            for (a, b) in flat(g1.get(v).unwrap()).iter().zip(flat(g2.get(v).unwrap())) {
                assert!((a - b).abs() < 1e-5, "{a} vs {b}");
            }
        }
    }

    #[test]
    fn the_fast_exp_matches_libm() {
        for i in -2000..=2000 {
            let x = i as f32 * 0.04;
            let (a, b) = (exp(x), x.exp());
            assert!((a - b).abs() <= 4e-7 * b, "{x}: {a} vs {b}");
            assert!((tanh(x) - x.tanh()).abs() < 3e-7, "{x}");
        }
        assert_eq!(tanh(0.0), 0.0);
        // Far outside the range above: no NaN, no negative, no overflow to infinity.
        assert!((0.0..1e-30).contains(&exp(-200.0)), "{}", exp(-200.0));
        assert!(exp(200.0).is_finite() && exp(200.0) > 1e30, "{}", exp(200.0));
    }
}
