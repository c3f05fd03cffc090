//! Displacement metrics of one forecast (ADE, FDE) and of two consecutive forecasts (ACE).

use crate::geometry::Point2;

/// Average displacement error: the mean over the horizon of the L2 distance between predicted
/// and true positions. `None` when the slices are empty or differ in length.
#[must_use]
pub fn ade(pred: &[Point2], truth: &[Point2]) -> Option<f32> {
    let sum: f32 = step_errors(pred, truth)?.sum();
    Some(sum / pred.len() as f32)
}

/// The L2 distance between predicted and true positions at each step of the horizon, in order
/// (their mean is the ADE, the last the FDE). `None` when the slices are empty or differ in
/// length.
pub fn step_errors<'a>(pred: &'a [Point2], truth: &'a [Point2]) -> Option<impl Iterator<Item = f32> + 'a> {
    if pred.is_empty() || pred.len() != truth.len() {
        return None;
    }
    Some(pred.iter().zip(truth).map(|(p, t)| p.distance(t)))
}

/// Final displacement error: the L2 distance at the last step of the horizon. `None` when the
/// slices are empty or differ in length.
#[must_use]
pub fn fde(pred: &[Point2], truth: &[Point2]) -> Option<f32> {
    if pred.len() != truth.len() {
        return None;
    }
    Some(pred.last()?.distance(truth.last()?))
}

/// Absolute consistency error (the paper's ACE): the distance between the forecast made at s for
/// step T (its last point) and the forecast made at s+1 for step T-1 (its second to last point):
/// two forecasts of the same future instant s+T. `None` when a forecast has fewer than 2 points
/// or the two differ in length.
#[must_use]
pub fn ace(pred_s: &[Point2], pred_next: &[Point2]) -> Option<f32> {
    if pred_s.len() != pred_next.len() || pred_s.len() < 2 {
        return None;
    }
    let last = pred_s.last()?;
    let same_instant = pred_next.get(pred_next.len() - 2)?;
    Some(last.distance(same_instant))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(n: usize, off: f32) -> [Point2; 4] {
        core::array::from_fn(|i| Point2::new(i as f32 + off, n as f32))
    }

    #[test]
    fn ade_fde_on_a_known_offset() {
        let t = line(0, 0.0);
        let mut p = t;
        p[3].x += 4.0; // only the last point is off, by 4
        assert_eq!(ade(&p, &t), Some(1.0));
        assert_eq!(fde(&p, &t), Some(4.0));
        assert_eq!(ade(&p[..2], &t), None);
        assert_eq!(ade(&[], &[]), None);
    }

    #[test]
    fn ace_compares_the_same_future_instant() {
        // Forecast at s covers s+1..s+4 at x = 1..4; at s+1 it covers s+2..s+5 at x = 2..5
        // (shifted by one step): perfectly consistent.
        let at_s: [Point2; 4] = core::array::from_fn(|i| Point2::new(i as f32 + 1.0, 0.0));
        let at_next: [Point2; 4] = core::array::from_fn(|i| Point2::new(i as f32 + 2.0, 0.0));
        assert_eq!(ace(&at_s, &at_next), Some(0.0));
        let mut moved = at_next;
        moved[2].y = 3.0;
        assert_eq!(ace(&at_s, &moved), Some(3.0));
    }
}
