//! The paper's figures from an experiment's data: for the longest-seen moving object of
//! sequence 0000, the distance between consecutive positions (its figure 2), speed (3) and
//! heading (4) per source, and the ACE of each arm's int8 forecasts over time (5); the heading
//! of the longest-seen moving object of sequence 0018 (6).

use std::path::{Path, PathBuf};

use dynotraj_core::BevState;
use dynotraj_core::geometry::angle_diff;

use crate::evaluate::score_sequence;
use crate::model_file::ModelFile;
use crate::report::chart::{Chart, Series, write_chart};
use crate::scene::Scene;
use crate::sequence::SequenceTracks;
use crate::trajectory::{EligibilityRule, Source, eligible_runs};

/// A figure written: its file stem's paths and its caption.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    /// The PNG (an SVG of the same name sits beside it).
    pub png: PathBuf,
    /// What it shows.
    pub caption: String,
}

/// The track id and length of the longest eligible run of the labels of `seq`.
#[must_use]
pub fn longest_moving_object(seq: &SequenceTracks, rule: &EligibilityRule) -> Option<(i32, usize)> {
    eligible_runs(&seq.tracks, rule).iter().max_by_key(|r| r.states.len()).map(|r| (r.track_id, r.states.len()))
}

/// The states of `track_id` through `source`, as (frame, state) in frame order.
fn states_of(seq: &SequenceTracks, source: Source, track_id: i32, dt: f32) -> Vec<(u32, BevState)> {
    let scene = Scene::new(seq.tracks_for(source), source, dt);
    scene
        .runs
        .iter()
        .filter(|r| r.track_id == track_id)
        .flat_map(|r| r.states.iter().enumerate().map(move |(i, s)| (r.first_frame + i as u32, *s)))
        .collect()
}

/// What a figure plots per frame: from the previous state (when the frame before is there),
/// the current one and the unwrapped heading (radians).
type Measure = fn(Option<&BevState>, &BevState, f64) -> Option<f64>;

fn step_distance(prev: Option<&BevState>, s: &BevState, _: f64) -> Option<f64> {
    prev.map(|p| f64::from(p.position().distance(&s.position())))
}

fn speed(_: Option<&BevState>, s: &BevState, _: f64) -> Option<f64> {
    Some(f64::from(s.speed))
}

fn heading_deg(_: Option<&BevState>, _: &BevState, unwrapped: f64) -> Option<f64> {
    Some(unwrapped.to_degrees())
}

/// One series per source of `f(previous, current)` over consecutive frames (or of the current
/// state alone when `f` ignores the previous one).
fn per_source(seq: &SequenceTracks, sources: &[Source], track_id: i32, dt: f32, f: Measure) -> Vec<Series> {
    sources
        .iter()
        .map(|&src| {
            let states = states_of(seq, src, track_id, dt);
            let mut points = Vec::new();
            let mut unwrapped = 0.0;
            for (i, (frame, s)) in states.iter().enumerate() {
                let prev =
                    i.checked_sub(1).and_then(|j| states.get(j)).filter(|(pf, _)| pf + 1 == *frame).map(|(_, p)| p);
                unwrapped = match prev {
                    Some(p) => unwrapped + f64::from(angle_diff(s.heading, p.heading)),
                    None => f64::from(s.heading),
                };
                if let Some(v) = f(prev, s, unwrapped) {
                    points.push((f64::from(*frame), v));
                }
            }
            Series { label: src.name().to_string(), points }
        })
        .collect()
}

/// Writes the figures into `dir` for what `sequences` hold: sources are `arms`' sources that
/// are loaded plus the labels; fold models are read from `models` (`<arm>-0000.blob.int8`).
/// Figures whose sequence is not loaded are left out.
///
/// # Errors
/// A figure that cannot be drawn or written, named.
pub fn write_figures(
    dir: &Path,
    sequences: &[SequenceTracks],
    arms: &[Source],
    rule: &EligibilityRule,
    dt: f32,
    models: &Path,
) -> anyhow::Result<Vec<Figure>> {
    std::fs::create_dir_all(dir)?;
    let mut sources = vec![Source::Gt, Source::GtEkf];
    sources.extend(arms.iter().copied().filter(|a| a.is_estimated() && a.is_causal()));
    let mut out = Vec::new();
    let find = |id: &str| sequences.iter().find(|s| s.id == id);
    if let Some(seq) = find("0000")
        && let Some((track, len)) = longest_moving_object(seq, rule)
    {
        let sources: Vec<Source> = sources.iter().copied().filter(|s| seq.has(*s)).collect();
        let what = format!("sequence 0000, object {track} (its longest eligible run: {len} frames)");
        let charts: [(&str, &str, &str, Measure); 3] = [
            ("fig2_distance_0000", "distance between consecutive positions", "metres", step_distance),
            ("fig3_speed_0000", "speed", "m/s", speed),
            ("fig4_heading_0000", "heading", "degrees", heading_deg),
        ];
        for (stem, name, unit, f) in charts {
            let chart = Chart {
                title: format!("{name}: {what}"),
                x_label: "frame".into(),
                y_label: unit.into(),
                series: per_source(seq, &sources, track, dt, f),
            };
            let [png, _] = write_chart(&chart, &dir.join(stem))?;
            out.push(Figure {
                png,
                caption: format!("The {name} of {what}, per source (the paper's figure {}).", &stem[3..4]),
            });
        }
        let mut series = Vec::new();
        for &arm in arms.iter().filter(|a| seq.has(**a)) {
            let path = models.join(format!("{arm}-0000.blob.int8"));
            let Ok(model) = ModelFile::load(&path) else { continue };
            let mut predictor = model.predictor();
            let tracks = seq.tracks_for(arm);
            let runs: Vec<_> = eligible_runs(tracks, rule).into_iter().filter(|r| r.track_id == track).collect();
            let scene = Scene::new(tracks, arm, dt);
            let scores = score_sequence(&runs, &scene, &mut predictor, dt);
            series.push(Series {
                label: format!("learned int8 on {arm}"),
                points: scores
                    .instances
                    .iter()
                    .filter_map(|i| i.ace.map(|a| (f64::from(i.frame), f64::from(a))))
                    .collect(),
            });
        }
        if series.iter().any(|s| !s.points.is_empty()) {
            let chart = Chart {
                title: format!("ACE per forecast: {what}"),
                x_label: "frame".into(),
                y_label: "ACE (m)".into(),
                series,
            };
            let [png, _] = write_chart(&chart, &dir.join("fig5_ace_0000"))?;
            out.push(Figure {
                png,
                caption: format!(
                    "ACE of consecutive int8 forecasts of {what}, per arm, each \
                model trained without sequence 0000 (the paper's figure 5)."
                ),
            });
        }
    }
    if let Some(seq) = find("0018")
        && let Some((track, len)) = longest_moving_object(seq, rule)
    {
        let sources: Vec<Source> = sources.iter().copied().filter(|s| seq.has(*s)).collect();
        let what = format!("sequence 0018, object {track} ({len} frames)");
        let chart = Chart {
            title: format!("heading: {what}"),
            x_label: "frame".into(),
            y_label: "degrees".into(),
            series: per_source(seq, &sources, track, dt, heading_deg),
        };
        let [png, _] = write_chart(&chart, &dir.join("fig6_heading_0018"))?;
        out.push(Figure { png, caption: format!("The heading of {what}, per source (the paper's figure 6).") });
    }
    Ok(out)
}
