//! Trained folds kept between runs of the experiment, so a rerun trains only the folds whose
//! inputs changed.
//!
//! A fold is found by a key: CRC-64 (ECMA-182) over [`CACHE_VERSION`], the fold's settings
//! (source, held-out sequences, frame period, eligibility, widths, optimisation, validation and
//! reflection settings) and every frame and state of every track of every sequence it trains
//! on, the source's own (labels, or the estimator's tracks). Changing any of those, or the
//! estimator that made the tracks, makes a new key. What the key cannot see is a change to the
//! training code itself: bump [`CACHE_VERSION`] with any change that alters what training
//! computes, or run with `--no-cache`.
//!
//! Each fold is one file in the cache folder, `<arm>-<seq>-<key>.fold`, in the caches' one file
//! format ([`dynotraj_sources::estimation::cache_file`]): the key, the two blobs (f32, int8) and
//! what training reported, under a checksum. A file renamed or copied to another fold's name
//! holds another key and is a miss, as is a damaged one: the fold is trained again.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use crc::{CRC_64_ECMA_182, Crc};
use dynotraj_core::model::arch::FEATURES;
use dynotraj_core::predict::{Dynamics, PriorSettings};

use dynotraj_sources::estimation::cache_file::{load_file, store_file};
use serde::{Deserialize, Serialize};

use super::FoldReport;
use dynotraj_train::TrainConfig;

/// Version of what training computes, and of the fold file; part of every key.
pub const CACHE_VERSION: u32 = 9;

/// A fold's blobs and report, as trained or as read back.
#[derive(Debug, Clone, PartialEq)]
pub struct CachedFold {
    /// The f32 blob.
    pub f32_blob: Vec<u8>,
    /// The int8 blob.
    pub int8_blob: Vec<u8>,
    /// What training did.
    pub report: FoldReport,
}

/// A folder of trained folds.
#[derive(Debug, Clone)]
pub struct FoldCache {
    dir: PathBuf,
}

/// The key of a fold's training inputs.
#[must_use]
pub fn fold_key(train: &TrainConfig<'_>) -> u64 {
    let crc = Crc::<u64>::new(&CRC_64_ECMA_182);
    let mut d = crc.digest();
    let settings = format!(
        "v{CACHE_VERSION} f{FEATURES} {:?} {:?} {} {:?} {:?} {:?} {} {} {} {} {:?}",
        train.source,
        train.exclude,
        train.dt,
        train.rule,
        train.dims,
        train.hyper,
        train.validation_fraction,
        train.validate_on_sequences,
        train.mirror,
        train.split_seed,
        train.prior
    );
    d.update(settings.as_bytes());
    // Only another agent type adds to the key, so vehicle folds keep the keys they had.
    if train.dynamics != Dynamics::Unicycle || train.empty_ships_prior {
        d.update(format!(" {:?} {}", train.dynamics, train.empty_ships_prior).as_bytes());
    }
    for seq in train.sequences.iter().filter(|s| !train.exclude.contains(&s.id)) {
        d.update(seq.id.as_bytes());
        for t in seq.tracks_for(train.source) {
            d.update(&t.track_id.to_le_bytes());
            d.update(format!("{:?}", t.class).as_bytes());
            for (f, s) in t.frames.iter().zip(&t.states) {
                d.update(&f.to_le_bytes());
                for v in [s.x, s.y, s.heading, s.speed] {
                    d.update(&v.to_bits().to_le_bytes());
                }
            }
        }
        for (f, p) in seq.observer_for(train.source) {
            d.update(&f.to_le_bytes());
            for v in [p.x, p.y] {
                d.update(&v.to_bits().to_le_bytes());
            }
        }
    }
    d.finalize()
}

