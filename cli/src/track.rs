//! `dynotraj track`: the front-end over an image sequence in the KITTI tracking layout (a real
//! KITTI download, or `dynotraj simulate`'s output), writing the tracks file that
//! `dynotraj estimate --tracks` and `dynotraj stream --tracks` read. Also:
//! `--cost` times the stages at KITTI resolution on rendered frames, and `--check` measures the
//! front-end on the real KITTI images in ../shared/kitti (stereo D1, KLT survival, ego-motion).
//! `--record` also writes what the front-end saw and found for Foxglove (MCAP).

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use clap::Args;
use dynotraj_bag::record::RecordingSummary;
use dynotraj_core::wire::CameraInfo;
use dynotraj_eval::recording::record_path;
use dynotraj_eval::recording::track::TrackRecorder;

use super::common::{FrameRateArg, PointDepthArgs, RenderOptics, progress};
use dynotraj_eval::jobs::{default_jobs, map_jobs, parse_jobs};
use dynotraj_eval::report::data::{Cell, ColumnKind, Data};
use dynotraj_eval::report::{Format, Table};
use dynotraj_formats::kitti::TrackingDir;
use dynotraj_formats::tracks_file::{TracksWriter, tracks_path};
use dynotraj_frontend::check::{CAR_BOX_000046, odometry06, stereo2015_d1, stereo2015_points};
use dynotraj_frontend::disparity_error::{DisparityErrors, ErrorRow};
use dynotraj_frontend::sequence::{DepthMode, ImageSequence, MaskMode};
use dynotraj_frontend::{FrontEnd, FrontEndStats, StageTimes, StereoParams, TrackerParams};
use dynotraj_sources::estimation::from_images::disparity_errors;
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
    #[arg(long, value_name = "DIR", required_unless_present_any = ["cost", "check", "disparity_error"])]
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
    /// Also write recordings to look at in Foxglove: MCAP (Foxglove's schemas, JSON) with, per
    /// frame at its capture time, the left image as it is on disk (`/camera/left/compressed`),
    /// the frame's tracks back-projected into the camera frame (`/tracks/static`;
    /// `/tracks/objects` with each point's `object_id`) and drawn over the image
    /// (`/camera/left/annotations`). One sequence: FILE is the recording; several, or FILE an
    /// existing folder: FILE is a folder of `<sequence>.mcap`.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["cost", "check"])]
    pub record: Option<PathBuf>,
    /// Time the stages on rendered frames at 1242 x 375 (the synthetic drive) instead; with
    /// `--masks boxes` (or detections) masks come from 2D boxes refined by depth.
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
        return check(root, stereo, args.tracker());
    }
    if args.disparity_error {
        let Some(dir) = &args.kitti else { anyhow::bail!("--disparity-error needs --kitti") };
        return disparity_error(dir, args);
    }
    if args.cost {
        let boxes = matches!(args.masks, MaskMode::Boxes | MaskMode::Detections);
        let (times, stats) = dynotraj_frontend::cost::run(args.frames.unwrap_or(30), (stereo, args.tracker()), boxes)?;
        println!("masks: {}", if boxes { "2D boxes refined by depth, IoU ids" } else { "rendered instance ids" });
        print_times(&times, &stereo);
        if args.counters {
            println!("{}", counters_table(&stats).render(Format::Md));
        }
        return Ok(());
    }
    let (Some(dir), Some(out)) = (&args.kitti, &args.out) else { anyhow::bail!("--kitti and --out are needed") };
    std::fs::create_dir_all(out).with_context(|| format!("creating the output folder {}", out.display()))?;
    let ids = image_sequences(dir, &args.sequences)?;
    for id in &ids {
        let file = tracks_path(out, id);
        let record = args.record.as_deref().map(|target| record_path(target, ids.len() > 1, None, id));
        let (times, stats, frames, recorded) = track_sequence(dir, id, &file, record.as_deref(), args, stereo)?;
        eprintln!("wrote {frames} frames of sequence {id} to {}", file.display());
        if let Some(r) = recorded {
            eprintln!("recorded {} ({} bytes)", r.path.display(), r.bytes);
        }
        print_times(&times, &stereo);
        if args.counters {
            println!("{}", counters_table(&stats).render(Format::Md));
        }
    }
    Ok(())
}

