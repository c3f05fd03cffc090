//! The image front-end over image sequences in the KITTI tracking layout (what `dynotraj track`
//! runs): each sequence tracked into a tracks file (and a recording), the stage times and
//! counters, the disparity error of sent points against renderings' exact depth, and the
//! checks on the real KITTI images.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Context as _;
use dynotraj_bag::record::{RecordingEncoding, RecordingSummary};
use dynotraj_core::wire::CameraInfo;
use dynotraj_formats::kitti::{SequenceData, TrackingDir};
use dynotraj_formats::tracks_file::TracksWriter;
use dynotraj_frontend::check::{CAR_BOX_000046, odometry06, stereo2015_d1, stereo2015_points};
use dynotraj_frontend::disparity_error::{DisparityErrors, ErrorRow};
use dynotraj_frontend::sequence::{DepthMode, ImageSequence, MaskMode};
use dynotraj_frontend::{FrontEnd, FrontEndStats, StageTimes, StereoParams, TrackerParams};
use dynotraj_sources::estimation::from_images::disparity_errors;
use dynotraj_sources::estimation::simulated::EvalOptions;

use crate::jobs::map_jobs;
use crate::recording::track::TrackRecorder;
use crate::report::data::{Cell, ColumnKind, Data};
use crate::report::{Format, Table};

/// How a sequence is tracked.
#[derive(Debug, Clone, Copy)]
pub struct TrackSettings {
    /// Depth from stereo matching or from depth maps.
    pub depth: DepthMode,
    /// Where instance masks come from.
    pub masks: MaskMode,
    /// At most this many frames.
    pub frames: Option<usize>,
    /// The frame rate of a layout without capture times, Hz.
    pub rate_hz: f32,
    /// The stereo matcher's settings.
    pub stereo: StereoParams,
    /// The tracker's settings.
    pub tracker: TrackerParams,
    /// The encoding of recordings.
    pub record_encoding: RecordingEncoding,
}

/// What tracking a sequence gave.
#[derive(Debug)]
pub struct TrackedSequence {
    /// Time per stage.
    pub times: StageTimes,
    /// The front-end's counters.
    pub stats: FrontEndStats,
    /// Frames tracked.
    pub frames: usize,
    /// The recording written, if one was asked for.
    pub recorded: Option<RecordingSummary>,
}

/// How [`disparity_error`] renders and tracks.
#[derive(Debug, Clone)]
pub struct DisparitySettings {
    /// The rendering and front-end options (frames, optics, point depth, rate).
    pub options: EvalOptions,
    /// Sequences rendered at once.
    pub jobs: usize,
    /// The point-depth setting as the header names it.
    pub point_depth_name: String,
    /// The render optics as the header names them.
    pub render_optics_name: String,
}

