//! A probe's residual against the camera's motion, in standard deviations of the stereo point
//! model.

use dynotraj_core::estimate::{Correspondence, PointModel};
use dynotraj_core::geometry::Pose3;

use super::{MotionParams, Probe, Seen};

/// [`normalised_residual`] under the depths a probe may have had, the least of them: its own,
/// and with [`MotionParams::depth_hypotheses_px`] the nearest and farthest around it, then and
/// now. Near a depth edge the stereo gives a corner either surface's depth; a static corner is
/// explained by one of them, a moving one by none.
pub(super) fn least_residual(
    model: &PointModel,
    pose: &Pose3,
    (then, now): (&Seen, &Seen),
    fb: f32,
    p: &MotionParams,
) -> Option<(nalgebra::Vector3<f32>, f32)> {
    let candidates = |s: &Seen| -> [Option<f32>; 3] {
        let (lo, hi) = s.around.map_or((None, None), |(lo, hi)| (Some(lo), Some(hi)));
        [s.depth, lo, hi]
    };
    let mut best: Option<(nalgebra::Vector3<f32>, f32)> = None;
    for z_then in candidates(then).into_iter().flatten() {
        for z_now in candidates(now).into_iter().flatten() {
            let t = Seen { depth: Some(z_then), ..*then };
            let n = Seen { depth: Some(z_now), ..*now };
            if let Some((r, m2)) = normalised_residual(model, pose, (&t, &n), fb, p)
                && best.is_none_or(|(_, b)| m2 < b)
            {
                best = Some((r, m2));
            }
        }
    }
    best
}

/// The residual of a probe seen at `then` and at `now` under the camera motion `pose` between
/// them, and its squared Mahalanobis distance: both observations have pixel noise
/// `pixel_sigma` and disparity noise `disparity_sigma` (with stereo `fb`), the older one's
/// carried through the motion by finite differences. Along the epipolar line a wrong depth then
/// moves the prediction as far as the stereo allows, across it only as far as the pixels do.
/// Without a depth now, the image part alone (its disparity part 0).
pub(super) fn normalised_residual(
    model: &PointModel,
    pose: &Pose3,
    (then, now): (&Seen, &Seen),
    fb: f32,
    p: &MotionParams,
) -> Option<(nalgebra::Vector3<f32>, f32)> {
    let z_then = then.depth?;
    // The image part of the residual does not depend on the depth now.
    let z_now = now.depth.unwrap_or(z_then);
    let residual_of = |u: f32, v: f32, z: f32| {
        let src = model.back_project(u, v, z).coords;
        model.residual(pose, &Correspondence { src, u: now.u, v: now.v, depth: z_now })
    };
    let r = residual_of(then.u, then.v, z_then)?;
    let h = 0.5;
    let du = (residual_of(then.u + h, then.v, z_then)? - r) / h;
    let dv = (residual_of(then.u, then.v + h, z_then)? - r) / h;
    let (sp, sd) = (p.pixel_sigma, p.disparity_sigma);
    let mut cov = nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::new(sp * sp, sp * sp, 0.0));
    cov += du * du.transpose() * (sp * sp) + dv * dv.transpose() * (sp * sp);
    if fb > 0.0 {
        let d_then = fb / z_then;
        let z_moved = fb / (d_then - h).max(0.05);
        let dd = (residual_of(then.u, then.v, z_moved)? - r) / h;
        cov += dd * dd.transpose() * (sd * sd);
        // The disparity residual is scaled by pixel_sigma / disparity_sigma in the point model.
        cov[(2, 2)] += sp * sp;
    }
    let (r, m2) = if now.depth.is_some() {
        (r, (r.transpose() * cov.try_inverse()? * r).x)
    } else {
        let image = r.xy();
        let m2 = (image.transpose() * cov.fixed_view::<2, 2>(0, 0).into_owned().try_inverse()? * image).x;
        (nalgebra::Vector3::new(r.x, r.y, 0.0), m2)
    };
    m2.is_finite().then_some((r, m2))
}

/// The correspondence of a probe between `back` frames ago (its point there) and now (its pixel
/// and depth), when it has both depths.
pub(super) fn step(q: &Probe, back: usize, model: &PointModel) -> Option<Correspondence> {
    let now = q.seen.back()?;
    let then = q.seen.get(q.seen.len().checked_sub(1 + back)?)?;
    let (z_then, z_now) = (then.depth?, now.depth?);
    let src = model.back_project(then.u, then.v, z_then).coords;
    Some(Correspondence { src, u: now.u, v: now.v, depth: z_now })
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynotraj_core::estimate::{EstimatorParams, Intrinsics};

    #[test]
    fn a_static_corner_given_the_far_surface_s_depth_is_explained_by_the_near_one_around_it() {
        let model = PointModel::new(&EstimatorParams::kitti(Intrinsics::KITTI_0926, 0.1));
        let fb = Intrinsics::KITTI_0926.stereo_fb;
        let p = MotionParams::default();
        // The camera drives 1 m forward past a static corner 10 m ahead and 2 m to the side,
        // which the stereo gave the depth of the wall 20 m behind it.
        let pose = Pose3::translation(0.0, 0.0, -1.0);
        let corner = nalgebra::Point3::new(2.0, 0.5, 10.0);
        let pixel = |q: &nalgebra::Point3<f32>| model.project(q).unwrap();
        let ((u0, v0), (u1, v1)) = (pixel(&corner), pixel(&pose.transform_point(&corner)));
        let then = Seen { u: u0, v: v0, depth: Some(20.0), around: Some((10.0, 20.0)) };
        let now = Seen { u: u1, v: v1, depth: Some(18.0), around: Some((9.0, 18.0)) };
        let alone = |s: &Seen| Seen { around: None, ..*s };
        let (_, own) = least_residual(&model, &pose, (&alone(&then), &alone(&now)), fb, &p).unwrap();
        let (_, least) = least_residual(&model, &pose, (&then, &now), fb, &p).unwrap();
        assert!(own > 100.0, "on the wall's depth the corner looks moving: {own}");
        assert!(least < 1.0, "on the near depth around it, it is static: {least}");
        // A corner that moves is explained by none of them.
        let moved = Seen { u: u1 + 15.0, ..now };
        let (_, m2) = least_residual(&model, &pose, (&then, &moved), fb, &p).unwrap();
        assert!(m2 > p.moving_sigmas * p.moving_sigmas, "{m2}");
    }
}
