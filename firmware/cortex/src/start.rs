//! Power-on: the vector table and the reset handler.
//!
//! After reset a Cortex-M core reads two words at address 0 (the flash, aliased there): the
//! initial stack pointer, then the address of the reset handler, and jumps to it. The words
//! after those are the addresses of the other exception and interrupt handlers (the "vector
//! table", ARM's Cortex-M4 Devices Generic User Guide, "Vector table"; the STM32F4's interrupts
//! in RM0090, "Vector table for STM32F405xx/07xx"). link.x puts the stack pointer first and
//! this table right after it.
//!
//! The reset handler does what a C runtime's start-up code does: switch the FPU on, copy the
//! initial values of statics from flash to RAM, zero the rest, then call `main`.

use crate::regs::SCB_CPACR;

type Handler = unsafe extern "C" fn();

/// The core's exceptions 1 to 15, then the chip's interrupts 0 to 37 (USART1's is the last
/// this firmware uses).
const VECTORS: usize = 15 + 38;
/// Where each handler goes: exception n at n - 1, interrupt n at 15 + n.
const SYSTICK: usize = 15 - 1;
const USART1_IRQ: u32 = 37;

#[link_section = ".vector_table.handlers"]
#[used]
static HANDLERS: [Option<Handler>; VECTORS] = {
    // Every exception and interrupt not named below is a fault: a bug, or a peripheral that
    // should be silent. The reserved entries (7-10, 13) stay in the table as fault handlers too.
    let mut v: [Option<Handler>; VECTORS] = [Some(crate::fault); VECTORS];
    v[0] = Some(reset);
    v[SYSTICK] = Some(crate::step_interrupt);
    v[15 + USART1_IRQ as usize] = Some(crate::uart::receive_interrupt);
    v
};

/// The USART1 interrupt's number, for the interrupt controller.
pub const USART1_INTERRUPT: u32 = USART1_IRQ;

extern "C" {
    // From link.x.
    static mut _data_start: u32;
    static mut _data_end: u32;
    static _data_load: u32;
    static mut _bss_start: u32;
    static mut _bss_end: u32;
}

/// The word free RAM is painted with at reset.
const STACK_PAINT: u32 = 0xA5A5_A5A5;
/// Words below the reset handler's stack pointer left unpainted: its own frame.
const STACK_PAINT_MARGIN_WORDS: usize = 16;

/// The reset handler.
///
/// # Safety
/// Run by the core at reset only.
#[no_mangle]
pub unsafe extern "C" fn reset() {
    // The FPU is off after reset, and the first float instruction would fault: give CP10 and
    // CP11 (the FPU) full access, then wait until the change is in effect (`dsb`, `isb`).
    // `main` is never inlined here, so no float register is saved before this.
    SCB_CPACR.modify(0xF << 20, 0xF << 20);
    // SAFETY: barriers only.
    unsafe { core::arch::asm!("dsb", "isb", options(nostack)) };
    // SAFETY: the linker script's symbols bound word-aligned sections of RAM and flash that no
    // Rust code uses yet.
    unsafe {
        let mut dst = &raw mut _data_start;
        let mut src = &raw const _data_load;
        while dst < &raw mut _data_end {
            dst.write_volatile(src.read());
            dst = dst.add(1);
            src = src.add(1);
        }
        let mut dst = &raw mut _bss_start;
        while dst < &raw mut _bss_end {
            dst.write_volatile(0);
            dst = dst.add(1);
        }
        // Paint the free RAM up to this handler's own frame, so that the stack's high-water
        // mark can be read from a RAM dump (bench/cortex_stack.py): the lowest word that is no
        // longer the paint.
        let sp: *mut u32;
        core::arch::asm!("mov {}, sp", out(reg) sp, options(nomem, nostack));
        let end = sp.sub(STACK_PAINT_MARGIN_WORDS);
        while dst < end {
            dst.write_volatile(STACK_PAINT);
            dst = dst.add(1);
        }
    }
    crate::main()
}
