//! The host build must take nalgebra's float functions from libm, as the firmware does: the edge
//! is held bit for bit to the host (edge_qemu), and glibc's `sinf`, `cosf`, `sqrtf`... differ from
//! libm's in the last bit on some inputs. simba's `libm` feature alone goes through num-traits,
//! whose `std` feature other host dependencies enable, and then calls glibc; the workspace
//! therefore enables nalgebra's `libm-force`. This test fails if that is lost.

use nalgebra::{ComplexField, UnitQuaternion, Vector3};

#[test]
fn nalgebra_float_functions_are_libm_bit_for_bit() {
    let mut seed = 3u32;
    let mut differ = 0;
    for _ in 0..100_000 {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        let x = (seed >> 8) as f32 / (1u32 << 24) as f32 * 20.0 - 10.0;
        let pairs = [
            (ComplexField::sin(x), libm::sinf(x)),
            (ComplexField::cos(x), libm::cosf(x)),
            (ComplexField::atan(x), libm::atanf(x)),
            (ComplexField::sqrt(x.abs()), libm::sqrtf(x.abs())),
            (ComplexField::exp(x), libm::expf(x)),
            // Rotations from angles, as the estimator builds a yaw.
            (UnitQuaternion::from_axis_angle(&Vector3::y_axis(), x).j, libm::sincosf(x / 2.0).0),
        ];
        differ += pairs.iter().filter(|(n, l)| n.to_bits() != l.to_bits()).count();
    }
    assert_eq!(differ, 0, "nalgebra's float functions are not libm's");
}
