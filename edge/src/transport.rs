//! The two things the edge loop needs from its platform: a byte link and a clock.
//!
//! The link is the embedded ecosystem's: any [`embedded_io::Read`] + [`embedded_io::Write`]
//! (a HAL's UART, a USB-CDC class, a CAN-TP channel, `std` streams through an adapter). Wrap
//! it in [`Io`] and it is a [`Transport`]; implement [`Transport`] yourself only to report the
//! bytes your receiver dropped ([`Transport::bytes_lost`]).

use dynotraj_core::wire::ComputeUnit;
use embedded_io::{ErrorType, Read, Write};

/// Where the loop's bytes come from and go to (UART on the MCU; TCP, serial or stdio on the
/// host). Reads follow [`embedded_io::Read`]: wait for at least one byte, `Ok(0)` means the
/// stream ended. Every reply frame is written with [`Write::write_all`] and then flushed.
pub trait Transport: Read + Write {
    /// Bytes the transport itself dropped so far (a receive buffer overrun); zero when it
    /// cannot lose bytes. Reported to the host with the decoder's own drops.
    fn bytes_lost(&self) -> u32 {
        0
    }
}

impl<T: Transport + ?Sized> Transport for &mut T {
    fn bytes_lost(&self) -> u32 {
        (**self).bytes_lost()
    }
}

/// Any embedded-io byte stream as a [`Transport`] that loses no bytes (or does not count
/// them): `Io(my_uart)`. A newtype with nothing but the driver in it, every call forwarded.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Io<T>(pub T);

impl<T: ErrorType> ErrorType for Io<T> {
    type Error = T::Error;
}

impl<T: Read> Read for Io<T> {
    #[inline]
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        self.0.read(buf)
    }
}

impl<T: Write> Write for Io<T> {
    #[inline]
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        self.0.write(buf)
    }

    #[inline]
    fn flush(&mut self) -> Result<(), Self::Error> {
        self.0.flush()
    }

    #[inline]
    fn write_all(&mut self, buf: &[u8]) -> Result<(), Self::Error> {
        self.0.write_all(buf)
    }
}

impl<T: Read + Write> Transport for Io<T> {}

/// A receive half and a transmit half with one error type (as HALs split a UART) as one
/// [`Transport`]: `Split(rx, tx)`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Split<R, W>(pub R, pub W);

impl<R: ErrorType, W: ErrorType<Error = R::Error>> ErrorType for Split<R, W> {
    type Error = R::Error;
}

impl<R: Read, W: ErrorType<Error = R::Error>> Read for Split<R, W> {
    #[inline]
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        self.0.read(buf)
    }
}

impl<R: ErrorType, W: Write<Error = R::Error>> Write for Split<R, W> {
    #[inline]
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        self.1.write(buf)
    }

    #[inline]
    fn flush(&mut self) -> Result<(), Self::Error> {
        self.1.flush()
    }

    #[inline]
    fn write_all(&mut self, buf: &[u8]) -> Result<(), Self::Error> {
        self.1.write_all(buf)
    }
}

impl<R: Read, W: Write<Error = R::Error>> Transport for Split<R, W> {}

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
