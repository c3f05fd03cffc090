//! sin and cos in single precision only.
//!
//! `libm::sinf` and `libm::cosf` evaluate their polynomials in f64, which a Cortex-M4F (an f32
//! FPU) runs in software: measured under QEMU, those double operations were about a tenth of
//! the firmware's instructions. Here the argument is reduced to [-pi/4, pi/4] around the nearest
//! multiple of pi/2 (pi/2 split in three parts, Cody and Waite, so the reduction is exact to f32
//! for |x| <= [`REDUCED_RANGE`]) and the Taylor series is summed to the x^13 / x^14 term, whose
//! remainder at pi/4 (below 1e-13) is far below f32 rounding. Beyond the range, and for
//! non-finite input, libm answers. The test holds both to libm within a few f32 ulps.

/// Largest |x| reduced here; libm takes over beyond it.
pub const REDUCED_RANGE: f32 = 8192.0;

// pi/2 = P1 + P2 + P3, P1 and P2 with few enough significant bits that k * P1 and k * P2 are
// exact for |k| < 2^13 (Cephes' DP1..DP3 scaled to pi/2).
// The literals are the exact binary values of the split, written out in full.
#[allow(clippy::excessive_precision)]
const P1: f32 = 1.570_312_5;
#[allow(clippy::excessive_precision)]
const P2: f32 = 4.837_512_969_970_703e-4;
#[allow(clippy::excessive_precision)]
const P3: f32 = 7.549_789_954_891_485e-8;

/// sin and cos of `x` on [-pi/4, pi/4], by their Taylor series (Horner form).
fn kernel(x: f32) -> (f32, f32) {
    let z = x * x;
    let s = x
        * (1.0
            + z * (-1.0 / 6.0
                + z * (1.0 / 120.0
                    + z * (-1.0 / 5040.0 + z * (1.0 / 362_880.0 + z * (-1.0 / 39_916_800.0 + z / 6_227_020_800.0))))));
    let c = 1.0
        + z * (-0.5
            + z * (1.0 / 24.0
                + z * (-1.0 / 720.0
                    + z * (1.0 / 40_320.0
                        + z * (-1.0 / 3_628_800.0 + z * (1.0 / 479_001_600.0 - z / 87_178_291_200.0))))));
    (s, c)
}

/// (sin x, cos x).
#[must_use]
pub fn sin_cos(x: f32) -> (f32, f32) {
    if !x.is_finite() || x.abs() > REDUCED_RANGE {
        return (libm::sinf(x), libm::cosf(x));
    }
    let k = x * core::f32::consts::FRAC_2_PI;
    // |k| <= 2^13: the rounding fits an i32 exactly.
    let q = (k + 0.5f32.copysign(k)) as i32;
    let qf = q as f32;
    let r = ((x - qf * P1) - qf * P2) - qf * P3;
    let (s, c) = kernel(r);
    match q & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sin_and_cos_match_libm_to_a_few_ulps_over_the_reduced_range() {
        let mut worst = 0.0f32;
        let mut x = -100.0f32;
        while x <= 100.0 {
            let (s, c) = sin_cos(x);
            worst = worst.max((s - libm::sinf(x)).abs()).max((c - libm::cosf(x)).abs());
            x += 0.000_731;
        }
        assert!(worst < 4e-7, "largest difference from libm {worst}");
        use core::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
        for x in [0.0f32, -0.0, 1e-30, 1e-6, FRAC_PI_4, FRAC_PI_2, PI, 4000.3, -8191.9] {
            let (s, c) = sin_cos(x);
            let tol = 4e-7 + x.abs() * 2e-8;
            assert!((s - libm::sinf(x)).abs() < tol && (c - libm::cosf(x)).abs() < tol, "{x}: {s} {c}");
        }
    }

    #[test]
    fn outside_the_range_and_non_finite_inputs_fall_back_to_libm() {
        for x in [1e6f32, -3e7, f32::INFINITY, f32::NAN] {
            let (s, c) = sin_cos(x);
            assert!(s.to_bits() == libm::sinf(x).to_bits() || (s.is_nan() && libm::sinf(x).is_nan()));
            assert!(c.to_bits() == libm::cosf(x).to_bits() || (c.is_nan() && libm::cosf(x).is_nan()));
        }
    }
}
