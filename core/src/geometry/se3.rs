//! SE(3) and SE(2) helpers over nalgebra's isometries.

use nalgebra::{Isometry2, Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3, Vector6};

use super::BevState;

/// A rigid pose or motion in 3D.
pub type Pose3 = Isometry3<f32>;

/// The identity pose as a constant, so that state holding poses has `const fn` constructors
/// (nalgebra's `identity()` is not `const`).
pub const POSE3_IDENTITY: Pose3 = Isometry3::from_parts(
    Translation3::new(0.0, 0.0, 0.0),
    UnitQuaternion::new_unchecked(Quaternion::new(1.0, 0.0, 0.0, 0.0)),
);

/// Rotation angle of a pose, radians in [0, pi] (the angle of its axis-angle form).
#[must_use]
pub fn rotation_angle(p: &Pose3) -> f32 {
    p.rotation.angle()
}

/// Exponential map of SE(3): twist `[rho (translation part); omega (rotation part)]` to a pose,
/// using the left Jacobian so that `se3_log(se3_exp(xi)) == xi`.
#[must_use]
pub fn se3_exp(xi: &Vector6<f32>) -> Pose3 {
    let rho = Vector3::new(xi[0], xi[1], xi[2]);
    let omega = Vector3::new(xi[3], xi[4], xi[5]);
    let rot = rotation_of_scaled_axis(&omega);
    let t = left_jacobian(&omega) * rho;
    Isometry3::from_parts(Translation3::from(t), rot)
}

/// The rotation of a rotation vector (axis times angle), as nalgebra's
/// `UnitQuaternion::from_scaled_axis` builds it, but with the single-precision
/// [`super::trig::sin_cos`]: nalgebra reaches libm's `sinf` and `cosf`, whose f64 polynomials the
/// Cortex-M4F runs in software (measured: about a tenth of a frame's estimation).
#[must_use]
pub fn rotation_of_scaled_axis(omega: &Vector3<f32>) -> UnitQuaternion<f32> {
    let angle = omega.norm();
    if angle == 0.0 {
        return UnitQuaternion::identity();
    }
    let (s, c) = super::trig::sin_cos(0.5 * angle);
    let axis = omega / angle;
    UnitQuaternion::new_unchecked(Quaternion::from_parts(c, axis * s))
}

/// Logarithm map of SE(3), the inverse of [`se3_exp`].
#[must_use]
pub fn se3_log(p: &Pose3) -> Vector6<f32> {
    let omega = p.rotation.scaled_axis();
    let rho = inverse_left_jacobian(&omega) * p.translation.vector;
    Vector6::new(rho.x, rho.y, rho.z, omega.x, omega.y, omega.z)
}

fn skew(w: &Vector3<f32>) -> nalgebra::Matrix3<f32> {
    nalgebra::Matrix3::new(0.0, -w.z, w.y, w.z, 0.0, -w.x, -w.y, w.x, 0.0)
}

/// Below this rotation angle the series forms of the Jacobians are used.
const SMALL_ANGLE: f32 = 1e-3;

fn left_jacobian(w: &Vector3<f32>) -> nalgebra::Matrix3<f32> {
    let th = w.norm();
    let k = skew(w);
    let (a, b) = if th < SMALL_ANGLE {
        (0.5 - th * th / 24.0, 1.0 / 6.0 - th * th / 120.0)
    } else {
        let th2 = th * th;
        let (sin, cos) = super::trig::sin_cos(th);
        ((1.0 - cos) / th2, (th - sin) / (th2 * th))
    };
    nalgebra::Matrix3::identity() + k * a + k * k * b
}

fn inverse_left_jacobian(w: &Vector3<f32>) -> nalgebra::Matrix3<f32> {
    let th = w.norm();
    let k = skew(w);
    let c = if th < SMALL_ANGLE {
        1.0 / 12.0 + th * th / 720.0
    } else {
        let half = 0.5 * th;
        let (sin, cos) = super::trig::sin_cos(half);
        (1.0 - half * cos / sin) / (th * th)
    };
    nalgebra::Matrix3::identity() - k * 0.5 + k * k * c
}

/// The SE(2) pose of a bird's-eye state (position and heading).
#[must_use]
pub fn se2_of_bev(s: &BevState) -> Isometry2<f32> {
    Isometry2::new(nalgebra::Vector2::new(s.x, s.y), s.heading)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_of_scaled_axis_matches_nalgebra() {
        for w in
            [Vector3::new(0.1, -0.2, 0.3), Vector3::new(0.0, 0.0, 1e-6), Vector3::new(2.5, 1.0, -0.5), Vector3::zeros()]
        {
            let (a, b) = (rotation_of_scaled_axis(&w), UnitQuaternion::from_scaled_axis(w));
            assert!(a.angle_to(&b) < 1e-6, "{w:?}: {a:?} vs {b:?}");
        }
        // A NaN stays visible, as with nalgebra.
        assert!(rotation_of_scaled_axis(&Vector3::new(f32::NAN, 0.0, 0.0)).w.is_nan());
    }

    #[test]
    fn exp_log_round_trip() {
        for xi in [
            Vector6::new(1.0, -2.0, 0.5, 0.1, -0.2, 0.3),
            Vector6::new(0.3, 0.0, 0.0, 0.0, 0.0, 1e-5),
            Vector6::new(0.0, 0.0, 2.0, 0.0, 2.5, 0.0),
        ] {
            let back = se3_log(&se3_exp(&xi));
            assert!((back - xi).norm() < 1e-4, "{xi:?} -> {back:?}");
        }
    }

    #[test]
    fn pure_rotation_angle() {
        let p = se3_exp(&Vector6::new(0.0, 0.0, 0.0, 0.0, 0.4, 0.0));
        assert!((rotation_angle(&p) - 0.4).abs() < 1e-5);
    }
}
