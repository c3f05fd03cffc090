//! The `track --segmentation` measurement: the front-end's motion masks on renderings of KITTI
//! sequences, scored against the renderings' truth by range band and class (recall of moving
//! objects, precision of segments, id switches, frames to the first detection), with the
//! segmentation's counters and the front-end's stage times.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use dynotraj_frontend::motion::Fate;
use dynotraj_frontend::motion_scores::{BANDS, MotionScores, PROBE_BUCKETS};
use dynotraj_frontend::{FrontEndStats, StageTimes};
use dynotraj_sources::estimation::from_images::motion_masks_scored;

use crate::report::Table;
use crate::report::data::{Cell, ColumnKind, Data};
use crate::tracking::{DisparitySettings, per_sequence};

/// What the measurement shows: a header, the recall table and the precision table.
#[derive(Debug, Clone)]
pub struct SegmentationReport {
    /// Settings, summary figures and counters, as text.
    pub header: String,
    /// Recall by band and class.
    pub recall: Table,
    /// Precision by band.
    pub precision: Table,
    /// The scores behind the tables.
    pub scores: MotionScores,
}

/// Renders the sequences `sequences` of the KITTI folder `dir` (all when empty) as
/// [`crate::tracking::disparity_error`] does, tracks them with motion masks and scores the
/// masks. `on_sequence` is told how many sequences there are after each.
///
/// # Errors
/// Loading, rendering or tracking errors, named.
pub fn motion_segmentation(
    dir: &Path,
    sequences: &[String],
    settings: &DisparitySettings,
    on_sequence: &(dyn Fn(usize) + Sync),
) -> anyhow::Result<SegmentationReport> {
    let opt = &settings.options;
    let (names, per_drive) =
        per_sequence(dir, sequences, settings.jobs, on_sequence, |id, data| motion_masks_scored(id, data, opt))?;
    let mut scores = MotionScores::default();
    let mut stats = FrontEndStats::default();
    let mut times = StageTimes::default();
    for (s, t, m) in per_drive {
        scores.merge(s);
        times.frames += t.frames;
        times.masks += t.masks;
        times.wall += t.wall;
        stats = stats.plus(&m);
    }
    let mut header = format!(
        "Motion masks against the renderings' truth: sequences {}, {} frames each at most, objects moving at least \
         {} m a frame counted as moving, point depth {}, render optics {}\n",
        names.join(","),
        opt.max_frames.map_or_else(|| "all".to_string(), |n| n.to_string()),
        opt.min_step_m,
        settings.point_depth_name,
        settings.render_optics_name,
    );
    let pct = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |v| format!("{:.1} %", 100.0 * v));
    let mut delays = scores.delays.clone();
    delays.sort_unstable();
    let _ = writeln!(
        header,
        "recall within 40 m {}, within 80 m {}; precision within 40 m {}, within 80 m {}; id switches {}; frames to \
         the first detection: median {}, over {} objects found ({} never found)",
        pct(scores.recall_within(40.0)),
        pct(scores.recall_within(80.0)),
        pct(scores.precision_within(40.0)),
        pct(scores.precision_within(80.0)),
        scores.id_switches,
        delays.get(delays.len() / 2).map_or_else(|| "-".to_string(), ToString::to_string),
        delays.len(),
        scores.never_found,
    );
    let per_frame = |s: f64| if times.frames > 0 { 1e3 * s / times.frames as f64 } else { 0.0 };
    let _ = writeln!(
        header,
        "segmentation: {} frames, camera motion not fitted in {}, probes judged {}, moving {}, in no object {}, \
         objects reported {} ({} coasted), {} found again after they were forgotten; masks {:.1} ms a frame of {:.1} ms\n",
        stats.frames,
        stats.motion_ego_failed,
        stats.motion_probes_judged,
        stats.motion_probes_moving,
        stats.motion_probes_unclustered,
        stats.motion_objects,
        stats.motion_objects_coasted,
        stats.motion_objects_reacquired,
        per_frame(times.masks),
        per_frame(times.wall),
    );
    let _ = writeln!(header, "probe residuals against the camera's motion, pixels (p50 / p90 / p99):\n");
    let _ = writeln!(
        header,
        "| range | on | at a depth edge | probes | across the ray | along it | sigmas |\n|---|---|---|---|---|---|---|"
    );
    for ((band, moving, edge), v) in &scores.residuals {
        let q = |k: usize| {
            let mut x: Vec<f32> = v.iter().map(|r| r[k]).collect();
            x.sort_by(f32::total_cmp);
            let at = |p: f64| x.get(((x.len() as f64 - 1.0) * p) as usize).copied().unwrap_or(f32::NAN);
            format!("{:.2} / {:.2} / {:.2}", at(0.5), at(0.9), at(0.99))
        };
        let _ = writeln!(
            header,
            "| {} | {} | {} | {} | {} | {} | {} |",
            band_name(*band),
            if *moving { "moving" } else { "static" },
            if *edge { "yes" } else { "no" },
            v.len(),
            q(0),
            q(1),
            q(2)
        );
    }
    header.push('\n');
    let fates_table = |header: &mut String, title: &str, fates: &BTreeMap<(usize, Fate), usize>| {
        let _ = writeln!(header, "{title}\n");
        let _ = writeln!(
            header,
            "| range | no depth | young | static | unconfirmed | unclustered | in an object |\n|---|---|---|---|---|---|---|"
        );
        for (b, _) in BANDS.iter().enumerate() {
            let n = |f: Fate| fates.get(&(b, f)).copied().unwrap_or(0);
            let _ = writeln!(
                header,
                "| {} | {} | {} | {} | {} | {} | {} |",
                band_name(b),
                n(Fate::NoDepth),
                n(Fate::Young),
                n(Fate::Static),
                n(Fate::Unconfirmed),
                n(Fate::Unclustered),
                n(Fate::InObject)
            );
        }
        header.push('\n');
    };
    fates_table(&mut header, "probes on moving objects, by what became of them:", &scores.fates);
    fates_table(
        &mut header,
        "of them, probes on objects that a segment touched but covered less than half of:",
        &scores.fates_undercovered,
    );
    let _ = writeln!(header, "moving objects' frames by the probes on them (found / frames):\n");
    let buckets: Vec<String> = PROBE_BUCKETS
        .iter()
        .zip(PROBE_BUCKETS.iter().skip(1).map(|n| Some(n - 1)).chain([None]))
        .map(|(lo, hi)| match hi {
            Some(hi) if hi == *lo => format!("{lo} probes"),
            Some(hi) => format!("{lo}-{hi} probes"),
            None => format!("{lo}+ probes"),
        })
        .collect();
    let _ = writeln!(header, "| range | {} |\n|---|{}", buckets.join(" | "), "---|".repeat(buckets.len()));
    for (b, _) in BANDS.iter().enumerate() {
        let cells: Vec<String> = (0..PROBE_BUCKETS.len())
            .map(|k| {
                scores.coverage.get(&(b, k)).map_or_else(|| "-".into(), |c| format!("{} / {}", c.found, c.visible))
            })
            .collect();
        let _ = writeln!(header, "| {} | {} |", band_name(b), cells.join(" | "));
    }
    header.push('\n');
    Ok(SegmentationReport { header, recall: recall_table(&scores), precision: precision_table(&scores), scores })
}

