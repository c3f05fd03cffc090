//! `dynotraj estimate`: the DynoSAM-style estimator on real KITTI sequences, rendered by the
//! image simulator and tracked by the front-end (`--ours-input rendered`, the default, as every
//! command) or simulated at the track level (`--ours-input tracks`), with one or more estimator
//! profiles (`--profile host,edge`); prints the paper's Table III (camera and object RPE) for
//! the frame-to-frame, causal and smoothed estimates, the restarts of object runs by cause, the
//! smoothness of object trajectories against the KITTI labels, and optionally writes pose files
//! and logs. `--cost` times the estimator per frame. `--write-tracks` records the tracks as a
//! tracks file; `--tracks` estimates on one (no truth: pose files and log only).

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::Context as _;
use clap::Args;
use dynotraj_bag::record::{CAMERA_FRAME, Line, Pose, Recorder, RecordingSummary, Rgba, WORLD_FRAME, frame_time_ns};
use dynotraj_core::estimate::{EstimatorProfile, Intrinsics, PROFILES, SmootherParams};
use dynotraj_core::wire::{ObjectClass, Track};
use dynotraj_sim::track_sim::SimFrame;

use super::common::{ClassesArg, EstimatedSourceArgs, FrameRateArg, MinStepArg, progress, record_path, sequence_ids};
use dynotraj_eval::jobs::map_jobs;
use dynotraj_eval::report::estimator_tables::{
    cost_table, counters_table, data_tables, per_object_table, replay_tables, rpe_sources_table, tables,
};
use dynotraj_eval::report::{Format, Table, check_table, render_tables};
use dynotraj_formats::kitti::TrackingDir;
use dynotraj_formats::tracks_file::{TracksFrame, tracks_path};
use dynotraj_sources::estimation::files::{write_estimates, write_run};
use dynotraj_sources::estimation::from_images::{render_and_track, rendered_intrinsics, rendered_params};
use dynotraj_sources::estimation::runner::EstimatorRun;
use dynotraj_sources::estimation::settings::SimulatedInput;
use dynotraj_sources::estimation::simulated::{
    EvalOptions, SequenceResult, camera_info, estimator_params, params_for, run_with_window, score_sequence,
    sim_max_depth, simulate_sequence, write_tracks,
};

