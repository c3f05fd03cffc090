//! The estimator's tables of `dynotraj estimate` and of the experiment report: the paper's
//! Table III (camera and object RPE) per estimate kind and profile, the restarts of object runs
//! by cause, trajectory smoothness, the estimator's counters and per-object RPE.

use dynotraj_core::estimate::EstimatorStats;

use super::{Table, fmt_opt};
use crate::estimate::bench::BenchResult;
use crate::estimate::evaluate::SequenceResult;
use crate::estimate::score::{moving_objects, object_rpe};
use crate::estimate::{EstimatorRun, Kind, RunScores};

/// The paper's Table III: DynoSAM's averages on real KITTI.
pub const DYNOSAM_TABLE_III: [f64; 4] = [0.04, 0.04, 0.38, 1.04];

/// The tables of `results`, per profile (in the order they first occur): Table III per kind,
/// the restarts of object runs by cause, then smoothness.
#[must_use]
pub fn tables(results: &[SequenceResult]) -> Vec<Table> {
    let mut profiles: Vec<&str> = Vec::new();
    for r in results {
        if !profiles.contains(&r.profile) {
            profiles.push(r.profile);
        }
    }
    let mut out = Vec::new();
    for profile in profiles {
        let rs: Vec<&SequenceResult> = results.iter().filter(|r| r.profile == profile).collect();
        for (k, kind) in Kind::ALL.iter().enumerate() {
            let rows = rs.iter().map(|r| (r.id.as_str(), r.frames, &r.scores));
            out.push(table_iii_of(rows, k, *kind).noted(format!("{profile} profile")));
        }
        out.push(restarts_table(&rs));
        out.push(smoothness_table(&rs));
    }
    out
}

