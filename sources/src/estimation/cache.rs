//! The estimated tracks of a sequence kept between runs of the experiment, so that a rerun
//! does not simulate (or render, track) and estimate again.
//!
//! A sequence is found by a key: CRC-64 (ECMA-182) over [`ESTIMATE_CACHE_VERSION`] and the
//! rendered cache's version (what the front-end computes), the
//! estimation settings, the sequence id and the bytes of its label, calibration and pose
//! files. What the key cannot see is a change to the simulator, front-end or estimator code:
//! bump the version with one, or run with `--no-cache`. Estimates from real images are not
//! cached (the key would have to read every image).
//!
//! File: `estimated-<seq>-<key>.bin`: the key (u64, little-endian), the [`EstimatedTracks`] as
//! postcard bytes, and the CRC-32 (little-endian) of both ([`decode`]). A file whose checksum does not match or that does not decode
//! is a miss (said in a warning), never an error; a file is written under a temporary name and
//! renamed, so an interrupted run leaves none that looks complete.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use crc::{CRC_64_ECMA_182, Crc};

pub use super::cache_file::decode;
use super::cache_file::{load_file, store_file};
use super::settings::EstimateSettings;
use crate::estimation::EstimatedTracks;
use dynotraj_formats::kitti::SequenceData;

/// Version of what estimation computes; part of every key. Bump it with every change to the
/// estimator's arithmetic (2: one-pass Levenberg-Marquardt with a cost-based stop; 4: RANSAC's
/// hypotheses by TRIAD instead of an SVD, and a step whose promised decrease is below the stop
/// is not evaluated, 2026-12-01; 5: the cached tracks also hold the RPE per frame; 6: and the
/// camera per frame, true and estimated; 7: the world yaw derived from those cameras, not kept;
/// 8: files end in a checksum; 9: the causal camera is its current estimate, the pose the
/// objects are placed against; 10: the causal camera's position on every input; 11: a
/// vehicle's frame pointing backwards is turned onto its travel; 12: the true object of each
/// object the front-end named itself).
pub const ESTIMATE_CACHE_VERSION: u32 = 12;

/// The key of sequence `id`'s estimation inputs.
///
/// # Errors
/// A label, calibration or pose file that cannot be read, named.
pub fn estimate_key(id: &str, data: &SequenceData, settings: &EstimateSettings) -> anyhow::Result<u64> {
    let crc = Crc::<u64>::new(&CRC_64_ECMA_182);
    let mut d = crc.digest();
    let what = format!(
        "v{ESTIMATE_CACHE_VERSION} r{} {id} {:?} {:?} {}",
        super::rendered_cache::RENDERED_CACHE_VERSION,
        settings.options,
        settings.input,
        settings.render_scale
    );
    d.update(what.as_bytes());
    for path in [&data.labels_path, &data.calib_path, &data.poses_path] {
        d.update(&std::fs::read(path).with_context(|| format!("reading {}", path.display()))?);
    }
    Ok(d.finalize())
}

/// The key of estimating sequence `id` from its images: [`estimate_key`]'s inputs and the bytes
/// of every image file the front-end reads (`files`, in order). Hashing a full KITTI sequence's
/// images takes about a second; tracking them takes minutes.
///
/// # Errors
/// A file that cannot be read, named.
pub fn image_estimate_key(
    id: &str,
    data: &SequenceData,
    settings: &EstimateSettings,
    files: &[PathBuf],
) -> anyhow::Result<u64> {
    let crc = Crc::<u64>::new(&CRC_64_ECMA_182);
    let mut d = crc.digest();
    d.update(&estimate_key(id, data, settings)?.to_le_bytes());
    d.update(b"images");
    for path in files {
        d.update(&std::fs::read(path).with_context(|| format!("reading {}", path.display()))?);
    }
    Ok(d.finalize())
}

/// The key of estimating drive `id` from its images where it has no labels or ego poses (an
/// imported drive): the settings and the bytes of `files` (calibration, any detections and
/// every image, in order).
///
/// # Errors
/// A file that cannot be read, named.
pub fn images_only_key(id: &str, settings: &EstimateSettings, files: &[PathBuf]) -> anyhow::Result<u64> {
    let crc = Crc::<u64>::new(&CRC_64_ECMA_182);
    let mut d = crc.digest();
    d.update(format!("v{ESTIMATE_CACHE_VERSION} {id} {:?} images only", settings.options).as_bytes());
    for path in files {
        d.update(&std::fs::read(path).with_context(|| format!("reading {}", path.display()))?);
    }
    Ok(d.finalize())
}

fn path(dir: &Path, id: &str, key: u64) -> PathBuf {
    dir.join(format!("estimated-{id}-{key:016x}.bin"))
}

