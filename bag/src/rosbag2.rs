//! rosbag2's storage layout: a bag is a folder holding `metadata.yaml` and its `.mcap` files
//! (`<name>_0.mcap`, ...). The writer makes such a folder as `ros2 bag record` does (header
//! profile `ros2`, `ros2msg` schemas, each channel's offered QoS, the `rosbag2` metadata record,
//! and `metadata.yaml` in rosbag2's version 9 format), so that rosbag2, rosbags and Foxglove
//! read it; the reader takes what an import needs from another tool's `metadata.yaml`.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail, ensure};

use crate::ros2;

/// The name of a bag folder's description.
pub const METADATA_FILE: &str = "metadata.yaml";

/// The largest `metadata.yaml` read: a bag of thousands of topics and files fits in far less.
pub const MAX_METADATA_BYTES: u64 = 16 << 20;

/// The version of rosbag2's `metadata.yaml` format written (ROS 2 Jazzy's).
const METADATA_VERSION: u32 = 9;

/// The QoS every channel is offered with: what a camera driver's default publisher offers
/// (keep the last 10, reliable, volatile, no deadline, lifespan or lease), so that
/// `ros2 bag play` republishes the topics as they were recorded. Durations of "infinite" are
/// rosbag2's `sec: 9223372036, nsec: 854775807`.
const OFFERED_QOS: [(&str, &str); 6] = [
    ("history", "keep_last"),
    ("depth", "10"),
    ("reliability", "reliable"),
    ("durability", "volatile"),
    ("liveliness", "automatic"),
    ("avoid_ros_namespace_conventions", "false"),
];

/// The QoS durations, all infinite.
const QOS_DURATIONS: [&str; 3] = ["deadline", "lifespan", "liveliness_lease_duration"];

/// The offered QoS list as YAML, each line indented by `indent` spaces (the channel metadata
/// holds it at indent 0, `metadata.yaml` nested under its topic).
fn offered_qos_yaml(indent: usize) -> String {
    let pad = " ".repeat(indent);
    let mut out = String::new();
    let mut first = true;
    for (key, value) in OFFERED_QOS {
        let lead = if first { "- " } else { "  " };
        first = false;
        let _ = writeln!(out, "{pad}{lead}{key}: {value}");
    }
    for key in QOS_DURATIONS {
        let _ = writeln!(out, "{pad}  {key}:\n{pad}    sec: 9223372036\n{pad}    nsec: 854775807");
    }
    out
}

/// A YAML scalar for `text`: a JSON string is a valid YAML double-quoted scalar.
fn quoted(text: &str) -> String {
    serde_json::Value::String(text.to_string()).to_string()
}

/// One topic being written.
#[derive(Debug)]
struct Topic {
    channel: u16,
    schema: String,
    messages: u64,
}

/// A rosbag2 bag folder being written: under a staging name beside the final one until
/// [`Rosbag2Writer::finish`] renames it, and removed if it is dropped unfinished, so that no
/// bag cut short looks complete.
pub struct Rosbag2Writer {
    folder: PathBuf,
    staging: PathBuf,
    file_name: String,
    writer: Option<mcap::Writer<BufWriter<File>>>,
    topics: BTreeMap<String, Topic>,
    sequence: u32,
    first_ns: Option<u64>,
    last_ns: u64,
}

impl std::fmt::Debug for Rosbag2Writer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Rosbag2Writer").field("folder", &self.folder).field("topics", &self.topics).finish()
    }
}

