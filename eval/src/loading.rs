//! Drives loaded for the sources a command scores or trains on: each drive's labels (when it
//! has them) and, when an estimated source is asked for, the estimator's tracks over its
//! images, its rendering or the track-level simulator, drives loaded in parallel.

use dynotraj_sources::drives::{Drive, load_drive};
use dynotraj_sources::estimation::settings::EstimateSettings;
use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::Source;

use crate::jobs::map_jobs;

/// Loads `drives` at frame period `dt` for `sources`, `jobs` at a time; when one of `sources`
/// is estimated, also runs the estimator over each drive as `estimate` says, keeping the
/// tracks in its cache when it has one (where bags are imported, in any case). `on_drive` is told each drive's name and whether it
/// loaded. Drives without labels add to the estimated sources only (a warning says so when
/// other sources are asked for).
///
/// # Errors
/// A missing or bad file, named.
pub fn load_drives(
    drives: &[Drive],
    sources: &[Source],
    dt: f32,
    estimate: &EstimateSettings,
    jobs: usize,
    on_drive: &(dyn Fn(&str, bool) + Sync),
) -> anyhow::Result<Vec<SequenceTracks>> {
    // The cache is also where bags are imported, estimated source or not.
    let cache = estimate.cache.as_deref();
    let estimate = sources.iter().any(Source::is_estimated).then_some(estimate);
    let out = map_jobs(drives, jobs, |d| {
        let s = load_drive(d, dt, estimate, cache);
        on_drive(&d.name, s.is_ok());
        s
    })?;
    let unlabelled: Vec<&str> = drives.iter().filter(|d| !d.is_labelled()).map(|d| d.name.as_str()).collect();
    if !unlabelled.is_empty() && sources.iter().any(|s| !s.is_estimated()) {
        log::warn!(
            "{} drive(s) without labels ({}) add to the estimated sources only",
            unlabelled.len(),
            unlabelled.join(", ")
        );
    }
    out.into_iter().collect()
}
