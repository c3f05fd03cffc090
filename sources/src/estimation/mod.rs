//! Running the core estimator on the track-level simulator driven by real KITTI sequences, and
//! scoring it: the paper's Table III (camera and object RPE), trajectory smoothness, pose files.
//!
//! - [`input`]: a loaded KITTI sequence as simulator input (label boxes, ego poses, calibration).
//! - [`runner`]: simulate, stream every frame through the wire (frame parts, encode, decode) into
//!   the estimator, and collect its three outputs per frame with the truth.
//! - [`hybrid`]: DynoSAM's hybrid object smoother (fits as pose measurements) run offline over a
//!   run's fits, to score it against the estimator's chain smoother.
//! - [`score`]: RPE (Sturm et al., delta = 1 frame) of the camera and of every moving object, and
//!   the smoothness of object trajectories (mean |delta heading|, |delta speed|).
//! - [`cache`]: estimated tracks kept between runs of the experiment.
//! - [`rendered_cache`]: the front-end's tracks of rendered sequences kept between runs.
//! - [`cache_file`]: the one file format of both caches (key, postcard value, CRC-32).
//! - [`cost`]: compute per frame at the ECU's full budget (16 objects x 128 points + 256 static).
//! - [`simulated`]: one sequence end to end on the track-level simulator (simulate, estimate,
//!   score).
//! - [`tracks`]: the estimator's outputs as bird's-eye object tracks (the Estimated source).
//! - [`from_images`]: the estimator on the image front-end's tracks of a real image sequence.
//! - [`end_to_end`]: a rendered sequence through the front-end and the estimator, scored.
//! - [`settings`]: how the Estimated source is made (options, simulated or rendered tracks).

pub mod cache;
pub mod cache_file;
pub mod cost;
#[cfg(feature = "images")]
pub mod end_to_end;
pub mod from_images;
pub mod hybrid;
pub mod input;
pub mod rendered_cache;
pub mod runner;
pub mod score;
pub mod settings;
pub mod simulated;
pub mod tracks;

pub use input::{SimInput, sim_input};
pub use runner::{EstimatorRun, Kind, run_estimator};
pub use score::{RunScores, TrajectorySmoothness, score_run, smoothness};
pub use tracks::{
    CameraPair, EstimateInput, EstimatedTracks, estimated_tracks, image_estimated_tracks, rendered_estimated_tracks,
    tracks_of_estimates, truth_tracks,
};
