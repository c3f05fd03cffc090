//! Instance masks: one 16-bit label image per frame (0 = static background, otherwise the wire
//! object id), either read from a mask PNG or made from 2D boxes refined by depth; and
//! consistent ids for boxes that come without them (IoU association with the previous frame).

use dynotraj_core::wire::ObjectClass;
use opencv::core::{CV_16UC1, Mat, Scalar};
use opencv::prelude::*;

use super::depth::DepthMap;
use super::error::{FrontEndError, cv};
#[cfg(test)]
use super::stereo::DisparityMap;

/// One object of a frame's instance image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Instance {
    /// Wire object id (never 0).
    pub object_id: u16,
    /// Class.
    pub class: ObjectClass,
}

/// A frame's instance masks.
#[derive(Debug, Clone)]
pub struct Instances {
    /// `CV_16UC1` label image: the object id per pixel, 0 for the background.
    pub labels: Mat,
    /// The objects present (each id painted on at least one pixel).
    pub objects: Vec<Instance>,
    /// Objects given (boxes or classes) whose mask came out empty.
    pub empty: usize,
}

/// A 2D detection: a box in the left image, its class and, if known, its track id.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Detection {
    /// Left, top, right, bottom, pixels.
    pub bbox: [f32; 4],
    /// Class.
    pub class: ObjectClass,
    /// Wire object id if the source has one (KITTI labels: track id + 1); `None` for raw
    /// detections, which [`IdAssigner`] numbers.
    pub object_id: Option<u16>,
}

/// The instances of a label image read from a mask PNG; `class_of` names each id's class.
///
/// # Errors
/// An OpenCV failure.
pub fn from_label_image(labels: Mat, class_of: impl Fn(u16) -> ObjectClass) -> Result<Instances, FrontEndError> {
    let mut seen = std::collections::BTreeSet::new();
    for v in 0..labels.rows() {
        let row = labels.at_row::<u16>(v).map_err(cv("reading an instance mask"))?;
        seen.extend(row.iter().copied().filter(|&id| id != 0));
    }
    let objects = seen.into_iter().map(|object_id| Instance { object_id, class: class_of(object_id) }).collect();
    Ok(Instances { labels, objects, empty: 0 })
}

/// Depth tolerance of a box's pixels around its median depth: `max(1 m, 15 %)`.
fn depth_tolerance(median: f32) -> f32 {
    (0.15 * median).max(1.0)
}

/// Masks from boxes refined by depth: inside each box, the pixels whose depth lies within
/// [`depth_tolerance`] of the median depth of the box's central half (the object's body; the
/// box's edges hold background). Farther boxes are painted first, so nearer objects occlude.
/// A box with no depth in its centre, or no pixel left, is counted in `empty`.
///
/// # Errors
/// An OpenCV failure.
pub fn from_boxes(
    width: i32,
    height: i32,
    detections: &[(u16, Detection)],
    depth: &DepthMap,
) -> Result<Instances, FrontEndError> {
    let mut labels = Mat::new_rows_cols_with_default(height, width, CV_16UC1, Scalar::all(0.0))
        .map_err(cv("allocating a label image"))?;
    let depth_at = |u: i32, v: i32| depth.at(u as f32, v as f32);
    let clamp_box = |b: &[f32; 4]| {
        let l = (b[0].floor() as i32).clamp(0, width - 1);
        let t = (b[1].floor() as i32).clamp(0, height - 1);
        let r = (b[2].ceil() as i32).clamp(0, width - 1);
        let bo = (b[3].ceil() as i32).clamp(0, height - 1);
        (l, t, r, bo)
    };
    let mut medians = Vec::new();
    let mut empty = 0;
    for (id, d) in detections {
        let (l, t, r, b) = clamp_box(&d.bbox);
        let (qw, qh) = ((r - l) / 4, (b - t) / 4);
        let mut depths: Vec<f32> = Vec::new();
        for v in (t + qh)..=(b - qh) {
            for u in (l + qw)..=(r - qw) {
                depths.extend(depth_at(u, v));
            }
        }
        if depths.is_empty() {
            empty += 1;
            continue;
        }
        let mid = depths.len() / 2;
        let median = *depths.select_nth_unstable_by(mid, f32::total_cmp).1;
        medians.push((median, *id, *d));
    }
    medians.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut objects = Vec::new();
    for (median, id, d) in medians {
        let (l, t, r, b) = clamp_box(&d.bbox);
        let tol = depth_tolerance(median);
        let mut painted = 0usize;
        for v in t..=b {
            for u in l..=r {
                if depth_at(u, v).is_some_and(|z| (z - median).abs() <= tol) {
                    *labels.at_2d_mut::<u16>(v, u).map_err(cv("painting a mask"))? = id;
                    painted += 1;
                }
            }
        }
        if painted == 0 {
            empty += 1;
        } else {
            objects.push(Instance { object_id: id, class: d.class });
        }
    }
    Ok(Instances { labels, objects, empty })
}

