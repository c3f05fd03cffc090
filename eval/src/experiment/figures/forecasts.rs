//! Forecasts over the true future: at a few test instances of an object, its past and true
//! future in the labels, each arm's int8 forecast and constant velocity, bird's-eye, one panel
//! per instance.
//!
//! Each arm forecasts from its own source's history, as the experiment scores it; its forecast
//! is drawn as its displacement from that source's current position, placed at the labels'
//! current position (and turned into the labels' world for the estimated arms by the yaw between
//! the estimator's world and the truth's at that frame), as the common-truth scoring compares
//! forecasts (`crate::forecast_eval`): each source refers to its own point of the object.

use std::path::Path;

use dynotraj_core::Point2;
use dynotraj_core::limits::{HORIZON, MAX_HISTORY};
use dynotraj_core::predict::{Baseline, Forecast};

use super::choice::Subject;
use super::time_axis::{rate_text, seconds};
use super::{Figure, FigureInputs};
use crate::forecast_eval::forecast_at;
use crate::report::chart::{Colour, Marker, Panel, PathFigure, PathLine, Style, write_paths};
use dynotraj_core::predict::Predictor;
use dynotraj_formats::model_file::ModelFile;
use dynotraj_sources::scene::Scene;
use dynotraj_sources::trajectory::{Source, eligible_runs};

/// Instances drawn per object.
pub const INSTANCES: usize = 3;

/// Image size, pixels: three panels side by side and the legend band.
const SIZE: (u32, u32) = (1500, 620);

/// `count` evenly spaced items of `items` (the middles of `count` equal parts), each once.
#[must_use]
pub fn evenly_spaced<T: Copy + PartialEq>(items: &[T], count: usize) -> Vec<T> {
    let mut out: Vec<T> = Vec::new();
    for j in 0..count {
        if let Some(&x) = items.get((2 * j + 1) * items.len() / (2 * count))
            && !out.contains(&x)
        {
            out.push(x);
        }
    }
    out
}

fn xy(p: &Point2) -> (f64, f64) {
    (f64::from(p.x), f64::from(p.y))
}

/// `forecast` (in a source's world, made from its position `from`) as a path starting at
/// `anchor` in the labels' world, turned by `yaw` radians.
fn placed(forecast: &Forecast, from: Point2, anchor: Point2, yaw: f32) -> Vec<(f64, f64)> {
    let (sin, cos) = yaw.sin_cos();
    std::iter::once(xy(&anchor))
        .chain(forecast.iter().map(|p| {
            let (dx, dy) = (p.x - from.x, p.y - from.y);
            (f64::from(anchor.x + cos * dx - sin * dy), f64::from(anchor.y + sin * dx + cos * dy))
        }))
        .collect()
}

/// One forecaster of the figure: its label, colour and how it reads a source.
struct Arm<'m> {
    label: String,
    source: Source,
    colour: Colour,
    dashed: bool,
    forecaster: Box<dyn Predictor + 'm>,
}

