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
    /// Points given a depth refined to sub-pixel (before the capacities drop any).
    pub subpixel_refined: u64,
    /// Points whose sub-pixel refinement was refused (it moved too far from the dense matcher's
    /// value, or the aligned patches still differed): sent with the dense value, or not at all
    /// with [`crate::SubpixelParams::drop_refused`].
    pub subpixel_refused: u64,
    /// Points that kept the dense matcher's disparity (patch too flat or too small to refine).
    pub subpixel_kept_dense: u64,
    /// Frames of motion segmentation whose camera motion could not be fitted (no object is
    /// found in them).
    pub motion_ego_failed: u64,
    /// Probes the motion segmentation judged (with depth now and some frames back).
    pub motion_probes_judged: u64,
    /// Of those, moving (in as many frames in a row as it asks).
    pub motion_probes_moving: u64,
    /// Moving probes in no cluster large enough to be an object.
    pub motion_probes_unclustered: u64,
    /// Objects the motion segmentation reported, summed over frames.
    pub motion_objects: u64,
    /// Of those, objects not found in the frame but reported from the probes they held
    /// ([`crate::motion::MotionParams::coast_frames`]).
    pub motion_objects_coasted: u64,
    /// Forgotten objects whose id a new cluster took back
    /// ([`crate::motion::MotionParams::reacquire_frames`]).
    pub motion_objects_reacquired: u64,
}

impl FrontEndStats {
    /// Every counter with its name, in declaration order (for tables).
    #[must_use]
    pub const fn named(&self) -> [(&'static str, u64); 27] {
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
            ("subpixel_refined", self.subpixel_refined),
            ("subpixel_refused", self.subpixel_refused),
            ("subpixel_kept_dense", self.subpixel_kept_dense),
            ("motion_ego_failed", self.motion_ego_failed),
            ("motion_probes_judged", self.motion_probes_judged),
            ("motion_probes_moving", self.motion_probes_moving),
            ("motion_probes_unclustered", self.motion_probes_unclustered),
            ("motion_objects", self.motion_objects),
            ("motion_objects_coasted", self.motion_objects_coasted),
            ("motion_objects_reacquired", self.motion_objects_reacquired),
        ]
    }

    /// The counters of `self` and `other` added.
    #[must_use]
    pub fn plus(&self, other: &Self) -> Self {
        let mut out = *self;
        let pairs: [(&mut u64, u64); 27] = [
            (&mut out.frames, other.frames),
            (&mut out.static_tracked, other.static_tracked),
            (&mut out.static_lost, other.static_lost),
            (&mut out.static_failed_check, other.static_failed_check),
            (&mut out.static_detected, other.static_detected),
            (&mut out.static_no_depth, other.static_no_depth),
            (&mut out.static_dropped, other.static_dropped),
            (&mut out.object_points_tracked, other.object_points_tracked),
            (&mut out.object_points_lost, other.object_points_lost),
            (&mut out.object_points_failed_check, other.object_points_failed_check),
            (&mut out.object_points_sampled, other.object_points_sampled),
            (&mut out.object_points_no_depth, other.object_points_no_depth),
            (&mut out.object_points_dropped, other.object_points_dropped),
            (&mut out.objects_dropped, other.objects_dropped),
            (&mut out.empty_masks, other.empty_masks),
            (&mut out.textureless_objects, other.textureless_objects),
            (&mut out.textureless_cells, other.textureless_cells),
            (&mut out.subpixel_refined, other.subpixel_refined),
            (&mut out.subpixel_refused, other.subpixel_refused),
            (&mut out.subpixel_kept_dense, other.subpixel_kept_dense),
            (&mut out.motion_ego_failed, other.motion_ego_failed),
            (&mut out.motion_probes_judged, other.motion_probes_judged),
            (&mut out.motion_probes_moving, other.motion_probes_moving),
            (&mut out.motion_probes_unclustered, other.motion_probes_unclustered),
            (&mut out.motion_objects, other.motion_objects),
            (&mut out.motion_objects_coasted, other.motion_objects_coasted),
            (&mut out.motion_objects_reacquired, other.motion_objects_reacquired),
        ];
        for (a, b) in pairs {
            *a += b;
        }
        out
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