/// Options of `dynotraj estimate`.
#[derive(Debug, Args)]
pub struct EstimateArgs {
    /// A KITTI tracking split folder (label_02/, calib/, ego poses), e.g.
    /// ../shared/kitti/tracking/training. Its labels and ego poses drive the simulator.
    #[arg(
        long = "kitti",
        visible_alias = "sim-kitti",
        env = "DYNOTRAJ_KITTI", hide_env_values = true,
        value_name = "DIR",
        required_unless_present_any = ["cost", "tracks"],
    )]
    pub kitti: Option<PathBuf>,
    /// Sequences, comma-separated (default: every sequence in the folder).
    #[arg(long = "sequences", visible_alias = "sequence", value_delimiter = ',', value_parser = crate::numbers::sequence_id, value_name = "LIST")]
    pub sequences: Vec<String>,
    /// The feature tracks' source (rendered by default, as every command; `tracks`: the
    /// track-level simulator with the noise below), the renderings' cache and the jobs.
    #[command(flatten)]
    pub ours: EstimatedSourceArgs,
    /// Instead of simulating, estimate on a recorded tracks file (`.dtt`, the link's byte
    /// stream: camera model, then each frame's tracks). Intrinsics and frame rate come from the
    /// file's camera model; `--pixel-sigma`, `--disparity-sigma` and `--noise-free` set the
    /// noise model the estimator assumes (give the values the recording was simulated with to
    /// reproduce a simulated run bit for bit). A tracks file has no truth: no RPE is printed.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["cost", "write_tracks"])]
    pub tracks: Option<PathBuf>,
    /// Also write each sequence's simulated tracks into --out as a tracks file,
    /// `<DIR>/<sequence>.dtt` (as `dynotraj track` names them), for `--tracks` replay.
    #[arg(long, requires = "out")]
    pub write_tracks: bool,
    /// Folder for pose files (TUM and KITTI, camera and objects) and the per-frame CSV log, one
    /// sub-folder per sequence (with several profiles, per profile and sequence; with
    /// `--tracks`: the folder itself).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Also write recordings to look at in Foxglove: MCAP (Foxglove's schemas, JSON) with, per
    /// frame, the estimated camera (`/tf`: world to camera; `/camera/path`), each object's
    /// estimated trajectory so far (`/objects/estimated`, causal estimates), with simulated input
    /// the simulator's truth (`/objects/truth`, `/camera/truth`), and the frame's measured
    /// points in the camera frame (`/points/static`, `/points/objects`). One sequence (or
    /// --tracks): FILE is the recording; several sequences or profiles, or FILE an existing
    /// folder: FILE is a folder of `<sequence>.mcap` (`<profile>/<sequence>.mcap` with several
    /// profiles; the tracks file's name with --tracks).
    #[arg(long, value_name = "FILE", conflicts_with = "cost")]
    pub record: Option<PathBuf>,
    /// The frame rate.
    #[command(flatten)]
    pub rate: FrameRateArg,
    /// The classes.
    #[command(flatten)]
    pub classes: ClassesArg,
    /// The moving threshold.
    #[command(flatten)]
    pub min_step: MinStepArg,
    /// Pixel noise of the simulated tracks, pixels.
    #[arg(long, value_parser = crate::numbers::non_negative, default_value_t = 0.5)]
    pub pixel_sigma: f64,
    /// Disparity noise of the simulated tracks, pixels (depth noise grows with depth squared).
    #[arg(long, value_parser = crate::numbers::non_negative, default_value_t = 0.5)]
    pub disparity_sigma: f64,
    /// Share of outlier tracks per frame.
    #[arg(long, value_parser = crate::numbers::fraction, default_value_t = 0.05)]
    pub outliers: f64,
    /// Mean track lifetime in frames (0: unlimited).
    #[arg(long, default_value_t = 40)]
    pub track_lifetime: usize,
    /// No noise, outliers or track turnover at all.
    #[arg(long)]
    pub noise_free: bool,
    /// Object smoother: standard deviation of the change of per-frame translation, metres
    /// (DynoSAM's world-frame value: 0.2).
    #[arg(
        long,
        value_parser = crate::numbers::positive_f32,
        default_value_t = SmootherParams::VEHICLE_OBJECT.sigma_translation,
    )]
    pub object_sigma_t: f32,
    /// Object smoother: standard deviation of the change of per-frame rotation, radians
    /// (DynoSAM's world-frame value: 0.01).
    #[arg(
        long,
        value_parser = crate::numbers::positive_f32,
        default_value_t = SmootherParams::VEHICLE_OBJECT.sigma_rotation,
    )]
    pub object_sigma_r: f32,
    /// Estimator profiles, comma-separated: host (DynoSAM's 20-frame window, the joint
    /// camera-object solve) and edge (what the ECU firmware runs: an 8-frame window, camera and
    /// objects smoothed apart). Every table is printed per profile.
    #[arg(long = "profile", value_delimiter = ',', default_value = "host", value_name = "LIST")]
    pub profiles: Vec<String>,
    /// Block Gauss-Seidel sweeps of the joint camera-object smoother per frame, instead of the
    /// profile's; 0 smooths the camera and each object apart (objects against the
    /// frame-to-frame camera).
    #[arg(long, value_name = "N")]
    pub joint_sweeps: Option<u8>,
    /// Seed of the simulator and of RANSAC.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Use at most this many frames of each sequence.
    #[arg(long, value_name = "N")]
    pub frames: Option<usize>,
    /// Also print the estimator's counters per sequence.
    #[arg(long)]
    pub counters: bool,
    /// Also print the RPE of every moving object (smoothed estimate).
    #[arg(long)]
    pub per_object: bool,
    /// Also print where the object RPE_t comes from: the pairs of every sequence pooled, by the
    /// object's true range, by the pair's place in its run, and the worst 1 % of pairs.
    #[arg(long)]
    pub rpe_sources: bool,
    /// Measurement: score the object poses of DynoSAM's hybrid smoother (each fit an absolute
    /// measurement of the object's pose, a constant-motion residual over three poses), run
    /// offline over the estimator's own fits in the same window, instead of the estimator's
    /// chain smoother, each fit's information multiplied by WEIGHT (default 1); prints the
    /// estimator's RPE on the same pairs beside it (docs/decisions.md "Item 4's first
    /// option"). Table III's object RPE changes; the bird's-eye states forecasts read do not.
    #[arg(long, num_args = 0..=1, default_missing_value = "1", value_parser = crate::numbers::positive, value_name = "WEIGHT")]
    pub hybrid_object_smoother: Option<f64>,
    /// Output format of the tables: md (for people), csv or json (one observation per row,
    /// every profile in one table with a `profile` column; JSON of several tables is one object
    /// keyed by table name).
    #[arg(long, value_parser = crate::numbers::choices(&Format::CHOICES), default_value = "md")]
    pub format: Format,
    /// With --format csv or json, print only this table: table_iii, restarts, smoothness,
    /// counters (with --counters), per_object (with --per-object), rpe_sources (with
    /// --rpe-sources); replay (and counters) on a
    /// tracks file; cost with --cost. CSV holds one table, so it needs this flag whenever
    /// several tables are printed.
    #[arg(long, value_name = "NAME")]
    pub table: Option<String>,
    /// Instead of the KITTI sequences, time the estimator per frame on a synthetic scene at the
    /// ECU's full budget (16 objects x 128 points + 256 static tracks); `--frames` sets how many
    /// frames are timed (default 300). Build with `--release` for meaningful figures.
    #[arg(long, alias = "bench")]
    pub cost: bool,
}

