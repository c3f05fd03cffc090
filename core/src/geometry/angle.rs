//! Angle wrapping.

use core::f32::consts::{PI, TAU};

/// Wraps an angle to (-pi, pi]. Non-finite input is returned unchanged (it stays visible as NaN
/// or infinity downstream instead of being hidden).
#[must_use]
pub fn wrap_angle(a: f32) -> f32 {
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
            assert!(libm::sinf(w) - libm::sinf(a) < 1e-4);
            assert!(libm::cosf(w) - libm::cosf(a) < 1e-4);
        }
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-5);
        assert!((angle_diff(PI - 0.1, -PI + 0.1) + 0.2).abs() < 1e-5);
        assert!(wrap_angle(f32::NAN).is_nan());
    }
}
