//! An object's bird's-eye trajectory per source, on one scale in both axes: the labels (GT),
//! GT+EKF, every other arm's source, the estimator's causal and smoothed estimates where it ran,
//! and the simulator's truth where there is one.

use std::path::Path;

use super::choice::Subject;
use super::{Figure, FigureInputs};
use crate::report::chart::{Colour, Marker, Panel, PathFigure, PathLine, Style, write_paths};
use dynotraj_sources::scene::Scene;
use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::{ObjectTrack, Source};

/// Image height, pixels.
const HEIGHT: u32 = 720;
/// Width of the plot itself, pixels, at most and at least: the image is as wide as the path's
/// shape needs between these, so that a path along the road does not sit in a wide empty plot.
const PLOT_WIDTH: (f64, f64) = (420.0, 1000.0);
/// Width of the axes' labels and of the legend band beside the plot, pixels.
const BESIDE: u32 = 340;

/// The image size for `paths`: [`HEIGHT`] high, wide enough for their shape at one scale.
fn size_for(paths: &[PathLine]) -> (u32, u32) {
    let (mut x, mut y) = ((f64::INFINITY, f64::NEG_INFINITY), (f64::INFINITY, f64::NEG_INFINITY));
    for &(px, py) in paths.iter().flat_map(|p| p.segments.iter().flatten()) {
        x = (x.0.min(px), x.1.max(px));
        y = (y.0.min(py), y.1.max(py));
    }
    let aspect = (x.1 - x.0) / (y.1 - y.0).max(1.0);
    // The plot's height is the image's less its title and x axis labels.
    let plot = (aspect * f64::from(HEIGHT - 110)).clamp(PLOT_WIDTH.0, PLOT_WIDTH.1);
    (plot as u32 + BESIDE, HEIGHT)
}

/// The sources drawn for `seq`: the labels' and the arms', and both estimator outputs where it
/// ran, each once, in that order.
fn sources(seq: &SequenceTracks, arms: &[Source]) -> Vec<Source> {
    let mut out = vec![Source::Gt, Source::GtEkf];
    out.extend(arms.iter().copied());
    if seq.estimated.is_some() {
        out.extend([Source::Estimated, Source::EstimatedSmoothed]);
    }
    let mut unique: Vec<Source> = Vec::new();
    for s in out {
        if seq.has(s) && !unique.contains(&s) {
            unique.push(s);
        }
    }
    unique
}

/// The (x, y) segments of `track_id` in `scene`, one per run of consecutive frames.
fn segments_of(scene: &Scene, track_id: i32) -> Vec<Vec<(f64, f64)>> {
    scene
        .runs
        .iter()
        .filter(|r| r.track_id == track_id)
        .map(|r| r.states.iter().map(|s| (f64::from(s.x), f64::from(s.y))).collect())
        .collect()
}

/// The (x, y) segments of `track_id` among `tracks` (no source applied), one per run.
fn track_segments(tracks: &[ObjectTrack], track_id: i32) -> Vec<Vec<(f64, f64)>> {
    tracks
        .iter()
        .filter(|t| t.track_id == track_id)
        .flat_map(|t| t.runs().map(|r| t.states[r].iter().map(|s| (f64::from(s.x), f64::from(s.y))).collect()))
        .collect()
}

/// The bird's-eye trajectory of `subject` per source; nothing when no source has it.
///
/// # Errors
/// The figure cannot be written, named.
pub fn write(dir: &Path, subject: &Subject<'_>, inputs: &FigureInputs<'_>) -> anyhow::Result<Vec<Figure>> {
    let (seq, track) = (subject.seq, subject.track);
    let mut paths = Vec::new();
    for (i, source) in sources(seq, inputs.arms).into_iter().enumerate() {
        let scene = seq.scene(source, inputs.dt);
        let segments = segments_of(&scene, track);
        if !segments.is_empty() {
            let style = Style { colour: Colour::Palette(i), dashed: false };
            paths.push(PathLine { label: source.name().into(), segments, style, marker: Marker::Start });
        }
    }
    let truth = seq.estimated.as_ref().map(|e| track_segments(&e.truth, track)).unwrap_or_default();
    let has_truth = !truth.is_empty();
    if has_truth {
        let style = Style { colour: Colour::Ink, dashed: true };
        paths.push(PathLine { label: "simulator's truth".into(), segments: truth, style, marker: Marker::None });
    }
    if paths.is_empty() {
        return Ok(Vec::new());
    }
    let figure = PathFigure {
        title: format!("bird's-eye trajectory: {}", subject.name()),
        x_label: "world x (m)".into(),
        y_label: "world y (m, forward at the first frame)".into(),
        size: size_for(&paths),
        panels: vec![Panel { title: String::new(), paths }],
    };
    let [png, _] = write_paths(&figure, &dir.join(format!("birdseye_{}", subject.stem())))?;
    let truth_note = if has_truth {
        " The dashed line is the simulator's true path of the box centre, which the estimator's tracks (the centroid \
            of the object's first tracked points) are offset from by a fixed amount."
    } else {
        ""
    };
    Ok(vec![Figure {
        png,
        caption: format!(
            "Bird's-eye trajectory of {} per source, in the world frame (the first camera's ground plane; metres, one \
            scale on both axes); a dot marks where each run starts. The estimator's world is its own estimate of \
            that frame, so its paths drift from the labels' as its camera error adds up.{truth_note}",
            subject.name()
        ),
    }])
}
