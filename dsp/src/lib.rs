//! The int8 products of dynotraj's inference ([`Int8Dot`]) on the Cortex-M4's DSP
//! instructions: SXTB16 unpacks four int8 values into two pairs of 16-bit lanes and SMLAD
//! multiplies both pairs and adds them to an accumulator, so four multiply-accumulates take a
//! word load, two unpacks and two SMLADs (the activations are unpacked once for all rows).
//!
//! Inline assembly needs `unsafe`, which `dynotraj-core` forbids: it lives here, in the one
//! module [`smlad`](self) compiled only with the `smlad` feature on 32-bit ARM. Everywhere else
//! [`DspDot`] is [`PortableDot`]. Either way the results equal [`PortableDot`]'s bit for bit
//! (both sum the same integer products modulo 2^32), which the firmware's kernel check tests on
//! the MCU under QEMU.
#![no_std]
#![deny(unsafe_code)]

use dynotraj_core::model::Int8Dot;
#[cfg(not(all(feature = "smlad", target_arch = "arm")))]
use dynotraj_core::model::PortableDot;

#[cfg(all(feature = "smlad", target_arch = "arm"))]
mod smlad;

/// Whether this build multiplies with SMLAD (else [`DspDot`] is the portable code).
pub const SMLAD: bool = cfg!(all(feature = "smlad", target_arch = "arm"));

/// The int8 dot products on SMLAD where the build has it, else [`PortableDot`]'s.
#[derive(Debug, Clone, Copy, Default)]
pub struct DspDot;

impl Int8Dot for DspDot {
    #[inline]
    fn rows(w: &[u8], stride: usize, x: &[i8], out: &mut [i32]) {
        #[cfg(all(feature = "smlad", target_arch = "arm"))]
        smlad::rows(w, stride, x, out);
        #[cfg(not(all(feature = "smlad", target_arch = "arm")))]
        PortableDot::rows(w, stride, x, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn off_arm_the_products_are_the_portable_ones() {
        let w = [1u8, 0xff, 0x80, 7, 9];
        let x = [3i8, -4, -128, 127, 2];
        let (mut a, mut b) = ([0; 2], [0; 2]);
        DspDot::rows(&w, 2, &x[..3], &mut a);
        PortableDot::rows(&w, 2, &x[..3], &mut b);
        assert_eq!(a, b);
    }
}
