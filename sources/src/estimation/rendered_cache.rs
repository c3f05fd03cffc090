//! The front-end's tracks of a rendered sequence kept between runs, so that a change to the
//! estimator is measured on renderings in seconds instead of rendering and tracking again
//! (minutes a sequence).
//!
//! A rendering is found by a key: CRC-64 (ECMA-182) over [`RENDERED_CACHE_VERSION`], what the
//! rendering depends on (sequence id, classes, seed, render scale, frame period, frame limit)
//! and the bytes of the sequence's label, calibration and pose files. The estimator's settings
//! are not part of it. What the key cannot see is a change to the image simulator or the
//! front-end: bump the version with one (or, for a change to the downscaled matcher's path
//! alone, [`DOWNSCALED_REFINE_VERSION`]). File: `rendered-<seq>-<key>.bin`, the key, postcard
//! bytes and their CRC-32, written as the estimate cache writes its files
//! ([`super::cache_file::decode`]); a file whose checksum does not match, that holds another key's
//! entry or that does not decode is a miss, never an error.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use crc::{CRC_64_ECMA_182, Crc};
use dynotraj_core::wire::{ObjectClass, Track};
use dynotraj_sim::track_sim::{ObjectTruth, SimFrame};
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use serde::{Deserialize, Serialize};

use super::cache_file::{load_file, store_file};
use dynotraj_formats::kitti::SequenceData;

/// Version of what rendering and tracking compute; part of every key (2: static points kept
/// clear of object masks; 3: a ground plane fitted under the ego path; 4: files end in a
/// checksum; 5: sub-pixel disparity at the sent points; 6: the point depth options name the
/// dense matcher's downscale, so every key changed).
pub const RENDERED_CACHE_VERSION: u32 = 6;

/// Version of how points are refined from a downscaled dense matcher's start, part of the keys
/// of renderings tracked with one only, so that the default keys stay as they are (1: the start
/// taken over the instance, slivers refused, a search where the fit is refused).
pub const DOWNSCALED_REFINE_VERSION: u32 = 1;

/// What a rendering depends on besides the sequence's files.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderSettings {
    /// Classes placed in the scene.
    pub classes: Vec<ObjectClass>,
    /// Seed of the image simulator.
    pub seed: u64,
    /// Render scale (1: KITTI's 1242 x 375).
    pub scale: f64,
    /// Frame period, seconds (the timestamps).
    pub dt: f32,
    /// Frames rendered.
    pub frames: usize,
    /// The camera model.
    pub optics: dynotraj_sim::image_sim::Optics,
    /// How the front-end gives points their depth.
    pub point_depth: super::simulated::PointDepthOptions,
}

/// A pose as translation then quaternion (i, j, k, w).
type StoredPose = [f64; 7];

fn store_pose(p: &Isometry3<f64>) -> StoredPose {
    let t = p.translation.vector;
    let q = p.rotation.coords;
    [t.x, t.y, t.z, q.x, q.y, q.z, q.w]
}

fn load_pose(p: &StoredPose) -> Isometry3<f64> {
    let [x, y, z, i, j, k, w] = *p;
    Isometry3::from_parts(Translation3::new(x, y, z), UnitQuaternion::from_quaternion(Quaternion::new(w, i, j, k)))
}

#[derive(Debug, Serialize, Deserialize)]
struct StoredTruth {
    object_id: u16,
    class: ObjectClass,
    size: [f64; 3],
    pose: StoredPose,
}

#[derive(Debug, Serialize, Deserialize)]
struct StoredFrame {
    frame: u32,
    timestamp_us: u64,
    tracks: Vec<Track>,
    camera: StoredPose,
    objects: Vec<StoredTruth>,
}

fn stored(f: &SimFrame) -> StoredFrame {
    StoredFrame {
        frame: f.frame,
        timestamp_us: f.timestamp_us,
        tracks: f.tracks.clone(),
        camera: store_pose(&f.camera),
        objects: f
            .objects
            .iter()
            .map(|o| StoredTruth { object_id: o.object_id, class: o.class, size: o.size, pose: store_pose(&o.pose) })
            .collect(),
    }
}