impl Rosbag2Writer {
    /// Starts the bag folder `folder` (its name names the bag and its `.mcap` file). A folder
    /// already there is replaced at [`Rosbag2Writer::finish`] only if it holds nothing but a
    /// bag's files (`metadata.yaml`, `.mcap` files).
    ///
    /// # Errors
    /// `folder` is a file or a folder holding other files; the staging folder cannot be made.
    pub fn create(folder: &Path) -> anyhow::Result<Self> {
        let name = folder
            .file_name()
            .and_then(|n| n.to_str())
            .with_context(|| format!("{}: expected a bag folder name in UTF-8", folder.display()))?
            .to_string();
        replaceable_bag(folder)?;
        let staging = folder.with_file_name(format!(".{name}.partial-{}", std::process::id()));
        if staging.exists() {
            std::fs::remove_dir_all(&staging).with_context(|| format!("removing {}", staging.display()))?;
        }
        std::fs::create_dir_all(&staging).with_context(|| format!("creating {}", staging.display()))?;
        let file_name = format!("{name}_0.mcap");
        let path = staging.join(&file_name);
        let opened = File::create(&path).with_context(|| format!("creating {}", path.display())).and_then(|file| {
            mcap::WriteOptions::new()
                .profile("ros2")
                .library(concat!("dynotraj-", env!("CARGO_PKG_VERSION")))
                .create(BufWriter::new(file))
                .with_context(|| format!("writing {}", path.display()))
        });
        let writer = match opened {
            Ok(w) => w,
            Err(e) => {
                let _ = std::fs::remove_dir_all(&staging);
                return Err(e);
            }
        };
        Ok(Self {
            folder: folder.to_path_buf(),
            staging,
            file_name,
            writer: Some(writer),
            topics: BTreeMap::new(),
            sequence: 0,
            first_ns: None,
            last_ns: 0,
        })
    }

    /// The bag folder this writer makes.
    #[must_use]
    pub fn folder(&self) -> &Path {
        &self.folder
    }

