//! Object-frame landmarks: every tracked point of an object kept as the running mean of its
//! measured positions in the object's frame, so that motion is fitted frame-to-model rather than
//! frame-to-frame.
//!
//! Why: a single stereo point 30 m away is a metre off along its viewing ray. Fitting the motion
//! from frame k-1's raw points both adds that noise to every motion and, because the noise sits in
//! the source points, shrinks fitted rotations towards zero. A landmark that averaged `n`
//! measurements has `sqrt(n)` less noise, and the fit's source-depth prior is weighted by `n`.
//! (DynoSAM keeps object points as landmarks in its factor graph for the same reason.)
//!
//! Storage: positions in millimetres as `i16` (objects are within 32 m of their own origin), so
//! a landmark takes 12 bytes, the same as a raw observation: the landmarks of 16 objects x 128
//! points replace the previous frame's object tracks at no extra memory.

use heapless::Vec;
use nalgebra::{Point3, Vector3};

use super::frame::Obs;
use super::matching::{Tracked, for_each_match};
use super::measure::Correspondences;
use super::point_model::{Correspondence, PointModel};
use crate::geometry::{NormBound, Pose3};
use crate::limits::MAX_POINTS_PER_OBJECT;

/// Landmark position steps per metre.
const STEPS_PER_M: f32 = 1000.0;
/// Most measurements a landmark averages: beyond it, new ones weigh 1 / this, so a landmark
/// still follows a slowly mis-estimated frame.
pub const MAX_LANDMARK_WEIGHT: u8 = 16;

/// One object point in the object's frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Landmark {
    /// Track id.
    pub track_id: u32,
    /// Position, millimetres.
    p: [i16; 3],
    /// Measurements averaged, `1..=MAX_LANDMARK_WEIGHT`.
    pub weight: u8,
}

impl Tracked for Landmark {
    fn track_id(&self) -> u32 {
        self.track_id
    }
}

impl Landmark {
    /// A landmark at `p` (metres), or `None` when `p` is not finite or out of range.
    #[must_use]
    pub fn new(track_id: u32, p: &Vector3<f32>, weight: u8) -> Option<Self> {
        let q = |x: f32| -> Option<i16> {
            let s = libm::roundf(x * STEPS_PER_M);
            // In range by the check, so the cast neither saturates nor wraps.
            #[allow(clippy::cast_possible_truncation)]
            (s.is_finite() && s >= f32::from(i16::MIN) && s <= f32::from(i16::MAX)).then_some(s as i16)
        };
        Some(Self { track_id, p: [q(p.x)?, q(p.y)?, q(p.z)?], weight: weight.clamp(1, MAX_LANDMARK_WEIGHT) })
    }

    /// Position, metres.
    #[must_use]
    pub fn point(&self) -> Vector3<f32> {
        let [x, y, z] = self.p;
        Vector3::new(f32::from(x), f32::from(y), f32::from(z)) / STEPS_PER_M
    }
}

/// One object's landmarks, sorted by track id.
pub type Landmarks = Vec<Landmark, MAX_POINTS_PER_OBJECT>;

/// Landmarks of the observations `current` of a newly seen object: each back-projected and put
/// in the object's frame by `object_from_camera`.
pub fn initial_landmarks(current: &[Obs], object_from_camera: &Pose3, model: &PointModel, out: &mut Landmarks) {
    out.clear();
    for o in current {
        let p = object_from_camera.transform_point(&model.back_project(o.u(), o.v(), o.depth)).coords;
        if let Some(l) = Landmark::new(o.track_id, &p, 1) {
            // Cannot overflow: `current` is at most the capacity long.
            let _ = out.push(l);
        }
    }
}

/// Correspondences between `landmarks` (the source points, in the object's frame) and the
/// observations `current` of frame k.
pub fn landmark_correspondences(landmarks: &Landmarks, current: &[Obs], out: &mut Correspondences) {
    out.clear();
    for_each_match(landmarks, current, |l, c| {
        let _ = out.push(Correspondence { src: l.point(), u: c.u(), v: c.v(), depth: c.depth });
    });
}

