//! Bird's-eye object trajectories: built from labels or from the estimator's output, turned
//! into the paper's sources (GT, GT+EKF, Estimated, and the labelled non-causal GT+RTS and
//! smoothed Estimated), cut into eligible runs and test instances.

mod eligibility;
pub mod estimated;
mod ground_truth;
mod object_number;
mod source;

pub use eligibility::{EligibilityRule, EligibleRun, MovingRule, eligible_runs, instance_frames};
pub use estimated::{
    CameraPair, EstimateInput, EstimatedTracks, estimated_tracks, image_estimated_tracks, rendered_estimated_tracks,
    tracks_of_estimates,
};
pub use ground_truth::{LabelledObservation, ObjectTrack, ground_truth_tracks, label_tracks};
pub use object_number::{object_number, track_id_of};
pub use source::{RTS_WINDOW, Source};
