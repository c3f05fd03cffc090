//! The estimator scored on KITTI sequences (the paper's Table III): each sequence simulated at
//! the track level or rendered and tracked once, estimated with every profile asked for, scored
//! against the labels; or a tracks recording estimated with no truth. What the `estimate`
//! command runs; its tables are in [`crate::report::estimator_tables`], its pose files in
//! [`pose_files`].

pub mod pose_files;

use std::path::Path;

use anyhow::Context as _;
use dynotraj_core::estimate::Intrinsics;
use dynotraj_core::wire::Track;
use dynotraj_formats::kitti::TrackingDir;
use dynotraj_formats::tracks_file::{TracksFrame, tracks_path};
use dynotraj_sources::drives::sequence_ids;
use dynotraj_sources::estimation::RunScores;
use dynotraj_sources::estimation::from_images::{render_and_track, rendered_intrinsics, rendered_params};
use dynotraj_sources::estimation::runner::EstimatorRun;
use dynotraj_sources::estimation::settings::SimulatedInput;
use dynotraj_sources::estimation::simulated::{
    EvalOptions, SequenceResult, camera_info, estimator_params, params_for, run_with_window, score_sequence,
    sim_max_depth, simulate_sequence, write_tracks,
};

use crate::jobs::map_jobs;
use crate::recording::estimate::{RecordInput, record_estimate};
use crate::recording::{record_path, recorded};
use crate::report::Table;
use crate::report::estimator_tables::{
    cost_table, counters_table, data_tables, per_object_table, replay_tables, rpe_sources_table, tables,
};
use dynotraj_bag::record::RecordingEncoding;

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

/// What is said of a result beside the tables: its numerical warning and, when the hybrid
/// smoother ran, its object RPE beside the estimator's on the same pairs.
#[must_use]
pub fn notes(r: &SequenceResult) -> Vec<String> {
    let mut out: Vec<String> =
        numerical_warning(&r.id, r.profile, r.stats.numerical_failures, r.frames).into_iter().collect();
    if let Some((h, own)) = &r.hybrid {
        let rpe = |scores: &RunScores, kind: usize| {
            scores.kinds.get(kind).and_then(|k| k.object).map_or(f64::NAN, |o| o.translation)
        };
        out.push(format!(
            "sequence {} ({} profile): hybrid smoother object RPE_t causal {:.3} m, smoothed {:.3} m; the estimator's \
             on the same pairs {:.3} m, {:.3} m ({} causal and {} smoothed poses; left out {} and {} estimates the \
             hybrid smoother has no pose for; {} solves failed)",
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
        ));
    }
    out
}

/// Which sequences are estimated, from what input, and how.
#[derive(Debug, Clone)]
pub struct SequencesRequest<'a> {
    /// The KITTI tracking folder.
    pub kitti: &'a Path,
    /// The sequences (all of the folder when empty).
    pub sequences: &'a [String],
    /// The options per profile, in the order the results come in; the first one's make the
    /// tracks, which depend on no profile setting.
    pub options: &'a [EvalOptions],
    /// The tracks' source: the track-level simulator or renderings through the front-end.
    pub input: SimulatedInput,
    /// Render scale of renderings.
    pub render_scale: f64,
    /// Where the front-end's tracks of renderings are kept between runs.
    pub cache: Option<&'a Path>,
    /// Sequences worked on at once.
    pub jobs: usize,
}

