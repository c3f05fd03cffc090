//! dynotraj-host: KITTI I/O, trajectory sources, evaluation and the `dynotraj` command.

pub mod estimate;
pub mod evaluate;
pub mod frontend;
pub mod jobs;
pub mod image_sim_files;
pub mod experiment;
pub mod model_file;
pub mod model_signing;
pub mod scene;
pub mod sequence;
pub mod report;
pub mod cli;
pub mod tracks_file;
pub mod trajectory;
pub mod train;
pub mod kitti;
pub mod link;
pub mod stream;
pub mod soak;
