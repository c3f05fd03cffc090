//! Drives: the sequences a run learns from and is scored on, wherever they are kept. A run
//! names them by one KITTI-layout folder (`--kitti`: every sequence is labelled) or by a drive
//! manifest (`--drives`: layout folders and ROS 2 bags, a line each, or a folder of them).
//!
//! A drive is one sequence, named by its sequence id (a layout's) or its file name (a bag's);
//! names are distinct within a run, since reports, caches and shards are keyed by them. A
//! layout sequence with ego poses is labelled (ground truth and the estimated sources); one
//! without (a drive imported from a bag) has images only and feeds the estimated sources
//! alone, which is the paper's point: no labels are needed to train on it. A bag is imported
//! into the estimate cache, keyed by its bytes, and is then such an images-only drive.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::Context as _;

use crate::estimation::cache;
use crate::estimation::from_images::{estimate_from_images, has_images, image_files};
use crate::estimation::image_estimated_tracks;
use crate::estimation::settings::EstimateSettings;
use crate::sequence::{SequenceTracks, load_sequence};
use dynotraj_formats::kitti::{PoseSource, TrackingDir, checked_sequence_id};
use dynotraj_formats::manifest::{ManifestEntry, read_manifest};

/// Bumped when an import of the same bag would write a different layout.
pub const IMPORT_VERSION: u32 = 1;

/// What a drive is read from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DriveSource {
    /// A sequence of a layout folder with ego poses and labels.
    Labelled {
        /// The layout folder.
        root: PathBuf,
    },
    /// A sequence of a layout folder with stereo images and no ego poses.
    Images {
        /// The layout folder.
        root: PathBuf,
    },
    /// A ROS 2 bag (an .mcap file or a bag folder), imported before it is read.
    Bag {
        /// The bag.
        path: PathBuf,
    },
}

/// One drive of a run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Drive {
    /// The drive's name: its sequence id in a layout, its file name for a bag.
    pub name: String,
    /// Where it is read from.
    pub source: DriveSource,
    /// Where it was listed (`drives.txt line 3`), for errors.
    pub listed: String,
}

impl Drive {
    /// What kind of drive this is, in a word for listings.
    #[must_use]
    pub fn kind(&self) -> &'static str {
        match self.source {
            DriveSource::Labelled { .. } => "labelled",
            DriveSource::Images { .. } => "images",
            DriveSource::Bag { .. } => "bag",
        }
    }

    /// Whether it has labels (and so ground truth).
    #[must_use]
    pub fn is_labelled(&self) -> bool {
        matches!(self.source, DriveSource::Labelled { .. })
    }

    /// The folder or file it is read from.
    #[must_use]
    pub fn path(&self) -> &Path {
        match &self.source {
            DriveSource::Labelled { root } | DriveSource::Images { root } => root,
            DriveSource::Bag { path } => path,
        }
    }
}

/// The labelled drives `ids` of the layout folder `root` (what `--kitti` names).
#[must_use]
pub fn labelled_drives(root: &Path, ids: &[String]) -> Vec<Drive> {
    ids.iter()
        .map(|id| Drive {
            name: id.clone(),
            source: DriveSource::Labelled { root: root.to_path_buf() },
            listed: root.display().to_string(),
        })
        .collect()
}

/// The drives of `path`: a manifest file, or itself a layout folder, a bag, or a folder whose
/// entries are layout folders and bags.
///
/// # Errors
/// A bad manifest line, a path that holds no drive, a listed sequence a layout does not hold,
/// a bag whose file name cannot be a drive name, or two drives of one name, each named.
pub fn manifest_drives(path: &Path) -> anyhow::Result<Vec<Drive>> {
    let entries = if path.is_dir() || is_bag(path) {
        vec![ManifestEntry { line: 0, path: path.to_path_buf(), sequences: Vec::new() }]
    } else {
        read_manifest(path)?
    };
    let mut drives = Vec::new();
    for e in &entries {
        let listed =
            if e.line == 0 { e.path.display().to_string() } else { format!("{} line {}", path.display(), e.line) };
        drives.extend(entry_drives(e, &listed)?);
    }
    let mut named: BTreeMap<&str, &Drive> = BTreeMap::new();
    for b in &drives {
        let Some(a) = named.insert(&b.name, b) else { continue };
        anyhow::bail!(
            "drive name {} is given twice: {} ({}) and {} ({}); drive names (a layout's sequence id, a bag's file name) \
             must be distinct",
            a.name,
            a.path().display(),
            a.listed,
            b.path().display(),
            b.listed
        );
    }
    Ok(drives)
}

