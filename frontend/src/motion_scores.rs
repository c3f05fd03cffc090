//! The front-end's object masks scored against a rendering's truth, for the motion
//! segmentation: per range band and class, the recall of moving objects (an object is found in a
//! frame when one segment covers at least half its visible pixels), the precision of segments (a
//! segment is false when most of its pixels belong to no moving object), id switches, and the
//! frames from an object's first visible frame to its first detection.

use std::collections::{BTreeMap, BTreeSet};

use dynotraj_core::wire::ObjectClass;

use super::motion::{Fate, Judged};

/// Range bands, metres: an object's band is the median true depth of its visible pixels.
pub const BANDS: [(f32, f32); 4] = [(0.0, 20.0), (20.0, 40.0), (40.0, 80.0), (80.0, f32::INFINITY)];

/// Fewest visible pixels for an object to count in a frame (smaller ones no stereo resolves).
pub const MIN_VISIBLE_PX: usize = 50;

/// Buckets of the probes on an object in a frame ([`MotionScores::coverage`]): the least count
/// of each.
pub const PROBE_BUCKETS: [usize; 5] = [0, 1, 5, 20, 50];

/// The bucket index of `n` probes.
#[must_use]
pub fn probe_bucket(n: usize) -> usize {
    PROBE_BUCKETS.iter().rposition(|&lo| n >= lo).unwrap_or(0)
}

/// Counts of one (band, class) cell.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FoundCount {
    /// Frames x objects visible.
    pub visible: usize,
    /// Of those, found.
    pub found: usize,
    /// Of those, overlapped by a segment at all (found or too little of it covered).
    pub touched: usize,
    /// Of those, covered at least half by the segments on it together: found, or split
    /// between segments none of which covers half.
    pub covered_together: usize,
    /// Of the visible frames, those in which the object stood (nearly) still.
    pub at_rest: usize,
    /// Of those, found.
    pub at_rest_found: usize,
}

/// Segments of one band.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SegmentCount {
    /// Segments in frames.
    pub segments: usize,
    /// Of those, false (most pixels on no moving object).
    pub false_segments: usize,
}

/// One frame's truth and the front-end's segments, row-major images of one size.
#[derive(Debug, Clone, Copy)]
pub struct FrameSegments<'a> {
    /// Frame index.
    pub frame: usize,
    /// Image width, pixels.
    pub width: usize,
    /// True instance id per pixel (0: static scene).
    pub truth_ids: &'a [u16],
    /// True depth per pixel, metres (0: none).
    pub truth_depth: &'a [f32],
    /// The front-end's segment id per pixel (0: none).
    pub segments: &'a [u16],
    /// The moving objects among the truth ids, with their classes.
    pub moving: &'a BTreeMap<u16, ObjectClass>,
    /// Those of them that stand (nearly) still in this frame.
    pub at_rest: &'a BTreeSet<u16>,
}

impl FrameSegments<'_> {
    /// The index of pixel `(x, y)`, when it lies in the image.
    fn index(&self, x: i64, y: i64) -> Option<usize> {
        let height = self.truth_ids.len() / self.width.max(1);
        (x >= 0 && y >= 0 && (x as usize) < self.width && (y as usize) < height)
            .then(|| y as usize * self.width + x as usize)
    }
}

/// An object's history over the frames.
#[derive(Debug, Clone, Copy, Default)]
struct History {
    first_visible: Option<usize>,
    first_found: Option<usize>,
    last_segment: Option<u16>,
    switches: usize,
}

