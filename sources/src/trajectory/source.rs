//! The paper's trajectory sources: GT (the labels), GT+EKF (the forward unicycle EKF over the
//! labels: causal), GT+RTS (a fixed-lag RTS smoother over them: has seen later frames), and
//! Estimated (Ours: the core estimator's own tracks, causal, and their smoothed variant).

use std::fmt;
use std::str::FromStr;

use dynotraj_core::BevState;
use dynotraj_core::gt_ekf::{EkfParams, FixedLagRts, Measurement, UnicycleEkf};

/// Look-ahead window of the GT+RTS source, frames (as DynoSAM's sliding window of 20).
pub const RTS_WINDOW: usize = 20;

/// Where the states of a run come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Source {
    /// The labels: positions and headings as annotated, finite-difference speed.
    Gt,
    /// The labels through the forward unicycle EKF: each state uses only frames up to its own
    /// (what an online vehicle knows).
    GtEkf,
    /// The labels through a fixed-lag RTS smoother: each state has seen up to
    /// `RTS_WINDOW - 1` later frames. Not causal; reported apart.
    GtRts,
    /// Ours: the estimator's newest-frame estimate at each frame (causal), from its own tracks
    /// ([`crate::estimation::tracks`]); no label enters a state.
    Estimated,
    /// Ours through the same forward unicycle EKF as `GtEkf` (causal): what a vehicle gets by
    /// filtering its own estimates before forecasting.
    EstimatedEkf,
    /// The estimator's states as they leave its smoothing window (each has seen up to `W - 1`
    /// later frames, as the paper's DynoSAM output). Not causal; reported apart.
    EstimatedSmoothed,
}

impl Source {
    /// Every source.
    pub const ALL: [Self; 6] =
        [Self::Gt, Self::GtEkf, Self::GtRts, Self::Estimated, Self::EstimatedEkf, Self::EstimatedSmoothed];

    /// The command-line name.
    #[must_use]
    pub const fn name(&self) -> &'static str {
        match self {
            Self::Gt => "gt",
            Self::GtEkf => "gt-ekf",
            Self::GtRts => "gt-rts",
            Self::Estimated => "estimated",
            Self::EstimatedEkf => "estimated-ekf",
            Self::EstimatedSmoothed => "estimated-smoothed",
        }
    }

    /// True when the states come from the estimator's tracks, not from the labels.
    #[must_use]
    pub const fn is_estimated(&self) -> bool {
        matches!(self, Self::Estimated | Self::EstimatedEkf | Self::EstimatedSmoothed)
    }

    /// True when each state depends only on frames up to its own.
    #[must_use]
    pub const fn is_causal(&self) -> bool {
        !matches!(self, Self::GtRts | Self::EstimatedSmoothed)
    }

    /// The states of this source for one run of consecutive frames of its base tracks
    /// (`labels`: the labels for the GT sources, the estimator's states for the estimated
    /// ones, which are already final), frame period `dt`. The output has one state per input
    /// frame.
    #[must_use]
    pub fn apply(&self, labels: &[BevState], dt: f32) -> Vec<BevState> {
        match self {
            Self::Gt | Self::Estimated | Self::EstimatedSmoothed => labels.to_vec(),
            Self::GtEkf | Self::EstimatedEkf => {
                let mut ekf = UnicycleEkf::new(EkfParams::vehicle(dt));
                measurements(labels, dt)
                    .map(|z| {
                        ekf.step(&z);
                        ekf.state().unwrap_or_default()
                    })
                    .collect()
            }
            Self::GtRts => {
                let mut rts = FixedLagRts::<RTS_WINDOW>::new(EkfParams::vehicle(dt));
                let mut out: Vec<BevState> = measurements(labels, dt).filter_map(|z| rts.push(&z)).collect();
                let done = out.len();
                out.resize(done + rts.len(), BevState::default());
                rts.smooth_into(|i, s| out[done + i] = s);
                out
            }
        }
    }
}

/// The EKF's measurements of a run: position and heading as labelled, speed as the backward
/// finite difference (none at the first frame: no earlier frame is known then).
fn measurements(labels: &[BevState], dt: f32) -> impl Iterator<Item = Measurement> + '_ {
    labels.iter().enumerate().map(move |(i, s)| Measurement {
        position: Some(s.position()),
        heading: Some(s.heading),
        speed: i.checked_sub(1).map(|j| labels[j].position().distance(&s.position()) / dt),
    })
}

impl fmt::Display for Source {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Source {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL.into_iter().find(|src| src.name() == s).ok_or_else(|| {
            let names: Vec<&str> = Self::ALL.iter().map(Self::name).collect();
            format!("unknown source `{s}`: expected one of {}", names.join(", "))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noisy_line(n: usize) -> Vec<BevState> {
        (0..n)
            .map(|k| {
                let wobble = if k % 2 == 0 { 0.3 } else { -0.3 };
                BevState { x: k as f32, y: wobble, heading: wobble * 0.3, speed: 10.0 + 5.0 * wobble }
            })
            .collect()
    }

    #[test]
    fn every_source_keeps_one_state_per_frame() {
        for src in Source::ALL {
            for n in [1, 5, RTS_WINDOW, RTS_WINDOW + 7] {
                let out = src.apply(&noisy_line(n), 0.1);
                assert_eq!(out.len(), n, "{src} {n}");
                assert!(out.iter().all(BevState::is_finite));
            }
        }
    }

    #[test]
    fn the_filter_is_causal_and_the_smoother_is_not() {
        let base = noisy_line(40);
        let mut changed = base.clone();
        changed[30].y += 5.0;
        for src in [Source::GtEkf, Source::GtRts, Source::EstimatedEkf] {
            let a = src.apply(&base, 0.1);
            let b = src.apply(&changed, 0.1);
            let early_equal = a[..30].iter().zip(&b[..30]).all(|(p, q)| p == q);
            assert_eq!(early_equal, src.is_causal(), "{src}");
        }
    }

    #[test]
    fn the_estimates_filtered_are_the_estimates_through_the_labels_filter() {
        let base = noisy_line(40);
        assert_eq!(Source::EstimatedEkf.apply(&base, 0.1), Source::GtEkf.apply(&base, 0.1));
        assert_ne!(Source::EstimatedEkf.apply(&base, 0.1), base);
        assert!(Source::EstimatedEkf.is_estimated() && Source::EstimatedEkf.is_causal());
        assert_eq!("estimated-ekf".parse::<Source>(), Ok(Source::EstimatedEkf));
        let e = "estimated-kf".parse::<Source>().unwrap_err();
        assert!(e.contains("estimated-ekf") && e.contains("gt-rts"), "{e}");
    }
}
