//! The estimator's counters: every input it could not use and every fallback it took, so that
//! nothing is lost silently. Counters saturate instead of wrapping.

/// What the estimator has seen and done. See [`super`] for the rule behind each counter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EstimatorStats {
    /// Frames whose every part arrived and which were processed.
    pub frames_processed: u32,
    /// Frames abandoned with parts missing (a part of a newer frame arrived first).
    pub frames_incomplete: u32,
    /// Parts whose numbering is impossible (`part >= parts`, too many parts, or a part count
    /// that disagrees with the frame's earlier parts).
    pub parts_malformed: u32,
    /// Parts received twice; the second copy is ignored.
    pub parts_duplicate: u32,
    /// Parts of a frame not newer than the last processed one; ignored.
    pub parts_stale: u32,
    /// Tracks with zero, negative, non-finite or too-near depth; skipped.
    pub tracks_bad_depth: u32,
    /// Tracks farther than the usable depth; skipped.
    pub tracks_too_far: u32,
    /// Tracks with a non-finite pixel or one outside the storable range; skipped.
    pub tracks_bad_pixel: u32,
    /// Tracks whose id already occurred in the same frame (and object); the first is kept.
    pub tracks_duplicate: u32,
    /// Static tracks beyond the static capacity; dropped.
    pub static_tracks_dropped: u32,
    /// Tracks of an object beyond the per-object point capacity; dropped.
    pub object_points_dropped: u32,
    /// Tracks of objects beyond the object capacity of a frame; dropped.
    pub object_tracks_dropped: u32,
    /// Frames in which at least one object was dropped for capacity.
    pub frames_with_objects_dropped: u32,
    /// Frame periods replaced by the nominal one (timestamps equal, decreasing or too far apart).
    pub timestamps_replaced: u32,
    /// Frames whose ego-motion could not be fitted (too few static matches or inliers); the
    /// previous motion was held.
    pub camera_motion_held: u32,
    /// Object-frames whose motion could not be fitted; the previous motion was held.
    pub object_motion_held: u32,
    /// Objects (re)initialised: first seen, or seen again after missing a frame.
    pub objects_initialised: u32,
    /// Runs that began tracking (their first motion was fitted): one per object, plus one per
    /// restart.
    pub runs_tracked: u32,
    /// Objects that came back after their run had ended (each also counts as initialised).
    pub objects_returned: u32,
    /// Objects seen too briefly or with too few points to be initialised.
    pub objects_not_initialised: u32,
    /// Objects whose frame was re-oriented once their heading became known from motion.
    pub objects_reoriented: u32,
    /// Object-frames a tracking object was missing from and coasted through on its last motion.
    pub object_frames_coasted: u32,
    /// Objects that came back within [`super::MAX_HELD_FRAMES`] frames and resumed their run.
    pub objects_resumed: u32,
    /// Runs ended because their object was missing from too many consecutive frames.
    pub runs_ended_lost: u32,
    /// Runs ended because their motion fit failed in too many consecutive frames.
    pub runs_ended_fit_failed: u32,
    /// Runs ended because their points lay beyond the usable depth for too many frames.
    pub runs_ended_out_of_range: u32,
    /// Runs of objects evicted from the object table to make room; their frames not yet
    /// smoothed are lost.
    pub runs_evicted: u32,
    /// Smoothed object-frames lost to eviction.
    pub smoothed_frames_lost: u32,
    /// Numerical failures (singular or non-finite systems) caught and answered with a hold.
    pub numerical_failures: u32,
}

impl EstimatorStats {
    /// Every counter at zero.
    pub const ZERO: Self = Self {
        frames_processed: 0,
        frames_incomplete: 0,
        parts_malformed: 0,
        parts_duplicate: 0,
        parts_stale: 0,
        tracks_bad_depth: 0,
        tracks_too_far: 0,
        tracks_bad_pixel: 0,
        tracks_duplicate: 0,
        static_tracks_dropped: 0,
        object_points_dropped: 0,
        object_tracks_dropped: 0,
        frames_with_objects_dropped: 0,
        timestamps_replaced: 0,
        camera_motion_held: 0,
        object_motion_held: 0,
        objects_initialised: 0,
        runs_tracked: 0,
        objects_returned: 0,
        objects_not_initialised: 0,
        objects_reoriented: 0,
        object_frames_coasted: 0,
        objects_resumed: 0,
        runs_ended_lost: 0,
        runs_ended_fit_failed: 0,
        runs_ended_out_of_range: 0,
        runs_evicted: 0,
        smoothed_frames_lost: 0,
        numerical_failures: 0,
    };
}

impl Default for EstimatorStats {
    fn default() -> Self {
        Self::ZERO
    }
}

impl EstimatorStats {
    /// Counts a run that ended for `cause`.
    pub(super) fn run_ended(&mut self, cause: EndCause) {
        bump(match cause {
            EndCause::Lost => &mut self.runs_ended_lost,
            EndCause::FitFailed => &mut self.runs_ended_fit_failed,
            EndCause::OutOfRange => &mut self.runs_ended_out_of_range,
        });
    }
}

/// Adds one to a counter, saturating.
pub(super) fn bump(c: &mut u32) {
    *c = c.saturating_add(1);
}

/// Adds `n` to a counter, saturating.
pub(super) fn add(c: &mut u32, n: usize) {
    *c = c.saturating_add(u32::try_from(n).unwrap_or(u32::MAX));
}

/// Why a run ended before its object was gone for good.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EndCause {
    /// The object was missing from more than [`super::MAX_HELD_FRAMES`] consecutive frames.
    Lost,
    /// Its motion fit failed in more than [`super::MAX_HELD_FRAMES`] consecutive frames (too few
    /// matched points, or no consensus).
    FitFailed,
    /// Its points lay beyond the usable depth for more than [`super::MAX_HELD_FRAMES`] frames.
    OutOfRange,
}
