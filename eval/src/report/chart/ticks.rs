//! Tick labels with as many decimals as the tick step needs: a whole step prints integers
//! ("20", not "20.0"), a step of 0.5 one decimal, a step of 0.05 two.

use plotters::coord::ranged1d::Ranged as _;
use plotters::coord::types::RangedCoordf64;

/// Labels per axis: the most ticks plotters may put on one.
pub const LABELS: usize = 10;

/// The decimals that print every multiple of `step` exactly (at most 6).
#[must_use]
pub fn decimals_of_step(step: f64) -> usize {
    if !(step.is_finite() && step > 0.0) {
        return 0;
    }
    (0..=6)
        .find(|&d| {
            let scaled = step * 10f64.powi(d as i32);
            (scaled - scaled.round()).abs() <= 1e-6 * scaled.max(1.0)
        })
        .unwrap_or(6)
}

/// The decimals of the ticks plotters puts on an axis over `range` with at most `labels` of
/// them (the same key points the mesh draws).
#[must_use]
pub fn decimals_for(range: (f64, f64), labels: usize) -> usize {
    let points = RangedCoordf64::from(range.0..range.1).key_points(labels);
    let step = points.windows(2).map(|w| w[1] - w[0]).fold(f64::INFINITY, f64::min);
    decimals_of_step(step)
}

/// `value` with `decimals` decimals, without a minus sign on zero.
#[must_use]
pub fn format_tick(value: f64, decimals: usize) -> String {
    let text = format!("{value:.decimals$}");
    match text.strip_prefix('-') {
        Some(rest) if rest.chars().all(|c| c == '0' || c == '.') => rest.to_string(),
        _ => text,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_steps_print_integers_and_others_the_decimals_they_need() {
        assert_eq!(decimals_of_step(20.0), 0);
        assert_eq!(decimals_of_step(1.0), 0);
        assert_eq!(decimals_of_step(0.5), 1);
        assert_eq!(decimals_of_step(0.1 + 0.2), 1, "float noise is not a decimal");
        assert_eq!(decimals_of_step(0.25), 2);
        assert_eq!(decimals_of_step(0.05), 2);
        assert_eq!(format_tick(20.0, 0), "20");
        assert_eq!(format_tick(-0.0001, 1), "0.0");
        assert_eq!(format_tick(-1.5, 1), "-1.5");
        // Frames 0..154 at 20 Hz: 0..7.7 s, ticks a whole second apart.
        assert_eq!(decimals_for((0.0, 7.7), LABELS), 0);
        // A 30-step horizon at 20 Hz: 0.05..1.5 s.
        assert!(decimals_for((0.05, 1.5), LABELS) >= 1);
    }
}
