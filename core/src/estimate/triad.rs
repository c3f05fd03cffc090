//! The rigid transform that maps three source points onto three target points: RANSAC's
//! minimal solver. Each triangle gives an orthonormal frame (its first edge, its normal, and
//! their cross product), the rotation takes the source frame onto the target frame, and the
//! translation matches the centroids (the TRIAD construction).
//!
//! It replaced a least-squares Kabsch fit through nalgebra's 3x3 SVD: for a hypothesis that only
//! seeds the robust refinement the least-squares optimum over three points buys nothing, and the
//! SVD was the costliest step of RANSAC on the MCU (about 0.9 M of a 16-object frame's
//! instructions; object RPE on the nine KITTI-driven sequences unchanged, docs/results.md).

use nalgebra::{Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

use crate::geometry::Pose3;

/// Smallest triangle (twice its area over its squared longest side) accepted as a sample: thinner
/// triangles leave the rotation about their long axis unobservable.
const MIN_TRIANGLE_SHAPE: f32 = 0.05;

/// The pose `m` with `m * src_i = dst_i` for three exact correspondences (close to it for noisy
/// ones), or `None` for a degenerate (near-collinear or non-finite) triangle.
#[must_use]
pub fn rigid_from_three(src: &[Vector3<f32>; 3], dst: &[Vector3<f32>; 3]) -> Option<Pose3> {
    let [a, b, c] = src;
    let [d0, d1, d2] = dst;
    // R F_src = F_dst.
    let (f_src, f_dst) = (triad(a, b, c)?, triad(d0, d1, d2)?);
    let r = f_dst * f_src.transpose();
    let cs = (a + b + c) / 3.0;
    let cd = (d0 + d1 + d2) / 3.0;
    let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    let t = cd - rot * cs;
    let pose = super::lie::normalised(Pose3::from_parts(Translation3::from(t), rot));
    super::lie::pose_is_finite(&pose).then_some(pose)
}

/// The orthonormal frame of a triangle as the columns of a matrix: its first edge, the normal,
/// and the normal crossed with the edge; `None` for a non-finite or too thin triangle (twice
/// its area at most [`MIN_TRIANGLE_SHAPE`] of its squared longest side).
fn triad(a: &Vector3<f32>, b: &Vector3<f32>, c: &Vector3<f32>) -> Option<Matrix3<f32>> {
    let (ab, ac, bc) = (b - a, c - a, c - b);
    let longest = ab.norm_squared().max(ac.norm_squared()).max(bc.norm_squared());
    let normal = ab.cross(&ac);
    let twice_area = normal.norm();
    let well_shaped =
        longest.is_finite() && twice_area.is_finite() && longest > 0.0 && twice_area > MIN_TRIANGLE_SHAPE * longest;
    if !well_shaped {
        return None;
    }
    let e1 = ab.try_normalize(0.0)?;
    let n = normal.try_normalize(0.0)?;
    Some(Matrix3::from_columns(&[e1, n.cross(&e1), n]))
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
        let fit = rigid_from_three(&src, &dst).unwrap();
        assert!((fit.translation.vector - m.translation.vector).norm() < 1e-4);
        assert!(fit.rotation.angle_to(&m.rotation) < 1e-4);
        let line = [Vector3::new(0.0, 0.0, 1.0), Vector3::new(0.0, 0.0, 2.0), Vector3::new(0.0, 0.0, 3.0)];
        assert!(rigid_from_three(&line, &line).is_none());
        let nan = [Vector3::new(f32::NAN, 0.0, 1.0), src[1], src[2]];
        assert!(rigid_from_three(&nan, &dst).is_none());
    }
}
