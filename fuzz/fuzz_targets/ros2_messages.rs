//! The ROS 2 message decoders of the bag import on arbitrary payloads: a message or an error,
//! never a panic.
#![no_main]

use dynotraj_bag::ros2::{CameraInfo, CompressedImage, Detection2DArray, Image, decode};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = decode::<Image>(data);
    let _ = decode::<CompressedImage>(data);
    let _ = decode::<CameraInfo>(data);
    let _ = decode::<Detection2DArray>(data);
});
