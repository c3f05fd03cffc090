//! Which true object each of a front-end's objects is.
//!
//! A front-end given box or motion masks names objects its own way (by box overlap, by the
//! probes they share), so its estimates cannot be matched to the simulator's truth by id. Each
//! of its objects is mapped instead to the true box that holds most of its measured points over
//! its whole life, and the truth is then also named after the front-end's objects
//! ([`name_truth_after`]), so every score that matches estimates to truth by id works as it
//! does for rendered ids.

use std::collections::BTreeMap;

use dynotraj_core::estimate::Intrinsics;
use dynotraj_core::geometry::back_project;
use nalgebra::{Point3, Vector3};

use super::{ObjectTruth, SimFrame};

/// A point counts as inside a true box within this margin, metres, plus
/// [`DEPTH_MARGIN_SHARE`] of its depth: stereo depth errors grow with depth (about 2 m at 40 m
/// for half a pixel of disparity noise at KITTI's baseline).
pub const BOX_MARGIN_M: f64 = 0.3;
/// The share of a point's depth added to [`BOX_MARGIN_M`].
pub const DEPTH_MARGIN_SHARE: f64 = 0.05;

/// What [`associate`] found.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Association {
    /// Front-end object id to the true object id holding more than half of its points.
    pub truth_of: BTreeMap<u16, u16>,
    /// Front-end objects whose points no true box holds the majority of (false objects, or
    /// objects that mixed several), with their point counts.
    pub unmatched: BTreeMap<u16, usize>,
    /// Object points seen, and how many of them fell in the box their object was mapped to.
    pub points: usize,
    /// See [`Association::points`].
    pub points_in_mapped_box: usize,
}

/// The true box of `objects` that holds the world point `p` within the margin, the nearest to
/// its centre (in box half-sizes) when several do.
fn box_holding(objects: &[ObjectTruth], p: &Point3<f64>, depth: f64) -> Option<u16> {
    let margin = BOX_MARGIN_M + DEPTH_MARGIN_SHARE * depth;
    let mut best: Option<(f64, u16)> = None;
    for o in objects {
        let [h, w, l] = o.size;
        let local = o.pose.inverse_transform_point(p);
        let half = Vector3::new(l / 2.0 + margin, h / 2.0 + margin, w / 2.0 + margin);
        let reach = (local.x.abs() / half.x).max(local.y.abs() / half.y).max(local.z.abs() / half.z);
        if reach <= 1.0 && best.is_none_or(|(r, _)| reach < r) {
            best = Some((reach, o.object_id));
        }
    }
    best.map(|(_, id)| id)
}

/// Maps each object the front-end sent in `frames` (tracks measured with `intrinsics`) to the
/// true box holding more than half of its points over every frame.
#[must_use]
pub fn associate(frames: &[SimFrame], intrinsics: &Intrinsics) -> Association {
    let focal = [f64::from(intrinsics.fx), f64::from(intrinsics.fy)];
    let centre = [f64::from(intrinsics.cx), f64::from(intrinsics.cy)];
    // Per front-end object: its point count and the votes of the boxes holding them.
    let mut votes: BTreeMap<u16, (usize, BTreeMap<u16, usize>)> = BTreeMap::new();
    for f in frames {
        for t in f.tracks.iter().filter(|t| !t.is_static()) {
            let depth = f64::from(t.depth);
            let entry = votes.entry(t.object_id).or_default();
            entry.0 += 1;
            if !(depth.is_finite() && depth > 0.0) {
                continue;
            }
            let [x, y, z] = back_project([f64::from(t.u), f64::from(t.v)], depth, focal, centre);
            let world = f.camera.transform_point(&Point3::new(x, y, z));
            if let Some(id) = box_holding(&f.objects, &world, depth) {
                *entry.1.entry(id).or_default() += 1;
            }
        }
    }
    let mut out = Association::default();
    for (object, (points, boxes)) in votes {
        out.points += points;
        let top = boxes.into_iter().max_by_key(|&(id, n)| (n, std::cmp::Reverse(id)));
        match top {
            Some((id, n)) if 2 * n > points => {
                out.truth_of.insert(object, id);
                out.points_in_mapped_box += n;
            }
            _ => {
                out.unmatched.insert(object, points);
            }
        }
    }
    out
}

