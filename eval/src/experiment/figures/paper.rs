//! The paper's per-object figures, for any object: the distance between consecutive positions
//! (its figure 2), speed (3) and heading (4, and 6 for sequence 0018) per source over time, and
//! the ACE of each arm's int8 forecasts over time (5).

use std::path::Path;

use dynotraj_core::BevState;
use dynotraj_core::geometry::angle_diff;

use super::choice::{Extent, Subject};
use super::time_axis::{seconds, time_label};
use super::{Figure, FigureInputs};
use crate::forecast_eval::score_sequence;
use crate::report::chart::{Chart, Series, write_chart};
use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::{Source, eligible_runs};

/// The states of `track_id` through `source`, as (frame, state) in frame order.
fn states_of(seq: &SequenceTracks, source: Source, track_id: i32, dt: f32) -> Vec<(u32, BevState)> {
    let scene = seq.scene(source, dt);
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

/// One series per source (with its states, as [`states_of`] gives them) of `f(previous,
/// current)` over consecutive frames (or of the current state alone when `f` ignores the
/// previous one), x in seconds.
fn per_source(states_by_source: &[(Source, Vec<(u32, BevState)>)], dt: f32, f: Measure) -> Vec<Series> {
    states_by_source
        .iter()
        .map(|(src, states)| {
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
                    points.push((seconds(*frame, dt), v));
                }
            }
            Series::new(src.name(), points)
        })
        .collect()
}

/// The paper's number of the figure `name` of sequence `seq`, if it is one of its figures.
fn paper_number(seq: &str, name: &str) -> Option<u8> {
    match (seq, name) {
        ("0000", "distance") => Some(2),
        ("0000", "speed") => Some(3),
        ("0000", "heading") => Some(4),
        ("0000", "ace") => Some(5),
        ("0018", "heading") => Some(6),
        _ => None,
    }
}

/// The file stem of figure `name` of `subject`: `fig<N>_` first when it is the paper's.
fn stem(subject: &Subject<'_>, name: &str) -> String {
    match paper_number(&subject.seq.id, name) {
        Some(n) => format!("fig{n}_{name}_{}", subject.stem()),
        None => format!("{name}_{}", subject.stem()),
    }
}

/// " (the paper's figure N)" when the figure is one of the paper's.
fn paper_note(subject: &Subject<'_>, name: &str) -> String {
    paper_number(&subject.seq.id, name).map_or_else(String::new, |n| format!(" (the paper's figure {n})"))
}

/// Distance, speed and heading per source over time for `subject` (heading alone for
/// [`Extent::Heading`]), then the ACE of each arm's int8 forecasts over time.
///
/// # Errors
/// A chart that cannot be written, named.
pub fn write(dir: &Path, subject: &Subject<'_>, inputs: &FigureInputs<'_>) -> anyhow::Result<Vec<Figure>> {
    let (seq, track, dt) = (subject.seq, subject.track, inputs.dt);
    let mut sources = vec![Source::Gt, Source::GtEkf];
    sources.extend(inputs.arms.iter().copied().filter(|a| a.is_estimated() && a.is_causal()));
    sources.retain(|s| seq.has(*s));
    let what = format!("{} (its longest eligible run: {} frames)", subject.name(), subject.longest_run(inputs.rule));
    let charts: [(&str, &str, &str, Measure); 3] = [
        ("distance", "distance between consecutive positions", "metres", step_distance),
        ("speed", "speed", "m/s", speed),
        ("heading", "heading", "degrees", heading_deg),
    ];
    let states: Vec<(Source, Vec<(u32, BevState)>)> =
        sources.iter().map(|&src| (src, states_of(seq, src, track, dt))).collect();
    let mut out = Vec::new();
    for (name, long, unit, f) in charts {
        if subject.extent == Extent::Heading && name != "heading" {
            continue;
        }
        let chart = Chart {
            title: format!("{long}: {what}"),
            x_label: time_label(dt),
            y_label: unit.into(),
            series: per_source(&states, dt, f),
        };
        let [png, _] = write_chart(&chart, &dir.join(stem(subject, name)))?;
        out.push(Figure {
            png,
            caption: format!("The {long} of {what}, per source, over time{}.", paper_note(subject, name)),
        });
    }
    if subject.extent == Extent::All
        && let Some(figure) = ace_figure(dir, subject, inputs, &what)?
    {
        out.push(figure);
    }
    Ok(out)
}

/// The ACE of consecutive int8 forecasts of `subject` over time, per arm with a fold model for
/// its sequence; `None` when no arm has one.
fn ace_figure(
    dir: &Path,
    subject: &Subject<'_>,
    inputs: &FigureInputs<'_>,
    what: &str,
) -> anyhow::Result<Option<Figure>> {
    let (seq, dt) = (subject.seq, inputs.dt);
    let mut series = Vec::new();
    for &arm in inputs.arms {
        let Some(model) = inputs.models.get(arm, &seq.id) else { continue };
        let mut predictor = model.predictor();
        let tracks = seq.tracks_for(arm);
        let runs: Vec<_> =
            eligible_runs(tracks, inputs.rule).into_iter().filter(|r| r.track_id == subject.track).collect();
        let scene = seq.scene(arm, dt);
        let scores = score_sequence(&runs, &scene, &mut predictor, dt);
        series.push(Series::new(
            format!("learned int8 on {arm}"),
            scores.instances.iter().filter_map(|i| i.ace.map(|a| (seconds(i.frame, dt), f64::from(a)))).collect(),
        ));
    }
    if !series.iter().any(|s| !s.points.is_empty()) {
        return Ok(None);
    }
    let chart = Chart {
        title: format!("ACE per forecast: {what}"),
        x_label: time_label(dt),
        y_label: "ACE (m)".into(),
        series,
    };
    let [png, _] = write_chart(&chart, &dir.join(stem(subject, "ace")))?;
    Ok(Some(Figure {
        png,
        caption: format!(
            "ACE of consecutive int8 forecasts of {what} over time (at the time each forecast is made), per arm, \
            each model trained without sequence {}{}.",
            seq.id,
            paper_note(subject, "ace")
        ),
    }))
}