/// Loads the requested sequences, simulates or renders and tracks each once, and estimates
/// and scores it with every profile's options: the results per profile, then per sequence.
/// `on_sequence` is called with each sequence's id when it is done, and how many there are.
///
/// # Errors
/// Loading, rendering or cache errors, named.
pub fn estimate_sequences(
    request: &SequencesRequest<'_>,
    on_sequence: &(dyn Fn(&str, usize) + Sync),
) -> anyhow::Result<Vec<SequenceResult>> {
    let dir = TrackingDir::open(request.kitti)?;
    let ids = sequence_ids(&dir, request.sequences)?;
    let options = request.options;
    let per_sequence = map_jobs(&ids, request.jobs, |id| -> anyhow::Result<Vec<SequenceResult>> {
        let data = dir.load_sequence(id).with_context(|| format!("loading KITTI tracking sequence {id}"))?;
        // The tracks depend on no profile setting: made once, estimated with every profile.
        let base = options.first().context("no profile")?;
        let scale = request.render_scale;
        let (frames, spec) = match request.input {
            SimulatedInput::Tracks => {
                let (sim, spec) = simulate_sequence(&data, base);
                (sim, Some(spec))
            }
            SimulatedInput::Rendered => {
                let (frames, _) = render_and_track(id, &data, base, scale, request.cache)
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
        on_sequence(id, ids.len());
        Ok(out)
    })?;
    // Profile-major: every sequence of the first profile, then of the next.
    let mut by_profile: Vec<Vec<SequenceResult>> = options.iter().map(|_| Vec::new()).collect();
    for results in per_sequence {
        for (bucket, r) in by_profile.iter_mut().zip(results?) {
            bucket.push(r);
        }
    }
    Ok(by_profile.into_iter().flatten().collect())
}

/// Writes each sequence's simulated tracks once (every profile estimates the same ones) as a
/// tracks file in `dir`, at `rate_hz`; returns the files written.
///
/// # Errors
/// Writing errors, named.
pub fn write_sequence_tracks(
    dir: &Path,
    results: &[SequenceResult],
    rate_hz: f32,
) -> anyhow::Result<Vec<std::path::PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("--out: creating {}", dir.display()))?;
    let first_profile = results.first().map(|r| r.profile);
    let mut out = Vec::new();
    for r in results.iter().filter(|r| Some(r.profile) == first_profile) {
        let path = tracks_path(dir, &r.id);
        write_tracks(&path, &camera_info(&r.intrinsics, rate_hz), &r.sim)
            .with_context(|| format!("--write-tracks {}", path.display()))?;
        out.push(path);
    }
    Ok(out)
}

/// Writes each result's pose files and log under `out` (`out/<profile>/<id>` with several
/// profiles, else `out/<id>`); returns the folders written.
///
/// # Errors
/// Writing errors, named.
pub fn write_sequence_poses(
    out: &Path,
    results: &[SequenceResult],
    several_profiles: bool,
) -> anyhow::Result<Vec<std::path::PathBuf>> {
    let mut dirs = Vec::new();
    for r in results {
        let dir = if several_profiles { out.join(r.profile).join(&r.id) } else { out.join(&r.id) };
        // The renderings are of KITTI drives: the files keep KITTI's capture clock whatever
        // rate the estimator ran at.
        pose_files::write_run(&dir, &r.sim, &r.run, pose_files::FileClock::KITTI)?;
        dirs.push(dir);
    }
    Ok(dirs)
}