/// `given`, or every sequence with a folder of left images in `dir`/image_02/, in order.
///
/// # Errors
/// A sequence given twice, or no image_02/ folder to list.
fn image_sequences(dir: &Path, given: &[String]) -> anyhow::Result<Vec<String>> {
    if !given.is_empty() {
        return dynotraj_sources::drives::distinct_ids("--sequences", given.to_vec());
    }
    let images = dir.join("image_02");
    let mut ids: Vec<String> = std::fs::read_dir(&images)
        .with_context(|| format!("listing {} (expected one folder of PNGs per sequence)", images.display()))?
        .filter_map(Result::ok)
        .filter(|e| e.path().is_dir())
        .filter_map(|e| e.file_name().to_str().map(str::to_string))
        .collect();
    ids.sort();
    anyhow::ensure!(!ids.is_empty(), "{}: no sequence folders", images.display());
    Ok(ids)
}

/// Tracks sequence `seq` of `dir` into the tracks file `out`, and with `record` also into a
/// recording there ([`TrackRecorder`]); returns the stage times, the counters, the frames
/// tracked and what the recording holds.
///
/// # Errors
/// Reading, tracking or writing errors, named.
pub fn track_sequence(
    dir: &Path,
    seq: &str,
    out: &Path,
    record: Option<&Path>,
    args: &TrackArgs,
    stereo: StereoParams,
) -> anyhow::Result<(StageTimes, FrontEndStats, usize, Option<RecordingSummary>)> {
    let s = ImageSequence::open(dir, seq, args.depth, args.masks)?;
    let [fx, fy, cx, cy] = s.intrinsics;
    // Capture times from the layout's times/ say the real rate; --rate is for layouts without.
    let rate_hz = s.measured_rate_hz().map_or(args.rate.hz, |r| r as f32);
    if let Some(r) = s.measured_rate_hz() {
        log::info!("sequence {seq}: {r:.3} Hz measured from times/{seq}.txt (--rate not used)");
    }
    let camera = CameraInfo {
        fx: fx as f32,
        fy: fy as f32,
        cx: cx as f32,
        cy: cy as f32,
        stereo_fb: s.fb as f32,
        width: u16::try_from(s.size.0).context("image width")?,
        height: u16::try_from(s.size.1).context("image height")?,
        frame_rate_hz: rate_hz,
    };
    let mut fe = FrontEnd::new(stereo, args.tracker(), s.fb as f32)?;
    let mut w = TracksWriter::create(out, &camera)?;
    let mut rec = record
        .map(|path| TrackRecorder::create(path, dir.join("image_02").join(seq), &camera).context("--record"))
        .transpose()?;
    let bar = progress(args.frames.map_or(0, |n| n as u64), "frames tracked");
    let n = s.track(&mut fe, args.frames.unwrap_or(usize::MAX), f64::from(rate_hz), |frame, t_us, tracks| {
        w.write_frame(frame, t_us, tracks)?;
        if let Some(r) = rec.as_mut() {
            r.frame(frame, t_us, tracks).context("--record")?;
        }
        bar.inc(1);
        Ok(())
    })?;
    bar.finish_and_clear();
    w.finish()?;
    let recorded = rec.map(|r| r.finish().context("--record")).transpose()?;
    Ok((fe.times, fe.tracker.stats, n, recorded))
}