/// Why object runs ended and began again, per sequence: the objects the estimator followed,
/// the runs it tracked them in (from the first fitted motion; a run beyond one per object is a
/// restart), how each ended run ended (an object leaving the view ends as lost), the runs
/// re-oriented once their heading was known, and how often an object resumed its run after
/// coasting through missing frames.
#[must_use]
pub fn restarts_table(results: &[&SequenceResult]) -> Table {
    let mut t = Table::new([
        format!("sequence ({} profile)", results.first().map_or("", |r| r.profile)),
        "objects followed".into(),
        "runs".into(),
        "restarts".into(),
        "ended: lost".into(),
        "ended: fit failed".into(),
        "ended: out of range".into(),
        "re-oriented".into(),
        "resumed after a gap".into(),
        "frames coasted".into(),
    ]);
    let mut sums = [0u64; 9];
    for r in results {
        let followed = objects_followed(r.run.of(Kind::Causal)) as u64;
        let s: &EstimatorStats = &r.stats;
        let runs = u64::from(s.runs_tracked);
        let row = [
            followed,
            runs,
            runs.saturating_sub(followed),
            u64::from(s.runs_ended_lost),
            u64::from(s.runs_ended_fit_failed),
            u64::from(s.runs_ended_out_of_range),
            u64::from(s.objects_reoriented),
            u64::from(s.objects_resumed),
            u64::from(s.object_frames_coasted),
        ];
        for (sum, v) in sums.iter_mut().zip(row) {
            *sum += v;
        }
        t.push(std::iter::once(r.id.clone()).chain(row.iter().map(u64::to_string)));
    }
    t.push(std::iter::once("sum".to_string()).chain(sums.iter().map(u64::to_string)));
    t
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
pub fn smoothness_table(results: &[&SequenceResult]) -> Table {
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
    let mut t = Table::new(["sequence", "profile", "counters (non-zero)", "estimate time (s)"]);
    for r in results {
        t.push([r.id.clone(), r.profile.to_string(), nonzero_counters(&r.stats), format!("{:.2}", r.estimate_seconds)]);
    }
    t
}

/// Per moving object: its class, how much of it the estimator kept (frames in the truth,
/// frames of causal estimate with a known heading, the runs of consecutive frames they form and
/// the longest; 32 frames make an object eligible), and its RPE (pairs scored by the smoothed
/// estimate; every kind on its own pairs).
#[must_use]
pub fn per_object_table(results: &[SequenceResult]) -> Table {
    let mut t = Table::new([
        "sequence",
        "profile",
        "object",
        "class",
        "frames (truth)",
        "frames (causal)",
        "runs",
        "longest run",
        "pairs",
        "f2f RPE_t (m)",
        "f2f RPE_r (deg)",
        "causal RPE_t (m)",
        "causal RPE_r (deg)",
        "smoothed RPE_t (m)",
        "smoothed RPE_r (deg)",
    ]);
    for r in results {
        let causal = crate::trajectory::tracks_of_estimates(r.run.of(Kind::Causal));
        for id in moving_objects(&r.sim, r.min_step_m) {
            let truth: Vec<_> = r.sim.iter().flat_map(|f| f.objects.iter()).filter(|o| o.object_id == id).collect();
            let class = truth.first().map_or("?", |o| o.class.kitti_name());
            let track = causal.iter().find(|c| c.track_id == i32::from(id) - 1);
            let runs: Vec<usize> = track.map(|c| c.runs().map(|run| run.len()).collect()).unwrap_or_default();
            let f = object_rpe(&r.sim, r.run.of(Kind::FrameToFrame), id).result();
            let c = object_rpe(&r.sim, r.run.of(Kind::Causal), id).result();
            let s = object_rpe(&r.sim, r.run.of(Kind::Smoothed), id).result();
            t.push([
                r.id.clone(),
                r.profile.to_string(),
                id.to_string(),
                class.to_string(),
                truth.len().to_string(),
                track.map_or(0, |c| c.frames.len()).to_string(),
                runs.len().to_string(),
                runs.iter().max().copied().unwrap_or(0).to_string(),
                s.map_or(0, |s| s.pairs).to_string(),
                fmt_opt(f.map(|x| x.translation), 3),
                fmt_opt(f.map(|x| x.rotation.to_degrees()), 3),
                fmt_opt(c.map(|x| x.translation), 3),
                fmt_opt(c.map(|x| x.rotation.to_degrees()), 3),
                fmt_opt(s.map(|x| x.translation), 3),
                fmt_opt(s.map(|x| x.rotation.to_degrees()), 3),
            ]);
        }
    }
    t
}

/// The objects (distinct ids) present in any of `estimates`.
pub fn objects_followed(estimates: &[Option<dynotraj_core::estimate::PoseEstimate>]) -> usize {
    estimates
        .iter()
        .flatten()
        .flat_map(|e| e.objects.iter().map(|o| o.object_id))
        .collect::<std::collections::BTreeSet<_>>()
        .len()
}

/// The non-zero counters of `stats` as `name: value` pairs.
pub fn nonzero_counters(stats: &dynotraj_core::estimate::EstimatorStats) -> String {
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

/// The tables of a run on a recorded tracks file (`source` names it): what was followed and how
/// long it took, then the non-zero counters. There is no truth, so no RPE.
#[must_use]
pub fn replay_tables(source: &str, frames: usize, run: &EstimatorRun, estimate_seconds: f64) -> (Table, Table) {
    let objects = |k: Kind| objects_followed(run.of(k));
    let mut t =
        Table::new(["tracks file", "frames", "objects (causal)", "objects (smoothed)", "estimate time (s)", "RPE"]);
    t.push([
        source.to_string(),
        frames.to_string(),
        objects(Kind::Causal).to_string(),
        objects(Kind::Smoothed).to_string(),
        format!("{estimate_seconds:.2}"),
        "not available: a tracks file carries no truth".to_string(),
    ]);
    let mut c = Table::new(["tracks file", "counters (non-zero)"]);
    c.push([source.to_string(), nonzero_counters(&run.stats)]);
    (t, c)
}

/// The estimator's compute benchmark as a table.
#[must_use]
pub fn bench_table(r: &BenchResult) -> Table {
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