/// Records every result ([`record_estimate`]) under `target` ([`record_path`]); returns what
/// is said of each recording.
///
/// # Errors
/// Writing errors, named.
pub fn record_sequences(
    target: &Path,
    results: &[SequenceResult],
    several_profiles: bool,
    rate_hz: f64,
    encoding: RecordingEncoding,
) -> anyhow::Result<Vec<String>> {
    let mut said = Vec::new();
    for r in results {
        let path = record_path(target, results.len() > 1, several_profiles.then_some(r.profile), &r.id);
        let frames: Vec<(u32, &[Track])> = r.sim.iter().map(|f| (f.frame, f.tracks.as_slice())).collect();
        let input = RecordInput { frames: &frames, run: &r.run, truth: &r.sim, intrinsics: r.intrinsics, rate_hz };
        said.push(recorded(&record_estimate(&path, encoding, &input).context("--record")?));
    }
    Ok(said)
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

/// Estimates on the tracks file `path` with `options`' noise model and priors (no truth, no
/// scores), over its first `max_frames` frames.
///
/// # Errors
/// A tracks file that cannot be read or is not one (named), or a camera model without a usable
/// frame rate.
pub fn estimate_tracks(path: &Path, mut options: EvalOptions, max_frames: Option<usize>) -> anyhow::Result<Replay> {
    let tracks = dynotraj_formats::tracks_file::read(path)?;
    let cam = tracks.camera;
    anyhow::ensure!(
        cam.frame_rate_hz.is_finite() && cam.frame_rate_hz > 0.0,
        "{}: camera model: frame_rate_hz is {}, expected a positive rate in Hz",
        path.display(),
        cam.frame_rate_hz
    );
    // The same expression as a direct run's period: a file written at rate r replays with the
    // period of a direct run at r, to the bit.
    options.dt = 1.0 / cam.frame_rate_hz;
    let params =
        params_for(Intrinsics::from(&cam), sim_max_depth(), options.pixel_sigma, options.disparity_sigma, &options);
    let frames: Vec<TracksFrame> = tracks.frames.into_iter().take(max_frames.unwrap_or(usize::MAX)).collect();
    let t0 = std::time::Instant::now();
    let run = run_with_window(&frames, params, &options);
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

impl Replay {
    /// Records this replay of the tracks file `source` under `target` ([`record_path`]);
    /// returns what is said of the recording.
    ///
    /// # Errors
    /// Writing errors, named.
    pub fn record(&self, source: &Path, target: &Path, encoding: RecordingEncoding) -> anyhow::Result<String> {
        let stem = source.file_stem().map_or_else(|| "replay".into(), |s| s.to_string_lossy().into_owned());
        let file = record_path(target, false, None, &stem);
        let frames: Vec<(u32, &[Track])> =
            self.frames.iter().zip(&self.tracks).map(|(&(frame, _), tracks)| (frame, tracks.as_slice())).collect();
        let input = RecordInput {
            frames: &frames,
            run: &self.run,
            truth: &[],
            intrinsics: self.intrinsics,
            rate_hz: self.rate_hz,
        };
        Ok(recorded(&record_estimate(&file, encoding, &input).context("--record")?))
    }
}

/// What the `estimate` command runs.
#[derive(Debug, Clone)]
pub enum EstimateJob<'a> {
    /// The estimator timed per frame on a synthetic scene at the ECU's full budget.
    Cost {
        /// Frames timed.
        frames: usize,
        /// Seed of the scene.
        seed: u64,
        /// Joint solver sweeps per frame.
        joint_sweeps: u8,
    },
    /// A tracks file estimated with no truth.
    Replay {
        /// The tracks file.
        tracks: &'a Path,
        /// The estimator's options (its frame period is the file's).
        options: EvalOptions,
        /// At most this many frames.
        max_frames: Option<usize>,
    },
    /// KITTI sequences estimated and scored (Table III).
    Sequences {
        /// Which sequences, from what input, with which profiles' options.
        request: SequencesRequest<'a>,
        /// Also write each sequence's simulated tracks into `out` as a tracks file.
        write_tracks: bool,
        /// The frame rate the tracks are written at, Hz.
        rate_hz: f32,
    },
}

/// Which tables beyond a job's own are asked for.
#[derive(Debug, Clone, Copy, Default)]
pub struct ExtraTables {
    /// The estimator's counters.
    pub counters: bool,
    /// The RPE of every moving object.
    pub per_object: bool,
    /// Where the object RPE comes from.
    pub rpe_sources: bool,
}

/// The `estimate` command as one request.
#[derive(Debug, Clone)]
pub struct EstimateRequest<'a> {
    /// What to run.
    pub job: EstimateJob<'a>,
    /// Extra tables.
    pub extra: ExtraTables,
    /// Whether the tables go to a program (CSV, JSON: each table's data) rather than a person
    /// (Markdown, Table III in blocks per kind of estimate).
    pub machine_tables: bool,
    /// The folder of pose files (and, with `write_tracks`, tracks files).
    pub out: Option<&'a Path>,
    /// Where recordings go.
    pub record: Option<&'a Path>,
    /// The encoding of recordings.
    pub record_encoding: RecordingEncoding,
    /// Whether more than one profile is run (results then go in a folder per profile).
    pub several_profiles: bool,
}

