//! Moving probes grouped into objects: linked in 3D, kept when their residual directions
//! agree, boxed and classed by size.

use std::collections::BTreeMap;

use dynotraj_core::estimate::{Intrinsics, PointModel};
use dynotraj_core::wire::ObjectClass;

use super::{Detection, MotionParams, Seen};

/// Groups of `points` (indices into it) linked by distance: across the viewing ray within
/// `link_m`, along it within `link_m` plus both points' stereo depth error at 1 px.
pub(super) fn clusters(points: &[(usize, nalgebra::Point3<f32>)], model: &PointModel, link_m: f32) -> Vec<Vec<usize>> {
    let n = points.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while let Some(&p) = parent.get(i) {
            if p == i {
                break;
            }
            let grand = parent.get(p).copied().unwrap_or(p);
            if let Some(slot) = parent.get_mut(i) {
                *slot = grand;
            }
            i = p;
        }
        i
    }
    for (i, (_, a)) in points.iter().enumerate() {
        for (j, (_, b)) in points.iter().enumerate().skip(i + 1) {
            let across = (a.x - b.x).hypot(a.y - b.y);
            let along = (a.z - b.z).abs();
            let slack = model.depth_error(a.z, 1.0) + model.depth_error(b.z, 1.0);
            if across < link_m && along < link_m + slack {
                let (ri, rj) = (root(&mut parent, i), root(&mut parent, j));
                if ri != rj
                    && let Some(slot) = parent.get_mut(ri)
                {
                    *slot = rj;
                }
            }
        }
    }
    let mut groups: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for i in 0..n {
        let r = root(&mut parent, i);
        groups.entry(r).or_default().push(i);
    }
    groups.into_values().collect()
}

/// The length of the mean of unit `directions` (1: all alike; near 0: spread every way).
pub(super) fn coherence<'a>(directions: impl Iterator<Item = &'a nalgebra::Vector3<f32>>) -> f32 {
    let (sum, n) = directions.fold((nalgebra::Vector3::zeros(), 0usize), |(a, n), d| (a + d, n + 1));
    if n == 0 { 0.0 } else { sum.norm() / n as f32 }
}

/// Whether the residual directions of a cluster's `members` (indices into `directions`) agree
/// by at least `min_coherence`: the probes of one rigid object disagree with the camera's motion
/// alike, noise does not. Three are the fewest whose directions can agree by more than chance.
pub(super) fn coherent(members: &[usize], directions: &[nalgebra::Vector3<f32>], min_coherence: f32) -> bool {
    members.len() >= 3 && coherence(members.iter().filter_map(|&m| directions.get(m))) >= min_coherence
}

/// A pedestrian is narrower than 1.2 m and taller than wide; anything else moving is taken for
/// a vehicle.
pub(super) fn class_of((width_m, height_m): (f32, f32)) -> ObjectClass {
    if width_m < 1.2 && height_m > 0.8 && height_m > 1.2 * width_m { ObjectClass::Pedestrian } else { ObjectClass::Car }
}

/// A cluster's place in the image: its box, its size and its depth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Extent {
    /// `[left, top, right, bottom]`, pixels.
    pub bbox: [f32; 4],
    /// Width and height at the median depth, metres.
    pub size_m: (f32, f32),
    /// The median depth, metres.
    pub depth_m: f32,
}

impl Extent {
    /// The box grown to at least `min_m` (width, height, metres) at its depth, about its
    /// centre across and upward from its bottom: where the moving probes hold only part of an
    /// object (its textured part, or the part with depth), the box still spans what an object
    /// of its class spans at least. Its bottom stays, since below an object lies the road at
    /// the object's own depth, which the mask's depth test would keep.
    pub fn at_least(self, (min_w, min_h): (f32, f32), intrinsics: &Intrinsics) -> [f32; 4] {
        let b = self.bbox;
        let (w, h) = (min_w * intrinsics.fx / self.depth_m, min_h * intrinsics.fy / self.depth_m);
        let (cx, half_w) = (0.5 * (b[0] + b[2]), 0.5 * (b[2] - b[0]).max(w));
        [cx - half_w, b[3] - (b[3] - b[1]).max(h), cx + half_w, b[3]]
    }

