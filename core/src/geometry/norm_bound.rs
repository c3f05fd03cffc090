//! `sqrt(x) <= limit` decided as `x <= t`: the MCU computes square roots in software (about 80
//! instructions each), and a gate on a norm needs only the comparison, not the norm.

/// Most single-ulp moves [`NormBound::new`] makes from `limit * limit` to the exact threshold;
/// a correctly rounded product and square root need at most two or three.
const MAX_ADJUST_STEPS: usize = 8;

/// A limit on a norm, as the largest squared norm whose square root is still within it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NormBound {
    max_squared: f32,
}

impl NormBound {
    /// The bound `sqrt(x) <= limit`: `t` is the largest float with `sqrtf(t) <= limit`, found from
    /// `limit * limit` by moving one ulp at a time (square root is monotone, so the floats it
    /// admits are exactly `[0, t]`). A NaN or negative limit admits nothing.
    #[must_use]
    pub fn new(limit: f32) -> Self {
        if limit.is_nan() || limit < 0.0 {
            return Self { max_squared: f32::NEG_INFINITY };
        }
        let mut t = limit * limit;
        for _ in 0..MAX_ADJUST_STEPS {
            if libm::sqrtf(t) > limit {
                t = t.next_down();
            } else if t < f32::INFINITY && libm::sqrtf(t.next_up()) <= limit {
                t = t.next_up();
            } else {
                break;
            }
        }
        Self { max_squared: t }
    }

    /// `sqrtf(squared) <= limit` for a squared norm (`squared >= 0` or NaN), without the root.
    #[must_use]
    pub fn admits(&self, squared: f32) -> bool {
        squared <= self.max_squared
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn agrees_with_the_square_root_around_every_threshold() {
        let limits = [0.0, 1e-30, 0.3, 1.0, 2.5, 3.0, 7.77, 1e3, 123_456.79, 1e19, 3e19, f32::MAX, f32::INFINITY];
        for limit in limits {
            let b = NormBound::new(limit);
            let t = (limit * limit).min(f32::MAX);
            let mut x = t;
            for _ in 0..64 {
                x = x.next_down();
            }
            for _ in 0..129 {
                // Squared norms are never negative (the walk below a zero limit goes there).
                if x >= 0.0 {
                    assert_eq!(b.admits(x), libm::sqrtf(x) <= limit, "limit {limit}, x {x}");
                }
                x = x.next_up();
            }
            for x in [0.0, f32::MIN_POSITIVE, 1.0, f32::MAX, f32::INFINITY, f32::NAN] {
                assert_eq!(b.admits(x), libm::sqrtf(x) <= limit, "limit {limit}, x {x}");
            }
        }
    }

    #[test]
    fn a_nan_or_negative_limit_admits_nothing() {
        for limit in [f32::NAN, -1.0, f32::NEG_INFINITY] {
            let b = NormBound::new(limit);
            for x in [0.0, 1.0, f32::INFINITY, f32::NAN] {
                assert!(!b.admits(x), "limit {limit}, x {x}");
            }
        }
    }
}
