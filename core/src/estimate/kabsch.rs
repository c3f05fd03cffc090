//! The rigid transform that best maps three source points onto three target points (Kabsch /
//! Horn, least squares): RANSAC's minimal solver.

use nalgebra::{Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3, SVD};

use crate::geometry::Pose3;

/// Most sweeps of the 3x3 SVD; it converges in a handful, this only bounds bad input.
const SVD_MAX_ITERATIONS: usize = 32;
/// Smallest triangle (twice its area over its squared longest side) accepted as a sample: thinner
/// triangles leave the rotation about their long axis unobservable.
const MIN_TRIANGLE_SHAPE: f32 = 0.05;

/// The pose `m` minimising `sum |m * src_i - dst_i|^2` over three correspondences, or `None`
/// for a degenerate (near-collinear or non-finite) triangle.
#[must_use]
pub fn kabsch3(src: &[Vector3<f32>; 3], dst: &[Vector3<f32>; 3]) -> Option<Pose3> {
    let [a, b, c] = src;
    let [d0, d1, d2] = dst;
    if !well_shaped(a, b, c) || !well_shaped(d0, d1, d2) {
        return None;
    }
    let cs = (a + b + c) / 3.0;
    let cd = (d0 + d1 + d2) / 3.0;
    let mut h = Matrix3::zeros();
    for (s, d) in src.iter().zip(dst) {
        h += (s - cs) * (d - cd).transpose();
    }
    let svd = SVD::try_new(h, true, true, f32::EPSILON, SVD_MAX_ITERATIONS)?;
    let (u, vt) = (svd.u?, svd.v_t?);
    let mut v = vt.transpose();
    if (v * u.transpose()).determinant() < 0.0 {
        let mut col = v.column_mut(2);
        col *= -1.0;
    }
    let r = v * u.transpose();
    let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    let t = cd - rot * cs;
    let pose = super::lie::normalised(Pose3::from_parts(Translation3::from(t), rot));
    super::lie::pose_is_finite(&pose).then_some(pose)
}

/// True for a finite, not too thin triangle.
fn well_shaped(a: &Vector3<f32>, b: &Vector3<f32>, c: &Vector3<f32>) -> bool {
    let (ab, ac, bc) = (b - a, c - a, c - b);
    let longest = ab.norm_squared().max(ac.norm_squared()).max(bc.norm_squared());
    let twice_area = ab.cross(&ac).norm();
    longest.is_finite() && twice_area.is_finite() && longest > 0.0 && twice_area > MIN_TRIANGLE_SHAPE * longest
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::geometry::se3_exp;
    use nalgebra::{Point3, Vector6};

    #[test]
    fn recovers_an_exact_transform_and_rejects_collinear() {
        let m = se3_exp(&Vector6::new(1.0, -0.5, 2.0, 0.1, 0.7, -0.2));
        let src = [Vector3::new(0.0, 0.0, 10.0), Vector3::new(2.0, 0.5, 12.0), Vector3::new(-1.0, 1.5, 9.0)];
        let dst = src.map(|s| m.transform_point(&Point3::from(s)).coords);
        let fit = kabsch3(&src, &dst).unwrap();
        assert!((fit.translation.vector - m.translation.vector).norm() < 1e-4);
        assert!(fit.rotation.angle_to(&m.rotation) < 1e-4);
        let line = [Vector3::new(0.0, 0.0, 1.0), Vector3::new(0.0, 0.0, 2.0), Vector3::new(0.0, 0.0, 3.0)];
        assert!(kabsch3(&line, &line).is_none());
        let nan = [Vector3::new(f32::NAN, 0.0, 1.0), src[1], src[2]];
        assert!(kabsch3(&nan, &dst).is_none());
    }
}
