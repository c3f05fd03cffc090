//! `dynotraj import`: a ROS 2 bag (MCAP) to a sequence in the KITTI tracking layout that
//! `dynotraj track` reads; `dynotraj export-bag`: the other way, a layout sequence as a bag.

use std::path::PathBuf;

use anyhow::Context as _;
use clap::Args;
use dynotraj_bag::from_layout::BagContents;
use dynotraj_bag::import::{ImportOptions, import};

use crate::numbers::{frame_rate, positive};

/// Options of `dynotraj import`.
#[derive(Debug, Args)]
#[command(after_help = "Topics left out are found by their message type and name: image topics \
    (sensor_msgs/Image or CompressedImage) with `left` / `right` in the name for a stereo pair, \
    `depth` for RGB-D, `mask` / `instance` for instance masks; each camera's CameraInfo in its \
    image topic's namespace; the one vision_msgs/Detection2DArray topic. A frame is a left \
    image with the other topics' messages nearest in header stamp within --sync-tolerance-ms.")]
pub struct ImportArgs {
    /// The bag: an .mcap file, or a ROS 2 bag folder of .mcap files.
    #[arg(long, value_name = "PATH")]
    pub bag: PathBuf,
    /// The new folder for the KITTI layout (image_02/, image_03/ or depth_02/, calib/, times/,
    /// label_02/ with detections, instance_02/ with masks).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// The drive's sequence id in the layout (its files' names).
    #[arg(long, default_value = "0000", value_parser = crate::numbers::sequence_id, value_name = "ID")]
    pub name: String,
    /// Left (or RGB) image topic.
    #[arg(long, value_name = "TOPIC")]
    pub left: Option<String>,
    /// Right image topic.
    #[arg(long, value_name = "TOPIC")]
    pub right: Option<String>,
    /// Depth image topic (16UC1 millimetres or 32FC1 metres).
    #[arg(long, value_name = "TOPIC")]
    pub depth: Option<String>,
    /// Instance-mask image topic (mono8 or 16UC1 ids, 0 = background).
    #[arg(long = "masks-topic", value_name = "TOPIC")]
    pub masks: Option<String>,
    /// vision_msgs/Detection2DArray topic (written as label_02 rows: track with
    /// `--masks detections`).
    #[arg(long, value_name = "TOPIC")]
    pub detections: Option<String>,
    /// Left camera's CameraInfo topic.
    #[arg(long, value_name = "TOPIC")]
    pub left_info: Option<String>,
    /// Right camera's CameraInfo topic.
    #[arg(long, value_name = "TOPIC")]
    pub right_info: Option<String>,
    /// An RGB-D bag: the left image and a depth topic, no right camera.
    #[arg(long)]
    pub rgbd: bool,
    /// Largest header-stamp difference between the messages of one frame, milliseconds.
    #[arg(long, default_value_t = dynotraj_bag::import::DEFAULT_SYNC_TOLERANCE_NS as f64 / 1e6, value_parser = positive, value_name = "MS")]
    pub sync_tolerance_ms: f64,
    /// Stereo baseline in metres, where the right CameraInfo's projection does not carry it.
    #[arg(long, value_parser = positive, value_name = "METRES")]
    pub baseline: Option<f64>,
    /// Only the first N frames (at least 1).
    #[arg(long, value_parser = crate::numbers::at_least_one, value_name = "N")]
    pub frames: Option<usize>,
}

/// Imports and says what was written and how to go on.
///
/// # Errors
/// See [`dynotraj_bag::import::import`].
pub fn run(args: &ImportArgs) -> anyhow::Result<()> {
    let opt = ImportOptions {
        left: args.left.clone(),
        right: args.right.clone(),
        depth: args.depth.clone(),
        masks: args.masks.clone(),
        detections: args.detections.clone(),
        left_info: args.left_info.clone(),
        right_info: args.right_info.clone(),
        sync_tolerance_ns: (args.sync_tolerance_ms * 1e6).round() as i64,
        baseline_m: args.baseline,
        max_frames: args.frames,
        rgbd: args.rgbd,
    };
    let s = import(&args.bag, &args.name, &args.out, &opt)?;
    for (role, topic) in &s.topics {
        println!("{role:>18}: {topic}");
    }
    let dropped: Vec<String> = s.unmatched.iter().filter(|(_, n)| *n > 0).map(|(t, n)| format!("{n} of {t}")).collect();
    println!(
        "imported {} frames at {:.2} Hz (measured from the left stamps), {} detection boxes{} into {}",
        s.frames,
        s.rate_hz,
        s.boxes,
        if dropped.is_empty() {
            String::new()
        } else {
            format!("; images without a frame, dropped: {}", dropped.join(", "))
        },
        args.out.display()
    );
    let depth = if s.topics.iter().any(|(r, _)| r == "depth") { " --depth given" } else { "" };
    let masks = if s.topics.iter().any(|(r, _)| r == "mask") {
        " --masks png"
    } else if s.boxes > 0 {
        " --masks detections"
    } else {
        " --masks motion"
    };
    // track reads the capture times (times/) the import wrote: no --rate needed.
    println!(
        "next: dynotraj track --kitti {} --sequences {}{depth}{masks} --out TRACKS",
        args.out.display(),
        args.name
    );
    Ok(())
}

/// Options of `dynotraj export-bag`.
#[derive(Debug, Args)]
pub struct ExportBagArgs {
    /// A folder in the KITTI tracking layout with images (image_02/, image_03/, calib/;
    /// instance_02/ and label_02/ when present), e.g. sim/data/image_sim.
    #[arg(long, env = "DYNOTRAJ_KITTI", hide_env_values = true, value_name = "DIR")]
    pub kitti: PathBuf,
    /// The sequences to write, comma-separated: one bag each.
    #[arg(long = "sequences", visible_alias = "sequence", value_delimiter = ',', required = true, value_parser = crate::numbers::sequence_id, value_name = "LIST")]
    pub sequences: Vec<String>,
    /// Frame rate of the stamps, Hz.
    #[arg(long, default_value_t = 10.0, value_parser = frame_rate, value_name = "HZ")]
    pub rate: f64,
    /// Folder for the bags: one rosbag2 bag folder each, `<DIR>/<sequence>/` (metadata.yaml
    /// and `<sequence>_0.mcap`).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Write the stereo images and their camera infos only, as a camera driver (or a
    /// converter such as kitti2mcap) records a drive: no depth, instance masks or detections,
    /// so that the front-end finds the moving objects itself (`--masks motion`).
    #[arg(long)]
    pub camera_only: bool,
}

/// Writes the bags and says where.
///
/// # Errors
/// See [`dynotraj_bag::from_layout::layout_to_bag`].
pub fn export_bag(args: &ExportBagArgs) -> anyhow::Result<()> {
    dynotraj_formats::atomic::output_folder("--out", &args.out)?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    for seq in &args.sequences {
        let bag = args.out.join(seq);
        let contents = if args.camera_only { BagContents::CameraOnly } else { BagContents::Everything };
        let frames = dynotraj_bag::from_layout::layout_to_bag(&args.kitti, seq, &bag, args.rate, contents)?;
        println!("wrote {frames} frames of sequence {seq} as a ROS 2 bag to {}", bag.display());
    }
    Ok(())
}
