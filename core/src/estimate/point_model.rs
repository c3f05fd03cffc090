//! The measurement model of a tracked point: a 3D point `p` in the camera frame is seen at pixel
//! `(u, v)` with stereo disparity `d = fb / p.z`. Residuals are kept in pixels: the disparity
//! residual is scaled by `pixel_sigma / disparity_sigma` so that one threshold and one robust
//! kernel serve all three components (as ORB-SLAM's stereo reprojection error does with u_right).

use super::params::EstimatorParams;
use crate::geometry::Pose3;
use nalgebra::{Matrix3, Matrix3x6, Point3, Vector3, Vector6};

/// Nearest depth at which a predicted point still counts as in front of the camera, metres.
const MIN_PREDICTED_DEPTH: f32 = 0.05;

/// One correspondence: a point in the source frame (from frame k-1) and its observation at k.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Correspondence {
    /// The point in the source frame, metres.
    pub src: Vector3<f32>,
    /// Observed pixel column at frame k.
    pub u: f32,
    /// Observed pixel row at frame k.
    pub v: f32,
    /// Observed depth at frame k, metres (positive and finite: checked on assembly).
    pub depth: f32,
}

/// The camera and noise model turning poses into residuals.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointModel {
    fx: f32,
    fy: f32,
    cx: f32,
    cy: f32,
    /// Stereo baseline x fx; 0 disables the disparity residual.
    fb: f32,
    /// `pixel_sigma / disparity_sigma`: weight of the disparity residual relative to pixels.
    disparity_weight: f32,
}

impl PointModel {
    /// The model of `params`.
    #[must_use]
    pub const fn new(params: &EstimatorParams) -> Self {
        let i = params.intrinsics;
        let fb = if i.stereo_fb.is_finite() && i.stereo_fb > 0.0 { i.stereo_fb } else { 0.0 };
        let w = params.pixel_sigma / params.disparity_sigma;
        Self { fx: i.fx, fy: i.fy, cx: i.cx, cy: i.cy, fb, disparity_weight: if w.is_finite() { w } else { 1.0 } }
    }

    /// The depth error, metres, of a point at `depth` metres whose disparity is `disparity_px`
    /// off (0 without stereo).
    #[must_use]
    pub fn depth_error(&self, depth: f32, disparity_px: f32) -> f32 {
        if self.fb > 0.0 { depth * depth * disparity_px / self.fb } else { 0.0 }
    }

    /// The camera-frame point of a pixel and depth.
    #[must_use]
    pub fn back_project(&self, u: f32, v: f32, depth: f32) -> Point3<f32> {
        Point3::from(crate::geometry::back_project([u, v], depth, [self.fx, self.fy], [self.cx, self.cy]))
    }

    /// The camera-frame point of a correspondence's observation.
    #[must_use]
    pub fn target(&self, c: &Correspondence) -> Vector3<f32> {
        self.back_project(c.u, c.v, c.depth).coords
    }

    /// The pixel (u, v) of a camera-frame point, `None` behind the camera.
    #[must_use]
    pub fn project(&self, p: &Point3<f32>) -> Option<(f32, f32)> {
        (p.z > MIN_PREDICTED_DEPTH).then(|| (self.fx * p.x / p.z + self.cx, self.fy * p.y / p.z + self.cy))
    }

    /// Residual (pixels) of `c` under the pose `m` (source -> camera k): predicted minus
    /// observed `(u, v, w * disparity)`. `None` when the point lands behind the camera.
    #[must_use]
    pub fn residual(&self, m: &Pose3, c: &Correspondence) -> Option<Vector3<f32>> {
        let p = m.transform_point(&Point3::from(c.src));
        let (u, v) = self.project(&p)?;
        let d = self.disparity_weight * self.fb * (1.0 / p.z - 1.0 / c.depth);
        Some(Vector3::new(u - c.u, v - c.v, d))
    }

    /// Residual and its Jacobian with respect to a right perturbation of `m`:
    /// `m * exp(delta)`, `delta = [rho; omega]`.
    #[must_use]
    pub fn residual_and_jacobian(&self, m: &Pose3, c: &Correspondence) -> Option<(Vector3<f32>, Matrix3x6<f32>)> {
        let (r, rows) = self.linearise(&m.rotation.to_rotation_matrix().into_inner(), &m.translation.vector, c)?;
        Some((r, Matrix3x6::from_rows(&rows.map(|row| row.transpose()))))
    }

    /// [`Self::residual_and_jacobian`] for a pose given as its rotation matrix `rot` and
    /// translation `t` (converted once per pose, not once per point), with the Jacobian as its
    /// three rows.
    ///
    /// With p = R s + t and the projection's Jacobian D = dr/dp (five non-zero entries), a
    /// right perturbation moves p by R (rho + omega x s), so the Jacobian is
    /// `[D R | -D R [s]x]`; row i of the second block is s x a_i for a_i row i of D R. That is
    /// about a third of the multiplications of forming `[R | -R [s]x]` and multiplying by D.
    #[must_use]
    pub fn linearise(
        &self,
        rot: &Matrix3<f32>,
        t: &Vector3<f32>,
        c: &Correspondence,
    ) -> Option<(Vector3<f32>, [Vector6<f32>; 3])> {
        let p = Point3::from(rot * c.src + t);
        let (u, v) = self.project(&p)?;
        let iz = 1.0 / p.z;
        let d = self.disparity_weight * self.fb * (iz - 1.0 / c.depth);
        let r = Vector3::new(u - c.u, v - c.v, d);
        let iz2 = iz * iz;
        let r2 = rot.row(2).transpose();
        let a0 = rot.row(0).transpose() * (self.fx * iz) - r2 * (self.fx * p.x * iz2);
        let a1 = rot.row(1).transpose() * (self.fy * iz) - r2 * (self.fy * p.y * iz2);
        let a2 = r2 * (-self.disparity_weight * self.fb * iz2);
        let row = |a: Vector3<f32>| {
            let b = c.src.cross(&a);
            Vector6::new(a.x, a.y, a.z, b.x, b.y, b.z)
        };
        Some((r, [row(a0), row(a1), row(a2)]))
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::estimate::params::{EstimatorParams, Intrinsics};
    use crate::geometry::{Pose3, se3_exp};

    #[test]
    fn jacobian_matches_finite_differences() {
        let model = PointModel::new(&EstimatorParams::kitti(Intrinsics::KITTI_0926, 0.1));
        let m = se3_exp(&Vector6::new(0.3, -0.1, 1.2, 0.02, -0.05, 0.01));
        let c = Correspondence { src: Vector3::new(2.0, 1.0, 12.0), u: 700.0, v: 230.0, depth: 13.0 };
        let (r0, j) = model.residual_and_jacobian(&m, &c).unwrap();
        for k in 0..6 {
            let mut d = Vector6::zeros();
            d[k] = 1e-3;
            let r1 = model.residual(&(m * se3_exp(&d)), &c).unwrap();
            let num = (r1 - r0) / 1e-3;
            let col = j.column(k);
            assert!((num - col).norm() < 0.02 * (1.0 + col.norm()), "column {k}: {num:?} vs {col:?}");
        }
        let id = Pose3::identity();
        let p = model.back_project(700.0, 230.0, 13.0);
        let (u, v) = model.project(&id.transform_point(&p)).unwrap();
        assert!((u - 700.0).abs() < 1e-3 && (v - 230.0).abs() < 1e-3);
    }
}
