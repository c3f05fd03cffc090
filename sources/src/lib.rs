//! dynotraj-sources: where trajectories come from. The labels' tracks and the paper's sources
//! (`trajectory`), the core estimator run on KITTI sequences and its estimated tracks
//! (`estimation`), a sequence's tracks for each source (`sequence`), the drives a run reads
//! from layout folders and bags (`drives`) and the scenes forecasts are scored in (`scene`); the forecasting windows of pedestrian recordings (`pedestrian_windows`). Training and the experiments build on it.

pub mod drives;
pub mod estimation;
pub mod on_step;
pub mod pedestrian_windows;
pub mod scene;
pub mod sequence;
pub mod trajectory;
