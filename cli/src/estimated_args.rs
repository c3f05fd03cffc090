//! The arguments of the estimated source (Ours): where its tracks come from (renderings or the
//! track-level simulator), how the front-end gives points their depth, the estimator's object
//! variants, the cache and the jobs.

use std::path::PathBuf;

use clap::Args;
use dynotraj_eval::jobs::{default_jobs, parse_jobs};
use dynotraj_sim::image_sim::{Optics, RenderedMasks};
use dynotraj_sources::estimation::settings::SimulatedInput;
use dynotraj_sources::estimation::simulated::{ObjectVariants, PointDepthOptions};

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
            ..PointDepthOptions::default()
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
    /// Where the front-end takes a rendering's object masks from (--ours-input rendered).
    #[arg(long, value_parser = crate::numbers::choices(&RenderedMasks::CHOICES), default_value = "ids", value_name = "MASKS")]
    pub ours_masks: RenderedMasks,
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
    /// The front-end's options for renderings: point depth and masks.
    #[must_use]
    pub fn point_depth_options(&self) -> PointDepthOptions {
        PointDepthOptions { masks: self.ours_masks, ..self.point_depth.options() }
    }

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn realign_heading_takes_degrees_or_off() {
        assert_eq!(realign_degrees("90"), Ok(Realign(Some(90.0))));
        assert_eq!(realign_degrees("OFF"), Ok(Realign(None)));
        for bad in ["0", "-5", "sideways", ""] {
            let e = realign_degrees(bad).unwrap_err();
            assert!(e.contains("`off`"), "{bad}: {e}");
        }
    }
}
