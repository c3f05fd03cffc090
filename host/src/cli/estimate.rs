//! `dynotraj estimate`: the DynoSAM-style estimator on the track-level simulator driven by real
//! KITTI sequences; prints the paper's Table III (camera and object RPE) for the frame-to-frame,
//! causal and smoothed estimates, the smoothness of object trajectories against the KITTI
//! labels, and optionally writes pose files and logs. `--bench` times the estimator per frame.
//! `--write-tracks` records the simulated tracks as a tracks file; `--tracks` estimates on one
//! (no truth: pose files and log only).

use std::path::PathBuf;

use anyhow::Context as _;
use clap::Args;
use dynotraj_core::estimate::{Intrinsics, SmootherParams};
use dynotraj_core::limits::PAPER_FRAME_RATE_HZ;
use dynotraj_core::wire::ObjectClass;

use super::common::progress;
use crate::estimate::evaluate::{
    ECU_WINDOW, EvalOptions, SequenceResult, WINDOW, camera_info, evaluate_sequence, params_for, run_with_window,
    sim_max_depth, write_tracks,
};
use crate::estimate::files::{write_estimates, write_run};
use crate::estimate::runner::{EstimatorRun, PartsFrame};
use crate::estimate::score::{moving_objects, object_rpe};
use crate::estimate::{Kind, RunScores};
use crate::kitti::TrackingDir;
use crate::report::{Format, Table, fmt_opt};

/// The paper's Table III: DynoSAM's averages on real KITTI.
pub const DYNOSAM_TABLE_III: [f64; 4] = [0.04, 0.04, 0.38, 1.04];

/// Options of `dynotraj estimate`.
#[derive(Debug, Args)]
pub struct EstimateArgs {
    /// A KITTI tracking split folder (label_02/, calib/, ego poses), e.g.
    /// ../shared/kitti/tracking/training. Its labels and ego poses drive the simulator.
    #[arg(long = "kitti", visible_alias = "sim-kitti", env = "DYNOTRAJ_KITTI", value_name = "DIR", required_unless_present_any = ["bench", "tracks"])]
    pub kitti: Option<PathBuf>,
    /// Sequences, comma-separated (default: every sequence in the folder).
    #[arg(long = "sequence", visible_alias = "sequences", value_delimiter = ',', value_name = "LIST")]
    pub sequences: Vec<String>,
    /// Instead of simulating, estimate on a recorded tracks file (`.dtt`, the link's byte
    /// stream: camera model, then each frame's tracks). Intrinsics and frame rate come from the
    /// file's camera model; `--pixel-sigma`, `--disparity-sigma` and `--noise-free` set the
    /// noise model the estimator assumes (give the values the recording was simulated with to
    /// reproduce a simulated run bit for bit). A tracks file has no truth: no RPE is printed.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["bench", "write_tracks"])]
    pub tracks: Option<PathBuf>,
    /// Also write the simulated tracks of the (single) sequence as a tracks file (`.dtt`), for
    /// `--tracks` replay.
    #[arg(long, value_name = "FILE")]
    pub write_tracks: Option<PathBuf>,
    /// Folder for pose files (TUM and KITTI, camera and objects) and the per-frame CSV log, one
    /// sub-folder per sequence (with `--tracks`: the folder itself).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Frame rate in Hz for timestamps and speeds (the paper's 20 by default; RPE does not
    /// depend on it).
    #[arg(long, default_value_t = PAPER_FRAME_RATE_HZ, value_name = "HZ")]
    pub rate: f32,
    /// Object classes placed in the scene (KITTI type names, comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "Car,Van,Truck,Tram,Cyclist,Pedestrian", value_name = "LIST")]
    pub classes: Vec<String>,
    /// An object is scored when its true motion averages at least this many metres per frame.
    #[arg(long, default_value_t = 0.1, value_name = "METRES")]
    pub min_step: f64,
    /// Pixel noise of the simulated tracks, pixels.
    #[arg(long, default_value_t = 0.5)]
    pub pixel_sigma: f64,
    /// Disparity noise of the simulated tracks, pixels (depth noise grows with depth squared).
    #[arg(long, default_value_t = 0.5)]
    pub disparity_sigma: f64,
    /// Share of outlier tracks per frame.
    #[arg(long, default_value_t = 0.05)]
    pub outliers: f64,
    /// Mean track lifetime in frames (0: unlimited).
    #[arg(long, default_value_t = 40)]
    pub track_lifetime: usize,
    /// No noise, outliers or track turnover at all.
    #[arg(long)]
    pub noise_free: bool,
    /// Object smoother: standard deviation of the change of per-frame translation, metres
    /// (DynoSAM's world-frame value: 0.2).
    #[arg(long, default_value_t = SmootherParams::VEHICLE_OBJECT.sigma_translation)]
    pub object_sigma_t: f32,
    /// Object smoother: standard deviation of the change of per-frame rotation, radians
    /// (DynoSAM's world-frame value: 0.01).
    #[arg(long, default_value_t = SmootherParams::VEHICLE_OBJECT.sigma_rotation)]
    pub object_sigma_r: f32,
    /// Block Gauss-Seidel sweeps of the joint camera-object smoother per frame; 0 smooths the
    /// camera and each object apart (objects against the frame-to-frame camera).
    #[arg(long, default_value_t = dynotraj_core::estimate::joint::JOINT_SWEEPS as u8, value_name = "N")]
    pub joint_sweeps: u8,
    /// Smoothing window in frames: 20 (the default, DynoSAM's) or 12 (the ECU firmware's).
    #[arg(long, default_value_t = WINDOW, value_name = "FRAMES")]
    pub window: usize,
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
    /// Output format of the tables.
    #[arg(long, value_enum, default_value_t = Format::Md)]
    pub format: Format,
    /// Instead of the KITTI sequences, time the estimator per frame on a synthetic scene at the
    /// ECU's full budget (16 objects x 128 points + 256 static tracks); `--frames` sets how many
    /// frames are timed (default 300). Build with `--release` for meaningful figures.
    #[arg(long)]
    pub bench: bool,
}