/// Correspondences by position, for when the track ids no longer match (the object was lost
/// for a few frames and the front-end follows new points on it): each observation of `current`,
/// put in the object's frame by the predicted `object_from_camera`, is paired with the nearest
/// landmark within `radius_m`. The pairs are approximate (the nearest landmark, not the same
/// surface point), so the fit they feed must be robust; `O(n m)` for `n` observations and `m`
/// landmarks, done only when ids fail.
pub fn nearest_landmark_correspondences(
    landmarks: &Landmarks,
    current: &[Obs],
    object_from_camera: &Pose3,
    model: &PointModel,
    radius_m: f32,
    out: &mut Correspondences,
) {
    out.clear();
    let limit = radius_m * radius_m;
    for o in current {
        let p = object_from_camera.transform_point(&model.back_project(o.u(), o.v(), o.depth)).coords;
        let nearest = landmarks
            .iter()
            .map(|l| (l.point(), (l.point() - p).norm_squared()))
            .filter(|(_, d)| *d <= limit)
            .min_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((src, _)) = nearest {
            let _ = out.push(Correspondence { src, u: o.u(), v: o.v(), depth: o.depth });
        }
    }
}

/// Fuses the observations `current` of frame k into `landmarks`, the object's pose now known:
/// `object_from_camera` maps camera k into the object's frame. A landmark whose reprojection
/// disagrees with its observation by more than `gate_px` restarts from the observation (a bad
/// landmark or a bad track); tracks not seen at k are dropped (ids do not come back); new
/// tracks become landmarks of weight 1. In place: the list never outgrows `current`.
pub fn fuse(landmarks: &mut Landmarks, current: &[Obs], object_from_camera: &Pose3, model: &PointModel, gate_px: f32) {
    let camera_from_object = object_from_camera.inverse();
    let gate = NormBound::new(gate_px);
    let measured = |o: &Obs| object_from_camera.transform_point(&model.back_project(o.u(), o.v(), o.depth)).coords;
    landmarks.retain_mut(|l| {
        let Some(o) = current.binary_search_by_key(&l.track_id, |o| o.track_id).ok().and_then(|i| current.get(i))
        else {
            return false;
        };
        let c = Correspondence { src: l.point(), u: o.u(), v: o.v(), depth: o.depth };
        let agrees = model.residual(&camera_from_object, &c).is_some_and(|r| gate.admits(r.norm_squared()));
        let m = measured(o);
        let next = if agrees {
            let w = f32::from(l.weight);
            Landmark::new(l.track_id, &((l.point() * w + m) / (w + 1.0)), l.weight.saturating_add(1))
        } else {
            Landmark::new(l.track_id, &m, 1)
        };
        match next {
            Some(n) => {
                *l = n;
                true
            }
            None => false,
        }
    });
    for o in current {
        if let Err(at) = landmarks.binary_search_by_key(&o.track_id, |l| l.track_id)
            && let Some(l) = Landmark::new(o.track_id, &measured(o), 1)
        {
            // Cannot overflow: the list holds only ids of `current`, at most the capacity.
            let _ = landmarks.insert(at, l);
        }
    }
}

/// Turns every landmark by the inverse of the pure rotation `r` (the object's frame became
/// `frame * r`).
pub fn reframe(landmarks: &mut Landmarks, r: &Pose3) {
    let inv = r.inverse();
    for l in landmarks.iter_mut() {
        if let Some(n) = Landmark::new(l.track_id, &inv.transform_point(&Point3::from(l.point())).coords, l.weight) {
            *l = n;
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn landmarks_round_trip_and_reject_out_of_range() {
        let l = Landmark::new(3, &Vector3::new(1.2345, -0.5, 30.0), 40).unwrap();
        assert!((l.point() - Vector3::new(1.2345, -0.5, 30.0)).norm() < 1e-3);
        assert_eq!(l.weight, MAX_LANDMARK_WEIGHT);
        assert!(Landmark::new(3, &Vector3::new(40.0, 0.0, 0.0), 1).is_none());
        assert!(Landmark::new(3, &Vector3::new(f32::NAN, 0.0, 0.0), 1).is_none());
    }
}
