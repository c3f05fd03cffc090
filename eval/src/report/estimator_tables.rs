//! The estimator's tables of `dynotraj estimate` and of the experiment report: the paper's
//! Table III (camera and object RPE) per estimate kind and profile, the restarts of object runs
//! by cause, trajectory smoothness, the estimator's counters and per-object RPE.
//!
//! Each table's data (CSV, JSON) has one observation per row and typed columns; aggregate rows
//! are marked by `row_kind` (`data`, `average`, `sum`, `weighted_average`, and
//! `paper_average` for DynoSAM's published figures).

use dynotraj_core::estimate::EstimatorStats;

use super::{Cell, ColumnKind, Data, Table};
use dynotraj_sources::estimation::cost::CostResult;
use dynotraj_sources::estimation::score::{ObjectPair, moving_objects, object_pairs, object_rpe};
use dynotraj_sources::estimation::simulated::SequenceResult;
use dynotraj_sources::estimation::{EstimatorRun, Kind, RunScores};

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

/// The tables of `results` as data, one per layout, every profile in one table (a `profile`
/// column): `table_iii` (every kind of estimate), `restarts` and `smoothness`.
#[must_use]
pub fn data_tables(results: &[SequenceResult]) -> Vec<(&'static str, Table)> {
    let mut profiles: Vec<&str> = Vec::new();
    for r in results {
        if !profiles.contains(&r.profile) {
            profiles.push(r.profile);
        }
    }
    let (mut iii, mut restarts, mut smooth) = (Vec::new(), Vec::new(), Vec::new());
    for profile in profiles {
        let rs: Vec<&SequenceResult> = results.iter().filter(|r| r.profile == profile).collect();
        let p = Cell::text(profile);
        for (k, kind) in Kind::ALL.iter().enumerate() {
            let rows = rs.iter().map(|r| (r.id.as_str(), r.frames, &r.scores));
            iii.push(table_iii_of(rows, k, *kind).data().with_leading("profile", ColumnKind::Text, &p));
        }
        restarts.push(restarts_table(&rs).data().with_leading("profile", ColumnKind::Text, &p));
        smooth.push(smoothness_table(&rs).data().with_leading("profile", ColumnKind::Text, &p));
    }
    let table = |d: Vec<Data>| Table::default().with_data(Data::concat(d));
    vec![("table_iii", table(iii)), ("restarts", table(restarts)), ("smoothness", table(smooth))]
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
    let mut d = Data::new([
        ("row_kind", ColumnKind::Text),
        ("sequence", ColumnKind::Text),
        ("objects_followed", ColumnKind::Int),
        ("runs", ColumnKind::Int),
        ("restarts", ColumnKind::Int),
        ("ended_lost", ColumnKind::Int),
        ("ended_fit_failed", ColumnKind::Int),
        ("ended_out_of_range", ColumnKind::Int),
        ("reoriented", ColumnKind::Int),
        ("resumed_after_gap", ColumnKind::Int),
        ("frames_coasted", ColumnKind::Int),
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
        d.push([Cell::text("data"), Cell::text(r.id.as_str())].into_iter().chain(row.map(Cell::int)).collect());
    }
    t.push(std::iter::once("sum".to_string()).chain(sums.iter().map(u64::to_string)));
    d.push([Cell::text("sum"), Cell::Blank].into_iter().chain(sums.map(Cell::int)).collect());
    t.with_data(d)
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
    let mut d = Data::new([
        ("row_kind", ColumnKind::Text),
        ("estimate", ColumnKind::Text),
        ("sequence", ColumnKind::Text),
        ("frames", ColumnKind::Int),
        ("camera_rpe_t_m", ColumnKind::Num),
        ("camera_rpe_r_deg", ColumnKind::Num),
        ("objects_scored", ColumnKind::Int),
        ("objects_moving", ColumnKind::Int),
        ("object_rpe_t_m", ColumnKind::Num),
        ("object_rpe_r_deg", ColumnKind::Num),
    ]);
    let estimate = Cell::text(kind.name());
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
        let cells = [
            Cell::opt(vals[0], 4),
            Cell::opt(vals[1], 4),
            Cell::int(s.objects),
            Cell::int(scores.moving_objects),
            Cell::opt(vals[2], 3),
            Cell::opt(vals[3], 3),
        ];
        t.push([
            id.to_string(),
            frames.to_string(),
            cells[0].md(),
            cells[1].md(),
            format!("{}/{}", s.objects, scores.moving_objects),
            cells[4].md(),
            cells[5].md(),
        ]);
        let head = [Cell::text("data"), estimate.clone(), Cell::text(id), Cell::int(frames)];
        d.push(head.into_iter().chain(cells).collect());
    }
    let mean = |i: usize| Cell::opt((counts[i] > 0).then(|| sums[i] / counts[i] as f64), 3);
    let averages = [mean(0), mean(1), Cell::Blank, Cell::Blank, mean(2), mean(3)];
    let dynosam = DYNOSAM_TABLE_III.map(|v| Cell::num(v, 2));
    let paper =
        [dynosam[0].clone(), dynosam[1].clone(), Cell::Blank, Cell::Blank, dynosam[2].clone(), dynosam[3].clone()];
    for (label, kind, cells) in
        [("average", "average", averages), ("DynoSAM on real KITTI (paper)", "paper_average", paper)]
    {
        t.push([
            label.to_string(),
            String::new(),
            cells[0].md(),
            cells[1].md(),
            String::new(),
            cells[4].md(),
            cells[5].md(),
        ]);
        let head = [Cell::text(kind), estimate.clone(), Cell::Blank, Cell::Blank];
        d.push(head.into_iter().chain(cells).collect());
    }
    t.with_data(d)
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
    let mut d = Data::new([
        ("row_kind", ColumnKind::Text),
        ("sequence", ColumnKind::Text),
        ("trajectory", ColumnKind::Text),
        ("heading_change_deg", ColumnKind::Num),
        ("speed_change_mps", ColumnKind::Num),
    ]);
    let mut sums = [(0.0f64, 0.0f64, 0usize); 5];
    for r in results {
        let mut row = vec![r.id.clone()];
        for (i, s) in r.smoothness.iter().enumerate() {
            let ok = s.pairs > 0;
            let cells = [Cell::opt(ok.then(|| s.heading.to_degrees()), 3), Cell::opt(ok.then_some(s.speed), 3)];
            row.extend(cells.iter().map(Cell::md));
            let name = names.get(i).copied().unwrap_or("?");
            d.push(
                [Cell::text("data"), Cell::text(r.id.as_str()), Cell::text(name)].into_iter().chain(cells).collect(),
            );
            if ok {
                sums[i].0 += s.heading.to_degrees() * s.pairs as f64;
                sums[i].1 += s.speed * s.pairs as f64;
                sums[i].2 += s.pairs;
            }
        }
        t.push(row);
    }
    let mut row = vec!["all (pair-weighted)".to_string()];
    for ((h, v, n), name) in sums.into_iter().zip(names) {
        let cells = [Cell::opt((n > 0).then(|| h / n as f64), 3), Cell::opt((n > 0).then(|| v / n as f64), 3)];
        row.extend(cells.iter().map(Cell::md));
        d.push([Cell::text("weighted_average"), Cell::Blank, Cell::text(name)].into_iter().chain(cells).collect());
    }
    t.push(row);
    t.with_data(d)
}

