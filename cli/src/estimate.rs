//! `dynotraj estimate`: the DynoSAM-style estimator on real KITTI sequences, rendered by the
//! image simulator and tracked by the front-end (`--ours-input rendered`, the default, as every
//! command) or simulated at the track level (`--ours-input tracks`), with one or more estimator
//! profiles (`--profile host,edge`); prints the paper's Table III (camera and object RPE) for
//! the frame-to-frame, causal and smoothed estimates, the restarts of object runs by cause, the
//! smoothness of object trajectories against the KITTI labels, and optionally writes pose files
//! and logs. `--cost` times the estimator per frame. `--write-tracks` records the tracks as a
//! tracks file; `--tracks` estimates on one (no truth: pose files and log only).

use std::path::PathBuf;

use anyhow::Context as _;
use clap::Args;
use dynotraj_core::estimate::{EstimatorProfile, PROFILES, SmootherParams};

use super::data_args::{ClassesArg, FrameRateArg, MinStepArg};
use super::estimated_args::EstimatedSourceArgs;
use super::progress::progress;
use dynotraj_eval::estimation::{
    EstimateJob, EstimateRequest, ExtraTables, OUTLIERS_WARNING, SequencesRequest, estimate,
};
use dynotraj_eval::report::{Format, Table, check_table, render_tables};
use dynotraj_sources::estimation::settings::SimulatedInput;
use dynotraj_sources::estimation::simulated::{EvalOptions, SequenceResult};

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
    /// Also write recordings to look at in Foxglove: MCAP (Foxglove's schemas; --record-encoding) with, per
    /// frame, the estimated camera (`/tf`: world to camera; `/camera/path`), each object's
    /// estimated trajectory so far (`/objects/estimated`, causal estimates), with simulated input
    /// the simulator's truth (`/objects/truth`, `/camera/truth`), and the frame's measured
    /// points in the camera frame (`/points/static`, `/points/objects`). One sequence (or
    /// --tracks): FILE is the recording; several sequences or profiles, or FILE an existing
    /// folder: FILE is a folder of `<sequence>.mcap` (`<profile>/<sequence>.mcap` with several
    /// profiles; the tracks file's name with --tracks).
    #[arg(long, value_name = "FILE", conflicts_with = "cost")]
    pub record: Option<PathBuf>,
    /// The recordings' encoding.
    #[command(flatten)]
    pub record_encoding: crate::record_args::RecordEncodingArgs,
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
            point_depth: self.ours.point_depth_options(),
            hybrid_object_smoother: self.hybrid_object_smoother,
            ..EvalOptions::kitti(self.rate.period())
        }
        .with_profile(profile);
        Ok(EvalOptions { joint_sweeps: self.joint_sweeps.unwrap_or(opt.joint_sweeps), ..opt })
    }

    /// The evaluation options of every profile asked for, in order.
    ///
    /// # Errors
    /// A bad class name, rate or profile.
    pub fn profile_options(&self) -> anyhow::Result<Vec<EvalOptions>> {
        self.profiles()?.into_iter().map(|p| self.options_for(p)).collect()
    }

    /// The evaluation options with the first profile asked for.
    ///
    /// # Errors
    /// A bad class name, rate or profile.
    pub fn options(&self) -> anyhow::Result<EvalOptions> {
        self.options_for(self.profiles()?.first().copied().unwrap_or(dynotraj_core::estimate::HOST_PROFILE))
    }
}

