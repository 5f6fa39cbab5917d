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

use gweave_controller::board;

/// One 32-bit register.
pub type Reg = board::Reg<u32>;

/// The register at `address`: only for the addresses of this crate's register lists (this
/// module, `pins.rs`, `step_timer.rs`, `uart.rs`, `watchdog.rs`), every one mapped on the STM32F4.
pub const fn reg(address: usize) -> Reg {
    // SAFETY: as said above; RM0090 and ARM's guide list each.
    unsafe { Reg::new(address) }
}

/// The reset and clock control: each peripheral's clock is off until enabled here.
pub const RCC: usize = 0x4002_3800;
/// RCC_AHB1ENR: the GPIO ports' clocks (bit n: port A + n).
pub const RCC_AHB1ENR: Reg = reg(RCC + 0x30);
/// RCC_APB2ENR: USART1 (bit 4).
pub const RCC_APB2ENR: Reg = reg(RCC + 0x44);
/// RCC_CSR: the causes of the last reset (bit 29, IWDGRSTF: the watchdog), cleared by RMVF (24).
pub const RCC_CSR: Reg = reg(RCC + 0x74);

/// The interrupt controller: set-enable registers (bit n of word n / 32: interrupt n).
pub const NVIC_ISER: usize = 0xE000_E100;

/// The coprocessor access control register: CP10 and CP11 are the FPU.
pub const SCB_CPACR: Reg = reg(0xE000_ED88);

/// Allow the interrupt `irq` (its number in the vector table after the 16 core exceptions).
pub fn nvic_enable(irq: u32) {
    reg(NVIC_ISER + 4 * (irq as usize / 32)).write(1 << (irq % 32));
}

/// Interrupts on (`cpsie i`).
#[inline(always)]
pub fn enable_interrupts() {
    // SAFETY: only clears PRIMASK; every handler's state is set up before this is called.
    unsafe { core::arch::asm!("cpsie i", options(nomem, nostack)) };
}