    /// Writes one CDR message of type `schema` (e.g. [`ros2::IMAGE`]) on `topic`, logged at
    /// `log_ns` nanoseconds since the epoch.
    ///
    /// # Errors
    /// A type with no definition in [`ros2`], a topic written before with another type, or
    /// the write failed.
    pub fn write(&mut self, topic: &str, schema: &str, log_ns: u64, payload: &[u8]) -> anyhow::Result<()> {
        let Some(writer) = self.writer.as_mut() else { bail!("{}: the bag is finished", self.folder.display()) };
        let channel = match self.topics.get_mut(topic) {
            Some(t) => {
                ensure!(t.schema == schema, "topic {topic}: written as {} before, now as {schema}", t.schema);
                t.messages += 1;
                t.channel
            }
            None => {
                // The definition text as rosbag2 writes it, so that ROS 2 tools decode the payloads.
                let text = ros2::schema_text(schema).with_context(|| format!("no message definition of {schema}"))?;
                let schema_id = writer.add_schema(schema, "ros2msg", text.as_bytes())?;
                let metadata = BTreeMap::from([("offered_qos_profiles".to_string(), offered_qos_yaml(0))]);
                let channel = writer.add_channel(schema_id, topic, ros2::CDR, &metadata)?;
                self.topics.insert(topic.to_string(), Topic { channel, schema: schema.to_string(), messages: 1 });
                channel
            }
        };
        self.sequence += 1;
        self.first_ns = Some(self.first_ns.map_or(log_ns, |f| f.min(log_ns)));
        self.last_ns = self.last_ns.max(log_ns);
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence: self.sequence,
            log_time: log_ns,
            publish_time: log_ns,
        };
        writer.write_to_known_channel(&header, payload)?;
        Ok(())
    }

    /// The description of the bag written so far, as `metadata.yaml` holds it under
    /// `rosbag2_bagfile_information` (indented by `indent` spaces).
    fn description(&self, indent: usize) -> String {
        let pad = " ".repeat(indent);
        let start = self.first_ns.unwrap_or(0);
        let duration = self.last_ns.saturating_sub(start);
        let messages: u64 = self.topics.values().map(|t| t.messages).sum();
        let file = quoted(&self.file_name);
        let mut y = String::new();
        let _ = writeln!(y, "{pad}version: {METADATA_VERSION}");
        let _ = writeln!(y, "{pad}storage_identifier: mcap");
        let _ = writeln!(y, "{pad}duration:\n{pad}  nanoseconds: {duration}");
        let _ = writeln!(y, "{pad}starting_time:\n{pad}  nanoseconds_since_epoch: {start}");
        let _ = writeln!(y, "{pad}message_count: {messages}");
        let _ = writeln!(y, "{pad}topics_with_message_count:");
        for (name, t) in &self.topics {
            let _ = writeln!(y, "{pad}  - topic_metadata:");
            let _ = writeln!(y, "{pad}      name: {}", quoted(name));
            let _ = writeln!(y, "{pad}      type: {}", quoted(&t.schema));
            let _ = writeln!(y, "{pad}      serialization_format: {}", ros2::CDR);
            let _ = writeln!(y, "{pad}      offered_qos_profiles:");
            y.push_str(&offered_qos_yaml(indent + 8));
            // The type's REP 2011 hash is not computed: rosbag2 leaves it empty when unknown.
            let _ = writeln!(y, "{pad}      type_description_hash: \"\"");
            let _ = writeln!(y, "{pad}    message_count: {}", t.messages);
        }
        let _ = writeln!(y, "{pad}compression_format: \"\"");
        let _ = writeln!(y, "{pad}compression_mode: \"\"");
        let _ = writeln!(y, "{pad}relative_file_paths:\n{pad}  - {file}");
        let _ = writeln!(y, "{pad}files:\n{pad}  - path: {file}");
        let _ = writeln!(y, "{pad}    starting_time:\n{pad}      nanoseconds_since_epoch: {start}");
        let _ = writeln!(y, "{pad}    duration:\n{pad}      nanoseconds: {duration}");
        let _ = writeln!(y, "{pad}    message_count: {messages}");
        let _ = writeln!(y, "{pad}custom_data: ~");
        let _ = writeln!(y, "{pad}ros_distro: \"\"");
        y
    }

    /// Ends the MCAP file, writes `metadata.yaml` and renames the staging folder to the bag's
    /// name (replacing a bag folder there); returns the messages written.
    ///
    /// # Errors
    /// No message was written, or a write or the rename failed (the staging folder is removed).
    pub fn finish(mut self) -> anyhow::Result<u64> {
        let done = self.finish_staging();
        if done.is_err() {
            let _ = std::fs::remove_dir_all(&self.staging);
        }
        done
    }

    fn finish_staging(&mut self) -> anyhow::Result<u64> {
        let messages: u64 = self.topics.values().map(|t| t.messages).sum();
        ensure!(messages > 0, "{}: no message to write", self.folder.display());
        let description = self.description(0);
        let mut writer = self.writer.take().with_context(|| format!("{}: finished twice", self.folder.display()))?;
        let record = mcap::records::Metadata {
            name: "rosbag2".into(),
            metadata: BTreeMap::from([("serialized_metadata".to_string(), description)]),
        };
        writer.write_metadata(&record)?;
        writer.finish().with_context(|| format!("finishing {}", self.staging.join(&self.file_name).display()))?;
        drop(writer);
        let yaml = format!("rosbag2_bagfile_information:\n{}", self.description(2));
        let meta = self.staging.join(METADATA_FILE);
        dynotraj_formats::atomic::write_file(&meta, yaml).with_context(|| format!("writing {}", meta.display()))?;
        replaceable_bag(&self.folder)?;
        if self.folder.exists() {
            std::fs::remove_dir_all(&self.folder)
                .with_context(|| format!("replacing the bag folder {}", self.folder.display()))?;
        }
        std::fs::rename(&self.staging, &self.folder)
            .with_context(|| format!("renaming {} to {}", self.staging.display(), self.folder.display()))?;
        Ok(messages)
    }
}

impl Drop for Rosbag2Writer {
    fn drop(&mut self) {
        if self.writer.is_some() {
            // Dropped unfinished (an error on the way): nothing that looks like a bag stays.
            let _ = std::fs::remove_dir_all(&self.staging);
        }
    }
}

