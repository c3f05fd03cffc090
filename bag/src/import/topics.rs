//! The topics of a bag: reading its messages in file order, and choosing the topic of each
//! role (by flag, or by message type and name).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail, ensure};

use super::{ImportOptions, Role};
use crate::ros2::{CAMERA_INFO, COMPRESSED_IMAGE, DETECTION_2D_ARRAY, IMAGE};

/// One topic of the bag.
#[derive(Debug, Clone)]
pub(super) struct Topic {
    pub(super) name: String,
    pub(super) schema: String,
    pub(super) encoding: String,
}

/// The `.mcap` files of a bag: the file itself, or a ROS 2 bag folder's files: those its
/// `metadata.yaml` lists, in its order, or else its `.mcap` files by name.
///
/// # Errors
/// A path that is neither, a folder without `.mcap` files, or a bag in another storage, named
/// with the conversion to use.
pub fn bag_files(path: &Path) -> anyhow::Result<Vec<PathBuf>> {
    if path.is_file() {
        return Ok(vec![path.to_path_buf()]);
    }
    ensure!(path.is_dir(), "{}: no such file or folder (expected an .mcap file or a ROS 2 bag folder)", path.display());
    if let Some(description) = crate::rosbag2::read_description(path)? {
        ensure!(
            description.storage == "mcap",
            "{}: a rosbag2 bag in {} storage: convert it to MCAP first (`ros2 bag convert`, or \
                `rosbags-convert --src {} --dst BAG_MCAP --dst-storage mcap`)",
            path.display(),
            description.storage,
            path.display()
        );
        for file in &description.files {
            ensure!(file.is_file(), "{}: listed in metadata.yaml, not in the folder", file.display());
        }
        ensure!(!description.files.is_empty(), "{}: metadata.yaml lists no file", path.display());
        return Ok(description.files);
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(path)
        .with_context(|| format!("reading {}", path.display()))?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| {
            p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.ends_with(".mcap") || n.ends_with(".mcap.zstd"))
        })
        .collect();
    files.sort();
    ensure!(
        !files.is_empty(),
        "{}: a folder without .mcap files (expected a ROS 2 bag in MCAP storage)",
        path.display()
    );
    Ok(files)
}

