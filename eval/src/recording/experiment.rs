//! Recordings of an experiment's test sequences, for a viewer (Foxglove): per test sequence one
//! MCAP file; per arm and frame, each eligible object's recent states and the forecasts made
//! from them by the arm's fold model (int8, trained without the sequence) and by constant
//! velocity, on `/<arm>/tracks`, `/<arm>/forecasts/learned` and `/<arm>/forecasts/cv`.

use std::path::Path;

use anyhow::Context as _;
use dynotraj_bag::record::{
    Line, Recorder, RecordingEncoding, RecordingSummary, Rgba, forecast_line as forecast_entity, ground, meta,
    trail_line,
};
use dynotraj_core::limits::HORIZON;
use dynotraj_core::predict::{Baseline, Predictor};
use dynotraj_sources::scene::{Scene, SourcedRun};
use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::{EligibilityRule, Source, eligible_runs};

use crate::experiment::figures::FoldModels;
use crate::forecast_eval::forecast_at;

/// How many past states a track's line shows: as far back as a forecast reaches ahead (a
/// whole run's path at every frame would grow a recording with the square of its length).
pub const TRAIL_STATES: usize = HORIZON;

const TRACK_COLOR: Rgba = Rgba::opaque(0.2, 0.6, 1.0);
const LEARNED_COLOR: Rgba = Rgba::opaque(1.0, 0.4, 0.1);
const CV_COLOR: Rgba = Rgba::opaque(0.6, 0.6, 0.6);

/// One arm of a sequence: its scene and, per eligible run, the run's index in the scene and
/// its test instances.
struct ArmRuns {
    arm: Source,
    scene: Scene,
    runs: Vec<(usize, std::ops::Range<usize>)>,
}

fn forecast_line(
    run: &SourcedRun,
    s: usize,
    scene: &Scene,
    p: &mut dyn Predictor,
    dt: f32,
    color: Rgba,
) -> Option<Line> {
    let f = forecast_at(run, s, scene, p, dt).ok()?;
    let mut points = vec![ground(run.states.get(s)?.x, run.states.get(s)?.y)];
    points.extend(f.iter().map(|q| ground(q.x, q.y)));
    Some(forecast_entity(run.track_id, points, color, Vec::new()))
}

/// Writes `<dir>/<seq>.mcap` for every sequence of `tests`, with `arms`' fold models from
/// `models` (an arm without a model for a sequence records its tracks and cv only).
///
/// # Errors
/// A recording that cannot be written, named.
pub fn write_recordings(
    dir: &Path,
    encoding: RecordingEncoding,
    tests: &[&SequenceTracks],
    arms: &[Source],
    models: &FoldModels,
    rule: &EligibilityRule,
    dt: f32,
) -> anyhow::Result<Vec<RecordingSummary>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let rate = 1.0 / f64::from(dt);
    let mut out = Vec::new();
    for seq in tests {
        let path = dir.join(format!("{}.mcap", seq.id));
        let mut rec = Recorder::create_with(&path, encoding)?;
        let arms: Vec<Source> = arms.iter().copied().filter(|a| seq.has(*a)).collect();
        let prepared: Vec<ArmRuns> = arms
            .iter()
            .map(|&arm| {
                let scene = seq.scene(arm, dt);
                // Each eligible run's index in the scene and its test instances.
                let runs = eligible_runs(seq.tracks_for(arm), rule)
                    .iter()
                    .filter_map(|r| {
                        let i = scene
                            .runs
                            .iter()
                            .position(|s| s.track_id == r.track_id && s.first_frame == r.first_frame)?;
                        Some((i, r.instances()))
                    })
                    .collect();
                ArmRuns { arm, scene, runs }
            })
            .collect();
        for frame in 0..u32::try_from(seq.frame_count).unwrap_or(u32::MAX) {
            let t = rec.frame_time(frame, rate)?;
            for ArmRuns { arm, scene, runs } in &prepared {
                let mut learned = models.get(*arm, &seq.id).map(|m| m.predictor());
                let (mut tracks, mut learned_lines, mut cv_lines) = (Vec::new(), Vec::new(), Vec::new());
                for (i, instances) in runs {
                    let Some(run) = scene.runs.get(*i) else { continue };
                    let Some(s) = frame.checked_sub(run.first_frame).map(|s| s as usize) else { continue };
                    let Some(trail) = run.states.get(s.saturating_sub(TRAIL_STATES)..=s) else { continue };
                    let points = trail.iter().map(|st| ground(st.x, st.y)).collect();
                    tracks.push(trail_line(run.track_id, points, TRACK_COLOR, meta("arm", arm)));
                    if !instances.contains(&s) {
                        continue;
                    }
                    if let Some(p) = learned.as_mut() {
                        learned_lines.extend(forecast_line(run, s, scene, p, dt, LEARNED_COLOR));
                    }
                    cv_lines.extend(forecast_line(run, s, scene, &mut Baseline::ConstantVelocity, dt, CV_COLOR));
                }
                rec.lines(&format!("/{arm}/tracks"), t, &tracks)?;
                if learned.is_some() {
                    rec.lines(&format!("/{arm}/forecasts/learned"), t, &learned_lines)?;
                }
                rec.lines(&format!("/{arm}/forecasts/cv"), t, &cv_lines)?;
            }
        }
        out.push(rec.finish()?);
    }
    Ok(out)
}