/// Scores summed over frames and sequences.
#[derive(Debug, Clone, Default)]
pub struct MotionScores {
    /// Recall counts per (band index, class).
    pub found: BTreeMap<(usize, ObjectClass), FoundCount>,
    /// Segments per band index (the median true depth of the segment's pixels).
    pub segments: BTreeMap<usize, SegmentCount>,
    /// Changes of the segment id that found an object between the frames it was found in.
    pub id_switches: usize,
    /// Frames from first visible to first found, one entry per object found.
    pub delays: Vec<usize>,
    /// Moving objects visible at some point and never found.
    pub never_found: usize,
    /// Residuals of judged probes (across, along the ray, pixels; in standard deviations) per (band, on a moving
    /// object), where the source of a false or missed detection shows.
    pub residuals: BTreeMap<(usize, bool, bool), Vec<[f32; 3]>>,
    /// Probes on moving objects by band and fate, and the object frames they were on.
    pub fates: BTreeMap<(usize, Fate), usize>,
    /// Object frames (as counted for recall) per (band, [`probe_bucket`] of the probes on
    /// them), and how many of those were found: whether a miss lacked probes or a verdict.
    pub coverage: BTreeMap<(usize, usize), FoundCount>,
    /// Per object of the sequence under way.
    objects: BTreeMap<u16, History>,
    /// The objects of the last frame added, as counted for recall: band and whether found.
    last_frame: BTreeMap<u16, (usize, bool)>,
    /// The objects of the last frame that a segment touched without finding them.
    last_undercovered: BTreeSet<u16>,
    /// Probes on objects a segment touched without finding them (covering too little), by
    /// band and fate: why the segment stopped short.
    pub fates_undercovered: BTreeMap<(usize, Fate), usize>,
}

/// The band index of `depth`.
#[must_use]
pub fn band_of(depth: f32) -> usize {
    BANDS.iter().position(|&(lo, hi)| depth >= lo && depth < hi).unwrap_or(BANDS.len() - 1)
}

fn median(mut v: Vec<f32>) -> Option<f32> {
    v.sort_by(f32::total_cmp);
    v.get(v.len() / 2).copied()
}

impl MotionScores {
    /// Adds one frame.
    pub fn add_frame(&mut self, f: &FrameSegments<'_>) {
        self.last_frame.clear();
        self.last_undercovered.clear();
        // Pixels per (truth id, segment id), and the truth depths per truth id and per segment.
        let mut overlap: BTreeMap<(u16, u16), usize> = BTreeMap::new();
        let mut depth_of_truth: BTreeMap<u16, Vec<f32>> = BTreeMap::new();
        let mut depth_of_segment: BTreeMap<u16, Vec<f32>> = BTreeMap::new();
        for ((&t, &s), &z) in f.truth_ids.iter().zip(f.segments).zip(f.truth_depth) {
            if t == 0 && s == 0 {
                continue;
            }
            *overlap.entry((t, s)).or_default() += 1;
            if t != 0 && f.moving.contains_key(&t) {
                depth_of_truth.entry(t).or_default().push(z);
            }
            if s != 0 {
                depth_of_segment.entry(s).or_default().push(z);
            }
        }
        for (&id, &class) in f.moving {
            // This object's pixels by segment (0: none), in one pass over its part of the map.
            let on_it = || overlap.range((id, 0)..=(id, u16::MAX)).map(|(&(_, s), &n)| (s, n));
            let visible: usize = on_it().map(|(_, n)| n).sum();
            if visible < MIN_VISIBLE_PX {
                continue;
            }
            let Some(z) = depth_of_truth.remove(&id).and_then(median) else { continue };
            let best = on_it().filter(|(s, _)| *s != 0).max_by_key(|(_, n)| *n);
            let together = visible - on_it().find(|(s, _)| *s == 0).map_or(0, |(_, n)| n);
            let found = best.filter(|(_, n)| 2 * n >= visible);
            self.last_frame.insert(id, (band_of(z), found.is_some()));
            if best.is_some() && found.is_none() {
                self.last_undercovered.insert(id);
            }
            let cell = self.found.entry((band_of(z), class)).or_default();
            cell.visible += 1;
            cell.touched += usize::from(best.is_some());
            cell.covered_together += usize::from(2 * together >= visible);
            if f.at_rest.contains(&id) {
                cell.at_rest += 1;
                cell.at_rest_found += usize::from(found.is_some());
            }
            let h = self.objects.entry(id).or_default();
            h.first_visible.get_or_insert(f.frame);
            if let Some((segment, _)) = found {
                cell.found += 1;
                if h.first_found.is_none() {
                    h.first_found = Some(f.frame);
                }
                if h.last_segment.is_some_and(|last| last != segment) {
                    h.switches += 1;
                }
                h.last_segment = Some(segment);
            }
        }
        for (segment, depths) in depth_of_segment {
            let pixels = depths.len();
            let Some(z) = median(depths) else { continue };
            let on_moving: usize =
                overlap.iter().filter(|((t, s), _)| *s == segment && f.moving.contains_key(t)).map(|(_, n)| n).sum();
            let cell = self.segments.entry(band_of(z)).or_default();
            cell.segments += 1;
            if 2 * on_moving < pixels {
                cell.false_segments += 1;
            }
        }
    }