impl FoldCache {
    /// The cache in `dir` (created when missing).
    ///
    /// # Errors
    /// The folder cannot be created.
    pub fn open(dir: &Path) -> anyhow::Result<Self> {
        std::fs::create_dir_all(dir).with_context(|| format!("creating the fold cache {}", dir.display()))?;
        Ok(Self { dir: dir.to_path_buf() })
    }

    fn path(&self, name: &str, key: u64) -> PathBuf {
        self.dir.join(format!("{name}-{key:016x}.fold"))
    }

    /// The fold `name` with `key`, when its file is there, holds `key`'s entry, is whole and
    /// its blobs parse; `report.arm` and `report.sequence` are taken from `template`.
    #[must_use]
    pub fn load(&self, name: &str, key: u64, template: &FoldReport) -> Option<CachedFold> {
        let path = self.path(name, key);
        let stored: StoredFold = load_file(&path, key)?;
        for blob in [&stored.f32_blob, &stored.int8_blob] {
            if let Err(e) = dynotraj_core::model::blob::ModelBlob::parse_exact(blob) {
                log::warn!("{}: a fold this build cannot read ({e}); the fold is trained again", path.display());
                return None;
            }
        }
        let prior = stored.prior;
        let report = FoldReport {
            train_instances: usize::try_from(stored.train_instances).ok()?,
            best_epoch: usize::try_from(stored.best_epoch).ok()?,
            shrink: stored.shrink,
            val_ade: stored.val_ade,
            val_cv_ade: stored.val_cv_ade,
            val_prior_ade: stored.val_prior_ade,
            prior: prior.is_valid().then_some(prior)?,
            seconds: stored.seconds,
            ..template.clone()
        };
        Some(CachedFold { f32_blob: stored.f32_blob, int8_blob: stored.int8_blob, report })
    }

    /// Keeps `fold` under `name` and `key` (one file, written under a temporary name and
    /// renamed, so an interrupted run leaves no fold that looks complete).
    ///
    /// # Errors
    /// The file cannot be written, named.
    pub fn store(&self, name: &str, key: u64, fold: &CachedFold) -> anyhow::Result<()> {
        let r = &fold.report;
        let stored = StoredFold {
            f32_blob: fold.f32_blob.clone(),
            int8_blob: fold.int8_blob.clone(),
            train_instances: r.train_instances as u64,
            best_epoch: r.best_epoch as u64,
            shrink: r.shrink,
            val_ade: r.val_ade,
            val_cv_ade: r.val_cv_ade,
            val_prior_ade: r.val_prior_ade,
            seconds: r.seconds,
            prior: r.prior,
        };
        store_file(&self.dir, &self.path(name, key), key, &stored, "a trained fold")
    }
}

/// A fold as its file holds it.
#[derive(Serialize, Deserialize)]
struct StoredFold {
    f32_blob: Vec<u8>,
    int8_blob: Vec<u8>,
    train_instances: u64,
    best_epoch: u64,
    shrink: f32,
    val_ade: f32,
    val_cv_ade: f32,
    val_prior_ade: f32,
    seconds: f32,
    prior: PriorSettings,
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynotraj_core::wire::ObjectClass;
    use dynotraj_core::{BevState, Point2};
    use dynotraj_sources::sequence::SequenceTracks;
    use dynotraj_sources::trajectory::{ObjectTrack, Source};

    fn seq(id: &str, x: f32) -> SequenceTracks {
        let track = ObjectTrack {
            track_id: 1,
            class: ObjectClass::Car,
            frames: vec![0, 1],
            states: vec![BevState::default(), BevState { x, ..BevState::default() }],
        };
        SequenceTracks { id: id.into(), frame_count: 2, tracks: vec![track], estimated: None, camera_path: Vec::new() }
    }

