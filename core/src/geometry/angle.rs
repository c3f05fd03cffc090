//! Angle wrapping.

use core::f32::consts::{PI, TAU};

/// Wraps an angle to (-pi, pi]. Non-finite input is returned unchanged (it stays visible as NaN
/// or infinity downstream instead of being hidden).
#[must_use]
pub fn wrap_angle(a: f32) -> f32 {
    // Angles and differences of wrapped angles lie within two turns: one exact subtraction
    // (Sterbenz: TAU / 2 <= |a| <= 2 TAU) gives remainderf's result there without its software
    // division, which had been most of the predictor's feature cost on the MCU.
    // A whole turn exactly (w = 0 from a != 0) goes the long way: the remainder keeps a's sign
    // on a zero result.
    let w = if a > PI && a <= 2.0 * TAU {
        a - TAU
    } else if (-2.0 * TAU..=-PI).contains(&a) {
        a + TAU
    } else {
        a
    };
    if w > -PI && w <= PI && (w != 0.0 || a == 0.0) { w } else { wrap_by_remainder(a) }
}

/// [`wrap_angle`] for any angle, by the IEEE remainder.
fn wrap_by_remainder(a: f32) -> f32 {
    if !a.is_finite() {
        return a;
    }
    let mut w = libm::remainderf(a, TAU);
    if w <= -PI {
        w += TAU;
    } else if w > PI {
        w -= TAU;
    }
    w
}

/// The signed smallest difference `a - b`, wrapped to (-pi, pi].
#[must_use]
pub fn angle_diff(a: f32, b: f32) -> f32 {
    wrap_angle(a - b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wraps_into_half_open_interval() {
        for k in -50..50 {
            let a = k as f32 * 0.37;
            let w = wrap_angle(a);
            assert!(w > -PI - 1e-6 && w <= PI + 1e-6, "{a} -> {w}");
            assert!((libm::sinf(w) - libm::sinf(a)).abs() < 1e-4, "{a} -> {w}: same sine");
            assert!((libm::cosf(w) - libm::cosf(a)).abs() < 1e-4, "{a} -> {w}: same cosine");
        }
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-5);
        assert!((angle_diff(PI - 0.1, -PI + 0.1) + 0.2).abs() < 1e-5);
        assert!(wrap_angle(f32::NAN).is_nan());
    }

    #[test]
    fn the_short_path_has_the_bits_of_the_remainder() {
        let check = |a: f32| {
            let (fast, general) = (wrap_angle(a), wrap_by_remainder(a));
            assert!(
                fast.to_bits() == general.to_bits() || (fast.is_nan() && general.is_nan()),
                "{a}: {fast} vs {general}"
            );
        };
        for edge in [0.0, PI, TAU, 1.5 * TAU, 2.0 * TAU, 3.0 * TAU, 100.0] {
            for sign in [1.0f32, -1.0] {
                let mut x = sign * edge;
                for _ in 0..40 {
                    x = x.next_down();
                }
                for _ in 0..80 {
                    check(x);
                    x = x.next_up();
                }
            }
        }
        let mut seed = 1u32;
        for _ in 0..200_000 {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            check((seed >> 8) as f32 / (1u32 << 24) as f32 * 30.0 - 15.0);
        }
        for a in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MAX, -f32::MAX, f32::MIN_POSITIVE, -0.0] {
            check(a);
        }
    }
}
