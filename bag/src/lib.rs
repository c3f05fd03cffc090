//! ROS 2 bags in, recordings out, both in MCAP.
//!
//! - [`ros2`]: the ROS 2 messages a bag brings (images, camera info, 2D detections) and their
//!   CDR decoding.
//! - [`rosbag2`]: rosbag2's bag folder (`metadata.yaml` beside the MCAP files), written and
//!   described.
//! - [`from_layout`]: a sequence in the KITTI tracking layout written as such a bag.
//! - [`import`]: a bag (an `.mcap` file, or a ROS 2 bag folder of them) to a folder in the KITTI
//!   tracking layout that the rest of the pipeline reads.
//! - [`record`]: recordings of what the pipeline computed, in MCAP with Foxglove's schemas, for
//!   a standard viewer.
//! - [`sim_layout`]: the image simulator's renderings written in the KITTI tracking layout,
//!   with their truth.
//! - [`png`]: the one PNG writer of the layouts.

pub mod from_layout;
pub mod import;
pub mod png;
pub mod record;
pub mod ros2;
pub mod rosbag2;
pub mod sim_layout;
