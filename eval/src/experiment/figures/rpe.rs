//! The estimator's RPE over time: per frame, the translational error of the relative pose from
//! the frame before, against the simulator's truth, for the camera and for the moving objects,
//! causal and smoothed estimates: the pairs behind Table III's RPE
//! ([`dynotraj_sources::estimation::score::rpe_over_time`]).

use std::path::Path;

use super::Figure;
use super::time_axis::{seconds, time_label};
use crate::report::chart::{Chart, Series, write_chart};
use dynotraj_sources::estimation::score::FrameRpe;
use dynotraj_sources::estimation::{Kind, RunScores};
use dynotraj_sources::sequence::SequenceTracks;

/// The kinds drawn, as Table III reports them.
const KINDS: [Kind; 2] = [Kind::Causal, Kind::Smoothed];

/// One chart: whose RPE (file stem part, long name, camera or objects), its value per frame and
/// how it relates to Table III.
struct Entity {
    name: &'static str,
    long: &'static str,
    camera: bool,
    value: fn(&FrameRpe) -> Option<f64>,
    how: &'static str,
}

/// Table III's RPE_t of `kind` in `scores` (camera or objects), metres.
fn table_value(scores: Option<&RunScores>, kind: Kind, camera: bool) -> Option<f64> {
    let k = Kind::ALL.iter().position(|x| *x == kind)?;
    let s = scores?.kinds.get(k)?;
    if camera { s.camera } else { s.object }.map(|r| r.translation)
}

/// `v` to three significant digits (a camera's RPE is millimetres, an object's centimetres).
fn significant(v: f64) -> String {
    let decimals = if v > 0.0 && v.is_finite() { (2 - v.log10().floor() as i32).max(0) as usize } else { 3 };
    format!("{v:.decimals$}")
}

/// The camera and object RPE over time of `seq`'s estimator run; nothing when it has no
/// per-frame RPE (no estimated arm, or real images without truth).
///
/// # Errors
/// A chart that cannot be written, named.
pub fn write(dir: &Path, seq: &SequenceTracks, dt: f32) -> anyhow::Result<Vec<Figure>> {
    let Some(est) = &seq.estimated else { return Ok(Vec::new()) };
    let kinds: Vec<(Kind, &[FrameRpe])> = KINDS
        .iter()
        .filter_map(|&k| {
            let i = Kind::ALL.iter().position(|x| *x == k)?;
            Some((k, est.rpe_frames.get(i)?.as_slice()))
        })
        .filter(|(_, frames)| !frames.is_empty())
        .collect();
    if kinds.is_empty() {
        return Ok(Vec::new());
    }
    let mut out = Vec::new();
    let entities = [
        Entity {
            name: "camera",
            long: "camera",
            camera: true,
            value: |f| f.camera,
            how: "the camera's pair error; Table III's camera RPE_t is their root mean square",
        },
        Entity {
            name: "objects",
            long: "moving objects",
            camera: false,
            value: |f| f.objects,
            how: "the root mean square over the moving objects' pairs ending at that frame; Table III's object RPE_t \
                is the root mean square over every pair",
        },
    ];
    for Entity { name, long, camera, value, how } in entities {
        let series: Vec<Series> = kinds
            .iter()
            .map(|(k, frames)| {
                let label = match table_value(est.rpe.as_ref(), *k, camera) {
                    Some(v) => format!("{} (RPE_t {} m)", k.name(), significant(v)),
                    None => k.name().to_string(),
                };
                Series::new(label, frames.iter().filter_map(|f| Some((seconds(f.frame, dt), value(f)?))).collect())
            })
            .collect();
        if series.iter().all(|s| s.points.is_empty()) {
            continue;
        }
        let chart = Chart {
            title: format!("{long} RPE per frame: sequence {}", seq.id),
            x_label: time_label(dt),
            y_label: "translational RPE (m)".into(),
            series,
        };
        let [png, _] = write_chart(&chart, &dir.join(format!("rpe_{name}_{}", seq.id)))?;
        out.push(Figure {
            png,
            caption: format!(
                "The estimator's translational RPE of the {long} over time, sequence {}: at each frame, the error of \
                the relative pose from the frame before against the simulator's truth (delta = 1 frame), causal and \
                smoothed estimates; for the {long}, {how} (in the legend).",
                seq.id
            ),
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn legend_values_keep_three_significant_digits() {
        assert_eq!(significant(0.00213), "0.00213");
        assert_eq!(significant(0.0245), "0.0245");
        assert_eq!(significant(1.5), "1.50");
        assert_eq!(significant(0.0), "0.000");
    }
}
