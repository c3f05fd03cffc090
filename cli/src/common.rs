//! Options and loading shared by the commands.

use dynotraj_sim::image_sim::Optics;
use dynotraj_sources::estimation::simulated::PointDepthOptions;
use std::path::{Path, PathBuf};

use clap::Args;
use dynotraj_core::limits::PAPER_FRAME_RATE_HZ;
use dynotraj_core::predict::Dynamics;
use dynotraj_core::wire::ObjectClass;

pub use super::progress::Progress;
use dynotraj_eval::jobs::{default_jobs, parse_jobs};
use dynotraj_eval::loading::load_drives;
use dynotraj_sources::drives::{Drive, distinct_ids, kitti_drives, manifest_drives, select_drives};
use dynotraj_sources::estimation::settings::{EstimateSettings, SimulatedInput};
use dynotraj_sources::estimation::simulated::{EvalOptions, ObjectVariants};
use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::{EligibilityRule, MovingRule, Source};

/// The paper's test sequences (Table IV).
pub const PAPER_TEST_SEQUENCES: [&str; 5] = ["0000", "0003", "0005", "0018", "0020"];

/// `Dims::DEFAULT` (the ECU setting) as the commands' `--dims` default; a test holds the two
/// together.
pub const DEFAULT_DIMS: &str = "8,8,3,8";

/// `--classes`' default: the classes forecast ([`ObjectClass::FORECAST`]; a test holds the two
/// together).
pub const FORECAST_CLASSES: &str = "Car,Van,Truck,Tram,Cyclist,Pedestrian";

/// `--dynamics` values: an agent type.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum DynamicsArg {
    /// Turn rate and acceleration: vehicles and cyclists.
    Unicycle,
    /// Velocity: pedestrians.
    SingleIntegrator,
}

impl From<DynamicsArg> for Dynamics {
    fn from(d: DynamicsArg) -> Self {
        match d {
            DynamicsArg::Unicycle => Self::Unicycle,
            DynamicsArg::SingleIntegrator => Self::SingleIntegrator,
        }
    }
}

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

/// Where a sent point's depth comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PointDepth {
    /// The dense matcher's disparity at the rounded pixel.
    Dense,
    /// Refined to sub-pixel at the point over its own instance (the default).
    Subpixel,
    /// No dense matcher where the masks need no depth (renderings, given masks): each point is
    /// matched along its row over the dense matcher's range, then refined to sub-pixel.
    RowMatch,
}

/// How the image front-end gives the points it sends their depth.
#[derive(Debug, Clone, Copy, Args)]
pub struct PointDepthArgs {
    /// Depth of each point the front-end sends: the dense matcher's disparity at the rounded
    /// pixel, or that value refined to sub-pixel over the point's own instance.
    #[arg(long, value_enum, default_value_t = PointDepth::Subpixel)]
    pub point_depth: PointDepth,
    /// Least distance of a newly sampled object point from its mask's edge, pixels.
    #[arg(long, default_value_t = PointDepthOptions::default().object_edge_margin_px, value_name = "PX")]
    pub object_edge_margin: i32,
    /// Dense stereo matching on images shrunk by this factor (1 or 2: about 4x less matching);
    /// each point's sub-pixel depth is still refined at full resolution.
    #[arg(long, default_value_t = PointDepthOptions::default().stereo_downscale, value_parser = clap::value_parser!(i32).range(1..=2), value_name = "N")]
    pub stereo_downscale: i32,
}

impl PointDepthArgs {
    /// The front-end's point-depth options these give.
    #[must_use]
    pub fn options(&self) -> PointDepthOptions {
        PointDepthOptions {
            subpixel: self.point_depth != PointDepth::Dense,
            object_edge_margin_px: self.object_edge_margin.max(0),
            stereo_downscale: self.stereo_downscale,
            row_match: self.point_depth == PointDepth::RowMatch,
        }
    }
}

/// The camera model of renderings, as a command-line value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RenderOptics {
    /// Pixel centres sampled: no blur, no vignetting, unit gain.
    Ideal,
    /// A camera's: pixel-area integration, lens blur, vignetting, a gain per exposure.
    Camera,
}

impl RenderOptics {
    /// The renderer's camera model.
    #[must_use]
    pub const fn optics(self) -> Optics {
        match self {
            Self::Ideal => Optics::IDEAL,
            Self::Camera => Optics::CAMERA,
        }
    }
}

