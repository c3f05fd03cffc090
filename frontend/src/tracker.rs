//! The tracking stage: static corners and dense object points followed by KLT from frame to
//! frame, topped up to their target counts, and emitted as wire tracks within the core's
//! capacities.
//!
//! Per frame:
//! 1. every point of frame k-1 (static and object) is tracked in one forward-backward KLT pass;
//!    a static point survives when it lands on background at least `static_margin_px` from
//!    every object, an object point when it lands on its own object's mask;
//! 2. static corners are re-detected ([`super::features::detect`]) on that background to hold
//!    `static_target`;
//! 3. each object is topped up to `points_per_object` with textured pixels of its mask sampled
//!    on a grid (dense: the grid step follows the mask's area), so points cover the whole body;
//! 4. tracks get their depth, refined to sub-pixel at the point over the patch pixels of its own
//!    instance ([`super::subpixel`]; points without depth are kept for the next frame but not sent),
//!    and are emitted static first (oldest first), then objects nearest first, within
//!    [`MAX_STATIC_TRACKS`], [`MAX_OBJECTS`] and [`MAX_POINTS_PER_OBJECT`]; the excess is
//!    dropped and counted.

use std::collections::BTreeMap;

use dynotraj_core::limits::{MAX_OBJECTS, MAX_POINTS_PER_OBJECT, MAX_STATIC_TRACKS};
use dynotraj_core::wire::{ObjectClass, STATIC_OBJECT_ID, Track};
use opencv::core::{BORDER_CONSTANT, CMP_EQ, Mat, Point, Point2f, Scalar, Size, compare};
use opencv::imgproc::{MORPH_RECT, erode, get_structuring_element, morphology_default_border_value};
use opencv::prelude::*;

use super::depth::DepthMap;
use super::depth::PointDepthOutcome;
use super::error::{FrontEndError, cv};
use super::features::{DetectParams, detect};
use super::klt::{KltParams, Pyramid, Tracked, track};
use super::masks::Instances;
use super::stats::FrontEndStats;
use super::subpixel::SubpixelParams;

/// Parameters of the tracking stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackerParams {
    /// KLT.
    pub klt: KltParams,
    /// Static corner detection.
    pub detect: DetectParams,
    /// Static features followed (more than the wire's 256, since some have no depth).
    pub static_target: usize,
    /// Points followed per object.
    pub points_per_object: usize,
    /// Nearest depth sent, metres.
    pub min_depth: f32,
    /// Farthest depth sent, metres (stereo depth beyond it is too noisy to help).
    pub max_depth: f32,
    /// Smallest central-difference gradient (|dI/du| + |dI/dv|, grey levels) of a sampled object
    /// pixel: KLT cannot follow flat regions.
    pub min_gradient: i32,
    /// Least distance of a static point from any object's mask, pixels. Block-matching stereo
    /// smears a near object's disparity over the background beside it, so a background corner
    /// next to a car carries the car's depth and moves with it: measured on rendered KITTI 0004,
    /// where such points were every static match of the first 20 frames (20-30 px off the true
    /// ego-motion, camera RPE_t 0.2 m).
    pub static_margin_px: i32,
    /// Least distance of a newly sampled object point from its mask's edge, pixels. 0 by
    /// default: with sub-pixel depth over the point's own instance, a margin cost more runs
    /// (fewer points on small objects) than it gained (docs/decisions.md).
    pub object_edge_margin_px: i32,
    /// Sub-pixel refinement of each sent point's disparity (`None`: the dense map's value).
    pub subpixel: Option<SubpixelParams>,
}

impl Default for TrackerParams {
    fn default() -> Self {
        Self {
            klt: KltParams::default(),
            detect: DetectParams::default(),
            static_target: 320,
            points_per_object: MAX_POINTS_PER_OBJECT,
            min_depth: 0.5,
            max_depth: 80.0,
            min_gradient: 12,
            static_margin_px: 6,
            object_edge_margin_px: 0,
            subpixel: Some(SubpixelParams::default()),
        }
    }
}

/// A followed point.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Feature {
    id: u32,
    at: Point2f,
    /// Frames it has been followed.
    age: u32,
}