/// What the `estimate` command has to show: lines said before the tables (warnings, notes,
/// files written before them), the tables for a person (Markdown only) and the named tables,
/// and lines said after them (files written).
#[derive(Debug, Default)]
pub struct EstimateOutput {
    /// Said before the tables.
    pub before: Vec<String>,
    /// Tables printed for a person only (Table III in blocks).
    pub person_tables: Vec<Table>,
    /// Named tables, printed in any format.
    pub named: Vec<(&'static str, Table)>,
    /// Said after the tables.
    pub after: Vec<String>,
}

impl EstimateRequest<'_> {
    /// The names of the tables this request prints, in order: what `--table` may choose.
    #[must_use]
    pub fn table_names(&self) -> Vec<&'static str> {
        let (mut names, truth) = match self.job {
            EstimateJob::Cost { .. } => return vec!["cost"],
            EstimateJob::Replay { .. } => (vec!["replay"], false),
            EstimateJob::Sequences { .. } => (vec!["table_iii", "restarts", "smoothness"], true),
        };
        if self.extra.counters {
            names.push("counters");
        }
        if self.extra.per_object && truth {
            names.push("per_object");
        }
        if self.extra.rpe_sources && truth {
            names.push("rpe_sources");
        }
        names
    }
}

/// Runs the `estimate` command's request: times the estimator, replays a tracks file, or
/// estimates and scores sequences, writing the files asked for; `on_sequence` as for
/// [`estimate_sequences`].
///
/// # Errors
/// Loading, estimating or writing errors, named.
pub fn estimate(
    request: &EstimateRequest<'_>,
    on_sequence: &(dyn Fn(&str, usize) + Sync),
) -> anyhow::Result<EstimateOutput> {
    let mut out = EstimateOutput::default();
    match &request.job {
        &EstimateJob::Cost { frames, seed, joint_sweeps } => {
            let r = dynotraj_sources::estimation::cost::measure(frames, 30, seed, joint_sweeps);
            out.named.push(("cost", cost_table(&r)));
        }
        EstimateJob::Replay { tracks, options, max_frames } => {
            let r = estimate_tracks(tracks, options.clone(), *max_frames)?;
            if let Some(dir) = request.out {
                pose_files::write_estimates(dir, &r.frames, &r.run, pose_files::FileClock { rate_hz: r.rate_hz })?;
                out.before.push(format!("wrote {}", dir.display()));
            }
            if let Some(target) = request.record {
                out.before.push(r.record(tracks, target, request.record_encoding)?);
            }
            let (t, counters) =
                replay_tables(&tracks.display().to_string(), r.frames.len(), &r.run, r.estimate_seconds);
            out.named.push(("replay", t));
            if request.extra.counters {
                out.named.push(("counters", counters));
            }
        }
        EstimateJob::Sequences { request: sequences, write_tracks, rate_hz } => {
            let results = estimate_sequences(sequences, on_sequence)?;
            out.before.extend(results.iter().flat_map(notes));
            if let (true, Some(dir)) = (*write_tracks, request.out) {
                for path in write_sequence_tracks(dir, &results, *rate_hz)? {
                    out.before.push(format!("wrote {}", path.display()));
                }
            }
            if request.machine_tables {
                out.named = data_tables(&results);
            } else {
                out.person_tables = tables(&results);
            }
            if request.extra.counters {
                out.named.push(("counters", counters_table(&results)));
            }
            if request.extra.per_object {
                out.named.push(("per_object", per_object_table(&results)));
            }
            if request.extra.rpe_sources {
                out.named.push(("rpe_sources", rpe_sources_table(&results)));
            }
            if let Some(dir) = request.out {
                for written in write_sequence_poses(dir, &results, request.several_profiles)? {
                    out.after.push(format!("wrote {}", written.display()));
                }
            }
            if let Some(target) = request.record {
                out.after.extend(record_sequences(
                    target,
                    &results,
                    request.several_profiles,
                    f64::from(*rate_hz),
                    request.record_encoding,
                )?);
            }
        }
    }
    Ok(out)
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
