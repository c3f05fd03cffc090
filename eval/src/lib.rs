//! dynotraj-eval: forecasts scored and compared. Predictors run over eligible runs
//! (`forecast_eval`), the paper's experiment and the benchmark (`experiment`), their reports,
//! tables and figures (`report`), the predictors a command names (`predictors`), and the pool
//! of jobs they run on (`jobs`).

pub mod estimation;
pub mod experiment;
pub mod forecast_eval;
pub mod jobs;
pub mod loading;
pub mod model_cost;
#[cfg(feature = "images")]
pub mod motion_segmentation;
pub mod pedestrian_benchmark;
pub mod predictors;
pub mod recording;
pub mod report;
pub mod scores;
#[cfg(feature = "images")]
pub mod tracking;
