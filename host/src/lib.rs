//! dynotraj-host: KITTI I/O, trajectory sources, evaluation and the `dynotraj` command.

pub mod estimate;
pub mod evaluate;
pub mod experiment;
pub mod jobs;
pub mod model_signing;
pub mod on_step;
pub mod predictors;
pub mod report;
pub mod scene;
pub mod sequence;
pub mod train;
pub mod trajectory;
