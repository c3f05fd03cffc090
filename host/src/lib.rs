//! dynotraj-host: the library behind the `dynotraj` command: trajectory sources, the core
//! estimator on KITTI sequences, forecast scoring, training, experiments and reports.

pub mod estimation;
pub mod experiment;
pub mod forecast_eval;
pub mod jobs;
pub mod model_signing;
pub mod on_step;
pub mod predictors;
pub mod report;
pub mod scene;
pub mod sequence;
pub mod train;
pub mod trajectory;
