//! The watchdog: a timer of its own that resets the chip unless the main loop restarts it in
//! time. A hang (a bug, a loop that never ends) then ends in a reset, and a reset switches every
//! output off: heaters cold, motors free. The main loop calls [`feed`] every pass.

use crate::regs::{interrupt_free, MCUSR, WDCE, WDE, WDRF, WDTCSR};

/// WDTCSR prescaler bits WDP2..0 = 0b110: about 1 s at the watchdog's own 128 kHz oscillator.
const TIMEOUT_1S: u8 = 0b110;

/// Restart the watchdog's count.
#[inline(always)]
pub fn feed() {
    // SAFETY: `wdr` only restarts the watchdog timer.
    unsafe { core::arch::asm!("wdr") };
}

/// Whether the last reset was the watchdog's, then switch the watchdog on with a 1 s timeout.
/// Call it first thing: after a watchdog reset the watchdog is still on, with its shortest
/// timeout (16 ms), and the chip would reset again and again.
pub fn start() -> bool {
    let by_watchdog = MCUSR.read() & WDRF != 0;
    interrupt_free(|| {
        feed();
        // WDRF must be cleared before WDE can be changed.
        MCUSR.write(0);
        // The timed sequence: WDCE + WDE, then the new setting within four cycles.
        WDTCSR.write(WDCE | WDE);
        WDTCSR.write(WDE | TIMEOUT_1S);
    });
    by_watchdog
}