impl EstimateArgs {
    /// The estimator profiles asked for, in order.
    ///
    /// # Errors
    /// A name that is no profile, or none at all.
    pub fn profiles(&self) -> anyhow::Result<Vec<EstimatorProfile>> {
        let names = || PROFILES.iter().map(|p| p.name).collect::<Vec<_>>().join(", ");
        let out = self
            .profiles
            .iter()
            .map(|n| {
                EstimatorProfile::named(n.trim())
                    .with_context(|| format!("--profile: `{n}` is not a profile (expected one of {})", names()))
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        anyhow::ensure!(!out.is_empty(), "--profile: expected at least one of {}", names());
        Ok(out)
    }

    /// The evaluation options with `profile`.
    ///
    /// # Errors
    /// A bad class name or rate.
    pub fn options_for(&self, profile: EstimatorProfile) -> anyhow::Result<EvalOptions> {
        anyhow::ensure!(
            self.rate.hz.is_finite() && self.rate.hz > 0.0,
            "--rate: expected a positive frame rate in Hz, found {}",
            self.rate.hz
        );
        let classes = self.classes.list.clone();
        let noise = |v: f64| if self.noise_free { 0.0 } else { v };
        let defaults =
            dynotraj_core::estimate::EstimatorParams::kitti(dynotraj_core::estimate::Intrinsics::KITTI_0926, 0.1);
        let opt = EvalOptions {
            dt: self.rate.period(),
            classes,
            min_step_m: self.min_step.metres,
            seed: self.seed,
            pixel_sigma: noise(self.pixel_sigma),
            disparity_sigma: noise(self.disparity_sigma),
            outlier_fraction: noise(self.outliers),
            track_lifetime: if self.noise_free { 0 } else { self.track_lifetime },
            object_smoother: SmootherParams {
                sigma_translation: self.object_sigma_t,
                sigma_rotation: self.object_sigma_r,
            },
            camera_smoother: defaults.camera_smoother,
            max_frames: self.frames,
            object_variants: self.ours.object_variants(),
            render_optics: self.ours.render_optics.optics(),
            point_depth: self.ours.point_depth.options(),
            hybrid_object_smoother: self.hybrid_object_smoother,
            ..EvalOptions::kitti(self.rate.period())
        }
        .with_profile(profile);
        Ok(EvalOptions { joint_sweeps: self.joint_sweeps.unwrap_or(opt.joint_sweeps), ..opt })
    }

    /// The evaluation options with the first profile asked for.
    ///
    /// # Errors
    /// A bad class name, rate or profile.
    pub fn options(&self) -> anyhow::Result<EvalOptions> {
        self.options_for(self.profiles()?.first().copied().unwrap_or(dynotraj_core::estimate::HOST_PROFILE))
    }
}

/// An `--outliers` share from which most of the simulated tracks lie: the estimate is then
/// expected to fail, which deserves a word before it does.
pub const OUTLIERS_WARNING: f64 = 0.5;

/// A share of frames with numerical failures from which the estimate is said to be unreliable.
pub const NUMERICAL_FAILURE_SHARE: f64 = 0.05;

/// The warning for `failures` numerical failures in `frames` frames of sequence `id`, when they
/// are [`NUMERICAL_FAILURE_SHARE`] of the frames or more: each is a solve the estimator
/// answered by holding its state, so many of them mean the figures printed are not the
/// estimator's.
#[must_use]
pub fn numerical_warning(id: &str, profile: &str, failures: u32, frames: usize) -> Option<String> {
    (failures > 0 && f64::from(failures) >= NUMERICAL_FAILURE_SHARE * frames as f64).then(|| {
        format!(
            "warning: sequence {id} ({profile} profile): {failures} numerical failures in {frames} frames (singular or \
             non-finite systems, answered by holding the state): the figures are not trustworthy; check the \
             calibration and the noise settings (--counters lists every counter)"
        )
    })
}

/// Runs every sequence, prints the tables and writes the files.
///
/// # Errors
/// Loading or writing errors, named.
pub fn run(args: &EstimateArgs) -> anyhow::Result<()> {
    args.out.as_deref().map(|d| super::common::output_folder("--out", d)).transpose()?;
    let mut names = if args.cost {
        vec!["cost"]
    } else if args.tracks.is_some() {
        vec!["replay"]
    } else {
        vec!["table_iii", "restarts", "smoothness"]
    };
    if args.counters && !args.cost {
        names.push("counters");
    }
    if args.per_object && !args.cost && args.tracks.is_none() {
        names.push("per_object");
    }
    if args.rpe_sources && !args.cost && args.tracks.is_none() {
        names.push("rpe_sources");
    }
    check_table(args.format, args.table.as_deref(), &names)?;
    if args.cost {
        let sweeps = args.joint_sweeps.unwrap_or(dynotraj_core::estimate::HOST_PROFILE.joint_sweeps);
        let r = dynotraj_sources::estimation::cost::measure(args.frames.unwrap_or(300), 30, args.seed, sweeps);
        return print_tables(args, vec![("cost", cost_table(&r))]);
    }
    if let Some(path) = &args.tracks {
        let (t, counters) = replay(args, path)?;
        let mut named = vec![("replay", t)];
        if args.counters {
            named.push(("counters", counters));
        }
        return print_tables(args, named);
    }
    if !args.noise_free && args.outliers >= OUTLIERS_WARNING {
        eprintln!(
            "warning: --outliers {}: at least {:.0} % of every frame's simulated tracks are outliers; expect the \
             estimate to fail",
            args.outliers,
            OUTLIERS_WARNING * 100.0
        );
    }
    let results = estimate_sequences(args)?;
    for r in &results {
        if let Some(w) = numerical_warning(&r.id, r.profile, r.stats.numerical_failures, r.frames) {
            eprintln!("{w}");
        }
        if let Some((h, own)) = &r.hybrid {
            let rpe = |scores: &dynotraj_sources::estimation::RunScores, kind: usize| {
                scores.kinds.get(kind).and_then(|k| k.object).map_or(f64::NAN, |o| o.translation)
            };
            eprintln!(
                "sequence {} ({} profile): hybrid smoother object RPE_t causal {:.3} m, smoothed {:.3} m; the \
                 estimator's on the same pairs {:.3} m, {:.3} m ({} causal and {} smoothed poses; left out {} and {} \
                 estimates the hybrid smoother has no pose for; {} solves failed)",
                r.id,
                r.profile,
                rpe(&r.scores, 1),
                rpe(&r.scores, 2),
                rpe(own, 1),
                rpe(own, 2),
                h.causal,
                h.smoothed,
                h.causal_left_out,
                h.smoothed_left_out,
                h.failed_solves
            );
        }
    }
    if let (true, Some(dir)) = (args.write_tracks, &args.out) {
        std::fs::create_dir_all(dir).with_context(|| format!("--out: creating {}", dir.display()))?;
        // Every profile estimates the same simulated tracks: write them once.
        let first_profile = results.first().map(|r| r.profile);
        for r in results.iter().filter(|r| Some(r.profile) == first_profile) {
            let path = tracks_path(dir, &r.id);
            write_tracks(&path, &camera_info(&r.intrinsics, args.rate.hz), &r.sim)
                .with_context(|| format!("--write-tracks {}", path.display()))?;
            eprintln!("wrote {}", path.display());
        }
    }
    if args.format == Format::Md {
        for t in tables(&results) {
            println!("{}", t.render(args.format));
        }
    }
    let mut named = if args.format == Format::Md { Vec::new() } else { data_tables(&results) };
    if args.counters {
        named.push(("counters", counters_table(&results)));
    }
    if args.per_object {
        named.push(("per_object", per_object_table(&results)));
    }
    if args.rpe_sources {
        named.push(("rpe_sources", rpe_sources_table(&results)));
    }
    print_tables(args, named)?;
    if let Some(out) = &args.out {
        let several = args.profiles.len() > 1;
        for r in &results {
            let dir = if several { out.join(r.profile).join(&r.id) } else { out.join(&r.id) };
            write_run(&dir, &r.sim, &r.run)?;
            eprintln!("wrote {}", dir.display());
        }
    }
    if let Some(target) = &args.record {
        let several_profiles = args.profiles.len() > 1;
        for r in &results {
            let path = record_path(target, results.len() > 1, several_profiles.then_some(r.profile), &r.id);
            let frames: Vec<(u32, &[Track])> = r.sim.iter().map(|f| (f.frame, f.tracks.as_slice())).collect();
            let input = RecordInput {
                frames: &frames,
                run: &r.run,
                truth: &r.sim,
                intrinsics: r.intrinsics,
                rate_hz: f64::from(args.rate.hz),
            };
            report_recording(&record(&path, &input).context("--record")?);
        }
    }
    Ok(())
}

/// What a recording of an estimate is made from.
#[derive(Debug, Clone, Copy)]
pub struct RecordInput<'a> {
    /// Per frame estimated: its index and the tracks the estimator got.
    pub frames: &'a [(u32, &'a [Track])],
    /// The estimator's outputs, indexed like `frames`.
    pub run: &'a EstimatorRun,
    /// The simulator's frames, indexed like `frames`, for their truth; empty without truth.
    pub truth: &'a [SimFrame],
    /// The camera the tracks were measured with.
    pub intrinsics: Intrinsics,
    /// Frames per second: a frame's log time is its index over it.
    pub rate_hz: f64,
}

