//! ADE and FDE against the horizon: for each arm's int8 model, its motion prior alone and
//! constant velocity on the same source, the error of every horizon from 1 to 30 steps, over the test instances of every
//! loaded sequence that has a fold model of that arm (each model trained without it), pooled.
//! Scored by [`crate::forecast_eval`] as Table IV is, against each source's own future.

use std::path::Path;

use dynotraj_core::limits::HORIZON;
use dynotraj_core::predict::{Baseline, MotionPrior};

use super::time_axis::horizon_label;
use super::{Figure, FigureInputs};
use crate::forecast_eval::{HorizonErrors, score_sequence};
use crate::report::chart::{Chart, Colour, Series, Style, write_chart};
use dynotraj_sources::trajectory::{Source, eligible_runs};

/// One arm's pooled errors: its int8 model's, its prior's, constant velocity's, the sequences
/// pooled.
struct ArmErrors {
    arm: Source,
    learned: HorizonErrors,
    prior: HorizonErrors,
    cv: HorizonErrors,
    sequences: Vec<String>,
}

/// The errors of every arm with at least one fold model among the loaded sequences.
fn arm_errors(inputs: &FigureInputs<'_>) -> Vec<ArmErrors> {
    let mut out = Vec::new();
    for &arm in inputs.arms {
        let mut e = ArmErrors {
            arm,
            learned: HorizonErrors::default(),
            prior: HorizonErrors::default(),
            cv: HorizonErrors::default(),
            sequences: vec![],
        };
        for seq in inputs.sequences {
            let Some(model) = inputs.models.get(arm, &seq.id) else { continue };
            let tracks = seq.tracks_for(arm);
            let runs = eligible_runs(tracks, inputs.rule);
            let scene = seq.scene(arm, inputs.dt);
            e.learned.merge(&score_sequence(&runs, &scene, &mut model.predictor(), inputs.dt).horizon);
            let mut prior = MotionPrior(*model.blob().prior());
            e.prior.merge(&score_sequence(&runs, &scene, &mut prior, inputs.dt).horizon);
            e.cv.merge(&score_sequence(&runs, &scene, &mut Baseline::ConstantVelocity, inputs.dt).horizon);
            e.sequences.push(seq.id.clone());
        }
        if e.learned.count() > 0 {
            out.push(e);
        }
    }
    out
}

/// One chart: its file stem, title, y unit, the curve of an arm's errors and what it shows.
struct Curve {
    stem: &'static str,
    title: &'static str,
    unit: &'static str,
    values: fn(&HorizonErrors) -> Vec<f64>,
    what: &'static str,
}

/// Points (horizon in seconds, value) of a per-step curve.
fn over_horizon(values: &[f64], dt: f32) -> Vec<(f64, f64)> {
    values.iter().enumerate().map(|(i, v)| ((i + 1) as f64 * f64::from(dt), *v)).collect()
}

/// The ADE and FDE against the horizon charts; nothing when no arm has a fold model.
///
/// # Errors
/// A chart that cannot be written, named.
pub fn write(dir: &Path, inputs: &FigureInputs<'_>) -> anyhow::Result<Vec<Figure>> {
    let arms = arm_errors(inputs);
    if arms.is_empty() {
        return Ok(Vec::new());
    }
    let pooled: Vec<String> = arms
        .iter()
        .map(|a| format!("{}: sequences {} ({} forecasts)", a.arm, a.sequences.join(", "), a.learned.count()))
        .collect();
    let mut out = Vec::new();
    let charts = [
        Curve {
            stem: "ade_horizon",
            title: "ADE against the horizon",
            unit: "ADE (m)",
            values: HorizonErrors::ade_by_step,
            what: "ADE against the horizon: at each horizon k, the mean displacement error over steps 1 to k",
        },
        Curve {
            stem: "fde_horizon",
            title: "FDE against the horizon (mean displacement error at each step)",
            unit: "FDE (m)",
            values: HorizonErrors::fde_by_step,
            what: "FDE against the horizon: at each horizon k, the mean displacement error at step k (the FDE of a \
                k-step horizon)",
        },
    ];
    for Curve { stem, title, unit, values, what } in charts {
        let mut series = Vec::new();
        for (i, a) in arms.iter().enumerate() {
            let colour = Colour::Palette(i);
            series.push(
                Series::new(format!("learned int8 on {}", a.arm), over_horizon(&values(&a.learned), inputs.dt))
                    .styled(Style { colour, dashed: false }),
            );
            series.push(
                Series::new(format!("prior on {}", a.arm), over_horizon(&values(&a.prior), inputs.dt))
                    .styled(Style { colour: Colour::Palette(i + arms.len()), dashed: false }),
            );
            series.push(
                Series::new(
                    format!("{} on {}", Baseline::ConstantVelocity.name(), a.arm),
                    over_horizon(&values(&a.cv), inputs.dt),
                )
                .styled(Style { colour, dashed: true }),
            );
        }
        let chart = Chart { title: title.into(), x_label: horizon_label(inputs.dt), y_label: unit.into(), series };
        let [png, _] = write_chart(&chart, &dir.join(stem))?;
        out.push(Figure {
            png,
            caption: format!(
                "{what}, of each arm's int8 model (solid), its motion prior alone (solid, its own colour) and \
                constant velocity on the same source (dashed, the model's colour), each scored against its own source's future over the test instances of the held-out \
                sequences that have a fold model, pooled ({}). At the full horizon ({HORIZON} steps) the curves \
                are the weighted ADE and FDE of Table IV's int8 and cv rows over those sequences.",
                pooled.join("; ")
            ),
        });
    }
    Ok(out)
}