/// The estimator's counters per sequence (only the non-zero ones).
#[must_use]
pub fn counters_table(results: &[SequenceResult]) -> Table {
    let mut t = Table::new(["sequence", "profile", "counters (non-zero)", "estimate time (s)"]);
    let mut parts = Vec::new();
    for r in results {
        let time = Cell::num(r.estimate_seconds, 2);
        t.push([r.id.clone(), r.profile.to_string(), nonzero_counters(&r.stats), time.md()]);
        let c = counters_data(&r.stats).with_leading("estimate_time_s", ColumnKind::Num, &time);
        let c = c.with_leading("profile", ColumnKind::Text, &Cell::text(r.profile));
        parts.push(c.with_leading("sequence", ColumnKind::Text, &Cell::text(r.id.as_str())));
    }
    t.with_data(Data::concat(parts))
}

/// Every counter of `stats` (zero or not), one column each, in one row.
fn counters_data(stats: &EstimatorStats) -> Data {
    let text = format!("{stats:?}");
    let pairs: Vec<(&str, i64)> = text
        .trim_start_matches("EstimatorStats {")
        .trim_end_matches('}')
        .split(',')
        .filter_map(|kv| {
            let (k, v) = kv.split_once(':')?;
            Some((k.trim(), v.trim().parse().ok()?))
        })
        .collect();
    let mut d = Data::new(pairs.iter().map(|(k, _)| (*k, ColumnKind::Int)));
    d.push(pairs.iter().map(|(_, v)| Cell::Int(*v)).collect());
    d
}