/// Colour of the estimated object trajectories.
const ESTIMATED_COLOR: Rgba = Rgba::opaque(1.0, 0.55, 0.1);
/// Colour of the true object trajectories.
const TRUTH_COLOR: Rgba = Rgba::opaque(0.2, 0.85, 0.3);

/// Writes the recording of an estimator run to `path`: per frame (log time: frame index over
/// the rate), the causal camera pose (`/tf`, `/camera/path`), each object's causal bird's-eye
/// trajectory so far (`/objects/estimated`), with truth the true ones (`/objects/truth`,
/// `/camera/truth`), and the frame's tracks back-projected into the camera frame, static and
/// object points apart (`/points/static`, `/points/objects`). The estimator keeps its
/// landmarks to itself; these points are its measurements, placed by the estimated camera.
/// Every frame has one message on each topic but `/tf`, which has one per estimated frame.
///
/// # Errors
/// Writing errors, named.
pub fn record(path: &std::path::Path, input: &RecordInput<'_>) -> anyhow::Result<RecordingSummary> {
    let mut rec = Recorder::create(path)?;
    let mut camera_path: Vec<Pose> = Vec::new();
    let mut truth_path: Vec<Pose> = Vec::new();
    let mut estimated: BTreeMap<u16, Vec<[f64; 3]>> = BTreeMap::new();
    let mut truth: BTreeMap<u16, Vec<[f64; 3]>> = BTreeMap::new();
    for (i, &(frame, tracks)) in input.frames.iter().enumerate() {
        let t = frame_time_ns(frame, input.rate_hz).with_context(|| format!("recording {}", path.display()))?;
        let mut lines = Vec::new();
        if let Some(e) = input.run.causal.get(i).and_then(Option::as_ref) {
            let (p, q) = (e.camera.translation.vector, e.camera.rotation.coords);
            let pose = Pose::from_camera_world([p.x, p.y, p.z].map(f64::from), [q.x, q.y, q.z, q.w].map(f64::from));
            rec.camera_transform("/tf", t, &pose)?;
            camera_path.push(pose);
            for o in e.objects.iter().filter(|o| o.bev.is_finite()) {
                let points = estimated.entry(o.object_id).or_default();
                points.push([f64::from(o.bev.x), f64::from(o.bev.y), 0.0]);
                lines.push(object_line(o.object_id, o.class, points, ESTIMATED_COLOR));
            }
        }
        rec.poses("/camera/path", t, WORLD_FRAME, &camera_path)?;
        rec.lines("/objects/estimated", t, &lines)?;
        if let Some(f) = input.truth.get(i) {
            let (p, q) = (f.camera.translation.vector, f.camera.rotation.coords);
            truth_path.push(Pose::from_camera_world([p.x, p.y, p.z], [q.x, q.y, q.z, q.w]));
            rec.poses("/camera/truth", t, WORLD_FRAME, &truth_path)?;
            let lines: Vec<Line> = f
                .objects
                .iter()
                .map(|o| {
                    let c = o.pose.translation.vector;
                    let points = truth.entry(o.object_id).or_default();
                    points.push([c.x, c.z, 0.0]);
                    object_line(o.object_id, o.class, points, TRUTH_COLOR)
                })
                .collect();
            rec.lines("/objects/truth", t, &lines)?;
        }
        let (statics, objects): (Vec<&Track>, Vec<&Track>) = tracks.iter().partition(|k| k.is_static());
        rec.points("/points/static", t, CAMERA_FRAME, &back_project(&statics, &input.intrinsics))?;
        rec.points("/points/objects", t, CAMERA_FRAME, &back_project(&objects, &input.intrinsics))?;
    }
    rec.finish()
}