    #[test]
    fn the_key_follows_training_inputs_only() {
        let a = [seq("0000", 1.0), seq("0001", 2.0)];
        let key = fold_key(&TrainConfig::new(&a, vec!["0000".into()], Source::Gt));
        // A change in the held-out sequence does not matter; one in a training sequence does,
        // and so do the settings.
        let b = [seq("0000", 5.0), seq("0001", 2.0)];
        assert_eq!(key, fold_key(&TrainConfig::new(&b, vec!["0000".into()], Source::Gt)));
        let c = [seq("0000", 1.0), seq("0001", 2.5)];
        assert_ne!(key, fold_key(&TrainConfig::new(&c, vec!["0000".into()], Source::Gt)));
        // So does where the training sequence's camera was (the range feature).
        let mut seen = [seq("0000", 1.0), seq("0001", 2.0)];
        seen[1].camera_path = vec![Point2::new(0.0, 0.0), Point2::new(0.0, 1.0)];
        assert_ne!(key, fold_key(&TrainConfig::new(&seen, vec!["0000".into()], Source::Gt)));
        assert_ne!(key, fold_key(&TrainConfig::new(&a, vec!["0000".into()], Source::GtEkf)));
        let mut other = TrainConfig::new(&a, vec!["0000".into()], Source::Gt);
        other.hyper.seed += 1;
        assert_ne!(key, fold_key(&other));
    }

    #[test]
    fn a_stored_fold_reads_back_and_a_damaged_or_renamed_one_is_a_miss() {
        let dir = tempfile::tempdir().unwrap();
        let cache = FoldCache::open(dir.path()).unwrap();
        let report = FoldReport {
            arm: Source::Gt,
            agents: dynotraj_core::predict::Dynamics::Unicycle,
            sequence: "0003".into(),
            seed: 1,
            train_instances: 10,
            val_ade: 1.5,
            val_cv_ade: 1.75,
            val_prior_ade: 1.6,
            prior: PriorSettings::DEFAULT,
            best_epoch: 3,
            shrink: 0.75,
            seconds: 2.5,
            cached: false,
        };
        let blob = |p| dynotraj_sim::cost_inputs::random_blob(&dynotraj_core::model::Dims::DEFAULT, p, 0.05);
        let (f32_blob, int8_blob) =
            (blob(dynotraj_core::model::blob::Precision::F32), blob(dynotraj_core::model::blob::Precision::Int8));
        let fold = CachedFold { f32_blob, int8_blob, report: report.clone() };
        cache.store("gt-0003", 7, &fold).unwrap();
        let template = FoldReport { train_instances: 0, cached: true, ..report.clone() };
        let read = CachedFold { report: FoldReport { cached: true, ..report }, ..fold.clone() };
        assert_eq!(cache.load("gt-0003", 7, &template), Some(read));
        assert_eq!(cache.load("gt-0003", 8, &template), None);
        // Another fold's file under this fold's name (swapped, copied) is a miss: its key is not
        // this one, so no held-out sequence is forecast by a model trained on it.
        cache.store("gt-0004", 9, &fold).unwrap();
        let ours = dir.path().join(format!("gt-0003-{:016x}.fold", 7));
        let theirs = dir.path().join(format!("gt-0004-{:016x}.fold", 9));
        let good = std::fs::read(&ours).unwrap();
        std::fs::copy(&theirs, &ours).unwrap();
        assert_eq!(cache.load("gt-0003", 7, &template), None, "another fold's file is a miss");
        let mut bad = good.clone();
        let mid = bad.len() / 2;
        bad[mid] ^= 1;
        std::fs::write(&ours, &bad).unwrap();
        assert_eq!(cache.load("gt-0003", 7, &template), None, "a damaged fold is a miss, not an error later");
        std::fs::write(&ours, &good).unwrap();
        assert!(cache.load("gt-0003", 7, &template).is_some());
        std::fs::write(&ours, "3 x").unwrap();
        assert_eq!(cache.load("gt-0003", 7, &template), None);
        assert!(
            std::fs::read_dir(dir.path()).unwrap().all(|e| !e.unwrap().path().to_string_lossy().ends_with(".partial"))
        );
    }
}
