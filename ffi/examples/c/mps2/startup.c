/*
 * The least a C program needs to boot on QEMU's mps2-an386 (Cortex-M4F): a vector table, a
 * reset handler that turns the FPU on (the code is built for the hard-float ABI), copies .data,
 * clears .bss and opens newlib's semihosting handles, and a fault handler that exits non-zero.
 */
#include <stdint.h>
#include <stdlib.h>

extern uint32_t __stack_top, __data_start__, __data_end__, __data_load__, __bss_start__, __bss_end__;
extern void initialise_monitor_handles(void);
extern int main(int argc, char **argv);

void reset_handler(void);
void fault_handler(void);

__attribute__((section(".vectors"), used)) static const uintptr_t vectors[16] = {
    (uintptr_t)&__stack_top,
    (uintptr_t)reset_handler,
    (uintptr_t)fault_handler, /* NMI */
    (uintptr_t)fault_handler, /* HardFault */
    (uintptr_t)fault_handler, /* MemManage */
    (uintptr_t)fault_handler, /* BusFault */
    (uintptr_t)fault_handler, /* UsageFault */
};

void reset_handler(void) {
    /* CPACR: full access to CP10 and CP11, the FPU. */
    *(volatile uint32_t *)0xE000ED88u |= 0xFu << 20;
    __asm volatile("dsb\n\tisb" ::: "memory");
    for (uint32_t *src = &__data_load__, *dst = &__data_start__; dst < &__data_end__;) {
        *dst++ = *src++;
    }
    for (uint32_t *p = &__bss_start__; p < &__bss_end__;) {
        *p++ = 0;
    }
    initialise_monitor_handles();
    exit(main(0, NULL));
}

void fault_handler(void) {
    _Exit(3);
}

/* newlib's exit runs these; they come with the C runtime's start files, which this image
 * replaces (-nostartfiles). */
void _init(void) {}
void _fini(void) {}