/// The drives of `drives` named in `names`, in that order; all of them when `names` is empty.
///
/// # Errors
/// A name no drive has, with the names there are.
pub fn select_drives(drives: Vec<Drive>, names: &[String]) -> anyhow::Result<Vec<Drive>> {
    if names.is_empty() {
        return Ok(drives);
    }
    names
        .iter()
        .map(|n| {
            drives.iter().find(|d| &d.name == n).cloned().with_context(|| {
                let all: Vec<&str> = drives.iter().map(|d| d.name.as_str()).collect();
                format!("--sequences: no drive is named {n} (the drives: {})", all.join(", "))
            })
        })
        .collect()
}

/// The drives one manifest entry names.
fn entry_drives(e: &ManifestEntry, listed: &str) -> anyhow::Result<Vec<Drive>> {
    let p = &e.path;
    anyhow::ensure!(p.exists(), "{listed}: {}: no such file or folder", p.display());
    if is_layout(p) {
        let ids = layout_sequences(p).with_context(|| format!("{listed}: {}", p.display()))?;
        for s in &e.sequences {
            anyhow::ensure!(
                ids.contains(s),
                "{listed}: {} holds no sequence {s} (it holds {})",
                p.display(),
                if ids.is_empty() { "none".to_string() } else { ids.join(", ") }
            );
        }
        let chosen = if e.sequences.is_empty() { ids } else { e.sequences.clone() };
        return Ok(chosen.into_iter().map(|id| layout_drive(p, id, listed)).collect());
    }
    anyhow::ensure!(
        e.sequences.is_empty(),
        "{listed}: {} is not a KITTI-layout folder (no label_02/ or image_02/), so it has no sequences to choose",
        p.display()
    );
    if is_bag(p) {
        return Ok(vec![bag_drive(p, listed)?]);
    }
    anyhow::ensure!(
        p.is_dir(),
        "{listed}: {}: expected a KITTI-layout folder, a ROS 2 bag (.mcap file or bag folder) or a folder of them",
        p.display()
    );
    let mut children: Vec<PathBuf> = std::fs::read_dir(p)
        .with_context(|| format!("{listed}: listing {}", p.display()))?
        .filter_map(Result::ok)
        .map(|c| c.path())
        .collect();
    children.sort();
    let mut out = Vec::new();
    let mut skipped = Vec::new();
    for c in children {
        if is_layout(&c) {
            let ids = layout_sequences(&c).with_context(|| format!("{listed}: {}", c.display()))?;
            out.extend(ids.into_iter().map(|id| layout_drive(&c, id, listed)));
        } else if is_bag(&c) {
            out.push(bag_drive(&c, listed)?);
        } else {
            skipped.push(c.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default());
        }
    }
    if !skipped.is_empty() {
        log::warn!(
            "{listed}: {}: {} entr{} neither a layout folder nor a bag, not read: {}",
            p.display(),
            skipped.len(),
            if skipped.len() == 1 { "y is" } else { "ies are" },
            skipped.join(", ")
        );
    }
    anyhow::ensure!(
        !out.is_empty(),
        "{listed}: {}: no drive in the folder (expected layout folders or bags)",
        p.display()
    );
    Ok(out)
}

/// Whether `p` is a layout folder: it has `label_02/` or `image_02/`.
fn is_layout(p: &Path) -> bool {
    p.join("label_02").is_dir() || p.join("image_02").is_dir()
}

/// The sequences of the layout folder `p`: its label files' and its image folders' ids.
fn layout_sequences(p: &Path) -> anyhow::Result<Vec<String>> {
    let mut ids = Vec::new();
    for (folder, suffix) in [(p.join("label_02"), ".txt"), (p.join("image_02"), "")] {
        if !folder.is_dir() {
            continue;
        }
        for entry in std::fs::read_dir(&folder).with_context(|| format!("listing {}", folder.display()))? {
            let entry = entry.with_context(|| format!("listing {}", folder.display()))?;
            let name = entry.file_name();
            let Some(id) = name.to_str().and_then(|n| n.strip_suffix(suffix)) else { continue };
            let kind_fits = if suffix.is_empty() { entry.path().is_dir() } else { entry.path().is_file() };
            if kind_fits && checked_sequence_id(id).is_ok() && !ids.iter().any(|x| x == id) {
                ids.push(id.to_string());
            }
        }
    }
    ids.sort();
    Ok(ids)
}

