//! The two things the edge loop needs from its platform: a byte link and a clock.

use dynotraj_core::wire::ComputeUnit;

/// Where the loop's bytes come from and go to (UART on the MCU; TCP, serial or stdio on the host).
pub trait Transport {
    /// The transport's error.
    type Error;
    /// Reads available bytes into `buf`, waiting for at least one; `Ok(0)` means the stream
    /// ended.
    ///
    /// # Errors
    /// A transport failure.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error>;
    /// Writes all of `bytes`.
    ///
    /// # Errors
    /// A transport failure.
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), Self::Error>;
    /// Bytes the transport itself dropped so far (a receive buffer overrun); zero when it
    /// cannot lose bytes.
    fn bytes_lost(&self) -> u32 {
        0
    }
}

/// A monotonic counter that measures compute; the core never learns what time it is, the loop
/// reads this around each frame's work and reports the difference in [`FrameStats`].
///
/// [`FrameStats`]: dynotraj_core::wire::FrameStats
pub trait Clock {
    /// What one count of [`Clock::now`] is.
    const UNIT: ComputeUnit;
    /// The counter now.
    fn now(&mut self) -> u64;
}

/// A clock that never advances: compute figures read zero (tests that compare outputs).
#[derive(Debug, Clone, Copy, Default)]
pub struct NoClock;

impl Clock for NoClock {
    const UNIT: ComputeUnit = ComputeUnit::Nanoseconds;
    fn now(&mut self) -> u64 {
        0
    }
}