/// The cached tracks of `id` under `key`, if a readable file holds them.
#[must_use]
pub fn load(dir: &Path, id: &str, key: u64) -> Option<EstimatedTracks> {
    load_file(&path(dir, id, key), key)
}

/// Keeps `tracks` of `id` under `key`.
///
/// # Errors
/// The folder or file cannot be written, named.
pub fn store(dir: &Path, id: &str, key: u64, tracks: &EstimatedTracks) -> anyhow::Result<()> {
    store_file(dir, &path(dir, id, key), key, tracks, "estimated tracks")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimation::EstimateInput;
    use crate::trajectory::ObjectTrack;
    use dynotraj_core::BevState;
    use dynotraj_core::wire::ObjectClass;

    #[test]
    fn tracks_round_trip_and_garbage_is_a_miss() {
        let dir = tempfile::tempdir().unwrap();
        let track = ObjectTrack {
            track_id: 3,
            class: ObjectClass::Cyclist,
            frames: vec![4, 5],
            states: vec![BevState { x: 1.5, y: -2.0, heading: 0.25, speed: 3.0 }; 2],
        };
        let tracks = EstimatedTracks {
            input: EstimateInput::Rendered,
            causal: vec![track.clone()],
            smoothed: vec![],
            rpe: Some(crate::estimation::RunScores::default()),
            truth: vec![track],
            truth_of: Some([(20_000, 3)].into()),
            cameras: [(
                4,
                crate::estimation::CameraPair {
                    truth: BevState { x: 1.0, y: 2.0, heading: 0.5, speed: 0.0 },
                    estimate: BevState { x: 1.1, y: 2.0, heading: 0.49, speed: 0.0 },
                },
            )]
            .into(),
            observer: [(4, dynotraj_core::Point2::new(1.1, 2.0))].into(),
            rpe_frames: [
                vec![],
                vec![crate::estimation::score::FrameRpe {
                    frame: 5,
                    camera: Some(0.02),
                    objects: None,
                    object_pairs: 0,
                }],
                vec![],
            ],
            frames: 6,
        };
        store(dir.path(), "0003", 9, &tracks).unwrap();
        assert_eq!(load(dir.path(), "0003", 9), Some(tracks));
        assert_eq!(load(dir.path(), "0003", 10), None);
        std::fs::write(path(dir.path(), "0003", 9), [1, 2, 3]).unwrap();
        assert_eq!(load(dir.path(), "0003", 9), None);
    }

    #[test]
    fn every_single_byte_flip_or_cut_of_a_cache_file_is_a_miss() {
        let dir = tempfile::tempdir().unwrap();
        let track = ObjectTrack {
            track_id: 1,
            class: ObjectClass::Car,
            frames: vec![0, 1, 2],
            states: vec![BevState { x: 10.0, y: 3.0, heading: 0.1, speed: 7.0 }; 3],
        };
        let tracks = EstimatedTracks {
            input: EstimateInput::Tracks,
            causal: vec![track.clone()],
            smoothed: vec![track.clone()],
            rpe: None,
            truth: vec![track],
            truth_of: None,
            cameras: std::collections::BTreeMap::new(),
            observer: std::collections::BTreeMap::new(),
            rpe_frames: [vec![], vec![], vec![]],
            frames: 3,
        };
        store(dir.path(), "0003", 1, &tracks).unwrap();
        let file = path(dir.path(), "0003", 1);
        let good = std::fs::read(&file).unwrap();
        assert!(
            !dynotraj_formats::atomic::partial_path(&file).exists(),
            "written under a temporary name, then renamed"
        );
        for at in 0..good.len() {
            let mut bad = good.clone();
            bad[at] ^= 0x10;
            std::fs::write(&file, &bad).unwrap();
            assert_eq!(load(dir.path(), "0003", 1), None, "byte {at} flipped was read back");
        }
        std::fs::write(&file, &good[..good.len() - 1]).unwrap();
        assert_eq!(load(dir.path(), "0003", 1), None, "a cut file was read back");
        std::fs::write(&file, &good).unwrap();
        assert_eq!(load(dir.path(), "0003", 1), Some(tracks.clone()));
        // A whole, valid entry under another key's name is a miss, not that key's value.
        std::fs::copy(&file, path(dir.path(), "0003", 2)).unwrap();
        assert_eq!(load(dir.path(), "0003", 2), None, "another key's entry was read back");
        assert_eq!(
            decode::<EstimatedTracks>(&good, 2),
            Err("a cache file holding another key's entry (renamed or copied)")
        );
        assert_eq!(decode::<EstimatedTracks>(&good, 1), Ok(tracks));
    }
}