/// Whether `p` is a ROS 2 bag: an .mcap file, or a bag folder as `ros2 bag record` writes it
/// (its `metadata.yaml` beside its files: .mcap, .mcap.zstd when compressed whole, .db3 in
/// sqlite3 storage, which the import names; a folder of .mcap files without one is a folder of
/// bags, each its own drive).
fn is_bag(p: &Path) -> bool {
    let mcap = |q: &Path| q.is_file() && q.extension().is_some_and(|x| x == "mcap");
    let stored = |q: &Path| {
        let name = q.file_name().and_then(|n| n.to_str()).unwrap_or_default();
        q.is_file() && [".mcap", ".mcap.zstd", ".db3"].iter().any(|end| name.ends_with(end))
    };
    mcap(p)
        || (p.join("metadata.yaml").is_file()
            && std::fs::read_dir(p).is_ok_and(|mut r| r.any(|c| c.is_ok_and(|c| stored(&c.path())))))
}

/// Sequence `id` of the layout folder `root`: labelled when it has ego poses.
fn layout_drive(root: &Path, id: String, listed: &str) -> Drive {
    let posed = PoseSource::PREFERENCE.iter().any(|s| root.join(s.folder()).join(format!("{id}.txt")).is_file());
    let root = root.to_path_buf();
    let source = if posed { DriveSource::Labelled { root } } else { DriveSource::Images { root } };
    Drive { name: id, source, listed: listed.to_string() }
}

/// The bag at `p`, named by its file name (without `.mcap`).
fn bag_drive(p: &Path, listed: &str) -> anyhow::Result<Drive> {
    let stem = if p.is_file() { p.file_stem() } else { p.file_name() };
    let name = stem.and_then(|s| s.to_str()).unwrap_or_default();
    let name = checked_sequence_id(name).map_err(|_| {
        anyhow::anyhow!(
            "{listed}: {}: a bag's file name is its drive's name, and `{name}` is not one (1 to 64 letters, digits, `_` \
             or `-`): rename the bag",
            p.display()
        )
    })?;
    Ok(Drive { name: name.to_string(), source: DriveSource::Bag { path: p.to_path_buf() }, listed: listed.to_string() })
}

/// Loads `drive` at frame period `dt`: its ground-truth tracks (none for an images-only drive)
/// and, with `estimate`, the estimator's tracks. A bag is imported first into `store` (a
/// folder named by the bag's bytes, reused when it is there).
///
/// # Errors
/// A bag without a store or that does not import, an images-only drive without stereo images,
/// or any loading error, named by the drive.
pub fn load_drive(
    drive: &Drive,
    dt: f32,
    estimate: Option<&EstimateSettings>,
    store: Option<&Path>,
) -> anyhow::Result<SequenceTracks> {
    match &drive.source {
        DriveSource::Labelled { root } => load_sequence(&TrackingDir::open(root)?, &drive.name, dt, estimate),
        DriveSource::Images { root } => load_images_only(root, &drive.name, estimate),
        DriveSource::Bag { path } => {
            let store = store.with_context(|| {
                format!(
                    "drive {} ({}) is a ROS 2 bag: it is imported into the estimate cache; give --estimate-cache DIR",
                    drive.name,
                    path.display()
                )
            })?;
            let root = imported_bag(path, &drive.name, store)?;
            load_images_only(&root, &drive.name, estimate)
        }
    }
}

/// The layout folder of the bag at `path` imported as sequence `name` in `store`: imported
/// now unless a folder with its key is there. Two processes importing one bag at once both end
/// with the same folder: each writes its own staging folder, and the one renamed second finds
/// the first's.
#[cfg(feature = "bags")]
fn imported_bag(path: &Path, name: &str, store: &Path) -> anyhow::Result<PathBuf> {
    use crc::{CRC_64_ECMA_182, Crc};
    use std::io::Read as _;
    let files = dynotraj_bag::import::bag_files(path)?;
    let crc = Crc::<u64>::new(&CRC_64_ECMA_182);
    let mut d = crc.digest();
    d.update(format!("import v{IMPORT_VERSION} {name}").as_bytes());
    let mut chunk = vec![0_u8; 1 << 20];
    for f in &files {
        let mut file = std::fs::File::open(f).with_context(|| format!("reading {}", f.display()))?;
        loop {
            let n = file.read(&mut chunk).with_context(|| format!("reading {}", f.display()))?;
            let Some(read) = chunk.get(..n).filter(|r| !r.is_empty()) else { break };
            d.update(read);
        }
    }
    let target = store.join(format!("imported-{name}-{:016x}", d.finalize()));
    if target.is_dir() {
        log::info!("drive {name}: the import of {} is read from {}", path.display(), target.display());
        return Ok(target);
    }
    std::fs::create_dir_all(store).with_context(|| format!("creating {}", store.display()))?;
    let opt = dynotraj_bag::import::ImportOptions {
        sync_tolerance_ns: dynotraj_bag::import::DEFAULT_SYNC_TOLERANCE_NS,
        ..dynotraj_bag::import::ImportOptions::default()
    };
    match dynotraj_bag::import::import(path, name, &target, &opt) {
        Ok(s) => {
            log::info!("drive {name}: imported {} frames at {:.2} Hz into {}", s.frames, s.rate_hz, target.display());
            Ok(target)
        }
        Err(_) if target.is_dir() => Ok(target),
        Err(e) => Err(e.context(format!("drive {name}: importing {}", path.display()))),
    }
}

