//! The 4 KB EEPROM: settings kept across power cycles (`M500` writes, start-up reads).
//!
//! A read is immediate; a write takes 3.4 ms and the EEPROM wears out after about 100 000
//! writes per byte, so a byte that already holds the value is not written again.

use crate::regs::{interrupt_free, EEAR, EECR, EEDR, EEMPE, EEPE, EERE};

fn wait_ready() {
    while EECR.read() & EEPE != 0 {}
}

/// Read the byte at `addr` (0..SIZE).
pub fn read(addr: u16) -> u8 {
    wait_ready();
    EEAR.write(addr);
    EECR.set_bits(EERE);
    EEDR.read()
}

/// Write `value` at `addr` (0..SIZE) unless it is already there.
pub fn write(addr: u16, value: u8) {
    if read(addr) == value {
        return;
    }
    wait_ready();
    interrupt_free(|| {
        EEAR.write(addr);
        EEDR.write(value);
        // The two-step unlock: EEMPE opens a window of four cycles in which setting EEPE starts
        // the write, so a stray write cannot change the EEPROM (interrupts off to keep it short).
        EECR.write(EEMPE);
        EECR.write(EEMPE | EEPE);
    });
}
