//! The few ATmega2560 registers this firmware uses, by hand.
//!
//! A register is a byte at a fixed address of the data space: writing it configures or drives a
//! peripheral, reading it gives its state. The addresses are those of the ATmega2560 datasheet's
//! "Register Summary" (the data-space address: I/O registers 0x00-0x3F sit at 0x20-0x5F).
//! Every access is volatile, so the compiler neither caches nor drops it.
//!
//! A crate generated from the vendor's register description (`avr-device`) would give every
//! register of the chip, but takes minutes to build; the two dozen below take no time.

use gweave_controller::board::Reg;

/// One 8-bit register at a data-space address.
pub type Reg8 = Reg<u8>;

/// The register at data-space address `address`: only for the addresses of this module and
/// of the ports in `pins.rs`, every one mapped on the ATmega2560.
pub const fn reg8(address: usize) -> Reg8 {
    // SAFETY: as said above; the datasheet's "Register Summary" lists each.
    unsafe { Reg::new(address) }
}

/// One 16-bit register (a low byte and the high byte after it). The AVR latches the high byte
/// through a shared temporary register: write high then low, read low then high, and never
/// while an interrupt may use another 16-bit register (callers run it with interrupts off).
#[derive(Clone, Copy)]
pub struct Reg16(pub usize);

impl Reg16 {
    /// Read low byte first (it latches the high byte).
    #[inline(always)]
    pub fn read(self) -> u16 {
        let lo = reg8(self.0).read();
        let hi = reg8(self.0 + 1).read();
        u16::from_le_bytes([lo, hi])
    }

    /// Write high byte first (it waits in the temporary register until the low byte lands).
    #[inline(always)]
    pub fn write(self, value: u16) {
        let [lo, hi] = value.to_le_bytes();
        reg8(self.0 + 1).write(hi);
        reg8(self.0).write(lo);
    }
}

/// Status register: bit 7 (I) enables interrupts globally.
pub const SREG: Reg8 = reg8(0x5F);

/// MCU status: why the chip last reset (bit 3 WDRF: the watchdog, bit 0 PORF: power on).
pub const MCUSR: Reg8 = reg8(0x54);
pub const WDRF: u8 = 1 << 3;

// Watchdog (datasheet 12.5): WDTCSR's WDCE + WDE unlock a change for four cycles.
pub const WDTCSR: Reg8 = reg8(0x60);
pub const WDCE: u8 = 1 << 4;
pub const WDE: u8 = 1 << 3;

// EEPROM (datasheet 8.4): address, data, and the control register's enable bits.
pub const EECR: Reg8 = reg8(0x3F);
pub const EEDR: Reg8 = reg8(0x40);
pub const EEAR: Reg16 = Reg16(0x41);
/// Master write enable: opens a four-cycle window for EEPE.
pub const EEMPE: u8 = 1 << 2;
/// Write enable: starts the write (3.4 ms); stays set until it is done.
pub const EEPE: u8 = 1 << 1;
/// Read enable: the byte is in EEDR at once.
pub const EERE: u8 = 1 << 0;

// Timer/Counter0, 8 bits: the millisecond clock.
pub const TCCR0A: Reg8 = reg8(0x44);
pub const TCCR0B: Reg8 = reg8(0x45);
pub const OCR0A: Reg8 = reg8(0x47);
pub const TIMSK0: Reg8 = reg8(0x6E);

// Timer/Counter1, 16 bits: the step timer.
pub const TCCR1A: Reg8 = reg8(0x80);
pub const TCCR1B: Reg8 = reg8(0x81);
pub const TCNT1: Reg16 = Reg16(0x84);
pub const OCR1A: Reg16 = Reg16(0x88);
pub const TIMSK1: Reg8 = reg8(0x6F);

// The analog-to-digital converter.
pub const ADCW: Reg16 = Reg16(0x78);
pub const ADCSRA: Reg8 = reg8(0x7A);
pub const ADCSRB: Reg8 = reg8(0x7B);
pub const ADMUX: Reg8 = reg8(0x7C);
/// Digital input disable for ADC8-15 (saves power and noise on the analog pins).
pub const DIDR2: Reg8 = reg8(0x7D);

// USART0, wired to the Mega's USB-serial chip.
pub const UCSR0A: Reg8 = reg8(0xC0);
pub const UCSR0B: Reg8 = reg8(0xC1);
pub const UCSR0C: Reg8 = reg8(0xC2);
pub const UBRR0: Reg16 = Reg16(0xC4);
pub const UDR0: Reg8 = reg8(0xC6);

/// Run `f` with interrupts off, then put the interrupt flag back as it was (so it also works
/// inside an interrupt, where they are already off).
#[inline(always)]
pub fn interrupt_free<R>(f: impl FnOnce() -> R) -> R {
    let sreg = SREG.read();
    // SAFETY: `cli` only clears the global interrupt flag.
    unsafe { core::arch::asm!("cli") };
    let r = f();
    SREG.write(sreg);
    r
}

/// Enable interrupts globally.
#[inline(always)]
pub fn enable_interrupts() {
    // SAFETY: `sei` only sets the global interrupt flag; every handler is set up by then.
    unsafe { core::arch::asm!("sei") };
}
