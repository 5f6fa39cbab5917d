//! The independent watchdog (IWDG): a counter on its own 32 kHz oscillator that resets the chip
//! unless the main loop reloads it in time. A hang then ends in a reset, and a reset leaves
//! every pin an input: heaters cold, motors free. Registers: RM0090, "IWDG register map".

use crate::regs::{reg, Reg, RCC_CSR};

const IWDG: usize = 0x4000_3000;
const KR: Reg = reg(IWDG);
const PR: Reg = reg(IWDG + 0x04);
const RLR: Reg = reg(IWDG + 0x08);
/// KR keys: reload the counter, start the watchdog, unlock PR and RLR.
const RELOAD: u32 = 0xAAAA;
const START: u32 = 0xCCCC;
const UNLOCK: u32 = 0x5555;
/// PR 3: the 32 kHz clock divided by 32, so RLR counts milliseconds; 1 s, as on the AVR.
const DIV_32: u32 = 3;
const TIMEOUT_MS: u32 = 1000;
/// RCC_CSR: the last reset was the watchdog's; writing RMVF clears the flags.
const IWDGRSTF: u32 = 1 << 29;
const RMVF: u32 = 1 << 24;

/// Reload the watchdog's counter.
pub fn feed() {
    KR.write(RELOAD);
}

/// Whether the last reset was the watchdog's, then start the watchdog with a 1 s timeout.
/// Once started it cannot be stopped, but by a reset.
pub fn start() -> bool {
    let by_watchdog = RCC_CSR.read() & IWDGRSTF != 0;
    RCC_CSR.modify(RMVF, RMVF);
    KR.write(START);
    KR.write(UNLOCK);
    PR.write(DIV_32);
    RLR.write(TIMEOUT_MS);
    feed();
    by_watchdog
}