/// Per moving object: its class, how much of it the estimator kept (frames in the truth,
/// frames of causal estimate with a known heading, the runs of consecutive frames they form and
/// the longest; 32 frames make an object eligible), and its RPE (pairs scored by the smoothed
/// estimate; every kind on its own pairs).
#[must_use]
pub fn per_object_table(results: &[SequenceResult]) -> Table {
    use ColumnKind::{Int, Num, Text};
    let columns = [
        ("sequence", "sequence", Text),
        ("profile", "profile", Text),
        ("object", "object", Int),
        ("class", "class", Text),
        ("frames (truth)", "frames_truth", Int),
        ("frames (causal)", "frames_causal", Int),
        ("runs", "runs", Int),
        ("longest run", "longest_run", Int),
        ("pairs", "pairs", Int),
        ("f2f RPE_t (m)", "f2f_rpe_t_m", Num),
        ("f2f RPE_r (deg)", "f2f_rpe_r_deg", Num),
        ("causal RPE_t (m)", "causal_rpe_t_m", Num),
        ("causal RPE_r (deg)", "causal_rpe_r_deg", Num),
        ("smoothed RPE_t (m)", "smoothed_rpe_t_m", Num),
        ("smoothed RPE_r (deg)", "smoothed_rpe_r_deg", Num),
    ];
    let mut d = Data::new(columns.map(|(_, n, k)| (n, k)));
    for r in results {
        let causal = dynotraj_sources::estimation::tracks_of_estimates(r.run.of(Kind::Causal));
        for id in moving_objects(&r.sim, r.min_step_m) {
            let truth: Vec<_> = r.sim.iter().flat_map(|f| f.objects.iter()).filter(|o| o.object_id == id).collect();
            let class = truth.first().map_or("?", |o| o.class.kitti_name());
            let track = causal.iter().find(|c| c.track_id == i32::from(id) - 1);
            let runs: Vec<usize> = track.map(|c| c.runs().map(|run| run.len()).collect()).unwrap_or_default();
            let f = object_rpe(&r.sim, r.run.of(Kind::FrameToFrame), id).result();
            let c = object_rpe(&r.sim, r.run.of(Kind::Causal), id).result();
            let s = object_rpe(&r.sim, r.run.of(Kind::Smoothed), id).result();
            d.push(vec![
                Cell::text(r.id.as_str()),
                Cell::text(r.profile),
                Cell::int(id),
                Cell::text(class),
                Cell::int(truth.len()),
                Cell::int(track.map_or(0, |c| c.frames.len())),
                Cell::int(runs.len()),
                Cell::int(runs.iter().max().copied().unwrap_or(0)),
                Cell::int(s.map_or(0, |s| s.pairs)),
                Cell::opt(f.map(|x| x.translation), 3),
                Cell::opt(f.map(|x| x.rotation.to_degrees()), 3),
                Cell::opt(c.map(|x| x.translation), 3),
                Cell::opt(c.map(|x| x.rotation.to_degrees()), 3),
                Cell::opt(s.map(|x| x.translation), 3),
                Cell::opt(s.map(|x| x.rotation.to_degrees()), 3),
            ]);
        }
    }
    Table::of_data(columns.map(|(h, _, _)| h), d)
}

/// Pairs at the start of an object's run that [`rpe_sources_table`] counts as its start.
const RUN_START_PAIRS: usize = 10;

use std::f64::consts::FRAC_PI_2;

