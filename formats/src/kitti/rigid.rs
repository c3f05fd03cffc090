//! Conversions between the 3x4 / 4x4 matrices of KITTI files and rigid transforms
//! ([`Isometry3`]), with checked re-orthonormalisation of rotation blocks.
//!
//! Files store rotations with a few decimals, so `RᵀR` is only approximately the identity. A
//! rotation block whose deviation `‖RᵀR − I‖_F` is at most [`ORTHONORMAL_TOLERANCE`] and whose
//! determinant is positive is projected onto the nearest rotation (in the Frobenius sense, by
//! SVD); anything else is rejected, because it is not a rotation written with rounding error but
//! a different kind of matrix (a scaled, sheared or reflecting one, or a mis-parsed file).

use std::fmt;

use nalgebra::{Isometry3, Matrix3, Matrix3x4, Matrix4, Rotation3, Translation3, UnitQuaternion, Vector3};

/// Largest accepted `‖RᵀR − I‖_F` of a rotation block read from a file.
///
/// Rounding a rotation to 6 significant digits (the KITTI devkit's `%e`) gives deviations around
/// 1e-6; 1e-3 leaves room for sloppy writers and still rejects anything that is not a rotation.
pub const ORTHONORMAL_TOLERANCE: f64 = 1e-3;

/// Why a 3x3 block is not accepted as a rotation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RotationDefect {
    /// `‖RᵀR − I‖_F` exceeds [`ORTHONORMAL_TOLERANCE`].
    NotOrthonormal {
        /// The measured `‖RᵀR − I‖_F`.
        deviation: f64,
    },
    /// `det R <= 0`: a reflection (or a degenerate matrix), not a rotation.
    NotProper {
        /// The determinant.
        det: f64,
    },
}

impl fmt::Display for RotationDefect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RotationDefect::NotOrthonormal { deviation } => {
                write!(f, "a matrix with |R^T R - I| = {deviation:.3e}")
            }
            RotationDefect::NotProper { det } => write!(f, "a matrix with det R = {det:.6}"),
        }
    }
}

/// What the checked conversions expect, worded for [`crate::kitti::KittiError::Parse`].
pub const ROTATION_EXPECTED: &str = "a rotation block with |R^T R - I| <= 1e-3 and det R = +1";

/// The rotation nearest to `m` (Frobenius norm), by SVD; always succeeds for a finite matrix.
///
/// Use [`checked_rotation`] for matrices read from files.
#[must_use]
pub fn project_to_rotation(m: &Matrix3<f64>) -> Rotation3<f64> {
    let svd = m.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Rotation3::identity();
    };
    let mut u = u;
    if (u * v_t).determinant() < 0.0 {
        // Flip the axis of the smallest singular value to get a proper rotation.
        let (mut i_min, mut s_min) = (0, f64::INFINITY);
        for (i, s) in svd.singular_values.iter().enumerate() {
            if *s < s_min {
                (i_min, s_min) = (i, *s);
            }
        }
        u.column_mut(i_min).neg_mut();
    }
    Rotation3::from_matrix_unchecked(u * v_t)
}

/// `m` as a rotation if it is one up to rounding (see the module docs), re-orthonormalised.
///
/// # Errors
/// The [`RotationDefect`] when `m` is not a rotation up to [`ORTHONORMAL_TOLERANCE`].
pub fn checked_rotation(m: &Matrix3<f64>) -> Result<Rotation3<f64>, RotationDefect> {
    let deviation = (m.transpose() * m - Matrix3::identity()).norm();
    // NaN deviations (non-finite input) fail this test too.
    if deviation.is_nan() || deviation > ORTHONORMAL_TOLERANCE {
        return Err(RotationDefect::NotOrthonormal { deviation });
    }
    let det = m.determinant();
    if det.is_nan() || det <= 0.0 {
        return Err(RotationDefect::NotProper { det });
    }
    Ok(project_to_rotation(m))
}

/// `[R | t]` as an isometry, with `R` checked and re-orthonormalised.
///
/// # Errors
/// As [`checked_rotation`] for the block `R`.
pub fn checked_isometry(m: &Matrix3x4<f64>) -> Result<Isometry3<f64>, RotationDefect> {
    let r: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into_owned();
    let t: Vector3<f64> = m.column(3).into_owned();
    let rot = checked_rotation(&r)?;
    Ok(Isometry3::from_parts(Translation3::from(t), UnitQuaternion::from_rotation_matrix(&rot)))
}

/// The upper 3x4 block `[R | t]` of an isometry.
#[must_use]
pub fn isometry_to_3x4(iso: &Isometry3<f64>) -> Matrix3x4<f64> {
    iso.to_homogeneous().fixed_view::<3, 4>(0, 0).into_owned()
}

/// A 3x4 `[A | b]` padded to the 4x4 homogeneous matrix `[A b; 0 0 0 1]`.
#[must_use]
pub fn homogeneous_3x4(m: &Matrix3x4<f64>) -> Matrix4<f64> {
    let mut h = Matrix4::identity();
    h.fixed_view_mut::<3, 4>(0, 0).copy_from(m);
    h
}

/// A 3x3 `A` padded to the 4x4 homogeneous matrix `[A 0; 0 1]`.
#[must_use]
pub fn homogeneous_3x3(m: &Matrix3<f64>) -> Matrix4<f64> {
    let mut h = Matrix4::identity();
    h.fixed_view_mut::<3, 3>(0, 0).copy_from(m);
    h
}

/// The 4x4 homogeneous matrix `m` as an isometry, projecting its rotation block onto the nearest
/// rotation without a tolerance check (for products of already-validated calibration matrices).
#[must_use]
pub fn project_to_isometry(m: &Matrix4<f64>) -> Isometry3<f64> {
    let r: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into_owned();
    let t = Vector3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]);
    Isometry3::from_parts(Translation3::from(t), UnitQuaternion::from_rotation_matrix(&project_to_rotation(&r)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding_noise_is_removed() {
        let r = Rotation3::from_euler_angles(0.1, -0.2, 0.3);
        let noisy = r.matrix().map(|v: f64| (v * 1e6).round() / 1e6);
        let fixed = checked_rotation(&noisy).unwrap();
        let dev = (fixed.matrix().transpose() * fixed.matrix() - Matrix3::identity()).norm();
        assert!(dev < 1e-12, "{dev}");
        assert!((fixed.matrix() - r.matrix()).norm() < 1e-5);
    }

    #[test]
    fn non_rotations_are_rejected() {
        assert!(matches!(checked_rotation(&(Matrix3::identity() * 1.1)), Err(RotationDefect::NotOrthonormal { .. })));
        let reflect = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0));
        assert!(matches!(checked_rotation(&reflect), Err(RotationDefect::NotProper { .. })));
        assert!(checked_rotation(&Matrix3::from_element(f64::NAN)).is_err());
    }

    #[test]
    fn projection_of_reflection_is_proper() {
        let reflect = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0));
        assert!(project_to_rotation(&reflect).matrix().determinant() > 0.0);
    }

    #[test]
    fn homogeneous_round_trip() {
        let iso = Isometry3::new(Vector3::new(1.0, -2.0, 3.0), Vector3::new(0.2, 0.1, -0.3));
        let back = checked_isometry(&isometry_to_3x4(&iso)).unwrap();
        assert!((back.to_homogeneous() - iso.to_homogeneous()).norm() < 1e-12);
        let h = homogeneous_3x4(&isometry_to_3x4(&iso));
        assert!((h - iso.to_homogeneous()).norm() < 1e-15);
        assert!((project_to_isometry(&h).to_homogeneous() - h).norm() < 1e-12);
    }
}
