//! Small SE(3) helpers for the solvers: the adjoint, the skew matrix, packed symmetric 6x6
//! matrices, and twists. Twists are ordered `[rho (translation); omega (rotation)]` as in
//! [`crate::geometry::se3_exp`].

use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};

use crate::geometry::Pose3;

/// A 6x6 matrix (information or covariance of a twist).
pub type Mat6 = Matrix6<f32>;
/// A twist or a 6-vector.
pub type Vec6 = Vector6<f32>;

/// The zero twist as a constant (nalgebra's `zeros()` is not `const`).
pub const VEC6_ZERO: Vec6 = Vec6::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0);

/// Entries of the upper triangle of a symmetric 6x6 matrix.
pub const PACKED6: usize = 21;

/// A symmetric 6x6 matrix stored as its upper triangle, row by row: 21 floats instead of 36.
/// The smoother keeps one per frame and object, so the saving is most of its memory.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PackedSym6(pub [f32; PACKED6]);

impl PackedSym6 {
    /// The zero matrix.
    pub const ZERO: Self = Self([0.0; PACKED6]);

    /// Packs the upper triangle of `m` (assumed symmetric).
    #[must_use]
    pub fn pack(m: &Mat6) -> Self {
        let mut out = [0.0; PACKED6];
        let mut slots = out.iter_mut();
        for r in 0..6 {
            for c in r..6 {
                if let (Some(slot), Some(v)) = (slots.next(), m.get((r, c))) {
                    *slot = *v;
                }
            }
        }
        Self(out)
    }

    /// The full symmetric matrix.
    #[must_use]
    pub fn unpack(&self) -> Mat6 {
        let mut m = Mat6::zeros();
        let mut vals = self.0.iter();
        for r in 0..6 {
            for c in r..6 {
                let v = vals.next().copied().unwrap_or(0.0);
                if let Some(x) = m.get_mut((r, c)) {
                    *x = v;
                }
                if let Some(x) = m.get_mut((c, r)) {
                    *x = v;
                }
            }
        }
        m
    }

    /// True when every entry is finite.
    #[must_use]
    pub fn is_finite(&self) -> bool {
        self.0.iter().all(|v| v.is_finite())
    }
}

/// The skew-symmetric matrix of `w`: `skew(w) * v == w.cross(v)`.
#[must_use]
pub fn skew(w: &Vector3<f32>) -> Matrix3<f32> {
    Matrix3::new(0.0, -w.z, w.y, w.z, 0.0, -w.x, -w.y, w.x, 0.0)
}

/// The adjoint of `t` acting on twists `[rho; omega]`: `t * exp(xi) * t^-1 == exp(adjoint(t) * xi)`.
#[must_use]
pub fn adjoint(t: &Pose3) -> Mat6 {
    let r = t.rotation.to_rotation_matrix().into_inner();
    let tr = skew(&t.translation.vector) * r;
    let mut a = Mat6::zeros();
    a.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    a.fixed_view_mut::<3, 3>(0, 3).copy_from(&tr);
    a.fixed_view_mut::<3, 3>(3, 3).copy_from(&r);
    a
}

/// The matrix of `ad(xi)` (the Lie bracket with `xi`) acting on twists `[rho; omega]`.
#[must_use]
pub fn ad_matrix(xi: &Vec6) -> Mat6 {
    let (w, r) = (skew(&omega(xi)), skew(&rho(xi)));
    let mut ad = Mat6::zeros();
    ad.fixed_view_mut::<3, 3>(0, 0).copy_from(&w);
    ad.fixed_view_mut::<3, 3>(0, 3).copy_from(&r);
    ad.fixed_view_mut::<3, 3>(3, 3).copy_from(&w);
    ad
}

/// A pose as 6 floats (translation, rotation vector): the compact form chains store.
#[must_use]
pub fn pose_to_lin(p: &Pose3) -> [f32; 6] {
    let (t, w) = (p.translation.vector, p.rotation.scaled_axis());
    [t.x, t.y, t.z, w.x, w.y, w.z]
}

/// The pose of [`pose_to_lin`]'s 6 floats.
#[must_use]
pub fn lin_to_pose(l: &[f32; 6]) -> Pose3 {
    let [tx, ty, tz, wx, wy, wz] = *l;
    Pose3::from_parts(
        nalgebra::Translation3::new(tx, ty, tz),
        crate::geometry::rotation_of_scaled_axis(&Vector3::new(wx, wy, wz)),
    )
}

/// The information of `b = a_map * a` given the information `info_a` of `a`, for an invertible
/// linear map: `a_map^-T info_a a_map^-1`. `None` when the map is singular.
#[must_use]
pub fn map_information(info_a: &Mat6, a_map: &Mat6) -> Option<Mat6> {
    let inv = a_map.try_inverse()?;
    Some(inv.transpose() * info_a * inv)
}

/// The rotation part of a twist.
#[must_use]
pub fn omega(xi: &Vec6) -> Vector3<f32> {
    xi.fixed_rows::<3>(3).into_owned()
}

/// The translation part of a twist.
#[must_use]
pub fn rho(xi: &Vec6) -> Vector3<f32> {
    xi.fixed_rows::<3>(0).into_owned()
}

/// `p` with its rotation quaternion renormalised: products of many poses in f32 (and rotations
/// from a rounded SVD) drift off unit length, and the drift compounds along a chain.
#[must_use]
pub fn normalised(mut p: Pose3) -> Pose3 {
    p.rotation.renormalize();
    p
}

/// True when every entry of a pose is finite.
#[must_use]
pub fn pose_is_finite(p: &Pose3) -> bool {
    p.translation.vector.iter().all(|v| v.is_finite()) && p.rotation.coords.iter().all(|v| v.is_finite())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::geometry::{se3_exp, se3_log};

    #[test]
    fn packing_round_trips() {
        let mut m = Mat6::zeros();
        for r in 0..6 {
            for c in 0..6 {
                m[(r, c)] = (r.min(c) * 10 + r.max(c)) as f32;
            }
        }
        assert_eq!(PackedSym6::pack(&m).unpack(), m);
    }

    #[test]
    fn adjoint_conjugates_exponentials() {
        let t = se3_exp(&Vec6::new(1.0, -2.0, 3.0, 0.2, -0.1, 0.3));
        let xi = Vec6::new(0.1, 0.2, -0.3, 0.01, 0.02, -0.03);
        let lhs = se3_log(&(t * se3_exp(&xi) * t.inverse()));
        let rhs = adjoint(&t) * xi;
        assert!((lhs - rhs).norm() < 1e-4, "{lhs:?} vs {rhs:?}");
    }
}