/// Where the object RPE_t comes from, per profile, over the pairs of every sequence pooled (root
/// mean square over pairs, not Table III's mean over sequences): by the object's true range at
/// the pair's later frame, by the pair's place in its run, by whether the object's frame points
/// the truth's way (within 90 degrees of its heading), and the worst 1 % of pairs; for the
/// causal and the smoothed estimate, each on its own pairs, with each group's share of the
/// kind's summed squared error.
#[must_use]
pub fn rpe_sources_table(results: &[SequenceResult]) -> Table {
    use ColumnKind::{Int, Num, Text};
    let columns = [
        ("profile", "profile", Text),
        ("pairs", "group", Text),
        ("causal pairs", "causal_pairs", Int),
        ("causal RPE_t (m)", "causal_rpe_t_m", Num),
        ("causal share of squared error", "causal_share", Num),
        ("smoothed pairs", "smoothed_pairs", Int),
        ("smoothed RPE_t (m)", "smoothed_rpe_t_m", Num),
        ("smoothed share of squared error", "smoothed_share", Num),
    ];
    type Filter = fn(&ObjectPair) -> bool;
    let groups: [(&str, Filter); 9] = [
        ("all", |_| true),
        ("0-20 m", |p| p.range_m < 20.0),
        ("20-40 m", |p| (20.0..40.0).contains(&p.range_m)),
        ("40-80 m", |p| (40.0..80.0).contains(&p.range_m)),
        ("80 m and more", |p| p.range_m >= 80.0),
        ("run start (first 10 pairs)", |p| p.place < RUN_START_PAIRS),
        ("later in a run", |p| p.place >= RUN_START_PAIRS),
        ("object frame within 90 deg of the truth's", |p| p.heading_error_rad <= FRAC_PI_2),
        ("object frame turned by more than 90 deg", |p| p.heading_error_rad > FRAC_PI_2),
    ];
    let mut d = Data::new(columns.map(|(_, n, k)| (n, k)));
    let mut profiles: Vec<&str> = results.iter().map(|r| r.profile).collect();
    profiles.dedup();
    for profile in profiles {
        let pairs_of = |kind| -> Vec<ObjectPair> {
            results
                .iter()
                .filter(|r| r.profile == profile)
                .flat_map(|r| object_pairs(&r.sim, r.run.of(kind), &moving_objects(&r.sim, r.min_step_m)))
                .collect()
        };
        let (causal, smoothed) = (pairs_of(Kind::Causal), pairs_of(Kind::Smoothed));
        let sq = |p: &ObjectPair| p.error.translation * p.error.translation;
        let summary = |all: &[ObjectPair], chosen: &[&ObjectPair]| {
            let (total, part): (f64, f64) = (all.iter().map(sq).sum(), chosen.iter().map(|p| sq(p)).sum());
            let rms = (!chosen.is_empty()).then(|| (part / chosen.len() as f64).sqrt());
            (chosen.len(), rms, (total > 0.0).then(|| part / total))
        };
        let rows = groups
            .iter()
            .map(|(name, keep)| {
                let (c, s): (Vec<&ObjectPair>, Vec<&ObjectPair>) =
                    (causal.iter().filter(|p| keep(p)).collect(), smoothed.iter().filter(|p| keep(p)).collect());
                ((*name).to_string(), summary(&causal, &c), summary(&smoothed, &s))
            })
            .chain(std::iter::once((
                "worst 1 % of pairs".to_string(),
                summary(&causal, &worst_pairs(&causal)),
                summary(&smoothed, &worst_pairs(&smoothed)),
            )));
        for (name, (cn, crms, cshare), (sn, srms, sshare)) in rows {
            d.push(vec![
                Cell::text(profile),
                Cell::text(name),
                Cell::int(cn),
                Cell::opt(crms, 3),
                Cell::opt(cshare, 3),
                Cell::int(sn),
                Cell::opt(srms, 3),
                Cell::opt(sshare, 3),
            ]);
        }
    }
    Table::of_data(columns.map(|(h, _, _)| h), d)
}