fn print_times(t: &StageTimes, stereo: &StereoParams) {
    let ms = |s: f64| 1e3 * s / t.frames.max(1) as f64;
    let [cs, cm, cp, ce] = t.cpu;
    let beside = t.concurrent_frames > 0;
    println!("| stage | wall ms/frame | CPU ms/frame (all threads) |\n|---|---|---|");
    let sgbm = format!("stereo (SGBM 3-way, {} disparities, downscale {})", stereo.num_disparities, stereo.downscale);
    if beside {
        println!("| {sgbm}, beside KLT | {:.1} | {:.1} with KLT |", ms(t.stereo), ms(cs));
    } else {
        println!("| {sgbm} | {:.1} | {:.1} |", ms(t.stereo), ms(cs));
    }
    println!("| masks | {:.1} | {:.1} |", ms(t.masks), ms(cm));
    if beside {
        println!("| KLT + detection + sampling, beside stereo | {:.1} | with stereo |", ms(t.points));
    } else {
        println!("| KLT + detection + sampling | {:.1} | {:.1} |", ms(t.points), ms(cp));
    }
    println!("| point depth + emission | {:.1} | {:.1} |", ms(t.emission), ms(ce));
    let cpu = ms(cs + cm + cp + ce);
    println!(
        "| total ({} frames{}) | {:.1} = {:.1} frames/s | {:.1} = {:.1} frames/s per core |",
        t.frames,
        if beside { format!(", {} with stereo beside KLT", t.concurrent_frames) } else { String::new() },
        ms(t.wall),
        t.fps(),
        cpu,
        if cpu > 0.0 { 1e3 / cpu } else { 0.0 }
    );
}

/// Renders, tracks and scores the sequences of `dir` ([`TrackArgs::disparity_error`]).
fn disparity_error(dir: &Path, args: &TrackArgs) -> anyhow::Result<()> {
    let drives = dynotraj_sources::drives::kitti_drives(dir, &args.sequences)?;
    let tracking = TrackingDir::open(dir)?;
    let opt = EvalOptions {
        max_frames: args.frames,
        render_optics: args.render_optics.optics(),
        point_depth: args.point_depth.options(),
        ..EvalOptions::kitti(args.rate.period())
    };
    let tracker = args.tracker();
    let bar = progress(drives.len() as u64, "sequences rendered and tracked");
    let per_drive = map_jobs(&drives, args.jobs, |d| {
        let data =
            tracking.load_sequence(&d.name).with_context(|| format!("loading KITTI tracking sequence {}", d.name))?;
        let out = disparity_errors(&d.name, &data, &opt);
        bar.inc(1);
        out
    })?;
    bar.finish_and_clear();
    let mut errors = DisparityErrors::default();
    let mut stats = FrontEndStats::default();
    for r in per_drive {
        let (e, s) = r?;
        errors.merge(e);
        stats = stats.plus(&s);
    }
    let names: Vec<&str> = drives.iter().map(|d| d.name.as_str()).collect();
    println!(
        "Disparity of the sent points against the rendering's exact depth: sequences {}, {} frames each at most, \
         point depth {:?}, object points sampled {} px off the mask edge, render optics {:?}, stereo downscale {}",
        names.join(","),
        args.frames.map_or_else(|| "all".to_string(), |n| n.to_string()),
        args.point_depth.point_depth,
        tracker.object_edge_margin_px,
        args.render_optics,
        opt.point_depth.stereo_downscale
    );
    println!(
        "points without truth under them {}; not sent for want of depth: {} object, {} static; sub-pixel: {} refined, \
         {} kept the dense value, {} refused\n",
        errors.without_truth,
        stats.object_points_no_depth,
        stats.static_no_depth,
        stats.subpixel_refined,
        stats.subpixel_kept_dense,
        stats.subpixel_refused
    );
    let table = disparity_table(&errors.rows());
    println!("{}", table.render(Format::Md));
    if let Some(out) = &args.out {
        for (format, ext) in [(Format::Md, "md"), (Format::Csv, "csv"), (Format::Json, "json")] {
            let path = out.join(format!("disparity_error.{ext}"));
            dynotraj_formats::atomic::write_file(&path, table.render(format).as_bytes())
                .with_context(|| format!("writing {}", path.display()))?;
        }
    }
    Ok(())
}