    /// Adds the residuals of one frame's judged probes, each placed by the truth under it: on a
    /// moving object or not, and at a depth edge (the truth within 3 pixels changes id or depth
    /// by more than 5 %) or not.
    pub fn add_residuals(&mut self, judged: &[Judged], f: &FrameSegments<'_>) {
        for j in judged {
            let (x, y) = (j.u.round() as i64, j.v.round() as i64);
            let Some(i) = f.index(x, y) else { continue };
            let (Some(&t), Some(&z)) = (f.truth_ids.get(i), f.truth_depth.get(i)) else { continue };
            let mut edge = false;
            for dy in -3..=3 {
                for dx in -3..=3 {
                    let Some(n) = f.index(x + dx, y + dy) else { continue };
                    let (nt, nz) = (f.truth_ids.get(n).copied(), f.truth_depth.get(n).copied().unwrap_or(0.0));
                    edge |= nt != Some(t) || (nz - z).abs() > 0.05 * z;
                }
            }
            let moving = f.moving.contains_key(&t);
            self.residuals.entry((band_of(j.depth), moving, edge)).or_default().push([
                j.across_px,
                j.along_px,
                j.sigmas,
            ]);
        }
    }

    /// Adds where the probes on moving objects ended, by the band of the object.
    /// Each object of that frame (after [`MotionScores::add_frame`]) is counted by the probes on
    /// it.
    pub fn add_fates(&mut self, fates: &[(f32, f32, Fate)], f: &FrameSegments<'_>) {
        let mut on: BTreeMap<u16, usize> = BTreeMap::new();
        for &(u, v, fate) in fates {
            let Some(at) = f.index(u.round() as i64, v.round() as i64) else { continue };
            let (Some(&t), Some(&z)) = (f.truth_ids.get(at), f.truth_depth.get(at)) else { continue };
            if f.moving.contains_key(&t) {
                *self.fates.entry((band_of(z), fate)).or_default() += 1;
                if self.last_undercovered.contains(&t) {
                    *self.fates_undercovered.entry((band_of(z), fate)).or_default() += 1;
                }
                *on.entry(t).or_default() += 1;
            }
        }
        for (id, &(band, found)) in &self.last_frame {
            let probes = on.get(id).copied().unwrap_or(0);
            let cell = self.coverage.entry((band, probe_bucket(probes))).or_default();
            cell.visible += 1;
            cell.found += usize::from(found);
        }
    }

    /// Ends a sequence: its objects' delays, switches and misses are counted.
    pub fn end_sequence(&mut self) {
        for h in std::mem::take(&mut self.objects).into_values() {
            self.id_switches += h.switches;
            match (h.first_visible, h.first_found) {
                (Some(v), Some(f)) => self.delays.push(f.saturating_sub(v)),
                (Some(_), None) => self.never_found += 1,
                _ => {}
            }
        }
    }