/// An object's trajectory as a line entity (its id the object id).
fn object_line(id: u16, class: ObjectClass, points: &[[f64; 3]], color: Rgba) -> Line {
    Line {
        id: id.to_string(),
        points: points.to_vec(),
        color,
        thickness: 0.15,
        metadata: vec![("class".into(), format!("{class:?}"))],
    }
}

/// Tracks (pixel and depth) as points of the camera frame (x right, y down, z forward).
fn back_project(tracks: &[&Track], k: &Intrinsics) -> Vec<[f32; 3]> {
    tracks.iter().filter_map(|t| super::common::track_point(t, [k.fx, k.fy], [k.cx, k.cy])).collect()
}

/// Says where a recording went.
fn report_recording(summary: &RecordingSummary) {
    eprintln!("recorded {} ({} bytes)", summary.path.display(), summary.bytes);
}

/// Prints `named` tables in `--format`: Markdown each followed by a blank line, CSV or JSON as
/// [`render_tables`] does (`--table` choosing one).
fn print_tables(args: &EstimateArgs, named: Vec<(&str, Table)>) -> anyhow::Result<()> {
    if args.format == Format::Md {
        for (_, t) in &named {
            println!("{}", t.render(Format::Md));
        }
        return Ok(());
    }
    let refs: Vec<(&str, &Table)> = named.iter().map(|(n, t)| (*n, t)).collect();
    print!("{}", render_tables(args.format, args.table.as_deref(), &refs)?);
    Ok(())
}

