//! Bird's-eye object trajectories: built from labels here (the estimator's in
//! [`crate::estimation::tracks`]), turned
//! into the paper's sources (GT, GT+EKF, Estimated, and the labelled non-causal GT+RTS and
//! smoothed Estimated), cut into eligible runs and test instances.

mod eligibility;
mod ground_truth;
mod object_number;
mod source;

pub use eligibility::{EligibilityRule, EligibleRun, MovingRule, eligible_runs, instance_frames};
pub use ground_truth::{LabelledObservation, ObjectTrack, ground_truth_tracks, label_tracks};
pub use object_number::{object_number, track_id_of};
pub use source::{RTS_WINDOW, Source};