    /// What is reported of object `id` of `class` here: its box grown to at least its class's
    /// size ([`MotionParams::min_box_m`]), found this frame or coasting.
    pub fn reported(self, id: u16, class: ObjectClass, p: &MotionParams, intrinsics: &Intrinsics) -> Detection {
        Detection { bbox: self.at_least(p.min_box_m(class), intrinsics), class, object_id: Some(id) }
    }
}

/// The box around the observations `seen` grown by `grow` of its size on each side, the
/// object's width and height at their median depth, metres, and that depth.
pub(super) fn grown_box(seen: impl Iterator<Item = Seen>, grow: f32, intrinsics: &Intrinsics) -> Option<Extent> {
    let mut b = [f32::MAX, f32::MAX, f32::MIN, f32::MIN];
    let mut depths = Vec::new();
    for s in seen {
        b = [b[0].min(s.u), b[1].min(s.v), b[2].max(s.u), b[3].max(s.v)];
        depths.extend(s.depth);
    }
    depths.sort_by(f32::total_cmp);
    let z = *depths.get(depths.len() / 2)?;
    let (w, h) = (b[2] - b[0], b[3] - b[1]);
    let size_m = (w * z / intrinsics.fx, h * z / intrinsics.fy);
    Some(Extent { bbox: [b[0] - grow * w, b[1] - grow * h, b[2] + grow * w, b[3] + grow * h], size_m, depth_m: z })
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynotraj_core::estimate::{EstimatorParams, Intrinsics};

    #[test]
    fn probes_are_clustered_by_distance_across_and_along_the_ray() {
        let params = EstimatorParams::kitti(Intrinsics::KITTI_0926, 0.1);
        let model = PointModel::new(&params);
        let at = |x: f32, z: f32| (0, nalgebra::Point3::new(x, 0.0, z));
        // Two groups 5 m apart across the ray; along it, 1 m apart at 40 m is within the
        // stereo's depth error there and stays one group.
        let points = [at(0.0, 10.0), at(1.0, 10.0), at(6.0, 10.0), at(6.5, 10.2), at(20.0, 40.0), at(20.5, 41.0)];
        let mut groups = clusters(&points, &model, 1.5);
        groups.sort();
        assert_eq!(groups, vec![vec![0, 1], vec![2, 3], vec![4, 5]]);
        assert_eq!(class_of((0.6, 1.7)), ObjectClass::Pedestrian);
        let (x, y) = (nalgebra::Vector3::x(), nalgebra::Vector3::y());
        assert!((coherence([x, x, x].iter()) - 1.0).abs() < 1e-6, "one rigid motion");
        assert!(coherence([x, -x, y, -y].iter()) < 1e-6, "noise every way");
        assert!((coherence([x, y].iter()) - std::f32::consts::FRAC_1_SQRT_2).abs() < 1e-6);
        assert_eq!(class_of((1.8, 1.5)), ObjectClass::Car);
    }

    #[test]
    fn a_box_smaller_than_its_class_grows_across_and_upward_and_a_larger_one_stays() {
        let k = Intrinsics::KITTI_0926;
        let seen = |u: f32, v: f32| Seen { u, v, depth: Some(20.0), around: None };
        let small = grown_box([seen(95.0, 95.0), seen(105.0, 105.0)].into_iter(), 0.0, &k).unwrap();
        assert_eq!(small.depth_m, 20.0);
        let b = small.at_least((2.0, 1.5), &k);
        let (w, h) = (2.0 * k.fx / 20.0, 1.5 * k.fy / 20.0);
        assert!((b[2] - b[0] - w).abs() < 1e-3 && (b[3] - b[1] - h).abs() < 1e-3, "{b:?}");
        assert!(((b[0] + b[2]) / 2.0 - 100.0).abs() < 1e-3 && b[3] == 105.0, "centred across, the bottom kept");
        let wide = grown_box([seen(0.0, 95.0), seen(300.0, 105.0)].into_iter(), 0.0, &k).unwrap();
        let b = wide.at_least((2.0, 1.5), &k);
        assert_eq!((b[0], b[2]), (0.0, 300.0), "wider than a car already");
        assert!((b[3] - b[1] - h).abs() < 1e-3);
    }
}
