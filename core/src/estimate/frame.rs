//! One camera frame's tracks in fixed arrays, and its assembly from [`FrameTracks`] parts.
//!
//! Points are kept sorted by track id (static tracks in one list, each object's tracks in its
//! own), so that matching frame k-1 to frame k is a linear merge and a duplicate id is found
//! by a binary search. Pixel coordinates are stored in 1/16 px steps as `u16` (range
//! [0, 4096) px, rounding error below 0.02 px rms) to keep an observation at 12 bytes: two frames
//! of 16 objects x 128 points + 256 static tracks then take 55 KiB instead of 74 KiB.

use heapless::Vec;

use super::stats::{EstimatorStats, add, bump};
use crate::limits::{MAX_OBJECTS, MAX_POINTS_PER_OBJECT, MAX_STATIC_TRACKS};
use crate::wire::{FrameTracks, MAX_FRAME_PARTS, ObjectClass, Track};

/// Sub-pixel steps per pixel of a stored pixel coordinate.
pub const PIXEL_STEPS: f32 = 16.0;
/// Pixel coordinates must lie in `[0, MAX_PIXEL)`.
pub const MAX_PIXEL: f32 = 65_535.0 / PIXEL_STEPS;

// The received-parts mask is a u64.
const _: () = assert!(MAX_FRAME_PARTS <= 64);

/// One track's observation in one frame: id, pixel and depth.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Obs {
    /// Track id.
    pub track_id: u32,
    /// Pixel column in 1/16 px.
    u: u16,
    /// Pixel row in 1/16 px.
    v: u16,
    /// Depth along the optical axis, metres.
    pub depth: f32,
}

impl Obs {
    /// The observation, or `None` when a pixel coordinate is not finite or out of range.
    #[must_use]
    pub fn new(track_id: u32, u: f32, v: f32, depth: f32) -> Option<Self> {
        let q = |x: f32| -> Option<u16> {
            if x.is_finite() && (0.0..MAX_PIXEL).contains(&x) {
                // In range by the check above, so the cast neither saturates nor wraps.
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                Some(round_non_negative(x * PIXEL_STEPS) as u16)
            } else {
                None
            }
        };
        Some(Self { track_id, u: q(u)?, v: q(v)?, depth })
    }

    /// Pixel column.
    #[must_use]
    pub fn u(&self) -> f32 {
        f32::from(self.u) / PIXEL_STEPS
    }

    /// Pixel row.
    #[must_use]
    pub fn v(&self) -> f32 {
        f32::from(self.v) / PIXEL_STEPS
    }
}

/// One object's points in one frame, sorted by track id.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectPoints {
    /// Object id (never the static id).
    pub object_id: u16,
    /// Class of the object's first track in the frame.
    pub class: ObjectClass,
    /// Observations, sorted by track id, ids unique.
    pub points: Vec<Obs, MAX_POINTS_PER_OBJECT>,
    /// Tracks of the object beyond the usable depth (skipped, counted in `tracks_too_far`):
    /// an object with no points but some of these is out of range, not gone.
    pub beyond_range: u16,
}

/// One camera frame's tracks.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameBuffer {
    /// Frame index.
    pub frame: u32,
    /// Capture time, microseconds.
    pub timestamp_us: u64,
    /// Static tracks, sorted by track id, ids unique.
    pub statics: Vec<Obs, MAX_STATIC_TRACKS>,
    /// Objects in order of first arrival.
    pub objects: Vec<ObjectPoints, MAX_OBJECTS>,
}

impl FrameBuffer {
    /// An empty buffer.
    #[must_use]
    pub const fn new() -> Self {
        Self { frame: 0, timestamp_us: 0, statics: Vec::new(), objects: Vec::new() }
    }

    /// Empties the buffer for frame `frame`.
    pub fn reset(&mut self, frame: u32, timestamp_us: u64) {
        self.frame = frame;
        self.timestamp_us = timestamp_us;
        self.statics.clear();
        self.objects.clear();
    }