fn band_name(b: usize) -> String {
    BANDS.get(b).map_or_else(String::new, |(lo, hi)| {
        if hi.is_finite() { format!("{lo:.0}-{hi:.0} m") } else { format!("{lo:.0}+ m") }
    })
}

fn share(part: usize, whole: usize) -> Cell {
    if whole > 0 { Cell::num(part as f64 / whole as f64, 3) } else { Cell::text("-") }
}

fn recall_table(scores: &MotionScores) -> Table {
    let mut data = Data::new([
        ("range", ColumnKind::Text),
        ("class", ColumnKind::Text),
        ("object frames", ColumnKind::Int),
        ("found", ColumnKind::Int),
        ("recall", ColumnKind::Num),
        ("touched by a segment", ColumnKind::Num),
        ("half covered by its segments together", ColumnKind::Num),
        ("standing still", ColumnKind::Int),
        ("standing still, found", ColumnKind::Int),
    ]);
    for (&(band, class), c) in &scores.found {
        data.push(vec![
            Cell::text(band_name(band)),
            Cell::text(class.kitti_name()),
            Cell::int(c.visible),
            Cell::int(c.found),
            share(c.found, c.visible),
            share(c.touched, c.visible),
            share(c.covered_together, c.visible),
            Cell::int(c.at_rest),
            Cell::int(c.at_rest_found),
        ]);
    }
    let headers: Vec<String> = data.names().into_iter().map(str::to_string).collect();
    Table::of_data(headers, data)
}

fn precision_table(scores: &MotionScores) -> Table {
    let mut data = Data::new([
        ("range", ColumnKind::Text),
        ("segments", ColumnKind::Int),
        ("false", ColumnKind::Int),
        ("precision", ColumnKind::Num),
    ]);
    for (&band, c) in &scores.segments {
        data.push(vec![
            Cell::text(band_name(band)),
            Cell::int(c.segments),
            Cell::int(c.false_segments),
            share(c.segments - c.false_segments, c.segments),
        ]);
    }
    let headers: Vec<String> = data.names().into_iter().map(str::to_string).collect();
    Table::of_data(headers, data)
}