/// The largest 1 % of `all` by translational error (at least one pair when there are any).
fn worst_pairs(all: &[ObjectPair]) -> Vec<&ObjectPair> {
    let mut sorted: Vec<&ObjectPair> = all.iter().collect();
    sorted.sort_by(|a, b| b.error.translation.total_cmp(&a.error.translation));
    sorted.truncate(all.len().div_ceil(100));
    sorted
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
    let mut d = Data::new([
        ("tracks_file", ColumnKind::Text),
        ("frames", ColumnKind::Int),
        ("objects_causal", ColumnKind::Int),
        ("objects_smoothed", ColumnKind::Int),
        ("estimate_time_s", ColumnKind::Num),
        ("rpe", ColumnKind::Text),
    ]);
    d.push(vec![
        Cell::text(source),
        Cell::int(frames),
        Cell::int(objects(Kind::Causal)),
        Cell::int(objects(Kind::Smoothed)),
        Cell::num(estimate_seconds, 2),
        Cell::text("not available: a tracks file carries no truth"),
    ]);
    let t = Table::of_data(
        ["tracks file", "frames", "objects (causal)", "objects (smoothed)", "estimate time (s)", "RPE"],
        d,
    );
    let mut c = Table::new(["tracks file", "counters (non-zero)"]);
    c.push([source.to_string(), nonzero_counters(&run.stats)]);
    let c = c.with_data(counters_data(&run.stats).with_leading("tracks_file", ColumnKind::Text, &Cell::text(source)));
    (t, c)
}

/// The estimator's compute benchmark as a table.
#[must_use]
pub fn cost_table(r: &CostResult) -> Table {
    let mut t = Table::new(["quantity", "value"]);
    let profile = if cfg!(debug_assertions) { "debug (use --release)" } else { "release" };
    let rows = [
        ("build", "build", Cell::text(profile)),
        ("frames timed", "frames_timed", Cell::int(r.frames)),
        ("tracks per frame (mean)", "tracks_per_frame_mean", Cell::num(r.tracks_per_frame, 0)),
        ("objects estimated per frame (mean)", "objects_per_frame_mean", Cell::num(r.objects_per_frame, 1)),
        ("time per frame, mean (us)", "time_per_frame_mean_us", Cell::num(r.mean(), 0)),
        ("time per frame, median (us)", "time_per_frame_median_us", Cell::num(r.quantile(0.5), 0)),
        ("time per frame, 95th percentile (us)", "time_per_frame_p95_us", Cell::num(r.quantile(0.95), 0)),
        ("time per frame, max (us)", "time_per_frame_max_us", Cell::num(r.quantile(1.0), 0)),
        ("estimator state (bytes)", "estimator_state_bytes", Cell::int(r.state_bytes)),
    ];
    // One row of named quantities for programs; a quantity per line for people.
    let kind = |c: &Cell| match c {
        Cell::Int(_) => ColumnKind::Int,
        Cell::Num(..) => ColumnKind::Num,
        _ => ColumnKind::Text,
    };
    let mut d = Data::new(rows.iter().map(|(_, n, c)| (*n, kind(c))));
    d.push(rows.iter().map(|(_, _, c)| c.clone()).collect());
    for (label, _, c) in &rows {
        t.push([label.to_string(), c.md()]);
    }
    t.with_data(d)
}

/// The end-to-end run of a rendered sequence (`id`, `n` frames of `size` pixels) as text: the
/// front-end's KLT survival and the estimator's RPE per kind of estimate.
#[cfg(feature = "images")]
#[must_use]
pub fn end_to_end_text(
    id: &str,
    n: usize,
    size: (usize, usize),
    r: &dynotraj_sources::estimation::end_to_end::EndToEnd,
) -> String {
    use std::fmt::Write as _;
    let s = r.stats;
    let mut out = format!(
        "sequence {id}, {n} frames of {}x{}: static KLT survival {:.1}%, object KLT survival {:.1}%, {} moving \
         objects\n",
        size.0,
        size.1,
        100.0 * s.static_survival(),
        100.0 * s.object_survival(),
        r.scores.moving_objects
    );
    out.push_str(
        "| estimate | camera RPE_t (m) | camera RPE_r (deg) | objects scored | object RPE_t (m) | object RPE_r \
            (deg) |\n|---|---|---|---|---|---|\n",
    );
    for (kind, k) in Kind::ALL.iter().zip(&r.scores.kinds) {
        let f = |x: Option<f64>, deg: bool| {
            x.map_or("-".to_string(), |v| format!("{:.3}", if deg { v.to_degrees() } else { v }))
        };
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} |",
            kind.name(),
            f(k.camera.map(|c| c.translation), false),
            f(k.camera.map(|c| c.rotation), true),
            k.objects,
            f(k.object.map(|c| c.translation), false),
            f(k.object.map(|c| c.rotation), true)
        );
    }
    out
}