    /// The points of object `object_id`, if present.
    #[must_use]
    pub fn object(&self, object_id: u16) -> Option<&ObjectPoints> {
        self.objects.iter().find(|o| o.object_id == object_id)
    }
}

impl Default for FrameBuffer {
    fn default() -> Self {
        Self::new()
    }
}

/// `libm::roundf(y)` for `0 <= y < 2^23`, without its software rounding (two of them per
/// received track were about 2% of a frame's instructions on the MCU): adding the largest
/// float below one half and truncating rounds halves up and everything else to nearest,
/// exactly, since the sum is either exact or rounds to an integer boundary that truncation
/// keeps (test: every float within 16 ulps of each integer and half-integer to 2^16).
#[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, clippy::cast_precision_loss)]
fn round_non_negative(y: f32) -> f32 {
    // The float-to-integer conversion truncates; the result is a whole number below 2^23.
    (y + (0.5 - 0.25 * f32::EPSILON)) as u32 as f32
}

/// Sorts `list` by track id and keeps one observation per id, the smallest by (pixel, depth):
/// the same frame whatever order its parts and tracks came in. Returns the copies removed.
/// Sorting once when the frame completes costs O(n log n) for any arrival order; inserting each
/// track in place had cost up to a shift of the whole list per track (about 0.7 M instructions
/// per 16-object frame on the MCU once the fixture's track ids came out of order).
fn sort_unique<const N: usize>(list: &mut Vec<Obs, N>) -> usize {
    list.sort_unstable_by_key(|o| (o.track_id, o.u, o.v, o.depth.to_bits()));
    let n = list.len();
    let mut last = None;
    // Sorted: the first copy of an id is its smallest; later ones repeat the previous id.
    list.retain(|o| last.replace(o.track_id) != Some(o.track_id));
    n - list.len()
}

/// Depth limits applied while assembling.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthRange {
    /// Nearest usable depth, metres.
    pub min: f32,
    /// Farthest usable depth, metres.
    pub max: f32,
}

/// What [`FrameAssembler::accept`] did with a part.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PartOutcome {
    /// The part was stored; its frame still misses parts.
    Pending,
    /// The part completed its frame: the buffer holds the whole frame.
    Complete,
    /// The part was rejected (counted in the stats).
    Rejected,
}

/// Assembles the parts of one frame into a [`FrameBuffer`]. Rules, each counted:
/// a malformed part is rejected; a part of a frame not newer than the last completed one is
/// stale and rejected; a repeated part is ignored; a part of a newer frame while the current one
/// is incomplete abandons the current one. Tracks are checked one by one as described on
/// [`FrameAssembler::accept`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FrameAssembler {
    /// The frame being assembled: (frame, parts, mask of parts received).
    current: Option<(u32, u16, u64)>,
    /// The last completed frame.
    last_complete: Option<u32>,
    /// Whether an object was dropped for capacity in the current frame.
    dropped_object: bool,
}

impl FrameAssembler {
    /// An assembler waiting for a first part.
    #[must_use]
    pub const fn new() -> Self {
        Self { current: None, last_complete: None, dropped_object: false }
    }