/// Checks that a bag folder may be (re)placed at `folder`: nothing is there, or a folder
/// holding only a bag's files.
fn replaceable_bag(folder: &Path) -> anyhow::Result<()> {
    let Ok(meta) = std::fs::symlink_metadata(folder) else { return Ok(()) };
    ensure!(
        meta.is_dir(),
        "{}: something other than a folder is there; a bag folder replaces only a bag folder",
        folder.display()
    );
    for entry in std::fs::read_dir(folder).with_context(|| format!("reading {}", folder.display()))? {
        let path = entry.with_context(|| format!("reading {}", folder.display()))?.path();
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
        ensure!(
            name == METADATA_FILE || name.ends_with(".mcap"),
            "{}: a folder holding {name}, not only a bag's files: not replaced (give another --out)",
            folder.display()
        );
    }
    Ok(())
}

/// What an import needs from a bag folder's `metadata.yaml`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BagDescription {
    /// The storage plugin: `mcap` or `sqlite3`.
    pub storage: String,
    /// The bag's files, in the order `metadata.yaml` lists them, as paths in the folder.
    pub files: Vec<PathBuf>,
    /// `zstd` when the bag is compressed, else empty.
    pub compression_format: String,
    /// `file` (each file compressed whole), `message` (each payload), or empty.
    pub compression_mode: String,
}

