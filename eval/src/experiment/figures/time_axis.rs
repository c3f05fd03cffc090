//! Time on the figures' x axes: seconds (frame x the frame period the run used), labelled with
//! that rate, because readers think in seconds while the data is in frames, and the paper's
//! 20 Hz is not KITTI's recorded 10 Hz.

use dynotraj_core::limits::{HORIZON, PAPER_FRAME_RATE_HZ};

/// The rate of frame period `dt`, as few decimals as it needs ("20", "12.5").
#[must_use]
pub fn rate_text(dt: f32) -> String {
    let hz = 1.0 / f64::from(dt);
    let text = format!("{hz:.2}");
    text.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// The x label of a chart over frames: "time (s; frames at 20 Hz; KITTI records 10 Hz: real
/// time x2)".
#[must_use]
pub fn time_label(dt: f32) -> String {
    format!("time (s; frames at {} Hz{})", rate_text(dt), real_time_note(dt))
}

/// The x label of a chart over horizon steps: "horizon (s; 30 steps at 20 Hz; ...)".
#[must_use]
pub fn horizon_label(dt: f32) -> String {
    format!("horizon (s; {HORIZON} steps at {} Hz{})", rate_text(dt), real_time_note(dt))
}

/// At the paper's 20 Hz convention, what KITTI's frames really span: it records at 10 Hz, so
/// real time is twice the axis.
fn real_time_note(dt: f32) -> &'static str {
    if (1.0 / dt - PAPER_FRAME_RATE_HZ).abs() < 1e-3 { "; KITTI records 10 Hz: real time x2" } else { "" }
}

/// The sentence every report carries about time: what the 30-step horizon and the history
/// span at the run's frame period, and in KITTI's real time where the run uses the paper's
/// 20 Hz convention.
#[must_use]
pub fn time_span_note(dt: f32, history_frames: usize) -> String {
    let at = |frames: usize| f64::from(dt) * frames as f64;
    let mut note = format!(
        "Time: every forecast covers {HORIZON} frames, {:.1} s at {} Hz; the history is up to {history_frames} \
            frames ({:.2} s).",
        at(HORIZON),
        rate_text(dt),
        at(history_frames)
    );
    if !real_time_note(dt).is_empty() {
        note.push_str(&format!(
            " KITTI records at 10 Hz, so in real time the horizon is {:.1} s and the history {:.2} s (the \
                paper's 20 Hz convention, kept for comparison).",
            2.0 * at(HORIZON),
            2.0 * at(history_frames)
        ));
    }
    note
}

/// Frame `frame` in seconds at frame period `dt`.
#[must_use]
pub fn seconds(frame: u32, dt: f32) -> f64 {
    f64::from(frame) * f64::from(dt)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_say_seconds_and_the_rate() {
        assert_eq!(time_label(0.05), "time (s; frames at 20 Hz; KITTI records 10 Hz: real time x2)");
        let note = time_span_note(0.05, 21);
        assert!(note.contains("1.5 s at 20 Hz") && note.contains("real time the horizon is 3.0 s"), "{note}");
        assert!(!time_span_note(0.1, 21).contains("real time"), "a 10 Hz run needs no conversion");
        assert_eq!(time_label(0.1), "time (s; frames at 10 Hz)");
        assert_eq!(horizon_label(0.08), "horizon (s; 30 steps at 12.5 Hz)");
        assert!((seconds(154, 0.05) - 7.7).abs() < 1e-6);
    }
}