impl EstimateArgs {
    /// The evaluation options.
    ///
    /// # Errors
    /// A bad class name or rate.
    pub fn options(&self) -> anyhow::Result<EvalOptions> {
        anyhow::ensure!(
            self.rate.is_finite() && self.rate > 0.0,
            "--rate: expected a positive frame rate in Hz, found {}",
            self.rate
        );
        anyhow::ensure!(
            self.window == WINDOW || self.window == ECU_WINDOW,
            "--window: expected {WINDOW} or {ECU_WINDOW} frames, found {}",
            self.window
        );
        let classes = self
            .classes
            .iter()
            .map(|c| {
                ObjectClass::from_kitti_name(c.trim()).with_context(|| format!("--classes: `{c}` is not a KITTI type"))
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        let noise = |v: f64| if self.noise_free { 0.0 } else { v };
        let defaults =
            dynotraj_core::estimate::EstimatorParams::kitti(dynotraj_core::estimate::Intrinsics::KITTI_0926, 0.1);
        Ok(EvalOptions {
            dt: 1.0 / self.rate,
            classes,
            min_step_m: self.min_step,
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
            joint_sweeps: self.joint_sweeps,
            window: self.window,
        })
    }
}

/// Runs every sequence, prints the tables and writes the files.
///
/// # Errors
/// Loading or writing errors, named.
pub fn run(args: &EstimateArgs) -> anyhow::Result<()> {
    if args.bench {
        println!("{}", bench_table(args).render(args.format));
        return Ok(());
    }
    if let Some(path) = &args.tracks {
        let (t, counters) = replay(args, path)?;
        println!("{}", t.render(args.format));
        if args.counters {
            println!("{}", counters.render(args.format));
        }
        return Ok(());
    }
    if args.write_tracks.is_some() {
        anyhow::ensure!(
            args.sequences.len() == 1,
            "--write-tracks: give exactly one --sequence (found {})",
            args.sequences.len()
        );
    }
    let results = evaluate(args)?;
    if let (Some(path), Some(r)) = (&args.write_tracks, results.first()) {
        write_tracks(path, &camera_info(&r.intrinsics, args.rate), &r.sim)
            .with_context(|| format!("--write-tracks {}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    for t in tables(&results) {
        println!("{}", t.render(args.format));
    }
    if args.counters {
        println!("{}", counters_table(&results).render(args.format));
    }
    if args.per_object {
        println!("{}", per_object_table(&results).render(args.format));
    }
    if let Some(out) = &args.out {
        for r in &results {
            let dir = out.join(&r.id);
            write_run(&dir, &r.sim, &r.run)?;
            eprintln!("wrote {}", dir.display());
        }
    }
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
}

/// Estimates on the tracks file `path` with `args`' noise model and priors (no truth, no scores).
///
/// # Errors
/// A tracks file that cannot be read or is not one (named), or a camera model without a usable
/// frame rate.
pub fn estimate_tracks(args: &EstimateArgs, path: &std::path::Path) -> anyhow::Result<Replay> {
    let tracks = crate::tracks_file::read(path)?;
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
    let frames: Vec<PartsFrame> = tracks
        .frames
        .into_iter()
        .take(n)
        .map(|f| PartsFrame { frame: f.frame, timestamp_us: f.timestamp_us, parts: f.parts })
        .collect();
    let t0 = std::time::Instant::now();
    let run = run_with_window(&frames, params, &opt);
    let estimate_seconds = t0.elapsed().as_secs_f64();
    Ok(Replay { frames: frames.iter().map(|f| (f.frame, f.timestamp_us)).collect(), run, estimate_seconds })
}

/// Estimates on a tracks file, writes the files of `--out`, and returns the summary table and
/// the counters table.
fn replay(args: &EstimateArgs, path: &std::path::Path) -> anyhow::Result<(Table, Table)> {
    let r = estimate_tracks(args, path)?;
    if let Some(out) = &args.out {
        write_estimates(out, &r.frames, &r.run)?;
        eprintln!("wrote {}", out.display());
    }
    let objects = |k: Kind| {
        r.run
            .of(k)
            .iter()
            .flatten()
            .flat_map(|e| e.objects.iter().map(|o| o.object_id))
            .collect::<std::collections::BTreeSet<_>>()
            .len()
    };
    let mut t =
        Table::new(["tracks file", "frames", "objects (causal)", "objects (smoothed)", "estimate time (s)", "RPE"]);
    t.push([
        path.display().to_string(),
        r.frames.len().to_string(),
        objects(Kind::Causal).to_string(),
        objects(Kind::Smoothed).to_string(),
        format!("{:.2}", r.estimate_seconds),
        "not available: a tracks file carries no truth".to_string(),
    ]);
    let mut c = Table::new(["tracks file", "counters (non-zero)"]);
    c.push([path.display().to_string(), nonzero_counters(&r.run.stats)]);
    Ok((t, c))
}

/// The non-zero counters of `stats` as `name: value` pairs.
fn nonzero_counters(stats: &dynotraj_core::estimate::EstimatorStats) -> String {
    let text = format!("{stats:?}");
    let nonzero: Vec<&str> = text
        .trim_start_matches("EstimatorStats {")
        .trim_end_matches('}')
        .split(',')
        .map(str::trim)
        .filter(|kv| !kv.ends_with(": 0") && !kv.is_empty())
        .collect();
    nonzero.join(" ")
}

/// Loads, simulates, estimates and scores the requested sequences.
///
/// # Errors
/// Loading errors, named.
pub fn evaluate(args: &EstimateArgs) -> anyhow::Result<Vec<SequenceResult>> {
    let opt = args.options()?;
    let kitti = args.kitti.as_ref().context("--kitti: the KITTI tracking folder is needed")?;
    let dir = TrackingDir::open(kitti)?;
    let ids: Vec<String> = if args.sequences.is_empty() { dir.sequences()? } else { args.sequences.clone() };
    let bar = progress(ids.len() as u64, "estimating");
    let mut out = Vec::new();
    for id in &ids {
        bar.set_message(id.clone());
        let data = dir.load_sequence(id).with_context(|| format!("loading KITTI tracking sequence {id}"))?;
        out.push(evaluate_sequence(id, &data, &opt));
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(out)
}

/// The tables of `results`: Table III per kind, then smoothness.
#[must_use]
pub fn tables(results: &[SequenceResult]) -> Vec<Table> {
    let mut out: Vec<Table> = Kind::ALL.iter().enumerate().map(|(k, kind)| table_iii(results, k, *kind)).collect();
    out.push(smoothness_table(results));
    out
}

/// The paper's Table III layout for one kind of estimate.
#[must_use]
pub fn table_iii(results: &[SequenceResult], k: usize, kind: Kind) -> Table {
    table_iii_of(results.iter().map(|r| (r.id.as_str(), r.frames, &r.scores)), k, kind)
}

/// The paper's Table III layout for one kind of estimate (`k`: its index in [`Kind::ALL`]) from
/// (sequence id, frames, scores) rows.
#[must_use]
pub fn table_iii_of<'a>(
    rows: impl IntoIterator<Item = (&'a str, usize, &'a RunScores)>,
    k: usize,
    kind: Kind,
) -> Table {
    let label = match kind {
        Kind::FrameToFrame => "frame-to-frame",
        Kind::Causal => "causal (smoother, newest frame)",
        Kind::Smoothed => "smoothed (fixed lag W - 1)",
    };
    let mut t = Table::new([
        format!("sequence ({label})"),
        "frames".into(),
        "camera RPE_t (m)".into(),
        "camera RPE_r (deg)".into(),
        "objects".into(),
        "object RPE_t (m)".into(),
        "object RPE_r (deg)".into(),
    ]);
    let mut sums = [0.0f64; 4];
    let mut counts = [0usize; 4];
    for (id, frames, scores) in rows {
        let s = scores.kinds[k];
        let vals = [
            s.camera.map(|c| c.translation),
            s.camera.map(|c| c.rotation.to_degrees()),
            s.object.map(|o| o.translation),
            s.object.map(|o| o.rotation.to_degrees()),
        ];
        for (i, v) in vals.iter().enumerate() {
            if let Some(v) = v {
                sums[i] += v;
                counts[i] += 1;
            }
        }
        t.push([
            id.to_string(),
            frames.to_string(),
            fmt_opt(vals[0], 4),
            fmt_opt(vals[1], 4),
            format!("{}/{}", s.objects, scores.moving_objects),
            fmt_opt(vals[2], 3),
            fmt_opt(vals[3], 3),
        ]);
    }
    let mean = |i: usize| (counts[i] > 0).then(|| sums[i] / counts[i] as f64);
    t.push([
        "average".to_string(),
        String::new(),
        fmt_opt(mean(0), 3),
        fmt_opt(mean(1), 3),
        String::new(),
        fmt_opt(mean(2), 3),
        fmt_opt(mean(3), 3),
    ]);
    let d = DYNOSAM_TABLE_III;
    t.push([
        "DynoSAM on real KITTI (paper)".to_string(),
        String::new(),
        format!("{:.2}", d[0]),
        format!("{:.2}", d[1]),
        String::new(),
        format!("{:.2}", d[2]),
        format!("{:.2}", d[3]),
    ]);
    t
}

/// Mean |delta heading| (deg) and |delta speed| (m/s) between consecutive frames of moving
/// objects: KITTI labels and simulator truth on the smoothed estimate's frame pairs, and each
/// estimate on its own pairs.
#[must_use]
pub fn smoothness_table(results: &[SequenceResult]) -> Table {
    let names = ["KITTI labels", "simulator truth", "frame-to-frame", "causal", "smoothed"];
    let mut headers = vec!["sequence".to_string()];
    for n in names {
        headers.push(format!("{n} |dh| (deg)"));
        headers.push(format!("{n} |dv| (m/s)"));
    }
    let mut t = Table::new(headers);
    let mut sums = [(0.0f64, 0.0f64, 0usize); 5];
    for r in results {
        let mut row = vec![r.id.clone()];
        for (i, s) in r.smoothness.iter().enumerate() {
            let ok = s.pairs > 0;
            row.push(fmt_opt(ok.then(|| s.heading.to_degrees()), 3));
            row.push(fmt_opt(ok.then_some(s.speed), 3));
            if ok {
                sums[i].0 += s.heading.to_degrees() * s.pairs as f64;
                sums[i].1 += s.speed * s.pairs as f64;
                sums[i].2 += s.pairs;
            }
        }
        t.push(row);
    }
    let mut row = vec!["all (pair-weighted)".to_string()];
    for (h, v, n) in sums {
        row.push(fmt_opt((n > 0).then(|| h / n as f64), 3));
        row.push(fmt_opt((n > 0).then(|| v / n as f64), 3));
    }
    t.push(row);
    t
}

/// The estimator's counters per sequence (only the non-zero ones).
#[must_use]
pub fn counters_table(results: &[SequenceResult]) -> Table {
    let mut t = Table::new(["sequence", "counters (non-zero)", "estimate time (s)"]);
    for r in results {
        t.push([r.id.clone(), nonzero_counters(&r.stats), format!("{:.2}", r.estimate_seconds)]);
    }
    t
}

/// RPE per moving object, smoothed and frame-to-frame, with its class and pairs scored.
#[must_use]
pub fn per_object_table(results: &[SequenceResult]) -> Table {
    let mut t = Table::new([
        "sequence",
        "object",
        "class",
        "pairs",
        "f2f RPE_t (m)",
        "f2f RPE_r (deg)",
        "smoothed RPE_t (m)",
        "smoothed RPE_r (deg)",
    ]);
    for r in results {
        for id in moving_objects(&r.sim, r.min_step_m) {
            let class = r
                .sim
                .iter()
                .flat_map(|f| f.objects.iter())
                .find(|o| o.object_id == id)
                .map_or("?", |o| o.class.kitti_name());
            let f = object_rpe(&r.sim, r.run.of(Kind::FrameToFrame), id).result();
            let s = object_rpe(&r.sim, r.run.of(Kind::Smoothed), id).result();
            t.push([
                r.id.clone(),
                id.to_string(),
                class.to_string(),
                s.map_or(0, |s| s.pairs).to_string(),
                fmt_opt(f.map(|x| x.translation), 3),
                fmt_opt(f.map(|x| x.rotation.to_degrees()), 3),
                fmt_opt(s.map(|x| x.translation), 3),
                fmt_opt(s.map(|x| x.rotation.to_degrees()), 3),
            ]);
        }
    }
    t
}

/// The compute benchmark as a table.
#[must_use]
pub fn bench_table(args: &EstimateArgs) -> Table {
    let r = crate::estimate::bench::bench(args.frames.unwrap_or(300), 30, args.seed, args.joint_sweeps);
    let mut t = Table::new(["quantity", "value"]);
    let profile = if cfg!(debug_assertions) { "debug (use --release)" } else { "release" };
    t.push(["build".to_string(), profile.to_string()]);
    t.push(["frames timed".to_string(), r.frames.to_string()]);
    t.push(["tracks per frame (mean)".to_string(), format!("{:.0}", r.tracks_per_frame)]);
    t.push(["objects estimated per frame (mean)".to_string(), format!("{:.1}", r.objects_per_frame)]);
    t.push(["time per frame, mean (us)".to_string(), format!("{:.0}", r.mean())]);
    t.push(["time per frame, median (us)".to_string(), format!("{:.0}", r.quantile(0.5))]);
    t.push(["time per frame, 95th percentile (us)".to_string(), format!("{:.0}", r.quantile(0.95))]);
    t.push(["time per frame, max (us)".to_string(), format!("{:.0}", r.quantile(1.0))]);
    t.push(["estimator state (bytes)".to_string(), r.state_bytes.to_string()]);
    t
}