    /// Takes one part into `buf`. Per track: a non-finite or out-of-range pixel, a depth that is
    /// not finite or below `depth.min` (zero and negative included), or beyond `depth.max`, is
    /// skipped; a track past a list's capacity, or of an object past the object capacity, is
    /// dropped (the sender should therefore send objects in order of priority). When the frame
    /// completes, each list is sorted by track id and a repeated id (within the static list or
    /// within one object) keeps one copy, the smallest by (pixel, depth), whatever the arrival
    /// order; repeats count against the capacity until then.
    ///
    /// Never inlined: its locals (the sorts') are off the stack before the frame is estimated.
    #[inline(never)]
    pub fn accept(
        &mut self,
        part: &FrameTracks,
        buf: &mut FrameBuffer,
        depth: DepthRange,
        stats: &mut EstimatorStats,
    ) -> PartOutcome {
        if !part.is_well_formed() {
            bump(&mut stats.parts_malformed);
            return PartOutcome::Rejected;
        }
        if self.last_complete.is_some_and(|f| part.frame <= f) {
            bump(&mut stats.parts_stale);
            return PartOutcome::Rejected;
        }
        let bit = 1u64 << u32::from(part.part).min(63);
        let mask = match self.current {
            Some((frame, parts, mask)) if frame == part.frame => {
                if parts != part.parts {
                    bump(&mut stats.parts_malformed);
                    return PartOutcome::Rejected;
                }
                if mask & bit != 0 {
                    bump(&mut stats.parts_duplicate);
                    return PartOutcome::Rejected;
                }
                mask
            }
            Some((frame, _, _)) if part.frame < frame => {
                bump(&mut stats.parts_stale);
                return PartOutcome::Rejected;
            }
            other => {
                if other.is_some() {
                    bump(&mut stats.frames_incomplete);
                }
                buf.reset(part.frame, part.timestamp_us);
                self.dropped_object = false;
                0
            }
        };
        for t in &part.tracks {
            self.add_track(t, buf, depth, stats);
        }
        let mask = mask | bit;
        let full = if part.parts >= 64 { u64::MAX } else { (1u64 << part.parts) - 1 };
        if mask == full {
            let mut duplicates = sort_unique(&mut buf.statics);
            for o in &mut buf.objects {
                duplicates = duplicates.saturating_add(sort_unique(&mut o.points));
            }
            add(&mut stats.tracks_duplicate, duplicates);
            self.current = None;
            self.last_complete = Some(part.frame);
            if self.dropped_object {
                bump(&mut stats.frames_with_objects_dropped);
            }
            PartOutcome::Complete
        } else {
            self.current = Some((part.frame, part.parts, mask));
            PartOutcome::Pending
        }
    }

    /// Notes an object track beyond the usable depth on its object, which is listed (with no
    /// points) if there is room: it is out of range, not gone. Never counts as a dropped object.
    fn note_beyond_range(t: &Track, buf: &mut FrameBuffer) {
        if let Some(slot) = object_slot(t, buf) {
            slot.beyond_range = slot.beyond_range.saturating_add(1);
        }
    }

    /// Checks and stores one track.
    fn add_track(&mut self, t: &Track, buf: &mut FrameBuffer, depth: DepthRange, stats: &mut EstimatorStats) {
        if !t.depth.is_finite() || t.depth < depth.min {
            bump(&mut stats.tracks_bad_depth);
            return;
        }
        if t.depth > depth.max {
            bump(&mut stats.tracks_too_far);
            if !t.is_static() {
                Self::note_beyond_range(t, buf);
            }
            return;
        }
        let Some(obs) = Obs::new(t.track_id, t.u, t.v, t.depth) else {
            bump(&mut stats.tracks_bad_pixel);
            return;
        };
        if t.is_static() {
            if buf.statics.push(obs).is_err() {
                bump(&mut stats.static_tracks_dropped);
            }
            return;
        }
        let Some(slot) = object_slot(t, buf) else {
            self.dropped_object = true;
            bump(&mut stats.object_tracks_dropped);
            return;
        };
        if slot.points.push(obs).is_err() {
            add(&mut stats.object_points_dropped, 1);
        }
    }
}

