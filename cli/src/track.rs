//! `dynotraj track`: the front-end over an image sequence in the KITTI tracking layout (a real
//! KITTI download, or `dynotraj simulate`'s output), writing the tracks file that
//! `dynotraj estimate --tracks` and `dynotraj stream --tracks` read. Also:
//! `--cost` times the stages at KITTI resolution on rendered frames, and `--check` measures the
//! front-end on the real KITTI images in ../shared/kitti (stereo D1, KLT survival, ego-motion).
//! `--record` also writes what the front-end saw and found for Foxglove (MCAP).

use std::path::PathBuf;

use anyhow::Context as _;
use clap::Args;
use dynotraj_eval::recording::{record_path, recorded};

use super::data_args::FrameRateArg;
use super::estimated_args::{PointDepthArgs, RenderOptics};
use super::progress::progress;
use dynotraj_eval::jobs::{default_jobs, parse_jobs};
use dynotraj_eval::motion_segmentation::motion_segmentation;
use dynotraj_eval::report::Format;
use dynotraj_eval::tracking::{
    DisparitySettings, TrackSettings, counters_table, disparity_error, image_sequences, real_image_checks, stage_times,
    track_sequence,
};
use dynotraj_formats::tracks_file::tracks_path;
use dynotraj_frontend::TrackerParams;
use dynotraj_frontend::sequence::{DepthMode, MaskMode};
use dynotraj_sim::image_sim::RenderedMasks;
use dynotraj_sources::estimation::simulated::EvalOptions;

/// Options of `dynotraj track`.
#[derive(Debug, Args)]
pub struct TrackArgs {
    /// A folder in the KITTI tracking layout (image_02/, image_03/, calib/, label_02/; see
    /// `dynotraj simulate` for the optional depth_02/ and instance_02/).
    #[arg(long, env = "DYNOTRAJ_KITTI", hide_env_values = true, value_name = "DIR", required_unless_present_any = ["cost", "check"])]
    pub kitti: Option<PathBuf>,
    /// Sequences to track, comma-separated (default: every sequence with images in
    /// image_02/).
    #[arg(long = "sequences", visible_alias = "sequence", value_delimiter = ',', value_parser = crate::numbers::sequence_id, value_name = "LIST")]
    pub sequences: Vec<String>,
    /// Folder for the tracks files, one per sequence: `<DIR>/<sequence>.dtt`.
    #[arg(long, value_name = "DIR", required_unless_present_any = ["cost", "check", "disparity_error", "segmentation"])]
    pub out: Option<PathBuf>,
    /// Depth from stereo matching or from the given depth maps (depth_02/).
    #[arg(long, value_parser = crate::numbers::choices(&DepthMode::CHOICES), default_value = "stereo")]
    pub depth: DepthMode,
    /// Instance masks: instance_02/ PNGs, label_02/ boxes refined by depth (with their ids, or
    /// re-identified by IoU as raw detections), or none.
    #[arg(long, value_parser = crate::numbers::choices(&MaskMode::CHOICES), default_value = "auto")]
    pub masks: MaskMode,
    /// Use at most this many frames.
    #[arg(long, value_name = "N")]
    pub frames: Option<usize>,
    /// The frame rate.
    #[command(flatten)]
    pub rate: FrameRateArg,
    /// Print the front-end's counters.
    #[arg(long)]
    pub counters: bool,
    /// Also write recordings to look at in Foxglove: MCAP (Foxglove's schemas; --record-encoding) with, per
    /// frame at its capture time, the left image as it is on disk (`/camera/left/compressed`),
    /// the frame's tracks back-projected into the camera frame (`/tracks/static`;
    /// `/tracks/objects` with each point's `object_id`) and drawn over the image
    /// (`/camera/left/annotations`). One sequence: FILE is the recording; several, or FILE an
    /// existing folder: FILE is a folder of `<sequence>.mcap`.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["cost", "check"])]
    pub record: Option<PathBuf>,
    /// The recordings' encoding.
    #[command(flatten)]
    pub record_encoding: crate::record_args::RecordEncodingArgs,
    /// Time the stages on rendered frames at 1242 x 375 (the synthetic drive) instead; with
    /// `--masks boxes` (or detections) masks come from 2D boxes refined by depth, with `--masks
    /// motion` from motion segmentation.
    #[arg(long, alias = "bench")]
    pub cost: bool,
    /// Measure the front-end on the real KITTI images of this folder (odometry/06,
    /// stereo2015/) instead, e.g. ../shared/kitti.
    #[arg(long, value_name = "DIR")]
    pub check: Option<PathBuf>,
    /// Render the sequences of --kitti at KITTI's resolution (its labels on its ego poses),
    /// track them and print the disparity error of every sent point against the rendering's
    /// exact depth, by range band, sub-pixel fraction and distance to the mask edge; with
    /// --out, also as disparity_error.{md,csv,json} there.
    #[arg(long, conflicts_with_all = ["cost", "check", "record"])]
    pub disparity_error: bool,
    /// Render the sequences of --kitti as --disparity-error does, track them with motion masks
    /// and print how the masks find the moving objects against the renderings' truth: recall by
    /// range band and class, precision of the segments, id switches, frames to the first
    /// detection; with --out, also as segmentation_{recall,precision}.{md,csv,json} there.
    #[arg(long, conflicts_with_all = ["cost", "check", "record", "disparity_error"])]
    pub segmentation: bool,
    /// How sent points get their depth.
    #[command(flatten)]
    pub point_depth: PointDepthArgs,
    /// Camera model of the renderings of --disparity-error.
    #[arg(long, value_enum, default_value_t = RenderOptics::Ideal, value_name = "MODEL")]
    pub render_optics: RenderOptics,
    /// Sequences rendered at once with --disparity-error (default: the number of cores).
    #[arg(long, env = "DYNOTRAJ_JOBS", hide_env_values = true, default_value_t = default_jobs(), hide_default_value = true, value_parser = parse_jobs, value_name = "N")]
    pub jobs: usize,
}