    /// Adds another set of scores (of other sequences).
    pub fn merge(&mut self, other: Self) {
        for (k, c) in other.found {
            let e = self.found.entry(k).or_default();
            e.visible += c.visible;
            e.found += c.found;
            e.touched += c.touched;
            e.covered_together += c.covered_together;
            e.at_rest += c.at_rest;
            e.at_rest_found += c.at_rest_found;
        }
        for (k, c) in other.segments {
            let e = self.segments.entry(k).or_default();
            e.segments += c.segments;
            e.false_segments += c.false_segments;
        }
        self.id_switches += other.id_switches;
        self.delays.extend(other.delays);
        self.never_found += other.never_found;
        for (k, v) in other.fates {
            *self.fates.entry(k).or_default() += v;
        }
        for (k, v) in other.fates_undercovered {
            *self.fates_undercovered.entry(k).or_default() += v;
        }
        for (k, c) in other.coverage {
            let e = self.coverage.entry(k).or_default();
            e.visible += c.visible;
            e.found += c.found;
        }
        for (k, v) in other.residuals {
            self.residuals.entry(k).or_default().extend(v);
        }
    }

    /// Recall over the bands whose upper edge is at most `max_m`, every class.
    #[must_use]
    pub fn recall_within(&self, max_m: f32) -> Option<f64> {
        let (v, f) = self
            .found
            .iter()
            .filter(|((b, _), _)| BANDS.get(*b).is_some_and(|(_, hi)| *hi <= max_m))
            .fold((0, 0), |(v, f), (_, c)| (v + c.visible, f + c.found));
        (v > 0).then(|| f as f64 / v as f64)
    }

    /// Precision of the segments in the bands whose upper edge is at most `max_m`.
    #[must_use]
    pub fn precision_within(&self, max_m: f32) -> Option<f64> {
        let (n, bad) = self
            .segments
            .iter()
            .filter(|(b, _)| BANDS.get(**b).is_some_and(|(_, hi)| *hi <= max_m))
            .fold((0, 0), |(n, bad), (_, c)| (n + c.segments, bad + c.false_segments));
        (n > 0).then(|| 1.0 - bad as f64 / n as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_object_half_covered_is_found_one_split_is_not_and_a_segment_on_the_static_scene_is_false() {
        // Four rows of 100 pixels: object 5 (moving, 10 m) on rows 0-1; static scene on rows 2-3.
        let (w, h) = (100, 4);
        let truth_ids: Vec<u16> = (0..w * h).map(|i| if i < 2 * w { 5 } else { 0 }).collect();
        let truth_depth = vec![10.0; w * h];
        let moving = BTreeMap::from([(5, ObjectClass::Car)]);
        let mut scores = MotionScores::default();
        // Frame 0: nothing found. Frame 1: segment 7 covers row 0 (half the object). Frame 2:
        // segment 8 covers the object, and segment 9 lies on the static scene. Frame 3: segments
        // 10 and 11 cover 60 pixels of each row: the object is split, not found. In frame 0 the
        // object stands still.
        let frames: [Vec<u16>; 4] = [
            vec![0; w * h],
            (0..w * h).map(|i| if i < w { 7 } else { 0 }).collect(),
            (0..w * h)
                .map(|i| {
                    if i < 2 * w {
                        8
                    } else if i >= 3 * w {
                        9
                    } else {
                        0
                    }
                })
                .collect(),
            (0..w * h)
                .map(|i| match (i / w, i % w) {
                    (0, x) if x < 60 => 10,
                    (1, x) if x < 60 => 11,
                    _ => 0,
                })
                .collect(),
        ];
        for (frame, segments) in frames.iter().enumerate() {
            scores.add_frame(&FrameSegments {
                frame,
                width: w,
                truth_ids: &truth_ids,
                truth_depth: &truth_depth,
                segments,
                moving: &moving,
                at_rest: &if frame == 0 { BTreeSet::from([5]) } else { BTreeSet::new() },
            });
        }
        scores.end_sequence();
        assert_eq!(
            scores.found[&(0, ObjectClass::Car)],
            FoundCount { visible: 4, found: 2, touched: 3, covered_together: 3, at_rest: 1, at_rest_found: 0 }
        );
        assert_eq!(scores.segments[&0], SegmentCount { segments: 5, false_segments: 1 });
        assert_eq!((scores.id_switches, scores.delays.clone(), scores.never_found), (1, vec![1], 0));
        assert!((scores.recall_within(20.0).unwrap() - 0.5).abs() < 1e-9);
        assert!((scores.precision_within(40.0).unwrap() - 0.8).abs() < 1e-9);
    }
}