/// Where the estimated source (Ours) takes its feature tracks, where renderings are kept, and
/// how many sequences are worked on at once: shared by every command that estimates.
#[derive(Debug, Args)]
pub struct EstimatedSourceArgs {
    /// Where the estimated sources take their feature tracks for sequences without real stereo
    /// images in the folder: rendered (the image simulator renders each sequence and the
    /// OpenCV front-end tracks it: images -> front-end -> estimator, as Ours is defined;
    /// about 19 minutes for the sixteen sequences at scale 1 on two cores; the front-end's
    /// tracks are kept in --estimate-cache and re-estimated in seconds) or tracks (the
    /// track-level simulator: tracks of points on the labelled boxes, seconds).
    #[arg(long, value_parser = crate::numbers::choices(&SimulatedInput::CHOICES), default_value = "rendered", value_name = "INPUT")]
    pub ours_input: SimulatedInput,
    /// Render scale with `--ours-input rendered` (1: KITTI's 1242 x 375; 0.5 renders and tracks
    /// about 2.5x faster but doubles the object estimates' error, docs/results.md).
    #[arg(long, value_parser = crate::numbers::positive, default_value_t = 1.0, value_name = "SCALE")]
    pub render_scale: f64,
    /// Camera model of renderings: ideal (each pixel samples its centre; the reports' renderings)
    /// or camera (pixel-area integration, lens blur, vignetting, a gain per exposure).
    #[arg(long, value_enum, default_value_t = RenderOptics::Ideal, value_name = "MODEL")]
    pub render_optics: RenderOptics,
    /// How the front-end gives points their depth on renderings.
    #[command(flatten)]
    pub point_depth: PointDepthArgs,
    /// A folder where the estimated sources' tracks (or, for renderings, the front-end's
    /// tracks) are kept between runs, keyed by every input (labels, poses, calibration, images,
    /// settings, estimator or renderer version): a rerun with the same inputs reads them back.
    /// `dynotraj experiment` uses its report's cache/ unless given.
    #[arg(long, value_name = "DIR")]
    pub estimate_cache: Option<PathBuf>,
    /// Sequences estimated (rendered, tracked) and folds trained at the same time (default:
    /// the number of cores). Results do not depend on it.
    #[arg(long, env = "DYNOTRAJ_JOBS", hide_env_values = true, default_value_t = default_jobs(), hide_default_value = true, value_parser = parse_jobs, value_name = "N")]
    pub jobs: usize,
    /// Estimator variant: fuse an object's points into its landmarks at the pose its fit found
    /// rather than at the smoother's (off by default; docs/decisions.md "Following the object").
    #[arg(long)]
    pub fuse_at_fit: bool,
    /// Turn a vehicle's frame onto its measured direction of travel whenever the two differ by
    /// more than this many degrees, or `off` to keep its first heading (default 90: only a frame
    /// pointing backwards is turned; docs/decisions.md "Reversed object frames").
    #[arg(long, value_parser = realign_degrees, default_value = "90", value_name = "DEG|off")]
    pub realign_heading: Realign,
    /// Estimator variant: a disparity error shared by all points of an object fit, pixels,
    /// which puts a floor under its depth uncertainty along the viewing ray (0: off, the
    /// default).
    #[arg(long, value_parser = crate::numbers::non_negative_f32, default_value_t = 0.0, value_name = "PX")]
    pub shared_disparity: f32,
    /// Estimator variant: causal estimates report the object's pose origin and its motion's
    /// speed instead of the bird's-eye track that fuses its points' centroid with its motion.
    #[arg(long)]
    pub no_bev_track: bool,
}

/// `--realign-heading`: a bound in degrees, or none (`off`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Realign(pub Option<f32>);

/// Parses `--realign-heading`: `off`, or a positive number of degrees.
///
/// # Errors
/// Anything else, with what was expected.
pub fn realign_degrees(text: &str) -> Result<Realign, String> {
    if text.eq_ignore_ascii_case("off") {
        return Ok(Realign(None));
    }
    crate::numbers::positive_f32(text).map(|d| Realign(Some(d))).map_err(|e| format!("{e}, or `off`"))
}