/// The disparity-error rows as a table.
fn disparity_table(rows: &[ErrorRow]) -> Table {
    let mut data = Data::new([
        ("points", ColumnKind::Text),
        ("count", ColumnKind::Int),
        ("bias (px)", ColumnKind::Num),
        ("median abs error (px)", ColumnKind::Num),
        ("outliers > 1 px", ColumnKind::Num),
        ("median abs depth error (m)", ColumnKind::Num),
    ]);
    for r in rows {
        data.push(vec![
            Cell::text(&r.group),
            Cell::int(r.points),
            Cell::num(r.bias_px, 3),
            Cell::num(r.median_abs_px, 3),
            Cell::num(r.outlier_share, 3),
            Cell::num(r.median_abs_depth_m, 2),
        ]);
    }
    let headers: Vec<String> = data.names().into_iter().map(str::to_string).collect();
    Table::of_data(headers, data)
}

fn check(root: &Path, stereo: StereoParams, tracker: TrackerParams) -> anyhow::Result<()> {
    let d1 = stereo2015_d1(root, "000046_10.png", stereo)?;
    println!(
        "stereo2015 000046_10: D1-all {:.2}% over {} ground-truth pixels ({:.1}% without a match, counted as bad)",
        100.0 * d1.share(),
        d1.pixels,
        100.0 * (1.0 - d1.density())
    );
    let pair = stereo2015_points(root, "000046_10.png", CAR_BOX_000046, stereo, &tracker)?;
    println!(
        "\nstereo2015 000046_10 against its ground-truth disparity (car: the hand-placed box {CAR_BOX_000046:?}):\n"
    );
    let mut data = Data::new([
        ("where", ColumnKind::Text),
        ("scored", ColumnKind::Int),
        ("no estimate", ColumnKind::Int),
        ("mean abs error (px)", ColumnKind::Num),
        ("median abs error (px)", ColumnKind::Num),
        ("bias (px)", ColumnKind::Num),
        ("D1 of scored", ColumnKind::Num),
    ]);
    for (name, e) in [
        ("dense map, all pixels", pair.dense_all),
        ("dense map, car pixels", pair.dense_car),
        ("corners, dense value", pair.corners_dense),
        ("corners, sub-pixel", pair.corners_subpixel),
        ("car points, dense value", pair.car_dense),
        ("car points, sub-pixel", pair.car_subpixel),
    ] {
        data.push(vec![
            Cell::text(name),
            Cell::int(e.scored),
            Cell::int(e.missing),
            Cell::num(e.mean_abs_px, 3),
            Cell::num(e.median_abs_px, 3),
            Cell::num(e.bias_px, 3),
            Cell::num(e.d1, 4),
        ]);
    }
    let headers: Vec<String> = data.names().into_iter().map(str::to_string).collect();
    println!("{}\n", Table::of_data(headers, data).render(Format::Md));
    let c = odometry06(root, stereo, tracker)?;
    println!(
        "odometry 06: {} static tracks with depth at frame 12; KLT survival 12->13 {:.1}%, 13->14 {:.1}%",
        c.corners,
        100.0 * c.survival[0],
        100.0 * c.survival[1]
    );
    for (pair, m) in ["12->13", "12->14"].iter().zip(c.motion) {
        match m {
            Some(m) => println!(
                "odometry 06 ego-motion {pair}: translation error {:.3} m (of {:.3} m travelled), rotation error \
                    {:.3} deg; {} of {} correspondences inliers",
                m.translation_m, m.true_translation_m, m.rotation_deg, m.inliers, m.points
            ),
            None => println!("odometry 06 ego-motion {pair}: the fit failed"),
        }
    }
    Ok(())
}

/// The front-end's counters as a table of (counter, value).
fn counters_table(stats: &FrontEndStats) -> Table {
    let mut data = Data::new([("counter", ColumnKind::Text), ("value", ColumnKind::Int)]);
    for (name, value) in stats.named() {
        data.push(vec![Cell::text(name), Cell::int(value)]);
    }
    Table::of_data(["counter", "value"], data)
}
