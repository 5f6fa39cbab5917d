//! SysTick: the step timer.
//!
//! SysTick is the Cortex-M core's own 24-bit timer (ARM's Cortex-M4 Devices Generic User
//! Guide, "System timer, SysTick"): it counts the CPU clock down from its reload value (RVR)
//! to 0, raises its exception, reloads and counts again. The step interrupt comes back after
//! the interval the core's stepper asks for, in ticks of 0.5 us (the AVR's Timer1 ticks), so
//! each interrupt restarts the count: it reads how many cycles passed since the interrupt was
//! due, and programs the rest of the interval. The steps thus keep the core's timing, however
//! long the handler runs, to within the few cycles between reading the count and restarting
//! it (a few nanoseconds at 168 MHz).

use crate::regs::{reg, Reg};

/// SysTick's control and status, reload and current value; the interrupt controller's ICSR.
const CSR: Reg = reg(0xE000_E010);
const RVR: Reg = reg(0xE000_E014);
const CVR: Reg = reg(0xE000_E018);
const ICSR: Reg = reg(0xE000_ED04);
/// CSR: counter on, exception on, counting the CPU clock; the count reached 0 since the last
/// read of CSR.
const ENABLE: u32 = 1;
const TICKINT: u32 = 1 << 1;
const CLKSOURCE_CPU: u32 = 1 << 2;
const COUNTFLAG: u32 = 1 << 16;
/// ICSR: clear a pending SysTick exception.
const PENDSTCLR: u32 = 1 << 25;

/// Timer ticks per second: the core's step timing unit.
pub const TICKS_PER_S: u32 = 2_000_000;
/// CPU cycles per tick (84 at 168 MHz).
const CYCLES_PER_TICK: u32 = crate::CPU_HZ / TICKS_PER_S;
/// Cycles from reading the count to the restart taking effect (a read, two writes): the
/// handler takes them off the next interval.
const RESTART_CYCLES: u32 = 4;
/// The shortest wait the handler programs: a moment that has passed, or is closer than the
/// handler needs to return, comes this far ahead (10 us, as on the AVR).
const MARGIN_CYCLES: u32 = 20 * CYCLES_PER_TICK;
/// The longest interval one count may take: SysTick's 24 bits.
pub const MAX_TICKS: u32 = 0x00FF_FFFF / CYCLES_PER_TICK;

/// Start the timer, the first interrupt after `ticks`.
pub fn start(ticks: u32) {
    RVR.write(ticks.min(MAX_TICKS) * CYCLES_PER_TICK - 1);
    CVR.write(0);
    CSR.write(ENABLE | TICKINT | CLKSOURCE_CPU);
}

/// First thing in the handler: forget the count's wrap that raised this interrupt, so that
/// [`set_next_in_interrupt`] can tell whether it wrapped again meanwhile.
#[inline(always)]
pub fn begin_in_interrupt() {
    let _ = CSR.read();
}

/// Schedule the next interrupt `ticks` after the one being handled.
///
/// If the handler ran past that moment (or past the end of the count in progress), the next
/// interrupt comes as soon as the handler is done: a late step rather than a lost one.
#[inline(always)]
pub fn set_next_in_interrupt(ticks: u32) {
    let target = ticks.min(MAX_TICKS) * CYCLES_PER_TICK;
    let count = CVR.read();
    let wrapped = CSR.read() & COUNTFLAG != 0;
    // The count reloaded with RVR one cycle after it reached 0 (when the interrupt was due).
    let since = RVR.read() - count + 1 + RESTART_CYCLES;
    let rest = if wrapped { 0 } else { target.saturating_sub(since) };
    RVR.write(rest.max(MARGIN_CYCLES) - 1);
    // Any write clears the count: it reloads from RVR at the next cycle.
    CVR.write(0);
    ICSR.write(PENDSTCLR);
}

/// Wait `cycles` after [`set_next_in_interrupt`] (a step pulse's width). The count has
/// restarted from RVR, which is larger than any pulse (see `MARGIN_CYCLES`).
#[inline(always)]
pub fn wait_in_interrupt(cycles: u32) {
    loop {
        let count = CVR.read();
        // 0 until the reload, one cycle after the restart.
        if count != 0 && RVR.read() - count >= cycles {
            break;
        }
    }
}
