//! Recordings for a viewer (Foxglove; MCAP with Foxglove's schemas, written by
//! [`dynotraj_bag::record`]), one module per command that records: an estimator run
//! ([`estimate`]), the edge's forecasts ([`forecast`]), the front-end's tracks over the images
//! ([`track`]) and an experiment's test sequences ([`experiment`]). Trails and forecasts are
//! drawn alike in all of them ([`dynotraj_bag::record::Trails`]).

pub mod estimate;
pub mod experiment;
pub mod forecast;
pub mod track;

use std::path::{Path, PathBuf};

use dynotraj_bag::record::RecordingSummary;
use dynotraj_core::estimate::Intrinsics;
use dynotraj_core::wire::Track;

/// The camera-frame point of a track's pixel and depth; `None` without a usable depth (the
/// front-end keeps tracks whose depth is unknown, and they have no place in 3D).
#[must_use]
pub fn track_point(k: &Track, camera: &Intrinsics) -> Option<[f32; 3]> {
    (k.depth.is_finite() && k.depth > 0.0).then(|| camera.back_project(k.u, k.v, k.depth))
}

/// Tracks with a usable depth as points of the camera frame (x right, y down, z forward).
fn back_project(tracks: &[&Track], camera: &Intrinsics) -> Vec<[f32; 3]> {
    tracks.iter().filter_map(|t| track_point(t, camera)).collect()
}

/// What a command says of a recording it wrote.
#[must_use]
pub fn recorded(summary: &RecordingSummary) -> String {
    format!("recorded {} ({} bytes)", summary.path.display(), summary.bytes)
}

/// Where `--record FILE` puts the recording of sequence `id`: FILE itself when the run makes
/// one recording (`several` false) and FILE is not an existing folder; otherwise FILE is a
/// folder holding `<id>.mcap`, under `<group>/` when a group is given (e.g. the estimator
/// profile, when several are run). Shared by the commands that record, so that every one lays
/// out a folder of recordings the same way.
#[must_use]
pub fn record_path(target: &Path, several: bool, group: Option<&str>, id: &str) -> PathBuf {
    if !several && !target.is_dir() {
        return target.to_path_buf();
    }
    let dir = group.map_or_else(|| target.to_path_buf(), |g| target.join(g));
    dir.join(format!("{id}.mcap"))
}
