//! Bird's-eye object trajectories: built from labels, turned into the paper's sources (GT,
//! GT+EKF, and the labelled non-causal GT+RTS), cut into eligible runs and test instances.

mod eligibility;
mod ground_truth;
mod source;

pub use eligibility::{eligible_runs, instance_frames, EligibilityRule, EligibleRun, MovingRule};
pub use ground_truth::{ground_truth_tracks, LabelledObservation, Track};
pub use source::{Source, RTS_WINDOW};
