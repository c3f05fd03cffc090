//! The device interrupt vectors of mps2-an386 that the programs fill: IRQ 0 (UART0 receive) and
//! IRQ 1 (UART0 transmit, never used). cortex-m-rt takes the table from the program as a static
//! named `__INTERRUPTS` in the `.vector_table.interrupts` section, so each program expands
//! [`device_interrupts!`](crate::device_interrupts) once; the `unsafe` attributes that placing
//! it takes are written here only.

/// Defines the program's device vector table: UART0's receive interrupt (IRQ 0) calls `$rx`
/// (an `unsafe extern "C" fn()`), IRQ 1 the default handler; with no argument, both go to the
/// default handler (a program that takes no interrupt).
#[macro_export]
macro_rules! device_interrupts {
    () => {
        $crate::device_interrupts!(DefaultHandler);
    };
    ($rx:ident) => {
        #[unsafe(link_section = ".vector_table.interrupts")]
        #[unsafe(no_mangle)]
        static __INTERRUPTS: [unsafe extern "C" fn(); 2] = [$rx, DefaultHandler];

        unsafe extern "C" {
            fn DefaultHandler();
        }
    };
}