/// A run of the estimator on a recorded tracks file.
#[derive(Debug, Clone)]
pub struct Replay {
    /// The frames as read (index, timestamp).
    pub frames: Vec<(u32, u64)>,
    /// The estimator's outputs, indexed like `frames`.
    pub run: EstimatorRun,
    /// Wall time of estimation, seconds.
    pub estimate_seconds: f64,
    /// Each frame's tracks as read, indexed like `frames`.
    pub tracks: Vec<Vec<Track>>,
    /// The camera of the tracks file.
    pub intrinsics: Intrinsics,
    /// The tracks file's frame rate, Hz.
    pub rate_hz: f64,
}

/// Estimates on the tracks file `path` with `args`' noise model and priors (no truth, no scores).
///
/// # Errors
/// A tracks file that cannot be read or is not one (named), or a camera model without a usable
/// frame rate.
pub fn estimate_tracks(args: &EstimateArgs, path: &std::path::Path) -> anyhow::Result<Replay> {
    let tracks = dynotraj_formats::tracks_file::read(path)?;
    let cam = tracks.camera;
    anyhow::ensure!(
        cam.frame_rate_hz.is_finite() && cam.frame_rate_hz > 0.0,
        "{}: camera model: frame_rate_hz is {}, expected a positive rate in Hz",
        path.display(),
        cam.frame_rate_hz
    );
    let mut opt = args.options()?;
    // The same expression as `options()` with `--rate`: a file written at rate r replays with
    // the period of a direct run at r, to the bit.
    opt.dt = 1.0 / cam.frame_rate_hz;
    let params = params_for(Intrinsics::from(&cam), sim_max_depth(), opt.pixel_sigma, opt.disparity_sigma, &opt);
    let n = args.frames.unwrap_or(usize::MAX);
    let frames: Vec<TracksFrame> = tracks.frames.into_iter().take(n).collect();
    let t0 = std::time::Instant::now();
    let run = run_with_window(&frames, params, &opt);
    let estimate_seconds = t0.elapsed().as_secs_f64();
    Ok(Replay {
        frames: frames.iter().map(|f| (f.frame, f.timestamp_us)).collect(),
        run,
        estimate_seconds,
        tracks: frames.iter().map(|f| f.parts.iter().flat_map(|p| p.tracks.iter().copied()).collect()).collect(),
        intrinsics: Intrinsics::from(&cam),
        rate_hz: f64::from(cam.frame_rate_hz),
    })
}