/// The list of `t`'s object in `buf`, added (empty) if the object is new; `None` when the
/// frame's object list is full.
fn object_slot<'b>(t: &Track, buf: &'b mut FrameBuffer) -> Option<&'b mut ObjectPoints> {
    if let Some(i) = buf.objects.iter().position(|o| o.object_id == t.object_id) {
        return buf.objects.get_mut(i);
    }
    buf.objects
        .push(ObjectPoints { object_id: t.object_id, class: t.class, points: Vec::new(), beyond_range: 0 })
        .ok()?;
    buf.objects.last_mut()
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    extern crate std;
    use super::*;
    use crate::wire::{STATIC_OBJECT_ID, frame_parts};

    const RANGE: DepthRange = DepthRange { min: 0.5, max: 40.0 };

    fn track(id: u32, object: u16, depth: f32) -> Track {
        let class = if object == STATIC_OBJECT_ID { ObjectClass::Background } else { ObjectClass::Car };
        Track { track_id: id, object_id: object, class, u: 100.0 + id as f32 * 0.37, v: 50.25, depth }
    }

    #[test]
    fn pixels_round_trip_within_a_step() {
        let o = Obs::new(1, 1241.97, 374.03, 5.0).unwrap();
        assert!((o.u() - 1241.97).abs() <= 0.5 / PIXEL_STEPS && (o.v() - 374.03).abs() <= 0.5 / PIXEL_STEPS);
        assert!(Obs::new(1, -0.1, 3.0, 1.0).is_none());
        assert!(Obs::new(1, f32::NAN, 3.0, 1.0).is_none());
        assert!(Obs::new(1, 5000.0, 3.0, 1.0).is_none());
    }

    #[test]
    fn assembles_sorted_lists_from_parts() {
        let mut tracks = [track(0, 0, 5.0); 150];
        for (i, t) in tracks.iter_mut().enumerate() {
            *t = track((149 - i) as u32, (i % 3) as u16, 5.0);
        }
        let mut asm = FrameAssembler::new();
        let mut buf = FrameBuffer::new();
        let mut stats = EstimatorStats::default();
        let parts: std::vec::Vec<_> = frame_parts(3, 30, &tracks).unwrap().collect();
        assert_eq!(parts.len(), 3);
        assert_eq!(asm.accept(&parts[2], &mut buf, RANGE, &mut stats), PartOutcome::Pending);
        assert_eq!(asm.accept(&parts[2], &mut buf, RANGE, &mut stats), PartOutcome::Rejected);
        assert_eq!(asm.accept(&parts[0], &mut buf, RANGE, &mut stats), PartOutcome::Pending);
        assert_eq!(asm.accept(&parts[1], &mut buf, RANGE, &mut stats), PartOutcome::Complete);
        assert_eq!(stats.parts_duplicate, 1);
        assert_eq!(buf.statics.len(), 50);
        assert_eq!(buf.objects.len(), 2);
        assert!(buf.statics.windows(2).all(|w| w[0].track_id < w[1].track_id));
        for o in &buf.objects {
            assert!(o.points.windows(2).all(|w| w[0].track_id < w[1].track_id));
        }
        // An old frame's part is stale now.
        assert_eq!(asm.accept(&parts[0], &mut buf, RANGE, &mut stats), PartOutcome::Rejected);
        assert_eq!(stats.parts_stale, 1);
    }

    #[test]
    fn the_frame_is_the_same_whatever_order_its_tracks_arrive_in() {
        // Static tracks (object 0) and two objects, ids interleaved, with
        // a repeated id in each list whose copies differ in depth.
        let mut tracks: std::vec::Vec<Track> =
            (0..60u32).map(|i| track(i * 7 % 61, (i % 3) as u16, 5.0 + (i % 5) as f32)).collect();
        tracks.push(track(7, 1, 9.0));
        tracks.push(track(14, 2, 3.0));
        let assemble = |tracks: &[Track]| {
            let (mut asm, mut buf, mut stats) = (FrameAssembler::new(), FrameBuffer::new(), EstimatorStats::default());
            let part = frame_parts(0, 0, tracks).unwrap().next().unwrap();
            assert_eq!(asm.accept(&part, &mut buf, RANGE, &mut stats), PartOutcome::Complete);
            (buf, stats.tracks_duplicate)
        };
        let (forward, dup) = assemble(&tracks);
        tracks.reverse();
        let (backward, dup_back) = assemble(&tracks);
        assert_eq!((dup, dup_back), (2, 2));
        assert_eq!(forward.statics, backward.statics);
        for o in &forward.objects {
            let b = backward.object(o.object_id).unwrap();
            assert_eq!(o.points, b.points, "object {}", o.object_id);
            assert!(o.points.windows(2).all(|w| w[0].track_id < w[1].track_id), "sorted, unique");
        }
        // The repeated ids keep their smaller depth.
        let depth_of = |object: u16, id: u32| {
            forward.object(object).unwrap().points.iter().find(|p| p.track_id == id).unwrap().depth
        };
        assert_eq!(depth_of(1, 7), 6.0);
        assert_eq!(depth_of(2, 14), 3.0);
    }

    #[test]
    fn bad_tracks_are_skipped_and_counted() {
        let tracks = [
            track(1, 0, 0.0),
            track(2, 0, -3.0),
            track(3, 0, f32::NAN),
            track(4, 0, f32::INFINITY),
            track(5, 0, 60.0),
            track(6, 0, 5.0),
            track(6, 0, 7.0),
            Track { u: f32::NAN, ..track(7, 0, 5.0) },
        ];
        let mut asm = FrameAssembler::new();
        let mut buf = FrameBuffer::new();
        let mut stats = EstimatorStats::default();
        let part = frame_parts(0, 0, &tracks).unwrap().next().unwrap();
        assert_eq!(asm.accept(&part, &mut buf, RANGE, &mut stats), PartOutcome::Complete);
        assert_eq!(stats.tracks_bad_depth, 4);
        assert_eq!(stats.tracks_too_far, 1);
        assert_eq!(stats.tracks_duplicate, 1);
        assert_eq!(stats.tracks_bad_pixel, 1);
        assert_eq!(buf.statics.len(), 1);
        assert_eq!(buf.statics[0].depth, 5.0);
    }

    #[test]
    fn objects_past_capacity_are_dropped_and_a_newer_frame_abandons_the_old() {
        let tracks: std::vec::Vec<Track> = (0..(MAX_OBJECTS as u32 + 2)).map(|i| track(i, i as u16 + 1, 5.0)).collect();
        let mut asm = FrameAssembler::new();
        let mut buf = FrameBuffer::new();
        let mut stats = EstimatorStats::default();
        let part = frame_parts(0, 0, &tracks).unwrap().next().unwrap();
        asm.accept(&part, &mut buf, RANGE, &mut stats);
        assert_eq!(buf.objects.len(), MAX_OBJECTS);
        assert_eq!(stats.object_tracks_dropped, 2);
        assert_eq!(stats.frames_with_objects_dropped, 1);
        let many: std::vec::Vec<Track> = (0..100).map(|i| track(i, 0, 5.0)).collect();
        let first = frame_parts(1, 0, &many).unwrap().next().unwrap();
        assert_eq!(asm.accept(&first, &mut buf, RANGE, &mut stats), PartOutcome::Pending);
        let next = frame_parts(2, 0, &many[..1]).unwrap().next().unwrap();
        assert_eq!(asm.accept(&next, &mut buf, RANGE, &mut stats), PartOutcome::Complete);
        assert_eq!(stats.frames_incomplete, 1);
        assert_eq!(buf.frame, 2);
        assert_eq!(buf.statics.len(), 1);
    }

    #[test]
    fn rounding_matches_libm_near_every_integer_and_half() {
        for k in 0..=65_536u32 {
            for base in [k as f32, k as f32 + 0.5] {
                let mut y = base;
                for _ in 0..16 {
                    y = f32::from_bits(y.to_bits().saturating_sub(1));
                }
                for _ in 0..33 {
                    if y >= 0.0 {
                        assert_eq!(round_non_negative(y).to_bits(), libm::roundf(y).to_bits(), "{y}");
                    }
                    y = f32::from_bits(y.to_bits() + 1);
                }
            }
        }
    }
}