/// Reads `folder/metadata.yaml` when there is one.
///
/// # Errors
/// The file cannot be read, is not YAML, or lacks `rosbag2_bagfile_information`'s
/// `relative_file_paths` or `storage_identifier`, named.
pub fn read_description(folder: &Path) -> anyhow::Result<Option<BagDescription>> {
    let path = folder.join(METADATA_FILE);
    if !path.is_file() {
        return Ok(None);
    }
    let bytes = dynotraj_formats::bounded::read_at_most(&path, MAX_METADATA_BYTES, "a rosbag2 metadata.yaml")?;
    let text = String::from_utf8(bytes).with_context(|| format!("{}: expected UTF-8 text", path.display()))?;
    let docs = yaml_rust2::YamlLoader::load_from_str(&text)
        .map_err(|e| anyhow::anyhow!("{}: not YAML: {e}", path.display()))?;
    let info = docs.first().map(|d| &d["rosbag2_bagfile_information"]);
    let Some(info) = info.filter(|i| !i.is_badvalue()) else {
        bail!("{}: expected a rosbag2 description (rosbag2_bagfile_information:)", path.display())
    };
    let field = |key: &str| info[key].as_str().unwrap_or_default().to_string();
    let storage = info["storage_identifier"]
        .as_str()
        .with_context(|| format!("{}: storage_identifier: expected mcap or sqlite3", path.display()))?
        .to_string();
    let listed = info["relative_file_paths"]
        .as_vec()
        .with_context(|| format!("{}: relative_file_paths: expected a list of files", path.display()))?;
    let mut files = Vec::with_capacity(listed.len());
    for (k, f) in listed.iter().enumerate() {
        let name = f
            .as_str()
            .with_context(|| format!("{}: relative_file_paths[{k}]: expected a file name", path.display()))?;
        // Only the file name counts, as in rosbag2: a listed path never leaves the folder.
        let base = Path::new(name)
            .file_name()
            .with_context(|| format!("{}: relative_file_paths[{k}]: {name:?} names no file", path.display()))?;
        files.push(folder.join(base));
    }
    Ok(Some(BagDescription {
        storage,
        files,
        compression_format: field("compression_format"),
        compression_mode: field("compression_mode").to_lowercase(),
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros2::{Header, IMAGE, Image, Time};

    fn image_payload(k: i32) -> Vec<u8> {
        let img = Image {
            header: Header { stamp: Time { sec: k, nanosec: 0 }, frame_id: "cam".into() },
            height: 1,
            width: 2,
            encoding: "mono8".into(),
            is_bigendian: 0,
            step: 2,
            data: vec![1, 2],
        };
        ros2::encode(&img).unwrap()
    }

    #[test]
    fn a_bag_folder_describes_its_topics_and_reads_back() {
        let tmp = tempfile::tempdir().unwrap();
        let folder = tmp.path().join("drive");
        let mut bag = Rosbag2Writer::create(&folder).unwrap();
        for k in 0..3 {
            bag.write("/cam/image_raw", IMAGE, 1_000_000_000 * (k as u64 + 1), &image_payload(k)).unwrap();
        }
        assert_eq!(bag.finish().unwrap(), 3);
        let names: Vec<String> =
            std::fs::read_dir(tmp.path()).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
        assert_eq!(names, ["drive"], "no staging folder left");
        let d = read_description(&folder).unwrap().unwrap();
        assert_eq!(d.storage, "mcap");
        assert_eq!(d.files, [folder.join("drive_0.mcap")]);
        assert_eq!((d.compression_format.as_str(), d.compression_mode.as_str()), ("", ""));
        let yaml = std::fs::read_to_string(folder.join(METADATA_FILE)).unwrap();
        let doc = &yaml_rust2::YamlLoader::load_from_str(&yaml).unwrap()[0]["rosbag2_bagfile_information"];
        assert_eq!(doc["message_count"].as_i64(), Some(3));
        assert_eq!(doc["duration"]["nanoseconds"].as_i64(), Some(2_000_000_000));
        let topic = &doc["topics_with_message_count"][0];
        assert_eq!(topic["topic_metadata"]["type"].as_str(), Some(IMAGE));
        assert_eq!(topic["topic_metadata"]["offered_qos_profiles"][0]["reliability"].as_str(), Some("reliable"));
        // The MCAP file: profile ros2, QoS on the channel, the description as a metadata record.
        let bytes = std::fs::read(folder.join("drive_0.mcap")).unwrap();
        let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
        let channel = summary.channels.values().next().unwrap();
        let qos = &yaml_rust2::YamlLoader::load_from_str(&channel.metadata["offered_qos_profiles"]).unwrap()[0];
        assert_eq!(qos[0]["history"].as_str(), Some("keep_last"));
        assert_eq!(qos[0]["deadline"]["sec"].as_i64(), Some(9_223_372_036));
        assert!(bytes.windows(8).any(|w| w == b"\x04\x00\x00\x00ros2"), "the header's profile is ros2");
    }

    #[test]
    fn an_unfinished_bag_leaves_nothing_and_a_foreign_folder_is_not_replaced() {
        let tmp = tempfile::tempdir().unwrap();
        let folder = tmp.path().join("drive");
        let mut bag = Rosbag2Writer::create(&folder).unwrap();
        bag.write("/cam/image_raw", IMAGE, 1, &image_payload(0)).unwrap();
        drop(bag);
        assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 0);
        let empty = Rosbag2Writer::create(&folder).unwrap();
        let e = empty.finish().unwrap_err().to_string();
        assert!(e.ends_with("drive: no message to write"), "{e}");
        assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 0);
        std::fs::create_dir(&folder).unwrap();
        std::fs::write(folder.join("notes.txt"), "mine").unwrap();
        let e = Rosbag2Writer::create(&folder).unwrap_err().to_string();
        assert!(e.contains("a folder holding notes.txt, not only a bag's files"), "{e}");
    }

    #[test]
    fn a_description_without_its_fields_is_named() {
        let tmp = tempfile::tempdir().unwrap();
        std::fs::write(tmp.path().join(METADATA_FILE), "rosbag2_bagfile_information:\n  version: 9\n").unwrap();
        let e = read_description(tmp.path()).unwrap_err().to_string();
        assert!(e.ends_with("metadata.yaml: storage_identifier: expected mcap or sqlite3"), "{e}");
        std::fs::write(tmp.path().join(METADATA_FILE), "just: [unclosed").unwrap();
        let e = read_description(tmp.path()).unwrap_err().to_string();
        assert!(e.contains("metadata.yaml: not YAML"), "{e}");
        std::fs::write(
            tmp.path().join(METADATA_FILE),
            "rosbag2_bagfile_information:\n  storage_identifier: mcap\n  relative_file_paths: [../../etc/x_0.mcap]\n",
        )
        .unwrap();
        let d = read_description(tmp.path()).unwrap().unwrap();
        assert_eq!(d.files, [tmp.path().join("x_0.mcap")], "a listed path stays in the folder");
    }
}