impl TrackArgs {
    /// The tracker's settings these options give.
    #[must_use]
    pub fn tracker(&self) -> TrackerParams {
        self.point_depth.options().tracker()
    }
}

/// Runs the command.
///
/// # Errors
/// Reading, tracking or writing errors, named.
pub fn run(args: &TrackArgs) -> anyhow::Result<()> {
    args.out.as_deref().map(|d| dynotraj_formats::atomic::output_folder("--out", d)).transpose()?;
    anyhow::ensure!(
        args.rate.hz.is_finite() && args.rate.hz > 0.0,
        "--rate: expected a positive frame rate, found {}",
        args.rate.hz
    );
    let stereo = args.point_depth.options().stereo(1.0);
    if let Some(root) = &args.check {
        print!("{}", real_image_checks(root, stereo, args.tracker())?);
        return Ok(());
    }
    if args.disparity_error || args.segmentation {
        let Some(dir) = &args.kitti else { anyhow::bail!("--disparity-error and --segmentation need --kitti") };
        return rendered_measurement(dir, args);
    }
    if args.cost {
        let (masks, said) = match args.masks {
            MaskMode::Boxes | MaskMode::Detections => (RenderedMasks::Boxes, "2D boxes refined by depth, IoU ids"),
            MaskMode::Motion => (RenderedMasks::Motion, "motion segmentation"),
            MaskMode::Auto | MaskMode::Png | MaskMode::None => (RenderedMasks::Ids, "rendered instance ids"),
        };
        let (times, stats) = dynotraj_frontend::cost::run(args.frames.unwrap_or(30), (stereo, args.tracker()), masks)?;
        println!("masks: {said}");
        print!("{}", stage_times(&times, &stereo));
        if args.counters {
            println!("{}", counters_table(&stats).render(Format::Md));
        }
        return Ok(());
    }
    let (Some(dir), Some(out)) = (&args.kitti, &args.out) else { anyhow::bail!("--kitti and --out are needed") };
    std::fs::create_dir_all(out).with_context(|| format!("creating the output folder {}", out.display()))?;
    let ids = image_sequences(dir, &args.sequences)?;
    let settings = TrackSettings {
        depth: args.depth,
        masks: args.masks,
        frames: args.frames,
        rate_hz: args.rate.hz,
        stereo,
        tracker: args.tracker(),
        record_encoding: args.record_encoding.into(),
    };
    for id in &ids {
        let file = tracks_path(out, id);
        let record = args.record.as_deref().map(|target| record_path(target, ids.len() > 1, None, id));
        let bar = progress(args.frames.map_or(0, |n| n as u64), "frames tracked");
        let done = track_sequence(dir, id, &file, record.as_deref(), &settings, &|| bar.inc(1))?;
        bar.finish_and_clear();
        eprintln!("wrote {} frames of sequence {id} to {}", done.frames, file.display());
        if let Some(r) = &done.recorded {
            eprintln!("{}", recorded(r));
        }
        print!("{}", stage_times(&done.times, &stereo));
        if args.counters {
            println!("{}", counters_table(&done.stats).render(Format::Md));
        }
    }
    Ok(())
}

/// Prints (and with --out writes) the disparity error or the motion masks' scores on the
/// renderings of the sequences of `dir`.
fn rendered_measurement(dir: &std::path::Path, args: &TrackArgs) -> anyhow::Result<()> {
    let settings = DisparitySettings {
        options: EvalOptions {
            max_frames: args.frames,
            render_optics: args.render_optics.optics(),
            point_depth: args.point_depth.options(),
            ..EvalOptions::kitti(args.rate.period())
        },
        jobs: args.jobs,
        point_depth_name: format!("{:?}", args.point_depth.point_depth),
        render_optics_name: format!("{:?}", args.render_optics),
    };
    let bar = progress(0, "sequences rendered and tracked");
    let on_sequence = |total: usize| {
        bar.set_length(total as u64);
        bar.inc(1);
    };
    let result = if args.segmentation {
        motion_segmentation(dir, &args.sequences, &settings, &on_sequence)
            .map(|r| (r.header, vec![("segmentation_recall", r.recall), ("segmentation_precision", r.precision)]))
    } else {
        disparity_error(dir, &args.sequences, &settings, &on_sequence).map(|(h, t)| (h, vec![("disparity_error", t)]))
    };
    bar.finish_and_clear();
    let (header, tables) = result?;
    print!("{header}");
    for (_, table) in &tables {
        println!("{}", table.render(Format::Md));
    }
    if let Some(out) = &args.out {
        for (stem, table) in &tables {
            for (format, ext) in [(Format::Md, "md"), (Format::Csv, "csv"), (Format::Json, "json")] {
                let path = out.join(format!("{stem}.{ext}"));
                dynotraj_formats::atomic::write_file(&path, table.render(format).as_bytes())
                    .with_context(|| format!("writing {}", path.display()))?;
            }
        }
    }
    Ok(())
}
