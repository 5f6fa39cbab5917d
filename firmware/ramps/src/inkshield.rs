//! The InkShield (Nicholas Lewis, 2011; its Arduino library, `NicholasCLewis/InkShield`) on
//! RAMPS: the pins that fire an HP C6602 cartridge, for the core's `M700`
//! (`gweave_controller::inkjet` explains the printhead and the command).
//!
//! The shield raises the cartridge's supply above the board's 5 V and switches one nozzle's
//! resistor at a time through a 4-to-16 decoder: four address lines (A, B, C, D: the nozzle's number in
//! binary) choose the resistor, the pulse line switches the current through it. A nozzle
//! fires as the library and Steve Kelly's Marlin patch do it: set the address, raise the pulse
//! for 5 us, lower it, clear the address; the next nozzle follows, in address order.
//!
//! The 5 us are counted in CPU cycles with interrupts off, so the step interrupt (70 us on
//! average) can never stretch a pulse: a resistor left on that long overheats and the drop
//! splashes. The interrupts wait at most the pulse and its address writes (about 7 us) per
//! nozzle, and run between nozzles.

use gweave_controller::board::Pin as _;
use gweave_controller::inkjet::{NOZZLES, PULSE_US};

use crate::pins::{Pin, INKSHIELD_ADDRESS, INKSHIELD_PULSE};
use crate::regs::interrupt_free;
use crate::CPU_HZ;

/// Heads wired: one pulse line each.
pub const HEADS: u8 = INKSHIELD_PULSE.len() as u8;

/// The pulse in CPU cycles (80 at 16 MHz).
const PULSE_CYCLES: u32 = PULSE_US * (CPU_HZ / 1_000_000);
/// Turns of the delay loop (3 cycles each, the last 2) for at least [`PULSE_CYCLES`]; the
/// pulse's own writes add a few cycles (the emulated board measures 5.2 us).
const PULSE_LOOPS: u8 = (PULSE_CYCLES / 3 + 1) as u8;
/// Turns of the delay loop between two nozzles: at least 1 us with the pulse line low, so the
/// decoder's output falls before the next address is set.
const GAP_LOOPS: u8 = (CPU_HZ / 1_000_000 / 3 + 1) as u8;

/// Every InkShield line an output, low: no nozzle selected, no current.
pub fn init() {
    for pin in INKSHIELD_ADDRESS.iter().chain(&INKSHIELD_PULSE) {
        pin.write(false);
        pin.make_output();
    }
}

/// Fires the nozzles set in `nozzles` (bit `a`: address `a`) of head `head`, in address order.
pub fn fire(head: u8, nozzles: u16) {
    let Some(&pulse) = INKSHIELD_PULSE.get(usize::from(head)) else { return };
    for nozzle in (0..NOZZLES as u8).filter(|&n| nozzles & (1 << n) != 0) {
        interrupt_free(|| {
            set_address(nozzle);
            pulse.write_in_interrupt(true);
            delay_loops(PULSE_LOOPS);
            pulse.write_in_interrupt(false);
            set_address(0);
        });
        delay_loops(GAP_LOOPS);
    }
}

/// Puts `nozzle`'s number on the address lines (with interrupts off: they share their ports
/// with the extruder drivers the step interrupt writes).
fn set_address(nozzle: u8) {
    for (bit, pin) in INKSHIELD_ADDRESS.iter().enumerate() {
        Pin::write_in_interrupt(*pin, nozzle & (1 << bit) != 0);
    }
}

/// Busy-waits `loops` turns of a 3-cycle loop (`dec` 1 cycle, `brne` 2 when taken, 1 at the
/// end): `3 * loops` cycles with the `ldi` that loads the count.
#[inline(always)]
fn delay_loops(loops: u8) {
    // SAFETY: only counts a register down to zero; no memory, no stack.
    unsafe {
        core::arch::asm!(
            "1: dec {n}",
            "brne 1b",
            n = inout(reg_upper) loops => _,
            options(nomem, nostack),
        )
    };
}