/// One frame's points: frame k followed from frame k-1 and topped up, before its depth is read
/// ([`Tracker::follow`]); kept as frame k-1 for the next frame once emitted.
#[derive(Debug)]
pub struct FramePoints {
    pyramid: Pyramid,
    statics: Vec<Feature>,
    objects: BTreeMap<u16, Vec<Feature>>,
}

/// The tracking stage's state.
#[derive(Debug)]
pub struct Tracker {
    params: TrackerParams,
    previous: Option<FramePoints>,
    next_id: u32,
    /// Counters since the start.
    pub stats: FrontEndStats,
}

/// Per object: pixel count and bounding box (l, t, r, b) in one pass over the label image.
fn mask_extents(labels: &Mat) -> Result<BTreeMap<u16, (usize, [i32; 4])>, FrontEndError> {
    let mut out: BTreeMap<u16, (usize, [i32; 4])> = BTreeMap::new();
    for v in 0..labels.rows() {
        let row = labels.at_row::<u16>(v).map_err(cv("reading the label image"))?;
        for (u, &id) in row.iter().enumerate() {
            if id == 0 {
                continue;
            }
            let u = u as i32;
            let e = out.entry(id).or_insert((0, [u, v, u, v]));
            e.0 += 1;
            e.1 = [e.1[0].min(u), e.1[1].min(v), e.1[2].max(u), e.1[3].max(v)];
        }
    }
    Ok(out)
}

/// The background (labels 0) at least `margin` pixels from every object's mask, as an 8-bit mask.
fn background_clear_of_objects(labels: &Mat, margin: i32) -> Result<Mat, FrontEndError> {
    let mut background = Mat::default();
    compare(labels, &Scalar::all(0.0), &mut background, CMP_EQ).map_err(cv("background mask"))?;
    if margin <= 0 {
        return Ok(background);
    }
    let side = 2 * margin + 1;
    let kernel =
        get_structuring_element(MORPH_RECT, Size::new(side, side), Point::new(-1, -1)).map_err(cv("margin kernel"))?;
    let mut clear = Mat::default();
    let border = morphology_default_border_value().map_err(cv("margin border"))?;
    erode(&background, &mut clear, &kernel, Point::new(-1, -1), 1, BORDER_CONSTANT, border)
        .map_err(cv("background margin"))?;
    Ok(clear)
}

fn label_at(labels: &Mat, p: &Point2f) -> Option<u16> {
    labels.at_2d::<u16>(p.y.round() as i32, p.x.round() as i32).ok().copied()
}

impl Tracker {
    /// A tracker with `params`.
    #[must_use]
    pub fn new(params: TrackerParams) -> Self {
        Self { params, previous: None, next_id: 0, stats: FrontEndStats::default() }
    }

    fn fresh_id(&mut self) -> u32 {
        self.next_id = self.next_id.wrapping_add(1);
        self.next_id
    }

    /// Tracks into the frame `grey` with its depth and instances; returns the tracks to send.
    ///
    /// # Errors
    /// An OpenCV failure.
    pub fn process(&mut self, grey: &Mat, depth: &DepthMap, inst: &Instances) -> Result<Vec<Track>, FrontEndError> {
        let points = self.follow(grey, inst)?;
        Ok(self.finish(points, depth, inst))
    }

