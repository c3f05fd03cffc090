//! Objects followed through the frames they are missed in: a reported object whose cluster
//! is not found is boxed around the probes it last held, for up to
//! [`super::MotionParams::coast_frames`] frames.

use dynotraj_core::estimate::Intrinsics;

use super::cluster::grown_box;
use super::{Detection, FrontEndStats, MotionSegmenter, Seen};

/// Fewest of its probes still followed that a missed object is boxed around: fewer say
/// little of where it is.
const MIN_COASTED_PROBES: usize = 3;

impl MotionSegmenter {
    /// The objects found in at least [`super::MotionParams::coast_after_frames`] frames in a
    /// row but not this frame (not among `seen`), each boxed around the probes it last held,
    /// for up to [`super::MotionParams::coast_frames`] frames; the others are forgotten, with
    /// their probes' ids. A moving object is missed when its probes lose their depth or their
    /// streak, or when it slows: following it on its probes keeps its id and its points
    /// downstream, where each gap ended the object's run.
    pub(super) fn coast(&mut self, seen: &[u16], intrinsics: &Intrinsics, stats: &mut FrontEndStats) -> Vec<Detection> {
        let p = self.params;
        let mut out = Vec::new();
        let probes = &self.probes;
        let mut forgotten = Vec::new();
        self.objects.retain(|id, followed| {
            if seen.contains(id) {
                return true;
            }
            followed.missed += 1;
            let extent = (followed.streak >= p.confirm_frames.max(p.coast_after_frames)
                && followed.missed <= p.coast_frames)
                .then(|| {
                    probes.iter().filter(|q| q.object == Some(*id)).filter_map(|q| q.seen.back().copied()).collect()
                })
                .filter(|held: &Vec<Seen>| held.len() >= MIN_COASTED_PROBES)
                .and_then(|held| grown_box(held.into_iter(), p.grow, intrinsics));
            let Some(extent) = extent else {
                forgotten.push((*id, *followed));
                return false;
            };
            stats.motion_objects += 1;
            stats.motion_objects_coasted += 1;
            out.push(extent.reported(*id, followed.class, &p, intrinsics));
            true
        });
        for (id, followed) in forgotten {
            self.forget(id, followed);
        }
        for q in &mut self.probes {
            if q.object.is_some_and(|id| !self.objects.contains_key(&id)) {
                q.object = None;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use std::collections::VecDeque;

    use dynotraj_core::wire::ObjectClass;

    use super::*;
    use crate::motion::{Extent, Followed, MotionParams, Probe};

    #[test]
    fn a_reported_object_that_is_missed_coasts_on_its_probes_then_is_forgotten() {
        let intrinsics = Intrinsics::KITTI_0926;
        let probe = |u: f32, object: u16| Probe {
            seen: VecDeque::from([Seen { u, v: 200.0, depth: Some(10.0), around: None }]),
            object: Some(object),
            streak: 0,
        };
        // Boxes as the probes give them (no least size), so that the box shows which it used.
        let params = MotionParams {
            coast_frames: 2,
            coast_after_frames: 3,
            min_vehicle_box_m: (0.0, 0.0),
            ..MotionParams::default()
        };
        let mut seg = MotionSegmenter::new(params);
        // Object 1 was found in 3 frames in a row and holds four probes; object 2 was found in
        // 2 (reported, but not long enough to coast); object 3 holds too few probes to be boxed.
        seg.probes = vec![probe(100.0, 1), probe(110.0, 1), probe(120.0, 1), probe(130.0, 1), probe(300.0, 2)];
        seg.probes.extend([probe(400.0, 2), probe(410.0, 2), probe(500.0, 3), probe(510.0, 3)]);
        seg.objects.insert(1, Followed { class: ObjectClass::Car, streak: 3, missed: 0, place: None });
        seg.objects.insert(2, Followed { class: ObjectClass::Car, streak: 2, missed: 0, place: None });
        seg.objects.insert(3, Followed { class: ObjectClass::Car, streak: 5, missed: 0, place: None });
        let mut stats = FrontEndStats::default();
        for frame in 1..=3 {
            let out = seg.coast(&[], &intrinsics, &mut stats);
            if frame <= 2 {
                assert_eq!(out.len(), 1, "frame {frame}: object 1 coasts");
                let d = out.first().unwrap();
                assert_eq!((d.object_id, d.class), (Some(1), ObjectClass::Car));
                // The probes span 100..130 px; the box grows by a fifth of that on each side.
                assert!((d.bbox[0] - 94.0).abs() < 1e-3 && (d.bbox[2] - 136.0).abs() < 1e-3, "{:?}", d.bbox);
            } else {
                assert!(out.is_empty(), "past coast_frames it is forgotten");
            }
            assert!(!seg.objects.contains_key(&2) && !seg.objects.contains_key(&3));
            assert!(
                seg.probes.iter().all(|q| q.object.is_none_or(|id| id == 1)),
                "forgotten objects free their probes"
            );
        }
        assert_eq!((stats.motion_objects_coasted, stats.motion_objects), (2, 2));
        assert!(seg.objects.is_empty() && seg.probes.iter().all(|q| q.object.is_none()));
        // Found again within its coast, an object keeps its streak: it is reported at once.
        seg.objects.insert(4, Followed { class: ObjectClass::Pedestrian, streak: 2, missed: 1, place: None });
        assert!(seg.coast(&[4], &intrinsics, &mut stats).is_empty(), "found objects are not coasted");
        let extent = Extent { bbox: [0.0, 0.0, 10.0, 10.0], size_m: (0.5, 1.7), depth_m: 10.0 };
        let again = seg.follow(4, extent, &intrinsics, &mut stats);
        assert_eq!(again.map(|d| (d.object_id, d.class)), Some((Some(4), ObjectClass::Pedestrian)));
        assert_eq!(seg.objects.get(&4).map(|f| (f.streak, f.missed)), Some((3, 0)));
    }
}
