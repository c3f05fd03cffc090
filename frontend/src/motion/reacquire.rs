//! Objects found again after they were forgotten: a forgotten object's place is carried on by
//! the camera's motion and its own for up to [`super::MotionParams::reacquire_frames`] frames,
//! and a new cluster near where it would be takes its id back instead of a fresh one. Downstream
//! an object that keeps its id across a short gap keeps its run.

use dynotraj_core::geometry::Pose3;
use nalgebra::{Point3, Vector3};

use super::{Followed, MotionSegmenter};

/// How far a new cluster's centre may lie from where a forgotten object would be, across the
/// viewing ray, metres; along it this plus [`GATE_DEPTH_SHARE`] of the depth, where stereo
/// depth is poorer.
const GATE_M: f32 = 2.0;
/// The share of the depth added to [`GATE_M`] along the ray.
const GATE_DEPTH_SHARE: f32 = 0.1;

/// Where an object is, in the current camera's frame, and how it moved over the last frame
/// apart from the camera's motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Place {
    /// The centre of its probes, metres.
    pub centre: Point3<f32>,
    /// Its own motion over the last frame, metres.
    pub step: Vector3<f32>,
}

impl Place {
    /// A place first seen at `centre`, not yet known to move.
    pub fn at(centre: Point3<f32>) -> Self {
        Self { centre, step: Vector3::zeros() }
    }

    /// Carried into the next frame by the camera's motion `t` (`T_{k, k-1}`) and its own last step.
    pub fn advance(&mut self, t: &Pose3) {
        self.step = t.rotation * self.step;
        self.centre = t * self.centre + self.step;
    }

    /// Seen at `centre` after [`Place::advance`]: its step is what it moved apart from the camera.
    pub fn seen_at(&mut self, centre: Point3<f32>) {
        let carried = self.centre - self.step;
        self.step = centre - carried;
        self.centre = centre;
    }

    /// Whether `centre` lies within the gate around this place.
    fn holds(&self, centre: &Point3<f32>) -> bool {
        let d = centre - self.centre;
        d.x.hypot(d.y) < GATE_M && d.z.abs() < GATE_M + GATE_DEPTH_SHARE * self.centre.z.abs()
    }
}

/// A forgotten object waiting to be found again.
#[derive(Debug, Clone, Copy)]
pub(super) struct Lost {
    /// Its id.
    pub id: u16,
    /// What the segmenter knew of it.
    pub followed: Followed,
    /// Frames since it was forgotten.
    pub frames: u32,
}

impl MotionSegmenter {
    /// Carries every followed and forgotten object's place into this frame by the camera's
    /// motion `t`, and drops the forgotten objects that waited too long.
    pub(super) fn advance_places(&mut self, t: &Pose3) {
        for followed in self.objects.values_mut() {
            if let Some(place) = &mut followed.place {
                place.advance(t);
            }
        }
        let wait = self.params.reacquire_frames;
        self.lost.retain_mut(|lost| {
            lost.frames += 1;
            if let Some(place) = &mut lost.followed.place {
                place.advance(t);
            }
            lost.frames <= wait
        });
    }

    /// The id of the forgotten object nearest where a new cluster with `centre` lies, within
    /// the gate, which is followed again. It starts its streak afresh, so that it is reported
    /// and coasted as a new object would be: only its id differs.
    pub(super) fn reacquire(&mut self, centre: &Point3<f32>) -> Option<u16> {
        let (at, _) = self
            .lost
            .iter()
            .enumerate()
            .filter_map(|(i, l)| l.followed.place.filter(|p| p.holds(centre)).map(|p| (i, (p.centre - centre).norm())))
            .min_by(|a, b| a.1.total_cmp(&b.1))?;
        let lost = self.lost.remove(at);
        self.objects.insert(lost.id, Followed { streak: 0, missed: 0, ..lost.followed });
        Some(lost.id)
    }

    /// Notes that object `id` was found with its probes' centre at `centre`.
    pub(super) fn place_found(&mut self, id: u16, centre: Point3<f32>) {
        if let Some(followed) = self.objects.get_mut(&id) {
            match &mut followed.place {
                Some(place) => place.seen_at(centre),
                None => followed.place = Some(Place::at(centre)),
            }
        }
    }

    /// Keeps a forgotten object that was reported, so that it can be found again.
    pub(super) fn forget(&mut self, id: u16, followed: Followed) {
        if self.params.reacquire_frames > 0 && followed.streak >= self.params.confirm_frames && followed.place.is_some()
        {
            self.lost.push(Lost { id, followed, frames: 0 });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynotraj_core::wire::ObjectClass;

    use crate::motion::MotionParams;

    #[test]
    fn a_forgotten_object_is_carried_on_and_a_cluster_where_it_would_be_takes_its_id() {
        let mut seg = MotionSegmenter::new(MotionParams { reacquire_frames: 3, ..MotionParams::default() });
        // Object 7 was at 20 m ahead, moving 1 m a frame to the right, when it was forgotten.
        let place = Place { centre: Point3::new(0.0, 0.0, 20.0), step: Vector3::new(1.0, 0.0, 0.0) };
        let followed = Followed { class: ObjectClass::Car, streak: 10, missed: 5, place: Some(place) };
        seg.forget(7, followed);
        // The camera drives 1 m forward a frame: the scene comes 1 m nearer.
        let t = Pose3::translation(0.0, 0.0, -1.0);
        seg.advance_places(&t);
        seg.advance_places(&t);
        // Two frames on it would be at x 2, z 18: a cluster far from there takes no id.
        assert_eq!(seg.reacquire(&Point3::new(-3.0, 0.0, 18.0)), None);
        assert_eq!(seg.reacquire(&Point3::new(2.3, 0.1, 18.5)), Some(7));
        assert_eq!(seg.objects.get(&7).map(|f| (f.streak, f.missed)), Some((0, 0)));
        assert!(seg.lost.is_empty());
        // Seen again, its step is what it moved apart from the camera.
        seg.advance_places(&t);
        seg.place_found(7, Point3::new(3.3, 0.0, 17.5));
        let step = seg.objects.get(&7).and_then(|f| f.place).map(|p| p.step).unwrap();
        assert!((step - Vector3::new(1.3, 0.0, 0.5)).norm() < 1e-4, "{step:?}");
        // Past reacquire_frames a forgotten object is dropped; one never reported is not kept.
        seg.forget(8, followed);
        seg.forget(9, Followed { streak: 1, ..followed });
        for _ in 0..4 {
            seg.advance_places(&t);
        }
        assert!(seg.lost.is_empty());
    }
}
