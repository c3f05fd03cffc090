//! Bootstrap intervals of the ratio of two predictors' errors on the same forecasts.
//!
//! Consecutive forecasts of one object run are nearly the same forecast, so instances are not
//! independent draws: resampling them would give intervals far too narrow. The unit of the
//! resampling is the whole object run (every sequence's runs pooled): a draw takes as many runs
//! as there are, with replacement, and computes the ratio of the two predictors' weighted
//! (per-forecast) means over the drawn runs. The interval is the 2.5th and 97.5th percentile of
//! [`DRAWS`] draws, from a seeded generator whose stream is portable (PCG), so a report is the
//! same on every machine.

use dynotraj_core::metrics::{ForecastScores, Mean};
use rand::{Rng as _, SeedableRng as _};
use rand_pcg::Pcg64Mcg;

/// Bootstrap draws per interval.
pub const DRAWS: usize = 2000;
/// Seed of every interval's generator.
pub const SEED: u64 = 20_261_203;

/// Which mean of [`ForecastScores`] a ratio compares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Metric {
    /// Average displacement error.
    Ade,
    /// Final displacement error.
    Fde,
}

impl Metric {
    fn of(self, s: &ForecastScores) -> &Mean {
        match self {
            Self::Ade => &s.ade,
            Self::Fde => &s.fde,
        }
    }
}

/// A ratio with its 95 % interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RatioInterval {
    /// The ratio over every run.
    pub ratio: f64,
    /// 2.5th percentile of the bootstrap ratios.
    pub low: f64,
    /// 97.5th percentile of the bootstrap ratios.
    pub high: f64,
}

/// Weighted mean of `metric` over the runs picked (by index, with multiplicity).
fn pooled(runs: &[ForecastScores], picks: &[usize], metric: Metric) -> Option<f64> {
    let mut total = Mean::new();
    for &i in picks {
        total.merge(metric.of(runs.get(i)?));
    }
    total.value()
}

/// The ratio of `num`'s to `den`'s weighted mean `metric`, with its run-bootstrap interval.
/// `num` and `den` hold the same runs in the same order (two predictors' rows of one source).
/// `None` when they differ in length, are empty or a mean is zero or missing.
#[must_use]
pub fn ratio_interval(num: &[ForecastScores], den: &[ForecastScores], metric: Metric) -> Option<RatioInterval> {
    if num.len() != den.len() || num.is_empty() {
        return None;
    }
    let all: Vec<usize> = (0..num.len()).collect();
    let ratio = |picks: &[usize]| {
        let (a, b) = (pooled(num, picks, metric)?, pooled(den, picks, metric)?);
        (b > 0.0).then(|| a / b)
    };
    let whole = ratio(&all)?;
    let mut rng = Pcg64Mcg::seed_from_u64(SEED);
    let mut picks = vec![0usize; num.len()];
    let mut draws: Vec<f64> = Vec::with_capacity(DRAWS);
    for _ in 0..DRAWS {
        for p in &mut picks {
            *p = rng.random_range(0..num.len());
        }
        if let Some(r) = ratio(&picks) {
            draws.push(r);
        }
    }
    draws.sort_by(f64::total_cmp);
    let at = |q: f64| draws.get(((draws.len().saturating_sub(1)) as f64 * q).round() as usize).copied();
    Some(RatioInterval { ratio: whole, low: at(0.025)?, high: at(0.975)? })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(ade: &[f32]) -> ForecastScores {
        let mut s = ForecastScores::default();
        for &a in ade {
            s.ade.push(a);
            s.fde.push(2.0 * a);
        }
        s
    }

    #[test]
    fn a_uniform_gain_has_a_tight_interval_and_a_mixed_one_a_wide_one() {
        let den: Vec<ForecastScores> = (0..40).map(|i| run(&[1.0 + 0.1 * i as f32; 5])).collect();
        let num: Vec<ForecastScores> = (0..40).map(|i| run(&[0.9 * (1.0 + 0.1 * i as f32); 5])).collect();
        let r = ratio_interval(&num, &den, Metric::Ade).unwrap();
        assert!((r.ratio - 0.9).abs() < 1e-6 && (r.high - r.low) < 1e-6, "{r:?}");
        // Half the runs much better, half much worse: the same mean ratio is uncertain.
        let mixed: Vec<ForecastScores> = (0..40)
            .map(|i| {
                let base = 1.0 + 0.1 * i as f32;
                run(&[if i % 2 == 0 { 0.4 * base } else { 1.4 * base }; 5])
            })
            .collect();
        let m = ratio_interval(&mixed, &den, Metric::Fde).unwrap();
        assert!(m.low < m.ratio && m.ratio < m.high && m.high - m.low > 0.2, "{m:?}");
        assert_eq!(ratio_interval(&mixed, &den, Metric::Fde), Some(m), "seeded: the same interval every time");
        assert!(ratio_interval(&num[..3], &den, Metric::Ade).is_none());
        assert!(ratio_interval(&[], &[], Metric::Ade).is_none());
    }
}
