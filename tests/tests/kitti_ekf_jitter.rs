//! On real KITTI labels, the GT+EKF source must be smoother than the raw labels: lower mean
//! |delta heading| and |delta speed| between consecutive frames of eligible runs.
//!
//! The first frame of a run is left out of both: a causal filter has no speed there yet (it has
//! seen one position), while the labels' speed at that frame peeks at the next frame.

use dynotraj_core::BevState;
use dynotraj_core::geometry::angle_diff;
use dynotraj_formats::kitti::TrackingDir;
use dynotraj_sources::sequence::load_ground_truth;
use dynotraj_sources::trajectory::{EligibilityRule, Source, eligible_runs};
use dynotraj_tests::kitti_training_dir;

/// Mean |delta heading| (rad) and |delta speed| (m/s) between consecutive states.
fn jitter(states: &[BevState]) -> (f64, f64) {
    let n = states.len().saturating_sub(1).max(1) as f64;
    let dh: f64 = states.windows(2).map(|w| f64::from(angle_diff(w[1].heading, w[0].heading).abs())).sum();
    let dv: f64 = states.windows(2).map(|w| f64::from((w[1].speed - w[0].speed).abs())).sum();
    (dh / n, dv / n)
}

#[test]
fn ekf_reduces_frame_to_frame_jitter_of_real_labels() {
    let Some(root) = kitti_training_dir() else { return };
    let dir = TrackingDir::open(&root).expect("open KITTI folder");
    let dt = 0.05;
    let rule = EligibilityRule::default();
    let mut totals = [(0.0, 0.0); 2];
    let mut runs_seen = 0;
    for id in dir.sequences().expect("list sequences") {
        let seq = load_ground_truth(&dir, &id, dt).expect("load sequence");
        let mut seq_totals = [(0.0, 0.0); 2];
        let runs = eligible_runs(&seq.tracks, &rule);
        for run in &runs {
            for (i, src) in [Source::Gt, Source::GtEkf].into_iter().enumerate() {
                let (h, v) = jitter(&src.apply(&run.states, dt)[1..]);
                seq_totals[i].0 += h;
                seq_totals[i].1 += v;
            }
            runs_seen += 1;
        }
        if seq_totals[0].0 > 0.0 {
            let n = runs.len() as f64;
            println!(
                "{id} ({} runs): mean |dheading| gt {:.4} ekf {:.4} rad/frame, mean |dspeed| gt {:.3} ekf {:.3} \
                    m/s/frame",
                runs.len(),
                seq_totals[0].0 / n,
                seq_totals[1].0 / n,
                seq_totals[0].1 / n,
                seq_totals[1].1 / n
            );
            assert!(seq_totals[1].0 < seq_totals[0].0, "{id}: EKF heading jitter not lower");
            assert!(seq_totals[1].1 < seq_totals[0].1, "{id}: EKF speed jitter not lower");
        }
        for i in 0..2 {
            totals[i].0 += seq_totals[i].0;
            totals[i].1 += seq_totals[i].1;
        }
    }
    assert!(runs_seen >= 20, "expected the nine sequences to hold many eligible runs, saw {runs_seen}");
    // The EKF must cut the jitter substantially, not marginally.
    assert!(totals[1].0 < 0.7 * totals[0].0, "heading jitter {:?}", totals);
    assert!(totals[1].1 < 0.5 * totals[0].1, "speed jitter {:?}", totals);
}