/// Without the `bags` feature a bag cannot be imported: say so.
#[cfg(not(feature = "bags"))]
fn imported_bag(path: &Path, name: &str, _store: &Path) -> anyhow::Result<PathBuf> {
    anyhow::bail!(
        "drive {name}: {} is a ROS 2 bag, and this build of dynotraj-sources has no `bags` feature to import it",
        path.display()
    )
}

/// The number of left images `image_02/<id>/000000.png ...` in a row from frame 0.
fn frames_of(root: &Path, id: &str) -> usize {
    let left = root.join("image_02").join(id);
    (0..).take_while(|k| left.join(format!("{k:06}.png")).is_file()).count()
}

/// An images-only drive: no ground truth; with `estimate`, the estimator's tracks from its
/// stereo images, kept in the settings' cache under the key of its calibration, detections,
/// images and settings.
fn load_images_only(root: &Path, id: &str, estimate: Option<&EstimateSettings>) -> anyhow::Result<SequenceTracks> {
    let frames = frames_of(root, id);
    anyhow::ensure!(
        has_images(root, id, frames),
        "drive {id} ({}): no ego poses, so it is read from its stereo images, and it has {frames} left image(s) from \
         000000.png in image_02/{id}/ with a right image for each in image_03/{id}/ (expected both for every frame; \
         an RGB-D drive cannot be estimated from images yet)",
        root.display()
    );
    let estimated = match estimate {
        Some(e) => {
            let mut files = vec![root.join("calib").join(format!("{id}.txt"))];
            let labels = root.join("label_02").join(format!("{id}.txt"));
            if labels.is_file() {
                files.push(labels);
            }
            files.extend(image_files(root, id, frames));
            let key = e.cache.as_ref().map(|_| cache::images_only_key(id, e, &files)).transpose()?;
            if let Some(t) = e.cache.as_deref().zip(key).and_then(|(dir, key)| cache::load(dir, id, key)) {
                log::info!("drive {id}: estimated tracks read from the cache");
                Some(t)
            } else {
                let t = image_estimated_tracks(
                    &estimate_from_images(root, id, &e.options)
                        .with_context(|| format!("drive {id}: from its images"))?,
                );
                if let (Some(dir), Some(key)) = (&e.cache, key) {
                    cache::store(dir, id, key, &t)?;
                }
                Some(t)
            }
        }
        None => None,
    };
    Ok(SequenceTracks {
        id: id.to_string(),
        frame_count: frames,
        tracks: Vec::new(),
        estimated,
        camera_path: Vec::new(),
    })
}

/// The sequences a command works on: `given`, or every sequence of `dir` when none is given.
///
/// # Errors
/// A sequence given twice (it would count twice), a folder that cannot be listed, or one that
/// holds no sequence (a command over nothing would print empty tables and succeed).
pub fn sequence_ids(dir: &TrackingDir, given: &[String]) -> anyhow::Result<Vec<String>> {
    if !given.is_empty() {
        return distinct_ids("--sequences", given.to_vec());
    }
    let ids = dir.sequences()?;
    if ids.is_empty() {
        anyhow::bail!(
            "{}: no sequence (expected label files named like 0000.txt)",
            dir.root().join("label_02").display()
        );
    }
    Ok(ids)
}

/// The first item of `items` that an earlier one equals (a value given twice in a list option).
#[must_use]
pub fn first_repeated<T: PartialEq>(items: &[T]) -> Option<&T> {
    items.iter().enumerate().find_map(|(i, x)| items[..i].contains(x).then_some(x))
}

