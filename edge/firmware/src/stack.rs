//! Peak stack by painting: every free word between the statics and the stack pointer gets a
//! pattern at boot; the lowest word that lost it marks the deepest the stack has been.

/// The paint.
const PAINT: u32 = 0x5EED_57AC;
/// Words just below the live stack left unpainted (the painting code's own frame).
const MARGIN: usize = 64;

unsafe extern "C" {
    /// End of the statics (.bss and .uninit), from cortex-m-rt's link.x.
    static mut __sheap: u32;
    /// Top of RAM, where the stack starts.
    static _stack_start: u32;
}

fn bottom() -> *mut u32 {
    &raw mut __sheap
}

fn top() -> usize {
    (&raw const _stack_start) as usize
}

/// Paints the free stack. Call first thing in `main`.
pub fn paint() {
    let sp = cortex_m::register::msp::read() as usize;
    let mut p = bottom();
    while (p as usize) < sp - MARGIN * 4 {
        // SAFETY: words between the end of the statics and below the live stack belong to no one.
        unsafe {
            p.write_volatile(PAINT);
            p = p.add(1);
        }
    }
}

/// Stack bytes available (top of RAM down to the statics).
pub fn available() -> usize {
    top() - bottom() as usize
}

/// Deepest stack use so far, bytes; equal to [`available`] when the stack reached the statics
/// (an overflow: the budget was exceeded).
pub fn peak() -> usize {
    let mut p = bottom() as *const u32;
    // SAFETY: reads of RAM between the statics and the top of the stack.
    while (p as usize) < top() && unsafe { p.read_volatile() } == PAINT {
        p = unsafe { p.add(1) };
    }
    top() - p as usize
}
