//! The front-end's counters: everything it drops or cannot do is counted, never a crash.

/// Counters since the front-end started.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FrontEndStats {
    /// Frames processed.
    pub frames: u64,
    /// Static points followed into the next frame.
    pub static_tracked: u64,
    /// Static points KLT lost (or that left the image or landed on an object).
    pub static_lost: u64,
    /// Static points rejected by the forward-backward check.
    pub static_failed_check: u64,
    /// New static corners.
    pub static_detected: u64,
    /// Static points not sent for want of depth (or out of the depth range), per frame.
    pub static_no_depth: u64,
    /// Static points not sent: beyond `MAX_STATIC_TRACKS`.
    pub static_dropped: u64,
    /// Object points followed into the next frame.
    pub object_points_tracked: u64,
    /// Object points KLT lost (or that left their mask).
    pub object_points_lost: u64,
    /// Object points rejected by the forward-backward check.
    pub object_points_failed_check: u64,
    /// New object points sampled in masks.
    pub object_points_sampled: u64,
    /// Object points not sent for want of depth, per frame.
    pub object_points_no_depth: u64,
    /// Object points not sent: beyond `MAX_POINTS_PER_OBJECT`, or of dropped objects.
    pub object_points_dropped: u64,
    /// Objects not sent: beyond `MAX_OBJECTS` (the farthest go).
    pub objects_dropped: u64,
    /// Objects whose mask came out empty (a box without depth inside).
    pub empty_masks: u64,
    /// Objects with a mask but no textured pixel to follow.
    pub textureless_objects: u64,
    /// Detection grid cells without a single corner (sky, blank walls), summed over frames.
    pub textureless_cells: u64,
}

impl FrontEndStats {
    /// Every counter with its name, in declaration order (for tables).
    #[must_use]
    pub const fn named(&self) -> [(&'static str, u64); 17] {
        [
            ("frames", self.frames),
            ("static_tracked", self.static_tracked),
            ("static_lost", self.static_lost),
            ("static_failed_check", self.static_failed_check),
            ("static_detected", self.static_detected),
            ("static_no_depth", self.static_no_depth),
            ("static_dropped", self.static_dropped),
            ("object_points_tracked", self.object_points_tracked),
            ("object_points_lost", self.object_points_lost),
            ("object_points_failed_check", self.object_points_failed_check),
            ("object_points_sampled", self.object_points_sampled),
            ("object_points_no_depth", self.object_points_no_depth),
            ("object_points_dropped", self.object_points_dropped),
            ("objects_dropped", self.objects_dropped),
            ("empty_masks", self.empty_masks),
            ("textureless_objects", self.textureless_objects),
            ("textureless_cells", self.textureless_cells),
        ]
    }

    pub(crate) fn count_lost(&mut self, is_static: bool) {
        if is_static {
            self.static_lost += 1;
        } else {
            self.object_points_lost += 1;
        }
    }

    pub(crate) fn count_failed_check(&mut self, is_static: bool) {
        if is_static {
            self.static_failed_check += 1;
        } else {
            self.object_points_failed_check += 1;
        }
    }

    /// Share of static points of a frame that were followed into the next (KLT survival).
    #[must_use]
    pub fn static_survival(&self) -> f64 {
        let n = self.static_tracked + self.static_lost + self.static_failed_check;
        if n == 0 { 0.0 } else { self.static_tracked as f64 / n as f64 }
    }

    /// Share of object points followed into the next frame.
    #[must_use]
    pub fn object_survival(&self) -> f64 {
        let n = self.object_points_tracked + self.object_points_lost + self.object_points_failed_check;
        if n == 0 { 0.0 } else { self.object_points_tracked as f64 / n as f64 }
    }
}