/// `ids` (the value of option `flag`) when no sequence is in it twice.
///
/// # Errors
/// A sequence given twice (it would count twice), named with its option.
pub fn distinct_ids(flag: &str, ids: Vec<String>) -> anyhow::Result<Vec<String>> {
    if let Some(twice) = first_repeated(&ids) {
        anyhow::bail!("{flag}: {twice} is given twice (each sequence counts once)");
    }
    Ok(ids)
}

/// The drives `sequences` of the KITTI tracking folder `kitti` (every one when empty), all
/// labelled: what `--kitti` names.
///
/// # Errors
/// The folder cannot be opened or listed, holds no sequence, or a sequence is given twice.
pub fn kitti_drives(kitti: &Path, sequences: &[String]) -> anyhow::Result<Vec<Drive>> {
    let dir = TrackingDir::open(kitti)?;
    Ok(labelled_drives(kitti, &sequence_ids(&dir, sequences)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn touch(p: &Path) {
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, "").unwrap();
    }

    #[test]
    fn a_manifest_names_labelled_and_images_only_sequences_and_bags() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        touch(&d.join("kitti/label_02/0000.txt"));
        touch(&d.join("kitti/label_02/0003.txt"));
        touch(&d.join("kitti/oxts/0000.txt"));
        touch(&d.join("kitti/oxts/0003.txt"));
        std::fs::create_dir_all(d.join("imported/image_02/run1")).unwrap();
        touch(&d.join("bags/run7.mcap"));
        touch(&d.join("bags/run8/run8_0.mcap"));
        touch(&d.join("bags/run8/metadata.yaml"));
        touch(&d.join("bags/run9/run9_0.mcap.zstd"));
        touch(&d.join("bags/run9/metadata.yaml"));
        touch(&d.join("bags/notes.txt"));
        std::fs::write(d.join("drives.txt"), "kitti 0003  # one of two\nimported\nbags\n").unwrap();
        let drives = manifest_drives(&d.join("drives.txt")).unwrap();
        let got: Vec<(&str, &str)> = drives.iter().map(|x| (x.name.as_str(), x.kind())).collect();
        assert_eq!(got, [("0003", "labelled"), ("run1", "images"), ("run7", "bag"), ("run8", "bag"), ("run9", "bag")]);
        assert!(drives[2].listed.ends_with("drives.txt line 3"), "{}", drives[2].listed);
        let folder = manifest_drives(&d.join("bags")).unwrap();
        assert_eq!(folder.iter().map(|x| x.name.as_str()).collect::<Vec<_>>(), ["run7", "run8", "run9"]);
        let picked = select_drives(drives, &["run7".into(), "0003".into()]).unwrap();
        assert_eq!(picked.iter().map(|x| x.name.as_str()).collect::<Vec<_>>(), ["run7", "0003"]);
    }

    #[test]
    fn unusable_manifests_are_named_by_line() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        touch(&d.join("a/label_02/0000.txt"));
        touch(&d.join("b/label_02/0000.txt"));
        touch(&d.join("bad.name.mcap"));
        let err = |text: &str| {
            std::fs::write(d.join("m.txt"), text).unwrap();
            format!("{:#}", manifest_drives(&d.join("m.txt")).unwrap_err())
        };
        let twice = err("a\nb\n");
        assert!(twice.contains("drive name 0000 is given twice") && twice.contains("m.txt line 2"), "{twice}");
        assert!(err("a 0001").contains("m.txt line 1: ") && err("a 0001").contains("holds no sequence 0001"));
        assert!(err("missing").contains("missing: no such file or folder"));
        assert!(err("a b c").contains("third field"));
        assert!(err("bad.name.mcap").contains("`bad.name` is not one"), "{}", err("bad.name.mcap"));
        let picked = select_drives(manifest_drives(&d.join("a")).unwrap(), &["0009".into()]).unwrap_err();
        assert!(picked.to_string().contains("no drive is named 0009 (the drives: 0000)"), "{picked}");
    }
}

#[cfg(all(test, not(feature = "bags")))]
mod tests_without_images_or_bags {
    use super::*;

    #[test]
    fn a_bag_drive_says_which_feature_the_build_lacks() {
        let e = imported_bag(Path::new("drives/run7.mcap"), "run7", Path::new("cache")).unwrap_err();
        let e = format!("{e:#}");
        assert!(e.contains("drive run7") && e.contains("run7.mcap") && e.contains("`bags` feature"), "{e}");
    }
}