    /// What needs no depth: frame k-1's points followed into `grey` (KLT), static corners and
    /// object points topped up within `inst`'s masks. [`Tracker::finish`] reads their depth; the
    /// dense matcher can run meanwhile.
    ///
    /// # Errors
    /// An OpenCV failure.
    pub fn follow(&mut self, grey: &Mat, inst: &Instances) -> Result<FramePoints, FrontEndError> {
        let p = self.params;
        self.stats.frames += 1;
        self.stats.empty_masks += inst.empty as u64;
        let pyramid = Pyramid::new(grey, &p.klt)?;
        let labels = &inst.labels;
        let background = background_clear_of_objects(labels, p.static_margin_px)?;
        let on_background =
            |q: &Point2f| background.at_2d::<u8>(q.y.round() as i32, q.x.round() as i32).is_ok_and(|&b| b != 0);

        // 1. One KLT pass over every point of frame k-1.
        let (mut statics, mut objects) = (Vec::new(), BTreeMap::<u16, Vec<Feature>>::new());
        if let Some(prev) = self.previous.take() {
            let all: Vec<(u16, Feature)> = prev
                .statics
                .iter()
                .map(|f| (STATIC_OBJECT_ID, *f))
                .chain(prev.objects.iter().flat_map(|(id, fs)| fs.iter().map(move |f| (*id, *f))))
                .collect();
            let pts: Vec<Point2f> = all.iter().map(|(_, f)| f.at).collect();
            let result = track(&prev.pyramid, &pyramid, &pts, &p.klt)?;
            for ((owner, f), r) in all.iter().zip(result) {
                let is_static = *owner == STATIC_OBJECT_ID;
                let outcome = match r {
                    Tracked::At(q) if is_static && on_background(&q) => Some(q),
                    Tracked::At(q) if !is_static && label_at(labels, &q) == Some(*owner) => Some(q),
                    Tracked::At(_) | Tracked::Lost => None,
                    Tracked::FailedCheck => {
                        self.stats.count_failed_check(is_static);
                        continue;
                    }
                };
                match outcome {
                    Some(q) => {
                        let moved = Feature { id: f.id, at: q, age: f.age + 1 };
                        if is_static {
                            self.stats.static_tracked += 1;
                            statics.push(moved);
                        } else {
                            self.stats.object_points_tracked += 1;
                            objects.entry(*owner).or_default().push(moved);
                        }
                    }
                    None => self.stats.count_lost(is_static),
                }
            }
        }

        // 2. Static corners on the background, up to the target.
        let existing: Vec<Point2f> = statics.iter().map(|f| f.at).collect();
        let want = p.static_target.saturating_sub(statics.len());
        let found = detect(grey, &background, &existing, want, &p.detect)?;
        self.stats.textureless_cells += found.empty_cells as u64;
        self.stats.static_detected += found.points.len() as u64;
        for q in found.points {
            let id = self.fresh_id();
            statics.push(Feature { id, at: q, age: 0 });
        }

        // 3. Objects topped up with dense textured points.
        let extents = mask_extents(labels)?;
        let image = grey.data_bytes().map_err(cv("reading the grey image"))?;
        let width = grey.cols();
        for o in &inst.objects {
            let Some(&(area, bbox)) = extents.get(&o.object_id) else { continue };
            let have = objects.entry(o.object_id).or_default();
            let need = p.points_per_object.saturating_sub(have.len());
            if need == 0 {
                continue;
            }
            let step = ((area as f64 / (2.0 * need as f64)).sqrt().floor() as i32).max(2);
            let occupied = |u: i32, v: i32, have: &[Feature]| {
                have.iter().any(|f| (f.at.x - u as f32).abs() < step as f32 && (f.at.y - v as f32).abs() < step as f32)
            };
            let mut candidates: Vec<(i32, i32, i32)> = Vec::new();
            let mut v = bbox[1].max(1);
            while v <= bbox[3].min(grey.rows() - 2) {
                let mut u = bbox[0].max(1);
                while u <= bbox[2].min(width - 2) {
                    let m = p.object_edge_margin_px;
                    let inside = [(0, 0), (-m, 0), (m, 0), (0, -m), (0, m)].iter().all(|(du, dv)| {
                        label_at(labels, &Point2f::new((u + du) as f32, (v + dv) as f32)) == Some(o.object_id)
                    });
                    if inside {
                        let at = |x: i32, y: i32| i32::from(image[(y * width + x) as usize]);
                        let g = (at(u + 1, v) - at(u - 1, v)).abs() + (at(u, v + 1) - at(u, v - 1)).abs();
                        if g >= p.min_gradient && !occupied(u, v, have) {
                            candidates.push((g, u, v));
                        }
                    }
                    u += step;
                }
                v += step;
            }
            if candidates.is_empty() && have.is_empty() {
                self.stats.textureless_objects += 1;
            }
            candidates.sort_by_key(|c| std::cmp::Reverse(c.0));
            for &(_, u, v) in candidates.iter().take(need) {
                self.next_id = self.next_id.wrapping_add(1);
                have.push(Feature { id: self.next_id, at: Point2f::new(u as f32, v as f32), age: 0 });
                self.stats.object_points_sampled += 1;
            }
        }
        // Objects no longer in the instance image are forgotten.
        objects.retain(|id, _| inst.objects.iter().any(|o| o.object_id == *id));
        Ok(FramePoints { pyramid, statics, objects })
    }