/// Runs the command ([`dynotraj_eval::estimation::estimate`]) and prints what it has to show.
///
/// # Errors
/// Bad options, loading, estimating or writing errors, named.
pub fn run(args: &EstimateArgs) -> anyhow::Result<()> {
    let options = args.profile_options()?;
    let request = args.request(&options)?;
    if matches!(request.job, EstimateJob::Sequences { .. }) && !args.noise_free && args.outliers >= OUTLIERS_WARNING {
        eprintln!(
            "warning: --outliers {}: at least {:.0} % of every frame's simulated tracks are outliers; expect the \
             estimate to fail",
            args.outliers,
            OUTLIERS_WARNING * 100.0
        );
    }
    let output = if matches!(request.job, EstimateJob::Sequences { .. }) {
        let label = if args.ours.ours_input == SimulatedInput::Rendered {
            "rendering, tracking, estimating"
        } else {
            "estimating"
        };
        let bar = progress(0, label);
        let output = estimate(&request, &|id, total| {
            bar.set_length(total as u64);
            bar.set_message(id.to_string());
            bar.inc(1);
        });
        bar.finish_and_clear();
        output?
    } else {
        estimate(&request, &|_, _| {})?
    };
    for line in &output.before {
        eprintln!("{line}");
    }
    for t in &output.person_tables {
        println!("{}", t.render(Format::Md));
    }
    if args.format == Format::Md {
        for (_, t) in &output.named {
            println!("{}", t.render(Format::Md));
        }
    } else {
        let refs: Vec<(&str, &Table)> = output.named.iter().map(|(n, t)| (*n, t)).collect();
        print!("{}", render_tables(args.format, args.table.as_deref(), &refs)?);
    }
    for line in &output.after {
        eprintln!("{line}");
    }
    Ok(())
}

impl EstimateArgs {
    /// The request these options make, with `options` per profile; the output folder and
    /// `--table` checked before any work.
    ///
    /// # Errors
    /// An output folder that is a file, a `--table` the run does not print, or no `--kitti`.
    pub fn request<'a>(&'a self, options: &'a [EvalOptions]) -> anyhow::Result<EstimateRequest<'a>> {
        self.out.as_deref().map(|d| dynotraj_formats::atomic::output_folder("--out", d)).transpose()?;
        let job = if self.cost {
            EstimateJob::Cost {
                frames: self.frames.unwrap_or(300),
                seed: self.seed,
                joint_sweeps: self.joint_sweeps.unwrap_or(dynotraj_core::estimate::HOST_PROFILE.joint_sweeps),
            }
        } else if let Some(tracks) = &self.tracks {
            let options = options.first().cloned().context("--profile: no profile")?;
            EstimateJob::Replay { tracks, options, max_frames: self.frames }
        } else {
            let kitti = self.kitti.as_ref().context("--kitti: the KITTI tracking folder is needed")?;
            let request = SequencesRequest {
                kitti,
                sequences: &self.sequences,
                options,
                input: self.ours.ours_input,
                render_scale: self.ours.render_scale,
                cache: self.ours.estimate_cache.as_deref(),
                jobs: self.ours.jobs,
            };
            EstimateJob::Sequences { request, write_tracks: self.write_tracks, rate_hz: self.rate.hz }
        };
        let extra = ExtraTables { counters: self.counters, per_object: self.per_object, rpe_sources: self.rpe_sources };
        let request = EstimateRequest {
            job,
            extra,
            machine_tables: self.format != Format::Md,
            out: self.out.as_deref(),
            record: self.record.as_deref(),
            record_encoding: self.record_encoding.into(),
            several_profiles: self.profiles.len() > 1,
        };
        check_table(self.format, self.table.as_deref(), &request.table_names())?;
        Ok(request)
    }
}

/// The requested sequences estimated and scored with every profile asked for
/// ([`dynotraj_eval::estimation::estimate_sequences`]), for tests that read the results.
///
/// # Errors
/// Bad options, loading, rendering or cache errors, named.
pub fn estimate_sequences(args: &EstimateArgs) -> anyhow::Result<Vec<SequenceResult>> {
    let options = args.profile_options()?;
    match args.request(&options)?.job {
        EstimateJob::Sequences { request, .. } => dynotraj_eval::estimation::estimate_sequences(&request, &|_, _| {}),
        _ => anyhow::bail!("--cost and --tracks estimate no sequences"),
    }
}