/// Intersection over union of two boxes `[l, t, r, b]`.
#[must_use]
pub fn iou(a: &[f32; 4], b: &[f32; 4]) -> f32 {
    let w = (a[2].min(b[2]) - a[0].max(b[0])).max(0.0);
    let h = (a[3].min(b[3]) - a[1].max(b[1])).max(0.0);
    let inter = w * h;
    let area = |x: &[f32; 4]| (x[2] - x[0]).max(0.0) * (x[3] - x[1]).max(0.0);
    let union = area(a) + area(b) - inter;
    if union > 0.0 { inter / union } else { 0.0 }
}

/// Gives detections consistent ids over frames: a detection with an id keeps it; one without is
/// matched greedily (highest IoU first, same class, IoU >= `min_iou`) to the previous frame's
/// boxes, else it gets a fresh id.
#[derive(Debug, Clone)]
pub struct IdAssigner {
    previous: Vec<(u16, Detection)>,
    next_id: u16,
    /// Smallest IoU that continues an object.
    pub min_iou: f32,
}

impl Default for IdAssigner {
    fn default() -> Self {
        // Fresh ids start high so that they never meet ids taken from labels (track id + 1).
        Self { previous: Vec::new(), next_id: 30_000, min_iou: 0.3 }
    }
}

impl IdAssigner {
    /// The ids of this frame's `detections`, in their order.
    pub fn assign(&mut self, detections: &[Detection]) -> Vec<(u16, Detection)> {
        let mut out: Vec<Option<u16>> = detections.iter().map(|d| d.object_id).collect();
        let mut pairs: Vec<(f32, usize, usize)> = Vec::new();
        for (i, d) in detections.iter().enumerate().filter(|(_, d)| d.object_id.is_none()) {
            for (j, (_, p)) in self.previous.iter().enumerate() {
                let s = iou(&d.bbox, &p.bbox);
                if s >= self.min_iou && p.class == d.class {
                    pairs.push((s, i, j));
                }
            }
        }
        pairs.sort_by(|a, b| b.0.total_cmp(&a.0));
        let mut used = vec![false; self.previous.len()];
        for (_, i, j) in pairs {
            if out[i].is_none() && !used[j] {
                out[i] = Some(self.previous[j].0);
                used[j] = true;
            }
        }
        let result: Vec<(u16, Detection)> = detections
            .iter()
            .zip(out)
            .map(|(d, id)| {
                let id = id.unwrap_or_else(|| {
                    self.next_id = self.next_id.checked_add(1).unwrap_or(30_001);
                    self.next_id
                });
                (id, *d)
            })
            .collect();
        self.previous.clone_from(&result);
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn det(l: f32, class: ObjectClass) -> Detection {
        Detection { bbox: [l, 10.0, l + 40.0, 50.0], class, object_id: None }
    }

    #[test]
    fn iou_association_keeps_ids_of_boxes_that_move_a_little() {
        let mut a = IdAssigner::default();
        let f0 = a.assign(&[det(0.0, ObjectClass::Car), det(200.0, ObjectClass::Car)]);
        let f1 = a.assign(&[det(205.0, ObjectClass::Car), det(4.0, ObjectClass::Car), det(400.0, ObjectClass::Car)]);
        assert_eq!(f1[0].0, f0[1].0);
        assert_eq!(f1[1].0, f0[0].0);
        assert!(f1[2].0 != f0[0].0 && f1[2].0 != f0[1].0);
        // A class change or a jump is a new object.
        let f2 = a.assign(&[det(205.0, ObjectClass::Cyclist), det(100.0, ObjectClass::Car)]);
        assert!(f2.iter().all(|(id, _)| f1.iter().all(|(p, _)| p != id)));
    }

    #[test]
    fn boxes_refined_by_depth_keep_the_object_and_drop_the_background() {
        // Disparity 40 px (object) in a 20x20 square inside a 40x40 box, 10 px elsewhere.
        let mut disp = Mat::new_rows_cols_with_default(100, 100, opencv::core::CV_32F, Scalar::all(10.0)).unwrap();
        for v in 30..50 {
            for u in 30..50 {
                *disp.at_2d_mut::<f32>(v, u).unwrap() = 40.0;
            }
        }
        let map = DepthMap::Stereo { disparity: DisparityMap { disparity: disp, downscale: 1 }, fb: 400.0, pair: None };
        let d = Detection { bbox: [20.0, 20.0, 59.0, 59.0], class: ObjectClass::Car, object_id: Some(3) };
        let inst = from_boxes(100, 100, &[(3, d)], &map).unwrap();
        assert_eq!(inst.objects.len(), 1);
        let count = (0..100)
            .flat_map(|v| (0..100).map(move |u| (u, v)))
            .filter(|&(u, v)| *inst.labels.at_2d::<u16>(v, u).unwrap() == 3)
            .count();
        assert_eq!(count, 400);
        // A box over a region without disparity is counted as empty, not a crash.
        let nothing =
            DepthMap::Given(Mat::new_rows_cols_with_default(100, 100, opencv::core::CV_32F, Scalar::all(0.0)).unwrap());
        let inst = from_boxes(100, 100, &[(3, d)], &nothing).unwrap();
        assert_eq!((inst.objects.len(), inst.empty), (0, 1));
    }
}