/// `given`, or every sequence with a folder of left images in `dir`/image_02/, in order.
///
/// # Errors
/// A sequence given twice, or no image_02/ folder to list.
pub fn image_sequences(dir: &Path, given: &[String]) -> anyhow::Result<Vec<String>> {
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
/// recording there ([`TrackRecorder`]); `on_frame` is called after each frame.
///
/// # Errors
/// Reading, tracking or writing errors, named.
pub fn track_sequence(
    dir: &Path,
    seq: &str,
    out: &Path,
    record: Option<&Path>,
    settings: &TrackSettings,
    on_frame: &dyn Fn(),
) -> anyhow::Result<TrackedSequence> {
    let s = ImageSequence::open(dir, seq, settings.depth, settings.masks)?;
    let [fx, fy, cx, cy] = s.intrinsics;
    // Capture times from the layout's times/ say the real rate; --rate is for layouts without.
    let rate_hz = s.measured_rate_hz().map_or(settings.rate_hz, |r| r as f32);
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
    let mut fe = FrontEnd::new(settings.stereo, settings.tracker, s.fb as f32)?;
    let mut w = TracksWriter::create(out, &camera)?;
    let mut rec = record
        .map(|path| {
            TrackRecorder::create(path, settings.record_encoding, dir.join("image_02").join(seq), &camera)
                .context("--record")
        })
        .transpose()?;
    let n = s.track(&mut fe, settings.frames.unwrap_or(usize::MAX), f64::from(rate_hz), |frame, t_us, tracks| {
        w.write_frame(frame, t_us, tracks)?;
        if let Some(r) = rec.as_mut() {
            r.frame(frame, t_us, tracks).context("--record")?;
        }
        on_frame();
        Ok(())
    })?;
    w.finish()?;
    let recorded = rec.map(|r| r.finish().context("--record")).transpose()?;
    Ok(TrackedSequence { times: fe.times, stats: fe.tracker.stats, frames: n, recorded })
}

/// The stage times per frame as a Markdown table.
#[must_use]
pub fn stage_times(t: &StageTimes, stereo: &StereoParams) -> String {
    let mut out = String::new();
    let ms = |s: f64| 1e3 * s / t.frames.max(1) as f64;
    let [cs, cm, cp, ce] = t.cpu;
    let beside = t.concurrent_frames > 0;
    let _ = writeln!(out, "| stage | wall ms/frame | CPU ms/frame (all threads) |\n|---|---|---|");
    let sgbm = format!("stereo (SGBM 3-way, {} disparities, downscale {})", stereo.num_disparities, stereo.downscale);
    if beside {
        let _ = writeln!(out, "| {sgbm}, beside KLT | {:.1} | {:.1} with KLT |", ms(t.stereo), ms(cs));
    } else {
        let _ = writeln!(out, "| {sgbm} | {:.1} | {:.1} |", ms(t.stereo), ms(cs));
    }
    let _ = writeln!(out, "| masks | {:.1} | {:.1} |", ms(t.masks), ms(cm));
    if beside {
        let _ = writeln!(out, "| KLT + detection + sampling, beside stereo | {:.1} | with stereo |", ms(t.points));
    } else {
        let _ = writeln!(out, "| KLT + detection + sampling | {:.1} | {:.1} |", ms(t.points), ms(cp));
    }
    let _ = writeln!(out, "| point depth + emission | {:.1} | {:.1} |", ms(t.emission), ms(ce));
    let cpu = ms(cs + cm + cp + ce);
    let _ = writeln!(
        out,
        "| total ({} frames{}) | {:.1} = {:.1} frames/s | {:.1} = {:.1} frames/s per core |",
        t.frames,
        if beside { format!(", {} with stereo beside KLT", t.concurrent_frames) } else { String::new() },
        ms(t.wall),
        t.fps(),
        cpu,
        if cpu > 0.0 { 1e3 / cpu } else { 0.0 }
    );
    out
}

/// Renders the sequences `sequences` of the KITTI folder `dir` (all when empty) at KITTI's
/// resolution, tracks them and scores the disparity of every sent point against the
/// rendering's exact depth; returns the header text and the table. `on_sequence` is told
/// how many sequences there are after each.
///
/// # Errors
/// Loading, rendering or tracking errors, named.
pub fn disparity_error(
    dir: &Path,
    sequences: &[String],
    settings: &DisparitySettings,
    on_sequence: &(dyn Fn(usize) + Sync),
) -> anyhow::Result<(String, Table)> {
    let opt = &settings.options;
    let (names, per_drive) =
        per_sequence(dir, sequences, settings.jobs, on_sequence, |id, data| disparity_errors(id, data, opt))?;
    let mut errors = DisparityErrors::default();
    let mut stats = FrontEndStats::default();
    for (e, s) in per_drive {
        errors.merge(e);
        stats = stats.plus(&s);
    }
    let mut header = format!(
        "Disparity of the sent points against the rendering's exact depth: sequences {}, {} frames each at most, \
         point depth {}, object points sampled {} px off the mask edge, render optics {}, stereo downscale {}",
        names.join(","),
        opt.max_frames.map_or_else(|| "all".to_string(), |n| n.to_string()),
        settings.point_depth_name,
        opt.point_depth.tracker().object_edge_margin_px,
        settings.render_optics_name,
        opt.point_depth.stereo_downscale
    );
    header.push('\n');
    let _ = writeln!(
        header,
        "points without truth under them {}; not sent for want of depth: {} object, {} static; sub-pixel: {} refined, \
         {} kept the dense value, {} refused\n",
        errors.without_truth,
        stats.object_points_no_depth,
        stats.static_no_depth,
        stats.subpixel_refined,
        stats.subpixel_kept_dense,
        stats.subpixel_refused
    );
    Ok((header, disparity_table(&errors.rows())))
}

/// `measure` run on each of the sequences `sequences` of the KITTI folder `dir` (all when
/// empty), `jobs` at a time, `on_sequence` told how many there are after each; with their
/// names, in order.
///
/// # Errors
/// A sequence that cannot be loaded, or what `measure` returns, named.
pub fn per_sequence<T: Send>(
    dir: &Path,
    sequences: &[String],
    jobs: usize,
    on_sequence: &(dyn Fn(usize) + Sync),
    measure: impl Fn(&str, &SequenceData) -> anyhow::Result<T> + Sync,
) -> anyhow::Result<(Vec<String>, Vec<T>)> {
    let drives = dynotraj_sources::drives::kitti_drives(dir, sequences)?;
    let tracking = TrackingDir::open(dir)?;
    let per_drive = map_jobs(&drives, jobs, |d| {
        let data =
            tracking.load_sequence(&d.name).with_context(|| format!("loading KITTI tracking sequence {}", d.name))?;
        let out = measure(&d.name, &data);
        on_sequence(drives.len());
        out
    })?;
    let out = per_drive.into_iter().collect::<anyhow::Result<Vec<T>>>()?;
    Ok((drives.into_iter().map(|d| d.name).collect(), out))
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

/// The front-end measured on the real KITTI images under `root` (stereo2015's disparity, and
/// odometry 06's tracks and ego-motion), as text and tables.
///
/// # Errors
/// Images that cannot be read, named.
pub fn real_image_checks(root: &Path, stereo: StereoParams, tracker: TrackerParams) -> anyhow::Result<String> {
    let mut out = String::new();
    let d1 = stereo2015_d1(root, "000046_10.png", stereo)?;
    let _ = writeln!(
        out,
        "stereo2015 000046_10: D1-all {:.2}% over {} ground-truth pixels ({:.1}% without a match, counted as bad)",
        100.0 * d1.share(),
        d1.pixels,
        100.0 * (1.0 - d1.density())
    );
    let pair = stereo2015_points(root, "000046_10.png", CAR_BOX_000046, stereo, &tracker)?;
    let _ = writeln!(
        out,
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
    let _ = writeln!(out, "{}\n", Table::of_data(headers, data).render(Format::Md));
    let c = odometry06(root, stereo, tracker)?;
    let _ = writeln!(
        out,
        "odometry 06: {} static tracks with depth at frame 12; KLT survival 12->13 {:.1}%, 13->14 {:.1}%",
        c.corners,
        100.0 * c.survival[0],
        100.0 * c.survival[1]
    );
    for (pair, m) in ["12->13", "12->14"].iter().zip(c.motion) {
        let _ = match m {
            Some(m) => writeln!(
                out,
                "odometry 06 ego-motion {pair}: translation error {:.3} m (of {:.3} m travelled), rotation error \
                    {:.3} deg; {} of {} correspondences inliers",
                m.translation_m, m.true_translation_m, m.rotation_deg, m.inliers, m.points
            ),
            None => writeln!(out, "odometry 06 ego-motion {pair}: the fit failed"),
        };
    }
    for (pair, s) in ["12->13", "12->14"].iter().zip(&c.segments) {
        if let Some(s) = s {
            let _ = writeln!(
                out,
                "odometry 06 motion segmentation {pair} (depth at 12 only, judged in the image; the street is \
                    static): {} corners judged, {} moving, {} moving segments",
                s.judged,
                s.moving,
                s.segments.len()
            );
        }
    }
    Ok(out)
}

/// The front-end's counters as a table of (counter, value).
#[must_use]
pub fn counters_table(stats: &FrontEndStats) -> Table {
    let mut data = Data::new([("counter", ColumnKind::Text), ("value", ColumnKind::Int)]);
    for (name, value) in stats.named() {
        data.push(vec![Cell::text(name), Cell::int(value)]);
    }
    Table::of_data(["counter", "value"], data)
}
