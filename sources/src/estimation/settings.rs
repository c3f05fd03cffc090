//! How the Estimated source is made for a sequence: the estimator's options and where its
//! feature tracks come from.

use crate::estimation::simulated::EvalOptions;

/// Where the Estimated source takes its feature tracks for a sequence without real images.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SimulatedInput {
    /// The track-level simulator: tracks of points on the labelled boxes and the static scene
    /// with pixel and depth noise and outliers (seconds for the nine sequences).
    Tracks,
    /// The image simulator renders each sequence and the OpenCV front-end tracks the images
    /// (minutes: rendering, SGBM stereo and KLT at the render scale). The default: Ours is
    /// images -> front-end -> estimator.
    #[default]
    Rendered,
}

impl SimulatedInput {
    /// Every input with its name on the command line and what it is.
    pub const CHOICES: [(Self, &'static str, &'static str); 2] = [
        (
            Self::Tracks,
            "tracks",
            "The track-level simulator: tracks of points on the labelled boxes and the static scene with pixel and \
             depth noise and outliers (seconds for the nine sequences)",
        ),
        (
            Self::Rendered,
            "rendered",
            "The image simulator renders each sequence and the OpenCV front-end tracks the images (minutes: \
             rendering, SGBM stereo and KLT at the render scale). The default: Ours is images -> front-end -> \
             estimator",
        ),
    ];
}

/// How the Estimated source is made for sequences without real images.
#[derive(Debug, Clone, PartialEq)]
pub struct EstimateSettings {
    /// The estimator's (and the track-level simulator's) options.
    pub options: EvalOptions,
    /// Simulated tracks or a rendering.
    pub input: SimulatedInput,
    /// Render scale for [`SimulatedInput::Rendered`] (1: KITTI's 1242 x 375).
    pub render_scale: f64,
    /// A folder where estimated tracks are kept between runs ([`super::cache`]).
    pub cache: Option<std::path::PathBuf>,
}

impl EstimateSettings {
    /// The track-level simulator with `options`.
    #[must_use]
    pub fn tracks(options: EvalOptions) -> Self {
        Self { options, input: SimulatedInput::Tracks, render_scale: 1.0, cache: None }
    }
}
