//! dynotraj-frontend, the image front-end (OpenCV): camera frames in, the wire's feature tracks
//! out. The only crate that links OpenCV; the estimator that reads its tracks is in the core,
//! and the host reaches it only through its `images` feature.
//!
//! Stages, each in its own module:
//! - [`subpixel`]: each sent point's disparity refined from the dense value over its own
//!   instance; [`disparity_error`]: sent points scored against a rendering's exact depth;
//! - [`stereo`]: dense disparity by semi-global matching (parameters documented there), and
//!   KITTI's D1 error against ground-truth disparity; [`depth`]: depth per pixel from it or from
//!   a given depth map;
//! - [`masks`]: instance masks from mask PNGs or from 2D boxes refined by depth, and consistent
//!   ids by IoU when boxes come without them; [`motion`]: moving objects found by geometry
//!   alone (motion segmentation), as boxes for the same refinement;
//! - [`features`] + [`klt`] + [`tracker`]: static corners spread on a grid, dense object points,
//!   pyramidal KLT with a forward-backward check, re-detection to hold the target counts, and the
//!   emission of [`dynotraj_core::wire::Track`]s within the core's capacities;
//! - [`image_io`]: reading PNGs with errors that name the file.
//!
//! Everything the front-end cannot use (no depth, an empty mask, a textureless region, more
//! than the capacities) is counted in [`FrontEndStats`], never a crash.

pub mod check;
pub mod cost;
pub mod depth;
pub mod disparity_error;
pub mod error;
pub mod features;
pub mod image_io;
pub mod klt;
pub mod masks;
pub mod motion;
pub mod motion_scores;
pub mod pipeline;
pub mod rendered;
pub mod sequence;
pub mod stats;
pub mod stereo;
pub mod subpixel;
pub mod tracker;

pub use depth::DepthMap;
pub use error::FrontEndError;
pub use masks::{Detection, IdAssigner, Instance, Instances};
pub use motion::{MotionParams, MotionSegmenter};
pub use pipeline::{DepthInput, FrameInput, FrontEnd, MaskInput, StageTimes};
pub use stats::FrontEndStats;
pub use stereo::{D1, DisparityMap, Stereo, StereoParams, d1_error};
pub use subpixel::{CoarseStart, RowSearch, SubpixelParams};
pub use tracker::{Tracker, TrackerParams};
