//! Where the data is and how to read it: the KITTI folder or the drives, the frame rate, the
//! classes and the moving threshold, and the drives loaded for the sources a command needs.

use std::path::{Path, PathBuf};

use clap::Args;
use dynotraj_core::limits::PAPER_FRAME_RATE_HZ;
use dynotraj_core::wire::ObjectClass;

use super::estimated_args::EstimatedSourceArgs;
use super::progress::LoadBar;
use dynotraj_eval::loading::{DataRequest, DriveSet};
use dynotraj_sources::estimation::settings::EstimateSettings;
use dynotraj_sources::estimation::simulated::EvalOptions;
use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::{EligibilityRule, MovingRule, Source};

/// `--classes`' default: the classes forecast ([`ObjectClass::FORECAST`]; a test holds the two
/// together).
pub const FORECAST_CLASSES: &str = "Car,Van,Truck,Tram,Cyclist,Pedestrian";

/// `--rate`: the frame rate of a sequence's frames.
#[derive(Debug, Clone, Copy, Args)]
pub struct FrameRateArg {
    /// Frame rate in Hz for timestamps, speeds and the dynamics. The paper treats KITTI as 20 Hz
    /// (its cameras really run at 10 Hz); horizons stay 30 frames either way, and RPE does not
    /// depend on it.
    #[arg(
        long = "rate",
        value_parser = crate::numbers::frame_rate_f32,
        default_value_t = PAPER_FRAME_RATE_HZ,
        value_name = "HZ",
    )]
    pub hz: f32,
}

impl FrameRateArg {
    /// The frame period, seconds.
    #[must_use]
    pub fn period(&self) -> f32 {
        1.0 / self.hz
    }
}

/// `--min-step`: the threshold of a moving object.
#[derive(Debug, Clone, Copy, Args)]
pub struct MinStepArg {
    /// An object counts as moving when it moves at least this many metres per frame on average
    /// (0.1 m/frame = 1 m/s at KITTI's real 10 Hz; parked cars drift 0.01-0.05). Only moving
    /// objects are eligible for forecasts, and only moving objects are scored by RPE.
    #[arg(
        long = "min-step",
        value_parser = crate::numbers::non_negative_single,
        default_value_t = 0.1,
        value_name = "METRES"
    )]
    pub metres: f64,
}

impl MinStepArg {
    /// The threshold in single precision, as the eligibility rule holds it (within it: the
    /// parser refused anything beyond).
    #[must_use]
    #[allow(clippy::cast_possible_truncation)]
    pub fn single(&self) -> f32 {
        self.metres as f32
    }
}

/// `--classes`: the objects forecast and scored, and those a simulator places in its scenes.
#[derive(Debug, Clone, Args)]
pub struct ClassesArg {
    /// Object classes (KITTI type names, comma-separated): those forecast and scored, each by
    /// the models of its agent type (pedestrians: the single integrator; every other class:
    /// the unicycle), and those a simulator places in its scenes.
    #[arg(
        long = "classes",
        value_delimiter = ',',
        value_parser = crate::numbers::object_class,
        default_value = FORECAST_CLASSES,
        value_name = "LIST"
    )]
    pub list: Vec<ObjectClass>,
}

/// Where the data is and how to read it.
#[derive(Debug, Args)]
pub struct DataArgs {
    /// A KITTI tracking split folder holding label_02/, calib/ and ego poses (oxts/,
    /// ego_poses_orbslam3/ or poses/), e.g. ../shared/kitti/tracking/training (default:
    /// $DYNOTRAJ_KITTI, unless --drives is given).
    #[arg(long, value_name = "DIR")]
    pub kitti: Option<PathBuf>,
    /// Instead of --kitti, the drives of several places: a manifest file (a KITTI-layout
    /// folder, optionally followed by sequence ids, or a ROS 2 bag, one per line; relative
    /// paths from the manifest's folder) or a folder of layout folders and bags. A drive is
    /// named by its sequence id or its bag's file name (--sequences chooses by that name);
    /// sequences without ego poses and bags have no labels and feed the estimated sources
    /// only; bags are imported into --estimate-cache. `dynotraj drives PATH` lists them.
    #[arg(long, value_name = "PATH", conflicts_with = "kitti")]
    pub drives: Option<PathBuf>,
    /// The frame rate.
    #[command(flatten)]
    pub rate: FrameRateArg,
    /// The classes.
    #[command(flatten)]
    pub classes: ClassesArg,
    /// The moving threshold.
    #[command(flatten)]
    pub min_step: MinStepArg,
    /// The estimated source's input, its cache and the jobs.
    #[command(flatten)]
    pub ours: EstimatedSourceArgs,
}

