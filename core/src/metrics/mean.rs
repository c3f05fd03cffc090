//! Running means of forecast scores.

/// A running mean with its count.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Mean {
    sum: f64,
    count: u32,
}

impl Mean {
    /// An empty mean.
    #[must_use]
    pub const fn new() -> Self {
        Self { sum: 0.0, count: 0 }
    }

    /// Adds one value; non-finite values are refused (returns false) so they stay visible.
    pub fn push(&mut self, v: f32) -> bool {
        if !v.is_finite() {
            return false;
        }
        self.sum += f64::from(v);
        self.count = self.count.saturating_add(1);
        true
    }

    /// Merges another mean (weighted by its count).
    pub fn merge(&mut self, other: &Self) {
        self.sum += other.sum;
        self.count = self.count.saturating_add(other.count);
    }

    /// The sum of the values pushed.
    #[must_use]
    pub const fn sum(&self) -> f64 {
        self.sum
    }

    /// Values pushed.
    #[must_use]
    pub const fn count(&self) -> u32 {
        self.count
    }

    /// The mean, or `None` when empty.
    #[must_use]
    pub fn value(&self) -> Option<f64> {
        (self.count > 0).then(|| self.sum / f64::from(self.count))
    }
}

/// ADE, FDE and ACE means of a set of forecasts. Merging two sets gives the weighted average
/// per forecast that the paper reports.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ForecastScores {
    /// ADE over forecasts.
    pub ade: Mean,
    /// FDE over forecasts.
    pub fde: Mean,
    /// ACE over pairs of consecutive forecasts.
    pub ace: Mean,
}

impl ForecastScores {
    /// Merges another set.
    pub fn merge(&mut self, other: &Self) {
        self.ade.merge(&other.ade);
        self.fde.merge(&other.fde);
        self.ace.merge(&other.ace);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merge_is_weighted_by_count() {
        let mut a = Mean::new();
        a.push(1.0);
        let mut b = Mean::new();
        b.push(4.0);
        b.push(4.0);
        b.push(4.0);
        a.merge(&b);
        assert_eq!(a.count(), 4);
        assert_eq!(a.value(), Some(3.25));
        assert!(!a.push(f32::NAN));
        assert_eq!(Mean::new().value(), None);
    }
}