impl EstimatedSourceArgs {
    /// The estimator's object variants these options choose.
    #[must_use]
    pub fn object_variants(&self) -> ObjectVariants {
        ObjectVariants {
            fuse_at_fit: self.fuse_at_fit,
            heading_realign_rad: self.realign_heading.0.map(f32::to_radians),
            shared_disparity_px: self.shared_disparity,
            bev_track: !self.no_bev_track,
        }
    }
}

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

    /// Opens the folder and loads `sequences` (all present when empty), with a progress bar;
    /// when one of `sources` is an estimated one, also runs the estimator over each sequence
    /// (on its images, its rendering or the track-level simulator: `--ours-input`), keeping
    /// the tracks in `--estimate-cache` when given.
    ///
    /// # Errors
    /// A missing folder, a missing sequence or a bad file, named.
    pub fn load_for(&self, sequences: &[String], sources: &[Source]) -> anyhow::Result<Vec<SequenceTracks>> {
        self.load_cached(sequences, sources, self.ours.estimate_cache.clone())
    }

    /// As [`DataArgs::load_for`], keeping estimated tracks in `cache` between runs.
    ///
    /// # Errors
    /// A missing folder, a missing sequence or a bad file, named.
    pub fn load_cached(
        &self,
        sequences: &[String],
        sources: &[Source],
        cache: Option<std::path::PathBuf>,
    ) -> anyhow::Result<Vec<SequenceTracks>> {
        self.load_drives(&self.drives(sequences)?, sources, cache)
    }

    /// Loads `drives` for `sources`, as [`DataArgs::load_cached`] does the drives it names
    /// ([`dynotraj_eval::loading::load_drives`]), with a progress bar.
    ///
    /// # Errors
    /// A missing or bad file, named.
    pub fn load_drives(
        &self,
        drives: &[Drive],
        sources: &[Source],
        cache: Option<std::path::PathBuf>,
    ) -> anyhow::Result<Vec<SequenceTracks>> {
        let dt = self.dt()?;
        let estimate = EstimateSettings {
            input: self.ours.ours_input,
            render_scale: self.ours.render_scale,
            cache,
            ..EstimateSettings::tracks(EvalOptions {
                object_variants: self.ours.object_variants(),
                render_optics: self.ours.render_optics.optics(),
                point_depth: self.ours.point_depth.options(),
                ..EvalOptions::kitti(dt)
            })
        };
        let estimating = sources.iter().any(Source::is_estimated);
        let bar = progress(drives.len() as u64, if estimating { "loading and estimating" } else { "loading" });
        let out = load_drives(drives, sources, dt, &estimate, self.ours.jobs, &|name, ok| {
            bar.set_message(format!("sequence {name} {}", if ok { "loaded" } else { "failed" }));
            bar.inc(1);
        });
        bar.finish_and_clear();
        out
    }

    /// The drives `sequences` names (all when empty) of --kitti or --drives.
    ///
    /// # Errors
    /// A folder or manifest that cannot be read, a name given twice or that no drive has.
    pub fn drives(&self, sequences: &[String]) -> anyhow::Result<Vec<Drive>> {
        if let Some(path) = &self.drives {
            let names = distinct_ids("--sequences", sequences.to_vec())?;
            return select_drives(manifest_drives(path)?, &names);
        }
        let Some(kitti) = kitti_or_env(self.kitti.as_deref()) else {
            anyhow::bail!(
                "--kitti or --drives: expected where the drives are (a KITTI tracking folder, also read from \
                 ${KITTI_ENV}, or a drive manifest)"
            )
        };
        kitti_drives(&kitti, sequences)
    }
}

/// Progress on stderr: a bar on a terminal, paced lines with the elapsed time elsewhere.
#[must_use]
pub fn progress(len: u64, what: &str) -> Progress {
    Progress::new(len, what)
}

#[cfg(test)]
mod tests {
    #[test]
    fn realign_heading_takes_degrees_or_off() {
        assert_eq!(realign_degrees("90"), Ok(Realign(Some(90.0))));
        assert_eq!(realign_degrees("OFF"), Ok(Realign(None)));
        for bad in ["0", "-5", "sideways", ""] {
            let e = realign_degrees(bad).unwrap_err();
            assert!(e.contains("`off`"), "{bad}: {e}");
        }
    }

    use super::*;
    use dynotraj_core::model::arch::Dims;

    #[test]
    fn the_default_dims_flag_is_the_core_default() {
        assert_eq!(super::super::model_cost::parse_dims(DEFAULT_DIMS).unwrap(), Dims::DEFAULT);
    }

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