fn restored(f: StoredFrame) -> SimFrame {
    SimFrame {
        frame: f.frame,
        timestamp_us: f.timestamp_us,
        tracks: f.tracks,
        camera: load_pose(&f.camera),
        objects: f
            .objects
            .iter()
            .map(|o| ObjectTruth { object_id: o.object_id, class: o.class, size: o.size, pose: load_pose(&o.pose) })
            .collect(),
    }
}

/// The key of rendering sequence `id` of `data` with `settings`.
///
/// # Errors
/// A label, calibration or pose file that cannot be read, named.
pub fn rendered_key(id: &str, data: &SequenceData, settings: &RenderSettings) -> anyhow::Result<u64> {
    let crc = Crc::<u64>::new(&CRC_64_ECMA_182);
    let mut d = crc.digest();
    let what = if settings.point_depth.stereo_downscale > 1 {
        format!("r{RENDERED_CACHE_VERSION} d{DOWNSCALED_REFINE_VERSION} {id} {settings:?}")
    } else {
        format!("r{RENDERED_CACHE_VERSION} {id} {settings:?}")
    };
    d.update(what.as_bytes());
    for path in [&data.labels_path, &data.calib_path, &data.poses_path] {
        d.update(&std::fs::read(path).with_context(|| format!("reading {}", path.display()))?);
    }
    Ok(d.finalize())
}

fn path(dir: &Path, id: &str, key: u64) -> PathBuf {
    dir.join(format!("rendered-{id}-{key:016x}.bin"))
}

/// The cached front-end frames of `id` under `key`, if a readable file holds them.
#[must_use]
pub fn load(dir: &Path, id: &str, key: u64) -> Option<Vec<SimFrame>> {
    let frames: Vec<StoredFrame> = load_file(&path(dir, id, key), key)?;
    Some(frames.into_iter().map(restored).collect())
}

/// The front-end frames of a cache file's bytes stored under `key` ([`super::cache_file::decode`]).
///
/// # Errors
/// What is wrong with the bytes, in words.
pub fn decode_frames(bytes: &[u8], key: u64) -> Result<Vec<SimFrame>, &'static str> {
    let frames: Vec<StoredFrame> = super::cache_file::decode(bytes, key)?;
    Ok(frames.into_iter().map(restored).collect())
}

/// Keeps the front-end frames of `id` under `key`.
///
/// # Errors
/// The folder or file cannot be written, named.
pub fn store(dir: &Path, id: &str, key: u64, frames: &[SimFrame]) -> anyhow::Result<()> {
    let stored: Vec<StoredFrame> = frames.iter().map(stored).collect();
    store_file(dir, &path(dir, id, key), key, &stored, "rendered frames")
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn frames_round_trip_and_garbage_is_a_miss() {
        let pose = Isometry3::new(Vector3::new(1.0, -2.0, 30.5), Vector3::new(0.01, 0.3, -0.02));
        let frame = SimFrame {
            frame: 7,
            timestamp_us: 700_000,
            tracks: vec![Track {
                track_id: 9,
                object_id: 2,
                class: ObjectClass::Cyclist,
                u: 100.25,
                v: 50.5,
                depth: 12.0,
            }],
            camera: pose,
            objects: vec![ObjectTruth { object_id: 2, class: ObjectClass::Cyclist, size: [1.7, 0.6, 1.8], pose }],
        };
        let dir = tempfile::tempdir().unwrap();
        store(dir.path(), "0003", 5, std::slice::from_ref(&frame)).unwrap();
        let back = load(dir.path(), "0003", 5).unwrap();
        assert_eq!(back.len(), 1);
        assert_eq!(back[0].tracks, frame.tracks);
        assert_eq!(back[0].objects[0].object_id, 2);
        assert!((back[0].camera.translation.vector - pose.translation.vector).norm() < 1e-12);
        assert!(back[0].objects[0].pose.rotation.angle_to(&pose.rotation) < 1e-12);
        assert!(load(dir.path(), "0003", 6).is_none());
        std::fs::write(path(dir.path(), "0003", 5), [1, 2, 3]).unwrap();
        assert!(load(dir.path(), "0003", 5).is_none());
    }
}