    /// Emits `points` ([`Tracker::follow`] of this frame) with their depth, within the
    /// capacities, and keeps them for the next frame.
    pub fn finish(&mut self, mut points: FramePoints, depth: &DepthMap, inst: &Instances) -> Vec<Track> {
        let out = self.emit(&mut points.statics, &points.objects, depth, inst);
        self.previous = Some(points);
        out
    }

    /// The newest frame's static points `(track id, u, v)`, sent or not.
    #[must_use]
    pub fn static_points(&self) -> Vec<(u32, f32, f32)> {
        self.previous.as_ref().map_or_else(Vec::new, |p| p.statics.iter().map(|f| (f.id, f.at.x, f.at.y)).collect())
    }

    fn emit(
        &mut self,
        statics: &mut [Feature],
        objects: &BTreeMap<u16, Vec<Feature>>,
        depth: &DepthMap,
        inst: &Instances,
    ) -> Vec<Track> {
        let p = self.params;
        let labels = &inst.labels;
        // Refined, kept dense, refused: added to the counters once the closure is done.
        let mut subpixel = [0u64; 3];
        let mut depth_of = |f: &Feature, owner: u16| {
            let same = |x: i64, y: i64| {
                let (Ok(x), Ok(y)) = (i32::try_from(x), i32::try_from(y)) else { return false };
                labels.at_2d::<u16>(y, x).ok().copied() == Some(owner)
            };
            let (z, outcome) = depth.at_point(f.at.x, f.at.y, same, p.subpixel.as_ref());
            match outcome {
                PointDepthOutcome::Dense => {}
                PointDepthOutcome::Refined => subpixel[0] += 1,
                PointDepthOutcome::KeptDense => subpixel[1] += 1,
                PointDepthOutcome::Refused => subpixel[2] += 1,
            }
            z.filter(|z| (p.min_depth..=p.max_depth).contains(z))
        };
        let mut out = Vec::new();
        statics.sort_by(|a, b| b.age.cmp(&a.age).then(a.id.cmp(&b.id)));
        let mut sent = 0;
        for f in statics.iter() {
            let Some(z) = depth_of(f, STATIC_OBJECT_ID) else {
                self.stats.static_no_depth += 1;
                continue;
            };
            if sent >= MAX_STATIC_TRACKS {
                self.stats.static_dropped += 1;
                continue;
            }
            sent += 1;
            out.push(Track {
                track_id: f.id,
                object_id: STATIC_OBJECT_ID,
                class: ObjectClass::Background,
                u: f.at.x,
                v: f.at.y,
                depth: z,
            });
        }
        let mut per_object: Vec<(f32, Vec<Track>)> = Vec::new();
        for (id, fs) in objects {
            let class = inst.objects.iter().find(|o| o.object_id == *id).map_or(ObjectClass::Misc, |o| o.class);
            let mut tracks: Vec<Track> = Vec::new();
            for f in fs {
                match depth_of(f, *id) {
                    Some(z) => {
                        tracks.push(Track { track_id: f.id, object_id: *id, class, u: f.at.x, v: f.at.y, depth: z })
                    }
                    None => self.stats.object_points_no_depth += 1,
                }
            }
            if tracks.len() > MAX_POINTS_PER_OBJECT {
                self.stats.object_points_dropped += (tracks.len() - MAX_POINTS_PER_OBJECT) as u64;
                tracks.truncate(MAX_POINTS_PER_OBJECT);
            }
            if tracks.is_empty() {
                continue;
            }
            let mut zs: Vec<f32> = tracks.iter().map(|t| t.depth).collect();
            let mid = zs.len() / 2;
            let median = *zs.select_nth_unstable_by(mid, f32::total_cmp).1;
            per_object.push((median, tracks));
        }
        per_object.sort_by(|a, b| a.0.total_cmp(&b.0));
        for (i, (_, tracks)) in per_object.into_iter().enumerate() {
            if i >= MAX_OBJECTS {
                self.stats.objects_dropped += 1;
                self.stats.object_points_dropped += tracks.len() as u64;
                continue;
            }
            out.extend(tracks);
        }
        self.stats.subpixel_refined += subpixel[0];
        self.stats.subpixel_kept_dense += subpixel[1];
        self.stats.subpixel_refused += subpixel[2];
        out
    }
}