/// Adds to the truth of `frames` a copy of each true object under the id of every front-end
/// object of `association` mapped to it (a true object followed under two ids gets two), so
/// that scores matching estimates to truth by id find it; the true objects keep their own ids
/// too, for the sources that use them (the labels). A front-end id that is also a true id gets
/// no copy: it would stand for two objects.
pub fn name_truth_after(frames: &mut [SimFrame], association: &Association) {
    let true_ids: std::collections::BTreeSet<u16> =
        frames.iter().flat_map(|f| f.objects.iter().map(|o| o.object_id)).collect();
    for f in frames {
        let copies: Vec<ObjectTruth> = association
            .truth_of
            .iter()
            .filter(|(object, _)| !true_ids.contains(object))
            .filter_map(|(&object, &true_id)| {
                f.objects.iter().find(|o| o.object_id == true_id).map(|o| ObjectTruth { object_id: object, ..*o })
            })
            .collect();
        f.objects.extend(copies);
    }
}

#[cfg(test)]
mod tests {
    use dynotraj_core::wire::{ObjectClass, STATIC_OBJECT_ID, Track};
    use nalgebra::{Isometry3, Translation3, UnitQuaternion};

    use super::*;

    const K: Intrinsics = Intrinsics { fx: 700.0, fy: 700.0, cx: 600.0, cy: 180.0, stereo_fb: 380.0 };

    fn truth(id: u16, x: f64, z: f64) -> ObjectTruth {
        ObjectTruth {
            object_id: id,
            class: ObjectClass::Car,
            size: [1.5, 1.6, 4.0],
            pose: Isometry3::from_parts(Translation3::new(x, 0.0, z), UnitQuaternion::identity()),
        }
    }

    /// A track of object `object` seen at camera point (x, y, z).
    fn track(object: u16, [x, y, z]: [f64; 3]) -> Track {
        let u = (K.fx as f64).mul_add(x / z, K.cx as f64) as f32;
        let v = (K.fy as f64).mul_add(y / z, K.cy as f64) as f32;
        Track { track_id: 0, object_id: object, class: ObjectClass::Car, u, v, depth: z as f32 }
    }

    fn frame(tracks: Vec<Track>, objects: Vec<ObjectTruth>) -> SimFrame {
        SimFrame { frame: 0, timestamp_us: 0, tracks, camera: Isometry3::identity(), objects }
    }

    #[test]
    fn each_front_end_object_takes_the_box_holding_most_of_its_points() {
        let objects = vec![truth(3, -2.0, 20.0), truth(7, 3.0, 30.0)];
        let mut tracks = vec![Track { object_id: STATIC_OBJECT_ID, ..track(1, [0.0, 0.0, 50.0]) }];
        // Object 20001: three points on box 3, one on box 7.
        tracks.extend(
            [[-2.0, 0.0, 19.0], [-1.5, 0.3, 20.5], [-2.5, -0.2, 21.0], [3.0, 0.0, 30.0]].map(|p| track(20001, p)),
        );
        // Object 20002: on box 7 beyond the box by less than the margin at its depth.
        tracks.extend([[3.0, 0.0, 32.0], [3.2, 0.1, 29.0]].map(|p| track(20002, p)));
        // Object 20003: in the open.
        tracks.extend([[10.0, 0.0, 10.0], [11.0, 0.0, 10.0]].map(|p| track(20003, p)));
        let mut frames = vec![frame(tracks, objects)];
        let a = associate(&frames, &K);
        assert_eq!(a.truth_of, BTreeMap::from([(20001, 3), (20002, 7)]));
        assert_eq!(a.unmatched, BTreeMap::from([(20003, 2)]));
        assert_eq!((a.points, a.points_in_mapped_box), (8, 5));
        name_truth_after(&mut frames, &a);
        let named: Vec<(u16, f64)> = frames[0].objects.iter().map(|o| (o.object_id, o.pose.translation.x)).collect();
        assert_eq!(named, vec![(3, -2.0), (7, 3.0), (20001, -2.0), (20002, 3.0)]);
        // A front-end id that a true object has already is not given to another.
        let before = frames[0].objects.len();
        name_truth_after(&mut frames, &Association { truth_of: BTreeMap::from([(7, 3)]), ..Association::default() });
        assert_eq!(frames[0].objects.len(), before);
    }

    #[test]
    fn a_half_split_object_and_one_without_depth_are_unmatched() {
        let objects = vec![truth(3, -2.0, 20.0), truth(7, 3.0, 30.0)];
        let mut tracks: Vec<Track> = [[-2.0, 0.0, 20.0], [3.0, 0.0, 30.0]].map(|p| track(9, p)).into();
        tracks.push(Track { depth: f32::NAN, ..track(11, [0.0, 0.0, 10.0]) });
        let a = associate(&[frame(tracks, objects)], &K);
        assert!(a.truth_of.is_empty());
        assert_eq!(a.unmatched, BTreeMap::from([(9, 2), (11, 1)]));
    }
}
