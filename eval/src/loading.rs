//! Drives loaded for the sources a command scores or trains on: each drive's labels (when it
//! has them) and, when an estimated source is asked for, the estimator's tracks over its
//! images, its rendering or the track-level simulator, drives loaded in parallel.

use std::path::PathBuf;

use dynotraj_sources::drives::{Drive, distinct_ids, kitti_drives, load_drive, manifest_drives, select_drives};
use dynotraj_sources::estimation::settings::EstimateSettings;
use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::{EligibilityRule, Source};

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

/// Where a command's drives are.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DriveSet {
    /// A KITTI tracking split folder: every sequence a labelled drive.
    Kitti(PathBuf),
    /// A drive manifest, a layout folder, a bag, or a folder of them
    /// ([`dynotraj_sources::drives::manifest_drives`]).
    Manifest(PathBuf),
}

/// How a command's loading goes, told as it goes (a bar in the command line).
pub trait LoadProgress: Sync {
    /// Loading of `drives` drives starts; `estimating` when the estimator runs over them.
    fn loading(&self, drives: usize, estimating: bool);
    /// The drive named `name` loaded (`ok`) or failed.
    fn loaded(&self, name: &str, ok: bool);
    /// Every drive is loaded or failed.
    fn finished(&self);
}

/// Where a command's data is and how to read it: the drives, the frame period, the rule that
/// makes an object eligible, and how the estimated sources are made.
#[derive(Debug, Clone)]
pub struct DataRequest {
    /// Where the drives are.
    pub drives: DriveSet,
    /// Frame period, seconds.
    pub dt: f32,
    /// The objects forecast and scored.
    pub rule: EligibilityRule,
    /// How the estimated sources are made; its cache is where they are kept by default.
    pub estimate: EstimateSettings,
    /// Drives loaded at a time.
    pub jobs: usize,
}

impl DataRequest {
    /// The drives `sequences` names (all when empty).
    ///
    /// # Errors
    /// A folder or manifest that cannot be read, a name given twice or that no drive has.
    pub fn drives(&self, sequences: &[String]) -> anyhow::Result<Vec<Drive>> {
        match &self.drives {
            DriveSet::Manifest(path) => {
                let names = distinct_ids("--sequences", sequences.to_vec())?;
                select_drives(manifest_drives(path)?, &names)
            }
            DriveSet::Kitti(kitti) => kitti_drives(kitti, sequences),
        }
    }

    /// Loads the drives `sequences` names (all when empty) for `sources`, keeping estimated
    /// tracks in `cache` ([`load_drives`]).
    ///
    /// # Errors
    /// A missing folder, a missing sequence or a bad file, named.
    pub fn load(
        &self,
        sequences: &[String],
        sources: &[Source],
        cache: Option<PathBuf>,
        progress: &dyn LoadProgress,
    ) -> anyhow::Result<Vec<SequenceTracks>> {
        self.load_drives(&self.drives(sequences)?, sources, cache, progress)
    }

    /// Loads `drives` for `sources`, keeping estimated tracks in `cache` ([`load_drives`]).
    ///
    /// # Errors
    /// A missing or bad file, named.
    pub fn load_drives(
        &self,
        drives: &[Drive],
        sources: &[Source],
        cache: Option<PathBuf>,
        progress: &dyn LoadProgress,
    ) -> anyhow::Result<Vec<SequenceTracks>> {
        let estimate = EstimateSettings { cache, ..self.estimate.clone() };
        progress.loading(drives.len(), sources.iter().any(Source::is_estimated));
        let out = load_drives(drives, sources, self.dt, &estimate, self.jobs, &|name, ok| progress.loaded(name, ok));
        progress.finished();
        out
    }
}