/// The forecasts of `subject` at [`INSTANCES`] evenly spaced test instances of its labels;
/// nothing when it has no test instance or no arm has a fold model for its sequence.
///
/// # Errors
/// A fold model that does not load, or the figure cannot be written, named.
pub fn write(dir: &Path, subject: &Subject<'_>, inputs: &FigureInputs<'_>) -> anyhow::Result<Vec<Figure>> {
    let (seq, track, dt) = (subject.seq, subject.track, inputs.dt);
    let frames: Vec<u32> = eligible_runs(&seq.tracks, inputs.rule)
        .iter()
        .filter(|r| r.track_id == track)
        .flat_map(|r| r.instances().map(move |s| r.first_frame + s as u32))
        .collect();
    let chosen = evenly_spaced(&frames, INSTANCES);
    let models: Vec<(Source, &ModelFile)> =
        inputs.arms.iter().filter_map(|&arm| Some((arm, inputs.models.get(arm, &seq.id)?))).collect();
    if chosen.is_empty() || models.is_empty() {
        return Ok(Vec::new());
    }
    let mut arms: Vec<Arm<'_>> = models
        .iter()
        .enumerate()
        .map(|(i, (arm, m))| Arm {
            label: format!("learned int8 on {arm}"),
            source: *arm,
            colour: Colour::Palette(i),
            dashed: false,
            forecaster: Box::new(m.predictor()),
        })
        .collect();
    arms.push(Arm {
        label: "constant velocity on gt".into(),
        source: Source::Gt,
        colour: Colour::Palette(models.len()),
        dashed: true,
        forecaster: Box::new(Baseline::ConstantVelocity),
    });
    let labels = seq.scene(Source::Gt, dt);
    let scenes: Vec<Scene> = arms.iter().map(|a| seq.scene(a.source, dt)).collect();
    let world_yaw = seq.estimated.as_ref().map(dynotraj_sources::estimation::EstimatedTracks::world_yaw);
    let mut panels = Vec::new();
    for &frame in &chosen {
        let Some(run) = labels.run_at(track, frame) else { continue };
        let s = (frame - run.first_frame) as usize;
        let position = |k: usize| run.states.get(k).map(|st| xy(&st.position()));
        let past: Vec<(f64, f64)> = (s.saturating_sub(HORIZON)..=s).filter_map(position).collect();
        let future: Vec<(f64, f64)> = (s..=s + HORIZON).filter_map(position).collect();
        let anchor = run.states[s].position();
        let mut paths = vec![
            PathLine {
                label: "past (labels)".into(),
                segments: vec![past],
                style: Style { colour: Colour::Grey, dashed: false },
                marker: Marker::End,
            },
            PathLine {
                label: "true future (labels)".into(),
                segments: vec![future],
                style: Style { colour: Colour::Ink, dashed: false },
                marker: Marker::None,
            },
        ];
        for (arm, scene) in arms.iter_mut().zip(&scenes) {
            let Some(own) = scene.run_at(track, frame) else { continue };
            let k = (frame - own.first_frame) as usize;
            let Ok(forecast) = forecast_at(own, k, scene, arm.forecaster.as_mut(), dt) else { continue };
            let yaw =
                if arm.source.is_estimated() { world_yaw.as_ref().and_then(|w| w.get(&frame)).copied() } else { None };
            paths.push(PathLine {
                label: arm.label.clone(),
                segments: vec![placed(&forecast, own.states[k].position(), anchor, yaw.unwrap_or(0.0))],
                style: Style { colour: arm.colour, dashed: arm.dashed },
                marker: Marker::None,
            });
        }
        panels.push(Panel { title: format!("frame {frame} (t = {:.2} s)", seconds(frame, dt)), paths });
    }
    if panels.is_empty() {
        return Ok(Vec::new());
    }
    let figure = PathFigure {
        title: format!("forecasts over the true future: {}", subject.name()),
        x_label: "world x (m)".into(),
        y_label: "world y (m)".into(),
        panels,
        size: SIZE,
    };
    let [png, _] = write_paths(&figure, &dir.join(format!("forecasts_{}", subject.stem())))?;
    Ok(vec![Figure {
        png,
        caption: format!(
            "Forecasts of {} at {} evenly spaced test instances (frames {}), bird's-eye on one scale: the past {HORIZON} \
            frames of the labels (the models read the last {}; the dot is the current position), the true future \
            over the {HORIZON}-frame horizon ({:.1} s at {} Hz), each arm's int8 model trained without sequence {} \
            and constant velocity on the labels. Each arm forecasts from its own source's history; its forecast is \
            drawn as a displacement from its own current position, placed at the labels' (in the labels' world), \
            as the common-truth scoring compares forecasts.",
            subject.name(),
            chosen.len(),
            chosen.iter().map(u32::to_string).collect::<Vec<_>>().join(", "),
            MAX_HISTORY + 1,
            HORIZON as f64 * f64::from(dt),
            rate_text(dt),
            seq.id
        ),
    }])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn instances_are_evenly_spaced_and_distinct() {
        let frames: Vec<u32> = (10..70).collect();
        assert_eq!(evenly_spaced(&frames, 3), vec![20, 40, 60]);
        assert_eq!(evenly_spaced(&[5u32, 6], 3), vec![5, 6]);
        assert!(evenly_spaced::<u32>(&[], 3).is_empty());
    }

    #[test]
    fn a_forecast_is_placed_as_a_displacement_turned_into_the_labels_world() {
        let mut forecast = [Point2::default(); HORIZON];
        for (k, p) in forecast.iter_mut().enumerate() {
            *p = Point2::new(10.0 + (k + 1) as f32, 5.0);
        }
        // From (10, 5) in its world, along its +x; placed at (0, 0) and turned a quarter turn.
        let path = placed(&forecast, Point2::new(10.0, 5.0), Point2::new(0.0, 0.0), std::f32::consts::FRAC_PI_2);
        assert_eq!(path.len(), HORIZON + 1);
        assert_eq!(path[0], (0.0, 0.0));
        let (x, y) = path[HORIZON];
        assert!(x.abs() < 1e-4 && (y - HORIZON as f64).abs() < 1e-4, "({x}, {y})");
    }
}