/// Calls `each` with every message of `files` in file order, with its index on its topic.
pub(super) fn for_each_message(
    files: &[PathBuf],
    mut each: impl FnMut(&Topic, usize, &mcap::Message<'_>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let mut counts: BTreeMap<String, usize> = BTreeMap::new();
    for file in files {
        let stream = super::container::open(file)?;
        for (read, m) in mcap::io::MessageReader::new(stream).enumerate() {
            let m = m.map_err(|e| {
                anyhow::anyhow!(
                    "{}: not a readable MCAP file after {read} messages: {e} (truncated or damaged?)",
                    file.display()
                )
            })?;
            let topic = Topic {
                name: m.channel.topic.clone(),
                schema: m.channel.schema.as_ref().map(|s| s.name.clone()).unwrap_or_default(),
                encoding: m.channel.message_encoding.clone(),
            };
            let index = counts.entry(topic.name.clone()).or_default();
            each(&topic, *index, &m)?;
            *index += 1;
        }
    }
    Ok(())
}

/// Every topic of the bag with its schema and message count.
pub(super) fn topics(files: &[PathBuf]) -> anyhow::Result<Vec<(Topic, usize)>> {
    let mut out: BTreeMap<String, (Topic, usize)> = BTreeMap::new();
    for_each_message(files, |t, _, _| {
        out.entry(t.name.clone()).or_insert_with(|| (t.clone(), 0)).1 += 1;
        Ok(())
    })?;
    Ok(out.into_values().collect())
}

pub(super) fn listing(topics: &[(Topic, usize)]) -> String {
    if topics.is_empty() {
        return "no topic with messages".into();
    }
    topics.iter().map(|(t, n)| format!("{} ({}, {n} messages)", t.name, t.schema)).collect::<Vec<_>>().join(", ")
}

/// The topic for `flag`: the given one (checked to exist with one of `schemas`), else the one
/// candidate of `schemas` whose name `matches`; `None` when there is none and it is optional.
pub(super) fn choose(
    all: &[(Topic, usize)],
    given: Option<&str>,
    schemas: &[&str],
    matches: impl Fn(&str) -> bool,
    flag: &str,
    required: bool,
) -> anyhow::Result<Option<String>> {
    if let Some(name) = given {
        let Some((t, _)) = all.iter().find(|(t, _)| t.name == name) else {
            bail!("{flag} {name}: no such topic in the bag; it has {}", listing(all));
        };
        ensure!(
            schemas.contains(&t.schema.as_str()),
            "{flag} {name}: a {} topic, expected {}",
            t.schema,
            schemas.join(" or ")
        );
        return Ok(Some(name.to_string()));
    }
    let found: Vec<&str> = all
        .iter()
        .filter(|(t, _)| schemas.contains(&t.schema.as_str()) && matches(&t.name.to_lowercase()))
        .map(|(t, _)| t.name.as_str())
        .collect();
    match found.as_slice() {
        [one] => Ok(Some((*one).to_string())),
        [] if !required => Ok(None),
        [] => bail!(
            "no {} topic for {flag} found; the bag has {}: choose one with {flag}",
            schemas.join(" or "),
            listing(all)
        ),
        many => bail!("{flag}: {} topics could be it ({}): choose one with {flag}", many.len(), many.join(", ")),
    }
}

/// The namespace of a topic (`/cam/left/image_raw` -> `/cam/left`).
pub(super) fn namespace(topic: &str) -> &str {
    topic.rsplit_once('/').map_or("", |(ns, _)| ns)
}

/// image_transport's transports, which publish under the raw topic's name plus their own
/// (`/cam/left/image_raw/compressed`).
const TRANSPORTS: [&str; 5] = ["compressed", "compresseddepth", "theora", "zstd", "ffmpeg"];

/// The camera's namespace of an image topic, where its CameraInfo is: the topic's namespace,
/// one level further up for an image_transport topic (`/cam/left/image_raw/compressed` ->
/// `/cam/left`).
pub(super) fn camera_namespace(topic: &str) -> &str {
    match topic.rsplit_once('/') {
        Some((raw, transport)) if TRANSPORTS.contains(&transport.to_lowercase().as_str()) => namespace(raw),
        _ => namespace(topic),
    }
}

/// The topics of every role, chosen as the module docs say.
#[derive(Debug, Clone)]
pub(super) struct Chosen {
    pub(super) images: Vec<(Role, String)>,
    pub(super) left_info: String,
    pub(super) right_info: Option<String>,
    pub(super) detections: Option<String>,
}

pub(super) fn choose_topics(all: &[(Topic, usize)], opt: &ImportOptions) -> anyhow::Result<Chosen> {
    ensure!(
        !all.is_empty(),
        "the bag holds no message (expected camera images, their camera info and optionally detections)"
    );
    let images = [IMAGE, COMPRESSED_IMAGE];
    let is_depth = |n: &str| n.contains("depth");
    let is_mask = |n: &str| n.contains("mask") || n.contains("instance") || n.contains("segment");
    let depth = choose(all, opt.depth.as_deref(), &images, is_depth, "--depth", false)?;
    let masks = choose(all, opt.masks.as_deref(), &images, is_mask, "--masks-topic", false)?;
    let plain = |n: &str| !is_depth(n) && !is_mask(n);
    let right = if opt.rgbd {
        None
    } else {
        choose(all, opt.right.as_deref(), &images, |n| plain(n) && n.contains("right"), "--right", false)?
    };
    let left = match (&opt.left, &right) {
        (Some(_), _) | (None, Some(_)) => {
            choose(all, opt.left.as_deref(), &images, |n| plain(n) && n.contains("left"), "--left", true)?
        }
        // RGB-D: the one colour topic.
        (None, None) => choose(all, None, &images, |n| plain(n) && !n.contains("right"), "--left", true)?,
    }
    .unwrap_or_default();
    ensure!(
        right.is_some() || depth.is_some(),
        "no right image topic and no depth topic: a stereo pair (--left, --right) or RGB-D (--left, --depth) is needed; the bag has {}",
        listing(all)
    );
    let info_of = |image: &str, given: Option<&str>, flag: &str, required: bool| {
        let ns = camera_namespace(image).to_lowercase();
        choose(all, given, &[CAMERA_INFO], |n| namespace(n) == ns, flag, required)
    };
    let left_info = info_of(&left, opt.left_info.as_deref(), "--left-info", true)?.unwrap_or_default();
    let right_info = match &right {
        Some(r) => info_of(r, opt.right_info.as_deref(), "--right-info", true)?,
        None => None,
    };
    let detections = choose(all, opt.detections.as_deref(), &[DETECTION_2D_ARRAY], |_| true, "--detections", false)?;
    let mut chosen = vec![(Role::Left, left)];
    chosen.extend(right.map(|t| (Role::Right, t)));
    chosen.extend(depth.map(|t| (Role::Depth, t)));
    chosen.extend(masks.map(|t| (Role::Mask, t)));
    Ok(Chosen { images: chosen, left_info, right_info, detections })
}