/// Estimates on a tracks file, writes the files of `--out`, and returns the summary table and
/// the counters table.
fn replay(args: &EstimateArgs, path: &std::path::Path) -> anyhow::Result<(Table, Table)> {
    let r = estimate_tracks(args, path)?;
    if let Some(out) = &args.out {
        write_estimates(out, &r.frames, &r.run)?;
        eprintln!("wrote {}", out.display());
    }
    if let Some(target) = &args.record {
        let stem = path.file_stem().map_or_else(|| "replay".into(), |s| s.to_string_lossy().into_owned());
        let file = record_path(target, false, None, &stem);
        let frames: Vec<(u32, &[Track])> =
            r.frames.iter().zip(&r.tracks).map(|(&(frame, _), tracks)| (frame, tracks.as_slice())).collect();
        let input =
            RecordInput { frames: &frames, run: &r.run, truth: &[], intrinsics: r.intrinsics, rate_hz: r.rate_hz };
        report_recording(&record(&file, &input).context("--record")?);
    }
    Ok(replay_tables(&path.display().to_string(), r.frames.len(), &r.run, r.estimate_seconds))
}

/// Loads the requested sequences, simulates or renders and tracks each once, and estimates
/// and scores it with every profile asked for: the results per profile, then per sequence.
///
/// # Errors
/// Loading, rendering or cache errors, named.
pub fn estimate_sequences(args: &EstimateArgs) -> anyhow::Result<Vec<SequenceResult>> {
    let profiles = args.profiles()?;
    let options = profiles.iter().map(|p| args.options_for(*p)).collect::<anyhow::Result<Vec<_>>>()?;
    let kitti = args.kitti.as_ref().context("--kitti: the KITTI tracking folder is needed")?;
    let dir = TrackingDir::open(kitti)?;
    let ids = sequence_ids(&dir, &args.sequences)?;
    let label =
        if args.ours.ours_input == SimulatedInput::Rendered { "rendering, tracking, estimating" } else { "estimating" };
    let bar = progress(ids.len() as u64, label);
    let per_sequence = map_jobs(&ids, args.ours.jobs, |id| -> anyhow::Result<Vec<SequenceResult>> {
        let data = dir.load_sequence(id).with_context(|| format!("loading KITTI tracking sequence {id}"))?;
        // The tracks depend on no profile setting: made once, estimated with every profile.
        let base = options.first().context("no profile")?;
        let scale = args.ours.render_scale;
        let (frames, spec) = match args.ours.ours_input {
            SimulatedInput::Tracks => {
                let (sim, spec) = simulate_sequence(&data, base);
                (sim, Some(spec))
            }
            SimulatedInput::Rendered => {
                let frames = render_and_track(id, &data, base, scale, args.ours.estimate_cache.as_deref())
                    .with_context(|| format!("sequence {id}: rendered front-end"))?;
                (frames, None)
            }
        };
        let intrinsics = spec.as_ref().map_or_else(|| rendered_intrinsics(scale), |s| s.intrinsics);
        let out = options
            .iter()
            .map(|opt| {
                let params = spec.as_ref().map_or_else(|| rendered_params(scale, opt), |s| estimator_params(s, opt));
                score_sequence(id, &data, opt, frames.clone(), params, intrinsics)
            })
            .collect();
        bar.set_message(id.clone());
        bar.inc(1);
        Ok(out)
    })?;
    bar.finish_and_clear();
    // Profile-major: every sequence of the first profile, then of the next.
    let mut by_profile: Vec<Vec<SequenceResult>> = profiles.iter().map(|_| Vec::new()).collect();
    for results in per_sequence {
        for (bucket, r) in by_profile.iter_mut().zip(results?) {
            bucket.push(r);
        }
    }
    Ok(by_profile.into_iter().flatten().collect())
}

#[cfg(test)]
mod warning_tests {
    use super::*;

    #[test]
    fn many_numerical_failures_are_said_and_a_few_are_not() {
        assert_eq!(numerical_warning("0003", "host", 0, 100), None);
        assert_eq!(numerical_warning("0003", "host", 4, 100), None);
        let w = numerical_warning("0003", "host", 142, 144).unwrap();
        assert!(w.starts_with("warning: sequence 0003 (host profile): 142 numerical failures in 144 frames"), "{w}");
        assert!(w.contains("--counters"), "{w}");
    }
}
