//! dynotraj-formats: the files dynotraj reads and writes, each reader strict and each error
//! naming the file, line (or byte offset) and field.
//!
//! - [`atomic`]: output files written whole or not at all.
//! - [`bounded`]: input files read up to a limit the format sets.
//! - [`eth_ucy`]: the ETH/UCY pedestrian recordings (the field's forecasting benchmark).
//! - [`kitti`]: the KITTI tracking layout (labels, calibration, pose files, GPS/IMU).
//! - [`line_file`]: the error of a line-oriented text file, naming file and line.
//! - [`manifest`]: drive manifests, the list of a run's layout folders and bags.
//! - [`tracks_file`]: recorded feature-track streams (`.dtt`), the link's bytes.
//! - [`model_file`]: model blobs on disk; [`model_signing`]: their signing keys and signatures.
//!
//! It depends on the core alone (no OpenCV, no candle, no simulator), so the fuzz targets of
//! these parsers build without the image and learning stacks.

pub mod atomic;
pub mod bounded;
pub mod eth_ucy;
pub mod kitti;
pub mod line_file;
pub mod manifest;
pub mod model_file;
pub mod model_signing;
pub mod tracks_file;
