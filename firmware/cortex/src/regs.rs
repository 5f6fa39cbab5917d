//! The few STM32F4 registers this firmware uses, by hand.
//!
//! A register is a 32-bit word at a fixed address: writing it configures or drives a
//! peripheral, reading it gives its state. The addresses are those of the reference manual
//! RM0090 ("Memory map" and each peripheral's "register map") and, for the core's own
//! peripherals (SysTick, the interrupt controller, the FPU), of ARM's Cortex-M4 Devices Generic
//! User Guide. Every access is volatile, so the compiler neither caches nor drops it.
//!
//! A crate generated from the vendor's register description (`stm32f4`) would give every
//! register of the chip, but takes minutes to build; the few below take no time.

use core::ptr::{read_volatile, write_volatile};

/// One 32-bit register at an address.
#[derive(Clone, Copy)]
pub struct Reg(pub usize);

impl Reg {
    /// Read the register.
    #[inline(always)]
    pub fn read(self) -> u32 {
        // SAFETY: the address is one of the registers below, always mapped on the STM32F4.
        unsafe { read_volatile(self.0 as *const u32) }
    }

    /// Write the register.
    #[inline(always)]
    pub fn write(self, value: u32) {
        // SAFETY: as in `read`.
        unsafe { write_volatile(self.0 as *mut u32, value) }
    }

    /// Replace the bits of `mask` by those of `value` (read, modify, write: callers do it at
    /// start-up, before the interrupts that could touch the same register are on).
    #[inline(always)]
    pub fn modify(self, mask: u32, value: u32) {
        self.write(self.read() & !mask | value & mask);
    }
}

/// The reset and clock control: each peripheral's clock is off until enabled here.
pub const RCC: usize = 0x4002_3800;
/// RCC_AHB1ENR: the GPIO ports' clocks (bit n: port A + n).
pub const RCC_AHB1ENR: Reg = Reg(RCC + 0x30);
/// RCC_APB2ENR: USART1 (bit 4).
pub const RCC_APB2ENR: Reg = Reg(RCC + 0x44);
/// RCC_CSR: the causes of the last reset (bit 29, IWDGRSTF: the watchdog), cleared by RMVF (24).
pub const RCC_CSR: Reg = Reg(RCC + 0x74);

/// The interrupt controller: set-enable registers (bit n of word n / 32: interrupt n).
pub const NVIC_ISER: usize = 0xE000_E100;

/// The coprocessor access control register: CP10 and CP11 are the FPU.
pub const SCB_CPACR: Reg = Reg(0xE000_ED88);

/// Allow the interrupt `irq` (its number in the vector table after the 16 core exceptions).
pub fn nvic_enable(irq: u32) {
    Reg(NVIC_ISER + 4 * (irq as usize / 32)).write(1 << (irq % 32));
}

/// Interrupts on (`cpsie i`).
#[inline(always)]
pub fn enable_interrupts() {
    // SAFETY: only clears PRIMASK; every handler's state is set up before this is called.
    unsafe { core::arch::asm!("cpsie i", options(nomem, nostack)) };
}
