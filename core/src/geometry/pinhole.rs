//! The pinhole camera's inverse: a pixel and its depth back to a point of the camera frame.

use core::ops::{Div, Mul, Sub};

/// The camera-frame point (x right, y down, z forward) seen at pixel `pixel` = (u, v) at depth
/// `depth` (along z), for focal lengths `focal` = (fx, fy) and principal point `centre` =
/// (cx, cy), all in pixels. Generic so that the simulator's f64 scenes and the estimator's f32
/// measurements back-project with the same expression, in the same order of operations.
#[must_use]
pub fn back_project<T>(pixel: [T; 2], depth: T, focal: [T; 2], centre: [T; 2]) -> [T; 3]
where
    T: Copy + Sub<Output = T> + Mul<Output = T> + Div<Output = T>,
{
    let [u, v] = pixel;
    let [fx, fy] = focal;
    let [cx, cy] = centre;
    [(u - cx) * depth / fx, (v - cy) * depth / fy, depth]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_principal_point_lies_on_the_axis_and_offsets_scale_with_depth() {
        assert_eq!(back_project([609.5, 172.5], 10.0_f64, [721.5, 721.5], [609.5, 172.5]), [0.0, 0.0, 10.0]);
        let [x, y, z] = back_project([709.5_f32, 72.5], 7.215, [721.5, 721.5], [609.5, 172.5]);
        assert!((x - 1.0).abs() < 1e-5 && (y + 1.0).abs() < 1e-5 && (z - 7.215).abs() < 1e-6, "{x} {y} {z}");
    }
}