/// The one sequence of a command that works on one stream: `given` must hold exactly one id.
///
/// # Errors
/// None or several ids, named.
pub fn one_sequence(given: &[String]) -> anyhow::Result<&str> {
    match given {
        [one] => Ok(one),
        [] => anyhow::bail!("--sequences: expected the id of the sequence to send, e.g. --sequences 0000"),
        more => anyhow::bail!("--sequences: this command sends one stream; expected one id, found {}", more.join(",")),
    }
}

/// The KITTI tracking folder: `given`, else `$DYNOTRAJ_KITTI`. For the commands where the
/// folder is one of several inputs, so that clap's conflict rules see only what was typed.
#[must_use]
pub fn kitti_or_env(given: Option<&Path>) -> Option<PathBuf> {
    given.map(Path::to_path_buf).or_else(|| std::env::var_os(KITTI_ENV).map(PathBuf::from))
}

/// The environment variable naming the KITTI tracking folder.
pub const KITTI_ENV: &str = "DYNOTRAJ_KITTI";

impl DataArgs {
    /// The frame period, seconds.
    ///
    /// # Errors
    /// When the rate is not a positive finite number.
    pub fn dt(&self) -> anyhow::Result<f32> {
        anyhow::ensure!(
            self.rate.hz.is_finite() && self.rate.hz > 0.0,
            "--rate: expected a positive frame rate in Hz, found {}",
            self.rate.hz
        );
        Ok(self.rate.period())
    }

    /// The eligibility rule from the options.
    ///
    /// # Errors
    /// A negative `--min-step`.
    pub fn rule(&self) -> anyhow::Result<EligibilityRule> {
        let classes = self.classes.list.clone();
        let min_step_m = self.min_step.single();
        anyhow::ensure!(min_step_m >= 0.0, "--min-step: expected metres >= 0, found {min_step_m}");
        Ok(EligibilityRule { classes, moving: MovingRule { min_step_m }, ..EligibilityRule::default() })
    }

    /// Where the drives are, how to read them and how the estimated sources are made.
    ///
    /// # Errors
    /// A bad rate or threshold, or neither --kitti, --drives nor `$DYNOTRAJ_KITTI`, named.
    pub fn request(&self) -> anyhow::Result<DataRequest> {
        let drives = if let Some(path) = &self.drives {
            DriveSet::Manifest(path.clone())
        } else if let Some(kitti) = kitti_or_env(self.kitti.as_deref()) {
            DriveSet::Kitti(kitti)
        } else {
            anyhow::bail!(
                "--kitti or --drives: expected where the drives are (a KITTI tracking folder, also read from \
                 ${KITTI_ENV}, or a drive manifest)"
            )
        };
        let dt = self.dt()?;
        let estimate = EstimateSettings {
            input: self.ours.ours_input,
            render_scale: self.ours.render_scale,
            cache: self.ours.estimate_cache.clone(),
            ..EstimateSettings::tracks(EvalOptions {
                object_variants: self.ours.object_variants(),
                render_optics: self.ours.render_optics.optics(),
                point_depth: self.ours.point_depth_options(),
                ..EvalOptions::kitti(dt)
            })
        };
        Ok(DataRequest { drives, dt, rule: self.rule()?, estimate, jobs: self.ours.jobs })
    }

    /// Loads `sequences` (all present when empty) for `sources` with a progress bar, keeping
    /// estimated tracks in `--estimate-cache` ([`DataRequest::load`]).
    ///
    /// # Errors
    /// A missing folder, a missing sequence or a bad file, named.
    pub fn load_for(&self, sequences: &[String], sources: &[Source]) -> anyhow::Result<Vec<SequenceTracks>> {
        let request = self.request()?;
        request.load(sequences, sources, request.estimate.cache.clone(), &LoadBar::default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_class_flags_are_the_core_lists() {
        let parse = |list: &str| -> Vec<ObjectClass> {
            list.split(',').map(|c| crate::numbers::object_class(c).unwrap()).collect()
        };
        assert_eq!(parse(FORECAST_CLASSES), ObjectClass::FORECAST);
        let err = crate::numbers::object_class("car").unwrap_err();
        assert!(err.contains("expected a KITTI type (Car, Van,") && err.contains("found `car`"), "{err}");
    }
}
